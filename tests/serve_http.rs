//! `orch serve` at the HTTP level, as an attacker or a script would reach it: off loopback a
//! token or 401; a foreign `Host` (DNS rebinding) refused; a command or a WebSocket upgrade
//! from another `Origin` refused; commands JSON only; an upload over 16 MiB is 413 and the
//! server goes on serving; a malformed file is refused with `orch play`'s message, changing
//! nothing; the API's commands acknowledged with the new state.

#[path = "support/serve.rs"]
mod serve;
mod support;

use serve::{request, Served};

const WS_UPGRADE: [&str; 4] = [
    "Connection: Upgrade",
    "Upgrade: websocket",
    "Sec-WebSocket-Version: 13",
    "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==",
];

/// The shared corpus of real MIDI files, beside the checkout.
fn corpus_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/midi")
}

#[test]
fn off_loopback_every_request_without_the_token_is_401_and_with_it_the_page_comes() {
    let s = Served::start(&["--listen", "0.0.0.0:0"]);
    let token = s.token.clone().expect("a token off loopback");
    assert_eq!(token.len(), 32);
    assert!(s.url.contains(&format!("?token={token}")), "{}", s.url);
    for path in ["/", "/api/state", "/assets/app.js", "/api/library"] {
        let (status, body) = s.request("GET", path, &[], b"");
        assert_eq!(status, 401, "GET {path} without the token: {body}");
        let wrong = format!("{path}?token=0123{}", &token[4..]);
        let (status, _) = s.request("GET", &wrong, &[], b"");
        assert_eq!(status, 401, "GET {path} with a wrong token");
    }
    let (status, _) = s.request(
        "POST",
        "/api/command",
        &["Content-Type: application/json"],
        br#"{"cmd":"stop"}"#,
    );
    assert_eq!(status, 401);
    let (status, _) = s.request("GET", "/api/ws", &WS_UPGRADE, b"");
    assert_eq!(status, 401);
    // The URL printed, a bearer token, the cookie the page is given.
    let (status, body) = s.request("GET", &format!("/?token={token}"), &[], b"");
    assert_eq!(status, 200);
    assert!(body.contains("data-testid=\"stop\""));
    let bearer = format!("Authorization: Bearer {token}");
    let (status, _) = s.request("GET", "/api/state", &[&bearer], b"");
    assert_eq!(status, 200);
    let cookie = format!("Cookie: orch_token={token}");
    let (status, _) = s.request("GET", "/assets/app.js", &[&cookie], b"");
    assert_eq!(status, 200);
    // The page's own address on loopback is this machine's too: its Host is let in.
    let (status, _) = request(
        s.addr,
        &format!("localhost:{}", s.addr.port()),
        "GET",
        "/api/state",
        &[&bearer],
        b"",
    );
    assert_eq!(status, 200);
}

#[test]
fn loopback_asks_no_token_but_a_foreign_host_or_origin_is_refused() {
    let s = Served::start(&["--listen", "127.0.0.1:0"]);
    assert_eq!(s.token, None);
    let port = s.addr.port();
    let (status, body) = s.request("GET", "/", &[], b"");
    assert_eq!(status, 200, "{body}");
    // DNS rebinding: a page of evil.example whose name now points here sends its own Host.
    for host in [
        format!("evil.example:{port}"),
        "127.0.0.1".into(),
        format!("127.0.0.1:{}", port + 1),
        format!("0.0.0.0:{port}"),
    ] {
        let (status, body) = request(s.addr, &host, "GET", "/api/state", &[], b"");
        assert_eq!(status, 403, "Host {host}: {body}");
        assert!(body.contains("refused"), "{body}");
    }
    let (status, _) = request(
        s.addr,
        &format!("localhost:{port}"),
        "GET",
        "/api/state",
        &[],
        b"",
    );
    assert_eq!(status, 200);
    // A command from another page is refused; from the page itself it is taken (409: nothing
    // is playing to pause).
    for origin in [
        "http://evil.example",
        "null",
        &format!("http://127.0.0.1:{}", port + 1),
        &format!("https://127.0.0.1:{port}"),
    ] {
        let (status, body) = s.request(
            "POST",
            "/api/command",
            &[
                "Content-Type: application/json",
                &format!("Origin: {origin}"),
            ],
            br#"{"cmd":"pause"}"#,
        );
        assert_eq!(status, 403, "Origin {origin}: {body}");
    }
    let (status, body) = s.command(r#"{"cmd":"pause"}"#);
    assert_eq!(status, 409, "{body}");
    assert_eq!(body["error"], "nothing is playing");
    // A WebSocket upgrade from another page too; from the page itself it is switched.
    let evil: Vec<&str> = WS_UPGRADE
        .iter()
        .copied()
        .chain(["Origin: http://evil.example"])
        .collect();
    let (status, _) = s.request("GET", "/api/ws", &evil, b"");
    assert_eq!(status, 403);
    let own = format!("Origin: http://{}", s.host);
    let ours: Vec<&str> = WS_UPGRADE.iter().copied().chain([own.as_str()]).collect();
    let mut ws = std::net::TcpStream::connect(s.addr).unwrap();
    use std::io::{Read, Write};
    let mut head = format!("GET /api/ws HTTP/1.1\r\nHost: {}\r\n", s.host);
    for h in &ours {
        head += &format!("{h}\r\n");
    }
    ws.write_all(format!("{head}\r\n").as_bytes()).unwrap();
    ws.set_read_timeout(Some(std::time::Duration::from_secs(30)))
        .unwrap();
    let mut got = [0u8; 12];
    ws.read_exact(&mut got).unwrap();
    assert_eq!(&got, b"HTTP/1.1 101", "the page's own upgrade is switched");
    // Commands are JSON only: a form's types are refused.
    for kind in [
        "text/plain",
        "application/x-www-form-urlencoded",
        "multipart/form-data; boundary=x",
    ] {
        let (status, body) = s.request(
            "POST",
            "/api/command",
            &[&format!("Content-Type: {kind}")],
            br#"{"cmd":"pause"}"#,
        );
        assert_eq!(status, 415, "{kind}: {body}");
        let (status, body) = s.request(
            "POST",
            "/api/songs?name=x.mid",
            &[&format!("Content-Type: {kind}")],
            &support::quarters_smf(4, 120.0),
        );
        assert_eq!(status, 415, "upload as {kind}: {body}");
    }
    let (status, body) = s.request(
        "POST",
        "/api/command",
        &["Content-Type: application/json"],
        br#"{"cmd":"launch"}"#,
    );
    assert_eq!(status, 422, "{body}");
}

#[test]
fn an_upload_over_16_mib_is_413_and_the_server_goes_on_serving() {
    let s = Served::start(&["--listen", "127.0.0.1:0"]);
    let octets = ["Content-Type: application/octet-stream"];
    // Announced too large: refused before it is read.
    let big = vec![0u8; (16 << 20) + 1];
    let (status, body) = s.request("POST", "/api/songs?name=big.mid", &octets, &big);
    assert_eq!(status, 413, "{body}");
    assert!(body.contains("16 MiB"), "{body}");
    // Sent in chunks with no length given: refused once it has gone past.
    let (status, body) = s.request(
        "POST",
        "/api/songs?name=big.mid",
        &[
            "Content-Type: application/octet-stream",
            "Transfer-Encoding: chunked",
        ],
        &chunked(&big),
    );
    assert_eq!(status, 413, "{body}");
    // Just at the limit: read, and refused as what it is (not a MIDI file).
    let mut at_limit = b"MThd".to_vec();
    at_limit.resize(16 << 20, 0);
    let (status, body) = s.request("POST", "/api/songs?name=huge.mid", &octets, &at_limit);
    assert_eq!(status, 400, "{body}");
    // Still serving, and a good song after all that.
    let (status, _) = s.request("GET", "/", &[], b"");
    assert_eq!(status, 200);
    let (status, body) = s.request(
        "POST",
        "/api/songs?name=quarters.mid",
        &octets,
        &support::quarters_smf(8, 240.0),
    );
    assert_eq!(status, 200, "{body}");
    let song: serde_json::Value = serde_json::from_str(&body).unwrap();
    assert_eq!(song["analysis"]["notes"], 8);
}

/// `body` in HTTP/1.1 chunks of 64 KiB.
fn chunked(body: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    for c in body.chunks(64 * 1024) {
        out.extend_from_slice(format!("{:x}\r\n", c.len()).as_bytes());
        out.extend_from_slice(c);
        out.extend_from_slice(b"\r\n");
    }
    out.extend_from_slice(b"0\r\n\r\n");
    out
}

#[test]
fn a_malformed_file_gets_orch_plays_message_and_changes_nothing() {
    let dir = corpus_dir();
    let s = Served::start(&[
        "--listen",
        "127.0.0.1:0",
        "--library",
        dir.to_str().unwrap(),
    ]);
    let library = s.get_json("/api/library");
    let files: Vec<&str> = library["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap())
        .collect();
    assert!(files.contains(&"bad-header-magic.mid"), "{files:?}");
    let before = s.get_json("/api/state");
    for bad in files.iter().filter(|f| f.starts_with("bad-")) {
        let bytes = std::fs::read(dir.join(bad)).unwrap();
        let (status, body) = s.request(
            "POST",
            &format!("/api/songs?name={bad}"),
            &["Content-Type: audio/midi"],
            &bytes,
        );
        let play = std::process::Command::new(env!("CARGO_BIN_EXE_orch"))
            .args(["play", "--fast", "--json"])
            .arg(dir.join(bad))
            .output()
            .unwrap();
        let said = String::from_utf8_lossy(&play.stderr);
        if play.status.code() == Some(2) {
            assert_eq!(status, 400, "{bad}: {body}");
            let error: serde_json::Value = serde_json::from_str(&body).unwrap();
            let message = error["error"].as_str().unwrap();
            // orch play names the file by its path, the page by its name.
            let path = dir.join(bad).display().to_string();
            assert_eq!(
                said.trim(),
                format!("orch: error: {}", message.replace(bad, &path)),
                "{bad}"
            );
        } else {
            assert_eq!(
                status, 200,
                "{bad}: orch play takes it ({said}), so does the page: {body}"
            );
        }
    }
    // The library's too, by name, and a name it does not list is not read.
    let (status, body) = s.request(
        "POST",
        "/api/library",
        &["Content-Type: application/json"],
        br#"{"name":"bad-header-magic.mid"}"#,
    );
    assert_eq!(status, 400, "{body}");
    assert!(body.contains("instead of MThd"), "{body}");
    let (status, _) = s.request(
        "POST",
        "/api/library",
        &["Content-Type: application/json"],
        br#"{"name":"../shared/midi/bach-bwv847.mid"}"#,
    );
    assert_eq!(status, 404);
    let after = s.get_json("/api/state");
    let loaded = after["songs"].as_array().unwrap().len();
    assert_eq!(before["playing"], after["playing"]);
    assert_eq!(before["queue"], after["queue"]);
    assert!(
        loaded < files.iter().filter(|f| f.starts_with("bad-")).count(),
        "the refused files were not loaded"
    );
}

#[test]
fn each_command_is_acknowledged_with_the_state_that_shows_it_and_the_queue_plays_on() {
    let s = Served::start(&["--listen", "127.0.0.1:0"]);
    let octets = ["Content-Type: application/octet-stream"];
    let upload = |name: &str, smf: Vec<u8>| -> u64 {
        let (status, body) = s.request("POST", &format!("/api/songs?name={name}"), &octets, &smf);
        assert_eq!(status, 200, "{body}");
        serde_json::from_str::<serde_json::Value>(&body).unwrap()["id"]
            .as_u64()
            .unwrap()
    };
    // 64 quarters at 120 BPM: 16 bars, 32 s; and a short one for the queue.
    let long = upload("long.mid", support::quarters_smf(64, 120.0));
    let short = upload("short.mid", support::quarters_smf(4, 480.0));
    let (status, body) = s.command(r#"{"cmd":"play","song":99}"#);
    assert_eq!(
        (status, body["error"].as_str()),
        (404, Some("no song 99 is loaded"))
    );
    let (status, body) = s.command(&format!(r#"{{"cmd":"play","song":{long},"bar":17}}"#));
    assert_eq!(
        (status, body["error"].as_str()),
        (400, Some("bar 17: the song has bars 1 to 16"))
    );
    let (status, body) = s.command(&format!(r#"{{"cmd":"play","song":{long}}}"#));
    assert_eq!(status, 200, "{body}");
    assert_eq!(body["state"]["playing"]["name"], "long.mid");
    assert_eq!(body["state"]["playing"]["bar"], 1, "{body}");
    let (status, body) = s.command(&format!(r#"{{"cmd":"play","song":{short}}}"#));
    assert_eq!(status, 409, "{body}");
    let (status, body) = s.command(&format!(r#"{{"cmd":"queue","song":{short}}}"#));
    assert_eq!(status, 200);
    assert_eq!(body["state"]["queue"][0]["name"], "short.mid");
    let (_, body) = s.command(r#"{"cmd":"pause"}"#);
    assert_eq!(body["state"]["playing"]["paused"], true, "{body}");
    let (_, body) = s.command(r#"{"cmd":"resume"}"#);
    assert_eq!(body["state"]["playing"]["paused"], false, "{body}");
    let (status, body) = s.command(r#"{"cmd":"tempo","factor":25}"#);
    assert_eq!(status, 400, "{body}");
    assert!(
        body["error"]
            .as_str()
            .unwrap()
            .starts_with("tempo 25: give a factor from 0.05 to 20"),
        "{body}"
    );
    let (_, body) = s.command(r#"{"cmd":"tempo","factor":1.5}"#);
    assert_eq!(body["state"]["playing"]["tempo"], 1.5, "{body}");
    assert_eq!(body["state"]["tempo"], 1.5);
    let (status, body) = s.command(r#"{"cmd":"jump","bar":40}"#);
    assert_eq!(
        (status, body["error"].as_str()),
        (400, Some("bar 40: the song has bars 1 to 16"))
    );
    let (_, body) = s.command(r#"{"cmd":"jump","bar":15}"#);
    assert_eq!(body["state"]["playing"]["bar"], 15, "{body}");
    let (status, _) = s.command(r#"{"cmd":"tap"}"#);
    assert_eq!(status, 200);
    // Played out (bars 15 and 16 at 1.5 times: under 3 s), the queue's song follows, then
    // its report.
    let state = s.wait_state(60, |st| st["ended"]["name"] == "short.mid");
    assert_eq!(state["queue"], serde_json::json!([]));
    assert_eq!(state["ended"]["stopped"], false);
    assert!(state["ended"]["text"]
        .as_str()
        .unwrap()
        .starts_with("short.mid\n"));
    // STOP: the queue is emptied with it, and the acknowledgement is the end, every key up.
    s.command(&format!(r#"{{"cmd":"play","song":{long}}}"#));
    s.command(&format!(r#"{{"cmd":"queue","song":{short}}}"#));
    s.command(&format!(r#"{{"cmd":"queue","song":{short}}}"#));
    let (status, body) = s.command(r#"{"cmd":"unqueue","index":5}"#);
    assert_eq!(status, 404, "{body}");
    let (_, body) = s.command(r#"{"cmd":"unqueue","index":0}"#);
    assert_eq!(body["state"]["queue"].as_array().unwrap().len(), 1);
    let (_, body) = s.command(r#"{"cmd":"stop"}"#);
    let state = &body["state"];
    assert_eq!(state["playing"], serde_json::Value::Null, "{state}");
    assert_eq!(state["queue"], serde_json::json!([]));
    assert_eq!(state["ended"]["name"], "long.mid");
    assert_eq!(state["ended"]["stopped"], true);
    let (status, body) = s.command(r#"{"cmd":"stop"}"#);
    assert_eq!(
        (status, body["error"].as_str()),
        (409, Some("nothing is playing"))
    );
}

#[test]
fn sigterm_with_a_viewer_watching_a_chord_releases_every_key_and_ends_the_server() {
    use std::io::{Read, Write};
    let udp = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    udp.set_read_timeout(Some(std::time::Duration::from_millis(200)))
        .unwrap();
    let out = format!("udp:{}", udp.local_addr().unwrap());
    let mut s = Served::start(&["--listen", "127.0.0.1:0", "--out", &out]);
    // 4 notes at once, held 30 s (61 568 ticks at 120 BPM; only 60 is let go, at the end).
    let tempo = testkit::smf::tempo(500_000);
    let mut events: Vec<(u32, &[u8])> = vec![(0, &tempo)];
    let ons: Vec<[u8; 3]> = [60u8, 64, 67, 72].map(|n| [0x90, n, 100]).to_vec();
    events.extend(ons.iter().map(|on| (0, &on[..])));
    events.push((61_568, &[0x80, 60, 0]));
    let smf = testkit::smf::one_track(&events);
    let (status, body) = s.request(
        "POST",
        "/api/songs?name=chord.mid",
        &["Content-Type: audio/midi"],
        &smf,
    );
    assert_eq!(status, 200, "{body}");
    let (status, body) = s.command(r#"{"cmd":"play","song":1}"#);
    assert_eq!(status, 200, "{body}");
    // A viewer on the WebSocket, as the page would be.
    let mut ws = std::net::TcpStream::connect(s.addr).unwrap();
    let mut head = format!("GET /api/ws HTTP/1.1\r\nHost: {}\r\n", s.host);
    for h in WS_UPGRADE {
        head += &format!("{h}\r\n");
    }
    ws.write_all(format!("{head}\r\n").as_bytes()).unwrap();
    ws.set_read_timeout(Some(std::time::Duration::from_secs(30)))
        .unwrap();
    let mut got = [0u8; 12];
    ws.read_exact(&mut got).unwrap();
    assert_eq!(&got, b"HTTP/1.1 101");
    let mut bytes = Vec::new();
    let mut buf = [0u8; 256];
    let t0 = std::time::Instant::now();
    while bytes.iter().filter(|b| **b == 0x90).count() < 4 {
        assert!(
            t0.elapsed() < std::time::Duration::from_secs(60),
            "no chord: {bytes:02x?}"
        );
        if let Ok(n) = udp.recv(&mut buf) {
            bytes.extend_from_slice(&buf[..n]);
        }
    }
    let status = s
        .terminate(10)
        .expect("orch serve ended on SIGTERM with a viewer connected");
    assert!(status.success(), "{status:?}");
    while let Ok(n) = udp.recv(&mut buf) {
        bytes.extend_from_slice(&buf[..n]);
    }
    let all_off: Vec<u8> = (0..16u8).flat_map(|ch| [0xB0 | ch, 123, 0]).collect();
    assert!(
        bytes.ends_with(&all_off),
        "no All Notes Off at the end: {bytes:02x?}"
    );
}

#[test]
fn two_taps_set_the_tempo_they_beat() {
    let s = Served::start(&["--listen", "127.0.0.1:0"]);
    let (status, body) = s.request(
        "POST",
        "/api/songs?name=long.mid",
        &["Content-Type: audio/midi"],
        &support::quarters_smf(64, 120.0),
    );
    assert_eq!(status, 200, "{body}");
    let (status, _) = s.command(r#"{"cmd":"play","song":1}"#);
    assert_eq!(status, 200);
    let (status, _) = s.command(r#"{"cmd":"tap"}"#);
    assert_eq!(status, 200);
    // 600 ms later: 100 BPM against the 120 written, a factor of 0.83 (the taps are timed as
    // the server gets them: a loaded machine moves them by some ms).
    std::thread::sleep(std::time::Duration::from_millis(600));
    let (status, _) = s.command(r#"{"cmd":"tap"}"#);
    assert_eq!(status, 200);
    let state = s.wait_state(30, |st| st["playing"]["tempo"] != 1.0);
    let tempo = state["playing"]["tempo"].as_f64().unwrap();
    assert!((0.6..1.05).contains(&tempo), "{state}");
    let (status, _) = s.command(r#"{"cmd":"stop"}"#);
    assert_eq!(status, 200);
}

#[test]
fn a_bad_library_output_or_address_is_refused_at_start_with_exit_2() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let busy = taken.local_addr().unwrap().to_string();
    for (args, said) in [
        (
            vec!["--library", "/nonexistent"],
            "--library /nonexistent: not a folder",
        ),
        (
            vec!["--out", "serial:/nonexistent/tty"],
            "--out serial:/nonexistent/tty: cannot open",
        ),
        (vec!["--listen", busy.as_str()], "Address already in use"),
    ] {
        let mut all = vec!["serve"];
        if !args.contains(&"--listen") {
            all.extend(["--listen", "127.0.0.1:0"]);
        }
        all.extend(&args);
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_orch"))
            .args(&all)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(said), "{args:?}: {err}");
        assert!(out.stdout.is_empty(), "no URL printed: {args:?}");
    }
}
