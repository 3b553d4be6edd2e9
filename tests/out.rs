//! `orch play --out`: the real outputs, end to end through the `orch` program, on kernel
//! objects instead of hardware (a pseudo-terminal for the UART, a file for raw MIDI, UDP on
//! loopback). Every byte the far end reads is what `orch play` planned; SIGTERM during a
//! chord lets go of every key on every output before `orch` exits.

use std::io::Read;
use std::net::UdpSocket;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use orch_perform::{song_events, Link, MidiRecording, Performer, Tempo};
use orch_seq::Song;
use serde_json::Value;

/// A one-track SMF, 480 ticks a quarter at 120 bpm (a tick is 1/960 s): each entry is
/// (delta ticks, message).
fn smf(events: &[(u32, &[u8])]) -> Vec<u8> {
    testkit::smf::one_track(events)
}

/// A short piece on two channels: a scale, repeated notes, chords, about 2.5 s.
fn piece() -> Vec<u8> {
    let mut ev: Vec<(u32, Vec<u8>)> = Vec::new();
    for (i, n) in [60u8, 62, 64, 65, 67, 69, 71, 72].iter().enumerate() {
        ev.push((if i == 0 { 240 } else { 0 }, vec![0x90, *n, 90]));
        ev.push((0, vec![0x91, n - 12, 90]));
        ev.push((120, vec![0x80, *n, 0]));
        ev.push((0, vec![0x81, n - 12, 0]));
    }
    for _ in 0..4 {
        ev.push((0, vec![0x90, 67, 80]));
        ev.push((100, vec![0x80, 67, 0]));
    }
    for chord in [[48u8, 52, 55, 60, 64], [50, 53, 57, 62, 65]] {
        for (i, n) in chord.iter().enumerate() {
            ev.push((if i == 0 { 60 } else { 0 }, vec![0x90, *n, 100]));
        }
        for (i, n) in chord.iter().enumerate() {
            ev.push((if i == 0 { 400 } else { 0 }, vec![0x80, *n, 0]));
        }
    }
    let refs: Vec<(u32, &[u8])> = ev.iter().map(|(d, m)| (*d, m.as_slice())).collect();
    smf(&refs)
}

/// C4 E4 G4 C5 from 0.25 s, held 20 s.
fn long_chord() -> Vec<u8> {
    smf(&[
        (240, &[0x90, 60, 100]),
        (0, &[0x90, 64, 100]),
        (0, &[0x90, 67, 100]),
        (0, &[0x90, 72, 100]),
        (19_200, &[0x80, 60, 0]),
        (0, &[0x80, 64, 0]),
        (0, &[0x80, 67, 0]),
        (0, &[0x80, 72, 0]),
    ])
}

fn temp(name: &str) -> PathBuf {
    testkit::in_test(name)
}

/// What `orch play` plans for `file` on `link`: every byte, in order.
fn planned(file: &[u8], link: Link) -> Vec<u8> {
    let song = Song::parse(file).unwrap();
    let robot = orch_stage::load_robot(None).unwrap();
    let setup = orch_stage::setup::setup(&robot, true, Tempo::NORMAL).with_link(link);
    let mut rec = MidiRecording::default();
    Performer::new(&setup, song_events(&song), song.notes())
        .midi(&mut rec)
        .run()
        .unwrap();
    rec.sent.into_iter().flat_map(|s| s.1).collect()
}

/// What the far end read: (arrival, bytes) chunks.
type Chunks = Arc<Mutex<Vec<(Instant, Vec<u8>)>>>;

/// A pseudo-terminal pair: the far end is read on a thread into chunks.
struct Pty {
    path: String,
    got: Chunks,
    _slave: std::fs::File,
}

/// A pseudo-terminal pair whose descriptors no child inherits (tests run in parallel and
/// spawn `orch`: a master inherited by another test's child would outlive its closing): the
/// master, the slave's path and the slave held open (a master reads EIO while no slave is
/// open).
fn pty_pair() -> (nix::pty::PtyMaster, String, std::fs::File) {
    use nix::fcntl::OFlag;
    use std::os::unix::fs::OpenOptionsExt;
    let master =
        nix::pty::posix_openpt(OFlag::O_RDWR | OFlag::O_NOCTTY | OFlag::O_CLOEXEC).unwrap();
    nix::pty::grantpt(&master).unwrap();
    nix::pty::unlockpt(&master).unwrap();
    let path = nix::pty::ptsname_r(&master).unwrap();
    // std opens with O_CLOEXEC.
    let slave = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(nix::libc::O_NOCTTY)
        .open(&path)
        .unwrap();
    (master, path, slave)
}

fn pty() -> Pty {
    let (master, path, slave) = pty_pair();
    let got = Arc::new(Mutex::new(Vec::new()));
    let sink = Arc::clone(&got);
    let mut master = master;
    std::thread::spawn(move || {
        let mut buf = [0u8; 4096];
        // Ends with EIO when every slave descriptor is closed.
        while let Ok(n) = master.read(&mut buf) {
            if n == 0 {
                break;
            }
            sink.lock()
                .unwrap()
                .push((Instant::now(), buf[..n].to_vec()));
        }
    });
    Pty {
        path,
        got,
        _slave: slave,
    }
}

fn bytes_of(chunks: &Mutex<Vec<(Instant, Vec<u8>)>>) -> Vec<u8> {
    chunks
        .lock()
        .unwrap()
        .iter()
        .flat_map(|c| c.1.clone())
        .collect()
}

fn all_notes_off() -> Vec<u8> {
    (0..16u8).flat_map(|c| [0xB0 | c, 123, 0]).collect()
}

#[test]
fn serial_to_a_pty_writes_exactly_the_planned_bytes_at_their_time() {
    let file = temp("piece.mid");
    std::fs::write(&file, piece()).unwrap();
    let want = planned(&piece(), Link::Din);
    let far = pty();
    let start = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_orch"))
        .args([
            "play",
            file.to_str().unwrap(),
            "--json",
            "--no-view",
            "--out",
        ])
        .arg(format!("serial:{}", far.path))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    std::thread::sleep(Duration::from_millis(200));
    let got = bytes_of(&far.got);
    assert_eq!(got.len(), want.len(), "bytes read at the far end");
    assert!(
        got == want,
        "the far end read other bytes than were planned"
    );
    assert!(got.ends_with(&all_notes_off()));
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["out"], format!("serial:{}", far.path));
    assert_eq!(report["link"]["bytes"], want.len() as u64);
    assert_eq!(report["link"]["lost"], 0);
    assert_eq!(report["notes"], 30);
    assert_eq!(report["unmatched"], 0);
    // The figures: how fast the bytes came, in the busiest 10 ms and overall.
    let chunks = far.got.lock().unwrap().clone();
    let t = |i: Instant| i.duration_since(start).as_secs_f64();
    let (first, last) = (t(chunks[0].0), t(chunks.last().unwrap().0));
    let mut peak = 0;
    for (i, c) in chunks.iter().enumerate() {
        let n: usize = chunks[i..]
            .iter()
            .take_while(|d| d.0.duration_since(c.0) < Duration::from_millis(10))
            .map(|d| d.1.len())
            .sum();
        peak = peak.max(n);
    }
    // Written at the wire's pace: a DIN line carries 31.25 bytes in 10 ms (one write of up to
    // 3 bytes goes at once, and the reader's timestamps can bunch a little). Unpaced, the
    // closing All Notes Off alone is 48 bytes at once.
    assert!(
        peak <= 40,
        "{peak} bytes within 10 ms: faster than the wire"
    );
    eprintln!(
        "serial to a pty: {} bytes in {} reads over {:.3} s: {:.0} bytes/s on average, at most \
         {} bytes in 10 ms ({:.0} bytes/s; a DIN line carries 3125 bytes/s)",
        got.len(),
        chunks.len(),
        last - first,
        got.len() as f64 / (last - first),
        peak,
        peak as f64 * 100.0
    );
}

#[test]
fn sigterm_during_a_chord_releases_every_key_on_every_output_before_exit() {
    let file = temp("chord.mid");
    std::fs::write(&file, long_chord()).unwrap();
    let raw = temp("raw.bin");
    std::fs::write(&raw, b"").unwrap();
    let udp = UdpSocket::bind("127.0.0.1:0").unwrap();
    udp.set_read_timeout(Some(Duration::from_millis(300)))
        .unwrap();
    let far = pty();
    let child = Command::new(env!("CARGO_BIN_EXE_orch"))
        .args(["play", file.to_str().unwrap(), "--json", "--no-view"])
        .arg("--out")
        .arg(format!("serial:{}", far.path))
        .arg("--out")
        .arg(format!("rawmidi:{}", raw.display()))
        .arg("--out")
        .arg(format!("udp:{}:ch=1", udp.local_addr().unwrap()))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until every output has the chord down.
    let chord_down = |b: &[u8]| b.windows(2).filter(|w| w[1] == 100).count() >= 4;
    let t0 = Instant::now();
    while !(chord_down(&bytes_of(&far.got)) && chord_down(&std::fs::read(&raw).unwrap())) {
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "the chord never came"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(300));
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGTERM,
    )
    .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        t0.elapsed() < Duration::from_secs(5),
        "stopped long before the chord's end"
    );
    std::thread::sleep(Duration::from_millis(200));
    // Every MIDI output: the chord struck, never let go note by note, then All Notes Off on
    // every channel, last.
    let mut datagrams = Vec::new();
    let mut buf = [0u8; 64];
    while let Ok(n) = udp.recv(&mut buf) {
        datagrams.extend_from_slice(&buf[..n]);
    }
    for (name, bytes) in [
        ("serial", bytes_of(&far.got)),
        ("rawmidi", std::fs::read(&raw).unwrap()),
        ("udp", datagrams),
    ] {
        assert!(chord_down(&bytes), "{name}: {bytes:02x?}");
        assert!(
            bytes.ends_with(&all_notes_off()),
            "{name}: no All Notes Off at the end: {bytes:02x?}"
        );
        assert!(
            !bytes.contains(&0x80),
            "{name}: a Note-Off came before the stop: {bytes:02x?}"
        );
    }
    // The reports: three robots, the chord struck on each, stopped early with nothing held.
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    let robots = report["robots"].as_array().unwrap();
    assert_eq!(robots.len(), 3);
    for r in robots {
        assert_eq!(r["notes"], 4, "{r}");
        assert_eq!(r["strikes"], 4, "{r}");
        assert!(r["seconds"].as_f64().unwrap() < 5.0, "{r}");
        assert_eq!(r["link"]["lost"], 0, "{r}");
    }
}

#[test]
fn bad_outs_are_refused_with_exit_2() {
    let file = temp("short.mid");
    std::fs::write(&file, piece()).unwrap();
    for (args, why) in [
        (vec!["--out", "tcp:x"], "unknown output kind"),
        (vec!["--out", "udp:nohost"], "HOST:PORT"),
        (vec!["--out", "serial:/dev/x:ch=17"], "1 to 16"),
        (
            vec!["--out", "serial:/nonexistent/tty"],
            "cannot open serial port",
        ),
        (
            vec!["--out", "rawmidi:/nonexistent/midi"],
            "cannot open /nonexistent/midi",
        ),
        (vec!["--fast", "--out", "udp:127.0.0.1:9"], "--fast"),
        (
            vec!["--out", "i2c:/nonexistent/i2c-9"],
            "cannot open /nonexistent/i2c-9",
        ),
        #[cfg(not(feature = "alsa"))]
        (vec!["--out", "alsa:128:0"], "the `alsa` feature"),
        #[cfg(feature = "alsa")]
        (
            vec!["--out", "alsa:no such client:0"],
            "cannot open ALSA sequencer port",
        ),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_orch"))
            .args(["play", file.to_str().unwrap(), "--no-view"])
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(why), "{args:?}: {err}");
    }
}

#[test]
fn i2c_on_something_that_is_not_a_bus_is_refused_with_exit_2() {
    // A regular file is no I2C adapter: the kernel refuses the adapter's ioctl at once.
    let file = temp("i2c.mid");
    std::fs::write(&file, piece()).unwrap();
    let bus = temp("not-a-bus");
    std::fs::write(&bus, b"").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_orch"))
        .args(["play", file.to_str().unwrap(), "--no-view", "--out"])
        .arg(format!("i2c:{}", bus.display()))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("cannot open") && err.contains("i2c:"), "{err}");
}

#[test]
fn a_serial_device_that_disappears_mid_piece_is_reported_and_the_piece_plays_on() {
    let file = temp("gone.mid");
    std::fs::write(&file, piece()).unwrap();
    let (mut master, path, slave) = pty_pair();
    // The far end reads the first bytes, then goes away (its master side closed): writes to
    // the line fail from then on.
    let far = std::thread::spawn(move || {
        let mut buf = [0u8; 64];
        let mut n = 0;
        while n < 20 {
            n += master.read(&mut buf).unwrap();
        }
        drop(master);
        n
    });
    let t0 = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_orch"))
        .args([
            "play",
            file.to_str().unwrap(),
            "--json",
            "--no-view",
            "--out",
        ])
        .arg(format!("serial:{path}"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(t0.elapsed() < Duration::from_secs(10), "no hang");
    assert!(far.join().unwrap() >= 20);
    assert!(err.contains("the MIDI output is gone"), "{err}");
    assert!(err.contains("went away 1 times"), "{err}");
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["link"]["lost"], 1, "{report}");
    assert!(report["link"]["dropped_bytes"].as_u64().unwrap() > 0);
    // The virtual copy played the whole piece.
    assert_eq!(report["notes"], 30);
    assert_eq!(report["unmatched"], 0);
    drop(slave);
}

#[test]
fn a_serial_device_that_comes_back_gets_all_notes_off_first_and_plays_on() {
    // The device path is a link (as udev makes /dev/serial/by-id/… links); the line behind it
    // goes away mid-piece and another takes its place, as an unplugged adapter plugged back.
    let file = temp("back.mid");
    std::fs::write(&file, piece()).unwrap();
    let link = temp("ttyMIDI");
    let _ = std::fs::remove_file(&link);
    let (mut first, first_path, first_slave) = pty_pair();
    std::os::unix::fs::symlink(&first_path, &link).unwrap();
    let child = Command::new(env!("CARGO_BIN_EXE_orch"))
        .args([
            "play",
            file.to_str().unwrap(),
            "--json",
            "--no-view",
            "--out",
        ])
        .arg(format!("serial:{}", link.display()))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut buf = [0u8; 64];
    let mut n = 0;
    while n < 20 {
        n += first.read(&mut buf).unwrap();
    }
    drop(first);
    let second = pty();
    std::fs::remove_file(&link).unwrap();
    std::os::unix::fs::symlink(&second.path, &link).unwrap();
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("the MIDI output is back"), "{err}");
    std::thread::sleep(Duration::from_millis(200));
    let got = bytes_of(&second.got);
    let off = all_notes_off();
    assert!(got.len() > 2 * off.len(), "{got:02x?}");
    assert_eq!(
        &got[..off.len()],
        &off[..],
        "All Notes Off first: {got:02x?}"
    );
    assert!(got[off.len()] >= 0x80, "then a status byte: {got:02x?}");
    assert!(got.ends_with(&off));
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["link"]["lost"], 1, "{report}");
    assert_eq!(report["link"]["reconnected"], 1, "{report}");
    drop(first_slave);
}
