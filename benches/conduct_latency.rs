//! Real-clock latency of `orch conduct`: from the moment a conductor's beat is written on a
//! real socket to the moment the performer sends a message that beat retimed.
//!
//! `orch conduct` (the binary given as the first argument) plays a piece of quarter notes
//! written at 240 BPM (one every 250 ms) with `--source osc:PORT --follow immediate`, its
//! only output `--out udp:127.0.0.1:PORT2`: every MIDI message it sends arrives as a datagram
//! here, stamped on arrival. The piece steadies at its written tempo; then, 15 to 25 ms (spread
//! over the samples) before a press is due, this program writes an OSC `/orch/beat 4800.0` (a
//! beat stating twenty times the tempo) on the source's UDP socket. At twenty times the tempo
//! that press is due at once, so the time from writing the beat to that press's arrival here
//! is the whole path: the source's thread reading and decoding the packet, the follower, the
//! performance's control ringing its bell, the performer waking on it (no poll), its
//! replanning and its send, and the loopback datagram (tens of µs). A `/orch/beat 240.0` then
//! puts the written tempo back and the next sample waits for the tempo to steady.
//!
//! With `busy`, a thread spinning on every core (as many as the machine has) competes with
//! `orch conduct` for the whole run. The bench's own two threads (writing the beats, stamping
//! the presses) ask for real-time priority as orch's sender and its OSC source do, so that
//! the figure is orch's, not the bench's wait for a core.
//!
//! ```sh
//! cargo build --release --bin orch
//! cargo bench --bench conduct_latency -- target/release/orch [SAMPLES] [busy]
//! ```
//!
//! Prints the median, 99th percentile and largest latency over the samples (40 by default).

#[path = "../tests/support/mod.rs"]
mod support;

use std::net::UdpSocket;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use orch_perform::conduct::{encode_osc, OscArg};

/// The piece's beat, ms (240 BPM).
const BEAT_MS: u64 = 250;
/// How long before a due press the beat is written: 15 ms and up to 10 ms more, spread
/// evenly over the samples (so that no one phase of the performer's waits is measured alone).
const AHEAD_US: u64 = 15_000;
const SPREAD_US: u64 = 10_000;

/// A free UDP port on 127.0.0.1.
fn free_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .map(|a| a.port())
        .expect("a free UDP port")
}

/// Kills the child on the way out, however this ends.
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1000.0
}

fn main() {
    // `cargo bench` adds `--bench`.
    let mut args = std::env::args().skip(1).filter(|a| a != "--bench");
    let orch = args
        .next()
        .expect("usage: conduct_latency PATH/TO/orch [SAMPLES]");
    let samples: usize = args.next().map_or(40, |s| s.parse().expect("SAMPLES"));
    let busy = args.next().is_some_and(|a| a == "busy");
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let cores = if busy {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        0
    };
    for _ in 0..cores {
        let stop = std::sync::Arc::clone(&stop);
        std::thread::spawn(move || {
            let mut x = 0u64;
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
            }
        });
    }
    let dir = std::env::temp_dir().join(format!("orch-conduct-latency-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a scratch folder");
    let file = dir.join("quarters-240.mid");
    // Each sample takes about six beats; room for all of them, twice over.
    std::fs::write(
        &file,
        support::quarters_smf(samples as u32 * 12 + 40, 60_000.0 / BEAT_MS as f64),
    )
    .expect("the piece written");

    let sink = UdpSocket::bind("127.0.0.1:0").expect("a UDP socket for the output");
    let out = sink.local_addr().expect("its address");
    let (tx, arrivals) = mpsc::channel();
    // The bench's own threads (this one writes the beats, that one stamps the presses) at
    // real-time priority where allowed, as orch's are: the busy threads delay neither.
    std::thread::spawn(move || {
        orch_perform::realtime::raise_priority();
        support::note_on_arrivals(sink, tx)
    });
    orch_perform::realtime::raise_priority();
    let osc_port = free_port();
    let _child = Killed(
        Command::new(&orch)
            .arg("conduct")
            .arg(&file)
            .args(["--source", &format!("osc:{osc_port}")])
            .args(["--follow", "immediate", "--no-view", "--json"])
            .args(["--out", &format!("udp:{out}")])
            .stdout(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("{orch}: {e}")),
    );
    let source = UdpSocket::bind("127.0.0.1:0").expect("a UDP socket for the beats");
    let beat = |bpm: f32| encode_osc("/orch/beat", &[OscArg::Float(bpm)]);
    let (fast, written) = (beat(240.0 * 20.0), beat(240.0));

    let beat_len = Duration::from_millis(BEAT_MS);
    let next = |within: Duration| {
        arrivals
            .recv_timeout(within)
            .expect("orch conduct stopped sending")
    };
    let mut latency = Vec::new();
    while latency.len() < samples {
        // Three presses a beat apart (±3 ms): the written tempo, steady.
        let mut last = next(Duration::from_secs(5));
        let mut steady = 0;
        while steady < 3 {
            let a = next(Duration::from_secs(5));
            let gap = ms(a - last);
            steady = if (gap - BEAT_MS as f64).abs() <= 3.0 {
                steady + 1
            } else {
                0
            };
            last = a;
        }
        let due = last + beat_len;
        let ahead = AHEAD_US + (latency.len() as u64 * 3_137) % SPREAD_US;
        std::thread::sleep(
            (due - Duration::from_micros(ahead)).saturating_duration_since(Instant::now()),
        );
        let written_at = Instant::now();
        source
            .send_to(&fast, ("127.0.0.1", osc_port))
            .expect("the beat sent");
        let arrived = next(Duration::from_secs(2));
        source
            .send_to(&written, ("127.0.0.1", osc_port))
            .expect("the tempo put back");
        if arrived < written_at {
            continue; // a press already on its way: not one the beat retimed
        }
        latency.push(ms(arrived - written_at));
        // Let the fast presses and the change back go by.
        std::thread::sleep(Duration::from_millis(600));
        while arrivals.try_recv().is_ok() {}
    }
    latency.sort_by(f64::total_cmp);
    let rank =
        |p: f64| latency[((p * latency.len() as f64).ceil() as usize).clamp(1, latency.len()) - 1];
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    println!(
        "OSC /orch/beat written on a UDP socket -> the press it retimed sent by orch conduct \
         (arriving on a UDP socket, same host), {}, {} samples: median {:.2} ms, p99 {:.2} ms, \
         max {:.2} ms",
        if busy {
            format!("a busy thread on each of {cores} cores")
        } else {
            "idle".to_string()
        },
        latency.len(),
        rank(0.5),
        rank(0.99),
        latency[latency.len() - 1]
    );
    let _ = std::fs::remove_dir_all(&dir);
}
