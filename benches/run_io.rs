//! `orch run` on this machine, through a real pseudo-terminal pair (a serial line as the
//! kernel shows it): the figures of the README's benchmark section.
//!
//! 1. **Latency**: from a byte written into the pty's master until its board write comes out
//!    of `orch run --in serial:PTY --out sim --json` (the JSON line read from its standard
//!    output: an upper bound, printing and the pipe included), median, p99 and max, on an idle
//!    machine and with a competing CPU load (one busy thread per core, normal priority).
//! 2. **Highest sustained input rate**: note messages (Note-On/Note-Off pairs over every key,
//!    running status: two bytes each) written at a rising rate (×3 a step) for 2 s each (at
//!    most 4 M messages a step); a rate is
//!    sustained when orch's decoder counted every message sent (nothing lost) and the writer
//!    kept the pace (the pty never pushed back: orch read as fast as it came). Against a DIN
//!    line's 1042 three-byte note messages a second (1563 with running status).
//!
//! `cargo bench --bench run_io` (or `bash scripts/bench-run.sh`). Not a test: it prints.

#[path = "../tests/support/mod.rs"]
mod support;

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

const ORCH: &str = env!("CARGO_BIN_EXE_orch");
/// A DIN byte (10 bits at 31 250 baud).
const WIRE_BYTE: Duration = Duration::from_micros(320);
/// DIN's note messages a second without running status.
const DIN_MESSAGES: f64 = 31_250.0 / 10.0 / 3.0;

/// `orch run` reading the pty; returns it once it says it reads, with its stderr collected.
fn start(path: &str, json: bool) -> (Child, Arc<Mutex<String>>) {
    let mut args = vec!["run", "--in"];
    let input = format!("serial:{path}");
    args.push(&input);
    args.extend(["--out", "sim", "--no-view", "--verbose"]);
    if json {
        args.push("--json");
    }
    let mut child = Command::new(ORCH)
        .args(&args)
        .stdin(Stdio::null())
        .stdout(if json { Stdio::piped() } else { Stdio::null() })
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (text, rx) = support::collect_stderr(&mut child);
    rx.recv_timeout(Duration::from_secs(20))
        .unwrap_or_else(|_| panic!("orch run never said it reads: {}", text.lock().unwrap()));
    (child, text)
}

/// Runs `f` on a thread of its own at real-time priority where the OS allows it (as orch's
/// reader runs): on a busy host a writer that is not scheduled would measure its own
/// lateness. The calling thread keeps its normal priority, so the threads it starts (the
/// competing load) do not inherit a real-time one.
fn on_a_writer_thread<R: Send + 'static>(f: impl FnOnce() -> R + Send + 'static) -> R {
    std::thread::spawn(move || {
        orch_perform::realtime::raise_priority();
        f()
    })
    .join()
    .unwrap()
}

/// The pty's master is closed: orch releases every key and waits for the device to come
/// back; SIGTERM ends it.
fn stop(child: &mut Child) -> std::process::ExitStatus {
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGTERM,
    )
    .unwrap();
    child.wait().unwrap()
}

/// One busy thread per core until dropped, at normal priority.
struct Load(Arc<AtomicBool>, Vec<std::thread::JoinHandle<()>>);

impl Load {
    fn start() -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let cores = std::thread::available_parallelism().map_or(2, |n| n.get());
        let threads = (0..cores)
            .map(|_| {
                let stop = Arc::clone(&stop);
                std::thread::spawn(move || {
                    let mut x = 1u64;
                    while !stop.load(Ordering::Relaxed) {
                        for _ in 0..10_000 {
                            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
                        }
                        std::hint::black_box(x);
                    }
                })
            })
            .collect();
        Load(stop, threads)
    }
}

impl Drop for Load {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
        for t in self.1.drain(..) {
            let _ = t.join();
        }
    }
}

/// Note-On / Note-Off pairs over the 61 keys, running status, `messages` of them.
fn notes(messages: usize) -> Vec<u8> {
    let mut s = vec![0x90];
    let mut i = 0;
    while i < messages {
        let key = 36 + (i / 2 % 61) as u8;
        s.extend([key, if i % 2 == 0 { 100 } else { 0 }]);
        i += 1;
    }
    s
}

fn percentiles(mut v: Vec<f64>) -> (f64, f64, f64) {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.99), v[v.len() - 1])
}

/// Latency of every board write: byte into the pty → its JSON line read.
fn latency(loaded: bool) -> (usize, f64, f64, f64) {
    let (mut master, path) = support::pty_master(true);
    let (mut child, stderr) = start(&path, true);
    let out = child.stdout.take().unwrap();
    let lines: Arc<Mutex<Vec<(Instant, u64)>>> = Arc::default();
    let sink = Arc::clone(&lines);
    let reader = std::thread::spawn(move || {
        orch_perform::realtime::raise_priority();
        for line in BufReader::new(out).lines() {
            let Ok(line) = line else { return };
            let v: serde_json::Value = serde_json::from_str(&line).unwrap();
            if let Some(b) = v.get("byte").and_then(serde_json::Value::as_u64) {
                sink.lock().unwrap().push((Instant::now(), b));
            }
        }
    });
    let _load = loaded.then(Load::start);
    // A note every 25 ms, each held 12 ms (two keys apart, so no re-strike waits), for 5 s:
    // 400 messages, every one a board write.
    let mut bytes = Vec::new();
    let mut at = Vec::new();
    for i in 0..200u64 {
        let key = 36 + (i * 2 % 61) as u8;
        for (t, m) in [
            (i * 25_000, [0x90, key, 100]),
            (i * 25_000 + 12_000, [0x80, key, 0]),
        ] {
            for (j, b) in m.into_iter().enumerate() {
                bytes.push(b);
                at.push(Duration::from_micros(t) + WIRE_BYTE * j as u32);
            }
        }
    }
    let mut order: Vec<usize> = (0..bytes.len()).collect();
    order.sort_by_key(|&i| at[i]);
    let sent = on_a_writer_thread(move || {
        let start = Instant::now();
        let mut sent = vec![start; bytes.len()];
        for i in order {
            let target = start + at[i];
            let now = Instant::now();
            if target > now {
                std::thread::sleep(target - now);
            }
            master.write_all(&[bytes[i]]).unwrap();
            sent[i] = Instant::now();
        }
        std::thread::sleep(Duration::from_millis(300));
        drop(master);
        sent
    });
    let status = stop(&mut child);
    reader.join().unwrap();
    assert!(status.success(), "{}", stderr.lock().unwrap());
    let got = lines.lock().unwrap();
    let ms: Vec<f64> = got
        .iter()
        .map(|&(t, b)| t.saturating_duration_since(sent[b as usize]).as_secs_f64() * 1e3)
        .collect();
    let (m, p99, max) = percentiles(ms);
    (got.len(), m, p99, max)
}

/// Writes `messages` note messages at `rate` a second into `orch run`; returns the messages
/// orch's decoder counted and the rate the writer achieved.
fn rate(rate: f64, messages: usize) -> (u64, u64, f64) {
    let (mut master, path) = support::pty_master(true);
    let (mut child, stderr) = start(&path, false);
    let bytes = notes(messages);
    let took = on_a_writer_thread(move || {
        let start = Instant::now();
        // Message i (byte 1 + 2i onwards) is due at i / rate; written in 0.5 ms slices.
        let mut next = 0usize;
        while next < bytes.len() {
            let due_messages = ((start.elapsed().as_secs_f64() * rate) as usize + 1).min(messages);
            let due = (1 + 2 * due_messages).min(bytes.len());
            if due > next {
                master.write_all(&bytes[next..due]).unwrap();
                next = due;
            } else {
                std::thread::sleep(Duration::from_micros(500));
            }
        }
        let took = start.elapsed().as_secs_f64();
        std::thread::sleep(Duration::from_millis(300));
        drop(master);
        took
    });
    let status = stop(&mut child);
    let err = stderr.lock().unwrap().clone();
    assert!(status.success(), "{err}");
    let line = err
        .lines()
        .rfind(|l| l.starts_with("orch run: "))
        .unwrap_or_else(|| panic!("no counters line: {err}"));
    let num = |after: &str| -> u64 {
        let i = line.find(after).unwrap();
        line[..i]
            .rsplit(|c: char| !c.is_ascii_digit())
            .find(|s| !s.is_empty())
            .unwrap()
            .parse()
            .unwrap()
    };
    (
        num(" bytes in"),
        num(" messages;"),
        messages as f64 / took.max(1e-9),
    )
}

fn main() {
    // `cargo bench` passes `--bench`; nothing else is taken.
    println!("orch run --in serial:PTY --out sim, through a pseudo-terminal pair on this machine");
    for loaded in [false, true] {
        let (n, m, p99, max) = latency(loaded);
        println!(
            "latency, {}: byte into the pty -> its board write read from orch's stdout, {n} writes: median {m:.3} ms, p99 {p99:.3} ms, max {max:.3} ms ({:.2} / {:.2} / {:.2} DIN bytes)",
            if loaded {
                "with a busy thread on every core"
            } else {
                "idle"
            },
            m / 0.32,
            p99 / 0.32,
            max / 0.32
        );
    }
    let mut best = 0.0f64;
    let mut failed = false;
    for target in [
        1_042.0,
        3_000.0,
        10_000.0,
        30_000.0,
        100_000.0,
        300_000.0,
        1_000_000.0,
        3_000_000.0,
        10_000_000.0,
        30_000_000.0,
    ] {
        // 2 s at each rate, at most 4 M messages (8 MB) a step.
        let messages = ((target * 2.0) as usize).clamp(2_000, 4_000_000);
        let (bytes, counted, achieved) = rate(target, messages);
        let lost = messages as u64 - counted.min(messages as u64);
        let kept_pace = achieved >= 0.98 * target;
        let sustained = lost == 0 && kept_pace && bytes == 1 + 2 * messages as u64;
        println!(
            "rate {target:>9.0} msgs/s asked: {messages} messages written at {achieved:.0}/s, {counted} counted by orch ({lost} lost): {}",
            if sustained {
                "sustained"
            } else if lost > 0 {
                "LOST MESSAGES"
            } else {
                "not sustained (the writer could not keep the pace)"
            }
        );
        if sustained {
            best = best.max(achieved);
        } else {
            failed = true;
            break;
        }
    }
    println!(
        "highest sustained input rate: {}{best:.0} note messages/s, {:.0}x a DIN line's {DIN_MESSAGES:.0} (three-byte messages)",
        if failed { "" } else { "at least (the highest asked) " },
        best / DIN_MESSAGES
    );
}
