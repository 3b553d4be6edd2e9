//! The thesis's whole chain, in simulation, all of it running at once as the real system would:
//!
//! 1. `orch play FILE --out serial:PTY` (the sequencer PC) writes MIDI into one end of a
//!    pseudo-terminal pair, in real time;
//! 2. a bridge (this test) reads the other end as the bytes come, and hands them to the ATmega16
//!    firmware in simavr at DIN pacing, each no sooner than it arrived;
//! 3. the firmware drives four simulated PCA9555 boards.
//!
//! The boards' presses and releases must be the ones `orch play` reports for the virtual copy
//! of that robot at the far end of the line (`--writes`), key by key, each within the DIN and
//! bus timing; the boards end as the virtual robot does, every key up.
//!
//! It needs the `orch` binary: `ORCH_BIN`, or the root workspace's `target/debug/orch`
//! (`firmware/test.sh` builds it).

use std::collections::VecDeque;
use std::io::Read;
use std::os::fd::{FromRawFd, IntoRawFd};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

use orch_atmega16_hil::*;

/// The piece: Mozart's *Eine kleine Nachtmusik* opening (16 s, 211 notes on five channels,
/// five tempo changes, chords and unisons across channels).
const PIECE: &str = "m21-k525short.mid";

/// How far apart the firmware's boards and the virtual copy's may put one press or release,
/// once the two clocks are aligned on the first press. The two see the same bytes, but: the
/// virtual copy's line carries a byte every 320 µs and simavr's every 352 (it counts a parity
/// bit that 8N1 lacks), 1 ms over a 21-byte chord burst; the virtual copy takes every message
/// as sent on time, where the host schedules orch's sender, the pty and the bridge's reader
/// (seen: at most 1.3–3.7 ms apart on this machine, 8.7 ms once under a load average of 10);
/// simavr's TWI times a write a little shorter than the real bus. 10 ms is 31 DIN bytes: far
/// below what a guard decision moves a key (a 20 ms shortest press, a 60 ms rest).
const TOLERANCE_US: u64 = 10_000;

/// The robot the firmware is: the thesis's board (`Config::THESIS`), its bus at 83.33 kHz,
/// no duty limit (the firmware is built without it).
const THESIS_TOML: &str = "[bus]\nclock = \"83.33kHz\"\n\n[guard]\nduty_window = \"off\"\n";

fn orch_bin() -> PathBuf {
    let path = std::env::var_os("ORCH_BIN").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/debug/orch"),
        PathBuf::from,
    );
    assert!(
        path.exists(),
        "no orch binary at {} (build it at the repository's root: cargo build -p orch; or set ORCH_BIN)",
        path.display()
    );
    path
}

fn corpus(name: &str) -> PathBuf {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/midi")
        .join(name);
    assert!(
        path.exists(),
        "the corpus file {} is missing (../shared/midi beside the repository)",
        path.display()
    );
    path
}

/// A pseudo-terminal pair: the master, and the slave's path.
fn pty() -> (std::fs::File, String) {
    use nix::fcntl::OFlag;
    let master =
        nix::pty::posix_openpt(OFlag::O_RDWR | OFlag::O_NOCTTY | OFlag::O_CLOEXEC).unwrap();
    nix::pty::grantpt(&master).unwrap();
    nix::pty::unlockpt(&master).unwrap();
    let path = nix::pty::ptsname_r(&master).unwrap();
    // Raw on both sides: no echo, no line discipline, no newline translation.
    let mut t = nix::sys::termios::tcgetattr(&master).unwrap();
    nix::sys::termios::cfmakeraw(&mut t);
    nix::sys::termios::tcsetattr(&master, nix::sys::termios::SetArg::TCSANOW, &t).unwrap();
    // SAFETY: the descriptor is ours and open; the File takes it over.
    let file = unsafe { std::fs::File::from_raw_fd(master.into_raw_fd()) };
    (file, path)
}

/// The virtual copy's board writes from `orch play --writes`.
fn virtual_writes(path: &std::path::Path) -> Vec<TimedWrite> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .map(|line| {
            let v: serde_json::Value = serde_json::from_str(line).unwrap();
            let address = v["address"].as_u64().unwrap() as usize;
            TimedWrite {
                t_us: v["t_us"].as_u64().unwrap(),
                board: address - 0x21,
                outputs: v["outputs"].as_u64().unwrap() as u16,
            }
        })
        .collect()
}

/// How the firmware's boards and the virtual copy's differ.
enum Mismatch {
    /// Not the same presses and releases, key by key and in order: always a failure.
    Sequence(String),
    /// The same, but one further apart in time than allowed.
    Timing(String),
}

/// Every key's presses and releases on the firmware's boards are the virtual copy's, in the
/// same order, none missing and none extra, each within `tolerance_us` of the virtual copy's
/// once both are measured from their first press. Returns each event's difference (µs,
/// firmware minus virtual copy, after alignment), sorted.
fn same_as_virtual_copy(
    firmware: &[KeyEvent],
    copy: &[KeyEvent],
    tolerance_us: u64,
) -> Result<Vec<i64>, Mismatch> {
    let first = |events: &[KeyEvent]| events.iter().find(|e| e.down).map(|e| e.t_us as i64);
    let (Some(f0), Some(c0)) = (first(firmware), first(copy)) else {
        return Err(Mismatch::Sequence("no press on one side".into()));
    };
    let mut diffs = Vec::new();
    for key in 0..64 {
        let fk: Vec<&KeyEvent> = firmware.iter().filter(|e| e.key == key).collect();
        let ck: Vec<&KeyEvent> = copy.iter().filter(|e| e.key == key).collect();
        if fk.len() != ck.len() {
            return Err(Mismatch::Sequence(format!(
                "key {key}: {} presses and releases on the firmware's boards, {} on the virtual copy's\n firmware: {:?}\n copy: {:?}",
                fk.len(),
                ck.len(),
                fk.iter().map(|e| (e.t_us as i64 - f0, e.down)).collect::<Vec<_>>(),
                ck.iter().map(|e| (e.t_us as i64 - c0, e.down)).collect::<Vec<_>>()
            )));
        }
        for (i, (f, c)) in fk.iter().zip(&ck).enumerate() {
            let what = if c.down { "press" } else { "release" };
            if f.down != c.down {
                return Err(Mismatch::Sequence(format!(
                    "key {key}: event #{i} differs in kind"
                )));
            }
            let d = (f.t_us as i64 - f0) - (c.t_us as i64 - c0);
            if d.unsigned_abs() > tolerance_us {
                return Err(Mismatch::Timing(format!(
                    "key {key}: {what} #{i} at {} µs on the firmware's boards, {} µs on the virtual copy's (from their first press): {d} µs apart, allowed ±{tolerance_us}",
                    f.t_us as i64 - f0,
                    c.t_us as i64 - c0
                )));
            }
            diffs.push(d);
        }
    }
    diffs.sort_unstable();
    Ok(diffs)
}

/// The chain runs in real time on a shared host: a run whose timing alone is off (every press
/// and release right, one further from the virtual copy's than allowed: the host held orch's
/// sender or the pty up) is said on standard error and played once more; a second such run,
/// or any other difference, fails.
#[test]
fn the_thesis_chain_orch_play_to_a_pty_to_the_atmega16_in_simavr_to_the_boards() {
    if let Err(first) = play_the_chain() {
        eprintln!("chain: the timing was off on this host ({first}); playing it once more");
        if let Err(second) = play_the_chain() {
            panic!("the timing was off twice:\n first: {first}\n second: {second}");
        }
    }
}

/// One performance through the whole chain. Panics on any difference but timing, which it
/// returns.
fn play_the_chain() -> Result<(), String> {
    let dir = std::env::temp_dir().join(format!("orch-chain-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let robot = dir.join("robot.toml");
    std::fs::write(&robot, THESIS_TOML).unwrap();
    let writes = dir.join("writes.jsonl");

    // The firmware boots first, as the board would be powered before the sequencer plays.
    let mut hil = Hil::new();
    hil.boot();
    let from = hil.bus.borrow().log.len();

    let (mut master, slave) = pty();
    let mut orch = Command::new(orch_bin())
        .arg("play")
        .arg(corpus(PIECE))
        .args(["--no-view", "--json", "--robot"])
        .arg(&robot)
        .arg("--out")
        .arg(format!("serial:{slave}"))
        .arg("--writes")
        .arg(&writes)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();

    // The bridge's ear: a thread reads the pty as the bytes come and stamps each with the
    // wall clock, so the simulation's pace cannot delay a byte's arrival time. It stops when
    // orch has closed its end, or, once orch has exited, when nothing more is there (orch may
    // fail before it ever opens the pty: then no end-of-file ever comes).
    let wall0 = Instant::now();
    let orch_exited = Arc::new(AtomicBool::new(false));
    let (tx, rx) = mpsc::channel::<(u64, u8)>();
    let exited = Arc::clone(&orch_exited);
    let reader = std::thread::spawn(move || {
        use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
        // At real-time priority where the OS allows it, as orch's sender: a stamp taken late
        // on a busy host would be a byte the firmware gets late.
        let fifo = thread_priority::ThreadSchedulePolicy::Realtime(
            thread_priority::RealtimeThreadSchedulePolicy::Fifo,
        );
        let _ = thread_priority::set_thread_priority_and_policy(
            thread_priority::thread_native_id(),
            thread_priority::ThreadPriority::Max,
            fifo,
        );
        use std::os::fd::AsFd;
        let mut buf = [0u8; 256];
        loop {
            let gone = exited.load(Ordering::SeqCst);
            let mut fds = [PollFd::new(master.as_fd(), PollFlags::POLLIN)];
            let ready = poll(&mut fds, PollTimeout::from(10u8)).unwrap_or(0);
            if ready == 0 {
                if gone {
                    break;
                }
                continue;
            }
            match master.read(&mut buf) {
                Ok(0) | Err(_) => break, // EIO: orch closed its end.
                Ok(n) => {
                    let t = wall0.elapsed().as_micros() as u64;
                    for &b in &buf[..n] {
                        if tx.send((t, b)).is_err() {
                            return;
                        }
                    }
                }
            }
        }
    });

    // The bridge's hand: the simulation follows the wall clock (sim time = boot + wall time),
    // and each byte goes to the UART at its arrival time, no sooner than one DIN byte (as
    // simavr paces it) after the previous one.
    let boot_us = hil.now_us();
    let mut queue: VecDeque<(u64, u8)> = VecDeque::new();
    let mut last_put: Option<u64> = None;
    let mut bytes = 0usize;
    let mut behind_us = 0u64;
    let mut reader_done = false;
    loop {
        loop {
            match rx.try_recv() {
                Ok((t, b)) => queue.push_back((boot_us + t, b)),
                Err(mpsc::TryRecvError::Empty) => break,
                Err(mpsc::TryRecvError::Disconnected) => {
                    reader_done = true;
                    break;
                }
            }
        }
        let wall_target = boot_us + wall0.elapsed().as_micros() as u64;
        while let Some(&(at, b)) = queue.front() {
            let put_at = last_put.map_or(at, |l| at.max(l + SIM_BYTE_US));
            if put_at > wall_target {
                break;
            }
            hil.run_until(put_at * (F_CPU / 1_000_000));
            hil.put(b);
            behind_us = behind_us.max(wall0.elapsed().as_micros() as u64 + boot_us - put_at);
            last_put = Some(put_at);
            bytes += 1;
            queue.pop_front();
        }
        if reader_done && queue.is_empty() {
            break;
        }
        if !orch_exited.load(Ordering::SeqCst) && orch.try_wait().unwrap().is_some() {
            orch_exited.store(true, Ordering::SeqCst);
        }
        let now = boot_us + wall0.elapsed().as_micros() as u64;
        if hil.now_us() < now {
            hil.run_until(now.min(hil.now_us() + 2_000) * (F_CPU / 1_000_000));
        } else {
            std::thread::sleep(Duration::from_micros(200));
        }
    }
    reader.join().unwrap();
    let status = orch.wait().unwrap();
    let mut report = String::new();
    orch.stdout
        .take()
        .unwrap()
        .read_to_string(&mut report)
        .unwrap();
    let mut errors = String::new();
    orch.stderr
        .take()
        .unwrap()
        .read_to_string(&mut errors)
        .unwrap();
    assert!(status.success(), "orch play failed: {errors}");
    // The line's last bytes, then long enough for every timer of the guard.
    hil.run_us(200_000);
    let wall_s = wall0.elapsed().as_secs_f64();

    let bus = hil.bus.borrow();
    let fw_writes = bus.timed_output_writes(from);
    let copy_writes = virtual_writes(&writes);
    let (fw, copy) = (key_events(&fw_writes), key_events(&copy_writes));
    let presses = copy.iter().filter(|e| e.down).count();
    assert!(presses > 150, "the piece makes {presses} presses");
    // How late orch's sender says it was (for a DIN line this includes each message's wait
    // for the wire inside a chord's burst, which the virtual copy models too): printed.
    let report: serde_json::Value = serde_json::from_str(report.trim()).unwrap();
    let sender_late_us = (report["lateness_ms"]["max"]
        .as_f64()
        .expect("orch play reports the lateness of what it sent")
        * 1e3) as u64;
    let diffs = match same_as_virtual_copy(&fw, &copy, TOLERANCE_US) {
        Ok(d) => d,
        Err(Mismatch::Sequence(e)) => panic!("{e}"),
        Err(Mismatch::Timing(e)) => {
            std::fs::remove_dir_all(&dir).ok();
            return Err(format!(
                "{e}; orch's sender at most {sender_late_us} µs late (wire waits included), the \
                 bridge at most {behind_us} µs behind the wall clock"
            ));
        }
    };

    // The boards end as the virtual robot does: every key up.
    let mut last = [0u16; 4];
    for w in &copy_writes {
        last[w.board] = w.outputs;
    }
    assert_eq!(bus.outputs(), last, "final board outputs");
    assert_eq!(last, [0; 4], "the virtual robot ends with every key up");

    let pct = |p: usize| diffs[(diffs.len() - 1) * p / 100];
    let abs_max = diffs.iter().map(|d| d.unsigned_abs()).max().unwrap_or(0);
    println!(
        "chain: orch play {PIECE} → pty → {bytes} bytes bridged at DIN pacing → ATmega16 in simavr → 4 PCA9555: {} presses and {} releases, each the virtual copy's; firmware minus copy (aligned on the first press): p1 {} µs, median {} µs, p99 {} µs, at most {abs_max} µs apart; the bridge at most {behind_us} µs behind the wall clock; orch's sender at most {sender_late_us} µs late (wire waits included); allowed ±{TOLERANCE_US} µs; {wall_s:.1} s",
        presses,
        copy.len() - presses,
        pct(1),
        pct(50),
        pct(99),
    );
    assert!(report["notes"].as_u64() > Some(200), "{report}");
    std::fs::remove_dir_all(&dir).ok();
    Ok(())
}
