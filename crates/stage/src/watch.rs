//! A song played live to its end with a front end watching on its own thread (a terminal
//! view, a daemon's loop): the session started (from a bar if asked), the front end called
//! over and over until every robot has finished, every robot stopped with its keys released
//! if the front end fails or panics, and every robot's end, or why it failed.

use std::any::Any;
use std::sync::Arc;
use std::time::Instant;

use orch_io::OutSpec;
use orch_perform::Control;
use orch_seq::Song;

use crate::session::{Ended, Lane, Session, SessionFailure};

/// Why a watched performance failed.
#[derive(Debug)]
pub enum WatchError<E> {
    /// The front end failed (every robot was stopped).
    Front(E),
    /// The front end panicked (every robot was stopped): the panic, to go on with.
    Panicked(Box<dyn Any + Send>),
    /// A robot failed: its output, and why.
    Failed(OutSpec, SessionFailure),
}

/// How a watched performance ended.
pub struct Watched<E> {
    /// Whether the OS refused real-time priority to a sender (its messages may then be late
    /// under load; the report's lateness says).
    pub priority_refused: bool,
    /// Every robot's end, in lane order, or why the performance failed.
    pub result: Result<Vec<Ended>, WatchError<E>>,
}

/// Plays `song` on `lanes`, steered by `control` on a clock whose zero is `origin`, from
/// `from_us` (µs of score time: a jump there before the first note) if given, calling `watch`
/// with the session until every robot has finished. A `watch` that fails stops every robot
/// (its first error is given back once they have); so does one that panics.
pub fn play<E>(
    song: Song,
    lanes: Vec<Lane>,
    control: Arc<Control>,
    origin: Instant,
    from_us: Option<u64>,
    watch: impl FnMut(&Session) -> Result<(), E>,
) -> Watched<E> {
    if let Some(t) = from_us {
        control.jump_to(t);
    }
    if lanes.is_empty() {
        return Watched {
            priority_refused: false,
            result: Ok(Vec::new()),
        };
    }
    watch_session(Session::start(song, lanes, control, origin), watch)
}

/// Calls `watch` with `session` (started by the caller: on a clock of its own, say) until
/// every robot has finished, as [`play`] does.
pub fn watch_session<E>(
    session: Session,
    mut watch: impl FnMut(&Session) -> Result<(), E>,
) -> Watched<E> {
    let control = Arc::clone(session.control());
    let watched = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let mut failed = None;
        while !session.is_finished() {
            if let Err(e) = watch(&session) {
                control.stop();
                failed.get_or_insert(e);
            }
        }
        failed
    }));
    if watched.is_err() {
        // The front end panicked: stop the robots and let them go before the panic goes on.
        control.stop();
    }
    let finished = session.finish();
    let result = match (watched, finished.failed) {
        (Err(panic), _) => Err(WatchError::Panicked(panic)),
        (Ok(Some(e)), _) => Err(WatchError::Front(e)),
        (Ok(None), Some((spec, why))) => Err(WatchError::Failed(spec, why)),
        (Ok(None), None) => Ok(finished.ended),
    };
    Watched {
        priority_refused: finished.priority_refused,
        result,
    }
}
