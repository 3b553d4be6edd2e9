//! The live view of `orch play`, in a real pseudo-terminal (tmux), shows the pressed keys.

use std::process::Command;
use std::thread::sleep;
use std::time::Duration;

/// A one-track SMF: 480 ticks a quarter at 120 bpm; C4 E4 G4 held from 0.5 s to 3.5 s.
fn chord_file() -> Vec<u8> {
    let mut track = Vec::new();
    let mut push = |delta: u32, msg: &[u8]| {
        // Deltas here fit two VLQ bytes.
        if delta >= 128 {
            track.push(0x80 | (delta >> 7) as u8);
        }
        track.push((delta & 0x7F) as u8);
        track.extend_from_slice(msg);
    };
    push(480, &[0x90, 60, 100]);
    push(0, &[0x90, 64, 100]);
    push(0, &[0x90, 67, 100]);
    push(2880, &[0x80, 60, 0]);
    push(0, &[0x80, 64, 0]);
    push(0, &[0x80, 67, 0]);
    push(0, &[0xFF, 0x2F, 0x00]);
    let mut smf = b"MThd\0\0\0\x06\0\0\0\x01\x01\xE0MTrk".to_vec();
    smf.extend_from_slice(&(track.len() as u32).to_be_bytes());
    smf.extend_from_slice(&track);
    smf
}

#[test]
fn live_view_under_a_pseudo_terminal_lights_the_pressed_keys_and_q_stops_it() {
    assert!(
        Command::new("tmux").arg("-V").output().is_ok(),
        "tmux is needed for this test; scripts/test.sh installs it"
    );
    let dir = std::env::temp_dir().join(format!("orch-view-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("chord.mid");
    std::fs::write(&file, chord_file()).unwrap();
    let socket = format!("orch-view-test-{}", std::process::id());
    let tmux = |args: &[&str]| {
        Command::new("tmux")
            .args(["-L", &socket, "-f", "/dev/null"])
            .args(args)
            .env("TERM", "xterm-256color")
            .output()
            .unwrap()
    };
    let command = format!(
        "{} play {}; sleep 10",
        env!("CARGO_BIN_EXE_orch"),
        file.display()
    );
    let started = tmux(&["new-session", "-d", "-x", "100", "-y", "30", &command]);
    assert!(
        started.status.success(),
        "{}",
        String::from_utf8_lossy(&started.stderr)
    );
    sleep(Duration::from_millis(2000));
    let screen = String::from_utf8_lossy(&tmux(&["capture-pane", "-p"]).stdout).into_owned();
    // `q` stops the performance early: the terminal comes back and the report is printed.
    tmux(&["send-keys", "q"]);
    sleep(Duration::from_millis(1500));
    let after = String::from_utf8_lossy(&tmux(&["capture-pane", "-p"]).stdout).into_owned();
    tmux(&["kill-server"]);
    assert!(after.contains("notes in the file      3"), "{after}");
    assert!(
        !after.contains("cut by the watchdog"),
        "stopping is not a watchdog cut: {after}"
    );
    assert!(!after.contains("down: "), "the view is gone: {after}");
    assert!(screen.contains("orch play"), "{screen}");
    assert!(screen.contains("down: C4 E4 G4"), "{screen}");
    assert!(screen.contains("bar 1 beat"), "{screen}");
    assert!(screen.contains("61 keys"), "{screen}");
}
