//! Headless Chromium for `orch serve`'s browser tests and figures: chromedriver on a free
//! port of loopback, browsers (a phone's window through mobile emulation), and waiting on a
//! condition in the page. Debian's `chromium` and `chromium-driver` (scripts/test.sh installs
//! them).

#![allow(dead_code)]

use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use fantoccini::error::NewSessionError;
use fantoccini::{Client, ClientBuilder};
use serde_json::{json, Value};

/// How long any one condition may take to come true.
pub const PATIENCE: Duration = Duration::from_secs(90);

/// chromedriver on a free port of loopback, ended when dropped.
pub struct Driver {
    child: Child,
    url: String,
    /// chromedriver's and its browsers' temporary folder (`TMPDIR`), removed after them:
    /// Chromium ended by a signal leaves its own folders behind.
    tmp: testkit::Scratch,
}

impl Driver {
    pub fn start() -> Driver {
        let port = TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let tmp = testkit::Scratch::new("chromium");
        let child = Command::new("chromedriver")
            .arg(format!("--port={port}"))
            .env("TMPDIR", &tmp)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect(
                "chromedriver runs (Debian's chromium and chromium-driver: scripts/test.sh \
                 installs them)",
            );
        let t0 = Instant::now();
        while TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(t0.elapsed() < PATIENCE, "chromedriver never listened");
            std::thread::sleep(Duration::from_millis(50));
        }
        Driver {
            child,
            url: format!("http://127.0.0.1:{port}"),
            tmp,
        }
    }

    /// A new headless Chromium, its window `width` × `height` CSS pixels.
    pub async fn browser(&self, width: u32, height: u32) -> Client {
        let mut options = json!({
            "args": [
                "--headless=new",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-dev-shm-usage",
                "--hide-scrollbars",
                format!("--window-size={width},{height}"),
            ],
        });
        if width < 500 {
            // A phone: Chromium's windows are at least 500 pixels wide, its emulated
            // phones any width.
            options["mobileEmulation"] = json!({
                "deviceMetrics": { "width": width, "height": height, "pixelRatio": 1.0 },
            });
        }
        if Path::new("/usr/bin/chromium").exists() {
            options["binary"] = json!("/usr/bin/chromium");
        }
        let mut caps = serde_json::Map::new();
        caps.insert("goog:chromeOptions".into(), options);
        // chromedriver now and then resets the connection of a new session's request on a
        // loaded machine (seen once in 118 test binaries' runs): a transport failure is tried
        // again, a few times; a refusal from chromedriver itself is not.
        let mut attempt = 1;
        loop {
            let connector = hyper_util::client::legacy::connect::HttpConnector::new();
            match ClientBuilder::new(connector)
                .capabilities(caps.clone())
                .connect(&self.url)
                .await
            {
                Ok(client) => return client,
                Err(
                    e @ (NewSessionError::Failed(_)
                    | NewSessionError::FailedC(_)
                    | NewSessionError::Lost(_)),
                ) if attempt < 4 => {
                    eprintln!("a Chromium session, attempt {attempt}: {e}; trying again");
                    attempt += 1;
                    tokio::time::sleep(Duration::from_millis(500)).await;
                }
                Err(e) => panic!("a Chromium session: {e:?}"),
            }
        }
    }
}

impl Drop for Driver {
    /// Ends chromedriver and the browsers it started (its children: a test that failed before
    /// closing its session would leave them running, reparented, after chromedriver is gone).
    fn drop(&mut self) {
        for pid in children(self.child.id()) {
            let _ = nix::sys::signal::kill(
                nix::unistd::Pid::from_raw(pid as i32),
                nix::sys::signal::Signal::SIGTERM,
            );
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The processes whose parent is `parent`, from /proc.
fn children(parent: u32) -> Vec<u32> {
    let Ok(dir) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    dir.filter_map(Result::ok)
        .filter_map(|e| e.file_name().to_str()?.parse::<u32>().ok())
        .filter(|pid| {
            std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|stat| {
                // After the command's name in parentheses: state, then the parent's id.
                stat.rfind(')')
                    .and_then(|i| stat[i + 2..].split_whitespace().nth(1))
                    .and_then(|p| p.parse::<u32>().ok())
                    == Some(parent)
            })
        })
        .collect()
}

pub fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap()
}

/// Runs `script` (a function body that returns a value) until it returns something other
/// than `null` or `false`, and gives that; panics naming `what` after [`PATIENCE`].
pub async fn wait_for(c: &Client, what: &str, script: &str) -> Value {
    let t0 = Instant::now();
    loop {
        let v = c.execute(script, vec![]).await.unwrap_or(Value::Null);
        if !(v.is_null() || v == Value::Bool(false)) {
            return v;
        }
        assert!(t0.elapsed() < PATIENCE, "{what}: never came");
        tokio::time::sleep(Duration::from_millis(25)).await;
    }
}
