//! `orch serve` for the tests: started on a free port, its URL read from what it prints, a
//! plain HTTP/1.1 client for the API (any `Host`, `Origin` or body, as a browser or an
//! attacker would send them), and stopped (SIGTERM) when dropped.

#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A running `orch serve`.
pub struct Served {
    child: Child,
    /// The page's URL as printed (with `?token=` off loopback).
    pub url: String,
    /// Where to connect.
    pub addr: SocketAddr,
    /// `host:port` as the URL has it.
    pub host: String,
    /// The token, off loopback.
    pub token: Option<String>,
}

impl Served {
    /// Starts `orch serve ARGS` (add `--listen ADDR:0`) and waits (at most 60 s) for its URL.
    pub fn start(args: &[&str]) -> Served {
        let mut child = Command::new(env!("CARGO_BIN_EXE_orch"))
            .arg("serve")
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("orch serve starts");
        let (tx, rx) = std::sync::mpsc::channel();
        let out = child.stdout.take().unwrap();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines() {
                let Ok(line) = line else { return };
                if let Some(i) = line.find("http://") {
                    let _ = tx.send(line[i..].to_string());
                }
            }
        });
        let url = rx
            .recv_timeout(Duration::from_secs(60))
            .expect("orch serve printed its URL");
        let rest = url.strip_prefix("http://").unwrap();
        let host = rest.split('/').next().unwrap().to_string();
        let token = rest.split("token=").nth(1).map(str::to_string);
        Served {
            child,
            addr: host.parse().unwrap(),
            host,
            url,
            token,
        }
    }

    /// Sends SIGTERM and waits (at most `secs`) for the server to exit: its status, or
    /// `None` if it did not.
    pub fn terminate(&mut self, secs: u64) -> Option<std::process::ExitStatus> {
        let _ = nix::sys::signal::kill(
            nix::unistd::Pid::from_raw(self.child.id() as i32),
            nix::sys::signal::Signal::SIGTERM,
        );
        let t0 = Instant::now();
        while t0.elapsed() < Duration::from_secs(secs) {
            if let Ok(Some(status)) = self.child.try_wait() {
                return Some(status);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        None
    }

    /// The server's process id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// A request with `headers` (each `Name: value`; `Host` is the server's unless given)
    /// and `body`: the status and the response's body.
    pub fn request(
        &self,
        method: &str,
        path: &str,
        headers: &[&str],
        body: &[u8],
    ) -> (u16, String) {
        request(self.addr, &self.host, method, path, headers, body)
    }

    /// A JSON command (`Origin` the page's own): the status and the body, parsed.
    pub fn command(&self, json: &str) -> (u16, serde_json::Value) {
        let origin = format!("Origin: http://{}", self.host);
        let (status, body) = self.request(
            "POST",
            "/api/command",
            &["Content-Type: application/json", &origin],
            json.as_bytes(),
        );
        (
            status,
            serde_json::from_str(&body).unwrap_or(serde_json::Value::Null),
        )
    }

    /// `GET path`, parsed as JSON.
    pub fn get_json(&self, path: &str) -> serde_json::Value {
        let (status, body) = self.request("GET", path, &[], b"");
        assert_eq!(status, 200, "GET {path}: {body}");
        serde_json::from_str(&body).unwrap()
    }

    /// Waits (at most `secs`) until the state satisfies `ok`, and gives it.
    pub fn wait_state(
        &self,
        secs: u64,
        ok: impl Fn(&serde_json::Value) -> bool,
    ) -> serde_json::Value {
        let t0 = Instant::now();
        loop {
            let s = self.get_json("/api/state");
            if ok(&s) {
                return s;
            }
            assert!(t0.elapsed() < Duration::from_secs(secs), "never came: {s}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Served {
    fn drop(&mut self) {
        let _ = nix::sys::signal::kill(
            nix::unistd::Pid::from_raw(self.child.id() as i32),
            nix::sys::signal::Signal::SIGTERM,
        );
        let t0 = Instant::now();
        while t0.elapsed() < Duration::from_secs(10) {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// One HTTP/1.1 request on a new connection (closed after it): the status and the body.
/// `Host` is `host` unless `headers` has one. The body is written in pieces and a write the
/// server refuses (it answered early and closed) ends the writing, not the request.
pub fn request(
    addr: SocketAddr,
    host: &str,
    method: &str,
    path: &str,
    headers: &[&str],
    body: &[u8],
) -> (u16, String) {
    let mut s = TcpStream::connect(addr).expect("connect");
    s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
    let mut head = format!("{method} {path} HTTP/1.1\r\n");
    if !headers
        .iter()
        .any(|h| h.to_ascii_lowercase().starts_with("host:"))
    {
        head += &format!("Host: {host}\r\n");
    }
    for h in headers {
        head += &format!("{h}\r\n");
    }
    let framed = |h: &&str| {
        let h = h.to_ascii_lowercase();
        h.starts_with("content-length:") || h.starts_with("transfer-encoding:")
    };
    if !headers.iter().any(framed) {
        head += &format!("Content-Length: {}\r\n", body.len());
    }
    head += "Connection: close\r\n\r\n";
    s.write_all(head.as_bytes()).expect("write the head");
    for piece in body.chunks(64 * 1024) {
        if s.write_all(piece).is_err() {
            break;
        }
    }
    let mut got = Vec::new();
    let _ = s.read_to_end(&mut got);
    let text = String::from_utf8_lossy(&got).into_owned();
    let status = text
        .split(' ')
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("no status in {text:?}"));
    let body = text
        .split_once("\r\n\r\n")
        .map_or("", |(_, b)| b)
        .to_string();
    (status, body)
}
