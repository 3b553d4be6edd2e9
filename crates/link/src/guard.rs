//! After the session stops: undoing an announcement that crossed the stop.
//!
//! A playing orch peer says now and then that the session plays (see
//! [`announce`](crate::announce)). The SDK keeps whichever start/stop state was committed
//! last, on any peer. So a peer that announces between another peer's stop and the moment
//! that stop reaches it has committed "playing" after the stop: its announcement wins
//! everywhere, and the session plays on, from its old start, with nobody there to stop it
//! (seen in two CI runs of `tests/link.rs`: a conductor stopped the session, and one robot
//! played on). That window is some ms: the network's delay, and up to 50 ms more when the
//! stopping peer's SDK had sent anything in the last 50 ms (it sends a peer's changes at most
//! that often). So each robot announcing once a second crosses about one stop in a couple of
//! hundred, more on a busy host (none in 16 runs of that test on an idle machine).
//!
//! Such a state is easy to tell from a real start: it plays since a moment *before* the stop
//! (the start it announced again), while a peer that starts the session after a stop starts it
//! at its own now, or later. So every orch peer that saw the session stop under its
//! performance keeps a [`StopGuard`] for a while ([`GUARD_US`]): a "playing" whose start lies
//! before the stop it saw is stopped again ([`Watch::Restop`]); a real start ends the guard.
//! The peer whose announcement crossed the stop never saw the stop (the SDK drops a state
//! older than its own), so it is the others' guards that stop it: the peer that stopped the
//! session (a conductor, `orch serve`'s page) and every robot that heard the stop. A session
//! stopped by another app (a DAW) with a single orch robot in it has nobody to guard it: the
//! chance there is that window over the second between two announcements: about one stop in
//! a couple of hundred.

use crate::announce::REANCHOR_US;
use crate::timeline::Timeline;

/// How long a peer guards the stop it saw, µs: an announcement that crossed the stop reaches
/// it within the network's delay, or a few of Link's rebroadcasts (every 250 ms) if lost.
pub const GUARD_US: i64 = 1_000_000;

/// The longest a guard lasts, µs from its beginning, however many announcements it undoes.
pub const GUARD_MAX_US: i64 = 10_000_000;

/// What a look at the session finds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Watch {
    /// Stopped: nothing to do.
    Quiet,
    /// Playing again since before the stop: an announcement that crossed it. Stop the session
    /// again.
    Restop,
    /// The guard is over: its time has passed, or the session was started again for real.
    Over,
}

/// A peer's watch over a stop it saw; see the [module notes](self).
///
/// ```
/// use orch_link::{Line, StopGuard, Watch};
///
/// // A session that stopped at host time 10 s (beat 20 at 120 BPM).
/// let mut session = Line { bpm: 120.0, at_us: 0, beat: 0.0, playing: false, started_beat: 20.0 };
/// let mut guard = StopGuard::after(&session, 10_001_000);
/// assert_eq!(guard.look(&session, 10_002_000), Watch::Quiet);
/// // An announcement that crossed the stop: playing since beat 4 (host time 2 s).
/// session.playing = true;
/// session.started_beat = 4.0;
/// assert_eq!(guard.look(&session, 10_010_000), Watch::Restop);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StopGuard {
    /// The moment of the stop, host µs.
    stopped_at: i64,
    /// When the guard ends, host µs.
    until: i64,
    /// Never later than this, host µs.
    last: i64,
}

impl StopGuard {
    /// A guard over the stop that `stopped` (the session as it was seen stopped) shows, seen
    /// at host time `now_us`.
    pub fn after(stopped: &impl Timeline, now_us: i64) -> Self {
        Self::at(stopped.started_at(), now_us)
    }

    /// A guard over a stop at host time `stopped_at` (the moment a stop committed here
    /// gave), from host time `now_us`. A stop set for a later moment (an app may stop at the
    /// next bar line) is guarded from now: a real start may come before that moment.
    pub fn at(stopped_at: i64, now_us: i64) -> Self {
        let stopped_at = stopped_at.min(now_us);
        Self {
            stopped_at,
            until: now_us + GUARD_US,
            last: now_us + GUARD_MAX_US,
        }
    }

    /// One look at the session, `timeline`, at host time `now_us`. After a
    /// [`Watch::Restop`] (the session was stopped again) the guard goes on for another
    /// [`GUARD_US`].
    pub fn look(&mut self, timeline: &impl Timeline, now_us: i64) -> Watch {
        if now_us >= self.until {
            return Watch::Over;
        }
        if !timeline.is_playing() {
            return Watch::Quiet;
        }
        // A start up to a few µs before the stop may be the stop's own moment, seen through
        // another host's clock; a real start is at the starter's now, after it heard of the
        // stop.
        if timeline.started_at() + REANCHOR_US < self.stopped_at {
            self.until = (now_us + GUARD_US).min(self.last);
            Watch::Restop
        } else {
            self.until = now_us;
            Watch::Over
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::timeline::Line;

    /// A session at 120 BPM (beat 0 at host time 0) that played since beat 8 (4 s) and
    /// stopped at beat 40 (20 s).
    fn stopped() -> Line {
        Line {
            bpm: 120.0,
            at_us: 0,
            beat: 0.0,
            playing: false,
            started_beat: 40.0,
        }
    }

    fn playing_since(beat: f64) -> Line {
        Line {
            playing: true,
            started_beat: beat,
            ..stopped()
        }
    }

    #[test]
    fn a_session_that_stays_stopped_is_watched_until_the_guard_ends() {
        let mut g = StopGuard::after(&stopped(), 20_000_500);
        for now in (20_000_500..21_000_500).step_by(2_000) {
            assert_eq!(g.look(&stopped(), now), Watch::Quiet, "at {now}");
        }
        assert_eq!(g.look(&stopped(), 21_000_500), Watch::Over);
    }

    #[test]
    fn playing_again_since_before_the_stop_is_stopped_again_and_watched_longer() {
        let mut g = StopGuard::after(&stopped(), 20_001_000);
        // The crossed announcement: the old start, a µs off.
        let crossed = Line {
            at_us: 1,
            ..playing_since(8.0)
        };
        assert_eq!(g.look(&crossed, 20_900_000), Watch::Restop);
        // Stopped again (at 20.9 s): quiet, and guarded a second from the restop.
        let again = Line {
            started_beat: 41.8,
            ..stopped()
        };
        assert_eq!(g.look(&again, 21_500_000), Watch::Quiet);
        // A second crossing, later: stopped again too.
        assert_eq!(g.look(&crossed, 21_800_000), Watch::Restop);
        assert_eq!(g.look(&again, 22_700_000), Watch::Quiet);
        assert_eq!(g.look(&again, 22_800_000), Watch::Over);
    }

    #[test]
    fn a_real_start_after_the_stop_ends_the_guard() {
        let mut g = StopGuard::after(&stopped(), 20_001_000);
        // Another peer starts the session half a second after the stop.
        assert_eq!(g.look(&playing_since(41.0), 20_500_000), Watch::Over);
        // And stays over, even if the old start came back afterwards.
        assert_eq!(g.look(&playing_since(8.0), 20_600_000), Watch::Over);
    }

    #[test]
    fn a_start_at_the_stop_seen_through_another_clock_is_a_real_start() {
        let mut g = StopGuard::after(&stopped(), 20_001_000);
        // Started at the stop's own moment, as another host converts it: 3 µs early.
        let start = Line {
            at_us: -3,
            ..playing_since(40.0)
        };
        assert_eq!(g.look(&start, 20_002_000), Watch::Over);
    }

    #[test]
    fn a_stop_set_for_a_later_bar_line_is_guarded_from_when_it_was_seen() {
        // Stopped for beat 48 (24 s), seen at 20 s; another peer starts it again at 20.5 s.
        let later = Line {
            started_beat: 48.0,
            ..stopped()
        };
        let mut g = StopGuard::after(&later, 20_000_000);
        assert_eq!(g.look(&playing_since(41.0), 20_500_000), Watch::Over);
        // While the old start played again is still stopped again.
        let mut g = StopGuard::after(&later, 20_000_000);
        assert_eq!(g.look(&playing_since(8.0), 20_500_000), Watch::Restop);
    }

    #[test]
    fn a_guard_that_keeps_stopping_ends_after_its_longest() {
        let mut g = StopGuard::after(&stopped(), 20_001_000);
        let mut now = 20_001_000;
        let mut restops = 0;
        while g.look(&playing_since(8.0), now) == Watch::Restop {
            restops += 1;
            now += 500_000;
        }
        // Every half second from the stop, until 10 s after it.
        assert_eq!(restops, 20);
        assert!(now >= 20_000_000 + GUARD_MAX_US);
    }
}
