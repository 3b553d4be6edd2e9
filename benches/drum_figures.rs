//! The drum kit's figures for the README's benchmark section: every corpus file with a
//! General MIDI drum part, played on the virtual robot of `orch config --instrument drums`
//! (on/off boards, the defaults), on the virtual clock.
//!
//! 1. **Onset error** of the drum notes' own strikes (sounded − score, ms): median, p99, max.
//! 2. **What became of the drum notes**: struck, joined a strike already on (or waiting),
//!    struck in unison with another note on the same beater, and dropped by reason.
//! 3. **The shortest interval each output repeats at**, from the virtual robot's pins: the
//!    closest two strikes of one output, against its rebound (the physical limit robot.toml
//!    gives: a beater cannot strike sooner); the hi-hat's lift too.
//! 4. **Energy**: the drum part's solenoid-on time (the pulses as the pins show them: the
//!    beaters' and the lift's, which add up to it) against holding each struck note's output
//!    for its written length, as a keyboard would.
//!
//! `cargo bench --bench drum_figures`. Not a test: it prints.

use std::collections::HashMap;
use std::path::Path;

use orch_perform::{Outcome, Tempo};
use orch_robot::{instrument_toml, BoardKind, Instrument, Robot};
use orch_seq::Song;

fn main() {
    let robot = Robot::from_toml(&instrument_toml(Instrument::Drums, BoardKind::OnOff))
        .expect("the kit's robot.toml");
    let mut setup = orch_stage::setup::setup(&robot, true, Tempo::new(1.0).expect("1"));
    setup.sim.keep = orch_sim::Keep::Everything;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/midi");
    let manifest = std::fs::read_to_string(dir.join("MANIFEST.tsv")).expect("the corpus");
    let (mut onsets, mut outcomes) = (Vec::new(), HashMap::<String, u64>::new());
    let (mut closest, mut files) = (HashMap::<u8, u64>::new(), 0);
    let (mut pulses_us, mut held_us) = (HashMap::<bool, u64>::new(), 0u64);
    let (mut lifts, mut open_hats) = (0u64, 0u64);
    for line in manifest.lines().skip(1) {
        let cols: Vec<&str> = line.split('\t').collect();
        if !cols
            .get(10)
            .is_some_and(|c| c.split(',').any(|ch| ch == "10"))
        {
            continue;
        }
        let Ok(song) = Song::parse(&std::fs::read(dir.join(cols[0])).expect("a corpus file"))
        else {
            continue;
        };
        files += 1;
        let played = orch_stage::setup::play_fast(&song, &setup).expect("plays");
        for r in played.records.iter().filter(|r| r.channel == 9) {
            if r.note == 46 && matches!(r.outcome, Outcome::OnTime { .. } | Outcome::Late { .. }) {
                open_hats += 1;
            }
            let word = match r.outcome {
                Outcome::OnTime { error_us } => {
                    onsets.push(f64::from(error_us) / 1000.0);
                    "struck".to_string()
                }
                Outcome::Late { by_us } => {
                    onsets.push(f64::from(by_us) / 1000.0);
                    "struck".to_string()
                }
                Outcome::Dropped(reason) => format!("dropped {}", reason.name()),
                o => o.name().to_string(),
            };
            *outcomes.entry(word).or_default() += 1;
        }
        let presses = &played.performance.presses;
        let mut last: HashMap<u8, u64> = HashMap::new();
        for p in presses {
            let (high, low) = (p.pin_high.as_nanos() / 1000, p.pin_low.as_nanos() / 1000);
            let extra = robot.config.strikes.is_extra(p.key);
            *pulses_us.entry(extra).or_default() += low - high;
            lifts += u64::from(extra);
            if let Some(before) = last.insert(p.key, high) {
                let c = closest.entry(p.key).or_insert(u64::MAX);
                *c = (*c).min(high - before);
            }
        }
        held_us += held_lengths(&song, &robot);
    }
    onsets.sort_by(f64::total_cmp);
    let at = |q: f64| onsets[((onsets.len() - 1) as f64 * q).round() as usize];
    println!(
        "drum parts: {files} corpus files, {} drum notes",
        outcomes.values().sum::<u64>()
    );
    println!(
        "onset error of {} strikes: median {:.3} ms, p99 {:.3} ms, max {:.3} ms",
        onsets.len(),
        at(0.5),
        at(0.99),
        onsets.last().copied().unwrap_or(0.0)
    );
    let mut list: Vec<_> = outcomes.into_iter().collect();
    list.sort();
    for (word, n) in list {
        println!("  {word}: {n}");
    }
    // Each output's closest two strikes, against its rebound.
    let kit = &robot.groups[0];
    println!("closest two strikes of each output (its rebound, the limit):");
    let mut keys: Vec<_> = closest.iter().collect();
    keys.sort();
    for (key, gap) in keys {
        println!(
            "  {}: {:.1} ms ({:.1} ms)",
            kit.output_name(*key).unwrap_or("?"),
            *gap as f64 / 1000.0,
            robot.config.strikes.pulse(*key).rebound.as_micros() as f64 / 1000.0
        );
    }
    println!("open hi-hats struck: {open_hats}, their lift fired first for {lifts} (skipped while still up)");
    let (beaters, lift) = (
        pulses_us.get(&false).copied().unwrap_or(0),
        pulses_us.get(&true).copied().unwrap_or(0),
    );
    let s = |us: u64| us as f64 / 1e6;
    println!(
        "solenoid-on time: {:.1} s = beaters {:.1} s + hi-hat lift {:.1} s ({lifts} lifts), against {:.1} s holding each note for its length ({:.1} %; the beaters alone {:.1} %)",
        s(beaters + lift),
        s(beaters),
        s(lift),
        s(held_us),
        100.0 * (beaters + lift) as f64 / held_us.max(1) as f64,
        100.0 * beaters as f64 / held_us.max(1) as f64
    );
}

/// The written lengths of the drum notes the kit has an output for, summed, µs: what a
/// keyboard would hold them for.
fn held_lengths(song: &Song, robot: &Robot) -> u64 {
    let kit = &robot.groups[0];
    let plays = |n: u8| kit.notes.iter().any(|notes| notes.contains(&n));
    let mut on: HashMap<u8, u64> = HashMap::new();
    let mut total = 0;
    for e in song.events() {
        if let Some((9, n, _)) = e.bytes.note_on() {
            if plays(n) {
                on.insert(n, e.time_us);
            }
        } else if let Some((9, n)) = e.bytes.note_off() {
            if let Some(t) = on.remove(&n) {
                total += e.time_us - t;
            }
        }
    }
    total
}
