//! Helpers the performer's integration tests share: the shared corpus, a robot on a fast bus,
//! and a render on the virtual clock.
#![allow(dead_code)]

use std::path::PathBuf;

use std::sync::Arc;

use orch_core::Config;
use orch_perform::{
    thesis_config, Control, Link, MidiOut, MidiRecording, Performer, Played, ScoreEvent, Setup,
};
use orch_seq::{Song, VirtualClock};

/// The shared corpus of real MIDI files, beside the checkout.
pub fn shared_midi() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/midi")
}

/// One file of the shared corpus, parsed.
pub fn corpus_song(file: &str) -> Song {
    let bytes = std::fs::read(shared_midi().join(file))
        .unwrap_or_else(|e| panic!("{file} of the shared corpus (../shared/midi): {e}"));
    Song::parse(&bytes).unwrap()
}

/// The thesis's robot with `config`'s settings on a 400 kHz bus, compensation on, at the
/// written tempo, over `link`.
pub fn setup_with(config: Config<16>, link: Link) -> Setup {
    Setup::new(
        config,
        orch_sim::SimConfig {
            clock: orch_sim::BusClock::FAST,
            ..orch_sim::SimConfig::thesis()
        },
    )
    .with_link(link)
}

/// [`setup_with`] the thesis's configuration.
pub fn setup(link: Link) -> Setup {
    setup_with(thesis_config(), link)
}

/// Performs `events` (`notes` Note-Ons) on the virtual clock, to `midi` if given.
pub fn render_to<M: MidiOut>(
    setup: &Setup,
    events: impl Iterator<Item = ScoreEvent> + Clone,
    notes: usize,
    midi: Option<&mut M>,
) -> Played {
    let performer = Performer::new(setup, events, notes);
    match midi {
        Some(out) => performer.midi(out).run(),
        None => performer.run(),
    }
    .unwrap()
}

/// Performs `events` on the virtual robot alone.
pub fn render(
    setup: &Setup,
    events: impl Iterator<Item = ScoreEvent> + Clone,
    notes: usize,
) -> Played {
    render_to::<MidiRecording>(setup, events, notes, None)
}

/// The note numbers of the Note-Ons sent, in order, with their send times.
pub fn note_ons_at(out: &MidiRecording) -> Vec<(u64, u8)> {
    out.sent
        .iter()
        .scan(0u8, |status, (t, b)| {
            let (st, data) = if b[0] >= 0x80 {
                (b[0], &b[1..])
            } else {
                (*status, &b[..])
            };
            if b[0] < 0xF8 {
                *status = st;
            }
            Some((*t, st, data.to_vec()))
        })
        .filter(|(_, st, d)| st & 0xF0 == 0x90 && d.len() == 2 && d[1] > 0)
        .map(|(t, _, d)| (t, d[0]))
        .collect()
}

/// The note numbers of the Note-Ons sent, in order.
pub fn note_ons(out: &MidiRecording) -> Vec<u8> {
    note_ons_at(out).into_iter().map(|(_, n)| n).collect()
}

/// A clock that acts on the performer's [`Control`] once (a jump, a tempo change), in the wait
/// that ends at `at_us` after the score's start or later: the performer takes it right after
/// what it sends then.
pub struct ActAt<F: FnMut(&Control)> {
    inner: VirtualClock,
    control: Arc<Control>,
    at_us: u64,
    act: Option<F>,
}

impl<F: FnMut(&Control)> ActAt<F> {
    /// Whether it has acted.
    pub fn done(&self) -> bool {
        self.act.is_none()
    }

    pub fn new(control: &Arc<Control>, at_us: u64, act: F) -> Self {
        Self {
            inner: VirtualClock::new(),
            control: Arc::clone(control),
            at_us,
            act: Some(act),
        }
    }
}

impl<F: FnMut(&Control)> orch_seq::Clock for ActAt<F> {
    fn now_us(&self) -> u64 {
        self.inner.now_us()
    }

    fn wait_until(&mut self, deadline_us: u64) -> u64 {
        if let Some(m) = self.control.time_map() {
            let start = m.wall(0).max(0) as u64;
            if deadline_us >= start + self.at_us {
                if let Some(mut act) = self.act.take() {
                    act(&self.control);
                }
            }
        }
        self.inner.wait_until(deadline_us)
    }

    fn lateness(&self) -> orch_seq::Lateness {
        self.inner.lateness()
    }
}

/// The thesis's 61 keys on four PCA9685 boards (0x40..=0x43) with the default dynamics (strike
/// at 45..100 % by velocity, hold at 35 %), on a 1 MHz bus, with `mechanics` for the keys.
pub fn pwm_setup(mechanics: orch_sim::MechanicsConfig, compensation: bool) -> Setup {
    let mut config = Config {
        dynamics: orch_core::Dynamics::PWM,
        ..thesis_config()
    };
    for (i, b) in config.layout.boards.iter_mut().take(4).enumerate() {
        b.address = 0x40 + i as u8;
    }
    let sim = orch_sim::SimConfig {
        clock: orch_sim::BusClock::from_hz(1_000_000),
        mechanics,
        kinds: vec![orch_core::BoardKind::Pwm; 4],
        ..orch_sim::SimConfig::thesis().with_layout(&config.layout)
    };
    Setup::new(
        config,
        orch_sim::SimConfig {
            boards: sim.boards[..4].to_vec(),
            ..sim
        },
    )
    .with_compensation(compensation)
}
