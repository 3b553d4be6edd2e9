//! The performer's two clocks, kept apart by type.
//!
//! [`WallTime`] is a moment on the performer's clock (µs since it started). [`ScoreTime`] is
//! a place in the song (µs at its written tempo). A [`TimeMap`](crate::TimeMap) turns one
//! into the other ([`TimeMap::wall_at`](crate::TimeMap::wall_at),
//! [`TimeMap::score_at`](crate::TimeMap::score_at)); nothing else does, so a score time can
//! never be waited for as if it were a wall time. The planner works in signed wall µs (a
//! send may be planned before the clock's start); [`WallTime::from_signed`] and
//! [`WallTime::signed`] are the one crossing.

use std::ops::Add;

/// A moment on the performer's clock, µs since it started.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct WallTime(u64);

/// A place in the song, µs at its written tempo.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ScoreTime(u64);

impl WallTime {
    /// The clock's start.
    pub const ZERO: Self = Self(0);

    /// `us` µs after the clock's start.
    pub const fn from_micros(us: u64) -> Self {
        Self(us)
    }

    /// A planner's signed wall time (0 before the clock's start).
    pub fn from_signed(us: i64) -> Self {
        Self(u64::try_from(us).unwrap_or(0))
    }

    /// µs since the clock's start.
    pub const fn as_micros(self) -> u64 {
        self.0
    }

    /// As the planner's signed wall µs (saturating at the end of time).
    pub fn signed(self) -> i64 {
        i64::try_from(self.0).unwrap_or(i64::MAX)
    }

    /// The time from `earlier` to `self`, µs, or 0 if `earlier` is later.
    pub const fn saturating_since(self, earlier: WallTime) -> u64 {
        self.0.saturating_sub(earlier.0)
    }
}

impl Add<u64> for WallTime {
    type Output = WallTime;
    /// `us` µs later (saturating).
    fn add(self, us: u64) -> WallTime {
        WallTime(self.0.saturating_add(us))
    }
}

impl ScoreTime {
    /// The top of the song.
    pub const ZERO: Self = Self(0);

    /// `us` µs into the song at its written tempo.
    pub const fn from_micros(us: u64) -> Self {
        Self(us)
    }

    /// µs into the song at its written tempo.
    pub const fn as_micros(self) -> u64 {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_planned_time_before_the_start_is_the_start() {
        assert_eq!(WallTime::from_signed(-5), WallTime::ZERO);
        assert_eq!(WallTime::from_signed(7).signed(), 7);
        assert_eq!((WallTime::from_micros(3) + 4).as_micros(), 7);
        assert_eq!(
            WallTime::from_micros(3).saturating_since(WallTime::from_micros(9)),
            0
        );
    }
}
