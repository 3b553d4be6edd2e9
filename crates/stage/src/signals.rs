//! The signals a live front end takes: for a performance, SIGINT, SIGTERM and SIGHUP set a
//! flag that the front end looks at, and stops the way its own stop key does (every robot
//! stopped, every key released) ([`stop_flag`]); for the live robot's loop, they are its
//! events ([`forward`]).

use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};
use std::sync::mpsc::Sender;
use std::sync::Arc;

use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM, SIGUSR1};
use signal_hook::iterator::{Handle, Signals};

use crate::run::Event;

/// The signals that stop a performance: SIGINT (Ctrl-C), SIGTERM and SIGHUP (the terminal
/// gone).
pub const STOPPING: [i32; 3] = [SIGINT, SIGTERM, SIGHUP];

/// A flag set by SIGINT, SIGTERM or SIGHUP from now on (for the rest of the process).
pub fn stop_flag() -> std::io::Result<Arc<AtomicBool>> {
    let flag = Arc::new(AtomicBool::new(false));
    for sig in STOPPING {
        signal_hook::flag::register(sig, Arc::clone(&flag))?;
    }
    Ok(flag)
}

/// Forwards SIGINT, SIGTERM, SIGHUP and SIGUSR1 into the live robot's loop
/// ([`crate::run::Loop`]) as its events, from a thread of its own: SIGHUP reads the robot
/// again ([`Event::Reload`]), SIGUSR1 asks for the counters ([`Event::Counters`]), SIGINT and
/// SIGTERM stop it ([`Event::Stop`]; the signal is kept in `stopped_by`). Closing the handle
/// ends the forwarding.
pub fn forward(tx: Sender<Event>, stopped_by: Arc<AtomicI32>) -> std::io::Result<Handle> {
    let mut signals = Signals::new([SIGINT, SIGTERM, SIGHUP, SIGUSR1])?;
    let handle = signals.handle();
    std::thread::Builder::new()
        .name("orch-signals".into())
        .spawn(move || {
            for s in signals.forever() {
                let event = match s {
                    SIGHUP => Event::Reload,
                    SIGUSR1 => Event::Counters,
                    _ => {
                        stopped_by.store(s, Ordering::SeqCst);
                        Event::Stop
                    }
                };
                if tx.send(event).is_err() {
                    return;
                }
            }
        })?;
    Ok(handle)
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    /// One test, so that no other raises a signal while it looks.
    #[test]
    fn the_stopping_signals_set_the_flag_and_each_is_its_loop_event() {
        let flag = stop_flag().unwrap();
        assert!(!flag.load(Ordering::SeqCst));
        for sig in STOPPING {
            flag.store(false, Ordering::SeqCst);
            signal_hook::low_level::raise(sig).unwrap();
            assert!(flag.load(Ordering::SeqCst), "signal {sig}");
        }

        let (tx, rx) = std::sync::mpsc::channel();
        let stopped_by = Arc::new(AtomicI32::new(0));
        let handle = forward(tx, Arc::clone(&stopped_by)).unwrap();
        let next = || rx.recv_timeout(Duration::from_secs(5)).unwrap();
        signal_hook::low_level::raise(SIGUSR1).unwrap();
        assert!(matches!(next(), Event::Counters));
        signal_hook::low_level::raise(SIGHUP).unwrap();
        assert!(matches!(next(), Event::Reload));
        assert_eq!(stopped_by.load(Ordering::SeqCst), 0);
        signal_hook::low_level::raise(SIGTERM).unwrap();
        assert!(matches!(next(), Event::Stop));
        assert_eq!(stopped_by.load(Ordering::SeqCst), SIGTERM);
        handle.close();
    }
}
