//! What a playing peer announces to newcomers: the session's start again, as a change the
//! SDK sends, that does not walk the start away however long the session plays.
//!
//! A peer learns the session's start/stop state only when it changes, so each orch peer that
//! plays commits the start again, a µs off the value the session holds (see the `session`
//! module). Moving it a µs from wherever the session holds it would let it walk: two peers
//! announcing at once each move it from the value they read, one of the two moves is lost,
//! and over hours of announcements the start wanders. A newcomer counts bar one from the
//! start it reads, so it could count from another bar line than the others did.
//!
//! So each peer keeps an [`Anchor`]: the start as it first saw it, on its own clock. It
//! announces either the anchor or the anchor plus one µs, whichever the session does not
//! hold now. Whatever the races, the start stays on values some peer anchored on (or a µs
//! after), so it moves only when a newcomer anchors on an announced value, by a µs at most.
//! A start farther than [`REANCHOR_US`] from the anchor is a new start (the session started
//! again, or its tempo changed, which moves the start's moment, not its beat): the peer
//! anchors on it.

/// How far (µs) the session's start may be from a peer's anchor and still be that start
/// announced again, not a new one.
pub const REANCHOR_US: i64 = 4;

/// A peer's memory of the start it announces; see the [module notes](self).
///
/// ```
/// use orch_link::Anchor;
///
/// let mut anchor = Anchor::at(1_000_000);
/// assert_eq!(anchor.announce(1_000_000), 1_000_001);
/// assert_eq!(anchor.announce(1_000_001), 1_000_000);
/// // Another peer's announcement, a µs later: back to this peer's anchor.
/// assert_eq!(anchor.announce(1_000_002), 1_000_000);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Anchor(Option<i64>);

impl Anchor {
    /// No start seen yet.
    pub const fn new() -> Self {
        Self(None)
    }

    /// Anchored on `start` (host µs): the start this peer counted its bar one from.
    pub const fn at(start: i64) -> Self {
        Self(Some(start))
    }

    /// The start to commit (host µs), given the start the session holds now: the anchor or
    /// the anchor plus one, never `now_start` itself.
    pub fn announce(&mut self, now_start: i64) -> i64 {
        let anchor = match self.0 {
            Some(a) if (now_start - a).abs() <= REANCHOR_US => a,
            _ => now_start,
        };
        self.0 = Some(anchor);
        if now_start == anchor {
            anchor + 1
        } else {
            anchor
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A session's start as the SDK keeps it (on a clock all peers share), announced by
    /// peers whose clocks are offset from it, who often read a start another peer has
    /// already replaced (announcing at once, the later commit wins).
    struct Sim {
        /// Every start committed, the session's now last.
        history: Vec<i64>,
        seed: u64,
    }

    impl Sim {
        fn random(&mut self, below: u64) -> u64 {
            self.seed = self
                .seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (self.seed >> 33) % below
        }

        /// The session's start now.
        fn start(&self) -> i64 {
            *self.history.last().expect("a start")
        }

        /// The peer whose clock is `offset` off announces, having read the start as it was
        /// up to two commits ago.
        fn announce(&mut self, commit: impl FnOnce(i64) -> i64, offset: i64) {
            let stale = self.random(3) as usize;
            let read = self.history[self.history.len() - 1 - stale.min(self.history.len() - 1)];
            let host = commit(read - offset);
            assert_ne!(
                host + offset,
                read,
                "an announcement must be a change the SDK sends"
            );
            self.history.push(host + offset);
        }
    }

    /// Four peers that counted from the start, their clocks 0 to 3 µs off the session's,
    /// announcing in a random order for the equivalent of hours (a second each), and a
    /// newcomer joining now and then, anchoring on whatever start it reads: the start never
    /// leaves where it began by more than a µs a newcomer.
    #[test]
    fn hours_of_racing_announcements_keep_the_start_where_it_began() {
        for seed in 0..20 {
            let began = 5_000_000_000;
            let mut sim = Sim {
                history: vec![began],
                seed,
            };
            let mut peers: Vec<(Anchor, i64)> =
                (0..4).map(|o| (Anchor::at(began - o), o)).collect();
            for round in 0..20_000 {
                if round % 5_000 == 4_999 {
                    peers.push((Anchor::new(), round as i64 % 7));
                }
                let who = sim.random(peers.len() as u64) as usize;
                let (anchor, offset) = &mut peers[who];
                sim.announce(|now| anchor.announce(now), *offset);
                let newcomers = peers.len() as i64 - 4;
                assert!(
                    (sim.start() - began).abs() <= 1 + newcomers,
                    "seed {seed}, round {round}: the start moved {} µs",
                    sim.start() - began
                );
            }
        }
    }

    /// The way before anchors (each peer nudging the start it read, by +1 and -1 in turn)
    /// walks the start away under the same races: what the test above guards against.
    #[test]
    fn nudging_the_start_read_walks_it_away() {
        let began = 5_000_000_000;
        let mut sim = Sim {
            history: vec![began],
            seed: 1,
        };
        let mut nudges = [1_i64; 4];
        let mut farthest = 0;
        for _ in 0..80_000 {
            let who = sim.random(4) as usize;
            nudges[who] = -nudges[who];
            let nudge = nudges[who];
            sim.announce(|now| now + nudge, who as i64);
            farthest = farthest.max((sim.start() - began).abs());
        }
        assert!(farthest > 20, "farthest {farthest} µs");
    }

    #[test]
    fn a_start_moved_farther_is_a_new_start() {
        let mut a = Anchor::new();
        assert_eq!(a.announce(1_000), 1_001);
        assert_eq!(a.announce(1_001), 1_000);
        assert_eq!(a.announce(1_004), 1_000);
        // The session was stopped and started again, 2 s later.
        assert_eq!(a.announce(2_001_000), 2_001_001);
        assert_eq!(a.announce(2_001_001), 2_001_000);
    }
}
