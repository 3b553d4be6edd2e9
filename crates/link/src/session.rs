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
//! sends it), which changes nothing for those that knew, and tells the newcomer; three times,
//! half a second apart, in case a datagram is lost. A session
//! played only by other apps (a DAW alone) is not announced again: there a newcomer waits
//! for the next start.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use orch_perform::Control;
use rusty_link::{AblLink, SessionState};

use crate::steer::{Steer, Step};
use crate::timeline::Timeline;

/// How often the session is looked at, while waiting and while following.
pub const LOOK_EVERY: Duration = Duration::from_millis(2);

/// How many times a newcomer is told that the session plays, and how far apart.
pub const ANNOUNCEMENTS: u32 = 3;
/// See [`ANNOUNCEMENTS`].
pub const ANNOUNCE_EVERY: Duration = Duration::from_millis(500);

/// How long a peer listens for a session before `--start` starts one: Link's discovery
/// answers within a few hundred ms on a LAN.
pub const DISCOVERY: Duration = Duration::from_millis(1_000);

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
    /// The last announcement's nudge (±1 µs), so that each one is a change the SDK sends.
    nudge: std::sync::atomic::AtomicI64,
}

impl Session {
    /// Joins (or founds) the session on every network interface, with start/stop sync. A
    /// session found keeps its tempo: `bpm` is the tempo of a session founded here.
    pub fn join(bpm: f64) -> Self {
        let link = AblLink::new(bpm);
        link.enable_start_stop_sync(true);
        link.enable(true);
        Self {
            link,
            nudge: 1.into(),
        }
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

    /// Stops the session.
    pub fn stop(&self) {
        self.commit(|s, now| s.set_is_playing(false, now));
    }

    /// Sets the session's tempo from now (the beat now stays where it is).
    pub fn set_tempo(&self, bpm: f64) {
        self.commit(|s, now| s.set_tempo(bpm, now));
    }

    /// Says again that the session plays, since the moment it began (see the [module
    /// notes](self)); nothing if it does not play.
    pub fn announce(&self) {
        let nudge = -self.nudge.fetch_neg();
        self.commit(|s, _| {
            if s.is_playing() {
                s.set_is_playing(true, s.time_for_is_playing() + nudge);
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
    /// [`DISCOVERY`] has passed. Whether it plays (false: `give_up` was set first).
    pub fn wait_playing(&self, start: bool, give_up: &AtomicBool) -> bool {
        let began = Instant::now();
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

trait FetchNeg {
    fn fetch_neg(&self) -> i64;
}

impl FetchNeg for std::sync::atomic::AtomicI64 {
    /// Negates the value, returning the old one.
    fn fetch_neg(&self) -> i64 {
        let mut old = self.load(Ordering::SeqCst);
        while let Err(v) = self.compare_exchange(old, -old, Ordering::SeqCst, Ordering::SeqCst) {
            old = v;
        }
        old
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
/// the session stops; announces the session to each newcomer ([`ANNOUNCEMENTS`] times).
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
        let mut peers = session.peers();
        // Announcements still to make, and when the last was: a newcomer is told three
        // times, half a second apart, in case one is lost.
        let (mut to_announce, mut announced_at) = (0, Instant::now());
        while !flag.load(Ordering::SeqCst) && !control.stopping() {
            thread::sleep(LOOK_EVERY);
            let now_peers = session.peers();
            if now_peers > peers {
                to_announce = ANNOUNCEMENTS;
            }
            peers = now_peers;
            if to_announce > 0 && announced_at.elapsed() >= ANNOUNCE_EVERY {
                session.announce();
                followed.announced += 1;
                to_announce -= 1;
                announced_at = Instant::now();
            }
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
                }
            }
        }
        followed
    });
    Following { done, thread }
}
