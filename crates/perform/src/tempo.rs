//! Score time to wall time, at a tempo that may change at any moment.
//!
//! Score time is the song's own µs at its written tempo. Wall time is µs on the performer's
//! clock. A [`TimeMap`] maps one to the other by a piecewise-linear function: from an anchor
//! (`wall`, `score`) on, score time runs `factor` times as fast as wall time (2.0 plays twice
//! as fast). A change of factor starts a new piece at the present, so score time stays
//! continuous: nothing already played moves, nothing is skipped or repeated.

use crate::time::{ScoreTime, WallTime};

/// How fast to play: a factor above 0 and finite (1.0 as written).
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd)]
pub struct Tempo(f64);

impl Tempo {
    /// As written.
    pub const NORMAL: Tempo = Tempo(1.0);

    /// A factor, if it is finite and above 0.
    pub fn new(factor: f64) -> Option<Tempo> {
        (factor.is_finite() && factor > 0.0).then_some(Tempo(factor))
    }

    /// The factor.
    pub fn get(self) -> f64 {
        self.0
    }
}

impl Default for Tempo {
    fn default() -> Self {
        Self::NORMAL
    }
}

/// Score time ↔ wall time. See the [module notes](self).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeMap {
    wall: i64,
    score: u64,
    tempo: Tempo,
}

impl TimeMap {
    /// Score time 0 is at wall time `wall`, playing at `tempo`.
    pub fn new(wall: i64, tempo: Tempo) -> Self {
        Self {
            wall,
            score: 0,
            tempo,
        }
    }

    /// The anchor: from wall time `.0` (µs) on, score time runs from `.1` at the tempo.
    /// It moves at each change of tempo (to the wall time the change took effect) and at a
    /// resume.
    pub fn anchor(&self) -> (i64, u64) {
        (self.wall, self.score)
    }

    /// The tempo now.
    pub fn tempo(&self) -> Tempo {
        self.tempo
    }

    /// The wall time (µs) at which score time `score` plays, rounded to the µs. Before the
    /// anchor it extrapolates at the present tempo.
    pub fn wall(&self, score: u64) -> i64 {
        if self.tempo.0 == 1.0 && score < i64::MAX as u64 / 4 {
            return self.wall + (score as i64 - self.score as i64);
        }
        let d = score as f64 - self.score as f64;
        let w = self.wall as f64 + d / self.tempo.0;
        if w >= i64::MAX as f64 / 2.0 {
            i64::MAX / 2
        } else if w <= i64::MIN as f64 / 2.0 {
            i64::MIN / 2
        } else {
            w.round() as i64
        }
    }

    /// The score time playing at wall time `wall` (0 before the start).
    pub fn score(&self, wall: i64) -> u64 {
        let s = self.score as f64 + (wall - self.wall) as f64 * self.tempo.0;
        if s <= 0.0 {
            0
        } else if s >= u64::MAX as f64 / 2.0 {
            u64::MAX / 2
        } else {
            s.round() as u64
        }
    }

    /// [`wall`](Self::wall), typed: the moment score time `score` plays (the clock's start if
    /// that is before it).
    pub fn wall_at(&self, score: ScoreTime) -> WallTime {
        WallTime::from_signed(self.wall(score.as_micros()))
    }

    /// [`score`](Self::score), typed: the place in the song playing at `wall`.
    pub fn score_at(&self, wall: WallTime) -> ScoreTime {
        ScoreTime::from_micros(self.score(wall.signed()))
    }

    /// Paused at wall time `paused`, going on at `now`: the score time at `paused` plays at
    /// `now`, at the same tempo (nothing of the score is skipped or repeated across the pause).
    pub fn resume(&mut self, paused: i64, now: i64) {
        let score = self.score(paused);
        self.wall = now;
        self.score = score;
    }

    /// A jump: score time `score` plays at wall time `wall`, at the same tempo (score time is
    /// continuous from there on).
    pub fn jump(&mut self, wall: i64, score: u64) {
        self.wall = wall;
        self.score = score;
    }

    /// From wall time `now` on, play at `tempo`; the score time at `now` does not move.
    pub fn change(&mut self, now: i64, tempo: Tempo) {
        let score = self.score(now);
        *self = Self {
            wall: now,
            score,
            tempo,
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tempo_change_keeps_score_time_continuous() {
        let mut m = TimeMap::new(1_000, Tempo::NORMAL);
        assert_eq!(m.wall(500_000), 501_000);
        m.change(101_000, Tempo::new(2.0).unwrap());
        assert_eq!(m.score(101_000), 100_000);
        assert_eq!(m.wall(300_000), 201_000);
        assert!(Tempo::new(0.0).is_none() && Tempo::new(f64::NAN).is_none());
    }
}
