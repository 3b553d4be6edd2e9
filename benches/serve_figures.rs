//! `orch serve`'s figures (README, Benchmarks): `cargo bench --bench serve_figures`.
//!
//! A dense piece of the shared corpus (blupi-music005.mid: 27 003 notes in 10 minutes, 45 a
//! second, up to 14 keys at once) played on the virtual robot in real time, watched by one
//! page, then by ten (each its own headless Chromium, a phone's window), 20 s each:
//!
//! - **key down to drawn**: for each key a page draws down, the time from its Note-On being
//!   sent to the virtual robot (the note-by-note account's `sent_ms`, on the performance's
//!   clock) to the frame that drew it (`performance.timeOrigin + performance.now()` in a
//!   `requestAnimationFrame` after the page set `data-down`): median, p99, max, over every
//!   key drawn on every page. A key that went down and up between two states (at most 30 a
//!   second) is never drawn and not counted.
//! - **the server**: its CPU (user + system time over the 20 s, as a share of one core) and
//!   its memory (resident now, and its peak) from /proc.
//!
//! The browsers share the machine with the server: on 2 cores, ten Chromiums are most of the
//! load, and the figures say so.

#[path = "../tests/support/browser.rs"]
mod browser;
#[path = "../tests/support/serve.rs"]
mod serve;

use std::path::Path;
use std::time::{Duration, Instant};

use browser::{runtime, wait_for, Driver};
use serde_json::Value;
use serve::Served;

const PIECE: &str = "blupi-music005.mid";
const WATCH: Duration = Duration::from_secs(20);

/// (user + system CPU ticks, resident KiB, peak resident KiB) of a process.
fn usage(pid: u32) -> (u64, u64, u64) {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap();
    // After the command's name in parentheses: state is field 3, utime 14, stime 15.
    let rest = &stat[stat.rfind(')').unwrap() + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = f[11].parse::<u64>().unwrap() + f[12].parse::<u64>().unwrap();
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let kib = |key: &str| -> u64 {
        status
            .lines()
            .find(|l| l.starts_with(key))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse().ok())
            .unwrap_or(0)
    };
    (ticks, kib("VmRSS:"), kib("VmHWM:"))
}

fn ticks_per_second() -> f64 {
    let t = nix::unistd::sysconf(nix::unistd::SysconfVar::CLK_TCK)
        .ok()
        .flatten()
        .unwrap_or(100);
    t as f64
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i]
}

/// One round: `viewers` pages watch the piece for [`WATCH`]; the latencies, and the server's
/// CPU share and memory.
fn round(s: &Served, driver: &Driver, song: u64, viewers: usize) -> (Vec<f64>, f64, u64, u64) {
    runtime().block_on(async {
        let mut pages = Vec::new();
        for _ in 0..viewers {
            let c = driver.browser(390, 844).await;
            c.goto(&s.url).await.unwrap();
            wait_for(
                &c,
                "the keys drawn",
                "return document.querySelector('[data-testid=\"key-60\"]') !== null;",
            )
            .await;
            pages.push(c);
        }
        let (status, body) = s.command(&format!(r#"{{"cmd":"play","song":{song}}}"#));
        assert_eq!(status, 200, "{body}");
        let (t0, _, _) = usage(s.pid());
        let wall = Instant::now();
        tokio::time::sleep(WATCH).await;
        let (t1, rss, peak) = usage(s.pid());
        let cpu = (t1 - t0) as f64 / ticks_per_second() / wall.elapsed().as_secs_f64();
        let (status, body) = s.command(r#"{"cmd":"stop"}"#);
        assert_eq!(status, 200, "{body}");
        let ended = s.get_json("/api/ended");
        let low = s.get_json("/api/state")["keyboard"]["low"]
            .as_u64()
            .unwrap();
        let zero = ended["origin_ms"].as_f64().unwrap() + ended["start_ms"].as_f64().unwrap();
        // Each key's Note-On times, on the epoch's clock.
        let mut sent: Vec<Vec<f64>> = vec![Vec::new(); 128];
        for l in ended["account"].as_array().unwrap() {
            if let (Some(k), Some(t)) = (l["key"].as_u64(), l["sent_ms"].as_f64()) {
                sent[(low + k) as usize].push(zero + t);
            }
        }
        for s in &mut sent {
            s.sort_by(|a, b| a.partial_cmp(b).unwrap());
        }
        let mut lat = Vec::new();
        for c in pages {
            let log = c
                .execute("return window.orchKeyLog;", vec![])
                .await
                .unwrap();
            for e in log.as_array().unwrap() {
                if e["down"] != Value::Bool(true) {
                    continue;
                }
                let (note, t) = (
                    e["note"].as_u64().unwrap() as usize,
                    e["t"].as_f64().unwrap(),
                );
                // The key's last Note-On sent before the page drew it down.
                if let Some(s) = sent[note].iter().rev().find(|s| **s <= t) {
                    lat.push(t - s);
                }
            }
            c.close().await.unwrap();
        }
        lat.sort_by(|a, b| a.partial_cmp(b).unwrap());
        (lat, cpu, rss, peak)
    })
}

fn main() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/midi")
        .join(PIECE);
    let bytes = std::fs::read(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    let s = Served::start(&["--listen", "127.0.0.1:0"]);
    let (status, body) = s.request(
        "POST",
        &format!("/api/songs?name={PIECE}"),
        &["Content-Type: application/octet-stream"],
        &bytes,
    );
    assert_eq!(status, 200, "{body}");
    let song = serde_json::from_str::<Value>(&body).unwrap()["id"]
        .as_u64()
        .unwrap();
    let (_, idle_rss, _) = usage(s.pid());
    let driver = Driver::start();
    println!(
        "orch serve, {PIECE} on the virtual robot, {} s a round",
        WATCH.as_secs()
    );
    println!(
        "server idle with the piece loaded: {} MiB resident",
        idle_rss / 1024
    );
    println!(
        "{:>7}  {:>6}  {:>10}  {:>10}  {:>10}  {:>9}  {:>12}  {:>9}",
        "viewers", "keys", "median ms", "p99 ms", "max ms", "CPU", "resident MiB", "peak MiB"
    );
    for viewers in [1, 10] {
        let (lat, cpu, rss, peak) = round(&s, &driver, song, viewers);
        println!(
            "{viewers:>7}  {:>6}  {:>10.1}  {:>10.1}  {:>10.1}  {:>8.1}%  {:>12.1}  {:>9.1}",
            lat.len(),
            percentile(&lat, 0.5),
            percentile(&lat, 0.99),
            lat.last().copied().unwrap_or(f64::NAN),
            cpu * 100.0,
            rss as f64 / 1024.0,
            peak as f64 / 1024.0,
        );
    }
}
