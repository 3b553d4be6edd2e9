//! A soundfont's exclusive classes across the render's synthesizers: a closed hi-hat cuts an
//! open one short.
//!
//! A SoundFont instrument zone may name an **exclusive class**: a new note of that class
//! on a channel ends every note of the class sounding on the channel at once (General MIDI
//! kits put the closed, pedal and open hi-hats, 42, 44 and 46, in one: TimGM6mb's class 1).
//! rustysynth does so within one synthesizer's channel; the render's strikes start on 64
//! synthesizers and 15 channels (see [`crate::synth`]), so the render does it itself: when
//! a strike of a class starts, each voice of that class and instrument still sounding
//! elsewhere is cut at that sample (at its synthesizer's next block: within 63 samples) by
//! a silent Note-On of the class on its synthesizer and channel (velocity 1, 84 dB down:
//! rustysynth gives the class's voice to it, ending the old sound as its own exclusive
//! class does, and drops it as inaudible at once).

use std::collections::HashMap;
use std::sync::Arc;

use rustysynth::SoundFont;

use crate::events::Instrument;

/// The velocity of the silent Note-On that cuts a voice: (1/127)² is −84 dB, under the −60
/// dB at which rustysynth drops a voice before it sounds.
pub(crate) const SILENT_VELOCITY: u8 = 1;

/// The exclusive class of each instrument's note at a velocity, looked up in the font
/// once, and the voices of each class sounding: (lane, channel, note).
pub(crate) struct Classes {
    font: Arc<SoundFont>,
    known: HashMap<(Instrument, u8, u8), i32>,
    sounding: Sounding,
}

impl Classes {
    pub(crate) fn new(font: &Arc<SoundFont>) -> Self {
        Self {
            font: Arc::clone(font),
            known: HashMap::new(),
            sounding: Sounding::default(),
        }
    }

    /// A voice of `instrument`'s `note` at `velocity` starts on `lane` and `channel`: the
    /// voices it cuts (lane, channel, note), which sound no more.
    pub(crate) fn start(
        &mut self,
        instrument: Instrument,
        note: u8,
        velocity: u8,
        lane: usize,
        channel: u8,
    ) -> Vec<Voice> {
        let font = &self.font;
        let class = *self
            .known
            .entry((instrument, note, velocity))
            .or_insert_with(|| exclusive_class(font, instrument, note, velocity));
        self.sounding
            .start(instrument, class, (lane, channel, note))
    }
}

/// A voice: its lane (synthesizer), channel and note.
pub(crate) type Voice = (usize, u8, u8);

/// The voices of each instrument's exclusive classes sounding (or not yet cut).
#[derive(Default)]
struct Sounding(HashMap<(Instrument, i32), Vec<Voice>>);

impl Sounding {
    /// `voice` (lane, channel, note) of `instrument`'s `class` starts: the voices of the class
    /// it cuts (none for class 0, none).
    fn start(&mut self, instrument: Instrument, class: i32, voice: Voice) -> Vec<Voice> {
        if class == 0 {
            return Vec::new();
        }
        std::mem::replace(self.0.entry((instrument, class)).or_default(), vec![voice])
    }
}

/// The exclusive class (0: none) of `note` at `velocity` in the preset `font` plays
/// `instrument` with (as rustysynth finds it: the bank and program, else the bank's program 0
/// for a kit or bank 0's program, else none), the first of its zones that has one.
pub(crate) fn exclusive_class(
    font: &SoundFont,
    instrument: Instrument,
    note: u8,
    velocity: u8,
) -> i32 {
    let (bank, program) = instrument.bank_and_program();
    let (bank, program) = (i32::from(bank), i32::from(program));
    let find = |b: i32, p: i32| {
        font.get_presets()
            .iter()
            .find(|x| x.get_bank_number() == b && x.get_patch_number() == p)
    };
    let fallback = if bank >= 128 { (128, 0) } else { (0, program) };
    let Some(preset) = find(bank, program).or_else(|| find(fallback.0, fallback.1)) else {
        return 0;
    };
    let (key, vel) = (i32::from(note), i32::from(velocity));
    preset
        .get_regions()
        .iter()
        .filter(|r| r.contains(key, vel))
        .filter_map(|r| font.get_instruments().get(r.get_instrument_id()))
        .flat_map(|i| i.get_regions())
        .filter(|r| r.contains(key, vel))
        .map(|r| r.get_exclusive_class())
        .find(|&c| c != 0)
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hi_hat_cuts_the_hi_hats_sounding_and_a_kick_cuts_nothing() {
        // A General MIDI kit's hi-hats are of one class (TimGM6mb: 1), its kick of none.
        let mut s = Sounding::default();
        let d = Instrument::Drums;
        assert_eq!(s.start(d, 1, (3, 0, 46)), []);
        assert_eq!(s.start(d, 0, (3, 0, 36)), []);
        assert_eq!(s.start(d, 1, (5, 1, 42)), [(3, 0, 46)]);
        assert_eq!(s.start(d, 1, (7, 2, 44)), [(5, 1, 42)]);
        // Another instrument's class 1 is its own.
        assert_eq!(s.start(Instrument::PIANO, 1, (7, 2, 44)), []);
        assert_eq!(s.start(d, 0, (7, 2, 36)), []);
    }
}
