//! A conductor on the virtual clock: beats at known times, sent as a source's bytes (OSC
//! packets or MIDI clock) through that source's decoder and the follower to a performance
//! of the virtual robot; each note's sound against its beat. Shared by the conductor's tests
//! and the `follow_figures` example (`#[path]`-included there).
#![allow(dead_code)]

use std::sync::Arc;

use orch_perform::conduct::encode_osc;
use orch_perform::{
    perform, song_events, thesis_config, Action, Control, Cue, Follow, Follower, Link, MidiClock,
    MidiRecording, OscCues, Outcome, ScoreBeats, Setup, Tempo, Timed,
};
use orch_seq::{Bell, Clock, Lateness, Song, VirtualClock};

/// A clock whose waits deliver the conductor's input falling inside them: each input at its
/// own time (µs after the score's start) goes through `apply`, which may steer `control`. A
/// wait on the control's bell ends at the input that rings it, at that input's time (as the
/// real performer wakes when a cue arrives).
pub struct Conducted<F: FnMut(u64, &Control)> {
    inner: VirtualClock,
    /// Times (from the score's start) at which `apply` is called, in order.
    times: Vec<u64>,
    next: usize,
    start: Option<u64>,
    control: Arc<Control>,
    apply: F,
}

impl<F: FnMut(u64, &Control)> Conducted<F> {
    pub fn new(control: &Arc<Control>, times: Vec<u64>, apply: F) -> Self {
        Self {
            inner: VirtualClock::new(),
            times,
            next: 0,
            start: None,
            control: Arc::clone(control),
            apply,
        }
    }

    /// Delivers the inputs up to `deadline_us`; with `bell`, stops after the first that rings
    /// it (after `seen` rings), the clock at that input's time: whether one did.
    fn deliver(&mut self, deadline_us: u64, bell: Option<(&Bell, u64)>) -> bool {
        if self.start.is_none() {
            self.start = self.control.time_map().map(|m| m.wall(0).max(0) as u64);
        }
        let Some(s) = self.start else {
            return false;
        };
        while let Some(&t) = self.times.get(self.next) {
            if s + t > deadline_us {
                break;
            }
            self.inner.advance_to(s + t);
            (self.apply)(s + t, &self.control);
            self.next += 1;
            if bell.is_some_and(|(b, seen)| b.rung() > seen) {
                return true;
            }
        }
        false
    }
}

impl<F: FnMut(u64, &Control)> Clock for Conducted<F> {
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
    Setup {
        config: thesis_config(),
        sim: orch_sim::SimConfig::thesis(),
        compensation: true,
        tempo: Tempo::NORMAL,
        link: Link::Direct,
    }
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
}

impl Run {
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
    let mut k = 0;
    let mut clock = Conducted::new(
        &control,
        input.iter().map(|(t, _)| *t).collect(),
        |t: u64, c: &Control| {
            let cues: Vec<Cue> = match via {
                Via::Osc => osc.packet(t, &input[k].1).unwrap(),
                Via::Clock => input[k]
                    .1
                    .iter()
                    .filter_map(|&b| clock_in.feed(t, b))
                    .collect(),
            };
            k += 1;
            for cue in cues {
                let action = follower.cue(&Timed { t_us: t, cue }, c.time_map().as_ref());
                if matches!(cue, Cue::Beat { .. }) {
                    bpm.push(follower.bpm().unwrap_or(f64::NAN));
                }
                if !matches!(action, Action::Start) {
                    action.apply(c, t);
                }
            }
        },
    );
    let mut live = |_: &orch_perform::Live| {};
    let played = perform::<_, MidiRecording>(
        &setup(),
        song_events(song),
        song.notes(),
        None,
        &mut clock,
        Some(&control),
        Some(&mut live),
    )
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
    Run { sounds, bpm }
}
