//! Clocks to play by: a virtual one for tests and rendering, a real one for robots.
//!
//! Both count microseconds from their own start and implement [`Clock`]. A clock's
//! [`wait_until`](Clock::wait_until) returns how late it woke up, and the clock keeps those
//! figures ([`Clock::lateness`]).

use std::thread;

use crate::Bell;
use std::time::{Duration, Instant};

/// Something that tells the time and waits for a deadline.
pub trait Clock {
    /// Microseconds since the clock started.
    fn now_us(&self) -> u64;

    /// Returns once `deadline_us` has come, and says how late that was, in µs (0 if on time;
    /// a deadline already past returns at once with its lateness).
    fn wait_until(&mut self, deadline_us: u64) -> u64;

    /// Statistics of the lateness of every wait so far.
    fn lateness(&self) -> Lateness;

    /// Waits as [`wait_until`](Self::wait_until) does, but returns as soon as `bell` has
    /// rung more than `seen` times (read [`Bell::rung`] before looking at what the bell
    /// announces): `true` if it was the bell (then the deadline may not have come). The
    /// default, for a clock no other thread can reach (a virtual one), looks at the bell
    /// once and otherwise waits for the deadline.
    fn wait_until_rung(&mut self, deadline_us: u64, bell: &Bell, seen: u64) -> bool {
        if bell.rung() > seen {
            return true;
        }
        self.wait_until(deadline_us);
        false
    }
}

/// How late a clock's wake-ups were, in µs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Lateness {
    /// Waits recorded.
    pub count: usize,
    /// The median lateness.
    pub median_us: u64,
    /// The 99th percentile (nearest rank).
    pub p99_us: u64,
    /// The largest lateness.
    pub max_us: u64,
}

impl Lateness {
    /// The statistics of `samples` (in any order).
    pub fn of(samples: &[u64]) -> Self {
        if samples.is_empty() {
            return Self::default();
        }
        let mut s = samples.to_vec();
        s.sort_unstable();
        let rank = |p: f64| {
            let r = (p * s.len() as f64).ceil() as usize;
            s[r.clamp(1, s.len()) - 1]
        };
        Self {
            count: s.len(),
            median_us: rank(0.5),
            p99_us: rank(0.99),
            max_us: s[s.len() - 1],
        }
    }
}

/// A clock that never waits: [`wait_until`](Clock::wait_until) sets the time to the deadline
/// at once. Playing against it runs as fast as possible and gives the same result every time.
#[derive(Clone, Debug, Default)]
pub struct VirtualClock {
    now: u64,
    samples: Vec<u64>,
}

impl VirtualClock {
    /// A clock at 0.
    pub fn new() -> Self {
        Self::default()
    }

    /// Moves the time on (never back).
    pub fn advance_to(&mut self, t_us: u64) {
        self.now = self.now.max(t_us);
    }
}

impl Clock for VirtualClock {
    fn now_us(&self) -> u64 {
        self.now
    }

    fn wait_until(&mut self, deadline_us: u64) -> u64 {
        let late = self.now.saturating_sub(deadline_us);
        self.now = self.now.max(deadline_us);
        self.samples.push(late);
        late
    }

    fn lateness(&self) -> Lateness {
        Lateness::of(&self.samples)
    }
}

/// The host's monotonic clock, waiting precisely: it sleeps until about
/// [`RealClock::SPIN`] before the deadline (a sleep may overshoot by a scheduler tick), then
/// yields in a loop until the deadline. It never wakes early.
#[derive(Clone, Debug)]
pub struct RealClock {
    start: Instant,
    samples: Vec<u64>,
}

impl RealClock {
    /// How long before a deadline the clock stops sleeping and starts spinning.
    pub const SPIN: Duration = Duration::from_millis(1);

    /// A clock starting now.
    pub fn new() -> Self {
        Self {
            start: Instant::now(),
            samples: Vec::new(),
        }
    }

    /// Every lateness recorded, in µs, in order.
    pub fn samples(&self) -> &[u64] {
        &self.samples
    }
}

impl Default for RealClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for RealClock {
    fn now_us(&self) -> u64 {
        u64::try_from(self.start.elapsed().as_micros()).unwrap_or(u64::MAX)
    }

    fn wait_until(&mut self, deadline_us: u64) -> u64 {
        let deadline = self.start + Duration::from_micros(deadline_us);
        loop {
            let now = Instant::now();
            if now >= deadline {
                break;
            }
            let left = deadline - now;
            if left > Self::SPIN {
                thread::sleep(left - Self::SPIN);
            } else {
                thread::yield_now();
            }
        }
        let late = self.now_us().saturating_sub(deadline_us);
        self.samples.push(late);
        late
    }

    fn lateness(&self) -> Lateness {
        Lateness::of(&self.samples)
    }

    /// Sleeps on the bell until [`SPIN`](Self::SPIN) before the deadline, then yields in a
    /// loop, looking at the bell, until the deadline.
    fn wait_until_rung(&mut self, deadline_us: u64, bell: &Bell, seen: u64) -> bool {
        let deadline = self.start + Duration::from_micros(deadline_us);
        loop {
            if bell.rung() > seen {
                return true;
            }
            let now = Instant::now();
            if now >= deadline {
                break;
            }
            let left = deadline - now;
            if left > Self::SPIN {
                bell.wait(seen, left - Self::SPIN);
            } else {
                thread::yield_now();
            }
        }
        let late = self.now_us().saturating_sub(deadline_us);
        self.samples.push(late);
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_real_clock_wait_ends_at_a_ring_and_otherwise_at_its_deadline() {
        let bell = std::sync::Arc::new(Bell::new());
        let mut c = RealClock::new();
        let seen = bell.rung();
        let b = std::sync::Arc::clone(&bell);
        let ringer = thread::spawn(move || {
            thread::sleep(Duration::from_millis(20));
            b.ring();
        });
        // A deadline 5 s off: the ring ends the wait long before.
        assert!(c.wait_until_rung(5_000_000, &bell, seen));
        assert!(c.now_us() < 2_000_000, "{}", c.now_us());
        ringer.join().unwrap();
        // No ring: the deadline, never early.
        let now = c.now_us();
        assert!(!c.wait_until_rung(now + 10_000, &bell, bell.rung()));
        assert!(c.now_us() >= now + 10_000);
        // The default (a virtual clock): a ring already there ends it, else the deadline.
        let mut v = VirtualClock::new();
        assert!(v.wait_until_rung(1_000, &bell, seen));
        assert!(!v.wait_until_rung(1_000, &bell, bell.rung()));
        assert_eq!(v.now_us(), 1_000);
    }

    #[test]
    fn virtual_clock_jumps_to_deadlines_and_reports_past_ones() {
        let mut c = VirtualClock::new();
        assert_eq!(c.wait_until(1_000), 0);
        assert_eq!(c.now_us(), 1_000);
        assert_eq!(c.wait_until(400), 600);
        assert_eq!(c.now_us(), 1_000);
        let l = c.lateness();
        assert_eq!((l.count, l.max_us), (2, 600));
    }

    #[test]
    fn lateness_percentiles() {
        let samples: Vec<u64> = (1..=100).collect();
        let l = Lateness::of(&samples);
        assert_eq!((l.median_us, l.p99_us, l.max_us), (50, 99, 100));
        assert_eq!(Lateness::of(&[]), Lateness::default());
    }

    #[test]
    fn real_clock_never_wakes_early() {
        let mut c = RealClock::new();
        for i in 1..=5u64 {
            let deadline = c.now_us() + 1_500 * i;
            c.wait_until(deadline);
            assert!(c.now_us() >= deadline);
        }
        assert_eq!(c.lateness().count, 5);
        assert_eq!(c.samples().len(), 5);
    }
}
