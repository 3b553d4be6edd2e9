//! A performance of a song on the virtual robot: schedule, engine, and what each note did.

use orch_core::{Channel, KeyPhase, Note};
use orch_seq::{schedule, Clock, Compensation, Lateness, Schedule, Scheduled, Song, TempoScale};
use orch_sim::Performance;

use crate::engine::Engine;
use crate::robot::Robot;

/// One message as it goes on the line.
pub struct Send<'a> {
    /// When it is sent, on the engine's clock.
    pub t_us: u64,
    /// Its bytes, with running status (a repeated status byte left out).
    pub bytes: &'a [u8],
    /// The schedule entry it comes from (`None` for a keep-alive).
    pub entry: Option<&'a Scheduled>,
}

/// The byte stream of a schedule starting at `start_us`, as a sequencer sends it on a DIN
/// line: running status, and an Active Sensing keep-alive whenever the line would otherwise
/// be silent for 200 ms, so the robot's watchdog fires only if the sender is really gone.
pub fn sends(sched: &Schedule, start_us: u64) -> Vec<Send<'_>> {
    let mut out = Vec::with_capacity(sched.entries().len());
    let mut status = 0u8;
    let mut last: Option<u64> = None;
    for e in sched.entries() {
        let t = start_us + e.send_us;
        if let Some(mut at) = last {
            while t > at + KEEP_ALIVE_US {
                at += KEEP_ALIVE_US;
                out.push(Send {
                    t_us: at,
                    bytes: &[0xFE],
                    entry: None,
                });
            }
        }
        last = Some(t);
        let bytes = e.bytes.as_slice();
        let first = bytes.first().copied().unwrap_or(0);
        let skip = (0x80..0xF0).contains(&first) && first == status;
        status = match first {
            0x80..=0xEF => first,
            0xF0..=0xF7 => 0,
            _ => status,
        };
        out.push(Send {
            t_us: t,
            bytes: &bytes[usize::from(skip)..],
            entry: Some(e),
        });
    }
    out
}

/// The longest the player stays silent: it sends Active Sensing after this.
const KEEP_ALIVE_US: u64 = 200_000;

/// How to play.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Send each key early by its mechanical delay (and the bus write).
    pub compensation: bool,
    /// Tempo factor: 2.0 plays twice as fast.
    pub scale: TempoScale,
}

/// One Note-On of the score and what became of it.
#[derive(Clone, Copy, Debug)]
pub struct NoteRecord {
    /// The key it lands on, if any.
    pub key: Option<u8>,
    /// Octaves it was folded by.
    pub octaves: i8,
    /// When the score wants it to sound, on the engine's clock.
    pub score_us: u64,
    /// The guard delayed its strike (re-strike gap), in the interpreter or in the schedule.
    pub delayed: bool,
    /// It struck its key (rather than joining a key already down, or being dropped).
    pub strikes: bool,
}

/// Where the performance stands, for a live view.
pub struct Progress<'a> {
    /// Where the song is, in its own µs (tempo scale undone).
    pub song_us: u64,
    pub engine: &'a Engine,
    pub notes_sent: u64,
}

/// Everything a report needs.
pub struct Outcome {
    pub performance: Performance,
    pub stats: orch_core::Stats,
    pub notes: Vec<NoteRecord>,
    pub schedule: orch_seq::ScheduleStats,
    pub lateness: Option<Lateness>,
    pub counters: orch_core::Counters,
    /// When the first note of the score was due, on the engine's clock.
    pub start_us: u64,
    /// When the robot should have finished playing.
    pub end_us: u64,
}

/// How early compensation sends `key`'s press: its press delay and one bus write.
fn press_lead_us(robot: &Robot, key: u8) -> u64 {
    robot.mechanics.for_key(key).press_delay.as_micros() as u64 + robot.write_micros().ceil() as u64
}

/// How early compensation sends `key`'s release: its release delay and one bus write.
fn release_lead_us(robot: &Robot, key: u8) -> u64 {
    robot.mechanics.for_key(key).release_delay.as_micros() as u64
        + robot.write_micros().ceil() as u64
}

/// The send schedule of `song` for `robot`.
pub fn plan(song: &Song, robot: &Robot, options: Options) -> Schedule {
    let c = &robot.config;
    let comp = Compensation::new(
        Compensation::core_key_map(c.range, c.out_of_range, c.channels),
        |k| press_lead_us(robot, k as u8),
        |k| release_lead_us(robot, k as u8),
    )
    .restrike_gap_us(if c.guard.enabled {
        c.guard.restrike_gap.as_micros() as u64
    } else {
        0
    })
    .min_press_us(c.guard.min_press.as_micros() as u64)
    .enabled(options.compensation);
    schedule(song.events(), options.scale, Some(&comp))
}

/// Plays `song` on a virtual `robot`. With a clock, waits for each message's time (and calls
/// `observe` as it goes); `observe` returning `false` stops the performance early.
pub fn perform(
    song: &Song,
    robot: &Robot,
    options: Options,
    mut clock: Option<&mut dyn Clock>,
    mut observe: impl FnMut(&Progress) -> bool,
) -> anyhow::Result<Outcome> {
    let sched = plan(song, robot, options);
    let mut engine = Engine::new(robot)?;
    // Start once the boards are configured, on a whole millisecond.
    let start = engine.ready_us().div_ceil(1000) * 1000;
    let c = robot.config;
    let mut notes = Vec::new();
    let mut stopped_at = None;
    let mut waiting: std::collections::HashMap<u8, usize> = std::collections::HashMap::new();
    for send in sends(&sched, start) {
        let t = send.t_us;
        if let Some(clock) = clock.as_deref_mut() {
            // Wake at least every 40 ms to keep the view alive.
            loop {
                let now = clock.now_us();
                let step = t.min(now + 40_000);
                clock.wait_until(step);
                let song_us = (step.saturating_sub(start + sched.lead_in_us()) as f64
                    * options.scale.get()) as u64;
                let p = Progress {
                    song_us,
                    engine: &engine,
                    notes_sent: notes.len() as u64,
                };
                if !observe(&p) {
                    stopped_at = Some(step);
                    break;
                }
                if step >= t {
                    break;
                }
            }
            if stopped_at.is_some() {
                break;
            }
        }
        let before = *engine.interpreter().stats();
        let key = send
            .entry
            .and_then(|e| e.bytes.note_on())
            .and_then(|(ch, n, _)| {
                let ch = Channel::new(ch)?;
                c.channels.contains(ch).then_some(())?;
                c.range.key_for(Note::from_bits(n), c.out_of_range)
            });
        let phase_before = key.map(|k| engine.interpreter().key_phase(k.key));
        engine.push_slice(t, send.bytes)?;
        let Some(e) = send.entry else { continue };
        if e.bytes.note_on().is_none() {
            continue;
        }
        let after = engine.interpreter().stats();
        let lead = match (options.compensation, key) {
            (true, Some(k)) => press_lead_us(robot, k.key),
            _ => 0,
        };
        let held_back = e.send_us + lead > e.score_us;
        let phase_after = key.map(|k| engine.interpreter().key_phase(k.key));
        use KeyPhase::*;
        let strikes = match (phase_before, phase_after) {
            (Some(Up | Resting), Some(Down | Waiting)) | (Some(Down), Some(Waiting)) => true,
            (Some(Waiting), Some(Waiting)) => {
                // The waiting strike is now this note's.
                if let Some(&i) = key.and_then(|k| waiting.get(&k.key)) {
                    let earlier: &mut NoteRecord = &mut notes[i];
                    earlier.strikes = false;
                }
                true
            }
            _ => false,
        };
        if let (Some(k), Some(Waiting)) = (key, phase_after) {
            waiting.insert(k.key, notes.len());
        }
        notes.push(NoteRecord {
            key: key.map(|k| k.key),
            octaves: key.map_or(0, |k| k.octaves),
            score_us: start + e.score_us,
            delayed: held_back
                || after.restrikes_delayed > before.restrikes_delayed
                || phase_after == Some(Waiting),
            strikes,
        });
    }
    let last =
        stopped_at.unwrap_or_else(|| start + sched.entries().last().map_or(0, |e| e.send_us));
    let drained = match stopped_at {
        Some(t) => engine.stop(t)?,
        None => engine.drain(last + 1)?,
    };
    let longest_release = (0..c.range.keys())
        .map(|k| robot.mechanics.for_key(k as u8).release_delay.as_micros() as u64)
        .max()
        .unwrap_or(0);
    let end = drained.max(last) + longest_release + 1_000;
    let lateness = clock.map(|c| c.lateness());
    let (performance, stats, counters) = engine.finish(end);
    Ok(Outcome {
        performance,
        stats,
        notes,
        schedule: sched.stats(),
        lateness,
        counters,
        start_us: start,
        end_us: end,
    })
}
