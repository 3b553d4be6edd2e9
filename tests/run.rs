//! `orch run`: live MIDI in, board writes out, end to end through the `orch` program on kernel
//! objects instead of hardware (a pseudo-terminal for the UART, UDP on loopback, a pipe for
//! standard input), against `orch interpret` fed the same bytes.

mod support;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::UdpSocket;
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde_json::Value;

const ORCH: &str = env!("CARGO_BIN_EXE_orch");
const WIRE_BYTE: Duration = Duration::from_micros(320);

/// A corpus file as a live DIN stream: every channel message of every track in time order,
/// with running status (the way a sequencer sends it).
fn live_stream(path: &str) -> Vec<u8> {
    let data = std::fs::read(path).unwrap();
    let smf = midly::Smf::parse(&data).unwrap();
    let mut events = Vec::new();
    for (n, track) in smf.tracks.iter().enumerate() {
        let mut tick = 0u64;
        for (i, e) in track.iter().enumerate() {
            tick += u64::from(e.delta.as_int());
            if let midly::TrackEventKind::Midi { channel, message } = e.kind {
                let mut b = Vec::new();
                midly::live::LiveEvent::Midi { channel, message }
                    .write_std(&mut b)
                    .unwrap();
                events.push((tick, n, i, b));
            }
        }
    }
    events.sort_by_key(|e| (e.0, e.1, e.2));
    let mut out = Vec::new();
    let mut status = 0;
    for (_, _, _, b) in events {
        if b[0] != status {
            status = b[0];
            out.extend_from_slice(&b);
        } else {
            out.extend_from_slice(&b[1..]);
        }
    }
    out
}

/// Random bytes (a fixed LCG: the same every run).
fn garbage(n: usize, seed: u64) -> Vec<u8> {
    let mut x = seed;
    (0..n)
        .map(|_| {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 56) as u8
        })
        .collect()
}

/// Lines of a child's standard output, each stamped when it was read.
type Lines = Arc<Mutex<Vec<(Instant, Value)>>>;

fn collect_lines(out: ChildStdout) -> (Lines, std::thread::JoinHandle<()>) {
    let lines: Lines = Arc::default();
    let sink = Arc::clone(&lines);
    let t = std::thread::spawn(move || {
        orch_perform::realtime::raise_priority(); // the stamps measure orch, not this thread
        for line in BufReader::new(out).lines() {
            let Ok(line) = line else { return };
            let v: Value = serde_json::from_str(&line).unwrap_or_else(|e| panic!("{line}: {e}"));
            sink.lock().unwrap().push((Instant::now(), v));
        }
    });
    (lines, t)
}

fn run_orch(args: &[&str], stdin: Stdio) -> Child {
    Command::new(ORCH)
        .arg("run")
        .args(args)
        .stdin(stdin)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn wait_ready(ready: &mpsc::Receiver<()>, stderr: &Mutex<String>) {
    ready
        .recv_timeout(Duration::from_secs(20))
        .unwrap_or_else(|_| panic!("orch run never said it reads: {}", stderr.lock().unwrap()));
}

fn wait_exit(child: &mut Child, within: Duration) -> std::process::ExitStatus {
    let t0 = Instant::now();
    loop {
        if let Some(s) = child.try_wait().unwrap() {
            return s;
        }
        if t0.elapsed() > within {
            let _ = child.kill();
            panic!("orch run did not exit within {within:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Writes `bytes` one at a time, byte `i` at `i × per_byte` from the start; returns when each
/// went out.
fn paced(out: &mut impl Write, bytes: &[u8], per_byte: Duration) -> Vec<Instant> {
    // At real-time priority where the OS allows it, as orch's reader: on a busy 2-core host
    // a writer that is not scheduled would measure its own lateness.
    orch_perform::realtime::raise_priority();
    let start = Instant::now();
    let mut when = Vec::with_capacity(bytes.len());
    for (i, &b) in bytes.iter().enumerate() {
        let target = start + per_byte * i as u32;
        let now = Instant::now();
        if target > now {
            std::thread::sleep(target - now);
        }
        out.write_all(&[b]).unwrap();
        out.flush().unwrap();
        when.push(Instant::now());
    }
    when
}

/// A board write of `--json`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct W {
    t_us: u64,
    byte: Option<u64>,
    address: u64,
    outputs: u64,
}

fn writes(lines: &[Value]) -> (Vec<W>, Option<Value>) {
    let mut ws = Vec::new();
    let mut fin = None;
    for v in lines {
        if v.get("type").is_some() {
            fin = Some(v.clone());
            continue;
        }
        ws.push(W {
            t_us: v["t_us"].as_u64().unwrap(),
            byte: v["byte"].as_u64(),
            address: v["address"].as_u64().unwrap(),
            outputs: v["outputs"].as_u64().unwrap(),
        });
    }
    (ws, fin)
}

fn interpret_json(bytes: &[u8], args: &[&str]) -> Vec<W> {
    let out = Command::new(ORCH)
        .args(["interpret", "-", "--json"])
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .and_then(|mut c| {
            c.stdin.take().unwrap().write_all(bytes)?;
            c.wait_with_output()
        })
        .unwrap();
    assert!(out.status.success());
    let lines: Vec<Value> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    writes(&lines).0
}

fn all_released(fin: &Option<Value>) {
    let fin = fin.as_ref().expect("no final line");
    for b in fin["boards"].as_array().unwrap() {
        assert_eq!(b["outputs"], 0, "{fin}");
    }
}

/// Per board, `orch run`'s writes begin with `orch interpret`'s: the same outputs in the same
/// order, each within `tol` of interpret's time (byte i at i × 320 µs); what run writes
/// after them comes after the last input byte (timers, the release at the end).
fn same_as_interpret(run: &[W], interp: &[W], last_byte_us: u64, tol_us: u64) -> Vec<i64> {
    let mut errors = Vec::new();
    let addresses: std::collections::BTreeSet<u64> = interp.iter().map(|w| w.address).collect();
    for a in addresses {
        let r: Vec<&W> = run.iter().filter(|w| w.address == a).collect();
        let i: Vec<&W> = interp.iter().filter(|w| w.address == a).collect();
        assert!(
            r.len() >= i.len(),
            "board {a:#x}: {} writes, interpret {}",
            r.len(),
            i.len()
        );
        for (n, (x, y)) in r.iter().zip(&i).enumerate() {
            assert_eq!(
                x.outputs,
                y.outputs,
                "board {a:#x} write {n}: run {x:?}, interpret {y:?}; before: run {:?}, \
                 interpret {:?}",
                &r[n.saturating_sub(4)..n],
                &i[n.saturating_sub(4)..n]
            );
            let err = x.t_us as i64 - y.t_us as i64;
            assert!(
                err.unsigned_abs() <= tol_us,
                "board {a:#x} write {n}: run at {} µs, interpret at {} µs",
                x.t_us,
                y.t_us
            );
            errors.push(err);
        }
        for x in &r[i.len()..] {
            assert!(
                x.byte.is_none(),
                "board {a:#x}: an extra write for a byte: {x:?}"
            );
            assert!(x.t_us + tol_us >= last_byte_us, "board {a:#x}: {x:?}");
        }
    }
    errors
}

fn percentiles(mut v: Vec<f64>) -> (f64, f64, f64) {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.99), v[v.len() - 1])
}

/// A robot whose guard decides nothing by time within a piece: a second note on a key joins
/// it (`overlap = "hold"`), no rest before a re-strike, no shortest press. Its writes then
/// follow from the bytes and their order alone, so a scheduling delay of a few ms on a busy
/// host moves a write, never changes it. (With the default guard, a note that ends within a
/// ms of its key's rest or the late limit may be played or dropped either way: those
/// decisions are orch-core's, tested there on exact times.)
fn timeless_robot() -> tempfile_path::TempPath {
    let out = Command::new(ORCH).arg("config").output().unwrap();
    let toml = String::from_utf8(out.stdout)
        .unwrap()
        .replace("overlap = \"restrike\"", "overlap = \"hold\"")
        .replace("restrike_gap = \"60ms\"", "restrike_gap = \"0ms\"")
        .replace("min_press = \"20ms\"", "min_press = \"0ms\"");
    assert!(toml.contains("\"hold\"") && toml.contains("\"0ms\""));
    tempfile_path::TempPath::write("robot.toml", &toml)
}

mod tempfile_path {
    /// A file in the temporary directory, removed on drop.
    pub struct TempPath(pub std::path::PathBuf);

    impl TempPath {
        pub fn write(name: &str, text: &str) -> TempPath {
            static N: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
            let n = N.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            let p = testkit::in_test(&format!("{n}-{name}"));
            std::fs::write(&p, text).unwrap();
            TempPath(p)
        }

        pub fn as_str(&self) -> &str {
            self.0.to_str().unwrap()
        }
    }

    impl Drop for TempPath {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.0);
        }
    }
}

#[test]
fn serial_pty_at_wire_pace_gives_what_interpret_gives() {
    let bytes = live_stream(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/ode-to-joy.mid"
    ));
    assert!(bytes.len() > 500, "{}", bytes.len());
    let robot = timeless_robot();
    let (mut master, path) = support::pty_master(false);
    let mut child = run_orch(
        &[
            "--in",
            &format!("serial:{path}"),
            "--out",
            "sim",
            "--json",
            "--verbose",
            "--robot",
            robot.as_str(),
        ],
        Stdio::null(),
    );
    let (lines, reader) = collect_lines(child.stdout.take().unwrap());
    let (stderr, ready) = support::collect_stderr(&mut child);
    wait_ready(&ready, &stderr);
    let sent = paced(&mut master, &bytes, WIRE_BYTE);
    std::thread::sleep(Duration::from_millis(300));
    drop(master); // the line hangs up: orch releases every key and waits for it to return
    wait_for("went away", &stderr);
    signal(&child, nix::sys::signal::Signal::SIGTERM);
    let status = wait_exit(&mut child, Duration::from_secs(10));
    reader.join().unwrap();
    let err = stderr.lock().unwrap().clone();
    assert!(status.success(), "{err}");
    let stamped = lines.lock().unwrap().clone();
    let (run, fin) = writes(&stamped.iter().map(|l| l.1.clone()).collect::<Vec<_>>());
    all_released(&fin);
    let interp = interpret_json(&bytes, &["--robot", robot.as_str()]);
    assert!(interp.len() > 200, "{}", interp.len());
    assert!(interp.iter().all(|w| w.byte.is_some()));
    let last_byte_us = (bytes.len() as u64 - 1) * 320;
    let errors = same_as_interpret(&run, &interp, last_byte_us, 5_000);
    // End to end: from the byte going into the pty to its board write read from orch's
    // standard output (the JSON line printed and piped: an upper bound).
    let mut latency = Vec::new();
    for (at, v) in &stamped {
        if let Some(i) = v.get("byte").and_then(Value::as_u64) {
            latency.push(at.saturating_duration_since(sent[i as usize]).as_secs_f64() * 1e3);
        }
    }
    let (m, p99, max) = percentiles(latency);
    let (em, ep99, emax) = percentiles(errors.iter().map(|e| *e as f64 / 1e3).collect());
    println!(
        "{} bytes, {} board writes: byte into the pty -> its write read from orch's stdout: \
         median {m:.3} ms, p99 {p99:.3} ms, max {max:.3} ms; write time against interpret's \
         i x 320 us: median {em:.3} ms, p99 {ep99:.3} ms, max {emax:.3} ms",
        bytes.len(),
        run.len()
    );
}

/// A serial device that goes away (a USB adapter unplugged: here the pty's master closed)
/// with a key down and a message half sent: every key is released at once, the cut message is
/// forgotten, and when the device comes back at the same path (a symlink, as
/// `/dev/serial/by-id/…` is) orch reads it again, from a clean start.
#[test]
fn a_serial_device_that_goes_away_releases_every_key_and_is_read_again_when_it_returns() {
    let link = testkit::in_test("serial-link");
    let _ = std::fs::remove_file(&link);
    let (mut first, path) = support::pty_master(false);
    std::os::unix::fs::symlink(&path, &link).unwrap();
    let mut child = run_orch(
        &[
            "--in",
            &format!("serial:{}", link.display()),
            "--json",
            "--verbose",
        ],
        Stdio::null(),
    );
    let (lines, reader) = collect_lines(child.stdout.take().unwrap());
    let (stderr, ready) = support::collect_stderr(&mut child);
    wait_ready(&ready, &stderr);
    let count = || lines.lock().unwrap().len();
    let wait_lines = |n: usize| {
        let t0 = Instant::now();
        while count() < n {
            assert!(t0.elapsed() < Duration::from_secs(10), "{} lines", count());
            std::thread::sleep(Duration::from_millis(5));
        }
    };
    // C4 and E4 down (board 0x22 bits 8 and 12), then a Note-On cut after its key.
    first
        .write_all(&[0x90, 60, 100, 64, 100, 0x90, 67])
        .unwrap();
    wait_lines(2);
    drop(first);
    wait_for("went away", &stderr);
    wait_lines(3);
    let released = lines.lock().unwrap()[2].1.clone();
    assert_eq!(
        (released["address"].as_u64(), released["outputs"].as_u64()),
        (Some(0x22), Some(0)),
        "{released}"
    );
    assert!(
        released["byte"].is_null(),
        "released by no byte: {released}"
    );

    // The device comes back at the same path.
    let (mut second, path) = support::pty_master(false);
    std::fs::remove_file(&link).unwrap();
    std::os::unix::fs::symlink(&path, &link).unwrap();
    wait_for("is back", &stderr);
    // Data bytes with no status first: neither the rest of the cut message nor a note under
    // the old running status. Then G4 as a whole message.
    second.write_all(&[100, 72, 100]).unwrap();
    second.write_all(&[0x90, 67, 100]).unwrap();
    wait_lines(4);
    std::thread::sleep(Duration::from_millis(50));
    signal(&child, nix::sys::signal::Signal::SIGUSR1);
    wait_for("went away 1 times (1 messages cut off)", &stderr);
    signal(&child, nix::sys::signal::Signal::SIGTERM);
    let status = wait_exit(&mut child, Duration::from_secs(5));
    reader.join().unwrap();
    let err = stderr.lock().unwrap().clone();
    assert!(status.success(), "{err}");
    let v: Vec<Value> = lines.lock().unwrap().iter().map(|l| l.1.clone()).collect();
    let (ws, fin) = writes(&v);
    all_released(&fin);
    let by_bytes: Vec<(u64, u64)> = ws
        .iter()
        .filter(|w| w.byte.is_some())
        .map(|w| (w.address, w.outputs))
        .collect();
    // C4, C4+E4, then after the loss only G4 (bit 15 of 0x22): nothing from the stray bytes.
    assert_eq!(
        by_bytes,
        [
            (0x22, 1 << 8),
            (0x22, (1 << 8) | (1 << 12)),
            (0x22, 1 << 15)
        ],
        "{ws:?}"
    );
    std::fs::remove_file(&link).ok();
}

/// A chord through UDP, then SIGTERM: every key released (seen in --json) before exit.
#[test]
fn udp_chord_then_sigterm_releases_every_key() {
    let port = UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let mut child = run_orch(
        &["--in", &format!("udp:{port}"), "--json", "--verbose"],
        Stdio::null(),
    );
    let (lines, reader) = collect_lines(child.stdout.take().unwrap());
    let (stderr, ready) = support::collect_stderr(&mut child);
    wait_ready(&ready, &stderr);
    let s = UdpSocket::bind("127.0.0.1:0").unwrap();
    // Notes 36 (board 0x21), 60 and 64 (0x22), 90 (0x24).
    for m in [
        [0x90, 36, 100],
        [0x90, 60, 100],
        [0x91, 64, 90],
        [0x90, 90, 1],
    ] {
        s.send_to(&m, ("127.0.0.1", port)).unwrap();
    }
    let t0 = Instant::now();
    while lines.lock().unwrap().len() < 4 {
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "the chord never came"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    std::thread::sleep(Duration::from_millis(100));
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGTERM,
    )
    .unwrap();
    let status = wait_exit(&mut child, Duration::from_secs(5));
    reader.join().unwrap();
    assert!(status.success(), "{}", stderr.lock().unwrap());
    let v: Vec<Value> = lines.lock().unwrap().iter().map(|l| l.1.clone()).collect();
    let (ws, fin) = writes(&v);
    all_released(&fin);
    let down: Vec<&W> = ws.iter().filter(|w| w.byte.is_some()).collect();
    assert_eq!(down.len(), 4, "{ws:?}");
    assert_eq!(down[3].outputs, 1 << (90 - 36 - 48), "{ws:?}");
    // After the chord: one release of each of the three boards, by no byte, after 100 ms.
    let after: Vec<&W> = ws[4..].iter().collect();
    assert_eq!(after.len(), 3, "{ws:?}");
    for w in after {
        assert_eq!((w.byte, w.outputs), (None, 0), "{ws:?}");
        assert!(w.t_us >= 100_000, "{ws:?}");
    }
}

/// Standard input: a chord, then the end of the input: keys released, exit 0.
#[test]
fn stdin_end_releases_and_exits_0() {
    let mut child = run_orch(&["--in", "-", "--json"], Stdio::piped());
    let mut stdin = child.stdin.take().unwrap();
    let (lines, reader) = collect_lines(child.stdout.take().unwrap());
    stdin.write_all(&[0x90, 60, 100, 64, 100]).unwrap();
    let t0 = Instant::now();
    while lines.lock().unwrap().len() < 2 {
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "the chord never came"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    std::thread::sleep(Duration::from_millis(50));
    drop(stdin);
    let status = wait_exit(&mut child, Duration::from_secs(5));
    reader.join().unwrap();
    assert!(status.success());
    let v: Vec<Value> = lines.lock().unwrap().iter().map(|l| l.1.clone()).collect();
    let (ws, fin) = writes(&v);
    all_released(&fin);
    assert_eq!(ws.len(), 3, "{ws:?}");
    assert_eq!((ws[1].address, ws[1].outputs), (0x22, (1 << 8) | (1 << 12)));
    assert_eq!((ws[2].address, ws[2].byte, ws[2].outputs), (0x22, None, 0));
}

/// A robot of PCA9685 boards: a Note-On is written as its strike's duty, the hold follows by
/// itself 40 ms later (a timer, no byte), and the end of the input lets every channel go.
#[test]
fn on_pca9685_boards_a_note_strikes_holds_on_its_own_and_releases_at_the_end() {
    let robot = testkit::in_test("robot.toml");
    let config = Command::new(ORCH)
        .args(["config", "--boards", "pca9685"])
        .output()
        .unwrap();
    std::fs::write(&robot, &config.stdout).unwrap();
    let mut child = run_orch(
        &["--in", "-", "--json", "--robot", robot.to_str().unwrap()],
        Stdio::piped(),
    );
    let mut stdin = child.stdin.take().unwrap();
    let (lines, reader) = collect_lines(child.stdout.take().unwrap());
    stdin.write_all(&[0x90, 60, 127]).unwrap();
    let t0 = Instant::now();
    // The strike, then the hold by the timer.
    while lines.lock().unwrap().len() < 2 {
        assert!(t0.elapsed() < Duration::from_secs(10), "no strike and hold");
        std::thread::sleep(Duration::from_millis(5));
    }
    drop(stdin);
    let status = wait_exit(&mut child, Duration::from_secs(5));
    reader.join().unwrap();
    assert!(status.success());
    let v: Vec<Value> = lines.lock().unwrap().iter().map(|l| l.1.clone()).collect();
    let duty = |l: &Value| l["duty"][8].as_u64().unwrap();
    // Middle C: board 1 (0x41), channel 8.
    assert_eq!(
        (v[0]["address"].as_u64(), duty(&v[0])),
        (Some(0x41), 4095),
        "{v:?}"
    );
    assert!(v[0]["byte"].is_u64());
    assert_eq!(duty(&v[1]), 1433, "the 35 % hold: {v:?}");
    assert!(v[1]["byte"].is_null(), "written by the timer");
    let strike_to_hold = v[1]["t_us"].as_u64().unwrap() - v[0]["t_us"].as_u64().unwrap();
    assert_eq!(strike_to_hold, 40_000, "{v:?}");
    assert_eq!(duty(&v[2]), 0, "released at the end: {v:?}");
    let fin = v.last().unwrap();
    assert_eq!(fin["type"], "final");
    assert!(fin["boards"]
        .as_array()
        .unwrap()
        .iter()
        .all(|b| b["outputs"] == 0));
}

/// No byte for the watchdog's time while a key is down: released by the timer alone, with
/// `orch run` still reading (4 s by default; 300 ms after an Active Sensing byte).
#[test]
fn watchdog_releases_keys_when_the_input_goes_silent() {
    for (bytes, watchdog_us) in [
        (&[0x90u8, 60, 100][..], 4_000_000u64),
        (&[0xFE, 0x90, 62, 100][..], 300_000),
    ] {
        let mut child = run_orch(&["--in", "-", "--json"], Stdio::piped());
        let mut stdin = child.stdin.take().unwrap();
        let (lines, reader) = collect_lines(child.stdout.take().unwrap());
        stdin.write_all(bytes).unwrap();
        std::thread::sleep(Duration::from_micros(watchdog_us) + Duration::from_millis(500));
        assert!(child.try_wait().unwrap().is_none(), "orch run ended early");
        let v: Vec<Value> = lines.lock().unwrap().iter().map(|l| l.1.clone()).collect();
        let (ws, _) = writes(&v);
        assert_eq!(ws.len(), 2, "{ws:?}");
        assert_eq!((ws[1].byte, ws[1].outputs), (None, 0), "{ws:?}");
        let late = ws[1].t_us - watchdog_us;
        assert!(ws[1].t_us >= watchdog_us && late < 50_000, "{ws:?}");
        drop(stdin);
        assert!(wait_exit(&mut child, Duration::from_secs(5)).success());
        reader.join().unwrap();
    }
}

/// The decoder's counters of a text `orch interpret` run: bytes, messages, dropped, abandoned,
/// notes.
fn interpret_counters(bytes: &[u8]) -> [u64; 5] {
    let out = Command::new(ORCH)
        .args(["interpret", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .and_then(|mut c| {
            c.stdin.take().unwrap().write_all(bytes)?;
            c.wait_with_output()
        })
        .unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    let nums = |line: &str| -> Vec<u64> {
        line.split(|c: char| !c.is_ascii_digit())
            .filter_map(|s| s.parse().ok())
            .collect()
    };
    let l1 = text.lines().find(|l| l.contains(" messages,")).unwrap();
    let l2 = text.lines().find(|l| l.contains(" notes: ")).unwrap();
    let (a, b) = (nums(l1), nums(l2));
    [a[0], a[1], a[2], a[3], b[0]]
}

/// A corpus piece with random garbage spliced in, at ten times the wire's speed: nothing
/// panics, the decoder's counters (every message, every stray byte) are those of the
/// interpreter fed the same bytes, and the counters line reports the garbage.
#[test]
fn flood_and_garbage_lose_no_message_and_are_counted() {
    let song = live_stream(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/ode-to-joy.mid"
    ));
    let noise = garbage(4000, 7);
    let mut bytes = Vec::new();
    for (i, chunk) in song.chunks(50).enumerate() {
        bytes.extend_from_slice(chunk);
        bytes.extend_from_slice(&noise[i * 40..i * 40 + 40]);
    }
    bytes.extend_from_slice(&song); // and the piece again, clean
    let mut child = run_orch(&["--in", "-", "--json", "--verbose"], Stdio::piped());
    let mut stdin = child.stdin.take().unwrap();
    let (lines, reader) = collect_lines(child.stdout.take().unwrap());
    let (stderr, _) = support::collect_stderr(&mut child);
    paced(&mut stdin, &bytes, WIRE_BYTE / 10);
    drop(stdin);
    let status = wait_exit(&mut child, Duration::from_secs(20));
    reader.join().unwrap();
    let err = stderr.lock().unwrap().clone();
    assert!(status.success() && !err.contains("panic"), "{err}");
    let v: Vec<Value> = lines.lock().unwrap().iter().map(|l| l.1.clone()).collect();
    all_released(&writes(&v).1);
    let line = err
        .lines()
        .rfind(|l| l.starts_with("orch run: "))
        .unwrap_or_else(|| panic!("no counters line: {err}"));
    let want = interpret_counters(&bytes);
    let num = |after: &str| -> u64 {
        let i = line
            .find(after)
            .unwrap_or_else(|| panic!("{after} in {line}"));
        line[..i]
            .rsplit(|c: char| !c.is_ascii_digit())
            .find(|s| !s.is_empty())
            .unwrap()
            .parse()
            .unwrap()
    };
    let got = [
        num(" bytes in"),
        num(" messages;"),
        num(" data bytes with no status"),
        num(" messages cut short"),
        num(" notes:"),
    ];
    assert_eq!(got, want, "{line}");
    assert_eq!(got[0], bytes.len() as u64);
    assert!(
        got[2] > 0 && got[3] > 0,
        "the garbage is not counted: {line}"
    );
    println!("{line}");
}

/// Bad usage exits 2 with a message.
#[test]
fn bad_input_or_output_exits_2() {
    for args in [
        &["--in", "tcp:1"][..],
        &["--in", "-", "--out", "udp:127.0.0.1:9"],
        &["--in", "-", "--thru", "sim"],
        &["--in", "rawmidi:/nonexistent/midi"],
        &["--in", "-", "--thru", "rawmidi:/nonexistent/midi"],
        #[cfg(not(feature = "alsa"))]
        &["--in", "alsa:"],
    ] {
        let out = Command::new(ORCH)
            .arg("run")
            .args(args)
            .stdin(Stdio::null())
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(!out.stderr.is_empty());
        if args[1] == "alsa:" {
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(err.contains("`alsa` feature"), "{err}");
        }
    }
}

/// `--thru udp:` passes the input on, only the chosen channel, re-encoded message by message.
#[test]
fn thru_passes_the_chosen_channels_on() {
    let rx = UdpSocket::bind("127.0.0.1:0").unwrap();
    rx.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let port = rx.local_addr().unwrap().port();
    let thru = format!("udp:127.0.0.1:{port}:ch=2");
    let mut child = run_orch(&["--in", "-", "--json", "--thru", &thru], Stdio::piped());
    let mut stdin = child.stdin.take().unwrap();
    let mut out = child.stdout.take().unwrap();
    stdin
        .write_all(&[0x90, 60, 100, 0x91, 62, 100, 64, 100, 0x90, 65, 100, 0xF8])
        .unwrap();
    drop(stdin);
    assert!(wait_exit(&mut child, Duration::from_secs(5)).success());
    let mut s = String::new();
    out.read_to_string(&mut s).unwrap();
    let mut got = Vec::new();
    let mut buf = [0u8; 64];
    while let Ok(n) = rx.recv(&mut buf) {
        got.push(buf[..n].to_vec());
        if buf[..n] == [0xB0 | 15, 123, 0] {
            break;
        }
    }
    assert_eq!(
        got[..3],
        [vec![0x91, 62, 100], vec![0x91, 64, 100], vec![0xF8]]
    );
    // Then All Notes Off on every channel.
    assert_eq!(got.len(), 3 + 16, "{got:?}");
}

fn signal(child: &Child, s: nix::sys::signal::Signal) {
    nix::sys::signal::kill(nix::unistd::Pid::from_raw(child.id() as i32), s).unwrap();
}

fn wait_for(what: &str, text: &Mutex<String>) {
    let t0 = Instant::now();
    while !text.lock().unwrap().contains(what) {
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "never said `{what}`: {}",
            text.lock().unwrap()
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// SIGHUP reads robot.toml again: a bad file is refused and the old robot plays on; a good one
/// takes over once no key is down, with no held key dropped. SIGUSR1 prints the counters.
#[test]
fn sighup_reloads_without_dropping_held_keys_and_sigusr1_counts() {
    let out = Command::new(ORCH).arg("config").output().unwrap();
    let default = String::from_utf8(out.stdout).unwrap();
    let robot = tempfile_path::TempPath::write("reload.toml", &default);
    let mut child = run_orch(
        &[
            "--in",
            "-",
            "--json",
            "--verbose",
            "--robot",
            robot.as_str(),
        ],
        Stdio::piped(),
    );
    let mut stdin = child.stdin.take().unwrap();
    let (lines, reader) = collect_lines(child.stdout.take().unwrap());
    let (stderr, ready) = support::collect_stderr(&mut child);
    wait_ready(&ready, &stderr);
    stdin.write_all(&[0x90, 60, 100]).unwrap();
    stdin.flush().unwrap();
    let t0 = Instant::now();
    while lines.lock().unwrap().is_empty() {
        assert!(t0.elapsed() < Duration::from_secs(10));
        std::thread::sleep(Duration::from_millis(5));
    }
    std::fs::write(&robot.0, "[guard]\nmax_keys_down = \"many\"\n").unwrap();
    signal(&child, nix::sys::signal::Signal::SIGHUP);
    wait_for("refused, the robot stays as it was", &stderr);
    let one_key = default.replace("max_keys_down = 16", "max_keys_down = 1");
    assert_ne!(one_key, default);
    std::fs::write(&robot.0, one_key).unwrap();
    signal(&child, nix::sys::signal::Signal::SIGHUP);
    wait_for("it takes over when no key is down", &stderr);
    signal(&child, nix::sys::signal::Signal::SIGUSR1);
    wait_for("keys down", &stderr);
    assert!(stderr.lock().unwrap().contains("1 keys down"));
    // The key is still down: nothing was written since its press.
    assert_eq!(lines.lock().unwrap().len(), 1);
    stdin.write_all(&[0x80, 60, 0]).unwrap();
    stdin.flush().unwrap();
    wait_for("the new robot configuration is in force", &stderr);
    // Two notes at once: the new power budget takes one.
    stdin.write_all(&[0x90, 62, 100, 64, 100]).unwrap();
    drop(stdin);
    assert!(wait_exit(&mut child, Duration::from_secs(5)).success());
    reader.join().unwrap();
    let v: Vec<Value> = lines.lock().unwrap().iter().map(|l| l.1.clone()).collect();
    let (ws, fin) = writes(&v);
    all_released(&fin);
    let seq: Vec<(u64, u64)> = ws.iter().map(|w| (w.address, w.outputs)).collect();
    assert_eq!(
        seq,
        [(0x22, 1 << 8), (0x22, 0), (0x22, 1 << 10), (0x22, 0)],
        "{ws:?}"
    );
}

/// With `--out sim` on a terminal (tmux), the live view shows the keys held by the input;
/// `q` stops: the terminal comes back and orch exits 0.
#[test]
fn live_view_shows_the_held_keys_and_q_stops() {
    assert!(
        Command::new("tmux").arg("-V").output().is_ok(),
        "tmux is needed for this test; scripts/test.sh installs it"
    );
    let port = UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let socket = format!("orch-run-view-{}", std::process::id());
    let tmux = |args: &[&str]| {
        Command::new("tmux")
            .args(["-L", &socket, "-f", "/dev/null"])
            .args(args)
            .env("TERM", "xterm-256color")
            .output()
            .unwrap()
    };
    let command = format!("{ORCH} run --in udp:{port}; echo EXIT=$?; sleep 10");
    let started = tmux(&["new-session", "-d", "-x", "100", "-y", "30", &command]);
    assert!(started.status.success());
    let s = UdpSocket::bind("127.0.0.1:0").unwrap();
    let t0 = Instant::now();
    let mut screen = String::new();
    while !screen.contains("down: C4 E4 G4") && t0.elapsed() < Duration::from_secs(10) {
        // Sent again until seen: the view may not have started when the first ones came.
        s.send_to(&[0x90, 60, 100, 64, 100, 67, 100], ("127.0.0.1", port))
            .unwrap();
        std::thread::sleep(Duration::from_millis(200));
        screen = String::from_utf8_lossy(&tmux(&["capture-pane", "-p"]).stdout).into_owned();
    }
    tmux(&["send-keys", "q"]);
    std::thread::sleep(Duration::from_millis(1000));
    let after = String::from_utf8_lossy(&tmux(&["capture-pane", "-p"]).stdout).into_owned();
    tmux(&["kill-server"]);
    assert!(screen.contains("down: C4 E4 G4"), "{screen}");
    assert!(screen.contains("61 keys"), "{screen}");
    assert!(after.contains("EXIT=0"), "{after}");
    assert!(!after.contains("down: "), "the view is gone: {after}");
}
