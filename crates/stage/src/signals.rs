//! The signals that stop a live front end: SIGINT, SIGTERM and SIGHUP set a flag that the
//! front end looks at, and stops the way its own stop key does (every robot stopped, every
//! key released).

use std::sync::atomic::AtomicBool;
use std::sync::Arc;

/// The signals that stop a performance: SIGINT (Ctrl-C), SIGTERM and SIGHUP (the terminal
/// gone).
pub const STOPPING: [i32; 3] = [
    signal_hook::consts::SIGINT,
    signal_hook::consts::SIGTERM,
    signal_hook::consts::SIGHUP,
];

/// A flag set by SIGINT, SIGTERM or SIGHUP from now on (for the rest of the process).
pub fn stop_flag() -> std::io::Result<Arc<AtomicBool>> {
    let flag = Arc::new(AtomicBool::new(false));
    for sig in STOPPING {
        signal_hook::flag::register(sig, Arc::clone(&flag))?;
    }
    Ok(flag)
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::Ordering;

    use super::*;

    #[test]
    fn each_stopping_signal_sets_the_flag() {
        let flag = stop_flag().unwrap();
        assert!(!flag.load(Ordering::SeqCst));
        for sig in STOPPING {
            flag.store(false, Ordering::SeqCst);
            signal_hook::low_level::raise(sig).unwrap();
            assert!(flag.load(Ordering::SeqCst), "signal {sig}");
        }
    }
}
