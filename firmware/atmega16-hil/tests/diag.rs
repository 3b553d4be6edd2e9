use orch_atmega16_hil::*;

#[test]
#[ignore]
fn diag_flood_cpu() {
    let n = (4_000_000 / SIM_BYTE_US) as usize;
    let mut s = vec![0x90];
    while s.len() < n / 3 {
        for k in 36..=96u8 {
            s.extend([k, 100, k, 0]);
        }
    }
    let mut x = 0x2545_f491_u32;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        x
    };
    while s.len() + 1 < n {
        let r = next();
        let key = 36 + (r % 61) as u8;
        let velocity = if r >> 16 & 1 == 0 {
            0
        } else {
            1 + (r >> 8) as u8 % 127
        };
        s.extend([key, velocity]);
    }
    let mut hil = Hil::new();
    hil.boot();
    let (mut work, mut isr, mut twi, mut total) = (0u64, 0u64, 0u64, 0u64);
    let mut pulses: Vec<(u64, u64)> = Vec::new();
    let mut cur = 0u64;
    let mut phase_work = [0u64; 2];
    for (i, &b) in s.iter().enumerate() {
        hil.put(b);
        let end = hil.cycles.get() + SIM_BYTE_US * 8;
        while hil.cycles.get() < end {
            let n = hil.step();
            total += n;
            let w = hil.pin('D', 4);
            if w {
                work += n;
                cur += n;
                phase_work[(i >= n_third(&s)) as usize] += n;
            } else if cur > 0 {
                pulses.push((cur, hil.now_us()));
                cur = 0;
            }
            if hil.pin('D', 2) {
                isr += n;
            }
            if hil.pin('D', 5) {
                twi += n;
            }
        }
    }
    pulses.sort();
    println!(
        "total {total} work {work} ({:.0}%) rx isr {isr} twi isr {twi}",
        work as f64 * 100.0 / total as f64
    );
    println!("work sweep {} random {}", phase_work[0], phase_work[1]);
    println!(
        "pulses {} longest {:?}",
        pulses.len(),
        &pulses[pulses.len() - 10..]
    );
    let mut hist = std::collections::BTreeMap::new();
    for (c, _) in &pulses {
        *hist.entry(c / 500 * 500).or_insert(0) += 1;
    }
    println!("hist {hist:?}");
}
fn n_third(s: &[u8]) -> usize {
    let n = s.len();
    let _ = n;
    (4_000_000 / SIM_BYTE_US) as usize / 3
}

#[test]
#[ignore]
fn diag_old_reset() {
    let mut s = vec![0x90];
    for _ in 0..20 {
        for k in 36..=96u8 {
            s.extend([k, 100, k, 0]);
        }
    }
    let mut hil = Hil::new();
    hil.boot();
    let mut high_since: Option<u64> = None;
    let mut longest = (0u64, 0u64);
    for &b in &s {
        hil.put(b);
        let end = hil.cycles.get() + SIM_BYTE_US * 8;
        while hil.cycles.get() < end {
            hil.step();
            let c = hil.cycles.get();
            if hil.pin('D', 4) {
                high_since.get_or_insert(c);
            } else if let Some(h) = high_since.take() {
                if c - h > longest.0 {
                    longest = (c - h, h);
                }
            }
            if let Some(h) = high_since {
                if c - h > longest.0 {
                    longest = (c - h, h);
                }
            }
            if c % 16_000 < 4 {
                let inits = hil
                    .bus
                    .borrow()
                    .log
                    .iter()
                    .filter(|t| t.bytes[0] == 6)
                    .count();
                let st = hil.stack_high_water();
                println!("stack {st} t={} ms PD4 high for {:?} ms, longest PD4 stretch {} ms from {} ms, inits {inits}, rx pending?", c/8000, high_since.map(|h| (c-h)/8000), longest.0/8000, longest.1/8000);
            }
        }
    }
}
