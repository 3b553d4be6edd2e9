//! Following a conductor: tempo sources behind one trait, and the follower that turns what
//! they say into tempo changes of a performance.
//!
//! A **tempo source** ([`TempoSource`]) gives [`Cue`]s with their times on the performer's
//! clock: a tempo, a beat, or the transport (start, stop, continue, song position). The
//! transport follows MIDI 1.0: Stop pauses, Continue goes on from where the performance
//! stands, Song Position jumps to its sixteenth note (through the score's tempo map; while
//! paused, the performance then goes on from there at Continue), and Start is Song Position
//! 0 and Continue: play from the top. The
//! sources' decoders here are pure (bytes and times in, cues out): incoming MIDI clock
//! ([`MidiClock`]), OSC ([`parse_osc`]), tap tempo ([`TapTempo`]); the I/O around them (a
//! file, standard input, a UDP port, a key, a video through `orch-baton`) is the front end's.
//!
//! The **follower** ([`Follower`], in [`follow`](crate::follow)) turns each cue into a tempo
//! factor for [`Control::set_tempo`](crate::Control::set_tempo), with the score's own tempo
//! as 1.0. The conductor's beats are quarter notes (MIDI clock counts 24 to the quarter). The
//! sources give beat times; the tempo is measured from them by the follower, by one rule for
//! every source ([`meter`](crate::meter)): a sustained change is taken at its second beat, a
//! single odd interval never. Two modes ([`Follow`]): the rate only, or the rate and the
//! phase.
//!
//! Score time stays continuous under both (see [`TimeMap`](crate::TimeMap)): a tempo change never skips,
//! repeats or reorders a note.

use std::collections::VecDeque;

pub use crate::follow::{Follow, Follower, FACTOR_RANGE, PHASE_CATCH_UP, PHASE_GAIN, PHASE_LIMIT};
use crate::tempo::Tempo;

/// What a conductor said.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Cue {
    /// Play at this tempo, in quarter notes a minute.
    Tempo(f64),
    /// A beat (a quarter note) fell at `t_us` on the performer's clock; `bpm`, a tempo the
    /// conductor states with it (an OSC `/orch/beat BPM`), if any. The follower measures the
    /// tempo from the beats' times otherwise: no source measures it for the follower.
    Beat {
        /// The beat's own time (the ictus), µs.
        t_us: u64,
        /// The tempo stated with it, quarter notes a minute.
        bpm: Option<f64>,
    },
    /// MIDI Start (0xFA): play from the beginning.
    Start,
    /// MIDI Stop (0xFC).
    Stop,
    /// MIDI Continue (0xFB).
    Continue,
    /// MIDI Song Position Pointer (0xF2): MIDI beats (sixteenth notes) from the start.
    SongPosition(u16),
}

/// A cue and when it arrived (µs on the performer's clock).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timed {
    /// When it arrived, µs.
    pub t_us: u64,
    /// The cue.
    pub cue: Cue,
}

/// What went wrong with a tempo source.
#[derive(Debug)]
pub enum ConductError {
    /// Reading the source failed.
    Io(std::io::Error),
    /// The source's input cannot be used (a video that cannot be read, a bad packet).
    Input(String),
}

impl std::fmt::Display for ConductError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ConductError::Io(e) => write!(f, "reading the tempo source: {e}"),
            ConductError::Input(e) => write!(f, "the tempo source: {e}"),
        }
    }
}

impl std::error::Error for ConductError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ConductError::Io(e) => Some(e),
            ConductError::Input(_) => None,
        }
    }
}

impl From<std::io::Error> for ConductError {
    fn from(e: std::io::Error) -> Self {
        ConductError::Io(e)
    }
}

/// Anything that conducts: MIDI clock, OSC, tap tempo, the baton tracker.
pub trait TempoSource {
    /// The next cue, waiting for it as long as it must; `Ok(None)` when the source has ended.
    fn next_cue(&mut self) -> Result<Option<Timed>, ConductError>;
}

/// MIDI clock from raw bytes: 0xF8 24 times a quarter note, Start 0xFA, Stop 0xFC, Continue
/// 0xFB, Song Position Pointer 0xF2 (two 7-bit data bytes, LSB first). Every other byte is
/// skipped (real-time bytes may come anywhere, even inside a Song Position message).
///
/// While running (after Start or Continue) every 24th clock is a [`Cue::Beat`], the first
/// being the first clock after Start, at the time of that clock; the follower measures the
/// tempo from those beats, as from any source's. Clock without Start (no position to follow)
/// gives [`Cue::Tempo`] every 24 clocks, the tempo of the last 24.
#[derive(Clone, Debug, Default)]
pub struct MidiClock {
    running: bool,
    /// Clocks since the position's last quarter note.
    ticks: u32,
    /// The times of the last 25 clocks.
    times: VecDeque<u64>,
    /// Song Position data bytes so far.
    spp: Option<Vec<u8>>,
}

impl MidiClock {
    /// Clocks to a quarter note.
    pub const PER_QUARTER: u32 = 24;

    /// A decoder, stopped.
    pub fn new() -> Self {
        Self::default()
    }

    /// The tempo of the last quarter note of clocks, quarter notes a minute.
    pub fn bpm(&self) -> Option<f64> {
        let n = self.times.len();
        if n < 2 {
            return None;
        }
        let span = self.times[n - 1].saturating_sub(self.times[0]) as f64;
        (span > 0.0).then(|| 60e6 * (n - 1) as f64 / Self::PER_QUARTER as f64 / span)
    }

    /// One byte, received at `t_us`.
    pub fn feed(&mut self, t_us: u64, byte: u8) -> Option<Cue> {
        match byte {
            0xF8 => {
                self.times.push_back(t_us);
                if self.times.len() > Self::PER_QUARTER as usize + 1 {
                    self.times.pop_front();
                }
                let beat = self.ticks % Self::PER_QUARTER == 0;
                self.ticks = self.ticks.wrapping_add(1);
                match (beat, self.running) {
                    (true, true) => Some(Cue::Beat { t_us, bpm: None }),
                    (true, false) => self.bpm().map(Cue::Tempo),
                    _ => None,
                }
            }
            0xFA => {
                self.running = true;
                self.ticks = 0;
                Some(Cue::Start)
            }
            0xFB => {
                self.running = true;
                Some(Cue::Continue)
            }
            0xFC => {
                self.running = false;
                Some(Cue::Stop)
            }
            0xF9 | 0xFD..=0xFF => None,
            0xF2 => {
                self.spp = Some(Vec::new());
                None
            }
            0x80..=0xF7 => {
                self.spp = None;
                None
            }
            data => {
                let spp = self.spp.as_mut()?;
                spp.push(data);
                if spp.len() < 2 {
                    return None;
                }
                let pos = u16::from(spp[0]) | u16::from(spp[1]) << 7;
                self.spp = None;
                // A MIDI beat is a sixteenth: 6 clocks.
                self.ticks = u32::from(pos) * 6;
                Some(Cue::SongPosition(pos))
            }
        }
    }
}

/// Tap tempo: each tap is a beat at its time. The follower measures the tempo from the taps
/// as from any source's beats (a sustained change taken at its second interval, one odd tap
/// ignored, a long pause a new start).
#[derive(Clone, Debug, Default)]
pub struct TapTempo {
    taps: u64,
}

impl TapTempo {
    /// No taps yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Taps so far.
    pub fn taps(&self) -> u64 {
        self.taps
    }

    /// A tap at `t_us`.
    pub fn tap(&mut self, t_us: u64) -> Cue {
        self.taps += 1;
        Cue::Beat { t_us, bpm: None }
    }
}

/// A malformed OSC packet.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OscError(pub String);

impl std::fmt::Display for OscError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "bad OSC packet: {}", self.0)
    }
}

impl std::error::Error for OscError {}

/// One OSC argument.
#[derive(Clone, Debug, PartialEq)]
pub enum OscArg {
    /// `i`: a 32-bit integer.
    Int(i32),
    /// `f`: a 32-bit float.
    Float(f32),
    /// `d`: a 64-bit float.
    Double(f64),
    /// `s`: a string.
    Str(String),
}

impl OscArg {
    fn number(&self) -> Option<f64> {
        match *self {
            OscArg::Int(i) => Some(f64::from(i)),
            OscArg::Float(f) => Some(f64::from(f)),
            OscArg::Double(d) => Some(d),
            OscArg::Str(_) => None,
        }
    }
}

/// One OSC message.
#[derive(Clone, Debug, PartialEq)]
pub struct OscMessage {
    /// Its address, such as `/orch/tempo`.
    pub address: String,
    /// Its arguments.
    pub args: Vec<OscArg>,
}

/// Parses an OSC 1.0 packet (a message, or a `#bundle` of them, nested; the bundle's time
/// tag is ignored: a cue acts when it arrives). Argument types `i`, `f`, `d`, `s`; others
/// are refused.
pub fn parse_osc(packet: &[u8]) -> Result<Vec<OscMessage>, OscError> {
    let mut out = Vec::new();
    parse_packet(packet, 0, &mut out)?;
    Ok(out)
}

fn parse_packet(p: &[u8], depth: u32, out: &mut Vec<OscMessage>) -> Result<(), OscError> {
    if depth > 8 {
        return Err(OscError("bundles nested too deep".into()));
    }
    if p.starts_with(b"#bundle\0") {
        let mut at = 16;
        if p.len() < at {
            return Err(OscError("bundle without a time tag".into()));
        }
        while at < p.len() {
            let size = read_u32(p, at)? as usize;
            at += 4;
            let end = at
                .checked_add(size)
                .filter(|&e| e <= p.len())
                .ok_or_else(|| OscError("bundle element past the end".into()))?;
            parse_packet(&p[at..end], depth + 1, out)?;
            at = end;
        }
        return Ok(());
    }
    let (address, mut at) = read_str(p, 0)?;
    if !address.starts_with('/') {
        return Err(OscError(format!(
            "address {address:?} does not start with /"
        )));
    }
    let mut args = Vec::new();
    if at < p.len() {
        let (tags, next) = read_str(p, at)?;
        at = next;
        let Some(tags) = tags.strip_prefix(',') else {
            return Err(OscError("type tags do not start with ,".into()));
        };
        for t in tags.chars() {
            match t {
                'i' => {
                    args.push(OscArg::Int(read_u32(p, at)? as i32));
                    at += 4;
                }
                'f' => {
                    args.push(OscArg::Float(f32::from_bits(read_u32(p, at)?)));
                    at += 4;
                }
                'd' => {
                    let hi = u64::from(read_u32(p, at)?);
                    let lo = u64::from(read_u32(p, at + 4)?);
                    args.push(OscArg::Double(f64::from_bits(hi << 32 | lo)));
                    at += 8;
                }
                's' => {
                    let (s, next) = read_str(p, at)?;
                    args.push(OscArg::Str(s));
                    at = next;
                }
                other => return Err(OscError(format!("argument type {other:?} not handled"))),
            }
        }
    }
    out.push(OscMessage { address, args });
    Ok(())
}

fn read_u32(p: &[u8], at: usize) -> Result<u32, OscError> {
    p.get(at..at + 4)
        .map(|b| u32::from_be_bytes([b[0], b[1], b[2], b[3]]))
        .ok_or_else(|| OscError("packet ends inside an argument".into()))
}

/// A NUL-terminated string padded to 4 bytes; returns it and the offset after the padding.
fn read_str(p: &[u8], at: usize) -> Result<(String, usize), OscError> {
    let rest = p.get(at..).unwrap_or_default();
    let len = rest
        .iter()
        .position(|&b| b == 0)
        .ok_or_else(|| OscError("string without its NUL".into()))?;
    let s = std::str::from_utf8(&rest[..len])
        .map_err(|_| OscError("string not UTF-8".into()))?
        .to_string();
    Ok((s, at + (len + 4) / 4 * 4))
}

/// Encodes an OSC message (for tests and for sending cues): arguments `i`, `f`, `d`, `s`.
pub fn encode_osc(address: &str, args: &[OscArg]) -> Vec<u8> {
    fn put_str(v: &mut Vec<u8>, s: &str) {
        v.extend_from_slice(s.as_bytes());
        v.push(0);
        while v.len() % 4 != 0 {
            v.push(0);
        }
    }
    let mut v = Vec::new();
    put_str(&mut v, address);
    let tags: String = std::iter::once(',')
        .chain(args.iter().map(|a| match a {
            OscArg::Int(_) => 'i',
            OscArg::Float(_) => 'f',
            OscArg::Double(_) => 'd',
            OscArg::Str(_) => 's',
        }))
        .collect();
    put_str(&mut v, &tags);
    for a in args {
        match a {
            OscArg::Int(i) => v.extend_from_slice(&i.to_be_bytes()),
            OscArg::Float(f) => v.extend_from_slice(&f.to_bits().to_be_bytes()),
            OscArg::Double(d) => v.extend_from_slice(&d.to_bits().to_be_bytes()),
            OscArg::Str(s) => put_str(&mut v, s),
        }
    }
    v
}

/// OSC to cues: `/orch/tempo f` (BPM, `i` and `d` too) is a [`Cue::Tempo`]; `/orch/beat`
/// is a beat at the packet's arrival, with the tempo it states if it has an argument (the
/// follower measures the tempo from the beats' times otherwise). Other addresses are ignored.
#[derive(Clone, Debug, Default)]
pub struct OscCues {
    beats: u64,
}

impl OscCues {
    /// No beats yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Beats received so far.
    pub fn beats(&self) -> u64 {
        self.beats
    }

    /// The cues of a packet received at `t_us`.
    pub fn packet(&mut self, t_us: u64, packet: &[u8]) -> Result<Vec<Cue>, OscError> {
        let mut cues = Vec::new();
        for m in parse_osc(packet)? {
            let n = m.args.first().and_then(OscArg::number);
            match m.address.as_str() {
                "/orch/tempo" => match n {
                    Some(bpm) if bpm.is_finite() && bpm > 0.0 => cues.push(Cue::Tempo(bpm)),
                    _ => return Err(OscError("/orch/tempo needs a tempo above 0".into())),
                },
                "/orch/beat" => {
                    self.beats += 1;
                    cues.push(Cue::Beat {
                        t_us,
                        bpm: n.filter(|b| b.is_finite() && *b > 0.0),
                    });
                }
                _ => {}
            }
        }
        Ok(cues)
    }
}

/// The score's quarter notes, µs of score time, for the follower.
#[derive(Clone, Debug, PartialEq)]
pub struct ScoreBeats {
    beats: Vec<u64>,
}

impl ScoreBeats {
    /// The quarter notes of `song` (with SMPTE timing, every 500 ms: 120 BPM).
    pub fn of(song: &orch_seq::Song) -> Self {
        let beats = match song.ticks_per_quarter() {
            Some(tpq) => {
                let n = song.duration_ticks() / u64::from(tpq) + 2;
                (0..=n)
                    .map(|i| song.time_at_tick(i * u64::from(tpq)))
                    .collect()
            }
            None => (0..=song.duration_us() / 500_000 + 2)
                .map(|i| i * 500_000)
                .collect(),
        };
        Self::from_times(beats)
    }

    /// From the times of the quarter notes (increasing; at least two, or 120 BPM is assumed).
    pub fn from_times(mut beats: Vec<u64>) -> Self {
        beats.dedup();
        if beats.len() < 2 {
            beats = vec![0, 500_000];
        }
        Self { beats }
    }

    /// Where `score_us` is, in quarter notes from the start, and how long that quarter is
    /// (µs of score time). Past the end the last quarter's length goes on.
    pub fn at(&self, score_us: u64) -> (f64, f64) {
        let b = &self.beats;
        let i = b
            .partition_point(|&t| t <= score_us)
            .saturating_sub(1)
            .min(b.len() - 2);
        let len = (b[i + 1] - b[i]) as f64;
        (i as f64 + (score_us as f64 - b[i] as f64) / len, len)
    }

    /// The score time (µs) `quarters` quarter notes from the start: the inverse of
    /// [`at`](Self::at) (past the end the last quarter's length goes on).
    pub fn time_of(&self, quarters: f64) -> u64 {
        let b = &self.beats;
        if quarters.is_nan() || quarters <= 0.0 {
            return 0;
        }
        let i = (quarters.floor() as usize).min(b.len() - 2);
        let len = (b[i + 1] - b[i]) as f64;
        let t = b[i] as f64 + (quarters - i as f64) * len;
        if t >= u64::MAX as f64 / 2.0 {
            u64::MAX / 2
        } else {
            t.round() as u64
        }
    }

    /// The score's tempo at `score_us`, quarter notes a minute.
    pub fn bpm(&self, score_us: u64) -> f64 {
        60e6 / self.at(score_us).1
    }
}

/// What the performance should do after a cue.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Action {
    /// Play at this factor from now on.
    Tempo(Tempo),
    /// The transport: stop (Stop).
    Pause,
    /// The transport: go on (Continue).
    Resume,
    /// The transport: jump to this score time, µs (Song Position); a pause stays a pause.
    Jump(u64),
    /// The transport: jump to the top and play (Start: Song Position 0 and Continue, as MIDI
    /// 1.0 has it).
    Start,
    /// Nothing to change.
    Nothing,
}

impl Action {
    /// Does it to a performance, through its control; `t_us` is when its cue arrived, on
    /// the performer's clock ([`Timed::t_us`]).
    pub fn apply(self, control: &crate::Control, t_us: u64) {
        match self {
            Action::Tempo(t) => control.set_tempo(t),
            Action::Pause => control.pause(),
            Action::Resume => control.resume(),
            Action::Jump(score_us) => control.jump_to(score_us),
            Action::Start => control.start_over(t_us),
            Action::Nothing => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn midi_clock_beats_every_24_clocks() {
        let mut c = MidiClock::new();
        assert_eq!(c.feed(0, 0xFA), Some(Cue::Start));
        // 120 BPM: a clock every 500_000 / 24 µs.
        let mut beats = Vec::new();
        for i in 0..49u64 {
            let t = i * 500_000 / 24;
            // A real-time byte inside nothing, and a Note-On's bytes: skipped.
            assert_eq!(c.feed(t, 0xFE), None);
            if let Some(cue) = c.feed(t, 0xF8) {
                beats.push(cue);
            }
        }
        assert_eq!(beats.len(), 3);
        // The beat at its clock's time; the tempo is the follower's to measure, and the
        // decoder's own measure (for clock without Start) is 120.
        assert_eq!(
            beats[2],
            Cue::Beat {
                t_us: 1_000_000,
                bpm: None
            }
        );
        assert!((c.bpm().unwrap() - 120.0).abs() < 0.01, "{:?}", c.bpm());
        assert_eq!(c.feed(2_000_000, 0xFC), Some(Cue::Stop));
        // Song position 0x0102 sixteenths, a clock byte inside the message.
        assert_eq!(c.feed(2_000_000, 0xF2), None);
        assert_eq!(c.feed(2_000_000, 0x02), None);
        assert_eq!(c.feed(2_000_000, 0xF8), None);
        assert_eq!(c.feed(2_000_000, 0x02), Some(Cue::SongPosition(2 | 2 << 7)));
        assert_eq!(c.feed(2_000_000, 0xFB), Some(Cue::Continue));
    }

    #[test]
    fn osc_messages_and_bundles_parse() {
        let m = encode_osc("/orch/tempo", &[OscArg::Float(96.5)]);
        assert_eq!(m.len(), 20);
        assert_eq!(
            parse_osc(&m).unwrap(),
            vec![OscMessage {
                address: "/orch/tempo".into(),
                args: vec![OscArg::Float(96.5)]
            }]
        );
        let beat = encode_osc("/orch/beat", &[]);
        let mut bundle = b"#bundle\0\0\0\0\0\0\0\0\x01".to_vec();
        for p in [&m, &beat] {
            bundle.extend_from_slice(&(p.len() as u32).to_be_bytes());
            bundle.extend_from_slice(p);
        }
        let mut cues = OscCues::new();
        assert_eq!(
            cues.packet(5, &bundle).unwrap(),
            vec![Cue::Tempo(96.5), Cue::Beat { t_us: 5, bpm: None }]
        );
        // A beat without a tempo: the follower measures it; with one: stated.
        assert_eq!(
            cues.packet(500_005, &beat).unwrap(),
            vec![Cue::Beat {
                t_us: 500_005,
                bpm: None
            }]
        );
        assert_eq!(
            cues.packet(900_000, &encode_osc("/orch/beat", &[OscArg::Float(150.0)]))
                .unwrap(),
            vec![Cue::Beat {
                t_us: 900_000,
                bpm: Some(150.0)
            }]
        );
        assert_eq!(cues.beats(), 3);
        for bad in [&m[..10], b"orch\0\0\0\0", &bundle[..20], b"/x\0\0,q\0\0"] {
            assert!(parse_osc(bad).is_err(), "{bad:?}");
        }
        assert!(cues
            .packet(0, &encode_osc("/orch/tempo", &[OscArg::Int(-3)]))
            .is_err());
    }

    #[test]
    fn a_tap_is_a_beat_at_its_time() {
        let mut t = TapTempo::new();
        assert_eq!(t.tap(0), Cue::Beat { t_us: 0, bpm: None });
        assert_eq!(
            t.tap(600_000),
            Cue::Beat {
                t_us: 600_000,
                bpm: None
            }
        );
        assert_eq!(t.taps(), 2);
    }

    #[test]
    fn song_position_lands_on_its_sixteenth_through_the_tempo_map() {
        // Quarters of 500 ms for two beats, then of 1 s.
        let beats = ScoreBeats::from_times(vec![0, 500_000, 1_000_000, 2_000_000, 3_000_000]);
        let mut f = Follower::new(beats.clone(), Follow::PHASE);
        // 10 sixteenths: 2.5 quarters, half into the third (a 1 s quarter).
        let at = |cue| Timed { t_us: 0, cue };
        assert_eq!(
            f.cue(&at(Cue::SongPosition(10)), None),
            Action::Jump(1_500_000)
        );
        assert_eq!(f.cue(&at(Cue::SongPosition(0)), None), Action::Jump(0));
        // Past the end the last quarter's length goes on.
        assert_eq!(beats.time_of(6.0), 5_000_000);
        for q in [0.0, 0.25, 1.5, 2.75, 3.5] {
            assert!((beats.at(beats.time_of(q)).0 - q).abs() < 1e-9, "{q}");
        }
    }
}
