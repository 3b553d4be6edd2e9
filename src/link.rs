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
pub use imp::{join, lead, page_session, Leader};

#[cfg(feature = "link")]
mod imp {
    use std::sync::atomic::AtomicBool;
    use std::sync::Arc;
    use std::time::Instant;

    use orch_link::session::{
        follow, Following, Leading, Session, ALONE_AFTER, DISCOVERY, DISCOVERY_GROUP,
    };
    use orch_link::{entry, Lead, Steer, StopGuard, Timeline};
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
        let alone = || {
            eprintln!(
                "orch: --link: no other Link peer after {} s; still waiting (peers find each other \
                 by multicast to {DISCOVERY_GROUP}: the network and every host's firewall must \
                 pass it)",
                ALONE_AFTER.as_secs()
            );
        };
        if !session.wait_playing(start, give_up, alone) {
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

    /// The time the other robots get between the conductor's start and bar one, µs: to hear
    /// of the start and send their first notes early.
    const LEADER_LEAD_US: i64 = 1_000_000;

    /// A conductor's performance leading the session (`orch conduct --link`).
    pub struct Leader(Leading);

    /// Joins the session and starts it for the performance that `control` steers (its
    /// clock's zero at `origin`), `song` from its top: bar one is the first bar line a second
    /// from now, where the performance starts; its tempo and phase are published from then
    /// on, and the session stops when [`Leader::end`] is called. Listens for a session
    /// first ([`DISCOVERY`]), so that it leads the one on the network, not one of its own.
    pub fn lead(song: &Song, control: &Arc<Control>, origin: Instant) -> anyhow::Result<Leader> {
        let quantum = quantum(song);
        let beats = ScoreBeats::of(song);
        let bpm = 60e6 / beats.at(0).1;
        let session = Arc::new(Session::join(bpm));
        std::thread::sleep(DISCOVERY);
        let (at, bar_one) = session.start_leading(bpm, LEADER_LEAD_US, quantum);
        let (host, wall) = session.now_pair(origin);
        control.start_at(WallTime::from_signed(at - host + wall));
        eprintln!(
            "orch: --link: started the Link session ({} other peers) at {bpm:.1} BPM; bar one in \
             {} ms",
            session.peers(),
            (at - host) / 1000
        );
        let lead = Lead::new(beats, quantum, bar_one);
        Ok(Leader(orch_link::session::lead(
            session,
            Arc::clone(control),
            origin,
            lead,
            quantum,
        )))
    }

    impl Leader {
        /// The performance ended: stop the session (every robot stops), and say so.
        pub fn end(self) {
            let led = self.0.finish();
            eprintln!("orch: --link: stopped the Link session");
            said_again(led.restops);
            tracing::debug!(
                "--link: {} tempos published, {} beats forced, {} announcements",
                led.tempos,
                led.beats,
                led.announced
            );
        }
    }

    /// Says that this peer stopped the session `restops` more times after its stop (an
    /// announcement that it played had crossed the stop), if it did.
    fn said_again(restops: u64) {
        if restops > 0 {
            eprintln!(
                "orch: --link: stopped the session again ({restops}x): a peer that had not yet \
                 heard of the stop said it played"
            );
        }
    }

    /// The session as `orch serve`'s page shows and steers it.
    struct PageSession(Arc<Session>);

    impl orch_serve::Session for PageSession {
        fn status(&self) -> orch_serve::SessionStatus {
            let t = self.0.capture();
            orch_serve::SessionStatus {
                peers: self.0.peers(),
                bpm: t.tempo(),
                playing: t.is_playing(),
            }
        }

        fn start(&self) {
            self.0.start();
        }

        /// Stops the session, and guards the stop for a moment from a thread of its own.
        fn stop(&self) {
            let at = self.0.stop();
            let session = Arc::clone(&self.0);
            std::thread::spawn(move || {
                let restops = session.guard_stop(StopGuard::at(at, session.host_us()));
                said_again(restops);
            });
        }

        fn set_tempo(&self, bpm: f64) {
            self.0.set_tempo(bpm);
        }
    }

    /// Joins the session for `orch serve --link`'s page.
    pub fn page_session() -> anyhow::Result<Arc<dyn orch_serve::Session>> {
        Ok(Arc::new(PageSession(Arc::new(Session::join(120.0)))))
    }

    /// The follower, running.
    pub struct Followed(Following);

    impl Followed {
        /// The performance ended: stop following, and say how it ended.
        pub fn end(self) {
            let f = self.0.finish();
            if f.stopped_by_session {
                eprintln!("orch: --link: the session stopped");
                said_again(f.restops);
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
fn without_the_feature() -> anyhow::Error {
    crate::error::bad_input(
        "--link: this orch was built without the `link` feature (Ableton Link, through \
         Ableton's GPL-2.0-or-later SDK: a binary built with it is distributed under the \
         GPL); build it with `cargo build --release --features link` (needs cmake and \
         libclang-dev)",
    )
}

/// `orch play --link` without the `link` feature: refused ([`without_the_feature`]).
#[cfg(not(feature = "link"))]
pub fn join(
    _: &Song,
    _: &orch_perform::Setup,
    _: bool,
    _: &std::sync::atomic::AtomicBool,
) -> anyhow::Result<Option<Joined>> {
    Err(without_the_feature())
}

/// `orch conduct --link` without the `link` feature: refused ([`without_the_feature`]).
#[cfg(not(feature = "link"))]
pub fn lead(_: &Song, _: &Arc<Control>, _: Instant) -> anyhow::Result<()> {
    Err(without_the_feature())
}

/// `orch serve --link` without the `link` feature: refused ([`without_the_feature`]).
#[cfg(not(feature = "link"))]
pub fn page_session() -> anyhow::Result<Arc<dyn orch_serve::Session>> {
    Err(without_the_feature())
}
