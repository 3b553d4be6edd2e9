//! The performer: the planner's sends, paced by a clock, to the robot; the account at the end.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use orch_core::{Config, Stats};
use orch_seq::{Bell, Clock};
use orch_sim::{Performance, SimConfig};

use crate::ledger::{Ledger, NoteRecord, Outcome};
use crate::link::{DinWire, Link, MidiOut, RunningStatus};
use crate::plan::{PlanRules, PlanStats, Planned, Planner, ScoreEvent};
use crate::report::{Bus, Outcomes, Report, Spread, VelocityError};
use crate::robot::{sim_boards, LocalRobot, SimBoards, MAX_BOARDS};
use crate::tempo::{Tempo, TimeMap};

/// The longest the performer leaves a line silent: it sends Active Sensing (0xFE) after
/// 200 ms without a byte, so the robot's watchdog fires only when the sender is really gone.
pub const KEEP_ALIVE_US: u64 = 200_000;

/// The longest burst the performer plans for on a DIN line: a chord of 16 notes, every
/// message with its status byte (15.4 ms).
const DIN_BURST_US: u64 = 16 * 3 * Link::DIN_BYTE_US;

/// How far a struck note's loudness may be from its velocity, in MIDI velocity steps, before
/// `orch analyze` names it as too loud or too soft for the robot.
pub const VELOCITY_TOLERANCE: u8 = 2;

/// How often a live performance tells where it stands (25 times a second).
const SHOW_EVERY_US: u64 = 40_000;

/// How a performance is set up.
#[derive(Clone, Debug)]
pub struct Setup {
    /// The interpreter's configuration (the robot's keys, boards and guard).
    pub config: Config<MAX_BOARDS>,
    /// The virtual robot: boards, bus clock, mechanics.
    pub sim: SimConfig,
    /// Send each key early by its delays.
    pub compensation: bool,
    /// The tempo to start at.
    pub tempo: Tempo,
    /// How the bytes reach the robot.
    pub link: Link,
}

impl Setup {
    /// One board write on the bus, µs (START, 4 bytes of 9 bits, STOP), rounded up.
    pub fn write_us(&self) -> u64 {
        self.sim.clock.nanos_for_bits(38).div_ceil(1000)
    }

    /// The longest the bus can be busy with one write to every board, µs: a PCA9555's is 38
    /// bit-times, a PCA9685's at most 596 (all 16 channels in one write). A write waits at
    /// most that long behind the others.
    pub fn bus_queue_us(&self) -> u64 {
        let bits: u64 = (0..self.sim.boards.len())
            .map(|i| match self.sim.kind(i) {
                orch_core::BoardKind::OnOff => 38,
                orch_core::BoardKind::Pwm => 596,
            })
            .sum();
        self.sim.clock.nanos_for_bits(bits).div_ceil(1000)
    }

    /// The planner's rules for this robot: each key's press lead is its press delay, one
    /// board write and the link's time; its release lead, its release delay and one write.
    pub fn rules(&self) -> PlanRules {
        let c = &self.config;
        let keys = c.keys();
        let write = self.write_us() + self.link.note_lead_us();
        let m = &self.sim.mechanics;
        let guard = c.guard.enabled;
        PlanRules {
            keys: crate::plan::KeyMap::new(*c),
            press_lead_us: (0..keys)
                .map(|k| m.for_key(k as u8).press_delay.as_micros() as u64 + write)
                .collect(),
            // A PWM key: its strike's duty (from the velocity) sets its press delay, and its
            // write is one channel's five bytes (56 bit-times).
            press_lead_by_velocity_us: if c.dynamics.is_on_off() {
                Vec::new()
            } else {
                let pwm_write =
                    self.sim.clock.nanos_for_bits(56).div_ceil(1000) + self.link.note_lead_us();
                (0..keys)
                    .map(|k| {
                        let touch = c.dynamics.touch(k as u8);
                        if touch.is_full() {
                            return Vec::new();
                        }
                        let figures = m.for_key(k as u8);
                        (0..=127u8)
                            .map(|v| {
                                let duty = touch.strike_duty(orch_core::Velocity::from_bits(v));
                                figures.press_delay_at(duty.get()).as_micros() as u64 + pwm_write
                            })
                            .collect()
                    })
                    .collect()
            },
            release_lead_us: (0..keys)
                .map(|k| m.for_key(k as u8).release_delay.as_micros() as u64 + write)
                .collect(),
            // The shortest press that sounds, plus the longest a write can queue on the bus
            // behind the other boards' (the press may reach its pin later than the release),
            // plus, on a DIN line, the longest burst a chord makes (a burst is centred on its
            // time, so a press can arrive half a burst later and its release half a burst
            // earlier than planned).
            min_hold_us: (0..keys)
                .map(|k| {
                    m.for_key(k as u8).min_hold.as_micros() as u64
                        + self.bus_queue_us()
                        + match self.link {
                            Link::Direct => 0,
                            Link::Din => DIN_BURST_US,
                        }
                })
                .collect(),
            restrike_gap_us: if guard {
                c.guard.restrike_gap.as_micros() as u64
            } else {
                0
            },
            min_press_us: if guard {
                c.guard.min_press.as_micros() as u64
            } else {
                0
            },
            late_limit_us: c
                .guard
                .late_limit
                .filter(|_| guard)
                .map(|d| d.as_micros() as u64),
            overlap: c.overlap,
            compensation: self.compensation,
            // The bus's queue; on a DIN line also half a burst, since a press can arrive that
            // much earlier than planned and find its key resting longer.
            bus_margin_us: self.bus_queue_us()
                + match self.link {
                    Link::Direct => 0,
                    Link::Din => DIN_BURST_US / 2,
                },
            extra_lookahead_us: match self.link {
                Link::Direct => 0,
                Link::Din => DIN_BURST_US,
            },
        }
    }
}

/// Steering a performance from another thread: stop it, pause and resume it, change its
/// tempo, jump. Every request rings the control's [`Bell`]: a performance waiting for its
/// next send (or paused) wakes at once and takes it, whatever its clock's wait (a clock that
/// can be woken: `orch-seq`'s `RealClock`, [`PreciseClock`](crate::realtime::PreciseClock)),
/// so a change takes effect as soon as it is asked, not at a poll. It also looks at its
/// control before each send.
#[derive(Debug, Default)]
pub struct Control {
    bell: Bell,
    stop: AtomicBool,
    pause: AtomicBool,
    poll_us: std::sync::atomic::AtomicU64,
    tempo: Asked<Tempo>,
    /// A jump asked: its target, and for a start over, when it was asked.
    jump: Asked<(u64, Option<u64>)>,
    map: Mutex<Option<TimeMap>>,
}

impl Control {
    /// A control with nothing asked.
    pub fn new() -> Arc<Self> {
        Arc::new(Self::default())
    }

    /// Stop as soon as possible: every key released, the rest of the song stopped.
    pub fn stop(&self) {
        self.stop.store(true, Ordering::SeqCst);
        self.bell.ring();
    }

    /// The bell every request rings (a performance waits on it).
    pub fn bell(&self) -> &Bell {
        &self.bell
    }

    /// Call the live view every `us` µs instead of every 40 ms, from 1 ms to 40 ms. (A request
    /// does not wait for it: it wakes the performance at once.)
    pub fn poll_every(&self, us: u64) {
        self.poll_us
            .store(us.clamp(1_000, SHOW_EVERY_US), Ordering::SeqCst);
    }

    fn poll_us(&self) -> u64 {
        match self.poll_us.load(Ordering::SeqCst) {
            0 => SHOW_EVERY_US,
            us => us,
        }
    }

    /// Whether a stop was asked.
    pub fn stopping(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }

    /// Pause (with a live view: see [`perform`]): every key is released at once (All Notes
    /// Off and All Sound Off on every channel, so the pedal's notes too), score time stops,
    /// and the performance waits for [`resume`](Self::resume) or [`stop`](Self::stop). Notes
    /// already struck are not struck again; the rest play after the pause, each once.
    pub fn pause(&self) {
        self.pause.store(true, Ordering::SeqCst);
        self.bell.ring();
    }

    /// Go on after a [`pause`](Self::pause), from the score time where it paused, at the
    /// tempo it had.
    pub fn resume(&self) {
        self.pause.store(false, Ordering::SeqCst);
        self.bell.ring();
    }

    /// Whether a pause is asked.
    pub fn paused(&self) -> bool {
        self.pause.load(Ordering::SeqCst)
    }

    /// Play at `tempo` from now on.
    pub fn set_tempo(&self, tempo: Tempo) {
        self.tempo.ask(tempo);
        self.bell.ring();
    }

    /// Jump to score time `score_us` (µs of the song at its written tempo): every key is
    /// released at once on every output (All Notes Off and All Sound Off on every channel),
    /// the channels' state at the target is chased (see [`Planner::jump`](crate::Planner::jump)),
    /// and the performance goes on from the target, at the tempo it had, each note after the
    /// target once and in order. Notes sounding across the target are not restarted. Paused,
    /// the jump is taken when the performance resumes. A later jump asked before this one is
    /// taken replaces it.
    pub fn jump_to(&self, score_us: u64) {
        self.jump.ask((score_us, None));
        self.bell.ring();
    }

    /// Play from the top (a conductor's Start), asked at wall time `asked_at_us` on the
    /// performer's clock: a [`jump_to`](Self::jump_to) the top and a
    /// [`resume`](Self::resume), unless at `asked_at_us` the performance had not got past the
    /// point its present pass began at (the top, or the last jump's target): then it only
    /// resumes (a Start that comes as the performance begins does not play its first notes
    /// twice).
    pub fn start_over(&self, asked_at_us: u64) {
        self.jump.ask((0, Some(asked_at_us)));
        self.resume();
    }

    /// The performance's score ↔ wall time map as it stands (`None` before it starts): where
    /// the score is at any moment, for a follower that pulls the phase toward a beat.
    pub fn time_map(&self) -> Option<TimeMap> {
        *self.map.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn publish(&self, map: TimeMap) {
        *self.map.lock().unwrap_or_else(|e| e.into_inner()) = Some(map);
    }
}

/// A request to every performance that shares a control (one per robot): each takes the
/// latest one it has not seen, by its number.
#[derive(Debug, Default)]
struct Asked<T> {
    latest: Mutex<(u64, Option<T>)>,
}

impl<T: Copy> Asked<T> {
    fn ask(&self, value: T) {
        let mut l = self.latest.lock().unwrap_or_else(|e| e.into_inner());
        *l = (l.0 + 1, Some(value));
    }

    /// The latest request not seen yet (`seen` is the number of the last one seen).
    fn pending(&self, seen: u64) -> Option<T> {
        let l = self.latest.lock().unwrap_or_else(|e| e.into_inner());
        l.1.filter(|_| l.0 > seen)
    }

    /// [`pending`](Self::pending), marked seen.
    fn take(&self, seen: &mut u64) -> Option<T> {
        let l = self.latest.lock().unwrap_or_else(|e| e.into_inner());
        let v = l.1.filter(|_| l.0 > *seen);
        *seen = l.0;
        v
    }
}

/// Where a performance stands, for a live view.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Live {
    /// Where the song is, µs of score time.
    pub song_us: u64,
    /// Whether each key of the virtual robot is down.
    pub keys_down: Vec<bool>,
    /// Score notes sent so far.
    pub notes_sent: u64,
    /// The tempo factor.
    pub tempo: f64,
    /// Paused ([`Control::pause`]).
    pub paused: bool,
    /// The interpreter's counters so far (the guard's among them: keys cut by the hold
    /// limit, the duty limit and the watchdog, notes refused by the power budget).
    pub stats: Stats,
}

/// What went wrong in a performance.
#[derive(Debug)]
pub enum PerformError {
    /// The robot's configuration cannot run, or the virtual robot failed.
    Robot(String),
    /// The MIDI output failed.
    Midi(Box<dyn std::error::Error + Send + Sync>),
}

impl std::fmt::Display for PerformError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PerformError::Robot(e) => write!(f, "the robot: {e}"),
            PerformError::Midi(e) => write!(f, "the MIDI output: {e}"),
        }
    }
}

impl std::error::Error for PerformError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            PerformError::Midi(e) => Some(&**e),
            PerformError::Robot(_) => None,
        }
    }
}

fn robot_err(e: impl std::fmt::Display) -> PerformError {
    PerformError::Robot(e.to_string())
}

/// A finished performance: every note's record and what the virtual robot did.
#[derive(Debug)]
pub struct Played {
    /// Every score note, in score order (its index is its [`NoteId`](crate::NoteId)), with its
    /// outcome.
    pub records: Vec<NoteRecord>,
    /// What the virtual robot did: writes, edges, sounds, presses.
    pub performance: Performance,
    /// The interpreter's counters.
    pub stats: Stats,
    /// What the planner changed.
    pub plan: PlanStats,
    /// Real-clock lateness of each message sent, µs (real-time play only).
    pub lateness_us: Option<Vec<u64>>,
    /// When the song started (score time 0), wall µs.
    pub start_us: u64,
    /// When the robot had finished, wall µs.
    pub end_us: u64,
    /// Re-strikes that waited for their key's rest.
    pub restrikes_waited: u64,
    /// Whether it was stopped before the end.
    pub stopped: bool,
    /// Jumps taken ([`Control::jump_to`]).
    pub jumps: u64,
    /// Notes the performance came to again after a jump back: `records` holds the score's
    /// notes plus these (each pass over a note is a record of its own).
    pub replayed: u64,
    /// Per key: whether velocity is played there (a PWM key), for the velocity error.
    pub dynamic_keys: Vec<bool>,
    /// Per key: whether it is a lead or a damper (an open hi-hat's lift, a bar's damper): an
    /// output no note strikes itself, whose presses are not notes' strikes.
    pub extra_keys: Vec<bool>,
}

impl Played {
    /// The report, with `uncompensated` (the onset error of the same piece played without
    /// compensation) beside it if given.
    pub fn report(&self, uncompensated: Option<Spread>) -> Report {
        let (outcomes, unmatched) = Outcomes::of(&self.records);
        let mut folded_by_octaves = std::collections::BTreeMap::new();
        for r in &self.records {
            if let Some(l) = r.landing.filter(|l| l.octaves != 0) {
                *folded_by_octaves.entry(l.octaves).or_insert(0) += 1;
            }
        }
        let m = self.performance.summary.mechanics;
        let bus = self.performance.summary.bus;
        let span = self.end_us.saturating_sub(self.start_us).max(1) as f64;
        let s = &self.stats;
        let extra = |e: &&orch_sim::SoundEvent| {
            e.kind == orch_sim::SoundKind::Down
                && self.extra_keys.get(usize::from(e.key)) == Some(&true)
        };
        let lifts_and_dampers = self.performance.sounds.iter().filter(extra).count() as u64;
        Report {
            notes: (self.records.len() as u64).saturating_sub(self.replayed),
            jumps: self.jumps,
            replayed: self.replayed,
            outcomes,
            strikes: m.clean_onsets + m.smeared_onsets - lifts_and_dampers,
            lifts_and_dampers,
            unmatched,
            folded: folded_by_octaves.values().sum(),
            folded_by_octaves,
            restrikes_delayed: self.restrikes_waited,
            planning: self.plan.into(),
            cut_by_hold_limit: s.cut_by_hold_limit.into(),
            cut_by_duty_limit: s.cut_by_duty_limit.into(),
            cut_by_watchdog: s.cut_by_watchdog.into(),
            onset_ms: Spread::of_onsets(&self.records),
            onset_uncompensated_ms: uncompensated,
            velocity_error: VelocityError::of(&self.records, |key| {
                self.dynamic_keys.get(key as usize) == Some(&true)
            }),
            peak_keys_down: s.peak_keys_down,
            too_short_to_sound: m.short_pulses,
            smeared: m.smeared_presses,
            muted: m.muted,
            bus: Bus {
                writes: bus.transactions,
                bytes: bus.bytes,
                busy_percent: (bus.busy_nanos as f64 / 1000.0 / span * 100_000.0).round() / 1000.0,
            },
            seconds: (span / 1e4).round() / 100.0,
            lateness_ms: self.lateness_us.as_ref().map(|l| {
                let mut ms: Vec<f64> = l.iter().map(|&u| u as f64 / 1000.0).collect();
                Spread::of(&mut ms)
            }),
        }
    }

    /// Whether `r` struck on a PWM key and sounded louder (`Some(true)`) or softer
    /// (`Some(false)`) than its velocity by more than [`VELOCITY_TOLERANCE`] steps.
    pub fn loudness_off(&self, r: &NoteRecord) -> Option<bool> {
        let key = r.landing?.key;
        if self.dynamic_keys.get(usize::from(key)) != Some(&true) || r.outcome.error_ms().is_none()
        {
            return None;
        }
        let heard = r.sounded_velocity?;
        (heard.abs_diff(r.velocity) > VELOCITY_TOLERANCE).then_some(heard > r.velocity)
    }

    /// The notes that went wrong, the worst first: dropped (too soft among them), struck
    /// without a sound, joined, late and early by how much, then those that sounded louder or
    /// softer than asked by more than [`VELOCITY_TOLERANCE`] steps, by how much.
    pub fn went_wrong(&self) -> Vec<&NoteRecord> {
        let rank = |r: &NoteRecord| -> (u8, i64) {
            match r.outcome {
                Outcome::Dropped(_) => (0, 0),
                Outcome::Unmatched => (1, 0),
                Outcome::Joined => (2, 0),
                Outcome::Late { by_us } | Outcome::Early { by_us } => (3, -i64::from(by_us)),
                _ if self.loudness_off(r).is_some() => (
                    4,
                    -i64::from(r.sounded_velocity.unwrap_or(0).abs_diff(r.velocity)),
                ),
                _ => (9, 0),
            }
        };
        let mut v: Vec<&NoteRecord> = self.records.iter().filter(|r| rank(r).0 < 9).collect();
        v.sort_by_key(|r| (rank(r), r.score_at_us));
        v
    }
}

/// Where the bytes go.
enum Out<'m, M: MidiOut> {
    Virtual,
    Midi {
        out: &'m mut M,
        wire: DinWire,
        status: RunningStatus,
    },
}

/// Plays `source` (score events in order, `notes` Note-Ons in all) as `setup` says. With a
/// `midi` output the bytes go out there, and the virtual robot is its copy at the far end of
/// `setup.link`; without, the virtual robot is the robot. `clock` paces the sends (a
/// `VirtualClock` renders as fast as the machine goes); with `live`, the performer wakes at
/// least every 40 ms (or as [`Control::poll_every`] says) to call it with where it stands.
/// A request to `control` wakes it at once (its [`Bell`]). With a `control`, `source` is cloned before it is read, so a
/// jump ([`Control::jump_to`]) can read the score again from its start.
///
/// After a jump the account goes on as one: notes a jump passes over (after a jump forward,
/// those between the place it left and the target; those the performer had read ahead and
/// not sent yet) are [`Outcome::Skipped`]; after a jump back, the notes played again are
/// records of their own ([`Played::replayed`]).
pub fn perform<S, M>(
    setup: &Setup,
    source: S,
    notes: usize,
    midi: Option<&mut M>,
    clock: &mut dyn Clock,
    control: Option<&Control>,
    mut live: Option<&mut dyn FnMut(&Live)>,
) -> Result<Played, PerformError>
where
    S: Iterator<Item = ScoreEvent> + Clone,
    M: MidiOut,
{
    let origin = control.map(|_| source.clone());
    let boards = sim_boards(&setup.sim).map_err(robot_err)?;
    let mut robot = LocalRobot::<SimBoards>::new(setup.config, boards).map_err(robot_err)?;
    // Start once the boards are configured, on a whole millisecond.
    let ready = robot
        .boards()
        .bus()
        .bus()
        .free_at()
        .as_micros()
        .div_ceil(1000)
        * 1000;
    let mut planner = Planner::new(source, setup.rules(), ready as i64, setup.tempo);
    let start = planner.wall(0).max(0) as u64;
    if let Some(c) = control {
        c.publish(*planner.time_map());
    }
    let mut ledger = Ledger::new(setup.config.keys());
    let mut out = match midi {
        Some(out) => Out::Midi {
            out,
            wire: DinWire::default(),
            status: RunningStatus::default(),
        },
        None => Out::Virtual,
    };
    let real = live.is_some();
    let mut lateness = real.then(Vec::new);
    let mut last_byte: Option<u64> = None;
    let mut notes_sent = 0u64;
    let mut stopped_at = None;
    let mut last_at = ready;
    // Sends left in the present DIN burst, and its time.
    let mut burst = 0usize;
    let mut burst_at = 0u64;

    let every = control.map_or(SHOW_EVERY_US, Control::poll_us);
    // Notes sent (early) whose time to sound has not come: a tempo change moves that time.
    let mut sent_ahead: Vec<(u32, i64)> = Vec::new();
    // The account's number of a planned note is its score index plus `offset`, which grows at
    // each jump back (a note played again is a record of its own). The latest score index
    // sent or dropped since the last jump tells a jump forward from one back.
    let mut offset = 0u32;
    let mut committed: Option<u32> = None;
    let mut jumps = 0u64;
    // Where the present pass began in the score (0, or the last jump's target).
    let mut pass_from = 0u64;
    // The numbers of the last tempo and jump asked of the control that this performance took.
    let (mut seen_tempo, mut seen_jump) = (0u64, 0u64);
    loop {
        // The control's rings so far, read before looking at it: a request after this wakes
        // the wait below.
        let seen = control.map_or(0, |c| c.bell().rung());
        if let (Some(c), Some(origin)) = (control, origin.as_ref()) {
            let now = clock.now_us().max(last_at);
            // A start over asked before the performance got past where its pass began
            // changes nothing.
            let here = |&(t, asked): &(u64, Option<u64>)| {
                asked.is_some_and(|a| t == pass_from && planner.time_map().score(a as i64) <= t)
            };
            if let Some((target, _)) = c.jump.take(&mut seen_jump).filter(|j| !here(j)) {
                release_all(&mut out, setup.link, now, &mut robot, &mut ledger)?;
                last_at = now;
                last_byte = Some(now);
                burst = 0;
                let read = planner.notes_read();
                let jumped = planner.jump(origin.clone(), now as i64, target);
                let first = planner.notes_read();
                let back = committed.is_some_and(|m| m >= first);
                let unsent = jumped.unsent.iter().filter(|u| back || u.note < first);
                for u in unsent.chain(&jumped.passed) {
                    let id = u.note + offset;
                    ledger.score(id, u.channel, u.note_number, u.velocity, u.score_at_us);
                    ledger.skipped(id);
                }
                if back {
                    offset += read - first;
                }
                committed = None;
                sent_ahead.clear();
                jumps += 1;
                pass_from = target;
                c.publish(*planner.time_map());
            }
        }
        if let Some(c) = control {
            if let Some(t) = c.tempo.take(&mut seen_tempo) {
                let now = clock.now_us() as i64;
                let old = *planner.time_map();
                planner.set_tempo(now, t);
                let new = *planner.time_map();
                c.publish(new);
                sent_ahead.retain(|&(_, at)| at > now);
                for (id, at) in &mut sent_ahead {
                    *at = new.wall(old.score(*at));
                    ledger.rescore(*id, *at);
                }
            }
        }
        let Some(next) = planner.peek_time() else {
            break;
        };
        let mut next = next.max(0) as u64;
        if burst == 0 {
            if let (Link::Din, Out::Midi { status, .. }) = (setup.link, &out) {
                // A chord goes out as one burst, centred on its time: see `din_burst`.
                let (start, members) = din_burst(&planner.final_sends(), *status);
                next = start.max(last_at as i64) as u64;
                burst = members;
                burst_at = next;
            }
        } else {
            next = burst_at;
        }
        // Keep the line alive through long silences while keys are down or waiting, so the
        // robot's watchdog does not cut a held chord (generated as the time comes, never
        // stored, and only while something could be cut: memory and time follow the events,
        // never the length of a silence).
        let busy = robot.interpreter().next_deadline().is_some();
        let mut due = match last_byte {
            Some(b) if busy && next > b + KEEP_ALIVE_US => (b + KEEP_ALIVE_US, true),
            _ => (next, false),
        };
        // An output with timers of its own (a robot driven from this host) is called at them.
        let mut poll = false;
        if let Out::Midi { out, .. } = &out {
            if let Some(d) = out.next_deadline().filter(|&d| d < due.0) {
                due = (d.max(last_at), false);
                poll = true;
            }
        }
        if let Some(l) = live.as_deref_mut() {
            // Wake at least every 40 ms (or the control's poll) to show where the song is, and
            // at once when the control rings (a request); the last stretch before a send is one
            // precise wait, with nothing else in it.
            let mut stop = false;
            let mut replan = false;
            loop {
                let seen = control.map_or(0, |c| c.bell().rung());
                if control.is_some_and(Control::stopping) {
                    stop = true;
                    break;
                }
                if let Some(c) = control.filter(|c| c.paused()) {
                    // Every key up, score time held, until resumed (or stopped).
                    let at = clock.now_us().max(last_at);
                    release_all(&mut out, setup.link, at, &mut robot, &mut ledger)?;
                    last_at = at;
                    last_byte = Some(at);
                    burst = 0;
                    let song_us = planner.time_map().score(at as i64);
                    loop {
                        let seen = c.bell().rung();
                        if !c.paused() || c.stopping() {
                            break;
                        }
                        let now = clock.now_us();
                        clock.wait_until_rung(now + every, c.bell(), seen);
                        // The robot's own timers run on (a strike held for its shortest
                        // sounding press lets go now).
                        robot.advance(clock.now_us()).map_err(robot_err)?;
                        for d in robot.drain_decided() {
                            ledger.decided(d.t_us, d.event);
                        }
                        robot.drain_presses(|p| ledger.press(p));
                        l(&Live {
                            song_us: c.jump.pending(seen_jump).map_or(song_us, |j| j.0),
                            keys_down: robot.keys_down(),
                            notes_sent,
                            tempo: planner.time_map().tempo().get(),
                            paused: true,
                            stats: *robot.interpreter().stats(),
                        });
                    }
                    let now = clock.now_us().max(at);
                    planner.resume(at as i64, now as i64);
                    c.publish(*planner.time_map());
                    replan = true;
                    break;
                }
                if control.is_some_and(|c| {
                    c.tempo.pending(seen_tempo).is_some() || c.jump.pending(seen_jump).is_some()
                }) {
                    replan = true;
                    break;
                }
                let now = clock.now_us();
                if now + every >= due.0 {
                    if wait(clock, control, due.0, seen) {
                        continue;
                    }
                    break;
                }
                if wait(clock, control, now + every, seen) {
                    continue;
                }
                l(&Live {
                    // In a jump's lead-in, the target.
                    song_us: planner
                        .time_map()
                        .score(clock.now_us() as i64)
                        .max(pass_from),
                    keys_down: robot.keys_down(),
                    notes_sent,
                    tempo: planner.time_map().tempo().get(),
                    paused: false,
                    stats: *robot.interpreter().stats(),
                });
            }
            if stop {
                stopped_at = Some(clock.now_us().max(last_at));
                break;
            }
            if replan {
                continue;
            }
        } else if wait(clock, control, due.0, seen) {
            continue;
        }
        if poll {
            if let Out::Midi { out, .. } = &mut out {
                out.poll(due.0)
                    .map_err(|e| PerformError::Midi(Box::new(e)))?;
            }
            continue;
        }
        if due.1 {
            deliver(
                &mut out,
                setup.link,
                due.0,
                &[0xFE],
                None,
                &mut robot,
                &mut ledger,
            )?;
            last_byte = Some(due.0);
            continue;
        }
        let Some(p) = planner.next_planned() else {
            break;
        };
        burst = burst.saturating_sub(1);
        match p {
            Planned::Send {
                bytes,
                note,
                score_at_us,
                ..
            } => {
                if let Some(i) = note {
                    committed = Some(committed.map_or(i, |m| m.max(i)));
                }
                let note = note.map(|i| i + offset);
                if let (Some(id), Some((ch, n, v))) = (note, bytes.note_on()) {
                    ledger.score(id, ch, n, v, score_at_us);
                    notes_sent += 1;
                    let now = clock.now_us() as i64;
                    sent_ahead.retain(|&(_, at)| at > now);
                    sent_ahead.push((id, score_at_us));
                }
                let t = next.max(last_at);
                deliver(
                    &mut out,
                    setup.link,
                    t,
                    &bytes,
                    note,
                    &mut robot,
                    &mut ledger,
                )?;
                if let Some(l) = lateness.as_mut() {
                    l.push(clock.now_us().saturating_sub(t));
                }
                last_at = t;
                last_byte = Some(t);
            }
            Planned::Dropped {
                score_at_us,
                channel,
                note_number,
                velocity,
                note,
                reason,
                ..
            } => {
                committed = Some(committed.map_or(note, |m| m.max(note)));
                let note = note + offset;
                ledger.score(note, channel, note_number, velocity, score_at_us);
                ledger.dropped(note, reason);
            }
        }
    }
    // The song is over (or stopped). A key struck at its very end (a note with no Note-Off
    // before the end of the file) is still let sound: the end comes its shortest sounding
    // press after the last send. Then a robot that interprets MIDI itself is told to let go
    // of everything, on every channel.
    let settle = rules_min_hold(setup);
    let wire_busy = match &out {
        Out::Midi { wire, .. } => wire.free_at(),
        Out::Virtual => 0,
    };
    let end_at = match stopped_at {
        Some(t) => t.max(last_at),
        None => {
            let t = last_at.max(wire_busy) + settle;
            clock.wait_until(t);
            t
        }
    };
    if let Out::Midi { .. } = out {
        let t = end_at;
        for ch in 0..16u8 {
            deliver(
                &mut out,
                setup.link,
                t,
                &[0xB0 | ch, 123, 0],
                None,
                &mut robot,
                &mut ledger,
            )?;
        }
        if let Out::Midi { out, .. } = &mut out {
            out.finish(t).map_err(|e| PerformError::Midi(Box::new(e)))?;
        }
        last_at = t;
    }
    let wire_end = match &out {
        Out::Midi { wire, .. } => wire.free_at(),
        Out::Virtual => 0,
    };
    let drained = match stopped_at {
        Some(t) => robot.stop(t.max(wire_end)).map_err(robot_err)?,
        None => robot
            .drain(end_at.max(last_at).max(wire_end) + 1)
            .map_err(robot_err)?,
    };
    for d in robot.drain_decided() {
        ledger.decided(d.t_us, d.event);
    }
    robot.drain_presses(|p| ledger.press(p));
    let longest_release = (0..setup.config.keys())
        .map(|k| {
            setup
                .sim
                .mechanics
                .for_key(k as u8)
                .release_delay
                .as_micros() as u64
        })
        .max()
        .unwrap_or(0);
    let end = drained + longest_release + 1_000;
    let restrikes_waited = ledger.restrikes_waited();
    let (interp, performance) = robot.finish(end);
    let records = ledger.close(&performance.presses, notes + offset as usize);
    Ok(Played {
        records,
        performance,
        stats: *interp.stats(),
        plan: planner.stats(),
        lateness_us: lateness,
        start_us: start,
        end_us: end,
        restrikes_waited,
        stopped: stopped_at.is_some(),
        jumps,
        replayed: u64::from(offset),
        dynamic_keys: (0..setup.config.keys())
            .map(|k| !setup.config.dynamics.touch(k as u8).is_full())
            .collect(),
        extra_keys: (0..setup.config.keys())
            .map(|k| setup.config.strikes.is_extra(k as u8))
            .collect(),
    })
}

/// Waits for `until` on `clock`, or until `control` rings after `seen` rings: whether it
/// rang.
fn wait(clock: &mut dyn Clock, control: Option<&Control>, until: u64, seen: u64) -> bool {
    match control {
        Some(c) => clock.wait_until_rung(until, c.bell(), seen),
        None => {
            clock.wait_until(until);
            false
        }
    }
}

/// Lets every key go at `t`, on every channel: All Notes Off and All Sound Off (the pedal's
/// notes too).
fn release_all<M: MidiOut>(
    out: &mut Out<'_, M>,
    link: Link,
    t: u64,
    robot: &mut LocalRobot<SimBoards>,
    ledger: &mut Ledger,
) -> Result<(), PerformError> {
    for ch in 0..16u8 {
        for cc in [123, 120] {
            deliver(out, link, t, &[0xB0 | ch, cc, 0], None, robot, ledger)?;
        }
    }
    Ok(())
}

/// Hands one message to the robot side at `t`.
fn deliver<M: MidiOut>(
    out: &mut Out<'_, M>,
    link: Link,
    t: u64,
    bytes: &[u8],
    note: Option<u32>,
    robot: &mut LocalRobot<SimBoards>,
    ledger: &mut Ledger,
) -> Result<(), PerformError> {
    if let Some(id) = note {
        ledger.delivered(id, t);
    }
    match out {
        Out::Virtual => robot.feed(t, bytes).map_err(robot_err)?,
        Out::Midi { out, wire, status } => {
            let sent = status.compress(bytes);
            out.send(t, sent)
                .map_err(|e| PerformError::Midi(Box::new(e)))?;
            for &b in sent {
                let at = match link {
                    Link::Din => wire.arrivals(t, 1).next().unwrap_or(t),
                    Link::Direct => t,
                };
                robot.feed(at, &[b]).map_err(robot_err)?;
            }
        }
    }
    for d in robot.drain_decided() {
        ledger.decided(d.t_us, d.event);
    }
    robot.drain_presses(|p| ledger.press(p));
    Ok(())
}

/// A DIN line carries one byte every 320 µs, so the messages of a chord arrive one after
/// another. The planner sends each note message early by two bytes (its length under running
/// status); here the head of the queue and the final sends that would queue behind it on the
/// line go out as one burst, started so that their arrivals are centred on the head's time:
/// for a lone message, early by its own length; for a 10-note chord (21 bytes, 6.7 ms), the
/// first arrives about 3 ms early and the last about 3 ms late. Returns the burst's send time
/// and how many sends it holds.
fn din_burst(finals: &[&Planned], mut status: RunningStatus) -> (i64, usize) {
    let byte = Link::DIN_BYTE_US as i64;
    let Some(head) = finals.first() else {
        return (0, 0);
    };
    let t0 = head.at_us();
    let target = t0 + Link::Din.note_lead_us() as i64;
    let (mut cum, mut sum, mut members, mut sends) = (0i64, 0i64, 0usize, 0i64);
    for p in finals {
        if let Planned::Send { at_us, bytes, .. } = p {
            if members > 0 && *at_us >= t0 + cum * byte {
                break;
            }
            cum += status.compress(bytes).len() as i64;
            sum += cum;
            sends += 1;
        }
        members += 1;
    }
    let mean_arrival = if sends > 0 { sum * byte / sends } else { 0 };
    (target - mean_arrival, members.max(1))
}

/// The longest shortest-sounding press of any key, with the bus's margin: how long the end of
/// a song waits so that a key struck last still sounds.
fn rules_min_hold(setup: &Setup) -> u64 {
    setup.rules().min_hold_us.into_iter().max().unwrap_or(0)
}
