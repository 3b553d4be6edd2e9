//! Where the ATmega16 firmware spends its cycles: runs the ELF in simavr under a full-rate
//! MIDI flood (the HIL test's) with four boards that acknowledge everything, samples the
//! program counter at every instruction and prints the cycles spent in each function (self
//! time, by `avr-nm`'s symbols), largest first: while the firmware works (its probe pins:
//! PD4 the main loop on a byte or a timer, PD2 the receive interrupt, PD5 the TWI interrupt,
//! and the interrupt handlers' register saves and restores outside their pins),
//! and in all (the main loop polls for work when idle).
//!
//! ```sh
//! cargo run --release --example profile [-- SECONDS]   # after building the firmware
//! ```

use avr_simulator::{AvrSimulator, TwiPacket};
use orch_atmega16_hil::{elf_path, F_CPU, SIM_BYTE_US};

fn main() {
    let seconds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(4);
    let elf = elf_path();
    let symbols = symbols(&elf);
    let mut sim = AvrSimulator::new("atmega16", F_CPU as u32, &elf);
    sim.set_twi_slave(0, |p: TwiPacket| {
        (p.is_start() || p.is_write() || p.is_stop()).then(|| p.respond_ack())
    });
    // `AvrSimulator` keeps its `avr_t` to itself; its Debug output names the pointer.
    let avr = orch_atmega16_hil::avr_pointer(&format!("{sim:?}"));

    // `ORCH_PROFILE_STREAM=notes`: the figures' six note messages (own status and running
    // status, Note-On and Note-Off) over and over, each followed by 3 ms of silence, so that
    // every message is worked on at rest, as the figures measure it. Else the flood.
    let notes = std::env::var("ORCH_PROFILE_STREAM").is_ok_and(|v| v == "notes");
    let stream: Vec<Option<u8>> = if notes {
        let msgs: [&[u8]; 6] = [
            &[0x90, 60, 100],
            &[0x90, 64, 100],
            &[67, 100],
            &[0x80, 60, 0],
            &[64, 0],
            &[67, 0],
        ];
        let n = (seconds * 1_000_000 / SIM_BYTE_US) as usize;
        let mut s = Vec::new();
        while s.len() < n {
            for m in msgs {
                s.extend(m.iter().map(|&b| Some(b)));
                s.extend([None; 9]);
            }
        }
        s
    } else {
        orch_atmega16_hil::flood_stream(seconds)
            .into_iter()
            .map(Some)
            .collect()
    };
    let bytes = stream.iter().flatten().count();
    let mut per_fn = vec![0u64; symbols.len() + 1];
    let mut busy_fn = vec![0u64; symbols.len() + 1];
    // Busy cycles by program counter, for `ORCH_PROFILE_LINES=1` (source lines by addr2line).
    let mut busy_pc = std::collections::HashMap::<u32, u64>::new();
    let mut cycles = 0u64;
    let per_byte = SIM_BYTE_US * (F_CPU / 1_000_000);
    let boot = 20_000 * (F_CPU / 1_000_000);
    let mut next_byte = boot;
    let mut i = 0;
    let end = boot + stream.len() as u64 * per_byte + 100_000 * (F_CPU / 1_000_000);
    while cycles < end {
        if cycles >= next_byte && i < stream.len() {
            if let Some(b) = stream[i] {
                sim.write_uart('0', b);
            }
            i += 1;
            next_byte += per_byte;
        }
        // SAFETY: the simulator is alive and not running.
        let pc = unsafe { (*avr).pc };
        let n = sim.step().tt.as_cycles();
        cycles += n;
        if cycles > boot {
            let at = symbols.partition_point(|s| s.0 <= pc);
            let f = if at > 0 && pc < symbols[at - 1].0 + symbols[at - 1].1 {
                at - 1
            } else {
                symbols.len()
            };
            per_fn[f] += n;
            // Busy: a probe pin is high, or an interrupt handler saves or restores its
            // registers (before its pin goes high, after it goes low) or its vector jumps.
            // (0x54: the end of the ATmega16's 21 vectors, 4 bytes each.)
            let in_handler =
                pc < 0x54 || symbols.get(f).is_some_and(|s| s.2.starts_with("__vector_"));
            if in_handler
                || sim.get_digital_pin('D', 4)
                || sim.get_digital_pin('D', 2)
                || sim.get_digital_pin('D', 5)
            {
                busy_fn[f] += n;
                *busy_pc.entry(pc).or_default() += n;
            }
        }
        while sim.read_uart('0').is_some() {}
    }
    let total: u64 = per_fn.iter().sum();
    let busy: u64 = busy_fn.iter().sum();
    println!(
        "{} bytes of MIDI in {:.1} s simulated ({} messages); {} cycles after boot, {} ({:.0} %) working: {:.0} cycles a byte",
        bytes,
        total as f64 / F_CPU as f64,
        if notes { bytes * 6 / 14 } else { bytes / 2 },
        total,
        busy,
        busy as f64 * 100.0 / total as f64,
        busy as f64 / bytes as f64
    );
    println!("  working            all   function");
    let mut rows: Vec<usize> = (0..per_fn.len()).collect();
    rows.sort_by_key(|&i| std::cmp::Reverse(busy_fn[i]));
    for &i in rows.iter().take(20) {
        println!(
            "{:6.2} % {:>9}  {:>9}  {}",
            busy_fn[i] as f64 * 100.0 / busy as f64,
            busy_fn[i],
            per_fn[i],
            symbols.get(i).map_or("(no symbol)", |s| s.2.as_str())
        );
    }
    if let Some(path) = std::env::var_os("ORCH_PROFILE_PCS") {
        // Busy cycles by program counter, one `address cycles` line each, for annotating
        // `avr-objdump -d`.
        let mut pcs: Vec<(u32, u64)> = busy_pc.iter().map(|(&a, &c)| (a, c)).collect();
        pcs.sort();
        let text: String = pcs.iter().map(|(a, c)| format!("{a:x} {c}\n")).collect();
        std::fs::write(path, text).expect("ORCH_PROFILE_PCS: a writable path");
    }
    if std::env::var_os("ORCH_PROFILE_LINES").is_some() {
        // Busy cycles by source line (innermost inlined frame), largest first.
        let mut pcs: Vec<(u32, u64)> = busy_pc.into_iter().collect();
        pcs.sort();
        let out = std::process::Command::new("avr-addr2line")
            .arg("-e")
            .arg(&elf)
            .args(pcs.iter().map(|p| format!("{:#x}", p.0)))
            .output()
            .expect("avr-addr2line");
        let mut by_line = std::collections::HashMap::<String, u64>::new();
        for (line, (_, c)) in String::from_utf8_lossy(&out.stdout).lines().zip(&pcs) {
            let short = line.rsplit("/src/").next().unwrap_or(line).to_string();
            *by_line.entry(short).or_default() += c;
        }
        let mut lines: Vec<(String, u64)> = by_line.into_iter().collect();
        lines.sort_by_key(|l| std::cmp::Reverse(l.1));
        println!("busy cycles by source line:");
        for (l, c) in lines.iter().take(40) {
            println!("{:6.2} % {:>9}  {}", *c as f64 * 100.0 / busy as f64, c, l);
        }
    }
}

/// (address, size, demangled name) of every function, by address.
fn symbols(elf: &std::path::Path) -> Vec<(u32, u32, String)> {
    let out = std::process::Command::new("avr-nm")
        .args(["-C", "-S", "--defined-only", "-n"])
        .arg(elf)
        .output()
        .expect("avr-nm (Debian's binutils-avr)");
    let mut v: Vec<(u32, u32, String)> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| {
            let mut p = l.splitn(4, ' ');
            let addr = u32::from_str_radix(p.next()?, 16).ok()?;
            let size = u32::from_str_radix(p.next()?, 16).ok()?;
            let kind = p.next()?;
            let name = p.next()?;
            let name = format!("{:#}", rustc_demangle::demangle(name));
            matches!(kind, "t" | "T" | "W" | "w").then_some((addr, size, name))
        })
        .collect();
    v.sort();
    v
}
