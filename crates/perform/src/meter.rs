//! The conductor's beats, one by one: which are in time, which are odd, when the tempo has
//! changed, and the period to expect next. Pure: beat times (µs) in, verdicts out.
//!
//! The rule (the [`Follower`](crate::Follower) applies it to every source alike: OSC beats,
//! MIDI clock, tap tempo, the baton):
//!
//! - The **period** is the beat interval the meter expects next. A beat whose interval from
//!   the last beat taken is within [`TOLERANCE`] of the period is **in time**: its interval
//!   joins the run of intervals since the last change of tempo, and the next period is the
//!   least-squares line through the last [`TREND`] of them carried one beat on (an
//!   accelerando or a ritardando is followed without lagging by half a window), kept within
//!   the range of those intervals widened by their last step (a jump is not extrapolated as
//!   a trend).
//! - An interval of two or three periods (within `TOLERANCE` of each) is a **missed beat**:
//!   in time, counting the beats it spans; the period stands.
//! - Any other interval is **odd**, and the beat is held back, taken neither for the tempo
//!   nor as a beat of the score: a single odd interval (an invented beat, a late or early
//!   beat, the end of a fermata) never changes the tempo. The next beat decides:
//!   - if its interval from the last beat taken is one period, the odd beat was invented: it
//!     is dropped;
//!   - else if the odd beat's interval and the new one **agree** (within `TOLERANCE` of each
//!     other), the tempo has **changed**: both beats are taken, the run starts again from
//!     those two intervals and the period jumps to them. A sustained change is so recognised
//!     at its second beat, and the rate follows it there;
//!   - else if the interval from the last beat taken spans two or three periods, the odd beat
//!     was invented among missed ones: dropped;
//!   - otherwise the conductor has started again (after a fermata, a pause, or a change
//!     steeper than the tolerance): the beat is a **restart**, the phase is found afresh at
//!     it, and its interval from the odd beat is the new period if it is not in time with
//!     the old one.
//!
//! A beat not after the last one heard (the same beat sent twice) is ignored (odd, and not
//! held back).
//!
//! Two intervals that agree but together make one period (an invented beat at exactly half a
//! beat) are taken as one beat split in two, not as a doubling of the tempo: the first rule
//! is asked before the second.

use std::collections::VecDeque;

/// How far an interval may be from the period (as a fraction) and still be in time; and how
/// close two intervals must be to agree. 0.12: a player's beat-to-beat wobble (a few %) and
/// an accelerando's step (2–5 % a beat) stay in; an abrupt change of 30 %, a missed beat
/// (+100 %) and an invented one stay out.
pub const TOLERANCE: f64 = 0.12;

/// Intervals of the run the period's trend is fitted to.
pub const TREND: usize = 3;

/// What a beat was.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Heard {
    /// The first beat, or the conductor starting again (after a fermata, a pause, or an
    /// irregular stretch): the phase is to be found afresh here.
    Restart,
    /// In time: `beats` conductor beats after the last beat taken (1; 2 or 3 after missed
    /// beats).
    InTime {
        /// Beats since the last beat taken.
        beats: u32,
    },
    /// The tempo changed: the odd beat before this one and this one are taken (this beat is
    /// two beats after the last taken before them), and the period has jumped.
    Changed,
    /// Odd: held back, not taken. `late`: it came more than a period late, and before a
    /// missed beat would have come (a slowing down, or a late beat); otherwise it came early
    /// (a speeding up, or an invented beat) or very late (a fermata).
    Odd {
        /// Between one period and two, outside the tolerance of both.
        late: bool,
    },
}

/// The beat-by-beat rule. See the [module notes](self).
#[derive(Clone, Debug, Default)]
pub struct Meter {
    /// The interval expected next, µs.
    period: Option<f64>,
    /// The in-time intervals since the last change, newest last.
    run: VecDeque<f64>,
    /// The last beat taken, µs.
    last: Option<u64>,
    /// An odd beat held back, µs.
    odd: Option<u64>,
}

impl Meter {
    /// No beats yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// The interval expected next, µs (`None` before two beats or a stated tempo).
    pub fn period(&self) -> Option<f64> {
        self.period
    }

    /// The last beat taken, µs (`None` before the first, and after a restart).
    pub fn last(&self) -> Option<u64> {
        self.last
    }

    /// The odd beat held back, µs, if one is (until the next beat decides what it was).
    pub fn held(&self) -> Option<u64> {
        self.odd
    }

    /// A tempo stated by the conductor: the period is `period_us` from now on, and the run
    /// starts again.
    pub fn state(&mut self, period_us: f64) {
        if period_us.is_finite() && period_us > 0.0 {
            self.period = Some(period_us);
            self.run.clear();
        }
    }

    /// Forgets the beats (not the period): the next beat is a restart (after a pause or a
    /// jump).
    pub fn restart(&mut self) {
        self.last = None;
        self.odd = None;
    }

    /// A beat at `t_us` (its own time: the ictus).
    pub fn beat(&mut self, t_us: u64) -> Heard {
        let Some(last) = self.last else {
            return self.restart_at(t_us);
        };
        if t_us <= last || self.odd.is_some_and(|o| t_us <= o) {
            // Not after the beats before it (a beat sent twice): ignored.
            return Heard::Odd { late: false };
        }
        let interval = (t_us - last) as f64;
        let Some(period) = self.period else {
            // The second beat: the first interval is the period.
            self.last = Some(t_us);
            self.take(interval);
            return Heard::InTime { beats: 1 };
        };
        let n = in_time(interval, period);
        let odd = self.odd.take();
        // With an odd beat held back, two intervals that agree are a change, even where the
        // whole would pass for missed beats (a slowing down by 30 % spans 2.9 periods at its
        // second beat); but not where they make one period (an invented beat's split).
        let changed = odd.filter(|&o| n != Some(1) && agree((o - last) as f64, (t_us - o) as f64));
        if let Some(o) = changed {
            self.last = Some(t_us);
            self.run.clear();
            self.take((o - last) as f64);
            self.take((t_us - o) as f64);
            return Heard::Changed;
        }
        if let Some(n) = n {
            self.last = Some(t_us);
            if n == 1 {
                self.take(interval);
            }
            return Heard::InTime { beats: n };
        }
        match odd {
            None => {
                self.odd = Some(t_us);
                let r = interval / period;
                Heard::Odd {
                    late: r > 1.0 + TOLERANCE && r < 2.0 * (1.0 - TOLERANCE),
                }
            }
            Some(odd) => {
                let b = (t_us - odd) as f64;
                let heard = self.restart_at(t_us);
                if in_time(b, period) != Some(1) {
                    self.run.clear();
                    self.take(b);
                }
                heard
            }
        }
    }

    fn restart_at(&mut self, t_us: u64) -> Heard {
        self.last = Some(t_us);
        self.odd = None;
        Heard::Restart
    }

    /// An in-time interval joins the run; the period is the run's trend carried on a beat.
    fn take(&mut self, interval: f64) {
        self.run.push_back(interval);
        while self.run.len() > TREND {
            self.run.pop_front();
        }
        self.period = Some(next_interval(&self.run));
    }
}

/// The beats an interval spans if it is in time with `period` (1), or one or two beats were
/// missed (2, 3).
fn in_time(interval: f64, period: f64) -> Option<u32> {
    let r = interval / period;
    (1..=3u32).find(|&n| (r - f64::from(n)).abs() <= TOLERANCE * f64::from(n))
}

/// Whether two intervals agree.
fn agree(a: f64, b: f64) -> bool {
    (a - b).abs() <= TOLERANCE * (a + b) / 2.0
}

/// The least-squares line through `run` (against the beat's index) at the next index, kept
/// within the run's range widened by its last step.
fn next_interval(run: &VecDeque<f64>) -> f64 {
    let n = run.len();
    let last = run[n - 1];
    if n == 1 {
        return last;
    }
    let nf = n as f64;
    let mx = (nf - 1.0) / 2.0;
    let my = run.iter().sum::<f64>() / nf;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (i, &y) in run.iter().enumerate() {
        let dx = i as f64 - mx;
        sxy += dx * (y - my);
        sxx += dx * dx;
    }
    let at = my + sxy / sxx * (nf - mx);
    let step = (last - run[n - 2]).abs();
    let lo = run.iter().copied().fold(f64::INFINITY, f64::min) - step;
    let hi = run.iter().copied().fold(0.0, f64::max) + step;
    at.clamp(lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Feeds beats at `times` (ms), returns what each was.
    fn hear(times: &[u64]) -> (Vec<Heard>, Meter) {
        let mut m = Meter::new();
        let v = times.iter().map(|&t| m.beat(t * 1000)).collect();
        (v, m)
    }

    const IN: Heard = Heard::InTime { beats: 1 };

    #[test]
    fn an_abrupt_change_is_taken_at_its_second_interval() {
        // 600 ms beats, then 450.
        let (v, m) = hear(&[0, 600, 1200, 1800, 2250, 2700, 3150]);
        assert_eq!(v[..4], [Heard::Restart, IN, IN, IN]);
        assert_eq!(v[4], Heard::Odd { late: false });
        assert_eq!(v[5], Heard::Changed);
        assert_eq!(v[6], IN);
        assert!((m.period().unwrap() - 450_000.0).abs() < 1.0, "{m:?}");
        // Slowing down: 450 to 650 ms, the odd beat late.
        let (v, m) = hear(&[0, 450, 900, 1550, 2200]);
        assert_eq!(v[3], Heard::Odd { late: true });
        assert_eq!(v[4], Heard::Changed);
        assert!((m.period().unwrap() - 650_000.0).abs() < 1.0, "{m:?}");
    }

    #[test]
    fn a_single_odd_interval_is_not_a_new_tempo() {
        // An invented beat (at a third of a beat, and at exactly half of one), a missed beat.
        for times in [
            &[0, 600, 1200, 1400, 1800, 2400][..],
            &[0, 600, 1200, 1500, 1800, 2400],
        ] {
            let (v, m) = hear(times);
            assert_eq!(v[3], Heard::Odd { late: false }, "{times:?}");
            assert_eq!(v[4..], [IN, IN], "{times:?}");
            assert!((m.period().unwrap() - 600_000.0).abs() < 1.0);
        }
        let (v, m) = hear(&[0, 600, 1200, 2400, 3000]);
        assert_eq!(v[3..], [Heard::InTime { beats: 2 }, IN]);
        // A beat sent twice: the second is ignored, the count goes on.
        let (v, _) = hear(&[0, 600, 1200, 1200, 1800]);
        assert_eq!(v[3..], [Heard::Odd { late: false }, IN]);
        assert!((m.period().unwrap() - 600_000.0).abs() < 1.0);
        // A fermata: a beat 2.5 s late, then the tempo as before: the phase starts again
        // there, the period stands.
        let (v, m) = hear(&[0, 600, 1200, 4300, 4900, 5500]);
        assert_eq!(v[3..], [Heard::Odd { late: false }, Heard::Restart, IN]);
        assert!((m.period().unwrap() - 600_000.0).abs() < 1.0);
    }

    #[test]
    fn an_accelerando_is_followed_by_its_trend() {
        // 80 to 140 BPM, linear in BPM per beat over 16 beats.
        let mut t = 0.0;
        let mut times = vec![0u64];
        for k in 0..16 {
            t += 60_000.0 / (80.0 + 60.0 * f64::from(k) / 16.0);
            times.push(t.round() as u64);
        }
        let (v, m) = hear(&times);
        assert!(v[1..].iter().all(|h| *h == IN), "{v:?}");
        // The next interval, at 140 - 3.75 BPM; the trend lands within 1 %.
        let next = 60e6 / (80.0 + 60.0 * 16.0 / 16.0);
        assert!((m.period().unwrap() / next - 1.0).abs() < 0.01, "{m:?}");
    }
}
