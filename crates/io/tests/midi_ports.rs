//! The MIDI byte outputs on real kernel objects, no hardware: a UART through a
//! pseudo-terminal pair, raw MIDI through a FIFO, UDP on loopback. Every byte the far end
//! reads is what the performer planned; a FIFO whose reader goes away and comes back gets
//! All Notes Off first and a full status byte.

use std::io::Read;
use std::net::UdpSocket;
use std::os::fd::OwnedFd;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use orch_io::midi::all_notes_off;
use orch_io::{RawMidiOut, SerialOut, UdpOut};
use orch_perform::{song_events, Link, MidiOut, MidiRecording, Performer, Setup};
use orch_seq::Song;

fn song() -> Song {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/midi");
    Song::parse(&std::fs::read(dir.join("bach-invention-01.mid")).unwrap()).unwrap()
}

fn setup(link: Link) -> Setup {
    Setup::thesis().with_link(link)
}

/// What the performer sends for the piece, as (time, bytes) sends.
fn planned(link: Link) -> Vec<(u64, Vec<u8>)> {
    let song = song();
    let mut rec = MidiRecording::default();
    Performer::new(&setup(link), song_events(&song), song.notes())
        .midi(&mut rec)
        .run()
        .unwrap();
    rec.sent
}

/// Plays the piece into `out` on the virtual clock.
fn play<M: MidiOut>(out: &mut M, link: Link) {
    let song = song();
    let played = Performer::new(&setup(link), song_events(&song), song.notes())
        .midi(out)
        .run()
        .unwrap();
    assert!(played.report(None).adds_up());
}

/// Reads `fd` until `len` bytes came or nothing came for 2 s.
fn read_back(mut f: std::fs::File, len: usize) -> Vec<u8> {
    let mut got = Vec::new();
    let mut buf = [0u8; 4096];
    let mut last = Instant::now();
    while got.len() < len && last.elapsed() < Duration::from_secs(2) {
        match f.read(&mut buf) {
            Ok(0) => std::thread::sleep(Duration::from_millis(1)),
            Ok(n) => {
                got.extend_from_slice(&buf[..n]);
                last = Instant::now();
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(1))
            }
            Err(e) => panic!("read: {e}"),
        }
    }
    got
}

#[test]
fn serial_through_a_pseudo_terminal_at_31250_baud_carries_exactly_the_planned_bytes() {
    let pty = nix::pty::openpty(None, None).unwrap();
    let slave_path = nix::unistd::ttyname(&pty.slave).unwrap();
    let want: Vec<u8> = planned(Link::Din).into_iter().flat_map(|s| s.1).collect();
    let master: OwnedFd = pty.master;
    let reader = std::fs::File::from(master);
    let len = want.len();
    let far_end = std::thread::spawn(move || read_back(reader, len));
    let mut out = SerialOut::open(slave_path.to_str().unwrap()).expect("a pty takes 31250 baud");
    play(&mut out, Link::Din);
    let stats = out.stats();
    drop(out);
    let got = far_end.join().unwrap();
    assert_eq!(stats.bytes, want.len() as u64);
    assert_eq!(stats.lost, 0);
    assert_eq!(got.len(), want.len());
    assert!(
        got == want,
        "the far end read other bytes than were planned"
    );
    // Running status on the line (fewer bytes than sends of 3), All Notes Off on every
    // channel at the end.
    assert!(want.len() < 3 * planned(Link::Din).len());
    assert!(got.ends_with(&all_notes_off()));
    drop(pty.slave);
}

fn fifo(name: &str) -> PathBuf {
    let path = testkit::in_test(name);
    nix::unistd::mkfifo(&path, nix::sys::stat::Mode::S_IRWXU).unwrap();
    path
}

/// The read end of a FIFO, opened without waiting for a writer.
fn fifo_reader(path: &Path) -> std::fs::File {
    std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(nix::libc::O_NONBLOCK)
        .open(path)
        .unwrap()
}

#[test]
fn raw_midi_through_a_fifo_carries_exactly_the_planned_bytes() {
    let path = fifo("raw");
    let want: Vec<u8> = planned(Link::Direct)
        .into_iter()
        .flat_map(|s| s.1)
        .collect();
    let reader = fifo_reader(&path);
    let len = want.len();
    let far_end = std::thread::spawn(move || read_back(reader, len));
    let mut out = RawMidiOut::open(path.to_str().unwrap()).unwrap();
    play(&mut out, Link::Direct);
    drop(out);
    let got = far_end.join().unwrap();
    assert!(
        got == want,
        "{} bytes read, {} planned",
        got.len(),
        want.len()
    );
    assert!(got.ends_with(&all_notes_off()));
    std::fs::remove_file(&path).unwrap();
}

#[test]
fn a_raw_midi_fifo_with_no_reader_is_refused_at_once() {
    let path = fifo("noreader");
    let t = Instant::now();
    let e = RawMidiOut::open(path.to_str().unwrap()).unwrap_err();
    assert!(t.elapsed() < Duration::from_secs(1));
    assert!(e.to_string().contains("cannot open"), "{e}");
    std::fs::remove_file(&path).unwrap();
}

#[test]
fn a_raw_midi_device_that_goes_away_is_reopened_with_all_notes_off_and_a_status_byte() {
    let path = fifo("gone");
    let mut reader = fifo_reader(&path);
    let mut out = RawMidiOut::open(path.to_str().unwrap()).unwrap();
    out.send(0, &[0x90, 60, 100]).unwrap();
    out.send(1, &[62, 100]).unwrap();
    let mut buf = [0u8; 64];
    assert_eq!(reader.read(&mut buf).unwrap(), 5);
    drop(reader);
    // The reader is gone: the write fails, the output says so and plays on.
    out.send(2, &[64, 100]).unwrap();
    assert!(!out.connected());
    assert_eq!(out.stats().lost, 1);
    let mut reader = fifo_reader(&path);
    // Too soon: the backoff has not passed; the message is not sent.
    out.send(3, &[65, 100]).unwrap();
    std::thread::sleep(Duration::from_millis(120));
    out.send(4, &[67, 100]).unwrap();
    assert!(out.connected());
    let s = out.stats();
    assert_eq!((s.lost, s.reconnected, s.dropped_bytes), (1, 1, 4));
    let got = read_back_now(&mut reader);
    let mut want = all_notes_off().to_vec();
    want.extend_from_slice(&[0x90, 67, 100]);
    assert_eq!(got, want);
    // A performance that stops without finishing (a panic unwinding) lets go of every key.
    drop(out);
    assert_eq!(read_back_now(&mut reader), all_notes_off().to_vec());
    std::fs::remove_file(&path).unwrap();
}

fn read_back_now(reader: &mut std::fs::File) -> Vec<u8> {
    let mut got = Vec::new();
    let mut buf = [0u8; 256];
    loop {
        match reader.read(&mut buf) {
            Ok(0) => return got,
            Ok(n) => got.extend_from_slice(&buf[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => return got,
            Err(e) => panic!("{e}"),
        }
    }
}

#[test]
fn udp_on_loopback_sends_one_whole_message_per_datagram() {
    let rx = UdpSocket::bind("127.0.0.1:0").unwrap();
    rx.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
    let addr = rx.local_addr().unwrap();
    let plan = planned(Link::Direct);
    // Each send as a whole message: running status undone.
    let mut status = 0;
    let want: Vec<Vec<u8>> = plan
        .iter()
        .map(|(_, b)| {
            if b[0] >= 0x80 {
                if b[0] < 0xF0 {
                    status = b[0];
                }
                b.clone()
            } else {
                let mut w = vec![status];
                w.extend_from_slice(b);
                w
            }
        })
        .collect();
    assert!(want.len() < plan.iter().map(|p| p.1.len()).sum::<usize>());
    let (tx, got_rx) = mpsc::channel();
    let n = want.len();
    let far_end = std::thread::spawn(move || {
        let mut buf = [0u8; 512];
        for _ in 0..n {
            let Ok(len) = rx.recv(&mut buf) else { break };
            tx.send(buf[..len].to_vec()).unwrap();
        }
    });
    let mut out = Paced(UdpOut::open(&addr.to_string()).unwrap());
    play(&mut out, Link::Direct);
    drop(out);
    far_end.join().unwrap();
    let got: Vec<Vec<u8>> = got_rx.try_iter().collect();
    assert_eq!(got.len(), want.len(), "datagrams lost on loopback");
    assert!(got == want);
    assert!(got
        .iter()
        .rev()
        .take(16)
        .all(|d| d.len() == 3 && d[1] == 123));
}

/// An output whose sends take 100 µs of real time, as real-time play spaces them: a burst of
/// 950 datagrams at once would overrun the receiving socket's buffer (UDP drops, by design).
struct Paced<M>(M);

impl<M: MidiOut> MidiOut for Paced<M> {
    type Error = M::Error;
    fn send(&mut self, t_us: u64, bytes: &[u8]) -> Result<(), M::Error> {
        std::thread::sleep(Duration::from_micros(100));
        self.0.send(t_us, bytes)
    }
}

/// An output that panics at its `n`th send: a bug on the sender's thread.
struct PanicAt<M> {
    inner: M,
    n: usize,
}

impl<M: MidiOut> MidiOut for PanicAt<M> {
    type Error = M::Error;
    fn send(&mut self, t_us: u64, bytes: &[u8]) -> Result<(), M::Error> {
        self.n -= 1;
        assert!(self.n > 0, "a bug in the middle of the piece");
        self.inner.send(t_us, bytes)
    }
}

#[test]
fn a_panic_in_the_middle_of_a_piece_lets_go_of_every_key_as_it_unwinds() {
    let path = fifo("panic");
    let reader = fifo_reader(&path);
    let far_end = std::thread::spawn(move || read_back(reader, usize::MAX));
    let out = RawMidiOut::open(path.to_str().unwrap()).unwrap();
    let played = std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || {
        let mut out = PanicAt { inner: out, n: 200 };
        play(&mut out, Link::Direct);
    }));
    assert!(played.is_err());
    let got = far_end.join().unwrap();
    let want: Vec<u8> = planned(Link::Direct)
        .into_iter()
        .take(199)
        .flat_map(|s| s.1)
        .collect();
    assert_eq!(&got[..want.len()], &want[..]);
    assert_eq!(&got[want.len()..], &all_notes_off()[..]);
    std::fs::remove_file(&path).unwrap();
}

#[test]
fn a_serial_line_that_takes_no_bytes_is_given_up_within_the_write_timeout_not_hung_on() {
    // Nobody reads the far end: the pty's buffer fills (100 000 bytes of note data under
    // running status, more than it holds), and the write waits at most `WRITE_TIMEOUT` before
    // the line counts as gone.
    let pty = nix::pty::openpty(None, None).unwrap();
    let path = nix::unistd::ttyname(&pty.slave).unwrap();
    let mut out = SerialOut::open(path.to_str().unwrap()).unwrap();
    out.send(0, &[0x90, 60, 100]).unwrap();
    assert!(out.connected());
    let flood = [60u8, 100].repeat(50_000);
    let t = Instant::now();
    out.send(1, &flood).unwrap();
    assert!(!out.connected(), "a full line is given up");
    assert!(t.elapsed() >= orch_io::midi::WRITE_TIMEOUT);
    assert!(t.elapsed() < orch_io::midi::WRITE_TIMEOUT + Duration::from_secs(1));
    assert_eq!(out.stats().lost, 1);
    drop(pty);
}
