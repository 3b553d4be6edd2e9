//! Helpers the performer's integration tests share: the shared corpus, a robot on a fast bus,
//! and a render on the virtual clock.
#![allow(dead_code)]

use std::path::PathBuf;

use orch_core::Config;
use orch_perform::{
    perform, thesis_config, Link, MidiOut, MidiRecording, Played, ScoreEvent, Setup, Tempo,
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
    Setup {
        config,
        sim: orch_sim::SimConfig {
            clock: orch_sim::BusClock::FAST,
            ..orch_sim::SimConfig::thesis()
        },
        compensation: true,
        tempo: Tempo::NORMAL,
        link,
    }
}

/// [`setup_with`] the thesis's configuration.
pub fn setup(link: Link) -> Setup {
    setup_with(thesis_config(), link)
}

/// Performs `events` (`notes` Note-Ons) on the virtual clock, to `midi` if given.
pub fn render_to<M: MidiOut>(
    setup: &Setup,
    events: impl Iterator<Item = ScoreEvent>,
    notes: usize,
    midi: Option<&mut M>,
) -> Played {
    perform(
        setup,
        events,
        notes,
        midi,
        &mut VirtualClock::new(),
        None,
        None,
    )
    .unwrap()
}

/// Performs `events` on the virtual robot alone.
pub fn render(setup: &Setup, events: impl Iterator<Item = ScoreEvent>, notes: usize) -> Played {
    render_to::<MidiRecording>(setup, events, notes, None)
}
