//! A Standard MIDI File read into one merged, timed list of MIDI messages.

use std::fmt;
use std::ops::Deref;

use midly::{Format, MetaMessage, MidiMessage, Timing, TrackEventKind};

use crate::error::SeqError;
use crate::smf::{self, Framed, Frames};

/// The tempo until a file sets one: 500 000 µs per quarter note, 120 bpm.
pub const DEFAULT_TEMPO: u32 = 500_000;

/// The wire bytes of one MIDI message: status and data, never running status.
///
/// Channel messages (1 to 3 bytes) are kept inline; a System Exclusive message (`F0 … F7`)
/// is kept on the heap. 16 bytes either way.
#[derive(Clone, PartialEq, Eq, Hash)]
pub struct WireBytes(Repr);

#[derive(Clone, PartialEq, Eq, Hash)]
enum Repr {
    Inline {
        len: u8,
        buf: [u8; 3],
    },
    /// Boxed twice so the pointer is thin and the whole value 16 bytes.
    Heap(Box<Box<[u8]>>),
}

impl WireBytes {
    /// The bytes of `message`.
    pub fn new(message: &[u8]) -> Self {
        if message.len() <= 3 {
            let mut buf = [0; 3];
            buf[..message.len()].copy_from_slice(message);
            Self(Repr::Inline {
                len: message.len() as u8,
                buf,
            })
        } else {
            Self(Repr::Heap(Box::new(message.into())))
        }
    }

    /// The bytes.
    pub fn as_slice(&self) -> &[u8] {
        match &self.0 {
            Repr::Inline { len, buf } => &buf[..*len as usize],
            Repr::Heap(b) => b,
        }
    }

    /// The status byte.
    pub fn status(&self) -> u8 {
        self.as_slice().first().copied().unwrap_or(0)
    }

    /// The channel (0..=15) of a channel message.
    pub fn channel(&self) -> Option<u8> {
        let s = self.status();
        (0x80..0xF0).contains(&s).then_some(s & 0x0F)
    }

    /// `(channel, note, velocity)` of a Note-On with velocity above 0.
    pub fn note_on(&self) -> Option<(u8, u8, u8)> {
        match *self.as_slice() {
            [s, n, v] if s & 0xF0 == 0x90 && v > 0 => Some((s & 0x0F, n, v)),
            _ => None,
        }
    }

    /// `(channel, note)` of a Note-Off: 0x8n, or 0x9n with velocity 0.
    pub fn note_off(&self) -> Option<(u8, u8)> {
        match *self.as_slice() {
            [s, n, _] if s & 0xF0 == 0x80 => Some((s & 0x0F, n)),
            [s, n, 0] if s & 0xF0 == 0x90 => Some((s & 0x0F, n)),
            _ => None,
        }
    }

    /// `(channel, controller, value)` of a Control Change.
    pub fn control_change(&self) -> Option<(u8, u8, u8)> {
        match *self.as_slice() {
            [s, c, v] if s & 0xF0 == 0xB0 => Some((s & 0x0F, c, v)),
            _ => None,
        }
    }
}

impl Deref for WireBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        self.as_slice()
    }
}

impl fmt::Debug for WireBytes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "[")?;
        for (i, b) in self.as_slice().iter().enumerate() {
            if i > 0 {
                write!(f, " ")?;
            }
            write!(f, "{b:02X}")?;
        }
        write!(f, "]")
    }
}

/// One MIDI message of the song, at its place in time.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Event {
    /// When it plays, in microseconds from the start of the song.
    pub time_us: u64,
    /// When it plays, in ticks from the start of the song (in format 2, tracks follow one
    /// another, so a track's ticks are offset by the lengths of the tracks before it).
    pub tick: u64,
    /// The 0-based track it came from.
    pub track: u16,
    /// The message, status byte first, with no running status.
    pub bytes: WireBytes,
}

/// A tempo in force from a tick on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TempoChange {
    /// The tick it takes effect.
    pub tick: u64,
    /// The time it takes effect, in µs.
    pub time_us: u64,
    /// Microseconds per quarter note.
    pub us_per_quarter: u32,
}

impl TempoChange {
    /// The tempo in quarter notes per minute.
    pub fn bpm(&self) -> f64 {
        60_000_000.0 / f64::from(self.us_per_quarter.max(1))
    }
}

/// A time signature in force from a tick on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TimeSignature {
    /// The tick it takes effect.
    pub tick: u64,
    /// The time it takes effect, in µs.
    pub time_us: u64,
    /// Beats in a bar (the upper number).
    pub numerator: u8,
    /// The beat's note value as a power of two: 2 is a quarter, 3 an eighth.
    pub denominator_log2: u8,
}

impl TimeSignature {
    /// The lower number: 4 for quarter-note beats. Clamped to 2⁷ = 128 for display.
    pub fn denominator(&self) -> u32 {
        1 << self.denominator_log2.min(7)
    }
}

/// A Standard MIDI File ready to play: every channel message and SysEx of every track,
/// merged into one list in playing order, each with its time in µs.
///
/// - **Formats**: 0 and 1 play their tracks together; 2 plays them one after another, each
///   with its own tempo (starting at 120 bpm).
/// - **Time**: the tempo map (120 bpm until the first tempo event; in formats 0 and 1 a tempo
///   event in any track applies to all) or SMPTE division (µs per tick =
///   10⁶ / (fps × ticks per frame), 29.97 drop-frame as 30000/1001 fps, tempo events then only
///   serve the bar/beat display). Each time is computed exactly from the start of its tempo
///   segment in integer arithmetic and rounded down once: no drift, however many changes.
/// - **Order**: by tick; simultaneous events keep track order and then their order in the
///   track, except that a Note-Off (0x8n, or 0x9n with velocity 0) that ends a note begun
///   *before* this tick moves ahead of the Note-Ons of this tick, so a repeated note is
///   released and strikes again. A Note-Off of a note begun at this very tick (a zero-length
///   note) keeps its place after its Note-On, so no key is left hanging.
/// - **Kept**: channel voice and mode messages (notes, controllers with sustain and all
///   notes off, program, pitch bend, pressures) and SysEx as `F0 … F7` (a SysEx split into
///   packets is joined and played at its first packet's time; one never finished is closed
///   with F7). Meta events are not emitted: tempo, time signatures and track names are read;
///   escape (`F7`) events that do not continue a SysEx are dropped.
#[derive(Clone, Debug)]
pub struct Song {
    format: Format,
    timing: Timing,
    events: Vec<Event>,
    tempo_map: Vec<TempoChange>,
    time_signatures: Vec<TimeSignature>,
    track_names: Vec<Option<String>>,
    duration_us: u64,
    duration_ticks: u64,
    notes: usize,
    timebase: Timebase,
    /// Position in quarter notes of each tempo change (for bar/beat display).
    tempo_quarters: Vec<f64>,
}

/// Exact tick → µs conversion: `time = (acc + (tick − seg.tick) × rate) / denom`.
#[derive(Clone, Debug)]
struct Timebase {
    denom: u128,
    segments: Vec<Segment>,
}

#[derive(Clone, Copy, Debug)]
struct Segment {
    tick: u64,
    rate: u128,
    acc: u128,
}

impl Timebase {
    /// `changes` sorted by tick: (tick, rate).
    fn new(denom: u128, first_rate: u128, changes: impl IntoIterator<Item = (u64, u128)>) -> Self {
        let mut segments = vec![Segment {
            tick: 0,
            rate: first_rate,
            acc: 0,
        }];
        for (tick, rate) in changes {
            let last = *segments.last().expect("never empty");
            if tick == last.tick {
                segments.last_mut().expect("never empty").rate = rate;
            } else {
                let acc = last.acc + u128::from(tick - last.tick) * last.rate;
                segments.push(Segment { tick, rate, acc });
            }
        }
        Self { denom, segments }
    }

    fn numerator(&self, tick: u64) -> u128 {
        let i = self.segments.partition_point(|s| s.tick <= tick) - 1;
        let s = self.segments[i];
        s.acc + u128::from(tick - s.tick) * s.rate
    }

    fn time_us(&self, tick: u64) -> u64 {
        u64::try_from(self.numerator(tick) / self.denom).unwrap_or(u64::MAX)
    }

    /// The last tick at or before `time_us`.
    fn tick_at(&self, time_us: u64) -> u64 {
        let target = u128::from(time_us) * self.denom + (self.denom - 1);
        let i = self.segments.partition_point(|s| s.acc <= target) - 1;
        let s = self.segments[i];
        if s.rate == 0 {
            return s.tick;
        }
        let ticks = (target - s.acc) / s.rate;
        let ticks = u64::try_from(ticks).unwrap_or(u64::MAX);
        match self.segments.get(i + 1) {
            Some(next) => s.tick.saturating_add(ticks).min(next.tick - 1),
            None => s.tick.saturating_add(ticks),
        }
    }
}

/// What one track contributed.
#[derive(Default)]
struct TrackData {
    tempos: Vec<(u64, u32)>,
    signatures: Vec<(u64, u8, u8)>,
    name: Option<String>,
    end_tick: u64,
}

/// Reads one track: its messages go straight into `events` (tick in `tick`, no time yet),
/// everything else into the returned [`TrackData`].
fn read_track(
    index: u16,
    bytes: &smf::TrackBytes<'_>,
    events: &mut Vec<Event>,
) -> Result<TrackData, SeqError> {
    let mut out = TrackData::default();
    let mut messages = TrackMessages { index, events };
    let mut tick: u64 = 0;
    let mut sysex: Option<(u64, Vec<u8>)> = None;
    for framed in Frames::new(index, bytes) {
        let Framed {
            start,
            end,
            delta,
            running_before,
            status,
        } = framed?;
        tick += u64::from(delta);
        out.end_tick = tick;
        // midly decodes the event the framing has vouched for.
        let mut it = midly::EventIter::new(&bytes.data[start..end]);
        *it.running_status_mut() = running_before;
        let decoded = it.next().and_then(Result::ok);
        let Some(event) = decoded else {
            if status == 0xFF {
                // A meta event whose contents midly refuses (an impossible SMPTE offset, a
                // short key signature): nothing we play depends on it.
                continue;
            }
            return Err(SeqError::Event {
                track: index,
                offset: bytes.offset + start,
                reason: "event midly could not decode",
            });
        };
        match event.kind {
            TrackEventKind::Midi { channel, message } => {
                let ch = channel.as_int();
                let wire = match message {
                    MidiMessage::NoteOff { key, vel } => [0x80 | ch, key.as_int(), vel.as_int()],
                    MidiMessage::NoteOn { key, vel } => [0x90 | ch, key.as_int(), vel.as_int()],
                    MidiMessage::Aftertouch { key, vel } => [0xA0 | ch, key.as_int(), vel.as_int()],
                    MidiMessage::Controller { controller, value } => {
                        [0xB0 | ch, controller.as_int(), value.as_int()]
                    }
                    MidiMessage::ProgramChange { program } => [0xC0 | ch, program.as_int(), 0],
                    MidiMessage::ChannelAftertouch { vel } => [0xD0 | ch, vel.as_int(), 0],
                    MidiMessage::PitchBend { bend } => {
                        let v = bend.0.as_int();
                        [0xE0 | ch, (v & 0x7F) as u8, (v >> 7) as u8]
                    }
                };
                let len = if matches!(wire[0] & 0xF0, 0xC0 | 0xD0) {
                    2
                } else {
                    3
                };
                messages.push((tick, WireBytes::new(&wire[..len])));
            }
            TrackEventKind::SysEx(data) => {
                if let Some((t, open)) = sysex.take() {
                    messages.push((t, close_sysex(open)));
                }
                let mut msg = Vec::with_capacity(data.len() + 1);
                msg.push(0xF0);
                msg.extend_from_slice(data);
                if data.last() == Some(&0xF7) {
                    messages.push((tick, WireBytes::new(&msg)));
                } else {
                    sysex = Some((tick, msg));
                }
            }
            TrackEventKind::Escape(data) => {
                if let Some((t, mut open)) = sysex.take() {
                    open.extend_from_slice(data);
                    if data.last() == Some(&0xF7) {
                        messages.push((t, WireBytes::new(&open)));
                    } else {
                        sysex = Some((t, open));
                    }
                }
            }
            TrackEventKind::Meta(meta) => match meta {
                MetaMessage::Tempo(t) if t.as_int() == 0 => {
                    return Err(SeqError::ZeroTempo {
                        track: index,
                        tick,
                        offset: bytes.offset + start,
                    });
                }
                MetaMessage::Tempo(t) => out.tempos.push((tick, t.as_int())),
                MetaMessage::TimeSignature(n, d, _, _) => out.signatures.push((tick, n, d)),
                MetaMessage::TrackName(name) if out.name.is_none() => {
                    out.name = Some(String::from_utf8_lossy(name).trim().to_string());
                }
                _ => {}
            },
        }
    }
    if let Some((t, open)) = sysex.take() {
        messages.push((t, close_sysex(open)));
    }
    Ok(out)
}

/// Where a track's messages go.
struct TrackMessages<'a> {
    index: u16,
    events: &'a mut Vec<Event>,
}

impl TrackMessages<'_> {
    fn push(&mut self, (tick, bytes): (u64, WireBytes)) {
        self.events.push(Event {
            time_us: 0,
            tick,
            track: self.index,
            bytes,
        });
    }
}

fn close_sysex(mut open: Vec<u8>) -> WireBytes {
    if open.last() != Some(&0xF7) {
        open.push(0xF7);
    }
    WireBytes::new(&open)
}

impl Song {
    /// Reads a Standard MIDI File.
    ///
    /// Damage is an error, never a panic: an empty file, a missing `MThd`, a format other than
    /// 0–2, an unplayable division, fewer tracks than declared, a chunk longer than the file,
    /// an event cut short or running past its chunk, a data byte with no running status, a
    /// status byte inside a message, a system common or real-time status in a track, a Set
    /// Tempo of 0 µs per quarter note ([`SeqError::ZeroTempo`]). Nothing
    /// is allocated from a declared length: only from bytes actually present.
    pub fn parse(bytes: &[u8]) -> Result<Song, SeqError> {
        let chunks = smf::split(bytes)?;
        let format = chunks.header.format;
        let timing = chunks.header.timing;
        // Every track's messages straight into one list (no copy per track); `starts[i]` is
        // where track i's begin.
        let mut events: Vec<Event> = Vec::new();
        let mut starts = Vec::with_capacity(chunks.tracks.len() + 1);
        let mut tracks = Vec::with_capacity(chunks.tracks.len());
        for (i, t) in chunks.tracks.iter().enumerate() {
            starts.push(events.len());
            tracks.push(read_track(i as u16, t, &mut events)?);
        }
        starts.push(events.len());

        // Tick offsets: format 2 plays its tracks one after another.
        let sequential = format == Format::Sequential;
        let mut offsets = Vec::with_capacity(tracks.len());
        let mut next = 0u64;
        for t in &tracks {
            offsets.push(if sequential { next } else { 0 });
            next += t.end_tick;
        }

        // The tempo map, in merge order.
        let mut tempo_ticks: Vec<(u64, u32)> = Vec::new();
        for (i, t) in tracks.iter().enumerate() {
            if sequential && i > 0 {
                tempo_ticks.push((offsets[i], DEFAULT_TEMPO));
            }
            tempo_ticks.extend(
                t.tempos
                    .iter()
                    .map(|&(tick, tempo)| (tick + offsets[i], tempo)),
            );
        }
        tempo_ticks.sort_by_key(|&(tick, _)| tick);

        let timebase = match timing {
            Timing::Metrical(ppq) => Timebase::new(
                u128::from(ppq.as_int()),
                u128::from(DEFAULT_TEMPO),
                tempo_ticks.iter().map(|&(t, r)| (t, u128::from(r))),
            ),
            Timing::Timecode(fps, tpf) => {
                let (num, den) = fps_ratio(fps);
                Timebase::new(num * u128::from(tpf), 1_000_000 * den, [])
            }
        };

        let mut tempo_map = vec![TempoChange {
            tick: 0,
            time_us: 0,
            us_per_quarter: DEFAULT_TEMPO,
        }];
        for &(tick, tempo) in &tempo_ticks {
            let change = TempoChange {
                tick,
                time_us: timebase.time_us(tick),
                us_per_quarter: tempo,
            };
            let last = tempo_map.last_mut().expect("never empty");
            if last.tick == tick {
                *last = change;
            } else {
                tempo_map.push(change);
            }
        }
        let tempo_quarters = quarters_of(&tempo_map, timing);

        let mut signatures: Vec<TimeSignature> = Vec::new();
        for (i, t) in tracks.iter().enumerate() {
            for &(tick, n, d) in &t.signatures {
                let tick = tick + offsets[i];
                signatures.push(TimeSignature {
                    tick,
                    time_us: timebase.time_us(tick),
                    numerator: n.max(1),
                    denominator_log2: d,
                });
            }
        }
        signatures.sort_by_key(|s| s.tick);
        signatures.dedup_by(|later, earlier| {
            if later.tick == earlier.tick {
                *earlier = *later;
                true
            } else {
                false
            }
        });

        let duration_ticks = tracks
            .iter()
            .enumerate()
            .map(|(i, t)| t.end_tick + offsets[i])
            .max()
            .unwrap_or(0);

        let track_names = tracks.iter().map(|t| t.name.clone()).collect();
        if sequential {
            for (i, w) in starts.windows(2).enumerate() {
                for e in &mut events[w[0]..w[1]] {
                    e.tick += offsets[i];
                }
            }
        }
        // Stable: track order, then order in the track (one track, or format 2, is in order
        // already and needs no sort and no scratch memory).
        if !events.is_sorted_by_key(|e| e.tick) {
            events.sort_by_key(|e| e.tick);
        }
        events.shrink_to_fit();
        release_before_restrike(&mut events);
        for e in &mut events {
            e.time_us = timebase.time_us(e.tick);
        }
        let notes = events
            .iter()
            .filter(|e| e.bytes.note_on().is_some())
            .count();

        Ok(Song {
            format,
            timing,
            events,
            duration_us: timebase.time_us(duration_ticks),
            duration_ticks,
            tempo_map,
            time_signatures: signatures,
            track_names,
            notes,
            timebase,
            tempo_quarters,
        })
    }

    /// Every message, in playing order.
    pub fn events(&self) -> &[Event] {
        &self.events
    }

    /// How many Note-Ons with velocity above 0.
    pub fn notes(&self) -> usize {
        self.notes
    }

    /// Time of the last event of any kind (End of Track included), in µs.
    pub fn duration_us(&self) -> u64 {
        self.duration_us
    }

    /// Tick of the last event of any kind.
    pub fn duration_ticks(&self) -> u64 {
        self.duration_ticks
    }

    /// The file's format: 0 single track, 1 parallel tracks, 2 sequential tracks.
    pub fn format(&self) -> Format {
        self.format
    }

    /// The file's time division.
    pub fn timing(&self) -> Timing {
        self.timing
    }

    /// Ticks per quarter note, for metrical division.
    pub fn ticks_per_quarter(&self) -> Option<u16> {
        match self.timing {
            Timing::Metrical(ppq) => Some(ppq.as_int()),
            Timing::Timecode(..) => None,
        }
    }

    /// The tempo map: always starts at tick 0 (120 bpm unless the file sets a tempo there);
    /// one entry per tick at which the tempo changes (the last of simultaneous tempo events
    /// wins). In format 2 each track starts again at 120 bpm. With SMPTE division the tempo
    /// does not change the timing; it only places bars and beats.
    pub fn tempo_map(&self) -> &[TempoChange] {
        &self.tempo_map
    }

    /// The tempo in force at `time_us`.
    pub fn tempo_at(&self, time_us: u64) -> TempoChange {
        let i = self.tempo_map.partition_point(|c| c.time_us <= time_us);
        self.tempo_map[i.saturating_sub(1)]
    }

    /// The time signatures, by tick (none if the file has none: 4/4 is assumed for display).
    pub fn time_signatures(&self) -> &[TimeSignature] {
        &self.time_signatures
    }

    /// Each track's name (its first Track Name meta event), by track index.
    pub fn track_names(&self) -> &[Option<String>] {
        &self.track_names
    }

    /// The time of `tick`, in µs (rounded down).
    pub fn time_at_tick(&self, tick: u64) -> u64 {
        self.timebase.time_us(tick)
    }

    /// The last tick that plays at or before `time_us`.
    pub fn tick_at_time(&self, time_us: u64) -> u64 {
        self.timebase.tick_at(time_us)
    }

    /// Position in quarter notes at `time_us` (for display).
    fn quarters_at(&self, time_us: u64) -> f64 {
        let i = self
            .tempo_map
            .partition_point(|c| c.time_us <= time_us)
            .saturating_sub(1);
        let c = self.tempo_map[i];
        self.tempo_quarters[i] + (time_us - c.time_us) as f64 / f64::from(c.us_per_quarter.max(1))
    }

    fn quarters_at_tick(&self, tick: u64) -> f64 {
        match self.timing {
            Timing::Metrical(ppq) => tick as f64 / f64::from(ppq.as_int()),
            Timing::Timecode(..) => self.quarters_at(self.timebase.time_us(tick)),
        }
    }

    /// Bar and beat (both from 1) at `time_us`, for display.
    ///
    /// Beats are the time signature's denominator notes (4/4 until the first signature); a
    /// signature change starts a new bar even in the middle of one.
    pub fn bar_beat(&self, time_us: u64) -> (u32, u32) {
        const EPS: f64 = 1e-6;
        let q = self.quarters_at(time_us);
        // (start in quarters, bar length, beat length) of each signature segment.
        let mut start_q = 0.0;
        let (mut num, mut den) = (4u32, 4u32);
        let mut bars_before = 0u64;
        for sig in &self.time_signatures {
            let sig_q = self.quarters_at_tick(sig.tick);
            if sig_q > q + EPS {
                break;
            }
            let bar_len = f64::from(num) * 4.0 / f64::from(den);
            bars_before = bars_before
                .saturating_add(((sig_q - start_q) / bar_len - EPS).ceil().max(0.0) as u64);
            start_q = sig_q;
            num = u32::from(sig.numerator);
            den = sig.denominator();
        }
        let bar_len = f64::from(num) * 4.0 / f64::from(den);
        let beat_len = 4.0 / f64::from(den);
        let into = (q - start_q).max(0.0) + EPS;
        let bar = bars_before.saturating_add((into / bar_len).floor() as u64);
        let beat = ((into % bar_len) / beat_len).floor() as u64;
        (
            u32::try_from(bar.saturating_add(1)).unwrap_or(u32::MAX),
            u32::try_from(beat.saturating_add(1))
                .unwrap_or(u32::MAX)
                .min(num),
        )
    }

    /// Where bar `bar` (from 1, as [`bar_beat`](Self::bar_beat) counts bars) begins, µs; `None`
    /// for bar 0. A bar past the end of the song is where it would begin if the last time
    /// signature went on.
    pub fn bar_start_us(&self, bar: u32) -> Option<u64> {
        const EPS: f64 = 1e-6;
        let want = u64::from(bar.checked_sub(1)?);
        let mut start_q = 0.0;
        let mut bar_len = 4.0;
        let mut bars_before = 0u64;
        for sig in &self.time_signatures {
            let sig_q = self.quarters_at_tick(sig.tick);
            let bars = ((sig_q - start_q) / bar_len - EPS).ceil().max(0.0) as u64;
            if want < bars_before.saturating_add(bars) {
                break;
            }
            bars_before = bars_before.saturating_add(bars);
            start_q = sig_q;
            bar_len = f64::from(sig.numerator.max(1)) * 4.0 / f64::from(sig.denominator());
        }
        Some(self.time_at_quarters(start_q + (want - bars_before) as f64 * bar_len))
    }

    /// The time (µs) `quarters` quarter notes from the start, by the tempo map (the last tempo
    /// going on past the end; 0 before the start).
    pub fn time_at_quarters(&self, quarters: f64) -> u64 {
        if quarters.is_nan() || quarters <= 0.0 {
            return 0;
        }
        let i = self
            .tempo_quarters
            .partition_point(|&q| q <= quarters)
            .saturating_sub(1);
        let c = self.tempo_map[i];
        let us = c.time_us as f64
            + (quarters - self.tempo_quarters[i]) * f64::from(c.us_per_quarter.max(1));
        if us >= u64::MAX as f64 / 2.0 {
            u64::MAX / 2
        } else {
            us.round() as u64
        }
    }

    /// The messages in order with their times: `(time_us, bytes)`.
    pub fn messages(&self) -> impl Iterator<Item = (u64, &[u8])> + '_ {
        self.events.iter().map(|e| (e.time_us, e.bytes.as_slice()))
    }
}

/// Frames per second as a ratio.
fn fps_ratio(fps: midly::Fps) -> (u128, u128) {
    match fps {
        midly::Fps::Fps24 => (24, 1),
        midly::Fps::Fps25 => (25, 1),
        midly::Fps::Fps29 => (30_000, 1_001),
        midly::Fps::Fps30 => (30, 1),
    }
}

/// Position in quarter notes of each tempo change.
fn quarters_of(map: &[TempoChange], timing: Timing) -> Vec<f64> {
    match timing {
        Timing::Metrical(ppq) => map
            .iter()
            .map(|c| c.tick as f64 / f64::from(ppq.as_int()))
            .collect(),
        Timing::Timecode(..) => {
            let mut out = Vec::with_capacity(map.len());
            let mut q = 0.0;
            for (i, c) in map.iter().enumerate() {
                if i > 0 {
                    let p = map[i - 1];
                    q += (c.time_us - p.time_us) as f64 / f64::from(p.us_per_quarter.max(1));
                }
                out.push(q);
            }
            out
        }
    }
}

/// Within each tick, moves the Note-Offs that end notes begun before this tick ahead of the
/// tick's first Note-On. Everything else keeps its (stable) order.
fn release_before_restrike(events: &mut [Event]) {
    let mut held = vec![0u32; 16 * 128];
    let idx = |ch: u8, n: u8| usize::from(ch) * 128 + usize::from(n & 0x7F);
    let mut start = 0;
    while start < events.len() {
        let tick = events[start].tick;
        let mut end = start;
        while end < events.len() && events[end].tick == tick {
            end += 1;
        }
        let group = &mut events[start..end];
        if let Some(first_on) = group.iter().position(|e| e.bytes.note_on().is_some()) {
            // How many earlier notes each (channel, note) can still release at this tick.
            let mut avail: Vec<(usize, u32)> = Vec::new();
            let mut hoist = Vec::new();
            for (i, e) in group.iter().enumerate() {
                if let Some((ch, n)) = e.bytes.note_off() {
                    let k = idx(ch, n);
                    let slot = match avail.iter().position(|&(key, _)| key == k) {
                        Some(p) => p,
                        None => {
                            avail.push((k, held[k]));
                            avail.len() - 1
                        }
                    };
                    if avail[slot].1 > 0 {
                        avail[slot].1 -= 1;
                        if i > first_on {
                            hoist.push(i);
                        }
                    }
                }
            }
            if !hoist.is_empty() {
                let mut order: Vec<usize> = (0..first_on).collect();
                order.extend(hoist.iter().copied());
                order.extend((first_on..group.len()).filter(|i| !hoist.contains(i)));
                let reordered: Vec<Event> = order.iter().map(|&i| group[i].clone()).collect();
                group.clone_from_slice(&reordered);
            }
        }
        for e in group.iter() {
            if let Some((ch, n, _)) = e.bytes.note_on() {
                held[idx(ch, n)] += 1;
            } else if let Some((ch, n)) = e.bytes.note_off() {
                let h = &mut held[idx(ch, n)];
                *h = h.saturating_sub(1);
            }
        }
        start = end;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wire_bytes_inline_and_heap() {
        let a = WireBytes::new(&[0x90, 60, 100]);
        assert_eq!(&*a, &[0x90, 60, 100]);
        assert_eq!(a.note_on(), Some((0, 60, 100)));
        let b = WireBytes::new(&[0xF0, 1, 2, 3, 0xF7]);
        assert_eq!(b.len(), 5);
        assert_eq!(b.channel(), None);
        assert_eq!(WireBytes::new(&[0x93, 60, 0]).note_off(), Some((3, 60)));
    }

    #[test]
    fn timebase_is_exact_across_many_segments() {
        // 3 ticks per quarter at 1 µs/quarter: each tick is 1/3 µs; 300 tempo "changes" to the
        // same value must not accumulate rounding.
        let changes = (1..=300u64).map(|t| (t, 1u128));
        let tb = Timebase::new(3, 1, changes);
        assert_eq!(tb.time_us(300), 100);
        assert_eq!(tb.time_us(301), 100);
        assert_eq!(tb.time_us(302), 100);
        assert_eq!(tb.time_us(303), 101);
    }

    #[test]
    fn tick_at_inverts_time_us() {
        let tb = Timebase::new(480, 500_000, [(960, 1_000_000), (1920, 250_000)]);
        for tick in [0, 1, 479, 480, 959, 960, 961, 1919, 1920, 5000] {
            let t = tb.time_us(tick);
            let back = tb.tick_at(t);
            assert_eq!(tb.time_us(back), t, "tick {tick}");
            assert!(back >= tick, "tick {tick} back {back}");
        }
    }
}
