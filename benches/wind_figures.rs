//! The recorder's figures for the book's benchmarks chapter, on the virtual robot of
//! `orch config --instrument recorder`, on the virtual clock:
//!
//! 1. **The fastest passage without a drop**: a legato scale up and down C5–C6 (every
//!    fingering change of the lower octave, the thumb among them) at a rising rate; the
//!    highest rate, notes per second, at which every note sounds on time.
//! 2. **Onset error on corpus melodies**: the highest voice of four polyphonic corpus parts
//!    (`voice = "highest"`): sounded − score of the notes that sounded, ms.
//! 3. **The fingers' energy**: the finger solenoids' on-time over those melodies, at full
//!    power (PCA9555 boards) and at the PWM hold duty after the strike (PCA9685 boards), in
//!    full-power seconds.
//!
//! `cargo bench --bench wind_figures`. Not a test: it prints.

use std::path::Path;

use orch_perform::{Played, Report, Spread, Tempo};
use orch_robot::{instrument_toml, BoardKind, Instrument, Robot};
use orch_seq::Song;

const MELODIES: [&str; 4] = [
    "bach-bwv66-6-chorale.mid",
    "mozart-k545-exposition.mid",
    "bach-invention-01.mid",
    "m21-k525short.mid",
];

fn robot(kind: BoardKind) -> Robot {
    Robot::from_toml(&instrument_toml(Instrument::Recorder, kind)).expect("the recorder")
}

fn play(song: &Song, robot: &Robot) -> Played {
    let mut setup = orch_stage::setup::setup(robot, true, Tempo::new(1.0).expect("1"));
    // Every press kept: the fingers' energy is read from them.
    setup.sim.keep = orch_sim::Keep::Everything;
    orch_stage::setup::play_fast(song, &setup).expect("plays")
}

/// A one-track file at 120 bpm (960 ticks a second): `notes` legato, `ms` apart.
fn passage(notes: &[u8], ms: f64) -> Song {
    let mut track = Vec::new();
    let tick = |i: usize| (i as f64 * ms * 0.96).round() as u32;
    let mut last = 0;
    let mut event = |t: u32, bytes: [u8; 3], track: &mut Vec<u8>| {
        let mut d = t - last;
        last = t;
        let mut var = vec![(d & 0x7F) as u8];
        d >>= 7;
        while d > 0 {
            var.insert(0, 0x80 | (d & 0x7F) as u8);
            d >>= 7;
        }
        track.extend_from_slice(&var);
        track.extend_from_slice(&bytes);
    };
    for (i, &n) in notes.iter().enumerate() {
        if i > 0 {
            event(tick(i), [0x80, notes[i - 1], 0], &mut track);
        }
        event(tick(i), [0x90, n, 100], &mut track);
    }
    event(
        tick(notes.len()),
        [0x80, notes[notes.len() - 1], 0],
        &mut track,
    );
    track.extend_from_slice(&[0, 0xFF, 0x2F, 0]);
    let mut f = b"MThd\0\0\0\x06\0\0\0\x01\x01\xE0MTrk".to_vec();
    f.extend_from_slice(&(track.len() as u32).to_be_bytes());
    f.extend_from_slice(&track);
    Song::parse(&f).expect("a passage")
}

fn fastest_passage() {
    let robot = robot(BoardKind::OnOff);
    // Up C5..C6 and down again, no note repeated: under the guard's 10 s hold limit for the
    // thumb, held throughout, from 2 notes a second.
    let scale = [72u8, 74, 76, 77, 79, 81, 83, 84];
    let notes: Vec<u8> = scale
        .iter()
        .chain(scale[..7].iter().rev())
        .copied()
        .collect();
    let mut best = 0.0;
    for tenths in 20..=400 {
        let rate = f64::from(tenths) / 10.0;
        let r = play(&passage(&notes, 1000.0 / rate), &robot).report(None);
        if r.outcomes.on_time != notes.len() as u64 {
            let d = &r.outcomes.dropped;
            println!(
                "passage   {rate:.1} notes/s: {} of {} on time, {} dropped ({} too fast), {} late, {} early, {} no sound (the first rate with a drop)",
                r.outcomes.on_time, notes.len(), d.total(), d.too_fast, r.outcomes.late, r.outcomes.early, r.unmatched
            );
            break;
        }
        best = rate;
    }
    println!(
        "passage   fastest without a drop: {best:.1} notes/s ({:.1} ms a note: each note's valve closes 5 ms and its fingers settle 30 ms before it opens)",
        1000.0 / best
    );
}

/// Full-power seconds of the finger outputs' presses: at full power throughout, or at the
/// strike's duty for the strike time and the hold duty after.
fn finger_energy(played: &Played, robot: &Robot, hold: Option<(f64, f64)>) -> f64 {
    let wind = &robot.config.wind;
    let fingers = |k: u8| wind.owns(k) && k != wind.valve();
    let on_s = |p: &orch_sim::Press| (p.pin_low.as_micros() - p.pin_high.as_micros()) as f64 / 1e6;
    played
        .performance
        .presses
        .iter()
        .filter(|p| fingers(p.key))
        .map(|p| match hold {
            None => on_s(p),
            Some((strike_s, duty)) => on_s(p).min(strike_s) + (on_s(p) - strike_s).max(0.0) * duty,
        })
        .sum()
}

fn melodies() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/midi");
    let (on_off, pwm) = (robot(BoardKind::OnOff), robot(BoardKind::Pwm));
    let d = &pwm.config.dynamics;
    let strike_s = d.strike.as_micros() as f64 / 1e6;
    let hold = f64::from(d.touch(pwm.config.wind.finger(0)).hold.get()) / 4095.0;
    let (mut errors, mut full, mut held, mut notes, mut sounded) = (Vec::new(), 0.0, 0.0, 0, 0);
    for file in MELODIES {
        let song = Song::parse(&std::fs::read(dir.join(file)).expect("corpus")).expect("parses");
        let played = play(&song, &on_off);
        let r: Report = played.report(None);
        errors.extend(played.records.iter().filter_map(|r| r.outcome.error_ms()));
        notes += r.notes;
        sounded += r.outcomes.on_time + r.outcomes.late + r.outcomes.early;
        full += finger_energy(&played, &on_off, None);
        held += finger_energy(&play(&song, &pwm), &pwm, Some((strike_s, hold)));
    }
    let s = Spread::of(&mut errors);
    println!(
        "melodies  {} files, {notes} notes, {sounded} sounded (the rest a chord's lower notes, dropped as monophonic, or cut by the guard)",
        MELODIES.len()
    );
    println!(
        "melodies  onset error: median {:.3}, p99 {:.3}, max {:.3} ms",
        s.median, s.p99, s.max
    );
    println!(
        "fingers   energy: {full:.1} full-power s on/off, {held:.1} at a {:.0} % hold after {:.0} ms ({:.0} % of it)",
        hold * 100.0,
        strike_s * 1000.0,
        held / full * 100.0
    );
}

fn main() {
    fastest_passage();
    melodies();
}
