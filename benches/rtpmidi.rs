//! RTP-MIDI into `orch run` on loopback: the figures of the README's benchmark section.
//!
//! 1. **Packet in → board write**: 1000 RTP-MIDI packets of one note message each, 4 ms
//!    apart, into `orch run --in rtpmidi:… --out sim --json` (a session begun as a Mac
//!    would: invitations on both ports, clock sync); from each packet's `send` until its
//!    board write is read from orch's standard output (the JSON line printed and piped: an
//!    upper bound), median, p99 and max.
//! 2. **A lost Note-Off's time to release**: 200 times, a Note-On, then its Note-Off's packet
//!    dropped, then 5 ms later the next packet (another note) with its recovery journal: from
//!    the lost Note-Off's due time, and from the next packet's send, until the key's release
//!    is read from orch's output. Without a journal the key would wait for the watchdog (4 s).
//!
//! `cargo bench --bench rtpmidi`. Not a test: it prints.

#[path = "../tests/support/mod.rs"]
mod support;

use std::io::{BufRead, BufReader};
use std::net::{SocketAddr, UdpSocket};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use orch_io::rtp::control::{self, Control, Exchange};
use orch_io::rtp::sender::Sender;

const ORCH: &str = env!("CARGO_BIN_EXE_orch");

/// The peer: its two sockets, orch's two ports, its stream.
struct Peer {
    data: UdpSocket,
    to: SocketAddr,
    sender: Sender,
    origin: Instant,
}

impl Peer {
    fn join(port: u16) -> Peer {
        let ctl = UdpSocket::bind("127.0.0.1:0").unwrap();
        let data = UdpSocket::bind("127.0.0.1:0").unwrap();
        let ex = Exchange {
            version: 2,
            token: 7,
            ssrc: 0xB0B,
            name: "bench".into(),
        };
        for (s, p) in [(&ctl, port), (&data, port + 1)] {
            s.send_to(
                &control::write(&Control::Invite(ex.clone())),
                ("127.0.0.1", p),
            )
            .unwrap();
            s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
            let mut buf = [0u8; 256];
            let n = s.recv(&mut buf).unwrap();
            assert!(matches!(control::parse(&buf[..n]), Ok(Control::Accept(_))));
        }
        let to: SocketAddr = ([127, 0, 0, 1], port + 1).into();
        let ck0 = Control::Sync {
            ssrc: 0xB0B,
            count: 0,
            stamps: [1, 0, 0],
        };
        data.send_to(&control::write(&ck0), to).unwrap();
        let mut buf = [0u8; 256];
        let n = data.recv(&mut buf).unwrap();
        assert!(matches!(
            control::parse(&buf[..n]),
            Ok(Control::Sync { count: 1, .. })
        ));
        // orch's feedback goes to the control socket; left unread here (it only trims).
        std::mem::forget(ctl);
        Peer {
            data,
            to,
            sender: Sender::new(0xB0B, 1000),
            origin: Instant::now(),
        }
    }

    /// Sends one message (or, `drop`, only counts it in the journal); when.
    fn send(&mut self, m: &[u8], drop: bool) -> Instant {
        let ts = (self.origin.elapsed().as_micros() / 100) as u32;
        let p = self.sender.packet(ts, &[(0, m)]);
        let at = Instant::now();
        if !drop {
            self.data.send_to(&p, self.to).unwrap();
        }
        at
    }
}

fn percentiles(mut v: Vec<f64>) -> (f64, f64, f64) {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.99), v[v.len() - 1])
}

fn main() {
    let mut child = Command::new(ORCH)
        .args([
            "run",
            "--in",
            "rtpmidi:bench@0",
            "--out",
            "sim",
            "--json",
            "--no-view",
            "--verbose",
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (text, ready) = support::collect_stderr(&mut child);
    ready
        .recv_timeout(Duration::from_secs(20))
        .expect("orch run never said it reads");
    std::thread::sleep(Duration::from_millis(50));
    let port: u16 = text
        .lock()
        .unwrap()
        .split("on 0.0.0.0:")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|p| p.parse().ok())
        .expect("orch's port");
    // Each board write's byte index, stamped when read.
    let (tx, writes) = mpsc::channel::<(u64, Instant)>();
    let out = child.stdout.take().unwrap();
    std::thread::spawn(move || {
        orch_perform::realtime::raise_priority();
        for line in BufReader::new(out).lines() {
            let Ok(line) = line else { return };
            let v: serde_json::Value = serde_json::from_str(&line).unwrap();
            if let Some(b) = v["byte"].as_u64() {
                let _ = tx.send((b, Instant::now()));
            }
        }
    });
    orch_perform::realtime::raise_priority();
    let mut peer = Peer::join(port);
    let pace = |i: u32, start: Instant, every: Duration| {
        let due = start + every * i;
        if let Some(d) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(d);
        }
    };

    // 1. One message a packet: byte index 3k + 2 is packet k's write.
    let n = 1000u32;
    let start = Instant::now();
    let mut sent = Vec::new();
    for k in 0..n {
        pace(k, start, Duration::from_millis(4));
        let key = 36 + (k / 2 % 61) as u8;
        let m = if k % 2 == 0 {
            [0x90, key, 100]
        } else {
            [0x80, key, 0]
        };
        sent.push(peer.send(&m, false));
    }
    let mut latency = Vec::new();
    while latency.len() < n as usize {
        let (b, at) = writes
            .recv_timeout(Duration::from_secs(5))
            .expect("a write per packet");
        latency.push(at.duration_since(sent[(b / 3) as usize]).as_secs_f64() * 1e3);
    }
    let (m, p99, max) = percentiles(latency);
    println!(
        "RTP-MIDI packet sent -> its board write read from orch's stdout ({n} packets, 4 ms apart): \
         median {m:.3} ms, p99 {p99:.3} ms, max {max:.3} ms"
    );

    // 2. Lost Note-Offs: per trial 4 packets, 12 bytes fed (the recovered Note-Off is bytes
    //    3..6 of the trial's, after the Note-On).
    let base = 3 * u64::from(n);
    let trials = 200u32;
    let start = Instant::now();
    let mut due = Vec::new();
    let mut next = Vec::new();
    for t in 0..trials {
        let a = 36 + (2 * t % 60) as u8;
        pace(4 * t, start, Duration::from_millis(5));
        peer.send(&[0x90, a, 100], false);
        pace(4 * t + 1, start, Duration::from_millis(5));
        due.push(peer.send(&[0x80, a, 0], true));
        pace(4 * t + 2, start, Duration::from_millis(5));
        next.push(peer.send(&[0x90, a + 1, 100], false));
        pace(4 * t + 3, start, Duration::from_millis(5));
        peer.send(&[0x80, a + 1, 0], false);
    }
    let (mut from_due, mut from_next) = (Vec::new(), Vec::new());
    let mut seen = 0;
    while seen < 4 * trials {
        let (b, at) = writes
            .recv_timeout(Duration::from_secs(5))
            .expect("every write");
        seen += 1;
        let i = b - base;
        if i % 12 == 5 {
            let t = (i / 12) as usize;
            from_due.push(at.duration_since(due[t]).as_secs_f64() * 1e3);
            from_next.push(at.duration_since(next[t]).as_secs_f64() * 1e3);
        }
    }
    let (dm, dp, _) = percentiles(from_due);
    let (nm, np, _) = percentiles(from_next);
    println!(
        "a lost Note-Off ({trials} losses, the next packet 5 ms later): released {dm:.3} ms \
         (p99 {dp:.3}) after it was due, {nm:.3} ms (p99 {np:.3}) after the next packet was \
         sent; without a journal: at the watchdog, 4 s"
    );
    let _ = child.kill();
    let _ = child.wait();
}
