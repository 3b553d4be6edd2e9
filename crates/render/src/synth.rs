//! Key events to samples, every strike sounding from its own sample.
//!
//! **Exact starts.** rustysynth (like FluidSynth and every block synthesizer) takes a
//! Note-On at the start of its next block: with its 64-sample default a strike would land up
//! to 1.45 ms late at 44.1 kHz, by an amount that depends on where the block boundaries fall.
//! Its blocks are at least 8 samples long, so a block of one sample is not to be had.
//! Instead, [`PHASES`] synthesizers run side by side on the same soundfont, each with blocks
//! of [`BLOCK`] (64) samples, synthesizer `p`'s blocks starting on the samples `s` with
//! `s % 64 == p`; a voice that must start on sample `s` goes to synthesizer `s % 64`, at the
//! very start of one of its blocks, so its first sample is sample `s`. Their outputs are summed (the synthesis is linear: a voice sounds the
//! same whichever synthesizer plays it, and each voice's envelope is stepped at the same
//! offsets from its own start).
//!
//! **The soundfont's lead.** A voice is silent for a while after it starts: rustysynth
//! applies the SoundFont default volume-envelope delay of −12 000 timecents literally (1 ms:
//! 41 samples at 44.1 kHz), and a font's samples may begin with silence (TimGM6mb's pianos:
//! up to 7.3 ms). Each note's lead at each velocity played is measured once (the note alone
//! from silence, on the render's own settings: the first sample that is not digital silence)
//! and the voice is started that much earlier, so that **its first sound is on the sample of
//! the strike**. A strike in the first `lead` samples of the song starts at sample 0 (late by
//! the rest of its lead). Leads longer than [`MAX_LEAD_MS`](crate::lead::MAX_LEAD_MS) are not looked for.
//!
//! **Releases.** A key's release goes to the synthesizer holding its voice, at the key-up's
//! sample, and takes effect at that synthesizer's next block boundary: up to 63 samples
//! (1.4 ms at 44.1 kHz) after the key's return (whose own release delay is tens of ms); the
//! sound then dies away by the soundfont's release (rustysynth makes it 10 ms at the least,
//! against clicks). A strike on a key still sounding ends the sound it had where the new one
//! begins (one string per key). A strike never takes the synthesizer and channel of its
//! key's previous strike, nor those of a voice of the same note still held (a Note-Off names
//! only a channel and a note), so that one strike's release never touches another's voice.
//! A strike that rings on (a drum, a bar) is released as [`crate::events`] says. A voice of
//! a soundfont's exclusive class (a General MIDI kit's hi-hats) is cut where another of its
//! class starts, on whichever synthesizer and channel it plays (a silent Note-On of the class
//! there: rustysynth's own exclusive classes, which act within one synthesizer's channel).
//!
//! **Instruments.** Each strike sounds as its [`Instrument`]: the channel it goes to is set
//! to the instrument's bank and program (bank select, program change) just before its
//! Note-On, and a voice keeps the preset it started with, so the 15 channels serve a piano,
//! a drum kit (bank 128 on any channel: rustysynth plays a bank by its number, not by the
//! channel) and a glockenspiel at once, all mixed into one output.
//!
//! **Loudness.** Each strike sounds at its exact loudness, not at a whole velocity step: see
//! [`expression_share`].
//!
//! **Dry.** No reverberation or chorus (the synthesizer's effects are off): a silence between
//! notes is digital silence once the notes' releases have died away (rustysynth ends a voice
//! under −60 dB).
//!
//! **Speed.** A voice costs more in short blocks (rustysynth steps its envelopes, LFOs and
//! filter once a block): on the densest corpus file (27 003 notes in 10 min) blocks of 64
//! rendered 91× real time on one core where blocks of 16 made 48× (idle synthesizers cost
//! little). So the blocks are rustysynth's default 64, and releases are within 1.4 ms. The
//! synthesizers are rendered in [`GROUPS`] fixed groups, on threads where the machine has
//! more than one core; the groups are summed in order either way, so the samples are the same
//! on any machine. Rendering is
//! streamed in chunks of [`CHUNK`] samples, so memory follows the notes sounding, not the
//! length of the piece; it ends when every voice has died away after the last event (at most
//! [`MAX_TAIL_S`] later).

use std::collections::{HashMap, VecDeque};
use std::sync::Arc;

use rustysynth::{SoundFont, Synthesizer, SynthesizerSettings};

use crate::error::RenderError;
use crate::events::{Action, Instrument, KeyEvent};
use crate::exclusive::{Classes, SILENT_VELOCITY};
use crate::lead::Leads;

/// The synthesizers' block, samples (rustysynth takes 8..=1024).
pub const BLOCK: usize = 64;
/// Synthesizers side by side, one for each sample position in a block.
pub const PHASES: usize = BLOCK;
/// Samples rendered at a time.
pub const CHUNK: usize = 16_384;
/// The synthesizers are rendered in this many groups, on as many threads where the machine
/// has more than one core.
pub const GROUPS: usize = 2;
/// The longest a render goes on after its last event, seconds (a sound still ringing then
/// is cut).
pub const MAX_TAIL_S: u32 = 30;
/// Voices each synthesizer may play at once (rustysynth's most): tails of released notes
/// are never stolen by new strikes in any file a robot can play.
const POLYPHONY: usize = 256;
/// The General MIDI program every channel starts with: 0, Acoustic Grand Piano.
const PROGRAM: i32 = 0;
/// The synthesizer velocity loudness 1 plays at. See [`voice_for`].
pub const SOFTEST_VELOCITY: u8 = 16;

/// The synthesizer's velocity, fractional, for a loudness on the MIDI velocity scale
/// (1.0..=127.0): loudness 1..=127 linearly as [`SOFTEST_VELOCITY`]..=127.
///
/// rustysynth's gain goes with the square of velocity, (v/127)²: −84 dB at 1, and a voice
/// under −60 dB is never started, so velocities below about 4 (more with a soundfont's own
/// attenuation) make no sound at all. On the robot, loudness 1 is a key's softest sound, a
/// sound all the same. So loudness 1..=127 plays as velocity 16..=127 (16: −36 dB, about a
/// piano's range from its softest to its loudest), for the robot and the score alike.
pub fn synth_velocity(loudness: f64) -> f64 {
    let l = loudness.clamp(1.0, 127.0);
    let soft = f64::from(SOFTEST_VELOCITY);
    soft + (127.0 - soft) * (l - 1.0) / 126.0
}

/// Each channel's expression (controller 11 and 43, 14 bits), as a share of the default's
/// (127 × 128): a ladder from 1 down to 16/17, geometric.
///
/// **Loudness between velocity's whole steps.** A strike's loudness is not a whole step
/// ([`orch_sim::Loudness`]), but a synthesizer's velocity is. rustysynth's gain is
/// `(velocity × expression)²` (times the channel's volume, the same on every channel), and a
/// channel's expression holds for every voice on it, so each of the 15 channels keeps its own
/// expression for the whole render, from this ladder, and a strike takes the channel and the
/// whole velocity whose product is nearest to its fractional velocity ([`voice_for`]). One
/// velocity step is 1/16 of the velocity at 16, and the ladder's 15 rungs split that: every
/// loudness sounds within 0.04 dB of its exact level (whole velocities alone: up to 0.53 dB
/// at the soft end, 0.07 at the loud; a calibration by ear reads a key's curve from level
/// differences of a tenth of a dB). On a soundfont with velocity layers a strike may take the
/// layer of a velocity up to 6 % above its own near a layer's edge.
pub fn expression_share(channel: usize) -> f64 {
    (16.0f64 / 17.0).powf(channel as f64 / CHANNELS.len() as f64)
}

/// The channel index (into the render's 15 channels) and whole velocity that play
/// `loudness` nearest to its exact level, other than on the channels `not` (a key's previous
/// strike's on the same synthesizer, see the [module notes](self): one left out, within
/// 0.08 dB). All 15 left out: channel index 0.
pub fn voice_for(loudness: f64, not: &[usize]) -> (usize, u8) {
    let want = synth_velocity(loudness);
    let mut best = (f64::INFINITY, 0, 127);
    for c in (0..CHANNELS.len()).filter(|c| !not.contains(c)) {
        let f = expression_share(c);
        let v = (want / f).round().clamp(1.0, 127.0);
        let err = (v * f / want).ln().abs();
        if err < best.0 {
            best = (err, c, v as u8);
        }
    }
    (best.1, best.2)
}

/// The 14-bit expression of channel index `c`.
fn expression(c: usize) -> u16 {
    (f64::from(127u16 << 7) * expression_share(c)).round() as u16
}

/// How to render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Samples a second (16 000..=192 000).
    pub sample_rate: u32,
    /// The synthesizers' master volume (rustysynth's default is 0.5).
    pub gain: f32,
}

impl Default for Settings {
    /// 44 100 Hz, gain 0.5.
    fn default() -> Self {
        Self {
            sample_rate: 44_100,
            gain: 0.5,
        }
    }
}

/// What a render gave.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rendered {
    /// Samples a channel written (frames).
    pub frames: u64,
    /// Strikes played.
    pub strikes: u64,
    /// The largest sample magnitude, 1.0 = full scale.
    pub peak: f32,
    /// Samples whose magnitude passed full scale (each channel counted).
    pub over: u64,
    /// The longest lead taken off a strike, samples (see the [module notes](self)).
    pub lead_max: u64,
}

enum Cmd {
    /// Channel, note, velocity, what it sounds as.
    On(u8, u8, u8, Instrument),
    /// Channel, note.
    Off(u8, u8),
    /// Channel, note, instrument: cut the voice of that note's exclusive class (see
    /// [`crate::exclusive`]).
    Cut(u8, u8, Instrument),
}

/// One synthesizer, its blocks starting on the samples `phase + 64k`, and what it is to do
/// when (in its own samples: its sample `j` is the song's sample `j + phase`).
struct Lane {
    synth: Synthesizer,
    phase: u64,
    /// Its own samples rendered so far.
    pos: u64,
    queue: VecDeque<(u64, Cmd)>,
    left: Vec<f32>,
    right: Vec<f32>,
}

/// The MIDI channels voices are spread over, each at its own expression
/// ([`expression_share`]), each set to a strike's instrument before its Note-On; a key's
/// successive strikes never share one, so releasing one strike's voice never touches
/// another's (channel 10, index 9, is rustysynth's percussion channel, whose bank select
/// adds 128: not used; the drums are bank 128 on the others).
const CHANNELS: [u8; 15] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 10, 11, 12, 13, 14, 15];

/// The synthesizer settings every render and lead measurement uses.
pub(crate) fn synth_settings(rate: u32, polyphony: usize) -> SynthesizerSettings {
    let mut s = SynthesizerSettings::new(rate as i32);
    s.block_size = BLOCK;
    s.maximum_polyphony = polyphony;
    s.enable_reverb_and_chorus = false;
    s
}

pub(crate) fn synthesizer(
    font: &Arc<SoundFont>,
    s: &SynthesizerSettings,
    gain: f32,
) -> Result<Synthesizer, RenderError> {
    let mut synth = Synthesizer::new(font, s).map_err(|e| RenderError::Synth(e.to_string()))?;
    synth.set_master_volume(gain);
    for (c, ch) in CHANNELS.into_iter().enumerate() {
        synth.process_midi_message(ch.into(), 0xC0, PROGRAM, 0);
        let e = expression(c);
        synth.process_midi_message(ch.into(), 0xB0, 0x0B, i32::from(e >> 7));
        synth.process_midi_message(ch.into(), 0xB0, 0x2B, i32::from(e & 0x7F));
    }
    Ok(synth)
}

/// Each lane's commands, from the events: see [`schedule`].
struct Plan {
    /// Each lane's commands, in its own samples, not sorted.
    cmds: Vec<Vec<(u64, Cmd)>>,
    strikes: u64,
    lead_max: u64,
    /// The sample of the last event, and of the last strike.
    last: u64,
    last_strike: u64,
}

/// Where each voice goes and when it starts and stops: the events in time order; who holds
/// each instrument's note's voice (its lane, channel and start); each lane's commands in its
/// own samples (a strike starts early by its lead, so a lane's commands do not come in the
/// events' order).
fn schedule(
    events: &[KeyEvent],
    rate: u32,
    leads: &mut Leads,
    classes: &mut Classes,
) -> Result<Plan, RenderError> {
    let mut order: Vec<(u64, usize)> = events
        .iter()
        .enumerate()
        .map(|(i, e)| (e.sample(rate), i))
        .collect();
    order.sort_unstable();
    let mut holder: HashMap<(Instrument, u8), (usize, u8, u64)> = HashMap::new();
    let mut last_voice: HashMap<(Instrument, u8), (usize, usize)> = HashMap::new();
    let mut plan = Plan {
        cmds: (0..PHASES).map(|_| Vec::new()).collect(),
        strikes: 0,
        lead_max: 0,
        last: 0,
        last_strike: 0,
    };
    for &(at, i) in &order {
        let e = &events[i];
        let note = e.note & 0x7F;
        let id = (e.instrument, note);
        let start = match e.action {
            Action::Strike { loudness } => {
                let busy = |lane: usize| -> Vec<usize> {
                    let held = holder
                        .iter()
                        .filter(|((_, n), (q, _, _))| *n == note && *q == lane)
                        .map(|(_, (_, ch, _))| channel_index(*ch));
                    let previous = last_voice
                        .get(&id)
                        .filter(|(q, _)| *q == lane)
                        .map(|(_, c)| *c);
                    held.chain(previous).collect()
                };
                let (c, v, lead) = voice(
                    loudness.get(),
                    at,
                    |v| leads.of(e.instrument, note, v),
                    busy,
                )?;
                last_voice.insert(id, (lane_of(at.saturating_sub(lead)), c));
                plan.lead_max = plan.lead_max.max(lead);
                plan.last_strike = plan.last_strike.max(at);
                Some((at.saturating_sub(lead), v, CHANNELS[c]))
            }
            Action::Release => None,
        };
        // The sound this instrument's note had ends at its release, or where a new strike
        // of it begins.
        if let Some((q, ch, began)) = holder.remove(&id) {
            let off = start.map_or(at, |(s, _, _)| s).max(began);
            plan.cmds[q].push((off - q as u64, Cmd::Off(ch, note)));
            plan.last = plan.last.max(off);
        }
        if let Some((begin, v, ch)) = start {
            let p = lane_of(begin);
            // The voices of its exclusive class it cuts, before it starts.
            for (q, qch, qnote) in classes.start(e.instrument, note, v, p, ch) {
                let cut = begin.max(q as u64);
                plan.cmds[q].push((cut - q as u64, Cmd::Cut(qch, qnote, e.instrument)));
            }
            plan.cmds[p].push((begin - p as u64, Cmd::On(ch, note, v, e.instrument)));
            holder.insert(id, (p, ch, begin));
            plan.strikes += 1;
        }
        plan.last = plan.last.max(at);
    }
    Ok(plan)
}

/// The lane whose blocks start on sample `s`.
fn lane_of(s: u64) -> usize {
    (s % PHASES as u64) as usize
}

/// The index into [`CHANNELS`] of MIDI channel `ch`.
fn channel_index(ch: u8) -> usize {
    CHANNELS.iter().position(|&c| c == ch).unwrap_or(0)
}

/// The channel index, whole velocity and lead of a strike of `loudness` at sample `at`: the
/// nearest to its level ([`voice_for`]) whose channel is not among those `busy` gives for
/// the lane it would start on (its start: `at` less the lead `lead_of` gives for its
/// velocity).
fn voice(
    loudness: f64,
    at: u64,
    mut lead_of: impl FnMut(u8) -> Result<u64, RenderError>,
    busy: impl Fn(usize) -> Vec<usize>,
) -> Result<(usize, u8, u64), RenderError> {
    let mut not = Vec::new();
    loop {
        let (c, v) = voice_for(loudness, &not);
        let lead = lead_of(v)?;
        if not.len() + 1 >= CHANNELS.len() || !busy(lane_of(at.saturating_sub(lead))).contains(&c) {
            return Ok((c, v, lead));
        }
        not.push(c);
    }
}

/// Sets channel `ch` of `synth` to play `instrument` (bank select, program change): the
/// next Note-On on it takes that preset; voices already sounding keep theirs.
pub(crate) fn set_instrument(synth: &mut Synthesizer, ch: u8, instrument: Instrument) {
    let (bank, program) = instrument.bank_and_program();
    synth.process_midi_message(ch.into(), 0xB0, 0x00, bank.into());
    synth.process_midi_message(ch.into(), 0xC0, program.into(), 0);
}

/// Renders `events` (in time order) with `font`, handing each chunk of samples (left,
/// right) to `sink` in order.
pub fn render(
    font: &Arc<SoundFont>,
    events: &[KeyEvent],
    settings: &Settings,
    mut sink: impl FnMut(&[f32], &[f32]) -> Result<(), RenderError>,
) -> Result<Rendered, RenderError> {
    let rate = settings.sample_rate;
    let s = synth_settings(rate, POLYPHONY);
    let mut lanes = Vec::with_capacity(PHASES);
    for phase in 0..PHASES as u64 {
        lanes.push(Lane {
            synth: synthesizer(font, &s, settings.gain)?,
            phase,
            pos: 0,
            queue: VecDeque::new(),
            left: vec![0.0; CHUNK],
            right: vec![0.0; CHUNK],
        });
    }
    let mut leads = Leads::new(font, rate, settings.gain);
    let plan = schedule(events, rate, &mut leads, &mut Classes::new(font))?;
    let mut out = Rendered {
        strikes: plan.strikes,
        lead_max: plan.lead_max,
        ..Rendered::default()
    };
    let (last, last_strike) = (plan.last, plan.last_strike);
    for (lane, mut c) in lanes.iter_mut().zip(plan.cmds) {
        c.sort_by_key(|&(t, _)| t);
        lane.queue = c.into();
    }
    let end_cap = last + u64::from(MAX_TAIL_S) * u64::from(rate);
    let (mut left, mut right) = (vec![0f32; CHUNK], vec![0f32; CHUNK]);
    // The lanes in GROUPS fixed groups, each summed into its own buffers, then the groups in
    // order: the same arithmetic whether they run on threads or one after the other.
    let mut sums: Vec<(Vec<f32>, Vec<f32>)> = (0..GROUPS)
        .map(|_| (vec![0f32; CHUNK], vec![0f32; CHUNK]))
        .collect();
    let parallel = std::thread::available_parallelism().map_or(1, |n| n.get()) > 1;
    let per = PHASES.div_ceil(GROUPS);
    let mut c = 0u64;
    loop {
        let n = CHUNK.min((end_cap - c) as usize);
        let work = |(group, (l, r)): (&mut [Lane], &mut (Vec<f32>, Vec<f32>))| {
            l[..n].fill(0.0);
            r[..n].fill(0.0);
            for lane in group {
                lane.fill(c, n, l, r);
            }
        };
        if parallel {
            std::thread::scope(|scope| {
                for job in lanes.chunks_mut(per).zip(sums.iter_mut()) {
                    scope.spawn(move || work(job));
                }
            });
        } else {
            lanes.chunks_mut(per).zip(sums.iter_mut()).for_each(work);
        }
        left[..n].fill(0.0);
        right[..n].fill(0.0);
        for (l, r) in &sums {
            for (d, x) in left[..n].iter_mut().zip(&l[..n]) {
                *d += *x;
            }
            for (d, x) in right[..n].iter_mut().zip(&r[..n]) {
                *d += *x;
            }
        }
        let silent = left[..n].iter().chain(&right[..n]).all(|&x| x == 0.0);
        // Silence after the last strike: the end (a release still to come, such as a ring's
        // end, has nothing left to stop).
        if c > last_strike && silent {
            break;
        }
        for &x in left[..n].iter().chain(&right[..n]) {
            out.peak = out.peak.max(x.abs());
            out.over += u64::from(x.abs() > 1.0);
        }
        sink(&left[..n], &right[..n])?;
        out.frames += n as u64;
        c += n as u64;
        if c >= end_cap {
            break;
        }
    }
    Ok(out)
}

impl Lane {
    /// Adds this lane's sound for the song's samples `c..c + n` into `left` and `right`.
    fn fill(&mut self, c: u64, n: usize, left: &mut [f32], right: &mut [f32]) {
        let end = c + n as u64; // the song's samples
        if end <= self.phase {
            return;
        }
        let until = end - self.phase; // its own
        while self.pos < until {
            let next = match self.queue.front() {
                Some(&(t, _)) if t <= self.pos => {
                    let (_, cmd) = self.queue.pop_front().expect("front");
                    match cmd {
                        Cmd::On(ch, note, v, instrument) => {
                            set_instrument(&mut self.synth, ch, instrument);
                            self.synth.note_on(ch.into(), note.into(), v.into())
                        }
                        Cmd::Off(ch, note) => self.synth.note_off(ch.into(), note.into()),
                        Cmd::Cut(ch, note, instrument) => {
                            set_instrument(&mut self.synth, ch, instrument);
                            self.synth
                                .note_on(ch.into(), note.into(), SILENT_VELOCITY.into());
                        }
                    }
                    continue;
                }
                Some(&(t, _)) => t.min(until),
                None => until,
            };
            let len = (next - self.pos) as usize;
            // Where its own sample `pos` falls in the chunk.
            let at = (self.pos + self.phase - c) as usize;
            let (l, r) = (&mut self.left[..len], &mut self.right[..len]);
            self.synth.render(l, r);
            for (d, s) in left[at..at + len].iter_mut().zip(l.iter()) {
                *d += *s;
            }
            for (d, s) in right[at..at + len].iter_mut().zip(r.iter()) {
                *d += *s;
            }
            self.pos = next;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_loudness_has_a_velocity_that_sounds_and_louder_is_louder() {
        assert_eq!(synth_velocity(1.0), f64::from(SOFTEST_VELOCITY));
        assert_eq!(synth_velocity(127.0), 127.0);
        assert_eq!(synth_velocity(0.0), f64::from(SOFTEST_VELOCITY));
        for l in 2..=127 {
            assert!(
                synth_velocity(f64::from(l)) > synth_velocity(f64::from(l - 1)),
                "{l}"
            );
        }
    }

    /// The level (dB) rustysynth gives a voice at `velocity` on channel index `c`, against
    /// velocity 127 on channel 0: `(velocity × expression)²`, the expression as sent (14 bits).
    fn level_db(c: usize, velocity: u8) -> f64 {
        let e = f64::from(expression(c)) / f64::from(127u16 << 7);
        40.0 * (f64::from(velocity) / 127.0 * e).log10()
    }

    #[test]
    fn every_loudness_sounds_within_four_hundredths_of_a_db_of_its_exact_level() {
        let (mut worst, mut worst_not): (f64, f64) = (0.0, 0.0);
        for i in 100..=12_700 {
            let loudness = f64::from(i) / 100.0;
            let exact = 40.0 * (synth_velocity(loudness) / 127.0).log10();
            let (c, v) = voice_for(loudness, &[]);
            worst = worst.max((level_db(c, v) - exact).abs());
            for not in 0..CHANNELS.len() {
                let (c, v) = voice_for(loudness, &[not]);
                assert_ne!(c, not);
                worst_not = worst_not.max((level_db(c, v) - exact).abs());
            }
        }
        assert!(worst < 0.04, "{worst} dB");
        assert!(worst_not < 0.08, "{worst_not} dB");
        // The loudest is velocity 127 at the default expression; whole velocities alone
        // would be up to 0.27 dB off.
        assert_eq!(voice_for(127.0, &[]), (0, 127));
        assert_eq!(expression(0), 127 << 7);
    }
}
