//! A conductor started: its tempo source opened on a thread of its own (a video's frame
//! source stays there) and followed there ([`crate::sources::follow`]), steering the
//! performance through its `Control` until the source ends.

use std::sync::mpsc::{self, Receiver};
use std::sync::{Arc, Mutex};

use orch_perform::{Control, Follower};

use crate::sources::{follow, open_source, SourceSpec, Stamp, Status};
use crate::SourceError;

/// Opens the source `spec` names and follows it with `follower` on a thread of its own,
/// steering `control`, with what the conductor did in `status`; `taps` carries the tap
/// source's key presses (µs on `stamp`'s clock). Returns once the source is open: a source
/// that cannot be opened is refused here, before anything plays.
///
/// A source that only waits for its input (not a video to decode) reads at the sender's
/// priority, so a cue is not left waiting behind other work on the machine. The thread is
/// detached: a source blocked on its input ends with the process.
pub fn start(
    spec: &SourceSpec,
    follower: Follower,
    control: &Arc<Control>,
    stamp: Stamp,
    taps: Option<Receiver<u64>>,
    status: &Arc<Mutex<Status>>,
) -> Result<(), SourceError> {
    let (control, status) = (Arc::clone(control), Arc::clone(status));
    let (opened_tx, opened) = mpsc::channel();
    let spec = spec.clone();
    let urgent = !matches!(spec, SourceSpec::Baton(_) | SourceSpec::Camera(_));
    std::thread::spawn(move || match open_source(&spec, &control, stamp, taps) {
        Ok(source) => {
            if urgent {
                orch_perform::realtime::raise_priority();
            }
            let _ = opened_tx.send(Ok(()));
            follow(source, follower, &control, &status, stamp);
        }
        Err(e) => {
            let _ = opened_tx.send(Err(e));
        }
    });
    opened.recv().unwrap_or_else(|_| {
        Err(SourceError::Io {
            what: "the tempo source's thread ended".into(),
            source: std::io::Error::other("it panicked opening the source"),
        })
    })
}
