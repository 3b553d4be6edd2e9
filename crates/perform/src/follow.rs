//! The follower: a conductor's cues in, tempo changes of the performance out.
//!
//! Every source's beats go through the same rule ([`Meter`]): only beat times count (the
//! ictus, the time the source gives for the beat, not the time it was recognised, which may
//! be two video frames later), and the tempo is measured from them here, not by the source.
//! A tempo the conductor states (`/orch/tempo`, `/orch/beat BPM`) is taken at its word.
//!
//! - **The rate** is the period the meter expects next: an in-time beat updates it (the
//!   trend of the last intervals), a sustained change makes it jump at the change's second
//!   beat, a single odd interval (an invented, missed or late beat, a fermata) leaves it.
//! - **The phase** (phase-following only): each beat taken is matched to a quarter note of
//!   the score by counting (the first beat, and a restart, to the nearest quarter; then one
//!   quarter a beat, two or three over missed beats), so a performance that a change has
//!   left more than half a beat behind or ahead is not matched to the wrong quarter. The
//!   error `e` (beats, positive: the performance is ahead) is made up over the next beat: the
//!   factor is set so that at the next expected beat the performance stands `e − pull`
//!   from its quarter, with `pull = gain × e` limited to ±`limit`. The factor is computed from
//!   the moment the cue arrived to the next expected beat, so a beat recognised late (the
//!   baton's) is made up all the same.
//!
//! How fast the phase is pulled: a one-beat error (noise, a single late beat) is halved each
//! beat, at most [`PHASE_LIMIT`] (0.15) of a beat a beat. A **consistent** error (the same
//! sign as the last beat's, or the error a confirmed change of tempo left) is made up whole
//! over the next beat as far as [`PHASE_CATCH_UP`] allows: the performance's beat may then
//! last from 0.76 to 1.24 of the conductor's (as the follower has it: the rate), so no beat of
//! it is longer or shorter than that by as much as a sixteenth note (0.25 beat). That makes up
//! to 0.32 of a beat when behind and 0.19 when ahead in one beat (0.15 before). No pull, at a
//! beat or between beats, takes a beat of the performance past those limits.
//!
//! **Between beats** ([`due`](Follower::due), [`wake`](Follower::wake): the front end wakes
//! the follower when it asks, on the performer's clock, as `orch conduct` does), phase-following
//! only:
//!
//! - An **early** odd beat (an invented beat, or a speeding up not yet confirmed) finds the
//!   performance behind it. While a beat in time with the last one taken may still come (up
//!   to 1.12 period after it, plus the delay with which the last cues came after their beats),
//!   it may be an invented beat, which may move no note by more than 25 ms: the performance
//!   only hedges toward it, [`HEDGE_US`] (15 ms) at the pace of a consistent error. Once that
//!   moment has passed with no beat, the early beat was a real one: the performance catches
//!   it up as fast as a consistent error, until it stands where the conductor is at least (the
//!   early beat's quarter, and the old tempo from there). The rate stays: a single interval is
//!   still not a new tempo; the next beat confirms the change (the rate jumps) or not.
//! - A beat **overdue** (none by 1.12 period after the last taken: a missed beat, a slowing
//!   down, a fermata): a hedge, 15 ms slower (a missed beat's next beat then finds the notes
//!   15 ms late, and pulls them back). A **late** odd beat (more than a period late, less than
//!   two: a slowing down not yet confirmed) finds the performance ahead of it: it waits for the
//!   conductor, as far as one beat may stretch (1.24 of the conductor's). A very late one (a
//!   fermata) moves nothing more; the beat after a fermata is a restart, its error a one-beat
//!   error.
//! - A hedge or a pull that has made up its share goes back to the rate.
//!
//! **How soon an abrupt change is followed** (every note within 25 ms of its beat; the change's
//! first beat is its 1st, the last at the old tempo its 0th). Faster, 100 → 130 BPM (beats of
//! 600 ms become 461.5): the 1st beat may be an invented one until 672 ms, so the note there
//! comes at 575 ms at the earliest, 113 ms late (here 123); from 672 ms the performance may
//! play a quarter in 0.75 × 600 ms at the fastest, so at the 2nd beat (923 ms) it stands at
//! 1.72 quarters at most and its note comes 97 ms late at least (here 108); the **3rd** is
//! reached (0 ms). Slower, 130 → 90 BPM (461.5 ms become 666.7): the 3rd and the 4th beats
//! cannot be reached by any follower within the rules, whatever its constants (a beat's
//! sixteenth measured against the tempo the follower holds, the old one until two intervals
//! agree: against the single odd interval it would be taking that interval for the tempo).
//! Before 461.5 ms it cannot tell this from the steady tempo, whose beat there must find its
//! note within 25 ms; from then until the 1st beat (666.7 ms) a beat may at most stretch to
//! 1.25 of the conductor's (0.2 ms a ms): the performance stands at least 66 ms short of the old
//! tempo's 1.445 quarters there, at 1.301. That beat is one odd interval: the rate stays 130
//! until the 2nd beat (1333 ms), a quarter lasts 1.25 × 461.5 = 577 ms at the slowest, so the
//! performance stands at 2.457 quarters at least there (the conductor at 2). At 90 a quarter
//! lasts 1.25 × 666.7 = 833 ms at the slowest: the performance reaches quarter 3 by 1786 ms,
//! 214 ms before the 3rd beat, and quarter 4 by 2619 ms, **47 ms before the 4th**. The 5th is
//! the first that can be reached, and is (0 ms; here 317 and 157 ms early at the 3rd and 4th,
//! with the constants above). Reaching the 3rd would take the single 1.44-period interval as
//! the new tempo, or a beat stretched to far past a sixteenth.

use std::collections::VecDeque;

use crate::conduct::{Action, Cue, ScoreBeats, Timed};
use crate::meter::{Heard, Meter, TOLERANCE};
use crate::tempo::{Tempo, TimeMap};

/// The phase-following gain for a one-beat error: the share of it made up over the next beat.
pub const PHASE_GAIN: f64 = 0.5;

/// The most a one-beat error pulls in one beat, in beats (the factor moved by at most ±15 %).
pub const PHASE_LIMIT: f64 = 0.15;

/// How much a consistent error (the same sign two beats running, or left by a confirmed
/// change of tempo) may change one beat: it is made up whole, as long as the performance's
/// next beat lasts between 1 − 0.24 and 1 + 0.24 of the conductor's, just under a sixteenth
/// note (0.25) either way. In beats of the score made up in one beat, that is at most 0.32
/// (catching up) and 0.19 (waiting).
pub const PHASE_CATCH_UP: f64 = 0.24;

/// The most a beat not yet explained moves the performance's notes, µs: the hedge taken
/// while it may still be an invented beat or a missed one (which may move no note by more
/// than 25 ms), at the pace of a consistent error.
pub const HEDGE_US: f64 = 15_000.0;

/// The tempo factors the follower gives: a twentieth to twenty times as written (as
/// `orch play --tempo` takes).
pub const FACTOR_RANGE: (f64, f64) = (0.05, 20.0);

/// How the follower follows. See the [module notes](self).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Follow {
    /// The rate only.
    Immediate,
    /// The rate, and each beat pulls the phase.
    Phase {
        /// The share of a one-beat error made up over the next beat.
        gain: f64,
        /// The most one beat may pull a one-beat error, in beats.
        limit: f64,
        /// How much longer or shorter than the conductor's (a fraction) one beat of the
        /// performance may be while a consistent error is made up whole.
        catch_up: f64,
    },
}

impl Follow {
    /// Phase-following with [`PHASE_GAIN`], [`PHASE_LIMIT`] and [`PHASE_CATCH_UP`].
    pub const PHASE: Follow = Follow::Phase {
        gain: PHASE_GAIN,
        limit: PHASE_LIMIT,
        catch_up: PHASE_CATCH_UP,
    };
}

/// Turns cues into tempo factors. See the [module notes](self).
#[derive(Clone, Debug)]
pub struct Follower {
    beats: ScoreBeats,
    follow: Follow,
    meter: Meter,
    /// The quarter of the score the last beat taken was matched to.
    quarter: Option<f64>,
    /// The phase error at the last beat taken, beats.
    last_error: Option<f64>,
    /// From the last beats' own times to their cues' arrival, µs, newest last (a baton's
    /// ictus is told two frames late): how long after a beat's time its cue may come.
    lags: VecDeque<u64>,
    /// When a hedge or a pull has made up its share: back to the rate then (µs on the
    /// performer's clock).
    settle: Option<u64>,
    /// What the beats have left open, and when it is settled without a beat (µs).
    expect: Option<(u64, Expect)>,
}

/// What the follower waits for between beats (phase-following only).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Expect {
    /// The beat in time with the last one taken: by then it is overdue (a missed beat, a
    /// slowing down, a fermata).
    Beat,
    /// An early beat held back, at `at` (µs), which would be quarter `quarter`: by then no beat
    /// in time with the last one taken has come, so it was not invented.
    Early {
        /// Its time, µs.
        at: u64,
        /// The quarter it would be.
        quarter: f64,
    },
}

/// Cues' lags kept.
const LAGS: usize = 4;

impl Follower {
    /// A follower of a score whose quarter notes are `beats`.
    pub fn new(beats: ScoreBeats, follow: Follow) -> Self {
        Self {
            beats,
            follow,
            meter: Meter::new(),
            quarter: None,
            last_error: None,
            lags: VecDeque::new(),
            settle: None,
            expect: None,
        }
    }

    /// When the follower is to be woken with no cue ([`wake`](Self::wake)), µs on the
    /// performer's clock: the end of a hedge or a pull, or the moment a beat in time with the
    /// last one is overdue. `None`: nothing to wait for.
    pub fn due(&self) -> Option<u64> {
        match (self.settle, self.expect.map(|e| e.0)) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// No cue has come until `now_us` (at or past [`due`](Self::due)): what to do, the
    /// performance's time map being `map`. See the [module notes](self).
    pub fn wake(&mut self, now_us: u64, map: Option<&TimeMap>) -> Action {
        let (Some(m), Some(period), Follow::Phase { catch_up, .. }) =
            (map, self.meter.period(), self.follow)
        else {
            self.settle = None;
            self.expect = None;
            return Action::Nothing;
        };
        let (here, len) = self.beats.at(m.score(now_us as i64));
        let rate = len / period;
        if let Some((_, what)) = self.expect.filter(|e| e.0 <= now_us) {
            self.expect = None;
            self.settle = None;
            // The performance's notes moved `d` µs at factor `f` in `wall` µs: `f` a
            // consistent error's most, held until they have moved as far as they may.
            let (f, d) = match what {
                // Overdue: a missed beat, or a slowing down. A hedge: slower, as far as a
                // missed beat may move a note.
                Expect::Beat => (rate / (1.0 + catch_up), HEDGE_US),
                // The early beat was a real one: catch it up, as fast as a consistent error,
                // as far as the conductor has gone at least (from it at the old rate).
                Expect::Early { at, quarter } => {
                    let gap = quarter + now_us.saturating_sub(at) as f64 / period - here;
                    (rate / (1.0 - catch_up), gap * period)
                }
            };
            if d > 0.0 && here > 0.0 {
                let wall = d / (f / rate - 1.0).abs();
                self.settle = Some(now_us + wall.round() as u64);
                return factor(f);
            }
            return factor(rate);
        }
        if self.settle.is_some_and(|s| s <= now_us) {
            self.settle = None;
            return factor(rate);
        }
        Action::Nothing
    }

    /// The conductor's tempo, as last heard or measured (quarter notes a minute).
    pub fn bpm(&self) -> Option<f64> {
        self.meter.period().map(|p| 60e6 / p)
    }

    /// What to do about `timed` (a cue and when it arrived), the performance's time map being
    /// `map` (`None` before it starts: then only a tempo can be taken). Between cues, the
    /// follower is to be woken at [`due`](Self::due) ([`wake`](Self::wake)): a hedge toward an
    /// odd beat ends there, and an early beat is caught up from there.
    pub fn cue(&mut self, timed: &Timed, map: Option<&TimeMap>) -> Action {
        let now = timed.t_us;
        let (t, stated) = match timed.cue {
            Cue::Tempo(bpm) => (None, Some(bpm)),
            Cue::Beat { t_us, bpm } => (Some(t_us), bpm),
            Cue::Stop => {
                self.forget();
                return Action::Pause;
            }
            Cue::Start => {
                self.forget();
                return Action::Start;
            }
            Cue::Continue => {
                self.forget();
                return Action::Resume;
            }
            // MIDI beats are sixteenth notes: four to the quarter.
            Cue::SongPosition(p) => {
                self.forget();
                return Action::Jump(self.beats.time_of(f64::from(p) / 4.0));
            }
        };
        if let Some(bpm) = stated.filter(|b| b.is_finite() && *b > 0.0) {
            // Taken at its word: the period, and a beat that starts the count again.
            self.meter.state(60e6 / bpm);
            self.meter.restart();
        }
        let held = self.meter.held();
        let heard = t.map(|t| self.meter.beat(t));
        if let (Some(t), Some(Heard::Odd { .. })) = (t, heard) {
            if held == Some(t) || self.meter.held() != Some(t) {
                // Ignored (a beat sent twice): what was open stays open.
                return Action::Nothing;
            }
        }
        // A beat, or a tempo stated: what the beats had left open is settled by it.
        self.settle = None;
        self.expect = None;
        if let Some(t) = t {
            self.lags.push_back(now.saturating_sub(t));
            if self.lags.len() > LAGS {
                self.lags.pop_front();
            }
        }
        let Some(period) = self.meter.period() else {
            // The first beat: the phase is noted, no rate yet.
            if let (Some(t), Some(m)) = (t, map) {
                self.quarter = Some(self.beats.at(m.score(t as i64)).0.round());
            }
            return Action::Nothing;
        };
        let rate_at = |s: u64| self.beats.at(s).1 / period;
        let Some(m) = map else {
            return factor(rate_at(0));
        };
        let (Some(t), Some(heard)) = (t, heard) else {
            return factor(rate_at(m.score(now as i64)));
        };
        let pos = self.beats.at(m.score(t as i64)).0;
        // The quarter this beat is, and whether its error is consistent.
        let (quarter, consistent) = match heard {
            Heard::Restart => {
                self.last_error = None;
                (pos.round(), false)
            }
            Heard::InTime { beats } => match self.quarter {
                Some(q) => (q + f64::from(beats), false),
                None => (pos.round(), false),
            },
            Heard::Changed => match self.quarter {
                Some(q) => (q + 2.0, true),
                None => (pos.round(), false),
            },
            Heard::Odd { late } => {
                // Not taken: the rate stands; a late one pulls a performance that is ahead,
                // an early one is hedged toward until it cannot have been invented.
                let q = self.quarter.map_or(pos.round(), |q| q + 1.0);
                let e = pos - q;
                let last = self.meter.last().unwrap_or(t);
                let early = ((t - last) as f64) < period && self.quarter.is_some();
                return match self.follow {
                    // The conductor's beat is late and the performance ahead of it: wait for
                    // it, as far as one beat may stretch.
                    Follow::Phase { catch_up, .. } if late && e > 0.0 && pos > 0.0 => {
                        let wait = e.min(1.0 - 1.0 / (1.0 + catch_up));
                        self.pulled(m, t, now, period, pos, wait)
                    }
                    // Early: it was invented if a beat comes in time with the last one taken;
                    // past the last moment one could (and its cue arrive), it was not.
                    Follow::Phase { catch_up, .. } if early && e < 0.0 && pos > 0.0 => {
                        let expiry = self.in_time_until(last, period);
                        self.expect = Some((expiry, Expect::Early { at: t, quarter: q }));
                        // Until then a hedge: toward it, as far as an invented beat may move a
                        // note.
                        let here = m.score(now as i64);
                        let rate = self.beats.at(here).1 / period;
                        let d = HEDGE_US.min(-e * period);
                        let wall = d * (1.0 - catch_up) / catch_up;
                        self.settle = Some(now + wall.round() as u64);
                        factor(rate / (1.0 - catch_up))
                    }
                    _ => Action::Nothing,
                };
            }
        };
        if let Follow::Phase { .. } = self.follow {
            self.expect = Some((self.in_time_until(t, period), Expect::Beat));
        }
        self.quarter = Some(quarter);
        let e = pos - quarter;
        let consistent = consistent
            || self
                .last_error
                .is_some_and(|l| l.signum() == e.signum() && l.abs() > 0.01);
        self.last_error = Some(e);
        match self.follow {
            // Before the first beat of the score the conductor is giving an upbeat: no pull.
            Follow::Phase {
                gain,
                limit,
                catch_up,
            } if pos > 0.0 => {
                let pull = if consistent {
                    // The performance's next beat lasts (1 − pull)⁻¹ of the conductor's:
                    // kept within 1 ± catch_up of it.
                    e.clamp(1.0 - 1.0 / (1.0 - catch_up), 1.0 - 1.0 / (1.0 + catch_up))
                } else {
                    (gain * e).clamp(-limit, limit)
                };
                self.pulled(m, t, now, period, pos, pull)
            }
            _ => factor(rate_at(m.score(now as i64))),
        }
    }

    /// The factor that, from `now`, brings the performance to `pos + 1 − pull` quarters at
    /// the next expected beat (`t + period`): the error at `t` less `pull` remains there.
    fn pulled(&self, m: &TimeMap, t: u64, now: u64, period: f64, pos: f64, pull: f64) -> Action {
        let next = t as f64 + period;
        let left = next - now as f64;
        let target = self.beats.time_of(pos + 1.0 - pull) as f64;
        let here = m.score(now as i64) as f64;
        if left < period / 2.0 || target <= here {
            // Recognised too late to steer to the next beat: the pull on the rate alone.
            let len = self.beats.at(here as u64).1;
            return factor(len / period * (1.0 - pull));
        }
        factor((target - here) / left)
    }

    /// The last moment a beat in time with the one taken at `last` could arrive (its cue
    /// as late as the last beats' were), µs.
    fn in_time_until(&self, last: u64, period: f64) -> u64 {
        let lag = self.lags.iter().copied().max().unwrap_or(0);
        last + (period * (1.0 + TOLERANCE)).round() as u64 + lag
    }

    /// The beats so far are forgotten (the transport moved): the next beat starts again.
    fn forget(&mut self) {
        self.meter.restart();
        self.quarter = None;
        self.last_error = None;
        self.settle = None;
        self.expect = None;
    }
}

fn factor(f: f64) -> Action {
    Tempo::new(f.clamp(FACTOR_RANGE.0, FACTOR_RANGE.1)).map_or(Action::Nothing, Action::Tempo)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(t_us: u64, cue: Cue) -> Timed {
        Timed { t_us, cue }
    }

    #[test]
    fn phase_following_pulls_by_the_gain_within_the_limit() {
        // A score at 120 BPM, played as written from wall 0.
        let beats = ScoreBeats::from_times((0..100).map(|i| i * 500_000).collect());
        let map = TimeMap::new(0, Tempo::NORMAL);
        let mut imm = Follower::new(beats.clone(), Follow::Immediate);
        let mut ph = Follower::new(beats, Follow::PHASE);
        // The conductor's beat at 4.1 beats of the score, stating 90 BPM: the performance is
        // 0.1 beat ahead.
        let cue = at(
            2_050_000,
            Cue::Beat {
                t_us: 2_050_000,
                bpm: Some(90.0),
            },
        );
        assert_eq!(
            imm.cue(&cue, Some(&map)),
            Action::Tempo(Tempo::new(0.75).unwrap())
        );
        let Action::Tempo(t) = ph.cue(&cue, Some(&map)) else {
            panic!()
        };
        assert!(
            (t.get() - 0.75 * (1.0 - PHASE_GAIN * 0.1)).abs() < 1e-9,
            "{t:?}"
        );
        // 0.45 beat behind, at a stated 120: a first error's pull is limited.
        let cue = at(
            2_275_000,
            Cue::Beat {
                t_us: 2_275_000,
                bpm: Some(120.0),
            },
        );
        let Action::Tempo(t) = ph.cue(&cue, Some(&map)) else {
            panic!()
        };
        assert!((t.get() - (1.0 + PHASE_LIMIT)).abs() < 1e-9, "{t:?}");
        assert_eq!(ph.cue(&at(0, Cue::Stop), Some(&map)), Action::Pause);
        assert_eq!(ph.cue(&at(0, Cue::Start), Some(&map)), Action::Start);
        assert_eq!(ph.cue(&at(0, Cue::Continue), Some(&map)), Action::Resume);
    }

    #[test]
    fn a_consistent_error_is_made_up_whole_up_to_the_catch_up_limit() {
        // Beats every 500 ms, the performance steady at the written 120 BPM but started
        // 60 ms late: 0.12 beat behind at every beat.
        let beats = ScoreBeats::from_times((0..100).map(|i| i * 500_000).collect());
        let map = TimeMap::new(60_000, Tempo::NORMAL);
        let mut f = Follower::new(beats, Follow::PHASE);
        let beat = |t| at(t, Cue::Beat { t_us: t, bpm: None });
        assert_eq!(f.cue(&beat(1_000_000), Some(&map)), Action::Nothing);
        // The first error: half of it.
        let Action::Tempo(t) = f.cue(&beat(1_500_000), Some(&map)) else {
            panic!()
        };
        assert!((t.get() - 1.06).abs() < 1e-6, "{t:?}");
        // The same error again: consistent, all of it.
        let Action::Tempo(t) = f.cue(&beat(2_000_000), Some(&map)) else {
            panic!()
        };
        assert!((t.get() - 1.12).abs() < 1e-6, "{t:?}");
        // A larger consistent error: the next beat of the performance 0.76 of the
        // conductor's, no shorter.
        let map = TimeMap::new(200_000, Tempo::NORMAL);
        let Action::Tempo(t) = f.cue(&beat(2_500_000), Some(&map)) else {
            panic!()
        };
        assert!(
            (1.0 / t.get() - (1.0 - PHASE_CATCH_UP)).abs() < 1e-6,
            "{t:?}"
        );
        // Ahead by as much, consistently: 1.24 of the conductor's beat, no longer.
        let map = TimeMap::new(-400_000, Tempo::NORMAL);
        f.cue(&beat(3_000_000), Some(&map));
        let Action::Tempo(t) = f.cue(&beat(3_500_000), Some(&map)) else {
            panic!()
        };
        assert!(
            (1.0 / t.get() - (1.0 + PHASE_CATCH_UP)).abs() < 1e-6,
            "{t:?}"
        );
    }

    #[test]
    fn an_early_beat_is_hedged_toward_then_caught_up_once_it_cannot_be_invented() {
        // 120 BPM beats on a score at 120, played as written from 0: on the beat. Then a beat
        // 0.3 beat early (at 2.35 s instead of 2.5).
        let beats = ScoreBeats::from_times((0..100).map(|i| i * 500_000).collect());
        let map = TimeMap::new(0, Tempo::NORMAL);
        let beat = |t| at(t, Cue::Beat { t_us: t, bpm: None });
        let fresh = || {
            let mut f = Follower::new(beats.clone(), Follow::PHASE);
            for t in [0, 500_000, 1_000_000, 1_500_000, 2_000_000] {
                f.cue(&beat(t), Some(&map));
            }
            f
        };
        let mut f = fresh();
        // Overdue 1.12 beat after the last.
        assert_eq!(f.due(), Some(2_560_000));
        let fast = 1.0 / (1.0 - PHASE_CATCH_UP);
        let tempo = |a: Action| match a {
            Action::Tempo(t) => t.get(),
            a => panic!("{a:?}"),
        };
        // The hedge: as fast as a consistent error, until the notes have moved HEDGE_US.
        assert!((tempo(f.cue(&beat(2_350_000), Some(&map))) - fast).abs() < 1e-9);
        let hedge_end = 2_350_000 + (HEDGE_US / (fast - 1.0)).round() as u64;
        assert_eq!(f.due(), Some(hedge_end));
        let mut m = map;
        m.change(2_350_000, Tempo::new(fast).unwrap());
        assert!((tempo(f.wake(hedge_end, Some(&m))) - 1.0).abs() < 1e-9);
        m.change(hedge_end as i64, Tempo::NORMAL);
        // Moved by the hedge, and no more.
        assert!((m.wall(2_500_000) - 2_485_000).abs() <= 1, "{m:?}");
        // Until a beat in time with the last could no longer come, nothing more.
        assert_eq!(f.due(), Some(2_560_000));
        assert_eq!(f.wake(2_559_999, Some(&m)), Action::Nothing);
        assert_eq!(f.bpm(), Some(120.0));
        // Then it was a real beat: caught up as fast as a consistent error may, until the
        // performance stands where the conductor does at least (from the early beat at the
        // old tempo): 0.3 beat, less the hedge's 0.03.
        assert!((tempo(f.wake(2_560_000, Some(&m))) - fast).abs() < 1e-9);
        let behind = 0.3 * 500_000.0 - HEDGE_US;
        let until = 2_560_000 + (behind / (fast - 1.0)).round() as u64;
        assert_eq!(f.due(), Some(until));
        // The tempo stands: one odd interval is not a new tempo.
        assert_eq!(f.bpm(), Some(120.0));
        m.change(2_560_000, Tempo::new(fast).unwrap());
        assert!((tempo(f.wake(until, Some(&m))) - 1.0).abs() < 1e-9);
        m.change(until as i64, Tempo::NORMAL);
        let q = beats.at(m.score(until as i64)).0;
        assert!(
            (q - (5.0 + (until - 2_350_000) as f64 / 500_000.0)).abs() < 1e-3,
            "{q}"
        );
        // The next beat agrees with the early one: the change is taken, the tempo jumps.
        f.cue(&beat(2_700_000), Some(&m));
        assert!((f.bpm().unwrap() - 60e6 / 350_000.0).abs() < 1e-6);

        // Invented: the beat in time with the last comes, the hedge is all that moved.
        let mut f = fresh();
        f.cue(&beat(2_350_000), Some(&map));
        // Sent twice (told again 50 ms later): the second changes nothing.
        let again = at(
            2_400_000,
            Cue::Beat {
                t_us: 2_350_000,
                bpm: None,
            },
        );
        assert_eq!(f.cue(&again, Some(&map)), Action::Nothing);
        assert_eq!(f.due(), Some(hedge_end));
        let Action::Tempo(_) = f.cue(&beat(2_500_000), Some(&map)) else {
            panic!()
        };
        assert_eq!(f.due(), Some(2_500_000 + 560_000));
        assert_eq!(f.bpm(), Some(120.0));

        // Rate only: nothing to wait for.
        let mut f = Follower::new(beats.clone(), Follow::Immediate);
        for t in [0, 500_000, 1_000_000, 2_350_000] {
            f.cue(&beat(t), Some(&map));
        }
        assert_eq!(f.due(), None);
    }

    #[test]
    fn an_overdue_beat_is_hedged_for_as_far_as_a_missed_beat_may_move_a_note() {
        let beats = ScoreBeats::from_times((0..100).map(|i| i * 500_000).collect());
        let map = TimeMap::new(0, Tempo::NORMAL);
        let mut f = Follower::new(beats, Follow::PHASE);
        for t in [0, 500_000, 1_000_000] {
            f.cue(&at(t, Cue::Beat { t_us: t, bpm: None }), Some(&map));
        }
        assert_eq!(f.due(), Some(1_560_000));
        let slow = 1.0 / (1.0 + PHASE_CATCH_UP);
        let Action::Tempo(t) = f.wake(1_560_000, Some(&map)) else {
            panic!()
        };
        assert!((t.get() - slow).abs() < 1e-9, "{t:?}");
        let end = 1_560_000 + (HEDGE_US / (1.0 - slow)).round() as u64;
        assert_eq!(f.due(), Some(end));
        let mut m = map;
        m.change(1_560_000, t);
        assert_eq!(f.wake(end, Some(&m)), Action::Tempo(Tempo::NORMAL));
        m.change(end as i64, Tempo::NORMAL);
        assert!((m.wall(1_000_000) - 1_015_000).abs() <= 1, "{m:?}");
        assert_eq!(f.due(), None);
        // A cue told late (a baton's): the overdue moment waits as long after the beat.
        let mut f = Follower::new(
            ScoreBeats::from_times((0..100).map(|i| i * 500_000).collect()),
            Follow::PHASE,
        );
        for t in [0u64, 500_000, 1_000_000] {
            f.cue(
                &at(t + 80_000, Cue::Beat { t_us: t, bpm: None }),
                Some(&map),
            );
        }
        assert_eq!(f.due(), Some(1_640_000));
    }

    #[test]
    fn a_beat_recognised_late_is_steered_to_from_when_it_arrived() {
        // 120 BPM beats, each 0.1 beat behind the performance (it plays as written from 0);
        // the fourth told 100 ms after its ictus. The error is consistent, made up whole: at
        // the next beat (2.55 s) the performance is at quarter 5, the 100 ms of delay counted.
        let beats = ScoreBeats::from_times((0..100).map(|i| i * 500_000).collect());
        let map = TimeMap::new(0, Tempo::NORMAL);
        let mut f = Follower::new(beats.clone(), Follow::PHASE);
        for t in [550_000u64, 1_050_000, 1_550_000] {
            f.cue(&at(t, Cue::Beat { t_us: t, bpm: None }), Some(&map));
        }
        let Action::Tempo(t) = f.cue(
            &at(
                2_150_000,
                Cue::Beat {
                    t_us: 2_050_000,
                    bpm: None,
                },
            ),
            Some(&map),
        ) else {
            panic!()
        };
        let mut m = map;
        m.change(2_150_000, t);
        let q = beats.at(m.score(2_550_000)).0;
        assert!((q - 5.0).abs() < 1e-3, "{q} {t:?}");
    }
}
