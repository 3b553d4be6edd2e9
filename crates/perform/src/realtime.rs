//! Real time: the sender on its own thread, a precise clock, lateness per message sent.
//!
//! [`PreciseClock`] waits with `spin_sleep` (the OS sleep for the bulk of the wait, then a
//! spin for the last stretch, so a deadline is met to a few µs on an idle machine instead of a
//! scheduler tick). [`spawn`] runs a performance on a thread of its own, asking the OS for
//! real-time priority first ([`raise_priority`]); the caller's thread stays free for the view.

use std::time::{Duration, Instant};

use orch_seq::{Bell, Clock, Lateness};

/// The host's monotonic clock, waiting with `spin_sleep`. It never wakes early.
#[derive(Debug)]
pub struct PreciseClock {
    start: Instant,
    sleeper: spin_sleep::SpinSleeper,
    samples: Vec<u64>,
}

impl PreciseClock {
    /// A clock starting now.
    pub fn new() -> Self {
        Self::starting_at(Instant::now())
    }

    /// A clock whose 0 is `start`: performances on several threads (one per output) that
    /// share it play in step.
    pub fn starting_at(start: Instant) -> Self {
        Self {
            start,
            sleeper: spin_sleep::SpinSleeper::default(),
            samples: Vec::new(),
        }
    }
}

impl PreciseClock {
    /// The last stretch of a wait that a [`Bell`] does not interrupt: spun out precisely.
    pub const BELL_SLACK: Duration = Duration::from_micros(250);
}

impl Default for PreciseClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for PreciseClock {
    fn now_us(&self) -> u64 {
        u64::try_from(self.start.elapsed().as_micros()).unwrap_or(u64::MAX)
    }

    fn wait_until(&mut self, deadline_us: u64) -> u64 {
        let now = self.now_us();
        if deadline_us > now {
            self.sleeper.sleep(Duration::from_micros(deadline_us - now));
        }
        let late = self.now_us().saturating_sub(deadline_us);
        self.samples.push(late);
        late
    }

    fn lateness(&self) -> Lateness {
        Lateness::of(&self.samples)
    }

    /// Sleeps on the bell until [`PreciseClock::BELL_SLACK`] before the deadline (a
    /// condition variable: a ring wakes it at once), then `spin_sleep`s the rest, which no
    /// ring interrupts (at most that long).
    fn wait_until_rung(&mut self, deadline_us: u64, bell: &Bell, seen: u64) -> bool {
        let slack = Self::BELL_SLACK.as_micros() as u64;
        loop {
            if bell.rung() > seen {
                return true;
            }
            let now = self.now_us();
            if now + slack >= deadline_us {
                break;
            }
            bell.wait(seen, Duration::from_micros(deadline_us - slack - now));
        }
        self.wait_until(deadline_us);
        false
    }
}

/// The priority [`raise_priority`] obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Priority {
    /// A real-time scheduling policy (Linux: `SCHED_FIFO` at its highest priority): the
    /// sender runs before every ordinary process.
    Realtime,
    /// The highest priority of the thread's ordinary policy (a lower nice value).
    Raised,
    /// The OS refused both (an unprivileged process usually may not): normal priority.
    Normal,
}

/// Asks the OS to run the current thread at real-time priority: `SCHED_FIFO` where the OS
/// has it and allows it (root, or `CAP_SYS_NICE`, or an `rtprio` limit), else the highest
/// priority of its ordinary policy.
pub fn raise_priority() -> Priority {
    #[cfg(unix)]
    {
        use thread_priority::{
            set_thread_priority_and_policy, thread_native_id, RealtimeThreadSchedulePolicy,
            ThreadPriority, ThreadSchedulePolicy,
        };
        let fifo = ThreadSchedulePolicy::Realtime(RealtimeThreadSchedulePolicy::Fifo);
        if set_thread_priority_and_policy(thread_native_id(), ThreadPriority::Max, fifo).is_ok() {
            return Priority::Realtime;
        }
    }
    if thread_priority::set_current_thread_priority(thread_priority::ThreadPriority::Max).is_ok() {
        Priority::Raised
    } else {
        Priority::Normal
    }
}

/// Runs `f` on a thread of its own at real-time priority where the OS allows it. The
/// handle's result says which priority it got, with `f`'s result.
pub fn spawn<T: Send + 'static>(
    f: impl FnOnce() -> T + Send + 'static,
) -> std::thread::JoinHandle<(Priority, T)> {
    std::thread::Builder::new()
        .name("orch-sender".into())
        .spawn(move || {
            let raised = raise_priority();
            (raised, f())
        })
        .expect("a thread can be started")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_precise_wait_ends_at_a_ring_and_otherwise_at_its_deadline() {
        let bell = std::sync::Arc::new(Bell::new());
        let mut c = PreciseClock::new();
        let seen = bell.rung();
        let b = std::sync::Arc::clone(&bell);
        let ringer = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(20));
            b.ring();
        });
        assert!(c.wait_until_rung(5_000_000, &bell, seen));
        assert!(c.now_us() < 2_000_000, "{}", c.now_us());
        ringer.join().unwrap();
        let now = c.now_us();
        assert!(!c.wait_until_rung(now + 10_000, &bell, bell.rung()));
        assert!(c.now_us() >= now + 10_000);
    }
}
