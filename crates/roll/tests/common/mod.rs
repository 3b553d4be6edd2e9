//! Two small hand-made songs, performed on the virtual robot and drawn.
#![allow(dead_code)]

use orch_perform::{song_events, Performer, Played, Setup, Tempo};
use orch_robot::Robot;
use orch_roll::Roll;
use orch_seq::Song;

/// A format-0 SMF at 480 ticks a quarter (120 bpm: a tick is 1.0417 ms) with a 3/4 time
/// signature, of `events` as (absolute tick, bytes), sorted by tick (stable).
pub fn smf(events: &[(u32, &[u8])]) -> Vec<u8> {
    // The time signature first, at tick 0; at_ticks keeps that order (a stable sort).
    let mut at: Vec<(u64, Vec<u8>)> = vec![(0, vec![0xFF, 0x58, 0x04, 3, 2, 24, 8])];
    at.extend(events.iter().map(|(t, b)| (u64::from(*t), b.to_vec())));
    testkit::smf::at_ticks(&at)
}

/// The thesis's robot listening to channels 1 and 2, and a song that gives every outcome a
/// straight performance can: on time, late, unison, joined, dropped (channel, too fast), a
/// folded note.
pub fn outcomes_song() -> (Song, Robot) {
    let robot_toml =
        orch_robot::DEFAULT_TOML.replace("channels = \"melodic\"", "channels = [1, 2]");
    assert!(
        robot_toml.contains("channels = [1, 2]"),
        "the default's channels line moved"
    );
    let robot = Robot::from_toml(&robot_toml).expect("a valid robot");
    let q = 480;
    let on = |ch: u8, n: u8| [0x90 | ch, n, 100];
    let off = |ch: u8, n: u8| [0x80 | ch, n, 0];
    let mut ev: Vec<(u32, Vec<u8>)> = Vec::new();
    let mut note = |t: u32, len: u32, ch: u8, n: u8| {
        ev.push((t, on(ch, n).to_vec()));
        ev.push((t + len, off(ch, n).to_vec()));
    };
    // Bar 1: a scale, on time.
    note(0, q, 0, 60);
    note(q, q, 0, 62);
    note(2 * q, q, 0, 64);
    // Bar 2: unison (C4 on channels 1 and 2 together), a note on channel 3 (dropped:
    // channel), a low note folded up (C1 → C2).
    note(3 * q, q, 0, 60);
    note(3 * q, q, 1, 60);
    note(3 * q, q, 2, 67);
    note(4 * q, 2 * q, 0, 24);
    // Joined: channel 2's E4 lands 10 ticks (10 ms) after channel 1's struck it.
    note(4 * q, q, 0, 64);
    note(4 * q + 10, q, 1, 64);
    // Bar 3: G4 repeated faster than its key can rest: late, then too fast.
    note(6 * q, 60, 0, 67);
    note(6 * q + 60, 60, 0, 67);
    note(6 * q + 110, 60, 0, 67);
    note(7 * q, q, 0, 72);
    let refs: Vec<(u32, &[u8])> = ev.iter().map(|(t, b)| (*t, b.as_slice())).collect();
    (Song::parse(&smf(&refs)).expect("a valid file"), robot)
}

/// Four PCA9685 boards (velocity played), and a phrase from pianissimo to fortissimo with a
/// chord.
pub fn dynamics_song() -> (Song, Robot) {
    let robot = Robot::from_toml(&orch_robot::default_toml(orch_robot::BoardKind::Pwm))
        .expect("a valid robot");
    let q = 480;
    let mut ev: Vec<(u32, Vec<u8>)> = Vec::new();
    for (i, v) in [10u8, 30, 50, 70, 90, 110, 127].into_iter().enumerate() {
        let t = i as u32 * q / 2;
        let n = 60 + 2 * i as u8;
        ev.push((t, vec![0x90, n, v]));
        ev.push((t + q / 2, vec![0x80, n, 0]));
    }
    for (n, v) in [(48u8, 40u8), (55, 80), (64, 120)] {
        ev.push((4 * q, vec![0x90, n, v]));
        ev.push((6 * q, vec![0x80, n, 0]));
    }
    let refs: Vec<(u32, &[u8])> = ev.iter().map(|(t, b)| (*t, b.as_slice())).collect();
    (Song::parse(&smf(&refs)).expect("a valid file"), robot)
}

/// `song` performed on `robot` on the virtual clock, every sound kept.
pub fn play(song: &Song, robot: &Robot) -> Played {
    play_at(song, robot, Tempo::NORMAL)
}

/// [`play`] at `tempo`.
pub fn play_at(song: &Song, robot: &Robot, tempo: Tempo) -> Played {
    let setup = Setup::for_robot(robot)
        .with_keep(orch_sim::Keep::Everything)
        .with_tempo(tempo);
    Performer::new(&setup, song_events(song), song.notes())
        .run()
        .expect("a performance")
}

/// The roll of `song` on `robot`.
pub fn roll(song: &Song, robot: &Robot, title: &str) -> (Roll, Played) {
    let played = play(song, robot);
    let keys = (
        robot.config.range.low().get(),
        robot.config.range.high().get(),
    );
    let roll = orch_roll::build::roll(song, &played, keys, 1.0, title).expect("a roll");
    (roll, played)
}
