//! The live view in a real pseudo-terminal (tmux): `orch play` shows the pressed keys and
//! jumps to a bar typed; `orch conduct --source tap` follows the taps of the space bar.

mod support;

use std::process::{Command, Output};
use std::thread::sleep;
use std::time::{Duration, Instant};

/// A one-track SMF: 480 ticks a quarter at 120 bpm; C4 E4 G4 held from 0.5 s to 3.5 s.
fn chord_file() -> Vec<u8> {
    testkit::smf::one_track(&[
        (480, &[0x90, 60, 100]),
        (0, &[0x90, 64, 100]),
        (0, &[0x90, 67, 100]),
        (2880, &[0x80, 60, 0]),
        (0, &[0x80, 64, 0]),
        (0, &[0x80, 67, 0]),
    ])
}

/// A tmux server of its own running one command in a 100×30 pseudo-terminal; killed on drop.
struct Tmux {
    socket: String,
}

impl Tmux {
    fn start(name: &str, command: &str) -> Self {
        assert!(
            Command::new("tmux").arg("-V").output().is_ok(),
            "tmux is needed for this test; scripts/test.sh installs it"
        );
        let t = Tmux {
            socket: format!("orch-{name}-{}", std::process::id()),
        };
        let started = t.run(&["new-session", "-d", "-x", "100", "-y", "30", command]);
        assert!(
            started.status.success(),
            "{}",
            String::from_utf8_lossy(&started.stderr)
        );
        t
    }

    fn run(&self, args: &[&str]) -> Output {
        Command::new("tmux")
            .args(["-L", &self.socket, "-f", "/dev/null"])
            .args(args)
            .env("TERM", "xterm-256color")
            .output()
            .unwrap()
    }

    fn screen(&self) -> String {
        String::from_utf8_lossy(&self.run(&["capture-pane", "-p"]).stdout).into_owned()
    }

    fn keys(&self, keys: &str) {
        self.run(&["send-keys", keys]);
    }

    /// The screen once it shows `text`, polled every 20 ms for up to `within`.
    fn wait_for(&self, text: &str, within: Duration) -> String {
        let t0 = Instant::now();
        loop {
            let screen = self.screen();
            if screen.contains(text) {
                return screen;
            }
            assert!(
                t0.elapsed() < within,
                "no {text:?} within {within:?}: {screen}"
            );
            sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Tmux {
    fn drop(&mut self) {
        self.run(&["kill-server"]);
    }
}

fn scratch(name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let file = testkit::in_test(name);
    std::fs::write(&file, bytes).unwrap();
    file
}

/// The number after `label` on the screen.
fn number_after(screen: &str, label: &str) -> f64 {
    let at = screen
        .find(label)
        .unwrap_or_else(|| panic!("no {label:?}: {screen}"))
        + label.len();
    let s: String = screen[at..]
        .trim_start()
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == '.')
        .collect();
    s.parse()
        .unwrap_or_else(|_| panic!("{label:?} {s:?}: {screen}"))
}

#[test]
fn live_view_under_a_pseudo_terminal_lights_the_pressed_keys_and_q_stops_it() {
    let file = scratch("chord.mid", &chord_file());
    let tmux = Tmux::start(
        "view",
        &format!(
            "{} play {}; sleep 10",
            env!("CARGO_BIN_EXE_orch"),
            file.display()
        ),
    );
    sleep(Duration::from_millis(2000));
    let screen = tmux.screen();
    // `q` stops the performance early: the terminal comes back and the report is printed.
    tmux.keys("q");
    let after = tmux.wait_for("notes in the file", Duration::from_secs(5));
    assert!(after.contains("notes in the file      3"), "{after}");
    assert!(
        !after.contains("cut by the watchdog"),
        "stopping is not a watchdog cut: {after}"
    );
    assert!(!after.contains("down: "), "the view is gone: {after}");
    assert!(screen.contains("orch play chord.mid"), "{screen}");
    assert!(screen.contains("down: C4 E4 G4"), "{screen}");
    assert!(screen.contains("bar 1 beat"), "{screen}");
    assert!(screen.contains("61 keys"), "{screen}");
}

#[test]
fn jump_keys_in_the_live_view_go_to_the_bar_typed_and_to_the_next() {
    // Eight bars of four quarters at 120 BPM: 16 s, a note on every beat.
    let file = scratch("bars.mid", &support::quarters_smf(32, 120.0));
    let tmux = Tmux::start(
        "jump",
        &format!(
            "{} play {}; sleep 30",
            env!("CARGO_BIN_EXE_orch"),
            file.display()
        ),
    );
    tmux.wait_for("bar 1 beat", Duration::from_secs(10));
    tmux.keys("6");
    tmux.wait_for("go to bar 6_", Duration::from_secs(2));
    tmux.keys("Enter");
    let at6 = tmux.wait_for("bar 6 beat 1", Duration::from_secs(2));
    assert!(!at6.contains("go to bar"), "{at6}");
    tmux.keys("]");
    tmux.wait_for("bar 7 beat 1", Duration::from_secs(2));
    tmux.keys("q");
    let after = tmux.wait_for("notes in the file", Duration::from_secs(5));
    assert!(after.contains("jumps                  2:"), "{after}");
    // Every note before bar 7 that did not sound was skipped; nothing was dropped.
    let skipped = number_after(&after, "2:");
    let struck = number_after(&after, "strikes heard");
    let stopped = number_after(&after, "stopped");
    // A press sent just before `q` is let go at once: struck, with no sound.
    let silent = if after.contains("struck but no sound") {
        number_after(&after, "struck but no sound")
    } else {
        0.0
    };
    assert!(skipped >= 16.0, "{after}");
    assert_eq!(skipped + struck + stopped + silent, 32.0, "{after}");
}

#[test]
fn tap_tempo_in_a_pseudo_terminal_sets_the_tempo_the_taps_give() {
    // 24 quarters written at 60 BPM (24 s); tapped at 240 BPM, four times as fast.
    let file = scratch("taps.mid", &support::quarters_smf(24, 60.0));
    let tmux = Tmux::start(
        "tap",
        &format!(
            "{} conduct {} --source tap --follow immediate; sleep 30",
            env!("CARGO_BIN_EXE_orch"),
            file.display()
        ),
    );
    tmux.wait_for("conductor tap", Duration::from_secs(10));
    let t0 = Instant::now();
    let mut sent = Vec::new();
    for i in 0..9u32 {
        sleep((t0 + Duration::from_millis(250) * i).saturating_duration_since(Instant::now()));
        tmux.keys("Space");
        // Stamped once tmux has handed the key to the terminal: starting the tmux client
        // takes a varying while on a loaded machine, the terminal's read does not.
        sent.push(Instant::now());
    }
    // The taps' own tempo: the last four intervals, as they reached the terminal.
    let tapped = 60.0 * 4.0 / (sent[8] - sent[4]).as_secs_f64();
    let screen = tmux.wait_for("9 beats", Duration::from_secs(2));
    assert!(screen.contains("orch conduct taps.mid"), "{screen}");
    let bpm = number_after(&screen, "9 beats,");
    let factor = number_after(&screen, "tempo x");
    assert!(
        (bpm - tapped).abs() < 0.08 * tapped,
        "{bpm} BPM, tapped {tapped}: {screen}"
    );
    assert!(
        (factor - bpm / 60.0).abs() < 0.01,
        "{factor} at {bpm} BPM: {screen}"
    );
    // The rest plays four times as fast: 24 s as written ends within about 8 s.
    tmux.wait_for("notes in the file", Duration::from_secs(12));
    let took = t0.elapsed().as_secs_f64();
    assert!(took < 10.0, "{took} s");
}

/// The terminal goes away mid-piece (its window closed, the tmux server killed, an ssh line
/// dropped): orch stops at once and lets every key go, on a MIDI output too, instead of
/// reading the dead terminal forever (crossterm alone spins on its EIO: the view used to keep
/// a core busy after the piece, for ever).
#[test]
fn a_terminal_that_hangs_up_stops_the_performance_and_releases_every_key() {
    let file = scratch("long.mid", &support::quarters_smf(120, 60.0));
    let pidfile = testkit::in_test("pid");
    let _ = std::fs::remove_file(&pidfile);
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    socket
        .set_read_timeout(Some(Duration::from_millis(200)))
        .unwrap();
    let port = socket.local_addr().unwrap().port();
    let tmux = Tmux::start(
        "hangup",
        &format!(
            "sh -c 'echo $$ > {}; exec {} play {} --out sim --out udp:127.0.0.1:{port}'",
            pidfile.display(),
            env!("CARGO_BIN_EXE_orch"),
            file.display()
        ),
    );
    tmux.wait_for("orch play", Duration::from_secs(20));
    let pid: i32 = std::fs::read_to_string(&pidfile)
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    sleep(Duration::from_millis(1500));
    drop(tmux); // kill-server: the terminal hangs up
    let gone = Instant::now();
    let alive = || {
        std::path::Path::new(&format!("/proc/{pid}")).exists() && {
            // A zombie has exited; only its parent has not looked yet.
            let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
            !stat.contains(") Z ")
        }
    };
    while alive() {
        if gone.elapsed() > Duration::from_secs(5) {
            let _ = nix::sys::signal::kill(
                nix::unistd::Pid::from_raw(pid),
                nix::sys::signal::Signal::SIGKILL,
            );
            panic!("orch play still ran 5 s after its terminal went away");
        }
        sleep(Duration::from_millis(20));
    }
    let mut got = Vec::new();
    let mut buf = [0u8; 512];
    while let Ok(n) = socket.recv(&mut buf) {
        got.extend_from_slice(&buf[..n]);
    }
    let all_notes_off = got.windows(3).any(|w| w == [0xB0, 123, 0]);
    assert!(
        all_notes_off,
        "no All Notes Off on the MIDI output: {got:02x?}"
    );
    std::fs::remove_file(&pidfile).ok();
}
