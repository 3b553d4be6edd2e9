//! Helpers shared by the `orch` package's tests and benchmarks (`mod support;` in a test;
//! `#[path = "../tests/support/mod.rs"] mod support;` in a bench). Each user takes what it
//! needs, so some go unused in any one of them.
#![allow(dead_code)]

#[allow(unused_imports)]
pub use testkit::smf::quarters_smf;

/// A pseudo-terminal: its master, and the path of its slave for `orch run --in serial:PATH`.
/// `raw`: the master's line discipline off (no echo, no translation of the bytes written).
pub fn pty_master(raw: bool) -> (std::fs::File, String) {
    use nix::fcntl::OFlag;
    use std::os::fd::{FromRawFd, IntoRawFd};
    let master =
        nix::pty::posix_openpt(OFlag::O_RDWR | OFlag::O_NOCTTY | OFlag::O_CLOEXEC).unwrap();
    nix::pty::grantpt(&master).unwrap();
    nix::pty::unlockpt(&master).unwrap();
    let path = nix::pty::ptsname_r(&master).unwrap();
    if raw {
        let mut t = nix::sys::termios::tcgetattr(&master).unwrap();
        nix::sys::termios::cfmakeraw(&mut t);
        nix::sys::termios::tcsetattr(&master, nix::sys::termios::SetArg::TCSANOW, &t).unwrap();
    }
    // SAFETY: the descriptor is the master's own, handed over.
    let file = unsafe { std::fs::File::from_raw_fd(master.into_raw_fd()) };
    (file, path)
}

/// A child's standard error, collected as it comes; `ready` gets a message when `orch run`
/// says it reads.
pub fn collect_stderr(
    child: &mut std::process::Child,
) -> (
    std::sync::Arc<std::sync::Mutex<String>>,
    std::sync::mpsc::Receiver<()>,
) {
    use std::io::BufRead;
    let err = child.stderr.take().unwrap();
    let text = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
    let sink = std::sync::Arc::clone(&text);
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(err).lines() {
            let Ok(line) = line else { return };
            if line.contains("reading") {
                let _ = tx.send(());
            }
            let mut s = sink.lock().unwrap();
            s.push_str(&line);
            s.push('\n');
        }
    });
    (text, rx)
}

/// The arrival of each Note-On (velocity above 0) in the MIDI datagrams `socket` receives,
/// under running status, each sent on `tx` until it hangs up.
pub fn note_on_arrivals(
    socket: std::net::UdpSocket,
    tx: std::sync::mpsc::Sender<std::time::Instant>,
) {
    let mut buf = [0u8; 2048];
    let (mut status, mut data) = (0u8, Vec::new());
    // Each datagram's arrival in the kernel: not late when this thread is.
    orch_io::arrival::stamp_arrivals(&socket).unwrap();
    while let Ok((n, at)) = orch_io::arrival::recv(&socket, &mut buf) {
        for &b in &buf[..n] {
            match b {
                0xF8..=0xFF => {}
                0x80..=0xF7 => {
                    status = b;
                    data.clear();
                }
                _ => {
                    data.push(b);
                    let len = if matches!(status & 0xF0, 0xC0 | 0xD0) {
                        1
                    } else {
                        2
                    };
                    if data.len() == len {
                        if status & 0xF0 == 0x90 && data[1] > 0 && tx.send(at).is_err() {
                            return;
                        }
                        data.clear();
                    }
                }
            }
        }
    }
}
