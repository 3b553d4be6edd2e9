//! A bell that wakes a waiting clock: whoever changes what a waiting thread acts on rings it,
//! and the wait ends at once instead of at its deadline (see [`Clock::wait_until_rung`]).
//!
//! [`Clock::wait_until_rung`]: crate::Clock::wait_until_rung

use std::sync::{Condvar, Mutex};
use std::time::Duration;

/// Counts its rings; threads wait for the next one. Any number of waiters wake at a ring.
#[derive(Debug, Default)]
pub struct Bell {
    rung: Mutex<u64>,
    cv: Condvar,
}

impl Bell {
    /// A bell never rung.
    pub fn new() -> Self {
        Self::default()
    }

    /// Rings: every wait for a ring after the ones seen ends.
    pub fn ring(&self) {
        let mut r = self.rung.lock().unwrap_or_else(|e| e.into_inner());
        *r += 1;
        self.cv.notify_all();
    }

    /// How many times it has rung. Read it before looking at what a ring announces, and wait
    /// for a ring after that count: a ring in between is not missed.
    pub fn rung(&self) -> u64 {
        *self.rung.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Waits (on the host's clock) until it has rung more than `seen` times or `timeout` has
    /// passed; whether it rang.
    pub fn wait(&self, seen: u64, timeout: Duration) -> bool {
        let r = self.rung.lock().unwrap_or_else(|e| e.into_inner());
        let (r, _) = self
            .cv
            .wait_timeout_while(r, timeout, |r| *r <= seen)
            .unwrap_or_else(|e| e.into_inner());
        *r > seen
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;
    use std::time::Instant;

    #[test]
    fn a_ring_ends_a_wait_at_once_and_is_not_missed_before_it() {
        let bell = Arc::new(Bell::new());
        let seen = bell.rung();
        // Rung before the wait starts: the wait returns at once.
        bell.ring();
        let t = Instant::now();
        assert!(bell.wait(seen, Duration::from_secs(5)));
        assert!(t.elapsed() < Duration::from_secs(1));
        // Rung from another thread while waiting.
        let seen = bell.rung();
        let b = Arc::clone(&bell);
        let ringer = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(50));
            b.ring();
        });
        let t = Instant::now();
        assert!(bell.wait(seen, Duration::from_secs(5)));
        assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
        ringer.join().unwrap();
        // Not rung: the timeout.
        assert!(!bell.wait(bell.rung(), Duration::from_millis(10)));
    }
}
