//! `orch serve`'s page in a real browser: Debian's headless Chromium driven through
//! chromedriver (WebDriver, by `fantoccini` over plain HTTP on loopback). `scripts/test.sh`
//! installs both (`chromium`, `chromium-driver`).
//!
//! - A corpus file uploaded: the outcome counts on the page are `orch analyze --json`'s; the
//!   roll is drawn; a malformed file shows `orch play`'s message and changes nothing else; the
//!   page on a phone-sized window (390 × 844), STOP in view however far it is scrolled (a
//!   screenshot is left in the target folder: `serve-phone-*.png`).
//! - A short file played on the virtual robot in real time: each key goes down and up on the
//!   page in the order the account says, on two browsers at once; the report at the end;
//!   the time from a key going down to the page drawing it (printed).
//! - STOP releases every key at once, on the page and on a UDP output.
//!
//! Every wait is on a condition, with a generous limit (the machine may be loaded).

#[path = "support/browser.rs"]
mod browser;
#[path = "support/serve.rs"]
mod serve;
mod support;

use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};
use testkit::Scratch;

use browser::{runtime, wait_for, Driver, PATIENCE};
use fantoccini::{Client, Locator};
use serde_json::{json, Value};
use serve::Served;

async fn testid(c: &Client, id: &str) -> fantoccini::elements::Element {
    c.find(Locator::Css(&format!("[data-testid=\"{id}\"]")))
        .await
        .unwrap_or_else(|e| panic!("[data-testid={id}]: {e}"))
}

/// Clicks `[data-testid=id]` as a person would: scrolled to the middle of the screen first
/// (WebDriver would scroll it to the top edge, under the page's fixed bar).
async fn click(c: &Client, id: &str) {
    c.execute(
        &format!(
            "document.querySelector('[data-testid=\"{id}\"]').scrollIntoView({{block: 'center'}});"
        ),
        vec![],
    )
    .await
    .unwrap();
    testid(c, id).await.click().await.unwrap();
}

/// Chooses `file` in the page's upload field, as a person picking it would.
async fn upload(c: &Client, file: &Path) {
    testid(c, "upload")
        .await
        .send_keys(file.to_str().unwrap())
        .await
        .unwrap();
}

/// The page loaded, its WebSocket's first state drawn (the keys are there).
async fn open(c: &Client, s: &Served) {
    c.goto(&s.url).await.unwrap();
    wait_for(
        c,
        "the keys drawn",
        "return document.querySelector('[data-testid=\"key-60\"]') !== null;",
    )
    .await;
}

/// The text of each `outcome-NAME` on the page, by NAME.
async fn outcomes(c: &Client) -> Value {
    c.execute(
        "const o = {}; for (const e of document.querySelectorAll('[data-testid^=\"outcome-\"]')) \
         o[e.dataset.testid.slice(8)] = Number(e.textContent); return o;",
        vec![],
    )
    .await
    .unwrap()
}

fn corpus(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/midi")
        .join(name)
        .canonicalize()
        .unwrap_or_else(|e| panic!("{name} of the shared corpus (../shared/midi): {e}"))
}

/// A scratch folder (removed when it drops) holding `bytes` as `name`, and that file.
fn scratch(name: &str, bytes: &[u8]) -> (Scratch, PathBuf) {
    let dir = Scratch::new("serve-browser");
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    (dir, path)
}

/// `orch analyze --json FILE`.
fn analyze_json(file: &Path) -> Value {
    let out = Command::new(env!("CARGO_BIN_EXE_orch"))
        .args(["analyze", "--json"])
        .arg(file)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn an_upload_is_analysed_as_orch_analyze_says_and_a_malformed_file_changes_nothing() {
    let library = corpus("bad-empty.mid").parent().unwrap().to_path_buf();
    let s = Served::start(&[
        "--listen",
        "127.0.0.1:0",
        "--library",
        library.to_str().unwrap(),
    ]);
    let driver = Driver::start();
    runtime().block_on(async {
        let c = driver.browser(390, 844).await;
        open(&c, &s).await;
        let file = corpus("freedoom2-in-cit.mid");
        upload(&c, &file).await;
        wait_for(
            &c,
            "the analysis",
            "return document.querySelector('[data-testid=\"outcome-on_time\"]') !== null \
             && document.querySelector('[data-testid=\"roll\"] svg') !== null;",
        )
        .await;
        // The counts on the page are orch analyze's.
        let want = analyze_json(&file);
        let page = outcomes(&c).await;
        let o = &want["outcomes"];
        let dropped: u64 = o["dropped"]
            .as_object()
            .unwrap()
            .values()
            .map(|v| v.as_u64().unwrap())
            .sum();
        for name in ["on_time", "late", "early", "unison", "joined", "skipped"] {
            assert_eq!(page[name], o[name], "outcome-{name}: {page} vs {want}");
        }
        assert_eq!(page["dropped"], dropped, "{page}");
        assert_eq!(page["unmatched"], want["unmatched"], "{page}");
        for (reason, n) in o["dropped"].as_object().unwrap() {
            if n.as_u64() != Some(0) {
                assert_eq!(&page[format!("dropped-{reason}")], n, "{page}");
            }
        }
        assert!(
            o["late"].as_u64().unwrap() > 0 && dropped > 0,
            "a piece with things to show"
        );
        // The notes that will go wrong, and the roll, one note a note.
        let rows = c
            .execute(
                "return document.querySelectorAll('[data-testid=\"went-wrong\"] tbody tr').length;",
                vec![],
            )
            .await
            .unwrap();
        let wrong = want["went_wrong"].as_array().unwrap().len();
        assert_eq!(rows, json!(wrong.min(50)));
        let notes = c
            .execute(
                "return document.querySelectorAll('[data-testid=\"roll\"] g.note').length;",
                vec![],
            )
            .await
            .unwrap();
        assert_eq!(notes, want["notes"]);

        // The phone: one column, nothing wider than the screen, STOP in view wherever the
        // page is scrolled, big enough for a thumb.
        let size = c
            .execute("return [window.innerWidth, window.innerHeight];", vec![])
            .await
            .unwrap();
        assert_eq!(size, json!([390, 844]));
        let png = c.screenshot().await.unwrap();
        let shot = Path::new(env!("CARGO_TARGET_TMPDIR")).join("serve-phone-top.png");
        std::fs::write(&shot, png).unwrap();
        let fits = c
            .execute(
                "return document.documentElement.scrollWidth <= window.innerWidth;",
                vec![],
            )
            .await
            .unwrap();
        assert_eq!(fits, json!(true), "the page is wider than the phone");
        for y in [
            "0",
            "document.body.scrollHeight / 2",
            "document.body.scrollHeight",
        ] {
            let seen = c
                .execute(
                    &format!(
                        "window.scrollTo(0, {y}); const r = document.querySelector(\
                         '[data-testid=\"stop\"]').getBoundingClientRect(); \
                         return [r.top >= 0 && r.bottom <= window.innerHeight && r.left >= 0 \
                         && r.right <= window.innerWidth, r.width, r.height];"
                    ),
                    vec![],
                )
                .await
                .unwrap();
            assert_eq!(
                seen[0],
                json!(true),
                "STOP out of view scrolled to {y}: {seen}"
            );
            assert!(seen[1].as_f64().unwrap() >= 88.0 && seen[2].as_f64().unwrap() >= 44.0);
        }
        c.execute(
            "document.querySelector('[data-testid=\"outcomes\"]').scrollIntoView();",
            vec![],
        )
        .await
        .unwrap();
        let png = c.screenshot().await.unwrap();
        let shot = Path::new(env!("CARGO_TARGET_TMPDIR")).join("serve-phone-analysis.png");
        std::fs::write(&shot, png).unwrap();
        eprintln!("screenshots in {}", shot.parent().unwrap().display());

        // A malformed file: orch play's message on the page; the analysis shown stays.
        let name_before = testid(&c, "song-name").await.text().await.unwrap();
        let bad = corpus("bad-header-magic.mid");
        let upload = testid(&c, "upload").await;
        upload.clear().await.unwrap();
        upload.send_keys(bad.to_str().unwrap()).await.unwrap();
        let shown = wait_for(
            &c,
            "the error",
            "const e = document.querySelector('[data-testid=\"error\"]'); \
             return !e.hidden && e.textContent;",
        )
        .await;
        let play = Command::new(env!("CARGO_BIN_EXE_orch"))
            .args(["play", "--fast"])
            .arg(&bad)
            .output()
            .unwrap();
        assert_eq!(play.status.code(), Some(2));
        let said = String::from_utf8_lossy(&play.stderr)
            .trim()
            .trim_start_matches("orch: error: ")
            .replace(bad.to_str().unwrap(), "bad-header-magic.mid");
        assert_eq!(shown, json!(said));
        assert_eq!(outcomes(&c).await, page, "the analysis shown is unchanged");
        assert_eq!(
            testid(&c, "song-name").await.text().await.unwrap(),
            name_before
        );

        // A song of the library, picked by name.
        wait_for(
            &c,
            "the library listed",
            "return document.querySelector('[data-testid=\"library\"] \
             option[value=\"abc-daramud.mid\"]') !== null;",
        )
        .await;
        c.execute(
            "const l = document.querySelector('[data-testid=\"library\"]'); \
             l.value = 'abc-daramud.mid';",
            vec![],
        )
        .await
        .unwrap();
        click(&c, "open").await;
        wait_for(
            &c,
            "the library's song",
            "return document.querySelector('[data-testid=\"song-name\"]').textContent\
             .startsWith('abc-daramud.mid:');",
        )
        .await;
        let want = analyze_json(&library.join("abc-daramud.mid"));
        assert_eq!(outcomes(&c).await["on_time"], want["outcomes"]["on_time"]);
        c.close().await.unwrap();
    });
}

/// The key-down and key-up events a page drew, in order: (note, down).
async fn key_log(c: &Client) -> Vec<(u64, bool)> {
    let log = c
        .execute("return window.orchKeyLog;", vec![])
        .await
        .unwrap();
    log.as_array()
        .unwrap()
        .iter()
        .map(|e| (e["note"].as_u64().unwrap(), e["down"].as_bool().unwrap()))
        .collect()
}

#[test]
fn a_performance_is_drawn_live_in_the_accounts_order_on_two_browsers_and_its_report_ends_it() {
    let s = Served::start(&["--listen", "127.0.0.1:0"]);
    let driver = Driver::start();
    // 16 quarter notes at 120 BPM (48, 49, … 63), each half a beat long (250 ms down, 250 ms
    // up: many states each, even on a loaded machine): 8 s.
    let (_dir, file) = scratch("quarters.mid", &support::quarters_smf(16, 120.0));
    runtime().block_on(async {
        let a = driver.browser(390, 844).await;
        let b = driver.browser(1024, 768).await;
        open(&a, &s).await;
        open(&b, &s).await;
        upload(&a, &file).await;
        wait_for(
            &a,
            "the analysis",
            "return document.querySelector('[data-testid=\"outcome-on_time\"]') !== null \
             && !document.querySelector('[data-testid=\"play\"]').disabled;",
        )
        .await;
        testid(&a, "play").await.click().await.unwrap();
        for c in [&a, &b] {
            wait_for(
                c,
                "the report at the end",
                "const r = document.querySelector('[data-testid=\"report\"]'); \
                 return !r.closest('section').hidden && r.textContent.length > 0;",
            )
            .await;
        }
        let ended = s.get_json("/api/ended");
        assert_eq!(ended["stopped"], json!(false));
        let low = s.get_json("/api/state")["keyboard"]["low"]
            .as_u64()
            .unwrap();
        // The account's order: each note's key down when its Note-On was sent, up before the
        // next (half a beat on, half a beat off).
        let mut lines: Vec<&Value> = ended["account"].as_array().unwrap().iter().collect();
        assert_eq!(lines.len(), 16);
        lines.sort_by(|x, y| {
            x["sent_ms"]
                .as_f64()
                .partial_cmp(&y["sent_ms"].as_f64())
                .unwrap()
        });
        let want: Vec<(u64, bool)> = lines
            .iter()
            .flat_map(|l| {
                let note = low + l["key"].as_u64().unwrap();
                [(note, true), (note, false)]
            })
            .collect();
        assert_eq!(want[0], (48, true));
        for (name, c) in [("a", &a), ("b", &b)] {
            assert_eq!(
                key_log(c).await,
                want,
                "browser {name} drew the keys in another order"
            );
            let report = testid(c, "report").await.text().await.unwrap();
            assert_eq!(
                report.trim_end(),
                ended["text"].as_str().unwrap().trim_end()
            );
        }
        let text = ended["text"].as_str().unwrap();
        assert!(text.starts_with("quarters.mid\n"), "{text}");
        assert!(text.contains("notes in the file      16"), "{text}");
        assert!(text.contains("struck on time         16"), "{text}");
        // From a key going down on the virtual robot (its Note-On sent) to the page drawing
        // it: each of the 16, on the phone's browser.
        let log = a
            .execute("return window.orchKeyLog;", vec![])
            .await
            .unwrap();
        let downs: Vec<f64> = log
            .as_array()
            .unwrap()
            .iter()
            .filter(|e| e["down"] == json!(true))
            .map(|e| e["t"].as_f64().unwrap())
            .collect();
        let zero = ended["origin_ms"].as_f64().unwrap() + ended["start_ms"].as_f64().unwrap();
        let mut lat: Vec<f64> = downs
            .iter()
            .zip(&lines)
            .map(|(t, l)| t - (zero + l["sent_ms"].as_f64().unwrap()))
            .collect();
        lat.sort_by(|x, y| x.partial_cmp(y).unwrap());
        eprintln!("key down to drawn: {lat:.1?} ms");
        assert!(lat[0] > 0.0 && lat[15] < 2_000.0, "{lat:?}");
        a.close().await.unwrap();
        b.close().await.unwrap();
    });
}

/// A chord of 60, 64, 67 and 72 held 10 s (at 120 BPM, 480 ticks a quarter).
fn long_chord() -> Vec<u8> {
    let tempo = testkit::smf::tempo(500_000);
    let mut events: Vec<(u32, Vec<u8>)> = vec![(0, tempo)];
    events.extend([60u8, 64, 67, 72].map(|n| (0, vec![0x90, n, 100])));
    // 20 quarters: 9600 ticks.
    events.extend([60u8, 64, 67, 72].map(|n| (if n == 60 { 9600 } else { 0 }, vec![0x80, n, 0])));
    let events: Vec<(u32, &[u8])> = events.iter().map(|(d, e)| (*d, e.as_slice())).collect();
    testkit::smf::one_track(&events)
}

#[test]
fn stop_releases_every_key_at_once_on_the_page_and_on_a_udp_output() {
    let udp = UdpSocket::bind("127.0.0.1:0").unwrap();
    udp.set_read_timeout(Some(Duration::from_millis(200)))
        .unwrap();
    let out = format!("udp:{}", udp.local_addr().unwrap());
    let s = Served::start(&["--listen", "127.0.0.1:0", "--out", "sim", "--out", &out]);
    let driver = Driver::start();
    let (_dir, file) = scratch("chord.mid", &long_chord());
    runtime().block_on(async {
        let c = driver.browser(390, 844).await;
        open(&c, &s).await;
        upload(&c, &file).await;
        wait_for(
            &c,
            "the analysis",
            "return !document.querySelector('[data-testid=\"play\"]').disabled;",
        )
        .await;
        testid(&c, "play").await.click().await.unwrap();
        let chord = "['60','64','67','72'].every(n => document.querySelector(\
                     `[data-testid=\"key-${n}\"]`).dataset.down === 'true')";
        wait_for(&c, "the chord down", &format!("return {chord};")).await;
        let png = c.screenshot().await.unwrap();
        std::fs::write(
            Path::new(env!("CARGO_TARGET_TMPDIR")).join("serve-phone-playing.png"),
            png,
        )
        .unwrap();
        let mut got = Vec::new();
        let mut buf = [0u8; 256];
        let t0 = Instant::now();
        while got.iter().filter(|b| **b == 0x90).count() < 4 {
            assert!(
                t0.elapsed() < PATIENCE,
                "the chord never came on UDP: {got:02x?}"
            );
            if let Ok(n) = udp.recv(&mut buf) {
                got.extend_from_slice(&buf[..n]);
            }
        }
        // STOP, and the time until the page shows every key up.
        let clicked = Instant::now();
        testid(&c, "stop").await.click().await.unwrap();
        wait_for(
            &c,
            "every key up",
            "return [...document.querySelectorAll('[data-testid^=\"key-\"]')]\
             .every(k => k.dataset.down === 'false');",
        )
        .await;
        let up_after = clicked.elapsed();
        let status = wait_for(
            &c,
            "stopped",
            "const t = document.querySelector('[data-testid=\"status\"]').textContent; \
             return t.startsWith('stopped') && t;",
        )
        .await;
        assert_eq!(status, json!("stopped: chord.mid"));
        assert!(
            up_after < Duration::from_secs(10),
            "stopped long before the chord's 10 s end: {up_after:?}"
        );
        // The UDP output: the chord, never let go note by note, then All Notes Off on every
        // channel, last.
        while let Ok(n) = udp.recv(&mut buf) {
            got.extend_from_slice(&buf[..n]);
        }
        let all_off: Vec<u8> = (0..16u8).flat_map(|ch| [0xB0 | ch, 123, 0]).collect();
        assert!(
            got.ends_with(&all_off),
            "no All Notes Off at the end: {got:02x?}"
        );
        assert!(
            !got.contains(&0x80),
            "a Note-Off before the stop: {got:02x?}"
        );
        let ended = s.get_json("/api/ended");
        assert_eq!(ended["stopped"], json!(true));
        let robots = ended["report"]["robots"].as_array().unwrap();
        assert_eq!(robots.len(), 2);
        for r in robots {
            assert_eq!(r["strikes"], 4, "{r}");
        }
        let report = testid(&c, "report").await.text().await.unwrap();
        assert!(report.contains(&format!("robot 2: {out}")), "{report}");
        c.close().await.unwrap();
    });
}

#[test]
fn the_controls_play_from_a_bar_on_the_roll_pause_set_the_tempo_and_jump() {
    let s = Served::start(&["--listen", "127.0.0.1:0"]);
    let driver = Driver::start();
    // 64 quarters at 120 BPM: 16 bars of 4/4, 32 s.
    let (_dir, file) = scratch("long.mid", &support::quarters_smf(64, 120.0));
    runtime().block_on(async {
        let c = driver.browser(390, 844).await;
        open(&c, &s).await;
        upload(&c, &file).await;
        wait_for(
            &c,
            "the roll",
            "return document.querySelector('[data-testid=\"roll\"] g.bar[data-bar=\"5\"]') !== null;",
        )
        .await;
        // A click on bar 5's number in the roll plays from there.
        c.execute(
            "document.querySelector('[data-testid=\"roll\"] g.bar[data-bar=\"5\"] text')\
             .scrollIntoView({block: 'center'});",
            vec![],
        )
        .await
        .unwrap();
        c.find(Locator::Css("[data-testid=\"roll\"] g.bar[data-bar=\"5\"] text"))
            .await
            .unwrap()
            .click()
            .await
            .unwrap();
        let bar_is = |bar: u32| {
            format!(
                "const t = document.querySelector('[data-testid=\"bar-beat\"]').textContent; \
                 return t.startsWith('{bar}:') && t;"
            )
        };
        wait_for(&c, "playing from bar 5", &bar_is(5)).await;
        click(&c, "pause").await;
        wait_for(
            &c,
            "paused",
            "return document.querySelector('[data-testid=\"status\"]').textContent\
             .startsWith('paused') && !document.querySelector('[data-testid=\"resume\"]').disabled;",
        )
        .await;
        let tempo = testid(&c, "tempo").await;
        tempo.clear().await.unwrap();
        tempo.send_keys("1.5\n").await.unwrap();
        c.execute(
            "document.querySelector('[data-testid=\"tempo\"]').dispatchEvent(new Event('change'));",
            vec![],
        )
        .await
        .unwrap();
        // Taken while paused: the performance goes on at it once resumed.
        let t0 = Instant::now();
        while s.get_json("/api/state")["tempo"] != json!(1.5) {
            assert!(t0.elapsed() < PATIENCE, "the tempo never came");
            tokio::time::sleep(Duration::from_millis(25)).await;
        }
        let bar = testid(&c, "bar-input").await;
        bar.send_keys("12\n").await.unwrap();
        click(&c, "resume").await;
        wait_for(&c, "jumped to bar 12", &bar_is(12)).await;
        wait_for(
            &c,
            "tempo 1.5",
            "return document.querySelector('[data-testid=\"bpm\"]').textContent\
             .includes('×1.50');",
        )
        .await;
        let state = s.get_json("/api/state");
        assert_eq!(state["playing"]["paused"], json!(false), "{state}");
        assert!((state["playing"]["bpm"].as_f64().unwrap() - 180.0).abs() < 0.01, "{state}");
        // A bar the song lacks: said on the page, the performance goes on.
        let bar = testid(&c, "bar-input").await;
        bar.clear().await.unwrap();
        bar.send_keys("99\n").await.unwrap();
        let said = wait_for(
            &c,
            "the error",
            "const e = document.querySelector('[data-testid=\"error\"]'); \
             return !e.hidden && e.textContent;",
        )
        .await;
        assert_eq!(said, json!("bar 99: the song has bars 1 to 16"));
        assert!(s.get_json("/api/state")["playing"]["bar"].as_u64().unwrap() >= 12);
        click(&c, "stop").await;
        wait_for(
            &c,
            "stopped",
            "return document.querySelector('[data-testid=\"status\"]').textContent\
             .startsWith('stopped');",
        )
        .await;
        let ended = s.get_json("/api/ended");
        assert_eq!(ended["report"]["jumps"], json!(2), "{ended}");
        c.close().await.unwrap();
    });
}
