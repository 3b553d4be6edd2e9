//! RTP-MIDI in and out, end to end through the `orch` program on loopback, against peers
//! that share no code with orch:
//!
//! - `orch play --out rtpmidi:` into pymidi 0.5.0's own server (PyPI), which answers the
//!   invitations and the clock sync, parses every packet and takes the goodbye;
//! - `orch run --in rtpmidi:` from `tests/rtpmidi/peer.py`, a session initiator and sender
//!   written from RFC 6295 on pymidi's packet definitions: pymidi cannot begin a session or
//!   send MIDI (its client is a stub), and so sends no recovery journal either.
//!
//! pymidi is installed here when it is missing (`pip install pymidi==0.5.0 six`).
//!
//! scripts/pi.sh runs these tests again with `ORCH_ARM64` naming a script that runs the
//! Raspberry Pi's orch (aarch64) under qemu-user: the same tests of the Pi's build.

mod support;

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

/// The orch under test: this build's, or the one `ORCH_ARM64` names (scripts/pi.sh).
fn orch() -> Command {
    Command::new(std::env::var_os("ORCH_ARM64").unwrap_or(env!("CARGO_BIN_EXE_orch").into()))
}
const PEER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/rtpmidi/peer.py");
const SERVER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/rtpmidi/server.py");

/// pymidi (and `six`, which it imports without declaring), installed once if missing.
fn pymidi() {
    static READY: OnceLock<()> = OnceLock::new();
    READY.get_or_init(|| {
        let check = || {
            Command::new("python3")
                .args(["-c", "import pymidi.packets, pymidi.server, six"])
                .status()
                .is_ok_and(|s| s.success())
        };
        if !check() {
            let ok = Command::new("python3")
                .args(["-m", "pip", "install", "-q", "pymidi==0.5.0", "six"])
                .status()
                .is_ok_and(|s| s.success());
            assert!(ok && check(), "pymidi 0.5.0 could not be installed");
        }
    });
}

/// JSON lines of a child's standard output, each stamped when read.
type Lines = Arc<Mutex<Vec<(Instant, Value)>>>;

fn collect_lines(out: ChildStdout) -> (Lines, std::thread::JoinHandle<()>) {
    let lines: Lines = Arc::default();
    let sink = Arc::clone(&lines);
    let t = std::thread::spawn(move || {
        for line in BufReader::new(out).lines() {
            let Ok(line) = line else { return };
            let v: Value = serde_json::from_str(&line).unwrap_or_else(|e| panic!("{line}: {e}"));
            sink.lock().unwrap().push((Instant::now(), v));
        }
    });
    (lines, t)
}

/// `orch run --in rtpmidi:peer-test@0 …` started; its control port.
fn orch_run(robot: Option<&str>) -> (Child, Lines, Arc<Mutex<String>>, u16) {
    let mut args = vec!["run", "--in", "rtpmidi:under-test@0", "--json", "--verbose"];
    if let Some(r) = robot {
        args.extend(["--robot", r]);
    }
    let mut child = orch()
        .args(&args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (lines, _) = collect_lines(child.stdout.take().unwrap());
    let (stderr, ready) = support::collect_stderr(&mut child);
    ready
        .recv_timeout(Duration::from_secs(20))
        .unwrap_or_else(|_| panic!("orch run never said it reads: {}", stderr.lock().unwrap()));
    wait_for("on 0.0.0.0:", &stderr);
    let text = stderr.lock().unwrap().clone();
    let port = text
        .split("on 0.0.0.0:")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("no port in: {text}"));
    (child, lines, stderr, port)
}

/// Runs the RFC peer on `script` (its port filled in); its events.
fn peer(port: u16, mut script: Value) -> Vec<Value> {
    pymidi();
    script["port"] = json!(port);
    let path = testkit::in_test(&format!("peer-{port}.json"));
    std::fs::write(&path, script.to_string()).unwrap();
    let out = Command::new("python3")
        .arg(PEER)
        .arg(&path)
        .output()
        .unwrap();
    let _ = std::fs::remove_file(&path);
    assert!(
        out.status.success(),
        "peer failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// A board write of `--json`: (t_us, byte index, address, outputs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct W {
    t_us: u64,
    byte: Option<u64>,
    address: u64,
    outputs: u64,
}

fn writes(lines: &Lines) -> Vec<W> {
    lines
        .lock()
        .unwrap()
        .iter()
        .filter(|(_, v)| v.get("type").is_none())
        .map(|(_, v)| W {
            t_us: v["t_us"].as_u64().unwrap(),
            byte: v["byte"].as_u64(),
            address: v["address"].as_u64().unwrap(),
            outputs: v["outputs"].as_u64().unwrap(),
        })
        .collect()
}

fn wait_for(what: &str, text: &Mutex<String>) {
    let t0 = Instant::now();
    while !text.lock().unwrap().contains(what) {
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "never said {what:?}: {}",
            text.lock().unwrap()
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn stop(mut child: Child, lines: &Lines) -> Value {
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGTERM,
    )
    .unwrap();
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "orch run did not stop"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(Duration::from_millis(50));
    let fin = lines
        .lock()
        .unwrap()
        .iter()
        .map(|l| l.1.clone())
        .find(|v| v.get("type").is_some())
        .expect("no final line");
    for b in fin["boards"].as_array().unwrap() {
        assert_eq!(b["outputs"], 0, "{fin}");
    }
    fin
}

/// Robot files: the thesis's robot with its guard timeless (a second note on a key joins it,
/// no rest before a re-strike), optionally with the sustain pedal obeyed.
fn robot(sustain: bool) -> std::path::PathBuf {
    let out = orch().arg("config").output().unwrap();
    let mut toml = String::from_utf8(out.stdout)
        .unwrap()
        .replace("overlap = \"restrike\"", "overlap = \"hold\"")
        .replace("restrike_gap = \"60ms\"", "restrike_gap = \"0ms\"")
        .replace("min_press = \"20ms\"", "min_press = \"0ms\"");
    if sustain {
        toml = toml.replace("sustain = false", "sustain = true");
    }
    static N: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let n = N.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    let p = testkit::in_test(&format!("robot-{n}.toml"));
    std::fs::write(&p, toml).unwrap();
    p
}

/// A MIDI byte stream cut into whole messages, status bytes put back.
fn messages(stream: &[u8]) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    let mut status = 0u8;
    let mut i = 0;
    while i < stream.len() {
        if stream[i] >= 0x80 {
            status = stream[i];
            i += 1;
        }
        let n = if (0xC0..0xE0).contains(&status) { 1 } else { 2 };
        let mut m = vec![status];
        m.extend_from_slice(&stream[i..i + n]);
        out.push(m);
        i += n;
    }
    out
}

/// The corpus melody as a live stream (every channel message in time order, running status),
/// as tests/run.rs makes it.
fn ode_to_joy() -> Vec<u8> {
    let data = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/ode-to-joy.mid"
    ))
    .unwrap();
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
    events.into_iter().flat_map(|e| e.3).collect()
}

fn interpret_outputs(bytes: &[u8], robot: &str) -> Vec<W> {
    let mut c = orch()
        .args(["interpret", "-", "--json", "--robot", robot])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    c.stdin.take().unwrap().write_all(bytes).unwrap();
    let out = c.wait_with_output().unwrap();
    assert!(out.status.success());
    let lines: Lines = Arc::default();
    for l in String::from_utf8(out.stdout).unwrap().lines() {
        lines
            .lock()
            .unwrap()
            .push((Instant::now(), serde_json::from_str(l).unwrap()));
    }
    writes(&lines)
}

/// The melody, three messages a packet (running status and delta times within a packet),
/// with hostile datagrams on both ports between: the board writes are `orch interpret`'s
/// for the same bytes, board by board, in order.
#[test]
fn a_melody_through_a_session_gives_what_interpret_gives() {
    let bytes = ode_to_joy();
    let robot = robot(false);
    let robot = robot.to_str().unwrap();
    let (child, lines, stderr, port) = orch_run(Some(robot));
    let mut steps = Vec::new();
    for (k, chunk) in messages(&bytes).chunks(3).enumerate() {
        let send: Vec<Value> = chunk
            .iter()
            .enumerate()
            .map(|(i, m)| json!([i, m]))
            .collect();
        steps.push(json!({"send": send}));
        if k % 20 == 10 {
            steps.push(json!({"garbage": "80610001000000", "to": "data"}));
            steps.push(json!({"garbage": "ffff494e0000", "to": "control"}));
            steps.push(json!({"garbage": "0000000000000000000000000000", "to": "data"}));
        }
        steps.push(json!({"sleep_ms": 2}));
    }
    steps.push(json!({"bye": true}));
    let events = peer(port, json!({"name": "melody", "steps": steps}));
    assert!(
        events.iter().any(|e| e["event"] == "rs"),
        "no receiver feedback"
    );
    wait_for("every key released", &stderr);
    stop(child, &lines);
    let run = writes(&lines);
    let interp = interpret_outputs(&bytes, robot);
    assert!(interp.len() > 200, "{}", interp.len());
    for a in [0x21, 0x22, 0x23, 0x24] {
        let r: Vec<u64> = run
            .iter()
            .filter(|w| w.address == a && w.byte.is_some())
            .map(|w| w.outputs)
            .collect();
        let i: Vec<u64> = interp
            .iter()
            .filter(|w| w.address == a)
            .map(|w| w.outputs)
            .collect();
        assert_eq!(r, i, "board {a:#x}");
    }
    let err = stderr.lock().unwrap().clone();
    assert!(err.contains("session with `melody`"), "{err}");
    assert!(
        err.contains("refused"),
        "the hostile datagrams are said: {err}"
    );
}

/// A packet carrying a Note-Off is lost (the peer drops it): the next packet's journal
/// (chapter N's OFFBITS) has orch release the key when that packet arrives, not the
/// watchdog 4 s later. The same for a lost pedal release (chapter C, controller 64) with a
/// robot that obeys the pedal. orch's receiver feedback names the last packet.
#[test]
fn a_lost_note_off_and_a_lost_pedal_release_are_recovered_from_the_journal() {
    let robot = robot(true);
    let (child, lines, stderr, port) = orch_run(Some(robot.to_str().unwrap()));
    let events = peer(
        port,
        json!({"name": "lossy", "steps": [
            {"send": [[0, [0x90, 60, 100]]]},
            {"send": [[0, [0x90, 64, 100]]]},
            {"send": [[0, [0x80, 60, 0]]], "drop": true},
            {"sleep_ms": 200},
            {"send": [[0, [0x90, 72, 90]]]},
            {"sleep_ms": 100},
            {"send": [[0, [0xB0, 64, 127]]]},
            {"send": [[0, [0x80, 64, 0]]]},
            {"send": [[0, [0xB0, 64, 0]]], "drop": true},
            {"sleep_ms": 200},
            {"send": [[0, [0x80, 72, 0]]]},
            {"sleep_ms": 300}
        ]}),
    );
    let sent: Vec<u64> = events
        .iter()
        .filter(|e| e["event"] == "sent")
        .map(|e| e["seq"].as_u64().unwrap())
        .collect();
    let rs: Vec<u64> = events
        .iter()
        .filter(|e| e["event"] == "rs")
        .map(|e| e["seq"].as_u64().unwrap())
        .collect();
    assert_eq!(
        rs.last(),
        sent.last(),
        "feedback on the last packet: {events:?}"
    );
    let ws = writes(&lines);
    let b22: Vec<(Option<u64>, u64)> = ws
        .iter()
        .filter(|w| w.address == 0x22)
        .map(|w| (w.byte, w.outputs))
        .collect();
    let (c4, e4, c5) = (1u64 << 8, 1u64 << 12, 1u64 << 20 >> 16);
    let outs: Vec<u64> = b22.iter().map(|w| w.1).collect();
    // C4, C4+E4; the journal: C4 up; E4's Note-Off held by the pedal; the journal: pedal up.
    assert_eq!(outs, [c4, c4 | e4, e4, 0], "{ws:?}");
    assert!(
        b22.iter().all(|w| w.0.is_some()),
        "every write by a byte: {ws:?}"
    );
    let c5_writes: Vec<u64> = ws
        .iter()
        .filter(|w| w.address == 0x23)
        .map(|w| w.outputs)
        .collect();
    assert_eq!(c5_writes, [c5, 0], "{ws:?}");
    let t = |n: usize| ws.iter().filter(|w| w.address == 0x22).nth(n).unwrap().t_us;
    assert!(t(2) - t(1) >= 150_000 && t(2) - t(1) < 1_000_000, "{ws:?}");
    let err = stderr.lock().unwrap().clone();
    assert!(err.contains("session with `lossy`"), "{err}");
    stop(child, &lines);
    let _ = std::fs::remove_file(robot);
}

/// A sender with no journal (as pymidi would be, had it a sender): a lost Note-Off leaves
/// the key down until the watchdog (4 s without a byte) releases every key; orch goes on.
#[test]
fn without_a_journal_a_lost_note_off_is_released_by_the_watchdog() {
    let (child, lines, _stderr, port) = orch_run(None);
    peer(
        port,
        json!({"name": "nojournal", "journal": false, "steps": [
            {"send": [[0, [0x90, 60, 100]]]},
            {"send": [[0, [0x80, 60, 0]]], "drop": true},
            {"send": [[0, [0x90, 64, 100]]]},
            {"vanish": true}
        ], "linger_ms": 0}),
    );
    std::thread::sleep(Duration::from_millis(4_600));
    let ws = writes(&lines);
    let outs: Vec<(Option<u64>, u64)> = ws.iter().map(|w| (w.byte, w.outputs)).collect();
    assert_eq!(outs.len(), 3, "{ws:?}");
    assert_eq!(outs[2], (None, 0), "released by the watchdog: {ws:?}");
    let late = ws[2].t_us - ws[1].t_us;
    assert!((4_000_000..4_100_000).contains(&late), "{ws:?}");
    stop(child, &lines);
}

/// A peer that vanishes mid-chord without a goodbye: every key released by the watchdog,
/// orch still running; BY from the next peer releases its keys at once; and a third peer
/// plays again.
#[test]
fn a_vanished_peer_is_released_by_the_watchdog_and_bye_releases_at_once() {
    let (child, lines, stderr, port) = orch_run(None);
    peer(
        port,
        json!({"name": "ghost", "steps": [
            {"send": [[0, [0x90, 36, 100]], [0, [0x90, 60, 100]], [0, [0x90, 90, 100]]]},
            {"vanish": true}
        ], "linger_ms": 0}),
    );
    std::thread::sleep(Duration::from_millis(4_500));
    let ws = writes(&lines);
    assert_eq!(ws.len(), 6, "{ws:?}");
    for w in &ws[3..] {
        assert_eq!((w.byte, w.outputs), (None, 0), "{ws:?}");
        assert!(w.t_us >= 4_000_000 && w.t_us < 4_100_000, "{ws:?}");
    }
    peer(
        port,
        json!({"name": "polite", "steps": [
            {"send": [[0, [0x90, 62, 100]], [0, [0x90, 65, 100]]]},
            {"sleep_ms": 100},
            {"bye": true}
        ], "linger_ms": 100}),
    );
    wait_for("`polite`", &stderr);
    wait_for("every key released", &stderr);
    std::thread::sleep(Duration::from_millis(50));
    let ws = writes(&lines);
    assert_eq!(ws.len(), 9, "{ws:?}");
    assert_eq!((ws[8].byte, ws[8].outputs), (None, 0), "{ws:?}");
    let after_bye = ws[8].t_us - ws[7].t_us;
    assert!(
        (90_000..1_000_000).contains(&after_bye),
        "released on BY: {ws:?}"
    );
    peer(
        port,
        json!({"name": "third", "steps": [{"send": [[0, [0x90, 67, 100]]]}], "linger_ms": 100}),
    );
    std::thread::sleep(Duration::from_millis(100));
    assert_eq!(writes(&lines).len(), 10);
    stop(child, &lines);
}

/// `orch play --out rtpmidi:` into pymidi's server: it takes the invitations and the clock
/// sync, parses every packet (journal included), and gets the same notes and controllers,
/// in the same order, as a `--out udp:` of the same performance; then orch's goodbye.
#[test]
fn orch_play_into_pymidis_server_sends_what_udp_sends() {
    pymidi();
    let mut server = Command::new("python3")
        .arg(SERVER)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (lines, _) = collect_lines(server.stdout.take().unwrap());
    let t0 = Instant::now();
    let port = loop {
        if let Some(p) = lines.lock().unwrap().first().map(|l| l.1["port"].as_u64()) {
            break p.unwrap();
        }
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "pymidi's server never listened"
        );
        std::thread::sleep(Duration::from_millis(10));
    };
    let song = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/ode-to-joy.mid");
    let play = |out: &str| {
        let s = orch()
            .args(["play", song, "--tempo", "8", "--no-view", "--out", out])
            .output()
            .unwrap();
        assert!(s.status.success(), "{}", String::from_utf8_lossy(&s.stderr));
    };
    let udp = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    udp.set_read_timeout(Some(Duration::from_millis(500)))
        .unwrap();
    play(&format!("udp:{}", udp.local_addr().unwrap()));
    let mut want = Vec::new();
    let mut buf = [0u8; 64];
    while let Ok(n) = udp.recv(&mut buf) {
        let m = &buf[..n];
        match m[0] & 0xF0 {
            0x90 if m[2] > 0 => want.push(("on", m[0] & 0x0F, m[1])),
            0x80 | 0x90 => want.push(("off", m[0] & 0x0F, m[1])),
            0xB0 => want.push(("cc", m[0] & 0x0F, m[1])),
            _ => {}
        }
    }
    play(&format!("rtpmidi:127.0.0.1:{port}"));
    std::thread::sleep(Duration::from_millis(300));
    let _ = server.kill();
    let _ = server.wait();
    let events: Vec<Value> = lines.lock().unwrap().iter().map(|l| l.1.clone()).collect();
    let got: Vec<(&str, u8, u8)> = events
        .iter()
        .filter_map(|e| {
            let ch = e["channel"].as_u64()? as u8;
            match e["event"].as_str()? {
                "note_on" if e["velocity"].as_u64()? > 0 => {
                    Some(("on", ch, e["key"].as_u64()? as u8))
                }
                "note_on" | "note_off" => Some(("off", ch, e["key"].as_u64()? as u8)),
                "cc" => Some(("cc", ch, e["controller"].as_u64()? as u8)),
                _ => None,
            }
        })
        .collect();
    assert!(want.len() > 100, "{}", want.len());
    assert_eq!(got, want);
    let kinds: Vec<&str> = events.iter().filter_map(|e| e["event"].as_str()).collect();
    assert_eq!(kinds.get(1), Some(&"connected"), "{kinds:?}");
    assert_eq!(
        kinds.last(),
        Some(&"disconnected"),
        "orch's goodbye: {kinds:?}"
    );
}
