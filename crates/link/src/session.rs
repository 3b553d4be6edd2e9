//! The session itself (the `abl` feature): Ableton's own Link SDK through `rusty_link`
//! (GPL-2.0-or-later: a binary built with this module is distributed under the GPL).
//!
//! [`Session::join`] enables Link with start/stop sync; [`Session::wait_playing`] waits for
//! the session to play (or starts it, asked to); [`follow`] keeps a performance on the
//! session's beat from a thread of its own until the performance ends or the session stops.
//!
//! **A peer that joins a session already playing.** The SDK tells a joining peer the
//! session's tempo and beat at once, but not that it plays: a peer learns the start/stop
//! state only when it changes (checked: a `rusty_link` peer joining a playing session sees it
//! stopped for as long as nobody starts or stops it). Ableton's test plan forbids the way
//! round that a joining peer could take (starting the session itself would start a stopped
//! one). So every orch peer that plays **announces** the state again when it sees the number
//! of peers grow: it commits "playing since the same moment" (one µs apart, so that the SDK
//! sends it, and never farther: see [`announce`](crate::announce)), which changes nothing for
//! those that knew, and tells the newcomer; and again every second while it plays, as a
//! newcomer on a lossy network may take seconds to join. A session played only by other apps
//! (a DAW alone) is not announced again: there a newcomer waits for the next start.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use orch_perform::Control;
use rusty_link::{AblLink, SessionState};

use crate::announce::Anchor;
use crate::guard::{StopGuard, Watch};
use crate::lead::{bar_line_after, Lead, Publish};
use crate::steer::{Steer, Step};
use crate::timeline::Timeline;
use crate::{LEAD_IN_BEATS, LEAD_IN_MARGIN};

/// How often the session is looked at, while waiting and while following.
pub const LOOK_EVERY: Duration = Duration::from_millis(2);

/// How often a playing robot says again that the session plays (besides at once when a peer
/// joins): a newcomer takes no announcement before it has joined the session, which on a lossy
/// network may take seconds.
pub const ANNOUNCE_EVERY: Duration = Duration::from_millis(1_000);

/// How long a peer listens for a session before `--start` starts one: Link's discovery
/// answers within a few hundred ms on a LAN.
pub const DISCOVERY: Duration = Duration::from_millis(1_000);

/// How long a waiting peer may find no other peer in its session before
/// [`Session::wait_playing`] says so: in `tests/link.rs`, through lost packets, robots found
/// the session within about a second.
pub const ALONE_AFTER: Duration = Duration::from_secs(5);

/// Where Link's discovery goes: every peer sends its state to these multicast groups, on
/// this UDP port (Ableton's SDK, `discovery/IpInterface.hpp`).
pub const DISCOVERY_GROUP: &str = "224.76.78.75 (IPv6: ff12::8080), UDP port 20808";

/// One capture of the session's state.
pub struct Captured(SessionState);

impl Timeline for Captured {
    fn tempo(&self) -> f64 {
        self.0.tempo()
    }

    fn beat_at(&self, host_us: i64, quantum: f64) -> f64 {
        self.0.beat_at_time(host_us, quantum)
    }

    fn time_at(&self, beat: f64, quantum: f64) -> i64 {
        self.0.time_at_beat(beat, quantum)
    }

    fn is_playing(&self) -> bool {
        self.0.is_playing()
    }

    fn started_at(&self) -> i64 {
        self.0.time_for_is_playing()
    }
}

/// This host's peer in a Link session.
pub struct Session {
    link: AblLink,
}

impl Session {
    /// Joins (or founds) the session on every network interface, with start/stop sync. A
    /// session found keeps its tempo: `bpm` is the tempo of a session founded here.
    pub fn join(bpm: f64) -> Self {
        let link = AblLink::new(bpm);
        link.enable_start_stop_sync(true);
        link.enable(true);
        Self { link }
    }

    /// Now, µs on the session's host clock.
    pub fn host_us(&self) -> i64 {
        self.link.clock_micros()
    }

    /// The session's state now.
    pub fn capture(&self) -> Captured {
        let mut s = SessionState::new();
        self.link.capture_app_session_state(&mut s);
        Captured(s)
    }

    /// The other peers in the session.
    pub fn peers(&self) -> u64 {
        self.link.num_peers()
    }

    /// Starts the session playing now (the beat goes on where it is).
    pub fn start(&self) {
        self.commit(|s, now| s.set_is_playing(true, now));
    }

    /// Stops the session; the moment it stopped at, host µs (for a [`StopGuard`]).
    pub fn stop(&self) -> i64 {
        let mut at = 0;
        self.commit(|s, now| {
            s.set_is_playing(false, now);
            at = now;
        });
        at
    }

    /// Keeps `guard` over a stop: looks every [`LOOK_EVERY`] until the guard is over, and
    /// stops the session again whenever an announcement that crossed the stop has it playing
    /// again (see [`guard`](crate::guard)). The times it stopped it again. Meanwhile the
    /// stop's news goes out: the process may end once this returns.
    pub fn guard_stop(&self, mut guard: StopGuard) -> u64 {
        let mut restops = 0;
        loop {
            match guard.look(&self.capture(), self.host_us()) {
                Watch::Quiet => {}
                Watch::Restop => {
                    self.stop();
                    restops += 1;
                }
                Watch::Over => return restops,
            }
            thread::sleep(LOOK_EVERY);
        }
    }

    /// Sets the session's tempo from now (the beat now stays where it is).
    pub fn set_tempo(&self, bpm: f64) {
        self.commit(|s, now| s.set_tempo(bpm, now));
    }

    /// Starts the session for a performance that leads it (see [`lead`]): at `bpm`, playing
    /// from the first bar line at least `lead_us` from now, so that every peer finds that bar
    /// line for bar one ([`bar_one`](crate::bar_one)). Returns that bar line, host µs and
    /// beat.
    pub fn start_leading(&self, bpm: f64, lead_us: i64, quantum: f64) -> (i64, f64) {
        self.set_tempo(bpm);
        let now = self.host_us();
        let timeline = self.capture();
        let (at, beat) = bar_line_after(&timeline, now, lead_us, quantum);
        let start = timeline.time_at(beat - LEAD_IN_BEATS - LEAD_IN_MARGIN, quantum);
        self.commit(|s, _| s.set_is_playing(true, start));
        (at, beat)
    }

    /// Forces the session's beat to `beat` at host time `at`, at `bpm`: a leader's
    /// correction (every peer's beat moves).
    pub fn force_beat(&self, bpm: f64, beat: f64, at: i64, quantum: f64) {
        self.commit(|s, _| {
            s.set_tempo(bpm, at);
            s.force_beat_at_time(beat, at, quantum);
        });
    }

    /// Says again that the session plays, since the moment it began, as `anchor` keeps it
    /// (see the [module notes](self)); nothing if it does not play.
    pub fn announce(&self, anchor: &mut Anchor) {
        self.commit(|s, _| {
            if s.is_playing() {
                s.set_is_playing(true, anchor.announce(s.time_for_is_playing()));
            }
        });
    }

    fn commit(&self, change: impl FnOnce(&mut SessionState, i64)) {
        let mut s = SessionState::new();
        self.link.capture_app_session_state(&mut s);
        change(&mut s, self.link.clock_micros());
        self.link.commit_app_session_state(&s);
    }

    /// Waits until the session plays; with `start`, starts it if it does not play once
    /// [`DISCOVERY`] has passed. Calls `alone` once if no other peer has joined this one's
    /// session after [`ALONE_AFTER`]. Whether it plays (false: `give_up` was set first).
    pub fn wait_playing(&self, start: bool, give_up: &AtomicBool, mut alone: impl FnMut()) -> bool {
        let began = Instant::now();
        let mut told = false;
        loop {
            if self.capture().is_playing() {
                return true;
            }
            if give_up.load(Ordering::SeqCst) {
                return false;
            }
            if start && began.elapsed() >= DISCOVERY {
                self.start();
            }
            if !told && began.elapsed() >= ALONE_AFTER && self.peers() == 0 {
                alone();
                told = true;
            }
            thread::sleep(LOOK_EVERY);
        }
    }

    /// Now on both clocks, read together: (host µs, µs since `origin`).
    pub fn now_pair(&self, origin: Instant) -> (i64, i64) {
        let before = self.host_us();
        let wall = i64::try_from(origin.elapsed().as_micros()).unwrap_or(i64::MAX);
        let after = self.host_us();
        (before + (after - before) / 2, wall)
    }
}

/// Tells newcomers that the session plays: at once when the number of peers grows, and
/// again every [`ANNOUNCE_EVERY`] while it plays, so a newcomer that took its time to join (a
/// lossy network) or missed one hears it within that.
struct Announcer {
    peers: u64,
    announced_at: Instant,
    anchor: Anchor,
}

impl Announcer {
    fn new(session: &Session) -> Self {
        Self {
            peers: session.peers(),
            announced_at: Instant::now(),
            anchor: Anchor::at(session.capture().started_at()),
        }
    }

    /// Announces if a newcomer is owed one now: the announcements made (0 or 1).
    fn look(&mut self, session: &Session) -> u64 {
        let peers = session.peers();
        let grew = peers > self.peers;
        self.peers = peers;
        if !grew && self.announced_at.elapsed() < ANNOUNCE_EVERY {
            return 0;
        }
        session.announce(&mut self.anchor);
        self.announced_at = Instant::now();
        1
    }
}

/// What following the session did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Followed {
    /// Tempo factors set.
    pub tempos: u64,
    /// Jumps (the session's beat jumped).
    pub jumps: u64,
    /// Announcements to newcomers.
    pub announced: u64,
    /// Whether the session stopped the performance.
    pub stopped_by_session: bool,
    /// Times this peer stopped the session again, after it stopped: an announcement that
    /// crossed the stop had it playing (see [`guard`](crate::guard)).
    pub restops: u64,
}

/// A thread keeping a performance on the session's beat. [`finish`](Self::finish) ends it.
pub struct Following {
    done: Arc<AtomicBool>,
    thread: JoinHandle<Followed>,
}

impl Following {
    /// Ends the following (the performance ended) and says what it did.
    pub fn finish(self) -> Followed {
        self.done.store(true, Ordering::SeqCst);
        self.thread.join().unwrap_or_default()
    }
}

/// Keeps the performance that `control` steers (its clock's zero at `origin`) on the
/// session's beat as `steer` says, looking every [`LOOK_EVERY`]; stops it, every key up, when
/// the session stops, and then guards that stop (see [`guard`](crate::guard)) before it
/// ends; announces the session to newcomers (see [`ANNOUNCE_EVERY`]).
pub fn follow(
    session: Arc<Session>,
    control: Arc<Control>,
    origin: Instant,
    steer: Steer,
) -> Following {
    let done = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&done);
    let thread = thread::spawn(move || {
        let mut followed = Followed::default();
        let mut announcer = Announcer::new(&session);
        let mut guard = None;
        while !flag.load(Ordering::SeqCst) && !control.stopping() {
            thread::sleep(LOOK_EVERY);
            followed.announced += announcer.look(&session);
            let Some(map) = control.time_map() else {
                continue;
            };
            let timeline = session.capture();
            let (host, wall) = session.now_pair(origin);
            match steer.step(&timeline, host, wall, &map) {
                Step::Hold => {}
                Step::Tempo(t) => {
                    control.set_tempo(t);
                    followed.tempos += 1;
                }
                Step::Jump(score_us) => {
                    control.jump_to(score_us);
                    followed.jumps += 1;
                }
                Step::Stop => {
                    control.stop();
                    followed.stopped_by_session = true;
                    guard = Some(StopGuard::after(&timeline, host));
                }
            }
        }
        if let Some(guard) = guard {
            followed.restops = session.guard_stop(guard);
        }
        followed
    });
    Following { done, thread }
}

/// What leading the session did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Led {
    /// Tempos published.
    pub tempos: u64,
    /// Beats forced.
    pub beats: u64,
    /// Announcements to newcomers.
    pub announced: u64,
    /// Times the session was stopped again after the leader's stop (see
    /// [`guard`](crate::guard)).
    pub restops: u64,
}

/// A thread telling the session where a performance stands. [`finish`](Self::finish) ends it
/// and stops the session.
pub struct Leading {
    done: Arc<AtomicBool>,
    thread: JoinHandle<Led>,
}

impl Leading {
    /// Ends the leading (the performance ended) and stops the session: every robot stops.
    /// Returns once the stop has been guarded (see [`guard`](crate::guard)): about a second.
    pub fn finish(self) -> Led {
        self.done.store(true, Ordering::SeqCst);
        self.thread.join().unwrap_or_default()
    }
}

/// Publishes the tempo and phase of the performance that `control` steers (its clock's zero
/// at `origin`) to the session as `lead` says, every [`LOOK_EVERY`], until
/// [`Leading::finish`]; then stops the session and guards the stop. Announces the session to
/// each newcomer.
pub fn lead(
    session: Arc<Session>,
    control: Arc<Control>,
    origin: Instant,
    lead: Lead,
    quantum: f64,
) -> Leading {
    let done = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&done);
    let thread = thread::spawn(move || {
        let mut led = Led::default();
        let mut announcer = Announcer::new(&session);
        while !flag.load(Ordering::SeqCst) {
            thread::sleep(LOOK_EVERY);
            led.announced += announcer.look(&session);
            let Some(map) = control.time_map() else {
                continue;
            };
            let timeline = session.capture();
            let (host, wall) = session.now_pair(origin);
            match lead.step(&timeline, host, wall, &map) {
                Publish::Nothing => {}
                Publish::Tempo(bpm) => {
                    session.commit(|s, _| s.set_tempo(bpm, host));
                    led.tempos += 1;
                }
                Publish::Beat(bpm, beat) => {
                    session.force_beat(bpm, beat, host, quantum);
                    led.beats += 1;
                }
            }
        }
        let at = session.stop();
        // The guard also keeps the session open while the SDK sends the stop from a thread of
        // its own (seen: a leader that left at once left robots on other hosts playing).
        led.restops = session.guard_stop(StopGuard::at(at, session.host_us()));
        led
    });
    Leading { done, thread }
}
