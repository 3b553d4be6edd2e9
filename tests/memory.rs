//! Guards that `orch decode` reads any input in bounded memory: a System Exclusive message of
//! 64 MiB (`--json`, which once took 3.6 GB for 50 MB) and a line of hex text of 128 MiB with
//! no newline (`--hex`, which once held the whole line twice).
//!
//! The input is written to the child's standard input as it is generated, and the child's
//! peak resident memory (`VmHWM` in /proc/PID/status) is read after it has shown the last
//! message (so it has read everything) and before its input is closed (so it is still alive).

#![cfg(target_os = "linux")]

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::thread::JoinHandle;

use serde_json::Value;

/// The most a decode may use, whatever it reads: a few MiB of binary and buffers, the 1 MiB of
/// SysEx it keeps, and the line it prints (about 7 MiB measured; holding the input instead
/// goes past this at once).
const PEAK_LIMIT_KB: u64 = 24 * 1024;

fn spawn(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_orch"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Writes `head`, then `total` bytes of `fill` repeated, then `tail`, on a thread; hands the
/// pipe back open.
fn feed(
    child: &mut Child,
    head: &[u8],
    fill: &[u8],
    total: usize,
    tail: &[u8],
) -> JoinHandle<ChildStdin> {
    let mut stdin = child.stdin.take().unwrap();
    let (head, tail) = (head.to_vec(), tail.to_vec());
    let block: Vec<u8> = fill.iter().copied().cycle().take(64 * 1024).collect();
    std::thread::spawn(move || {
        stdin.write_all(&head).unwrap();
        let mut left = total;
        while left > 0 {
            let n = left.min(block.len());
            stdin.write_all(&block[..n]).unwrap();
            left -= n;
        }
        stdin.write_all(&tail).unwrap();
        stdin.flush().unwrap();
        stdin
    })
}

/// The child's peak resident memory so far, in KiB.
fn peak_kb(child: &Child) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{}/status", child.id())).unwrap();
    let line = status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .expect("VmHWM in /proc/PID/status");
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

#[test]
fn decode_json_reads_a_64_mib_sysex_in_bounded_memory() {
    let payload = 64 << 20;
    let mut child = spawn(&["decode", "--json", "-"]);
    // The SysEx, then a clock byte to show that everything before it was read.
    let writer = feed(
        &mut child,
        &[0xF0],
        &[0x01, 0x02, 0x03],
        payload,
        &[0xF7, 0xF8],
    );
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let sysex: Value = serde_json::from_str(&lines.next().unwrap().unwrap()).unwrap();
    assert_eq!(sysex["type"], "sysex");
    assert_eq!(sysex["length"], payload);
    assert_eq!(
        sysex["data"].as_array().unwrap().len(),
        orch_stage::messages::SYSEX_SHOWN
    );
    let clock: Value = serde_json::from_str(&lines.next().unwrap().unwrap()).unwrap();
    assert_eq!(clock["type"], "clock");
    let peak = peak_kb(&child);
    eprintln!("peak resident memory: {peak} KiB");
    drop(writer.join().unwrap());
    let summary: Value = serde_json::from_str(&lines.next().unwrap().unwrap()).unwrap();
    assert_eq!(summary["bytes"], payload + 3);
    assert!(child.wait().unwrap().success());
    assert!(
        peak < PEAK_LIMIT_KB,
        "decode --json of a {} MiB SysEx peaked at {peak} KiB (limit {PEAK_LIMIT_KB})",
        payload >> 20
    );
}

#[test]
fn decode_hex_reads_a_128_mib_line_without_newline_in_bounded_memory() {
    let digits = 128 << 20;
    let mut child = spawn(&["decode", "--hex", "--json", "-"]);
    // Data bytes with no status (each dropped), all on one line; then a clock on a new line.
    let writer = feed(&mut child, b"", b"00", digits, b"\nF8\n");
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let clock: Value = serde_json::from_str(&lines.next().unwrap().unwrap()).unwrap();
    assert_eq!(clock["type"], "clock");
    let peak = peak_kb(&child);
    eprintln!("peak resident memory: {peak} KiB");
    drop(writer.join().unwrap());
    let summary: Value = serde_json::from_str(&lines.next().unwrap().unwrap()).unwrap();
    assert_eq!(summary["dropped"], digits / 2);
    assert!(child.wait().unwrap().success());
    assert!(
        peak < PEAK_LIMIT_KB,
        "decode --hex of a {} MiB line peaked at {peak} KiB (limit {PEAK_LIMIT_KB})",
        digits >> 20
    );
}
