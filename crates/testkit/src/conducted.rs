//! A conductor on the virtual clock: beats at known times, sent as a source's bytes (OSC
//! packets or MIDI clock) through that source's decoder and the follower to a performance
//! of the virtual robot; each note's sound against its beat. Shared by the conductor's tests,
//! the `follow_figures` bench and `orch`'s baton tests (whose video frames are the inputs).

use std::sync::Arc;

use orch_perform::conduct::encode_osc;
use orch_perform::{
    song_events, Action, Control, Cue, Follow, Follower, MidiClock, OscCues, Outcome, Performer,
    ScoreBeats, Setup, Timed,
};
use orch_seq::{Bell, Clock, Lateness, Song, VirtualClock};

/// A clock whose waits deliver the conductor's input falling inside them: each input at its
/// own time (µs after the score's start) goes through `apply` (with the input's index), which
/// may steer `control` and returns when it wants to be called again with no input (the
/// follower's [`due`](Follower::due), on the wall clock): then `apply` is called with `None`
/// (as the real follower's waker does). A wait on the control's bell ends at the call that
/// rings it, at that call's time (as the real performer wakes when a cue arrives).
pub struct Conducted<F: FnMut(u64, Option<usize>, &Control) -> Option<u64>> {
    inner: VirtualClock,
    /// Times (from the score's start) at which `apply` is called, in order.
    times: Vec<u64>,
    next: usize,
    /// When `apply` asked to be called with no input (wall clock), if it did.
    wake: Option<u64>,
    start: Option<u64>,
    control: Arc<Control>,
    apply: F,
}

impl<F: FnMut(u64, Option<usize>, &Control) -> Option<u64>> Conducted<F> {
    pub fn new(control: &Arc<Control>, times: Vec<u64>, apply: F) -> Self {
        Self {
            inner: VirtualClock::new(),
            times,
            next: 0,
            wake: None,
            start: None,
            control: Arc::clone(control),
            apply,
        }
    }

    /// Delivers the inputs and wakes up to `deadline_us` (an input before a wake at the same
    /// time); with `bell`, stops after the first that rings it (after `seen` rings), the clock
    /// at that call's time: whether one did.
    fn deliver(&mut self, deadline_us: u64, bell: Option<(&Bell, u64)>) -> bool {
        if self.start.is_none() {
            self.start = self.control.time_map().map(|m| m.wall(0).max(0) as u64);
        }
        let Some(s) = self.start else {
            return false;
        };
        loop {
            let input = self.times.get(self.next).map(|&t| s + t);
            let (at, which) = match (input, self.wake) {
                (Some(i), Some(w)) if w < i => (w, None),
                (Some(i), _) => (i, Some(self.next)),
                (None, Some(w)) => (w, None),
                (None, None) => break,
            };
            if at > deadline_us {
                break;
            }
            self.inner.advance_to(at);
            if which.is_some() {
                self.next += 1;
            }
            // A wake asked for the present or the past, after a wake: not again.
            self.wake = (self.apply)(at, which, &self.control)
                .filter(|&w| w > at || which.is_some())
                .map(|w| w.max(at));
            if bell.is_some_and(|(b, seen)| b.rung() > seen) {
                return true;
            }
        }
        false
    }
}

impl<F: FnMut(u64, Option<usize>, &Control) -> Option<u64>> Clock for Conducted<F> {
    fn now_us(&self) -> u64 {
        self.inner.now_us()
    }

    fn wait_until(&mut self, deadline_us: u64) -> u64 {
        self.deliver(deadline_us, None);
        self.inner.wait_until(deadline_us)
    }

    fn wait_until_rung(&mut self, deadline_us: u64, bell: &Bell, seen: u64) -> bool {
        if bell.rung() > seen || self.deliver(deadline_us, Some((bell, seen))) {
            return true;
        }
        self.inner.wait_until(deadline_us);
        false
    }

    fn lateness(&self) -> Lateness {
        self.inner.lateness()
    }
}

/// The thesis's robot, compensation on, as written.
pub fn setup() -> Setup {
    Setup::thesis()
}

/// How the beats reach the follower.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Via {
    /// An OSC `/orch/beat` (no tempo) at each beat, through [`OscCues`].
    Osc,
    /// MIDI clock: Start, then 24 clocks a beat evenly between the beats, through
    /// [`MidiClock`] (every 24th clock is a beat).
    Clock,
}

/// Beats `n1` intervals of `bpm1` then `n2` of `bpm2`, from 0, µs.
pub fn abrupt(bpm1: f64, n1: usize, bpm2: f64, n2: usize) -> Vec<u64> {
    tempo_beats(
        &std::iter::repeat_n(bpm1, n1)
            .chain(std::iter::repeat_n(bpm2, n2))
            .collect::<Vec<_>>(),
    )
}

/// `pre` intervals at `from`, then `ramp` intervals stepping linearly (per beat) up to `to`,
/// then `post` at `to`, µs from 0.
pub fn ramp(from: f64, to: f64, pre: usize, ramp: usize, post: usize) -> Vec<u64> {
    let mut bpms = vec![from; pre];
    bpms.extend((1..=ramp).map(|k| from + (to - from) * k as f64 / ramp as f64));
    bpms.extend(std::iter::repeat_n(to, post));
    tempo_beats(&bpms)
}

/// Beats from 0, each interval at its BPM.
pub fn tempo_beats(bpms: &[f64]) -> Vec<u64> {
    let mut t = 0.0;
    let mut v = vec![0];
    for b in bpms {
        t += 60e6 / b;
        v.push(t.round() as u64);
    }
    v
}

/// The source's input for beats at `beats` (µs from the score's start).
pub fn input(beats: &[u64], via: Via) -> Vec<(u64, Vec<u8>)> {
    match via {
        Via::Osc => beats
            .iter()
            .map(|&t| (t, encode_osc("/orch/beat", &[])))
            .collect(),
        Via::Clock => {
            let mut v = vec![(beats[0], vec![0xFA, 0xF8])];
            for w in beats.windows(2) {
                let (a, b) = (w[0] as f64, w[1] as f64);
                for i in 1..=24 {
                    v.push((
                        (a + (b - a) * f64::from(i) / 24.0).round() as u64,
                        vec![0xF8],
                    ));
                }
            }
            v
        }
    }
}

/// What a conducted performance did.
#[derive(Clone, Debug)]
pub struct Run {
    /// Each note's sound, µs after the score's start on the wall clock (score order).
    pub sounds: Vec<i64>,
    /// The conductor's tempo as the follower had it after each beat cue, BPM.
    pub bpm: Vec<f64>,
    /// The conductor's period as the follower had it from each cue or wake on (µs after the
    /// score's start, µs), in order.
    pub periods: Vec<(i64, f64)>,
    /// Each tempo the follower asked against its rate (the factor that plays the score's
    /// quarter in the follower's period): above 1 pulling the phase forward, below back.
    pub pulls: Vec<f64>,
}

impl Run {
    /// For each note after the first, the conductor's beats (as the follower had the
    /// conductor's tempo, from note to note) that the performance took to play its quarter:
    /// 1 when it plays at the follower's rate, less when the phase is pulled forward, more
    /// when back.
    pub fn beats_per_quarter(&self) -> Vec<f64> {
        let period_at = |t: i64| {
            let i = self.periods.partition_point(|&(p, _)| p <= t);
            self.periods[i.saturating_sub(1)].1
        };
        self.sounds
            .windows(2)
            .map(|w| {
                // The rate changes only at the recorded times: sum over the pieces.
                let mut cuts: Vec<i64> = self
                    .periods
                    .iter()
                    .map(|&(p, _)| p)
                    .filter(|&p| p > w[0] && p < w[1])
                    .collect();
                cuts.insert(0, w[0]);
                cuts.push(w[1]);
                cuts.windows(2)
                    .map(|c| (c[1] - c[0]) as f64 / period_at(c[0]))
                    .sum()
            })
            .collect()
    }

    /// Note k's sound minus beat k, ms, for every beat with a note.
    pub fn errors_ms(&self, beats: &[u64]) -> Vec<f64> {
        beats
            .iter()
            .zip(&self.sounds)
            .map(|(&b, &s)| (s - b as i64) as f64 / 1000.0)
            .collect()
    }
}

/// Plays `song` (its quarter notes one a beat, the first at the score's start, where the
/// first input falls) following `input` through `via`'s decoder with `follow`. Every note is
/// struck once, none dropped.
pub fn conduct(song: &Song, input: &[(u64, Vec<u8>)], via: Via, follow: Follow) -> Run {
    let control = Control::new();
    let mut follower = Follower::new(ScoreBeats::of(song), follow);
    let (mut osc, mut clock_in) = (OscCues::new(), MidiClock::new());
    let mut bpm = Vec::new();
    let mut periods = Vec::new();
    let mut pulls = Vec::new();
    let beats = ScoreBeats::of(song);
    // The tempo asked against the follower's rate, where the performance stands at `t`.
    let mut pull =
        |action: &Action, t: u64, map: Option<orch_perform::TimeMap>, bpm: Option<f64>| {
            if let (Action::Tempo(f), Some(m), Some(bpm)) = (action, map, bpm) {
                let len = beats.at(m.score(t as i64)).1;
                pulls.push(f.get() / (len / (60e6 / bpm)));
            }
        };
    let mut clock = Conducted::new(
        &control,
        input.iter().map(|(t, _)| *t).collect(),
        |t: u64, k: Option<usize>, c: &Control| {
            let Some(k) = k else {
                // Woken with no cue: as the front end's waker does.
                let map = c.time_map();
                let action = follower.wake(t, map.as_ref());
                pull(&action, t, map, follower.bpm());
                action.apply(c, t);
                if let Some(p) = follower.bpm() {
                    periods.push((t, 60e6 / p));
                }
                return follower.due();
            };
            let cues: Vec<Cue> = match via {
                Via::Osc => osc.packet(t, &input[k].1).unwrap(),
                Via::Clock => input[k]
                    .1
                    .iter()
                    .filter_map(|&b| clock_in.feed(t, b))
                    .collect(),
            };
            for cue in cues {
                let map = c.time_map();
                let action = follower.cue(&Timed { t_us: t, cue }, map.as_ref());
                pull(&action, t, map, follower.bpm());
                if matches!(cue, Cue::Beat { .. }) {
                    bpm.push(follower.bpm().unwrap_or(f64::NAN));
                    if let Some(p) = follower.bpm() {
                        periods.push((t, 60e6 / p));
                    }
                }
                if !matches!(action, Action::Start) {
                    action.apply(c, t);
                }
            }
            follower.due()
        },
    );
    let mut live = |_: &orch_perform::Live| {};
    let played = Performer::new(&setup(), song_events(song), song.notes())
        .clock(&mut clock)
        .control(&control)
        .live(&mut live)
        .run()
        .unwrap();
    drop(clock);
    let r = played.report(None);
    assert!(r.adds_up(), "{r:?}");
    assert_eq!(r.outcomes.dropped.total(), 0, "{r:?}");
    assert_eq!(r.strikes, song.notes() as u64, "every note once: {r:?}");
    let start = played.start_us as i64;
    let sounds = played
        .records
        .iter()
        .map(|r| {
            let e = match r.outcome {
                Outcome::OnTime { error_us } => i64::from(error_us),
                Outcome::Late { by_us } => i64::from(by_us),
                Outcome::Early { by_us } => -i64::from(by_us),
                o => panic!("{o:?}"),
            };
            r.score_at_us + e - start
        })
        .collect();
    let periods = periods
        .into_iter()
        .map(|(t, p)| (t as i64 - start, p))
        .collect();
    Run {
        sounds,
        bpm,
        periods,
        pulls,
    }
}
