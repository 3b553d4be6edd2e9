//! How long a soundfont's note is silent after its voice starts, to start it that much early.

use std::collections::HashMap;
use std::sync::Arc;

use rustysynth::{SoundFont, SynthesizerSettings};

use crate::error::RenderError;
use crate::events::Instrument;
use crate::synth::{set_instrument, synth_settings, synthesizer};

/// Each note's **lead** in this soundfont: the samples from a voice's start to its first
/// sample that is not silent (the soundfont's volume-envelope delay, which the SF2 default of
/// −12 000 timecents makes about 1 ms, and any silence at the head of its sample). Measured
/// once for each instrument, note and velocity a render plays, by playing it alone from
/// silence on the render's own settings, and taken off the strike's start, so that the sound
/// begins on the strike's sample. At most [`MAX_LEAD_MS`]; a note silent that long counts no lead.
pub(crate) struct Leads {
    font: Arc<SoundFont>,
    settings: SynthesizerSettings,
    gain: f32,
    max: usize,
    known: HashMap<(Instrument, u8, u8), u64>,
}

/// The longest lead looked for, ms.
pub const MAX_LEAD_MS: u32 = 100;

impl Leads {
    pub(crate) fn new(font: &Arc<SoundFont>, rate: u32, gain: f32) -> Self {
        Self {
            font: Arc::clone(font),
            settings: synth_settings(rate, 8),
            gain,
            max: (rate * MAX_LEAD_MS / 1000) as usize,
            known: HashMap::new(),
        }
    }

    /// The lead of `note` of `instrument` at synthesizer velocity `velocity`, samples.
    pub(crate) fn of(
        &mut self,
        instrument: Instrument,
        note: u8,
        velocity: u8,
    ) -> Result<u64, RenderError> {
        if let Some(&lead) = self.known.get(&(instrument, note, velocity)) {
            return Ok(lead);
        }
        let mut synth = synthesizer(&self.font, &self.settings, self.gain)?;
        set_instrument(&mut synth, 0, instrument);
        synth.note_on(0, note.into(), velocity.into());
        let (mut l, mut r) = ([0f32; 64], [0f32; 64]);
        let mut lead = 0;
        let mut seen = 0;
        while seen < self.max {
            synth.render(&mut l, &mut r);
            if let Some(k) = l.iter().zip(&r).position(|(a, b)| *a != 0.0 || *b != 0.0) {
                lead = (seen + k) as u64;
                break;
            }
            seen += l.len();
        }
        self.known.insert((instrument, note, velocity), lead);
        Ok(lead)
    }
}
