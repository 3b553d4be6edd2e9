//! The ATmega16 firmware on a simulated ATmega16 at 8 MHz with four PCA9555 boards.
//!
//! Every stream is compared with orch-core run on the host with the firmware's configuration,
//! fed the same bytes at the times simavr hands them to the firmware: the boards must see the
//! same writes, in the same order, and end with the same outputs. A hang in the firmware shows
//! as a test that never ends (the test command runs them under a timeout).

use orch_atmega16_hil::*;

/// The latest a press or release may reach its board after the host made it. A write takes
/// 456 µs at 83.33 kHz, but under a full-rate flood bytes, the guard's timers (each a visit of
/// the keys down or waiting) and the writes they make queue behind each other: at most
/// 2.3 ms measured; 6 ms is 19 DIN bytes.
const MAX_LATE_US: u64 = 6_000;

/// Plays `stream` into a booted robot, one byte every `pace_us`, and the same bytes at the
/// same times into orch-core on the host; runs both `tail_us` past the last byte.
fn play_paced(stream: &[u8], pace_us: u64, tail_us: u64) -> (Hil, HostRobot, usize) {
    let mut hil = Hil::new();
    hil.boot();
    let from = hil.bus.borrow().log.len();
    hil.send_paced(stream, pace_us);
    hil.run_us(tail_us);
    let mut host = HostRobot::new();
    for (&t, &b) in hil.arrivals_us().iter().zip(stream) {
        host.feed(b, t);
    }
    host.advance_to(hil.now_us());
    (hil, host, from)
}

/// The firmware made exactly the host's board writes, in order, and every press and release
/// reached its board in time; thru equals the input. Returns the match.
fn assert_same_as_host(hil: &Hil, host: &HostRobot, from: usize, stream: &[u8]) -> EventMatch {
    assert_eq!(hil.thru, stream, "MIDI thru must equal the input");
    let bus = hil.bus.borrow();
    // Besides whole writes (outputs, or configuration when a board is initialised again),
    // only the register byte alone: a write addressed ahead that had nothing to write.
    for t in &bus.log[from..] {
        assert!(
            t.bytes == [0x02] || (t.bytes.len() == 3 && matches!(t.bytes[0], 0x02 | 0x06)),
            "an unexpected transaction on the bus: {t:?}"
        );
    }
    let fw = bus.timed_output_writes(from);
    let m =
        same_key_events(&fw, &host.boards.writes, MAX_LATE_US).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        per_board(&fw),
        host.writes(),
        "the same board writes as the host"
    );
    assert_eq!(bus.outputs(), host.outputs(), "final board outputs");
    println!(
        "{} host writes; {} presses and {} releases on the boards after the host's by: median {} µs, 99 % {} µs, at most {} µs",
        host.boards.writes.len(),
        m.presses,
        m.releases,
        m.percentile(50),
        m.percentile(99),
        m.max_late_us
    );
    m
}

fn check_against_host(stream: &[u8]) -> (Hil, HostRobot) {
    // Back to back on simavr's wire (a byte every 352 µs: its UART counts a parity bit that
    // 8N1 does not have; fed faster, it hands the firmware two bytes at once now and then).
    // Then 100 ms: past the guard's shortest strike (20 ms) and rest (60 ms), so no timer of
    // the host's fires while the firmware's write of it is still on the bus.
    let (hil, host, from) = play_paced(stream, SIM_BYTE_US, 100_000);
    assert_same_as_host(&hil, &host, from, stream);
    (hil, host)
}

#[test]
fn thesis_table_3_three_note_ons() {
    let (hil, _) = check_against_host(&[0x90, 0x3C, 0x7F, 0x90, 0x40, 0x7F, 0x90, 0x43, 0x7F]);
    // C, E, G: keys 24, 28, 31 on board 1.
    assert_eq!(hil.outputs(), [0, (1 << 8) | (1 << 12) | (1 << 15), 0, 0]);
}

#[test]
fn thesis_table_4_running_status_and_note_off() {
    let (hil, _) =
        check_against_host(&[0x90, 0x3C, 0x7F, 0x40, 0x7F, 0x43, 0x7F, 0x80, 0x40, 0x00]);
    assert_eq!(hil.outputs(), [0, (1 << 8) | (1 << 15), 0, 0]);
}

/// A note message's board is addressed while its last byte is on the wire (START, address,
/// output register, then the bus held). A Note-Off for a note that is not on writes nothing:
/// that transaction ends after the register byte, which changes no register, and the next
/// write goes out as usual.
#[test]
fn a_note_off_for_no_note_addresses_its_board_ahead_and_writes_nothing() {
    let stream = [0x80, 60, 0, 0x90, 60, 100];
    let (hil, host) = check_against_host(&stream);
    let bus = hil.bus.borrow();
    let board_1: Vec<&[u8]> = bus
        .log
        .iter()
        .filter(|t| t.board == 1)
        .map(|t| &t.bytes[..])
        .skip(2) // power-up: outputs, then configuration
        .collect();
    assert_eq!(
        board_1,
        [&[0x02u8][..], &[0x02, 0x00, 0x01][..]],
        "the register byte alone, then the Note-On's write (key 24: board 1, bit 8)"
    );
    assert_eq!(bus.boards[1].outputs(), 1 << 8);
    assert_eq!(host.outputs()[1], 1 << 8);
    // Each began before the last byte of its message had arrived.
    let arrivals = hil.arrivals_us();
    let ahead: Vec<&Transaction> = bus.log.iter().filter(|t| t.board == 1).skip(2).collect();
    for (t, last) in ahead.iter().zip([arrivals[2], arrivals[5]]) {
        assert!(
            t.start_cycle < last * (F_CPU / 1_000_000),
            "the write began at cycle {} after its message's last byte ({last} µs)",
            t.start_cycle
        );
    }
}

/// A line that stops inside a note message (its last byte late, or never) does not keep the
/// bus: the transaction addressed ahead ends after the register byte once the bus has been
/// held for the step timeout (1 ms), and the message, when its byte does come, writes as
/// usual.
#[test]
fn a_line_that_stops_inside_a_note_message_lets_the_bus_go() {
    let mut hil = Hil::new();
    hil.boot();
    let from = hil.bus.borrow().log.len();
    hil.send(&[0x90, 60]);
    let note_at = *hil.arrivals_us().last().unwrap();
    hil.run_us(3_000);
    {
        let bus = hil.bus.borrow();
        let ended: Vec<&Transaction> = bus.log[from..].iter().collect();
        assert_eq!(ended.len(), 1, "one transaction: {ended:?}");
        assert_eq!((ended[0].board, &ended[0].bytes[..]), (1, &[0x02u8][..]));
        let held_us = ended[0].stop_cycle / (F_CPU / 1_000_000) - note_at;
        assert!(
            (1_000..2_500).contains(&held_us),
            "the bus was let go {held_us} µs after the note byte"
        );
    }
    // Thru kept working, and the velocity, late, completes the message.
    hil.send(&[100]);
    hil.run_us(3_000);
    let bus = hil.bus.borrow();
    assert_eq!(bus.outputs(), [0, 1 << 8, 0, 0]);
    assert_eq!(
        bus.log[from + 1..]
            .iter()
            .map(|t| &t.bytes[..])
            .collect::<Vec<_>>(),
        [&[0x02u8, 0x00, 0x01][..]]
    );
    drop(bus);
    hil.drain_thru();
    assert_eq!(hil.thru, [0x90, 60, 100]);
}

#[test]
fn running_status_with_velocity_zero_note_offs() {
    let mut s = vec![0x90];
    for n in [48u8, 52, 55, 60, 64, 67] {
        s.extend([n, 90]);
    }
    for n in [48u8, 55, 64] {
        s.extend([n, 0]);
    }
    let (hil, _) = check_against_host(&s);
    assert_ne!(hil.outputs(), [0; 4]);
}

#[test]
fn real_time_bytes_inside_messages() {
    let s = [
        0x90, 0xF8, 0x3C, 0xFE, 0x7F, // clock and active sensing inside a Note-On
        0xF8, 0x40, 0xFA, 0x7F, // running status with Start inside
        0x80, 0x3C, 0xF8, 0x00,
    ];
    let (hil, _) = check_against_host(&s);
    assert_eq!(hil.outputs(), [0, 1 << 12, 0, 0]);
}

#[test]
fn all_16_channels() {
    let mut s = Vec::new();
    for ch in 0..16u8 {
        s.extend([0x90 | ch, 40 + ch * 3, 100]);
    }
    for ch in (0..16u8).step_by(2) {
        s.extend([0x80 | ch, 40 + ch * 3, 0]);
    }
    let (hil, _) = check_against_host(&s);
    assert_ne!(hil.outputs(), [0; 4]);
}

#[test]
fn notes_0_to_127_fold_into_the_keyboard() {
    let mut s = Vec::new();
    for n in 0..=127u8 {
        s.extend([0x90, n, 64]);
    }
    for n in 0..=127u8 {
        s.extend([0x80, n, 0]);
    }
    let (hil, _) = check_against_host(&s);
    assert_eq!(hil.outputs(), [0; 4]);
}

#[test]
fn power_up_drives_no_pin_before_the_first_note() {
    let mut hil = Hil::new();
    hil.run_us(100_000);
    {
        let bus = hil.bus.borrow();
        assert_eq!(
            bus.first_driven_high, None,
            "a pin was driven high at power-up"
        );
        for (i, b) in bus.boards.iter().enumerate() {
            assert_eq!(b.outputs(), 0, "board {i} outputs");
            assert_eq!(b.config(), 0, "board {i} pins are outputs (driven low)");
        }
        // Each board: outputs to 0 FIRST, THEN the configuration.
        for i in 0..4 {
            let seq: Vec<&[u8]> = bus
                .log
                .iter()
                .filter(|t| t.board == i)
                .map(|t| &t.bytes[..])
                .collect();
            assert_eq!(
                seq,
                [&[2u8, 0, 0][..], &[6, 0, 0][..]],
                "board {i} init order"
            );
        }
    }
    for pin in 0..8 {
        assert!(
            !hil.pin('B', pin),
            "PB{pin} (the thesis's MOSFET port) must stay low"
        );
    }
    let before = hil.cycles.get();
    hil.send(&[0x90, 60, 100]);
    hil.run_us(5_000);
    let first = hil
        .bus
        .borrow()
        .first_driven_high
        .expect("the note drives a pin");
    assert!(first > before);
}

#[test]
fn a_nacking_board_is_retried_and_released_when_it_answers_again() {
    let mut hil = Hil::new();
    hil.boot();
    hil.send(&[0x90, 60, 100, 0x90, 36, 100]); // board 1 bit 8, board 0 bit 0
    hil.run_us(5_000);
    assert_eq!(hil.outputs(), [1, 1 << 8, 0, 0]);

    hil.bus.borrow_mut().boards[1].nack = true;
    hil.send(&[0x80, 60, 0, 0x80, 36, 0]);
    hil.run_us(100_000);
    // Board 0 was written despite board 1; board 1 keeps its stale value for now.
    assert_eq!(hil.outputs(), [0, 1 << 8, 0, 0]);
    let nacked = hil.bus.borrow().nacked;
    assert!(
        nacked >= 3,
        "the firmware retried ({nacked} NACKed address phases)"
    );
    // Still alive: thru works and the other boards play.
    hil.thru.clear();
    hil.send(&[0x90, 84, 1]);
    hil.run_us(15_000); // longer than the retry period (10 ms)
    assert_eq!(hil.thru, [0x90, 84, 1]);
    assert_eq!(hil.outputs()[3], 1);
    let more = hil.bus.borrow().nacked;
    assert!(more > nacked, "it keeps retrying");

    // The board comes back (after losing power: pins are inputs again, outputs 1).
    {
        let mut bus = hil.bus.borrow_mut();
        bus.boards[1].power_cycle();
        bus.boards[1].nack = false;
    }
    hil.run_us(30_000);
    let bus = hil.bus.borrow();
    assert_eq!(
        bus.boards[1].outputs(),
        0,
        "key released once the board answers"
    );
    assert_eq!(bus.boards[1].config(), 0, "board re-initialised");
    assert_eq!(bus.outputs(), [0, 0, 0, 1]);
}

#[test]
fn a_dead_bus_does_not_hang_the_firmware_and_it_catches_up() {
    let mut hil = Hil::new();
    hil.boot();
    hil.send(&[0x90, 60, 100, 0x90, 72, 100]);
    hil.run_us(5_000);
    assert_eq!(hil.outputs(), [0, 1 << 8, 1 << 4, 0]);
    // No board answers at all (the closest simavr's TWI comes to a bus held low).
    for b in hil.bus.borrow_mut().boards.iter_mut() {
        b.nack = true;
    }
    hil.thru.clear();
    let during = [
        0x80, 60, 0, 0x80, 72, 0, 0x90, 40, 100, 0x80, 40, 0, 0x90, 96, 100,
    ];
    hil.send(&during);
    hil.run_us(2_000_000); // longer than the watchdog's 0.5 s: no reset loop either
    assert_eq!(hil.thru, during, "thru keeps working with the bus down");
    for b in hil.bus.borrow_mut().boards.iter_mut() {
        b.nack = false;
    }
    hil.run_us(30_000);
    // Keys 60 and 72 released; 96 (board 3, bit 12) down as the frame says now.
    assert_eq!(hil.outputs(), [0, 0, 0, 1 << 12]);
    // The power-up init ran once (no watchdog reset): exactly one [6,0,0] per board before the
    // outage.
    let bus = hil.bus.borrow();
    let inits_at_boot = bus.log.iter().take(8).filter(|t| t.bytes[0] == 6).count();
    assert_eq!(inits_at_boot, 4);
}

fn stream_file(name: &str) -> (Hil, Vec<u8>, usize) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/midi")
        .join(name);
    let path = if path.exists() {
        path
    } else {
        std::path::PathBuf::from("/work/shared/midi").join(name)
    };
    let data = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let timed = smf_to_wire(&data);
    let mut hil = Hil::new();
    hil.boot();
    let from = hil.bus.borrow().log.len();
    let start = hil.now_us();
    let mut next = start;
    for &(t, b) in &timed {
        // Wire speed (simavr's): at its time, or right after the byte before it.
        let at = (start + t).max(next);
        hil.run_until(at * (F_CPU / 1_000_000));
        hil.put(b);
        next = at + SIM_BYTE_US;
    }
    let bytes: Vec<u8> = timed.iter().map(|&(_, b)| b).collect();
    (hil, bytes, from)
}

#[test]
fn a_whole_midi_file_at_wire_speed() {
    let t0 = std::time::Instant::now();
    let (mut hil, bytes, from) = stream_file("m21-test06.mid");
    hil.run_us(5_000_000); // past the guard's 4 s watchdog
    assert_eq!(hil.thru, bytes, "thru equals input");
    assert_eq!(hil.outputs(), [0; 4], "boards end all-off");

    // No key held past the guard's 10 s limit.
    let bus = hil.bus.borrow();
    let mut down_since: [[Option<u64>; 16]; 4] = [[None; 16]; 4];
    let mut longest = 0u64;
    let mut writes = 0;
    for t in &bus.log[from..] {
        if t.bytes.len() != 3 || t.bytes[0] != 2 {
            continue;
        }
        writes += 1;
        let v = u16::from_le_bytes([t.bytes[1], t.bytes[2]]);
        for (bit, slot) in down_since[t.board].iter_mut().enumerate() {
            let on = v & (1 << bit) != 0;
            match (on, *slot) {
                (true, None) => *slot = Some(t.stop_cycle),
                (false, Some(s)) => {
                    longest = longest.max(t.stop_cycle - s);
                    *slot = None;
                }
                _ => {}
            }
        }
    }
    let longest_ms = longest / (F_CPU / 1000);
    assert!(longest_ms <= 10_010, "a key was held {longest_ms} ms");

    // And the same writes as orch-core on the host: every press and release, in time.
    let mut host = HostRobot::new();
    for (&t, &b) in hil.arrivals_us().iter().zip(&bytes) {
        host.feed(b, t);
    }
    host.advance_to(hil.now_us());
    assert_same_as_host(&hil, &host, from, &bytes);
    println!(
        "m21-test06.mid: {} bytes, {} board writes, longest key {} ms, simulated {:.1} s in {:.1?}",
        bytes.len(),
        writes,
        longest_ms,
        hil.now_us() as f64 / 1e6,
        t0.elapsed()
    );
}

fn flood(seconds: u64) -> Vec<u8> {
    flood_stream(seconds)
}

#[test]
fn a_full_rate_din_line_loses_no_press_or_release() {
    // Back to back at the fastest rate simavr's UART delivers (a byte every 352 µs), for
    // four seconds.
    let stream = flood(4);
    let t0 = std::time::Instant::now();
    // Then 4.5 s of silence: the guard's watchdog (4 s) lets every key go, on both.
    let (mut hil, host, from) = play_paced(&stream, SIM_BYTE_US, 4_500_000);
    let m = assert_same_as_host(&hil, &host, from, &stream);
    // The power-up initialisation ran once: no reset on the way.
    let inits = hil
        .bus
        .borrow()
        .log
        .iter()
        .filter(|t| t.bytes[0] == 6)
        .count();
    assert_eq!(
        inits, 4,
        "the boards were initialised again: the firmware reset"
    );
    assert!(
        m.presses > 1000 && m.releases > 1000,
        "a flood that presses keys ({} presses, {} releases)",
        m.presses,
        m.releases
    );
    // Half of them within one byte and one board write (456 µs at 83.33 kHz) of the host's;
    // the rest wait behind other bytes, guard timers and writes (MAX_LATE_US).
    assert!(
        m.percentile(50) <= SIM_BYTE_US + 456,
        "median lateness {} µs",
        m.percentile(50)
    );
    let stack = {
        hil.run_us(300_000);
        hil.stack_high_water()
    };
    println!(
        "flood: {} bytes in {:.1} s simulated, {} presses and {} releases, after the host's by median {} µs, 99 % {} µs, at most {} µs; deepest stack {} bytes; {:.1?}",
        stream.len(),
        stream.len() as f64 * SIM_BYTE_US as f64 / 1e6,
        m.presses,
        m.releases,
        m.percentile(50),
        m.percentile(99),
        m.max_late_us,
        stack,
        t0.elapsed()
    );
}

/// The size of section `name` in a 32-bit little-endian ELF file, 0 if it has none.
fn elf_section_size(path: &std::path::Path, name: &str) -> u64 {
    let f = std::fs::read(path).unwrap();
    let u16_at = |o: usize| u16::from_le_bytes([f[o], f[o + 1]]) as usize;
    let u32_at = |o: usize| u32::from_le_bytes([f[o], f[o + 1], f[o + 2], f[o + 3]]) as usize;
    assert_eq!(&f[..5], b"\x7fELF\x01", "a 32-bit ELF file");
    let (shoff, shentsize, shnum, shstrndx) =
        (u32_at(0x20), u16_at(0x2E), u16_at(0x30), u16_at(0x32));
    let header = |i: usize| shoff + i * shentsize;
    let names = u32_at(header(shstrndx) + 0x10);
    (0..shnum)
        .find(|&i| {
            let at = names + u32_at(header(i));
            f[at..].split(|&b| b == 0).next() == Some(name.as_bytes())
        })
        .map_or(0, |i| u32_at(header(i) + 0x14) as u64)
}

/// The cycles of each run of interrupt handler `vector` that its probe pin (PD`pin`) does not
/// cover: the interrupt's response (4 cycles) and the vector's `jmp` (3), the registers saved
/// before the pin goes high, and those restored after it goes low with the `reti`. Read from
/// the handler's code (`avr-objdump`), so that the figures count whole interrupts.
fn unprobed_cycles(elf: &std::path::Path, vector: &str, pin: u8) -> u64 {
    let out = std::process::Command::new("avr-objdump")
        .arg("-d")
        .arg(elf)
        .output()
        .expect("avr-objdump (Debian's binutils-avr)");
    let text = String::from_utf8_lossy(&out.stdout);
    let body: Vec<String> = text
        .lines()
        .skip_while(|l| !l.ends_with(&format!("<{vector}>:")))
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .map(|l| l.splitn(3, '\t').nth(2).unwrap_or("").replace('\t', " "))
        .collect();
    let cycles = |ins: &[String]| -> u64 {
        ins.iter()
            .map(|i| match i.split_whitespace().next().unwrap_or("") {
                "push" | "pop" | "cbi" => 2,
                "in" | "out" | "eor" => 1,
                "reti" => 4,
                other => panic!("unexpected {other:?} in {vector}'s entry or exit"),
            })
            .sum()
    };
    let (sbi, cbi) = (format!("sbi 0x12, {pin}"), format!("cbi 0x12, {pin}"));
    let on = body
        .iter()
        .position(|i| i.starts_with(&sbi))
        .unwrap_or_else(|| panic!("{vector} raises PD{pin}"));
    let off = body
        .iter()
        .rposition(|i| i.starts_with(&cbi))
        .unwrap_or_else(|| panic!("{vector} lowers PD{pin}"));
    let reti = off
        + body[off..]
            .iter()
            .position(|i| i.starts_with("reti"))
            .unwrap_or_else(|| panic!("{vector} returns"));
    4 + 3 + cycles(&body[..on]) + cycles(&body[off..=reti])
}

/// Figures for the README: run with `--nocapture`.
#[test]
fn figures() {
    // Flash and RAM from the ELF's section headers (what `avr-size -A` prints).
    let elf = elf_path();
    let section = |name: &str| elf_section_size(&elf, name);
    let (flash_text, data, bss) = (section(".text"), section(".data"), section(".bss"));

    // USART_RXC and TWI, PD2 and PD5.
    let rx_unprobed = unprobed_cycles(&elf, "__vector_11", 2);
    let twi_unprobed = unprobed_cycles(&elf, "__vector_17", 5);
    let mut hil = Hil::new();
    hil.boot();
    // Cycles per note message: instructions run while the firmware works on it (PD4: decode,
    // interpret and queue the write; PD2: the receive interrupt), and in the TWI interrupt
    // (PD5) for its board write, for Note-On and Note-Off messages with their own status
    // byte and with running status.
    let mut interp = Vec::new();
    let mut twi_cycles = Vec::new();
    let mut latency = Vec::new();
    let mut real_latency = Vec::new();
    let mut ahead_bits = Vec::new();
    let mut began_ahead = Vec::new();
    // Each byte's share (main loop and receive interrupt), by its place in the message.
    let mut per_byte: Vec<Vec<u64>> = Vec::new();
    let msgs: [&[u8]; 6] = [
        &[0x90, 60, 100],
        &[0x90, 64, 100],
        &[67, 100],
        &[0x80, 60, 0],
        &[64, 0],
        &[67, 0],
    ];
    // One SCL period in CPU cycles, at the firmware's TWI_HZ.
    let bit_cycles = F_CPU as f64 / twi_hz() as f64;
    for m in msgs {
        let log_from = hil.bus.borrow().log.len();
        let mut twi = 0u64;
        let mut in_twi = false;
        // Runs for `us`; returns the cycles of work seen meanwhile.
        let mut run_for = |hil: &mut Hil, us: u64| {
            let mut work = 0;
            let end = hil.cycles.get() + us * 8;
            while hil.cycles.get() < end {
                let n = hil.step();
                // The TWI interrupt can preempt the main loop's work: counted as the write's,
                // each run of it whole.
                let twi_pin = hil.pin('D', 5);
                if twi_pin && !in_twi {
                    twi += twi_unprobed;
                }
                in_twi = twi_pin;
                if twi_pin {
                    twi += n;
                } else if hil.pin('D', 4) || hil.pin('D', 2) {
                    work += n;
                }
            }
            work
        };
        let mut last_put = 0;
        let mut shares = Vec::new();
        for (i, &b) in m.iter().enumerate() {
            last_put = hil.cycles.get();
            hil.put(b);
            let mut share = run_for(&mut hil, SIM_BYTE_US);
            if i + 1 == m.len() {
                share += run_for(&mut hil, 3_000);
            }
            // The byte's receive interrupt, whole.
            shares.push(share + rx_unprobed);
        }
        let work: u64 = shares.iter().sum();
        per_byte.push(shares);
        interp.push(work);
        twi_cycles.push(twi);
        // From the end of the last byte's stop bit (when simavr raises receive-complete) to
        // the STOP of the board write.
        let rx_done = last_put + SIM_BYTE_US * 8;
        let bus = hil.bus.borrow();
        let t = bus.log[log_from..]
            .iter()
            .find(|t| t.bytes.len() == 3 && t.bytes[0] == 2)
            .expect("the message made a board write");
        let sim = (t.stop_cycle - rx_done) as f64 / 8.0;
        // simavr's TWI takes 9 bit times for each byte after the address and none for START,
        // the address and STOP: a real bus takes 11 bit times more for a write. The firmware
        // addresses the board ahead (START, address, register byte) and holds the bus until
        // the outputs come: that wait is when a real bus sends START and the address, up to
        // their 10 bit times, already on the wire before the outputs are known. STOP follows
        // the data either way.
        let held = (t.stop_cycle - t.start_cycle) as f64 - 27.0 * bit_cycles - twi as f64;
        let hidden = (held / bit_cycles).clamp(0.0, 10.0);
        latency.push(sim);
        real_latency.push(sim + (11.0 - hidden) * bit_cycles / 8.0);
        ahead_bits.push(hidden);
        // The register byte, its address and START before the last stop bit: the write began
        // while that byte was on the wire.
        began_ahead.push(t.start_cycle < rx_done);
    }
    hil.drain_thru();

    // The deepest stack, after a busy stretch: a full-rate flood.
    let stream = flood(1);
    let mut busy = Hil::new();
    busy.boot();
    busy.send_paced(&stream, SIM_BYTE_US);
    busy.run_us(600_000); // the firmware publishes its stack depth every 250 ms
    let stack = busy.stack_high_water().max(hil.stack_high_water());

    let avg = |v: &[u64]| v.iter().sum::<u64>() as f64 / v.len() as f64;
    let span = |v: &[f64]| {
        v.iter()
            .fold((f64::MAX, 0f64), |(a, b), &x| (a.min(x), b.max(x)))
    };
    let (lmin, lmax) = span(&latency);
    let (rmin, rmax) = span(&real_latency);
    let (hmin, hmax) = span(&ahead_bits);
    // On a real bus the write is START + 4 bytes × 9 bits + STOP: about 38 bit times.
    let real_write = 38.0 * bit_cycles / 8.0;
    println!("\n== ATmega16 firmware figures (simavr, 8 MHz) ==");
    println!("ELF: {}", elf.display());
    println!(
        "flash: {} bytes (.text {} + .data {}) of 16384 ({:.0}%); the thesis: 1846 bytes",
        flash_text + data,
        flash_text,
        data,
        (flash_text + data) as f64 / 163.84
    );
    println!(
        "RAM: {} bytes static (.data {} + .bss {}) + {} bytes deepest stack seen = {} of 1024; the thesis: 145 bytes static",
        data + bss,
        data,
        bss,
        stack,
        data + bss + stack as u64
    );
    println!(
        "CPU cycles per note message (decode + interpret + queue + receive interrupts): {:?}, mean {:.0} ({:.0} µs at 8 MHz)",
        interp,
        avg(&interp),
        avg(&interp) / 8.0
    );
    println!(
        "  (each byte's receive interrupt whole: its probed body and {rx_unprobed} cycles of entry and exit)"
    );
    for (m, shares) in msgs.iter().zip(&per_byte) {
        println!("  {m:02x?}: {shares:?} cycles, byte by byte");
    }
    println!(
        "CPU cycles in the TWI interrupt per board write: {:?}, mean {:.0} ({:.0} µs)",
        twi_cycles,
        avg(&twi_cycles),
        avg(&twi_cycles) / 8.0
    );
    println!(
        "last MIDI stop bit -> TWI STOP of the write: {lmin:.0}..{lmax:.0} µs in simavr at {:.2} kHz (the board addressed ahead: START, address and register byte while the last byte is on the wire, the bus then held for {hmin:.1}..{hmax:.1} bit times)",
        twi_hz() as f64 / 1000.0
    );
    println!(
        "  on a real bus (the write = 38 bit times = {real_write:.0} µs): {rmin:.0}..{rmax:.0} µs = {:.2}..{:.2} × the write; the thesis: 775..3420 µs at 83.33 kHz",
        rmin / real_write,
        rmax / real_write
    );
    for ((m, l), r) in msgs.iter().zip(&latency).zip(&real_latency) {
        println!("  {m:02x?}: {l:.0} µs in simavr, ≈ {r:.0} µs on a real bus");
    }
    assert!(
        began_ahead.iter().all(|&b| b),
        "every write began while its message's last byte was on the wire: {began_ahead:?}"
    );
    // Issue 11's budget, at the thesis's bus clock: at most 1.2 × the write's own bus time.
    // (A faster clock shortens the write, not the firmware's work after the last byte: at
    // 222 222 Hz the same work is 1.1–1.25 × a 171 µs write, printed above.)
    assert!(
        twi_hz() != 83_333 || rmax <= 1.2 * real_write,
        "last stop bit to the write done: up to {rmax:.0} µs, over 1.2 × the write's {real_write:.0} µs"
    );
    assert!(data + bss + (stack as u64) < 1024);
    assert!(flash_text + data < 16384);
}

/// The SCL period the ATmega16 makes for a bus clock of `hz`, in CPU cycles: F_CPU / (16 + 2 ·
/// TWBR · 4^TWPS), with TWBR · 4^TWPS rounded as the firmware rounds it.
fn scl_period_cycles(hz: u64) -> u64 {
    let divider = (F_CPU + hz / 2) / hz;
    16 + 2 * ((divider - 16) / 2)
}

/// The firmware runs the bus at the clock it was built with (`ORCH_TWI_HZ`): in simavr each
/// data byte of a write takes 9 SCL periods; what the write takes besides is the TWI
/// interrupt's answer to each step (probe PD5, plus its entry before the probe rises).
#[test]
fn the_bus_runs_at_the_chosen_twi_hz() {
    let mut hil = Hil::new();
    hil.boot();
    // A write that is not addressed ahead (see `a_note_off_for_no_note_addresses_its_board_
    // ahead_and_writes_nothing`): the release by a System Reset, a one-byte message.
    hil.send(&[0x90, 60, 100]);
    hil.run_us(5_000);
    let from = hil.bus.borrow().log.len();
    hil.send(&[0xFF]);
    // The cycles the TWI interrupt's probe is up, by the cycle they end.
    let mut in_handler = Vec::new();
    let end = hil.cycles.get() + 5_000 * 8;
    while hil.cycles.get() < end {
        let n = hil.step();
        if hil.pin('D', 5) {
            in_handler.push((hil.cycles.get(), n));
        }
    }
    let bus = hil.bus.borrow();
    let t = bus.log[from..]
        .iter()
        .find(|t| t.bytes.len() == 3 && t.bytes[0] == 2)
        .expect("the reset made a board write");
    assert_eq!(t.bytes, [2, 0, 0], "the reset released the key");
    let handler: u64 = in_handler
        .iter()
        .filter(|&&(c, _)| (t.start_cycle..=t.stop_cycle).contains(&c))
        .map(|&(_, n)| n)
        .sum();
    let bus_cycles = t.stop_cycle - t.start_cycle - handler;
    let bit = scl_period_cycles(twi_hz());
    println!(
        "ORCH_TWI_HZ {}: the write took {} cycles, {handler} of them in the TWI interrupt; 27 SCL periods are {}",
        twi_hz(),
        t.stop_cycle - t.start_cycle,
        27 * bit
    );
    // Four interrupts in the write, each entered within 60 cycles (the probe rises a few
    // instructions in, and the main loop masks interrupts now and then): at 83.33 kHz less
    // than 27 × two TWBR steps (75 kHz and 90 kHz fail), at 222 kHz four steps.
    assert!(
        (27 * bit..=27 * bit + 4 * 60).contains(&bus_cycles),
        "the write's bus time was {bus_cycles} cycles, not 27 SCL periods of {bit} cycles"
    );
}
