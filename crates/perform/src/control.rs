//! Steering a performance from another thread: stop, pause, resume, tempo, jump.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use orch_seq::Bell;

use crate::tempo::{Tempo, TimeMap};
use crate::time::{ScoreTime, WallTime};

/// How often a live performance tells where it stands (25 times a second).
pub(crate) const SHOW_EVERY_US: u64 = 40_000;

/// A jump asked: its target, and for a start over, when it was asked.
pub(crate) type Jump = (ScoreTime, Option<WallTime>);

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
    poll_us: AtomicU64,
    pub(crate) tempo: Asked<Tempo>,
    pub(crate) jump: Asked<Jump>,
    map: Mutex<Option<TimeMap>>,
    start_at: Mutex<Option<WallTime>>,
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

    pub(crate) fn poll_us(&self) -> u64 {
        match self.poll_us.load(Ordering::SeqCst) {
            0 => SHOW_EVERY_US,
            us => us,
        }
    }

    /// Whether a stop was asked.
    pub fn stopping(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }

    /// Pause (with a live view: see [`Performer::live`](crate::Performer::live)): every key is released at once (All Notes
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
        self.jump.ask((ScoreTime::from_micros(score_us), None));
        self.bell.ring();
    }

    /// Play from the top (a conductor's Start), asked at wall time `asked_at_us` on the
    /// performer's clock: a [`jump_to`](Self::jump_to) the top and a
    /// [`resume`](Self::resume), unless at `asked_at_us` the performance had not got past the
    /// point its present pass began at (the top, or the last jump's target): then it only
    /// resumes (a Start that comes as the performance begins does not play its first notes
    /// twice).
    pub fn start_over(&self, asked_at_us: u64) {
        self.jump
            .ask((ScoreTime::ZERO, Some(WallTime::from_micros(asked_at_us))));
        self.resume();
    }

    /// The performance's score ↔ wall time map as it stands (`None` before it starts): where
    /// the score is at any moment, for a follower that pulls the phase toward a beat.
    pub fn time_map(&self) -> Option<TimeMap> {
        *self.map.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Start at a moment given, not as soon as the robot is ready: the performance's first
    /// place (score time 0, or the target of a jump asked before it starts, such as
    /// `--from`) plays at wall time `at` on the performer's clock, its first notes sent
    /// early by their leads as always. Asked before the performance starts (it is read once,
    /// there); a moment too soon for the robot's setup and the planner's lookahead is taken
    /// as soon as possible ([`TimeMap::wall_at`] says when). A session shared with other
    /// hosts (Ableton Link) starts every robot on one bar line this way.
    pub fn start_at(&self, at: WallTime) {
        *self.start_at.lock().unwrap_or_else(|e| e.into_inner()) = Some(at);
    }

    /// The start asked with [`start_at`](Self::start_at), if any.
    pub(crate) fn asked_start(&self) -> Option<WallTime> {
        *self.start_at.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub(crate) fn publish(&self, map: TimeMap) {
        *self.map.lock().unwrap_or_else(|e| e.into_inner()) = Some(map);
    }
}

/// A request to every performance that shares a control (one per robot): each takes the
/// latest one it has not seen, by its number.
#[derive(Debug, Default)]
pub(crate) struct Asked<T> {
    latest: Mutex<(u64, Option<T>)>,
}

impl<T: Copy> Asked<T> {
    pub(crate) fn ask(&self, value: T) {
        let mut l = self.latest.lock().unwrap_or_else(|e| e.into_inner());
        *l = (l.0 + 1, Some(value));
    }

    /// The latest request not seen yet (`seen` is the number of the last one seen).
    pub(crate) fn pending(&self, seen: u64) -> Option<T> {
        let l = self.latest.lock().unwrap_or_else(|e| e.into_inner());
        l.1.filter(|_| l.0 > seen)
    }

    /// [`pending`](Self::pending), marked seen.
    pub(crate) fn take(&self, seen: &mut u64) -> Option<T> {
        let l = self.latest.lock().unwrap_or_else(|e| e.into_inner());
        let v = l.1.filter(|_| l.0 > *seen);
        *seen = l.0;
        v
    }
}
