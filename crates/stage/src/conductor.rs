//! A conductor started: its tempo source opened on a thread of its own (a video's frame
//! source stays there) and followed there ([`crate::sources::follow`]), steering the
//! performance through its `Control` until the source ends; [`Conducting`]: a conductor
//! started for a song, with the control, the clock, the taps and the status line a front end
//! steering a live performance by it needs.

use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use orch_perform::{Control, Follow, Follower, ScoreBeats};
use orch_seq::Song;

use crate::sources::{follow, open_source, source_name, SourceSpec, Stamp, Status};
use crate::SourceError;

/// A conductor started for a song: its source followed on a thread of its own (see
/// [`start`]), steering [`control`](Self::control), the performance's.
pub struct Conducting {
    /// The control the conductor steers: the performance's (a conductor's change rings its
    /// bell: the performer wakes and takes it at once).
    pub control: Arc<Control>,
    /// The performers' clock's zero: the conductor's cues are timed on it.
    pub origin: Instant,
    taps: Option<Sender<u64>>,
    status: Arc<Mutex<Status>>,
    name: String,
}

impl Conducting {
    /// Opens the source `spec` names and follows it, the beats of `song` in `mode`, on a
    /// thread of its own (see [`start`]). Returns once the source is open.
    pub fn start(spec: &SourceSpec, song: &Song, mode: Follow) -> Result<Self, SourceError> {
        let follower = Follower::new(ScoreBeats::of(song), mode);
        let control = Control::new();
        let origin = Instant::now();
        let status = Arc::new(Mutex::new(Status::default()));
        let (tx, rx) = mpsc::channel();
        let tap = *spec == SourceSpec::Tap;
        let rx = tap.then_some(rx);
        start(spec, follower, &control, Stamp(origin), rx, &status)?;
        Ok(Self {
            control,
            origin,
            taps: tap.then_some(tx),
            status,
            name: source_name(spec),
        })
    }

    /// A beat tapped now, for a tap source (`--source tap`); nothing for any other.
    pub fn tap(&self) {
        if let Some(tx) = &self.taps {
            let _ = tx.send(Stamp(self.origin).now_us());
        }
    }

    /// What the conductor did so far, in a line ([`Status::line`]).
    pub fn line(&self) -> String {
        self.status
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .line(&self.name)
    }
}

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
