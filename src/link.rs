//! `orch play --link`: the robot as one peer of an Ableton Link session (the `link` feature).
//! Joining, waiting for the session to play, the entry (bar and beat), the start on the
//! session's bar line and the follower are `orch_link`'s; here: the order of things and what
//! is said on standard error.

use std::sync::Arc;
use std::time::Instant;

use orch_perform::{Control, Tempo};
use orch_seq::Song;

/// A session joined and playing, and where this robot comes in.
pub struct Joined {
    /// Steers the performance: its start, tempo and stop.
    pub control: Arc<Control>,
    /// The performer's clock's zero.
    pub origin: Instant,
    /// Where the robot comes in, µs of score time (`None`: the top).
    pub from_us: Option<u64>,
    /// The tempo factor to start at.
    pub tempo: Tempo,
    #[cfg(feature = "link")]
    inner: imp::Inner,
}

/// The beats of the file's first bar (a quarter note a beat): the session's quantum.
pub fn quantum(song: &Song) -> f64 {
    // 4/4 until the file says otherwise.
    match song.time_signatures().first().filter(|ts| ts.tick == 0) {
        Some(ts) => f64::from(ts.numerator) * 4.0 / f64::from(1u32 << ts.denominator_log2),
        None => 4.0,
    }
}

#[cfg(feature = "link")]
pub use imp::join;

#[cfg(feature = "link")]
mod imp {
    use std::sync::atomic::AtomicBool;
    use std::sync::Arc;
    use std::time::Instant;

    use orch_link::session::{follow, Following, Session};
    use orch_link::{entry, Steer, Timeline};
    use orch_perform::{Control, Planner, ScoreBeats, Setup, Tempo, WallTime};
    use orch_seq::Song;

    use super::{quantum, Joined};

    /// The session and its follower, kept for the end.
    pub struct Inner {
        session: Arc<Session>,
        steer: Steer,
    }

    /// Time for setting the robot up after the entry is chosen (opening its outputs,
    /// configuring its boards), µs.
    const SETTING_UP_US: i64 = 50_000;

    /// Joins the session, waits for it to play (starting it with `start`), and finds where
    /// the robot comes in. `give_up` (a signal) stops the wait: `None`.
    pub fn join(
        song: &Song,
        setup: &Setup,
        start: bool,
        give_up: &AtomicBool,
    ) -> anyhow::Result<Option<Joined>> {
        let quantum = quantum(song);
        let session = Arc::new(Session::join(120.0));
        eprintln!("orch: --link: joined the Link session; waiting for it to play");
        if !session.wait_playing(start, give_up) {
            return Ok(None);
        }
        let lookahead =
            Planner::new(std::iter::empty(), setup.rules(), 0, Tempo::NORMAL).jump_lead_us();
        let timeline = session.capture();
        let origin = Instant::now();
        let (host, wall) = session.now_pair(origin);
        let entry = entry(&timeline, quantum, host, lookahead + SETTING_UP_US);
        let steer = Steer::new(ScoreBeats::of(song), quantum, entry, lookahead);
        let from = steer.entry_score_us();
        let tempo = steer
            .factor_at(from, timeline.tempo())
            .ok_or_else(|| anyhow::anyhow!("--link: the session's tempo {}", timeline.tempo()))?;
        let control = Control::new();
        control.start_at(WallTime::from_signed(entry.host_us - host + wall));
        let (bar, beat) = song.bar_beat(from);
        eprintln!(
            "orch: --link: the session plays at {:.1} BPM with {} other peers; coming in at bar \
             {bar} beat {beat} in {} ms",
            timeline.tempo(),
            session.peers(),
            (entry.host_us - host) / 1000
        );
        Ok(Some(Joined {
            control,
            origin,
            from_us: (from > 0).then_some(from),
            tempo,
            inner: Inner { session, steer },
        }))
    }

    impl Joined {
        /// Keeps the performance on the session's beat until the follower's `end`.
        pub fn follow(&self) -> Followed {
            Followed(follow(
                Arc::clone(&self.inner.session),
                Arc::clone(&self.control),
                self.origin,
                self.inner.steer.clone(),
            ))
        }
    }

    /// The follower, running.
    pub struct Followed(Following);

    impl Followed {
        /// The performance ended: stop following, and say how it ended.
        pub fn end(self) {
            let f = self.0.finish();
            if f.stopped_by_session {
                eprintln!("orch: --link: the session stopped");
            }
            tracing::debug!(
                "--link: {} tempo factors, {} jumps, {} announcements",
                f.tempos,
                f.jumps,
                f.announced
            );
        }
    }
}

/// `--link` without the `link` feature: said so, with how to build it and what that means.
#[cfg(not(feature = "link"))]
pub fn join(
    _: &Song,
    _: &orch_perform::Setup,
    _: bool,
    _: &std::sync::atomic::AtomicBool,
) -> anyhow::Result<Option<Joined>> {
    Err(crate::error::bad_input(
        "--link: this orch was built without the `link` feature (Ableton Link, through \
         Ableton's GPL-2.0-or-later SDK: a binary built with it is distributed under the \
         GPL); build it with `cargo build --release --features link` (needs cmake and \
         libclang-dev)",
    ))
}
