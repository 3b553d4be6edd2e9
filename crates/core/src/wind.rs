//! A fingered group: a wind robot (a recorder, a flute), one note at a time.
//!
//! A keyboard's note is one key. A wind instrument's note is a **fingering** (several finger
//! solenoids closing holes at once) and the **breath** (an air valve, on/off or at a PWM duty).
//! Only one note sounds at a time, and the fingers must have settled before the air comes, or
//! the note cracks. A robot may have one fingered group ([`Wind`]) beside its keyboard and
//! strike groups: its valve, then its finger outputs, numbered after theirs. The valve comes
//! first so that it is on the first of the group's boards: boards are written in order, so
//! when everything stops at once the valve closes before (or with) the fingers.
//!
//! How the interpreter plays it:
//!
//! - A new note **closes the valve**, then (once the valve's closing is written to the boards,
//!   and no sooner than [`Wind::close`] later) **sets the fingers** to the note's fingering,
//!   waits the [`Wind::settle`] time and **opens the valve** at the note's breath. The note
//!   reports [`NoteEvent::Waiting`](crate::NoteEvent::Waiting) on the valve's key, then
//!   [`NoteEvent::WaitOver`](crate::NoteEvent::WaitOver) when the air comes.
//! - **The interlock**: the valve is never open while a finger output changes. Fingers change
//!   only with the valve closed and written so; the valve opens only after the fingers have
//!   been still for the settle time.
//! - A chord: the group plays one of its notes ([`Voice`]: the highest by default). A note
//!   that does not win is dropped as
//!   [`DropReason::Monophonic`](crate::DropReason::Monophonic); a note that loses its place
//!   to a later one before it sounded is dropped as `Monophonic` too (or `TooFast` if its
//!   Note-Off had come). A note that lost never comes back when the winner ends: it would
//!   sound late.
//! - The Note-Off of the note playing closes the valve, then releases the fingers.
//! - `all_off`, the watchdog and any guard cut of one of its outputs release the valve and the
//!   fingers in one frame: the valve's board is written first (the fingers' boards after it,
//!   or the same write where they share it).
//!
//! Needs the `wind` feature (on by default, off on the ATmega16).

use crate::keymap::{KeyOf, KeyRange, OutOfRange};
use crate::time::Duration;
use crate::values::{ChannelMask, Note};

/// The most finger outputs a fingered group has.
pub const MAX_FINGERS: usize = 16;
/// The most notes a fingering table holds.
pub const MAX_FINGERINGS: usize = 48;

/// One note's fingering: the fingers closed and the valve's duty.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Fingering {
    /// Bit `i`: finger output `i` is powered (its hole closed).
    pub fingers: u16,
    /// The valve's duty at velocity 127, of 4095 (high notes need more breath); on an on/off
    /// board any duty above 0 is full.
    pub breath: u16,
}

impl Fingering {
    /// No note.
    pub const NONE: Self = Self {
        fingers: 0,
        breath: 0,
    };
}

/// Which note of a chord a one-voice group plays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Voice {
    /// The highest note held: the melody of most parts.
    #[default]
    Highest,
    /// The lowest note held: a bass line.
    Lowest,
    /// The note that came last.
    Last,
}

/// A fingered group: its outputs, its fingering table and its timing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Wind {
    /// The channels it listens to; none: the robot has no fingered group.
    pub channels: ChannelMask,
    /// Its first output, the valve: a key of the robot. Its fingers follow.
    pub first: u8,
    /// How many finger outputs it has.
    pub fingers: u8,
    /// The notes of its table, `table[0]` the lowest.
    pub range: KeyRange,
    /// What happens to notes outside `range`.
    pub out_of_range: OutOfRange,
    /// Each note's fingering, from `range.low()`.
    pub table: [Fingering; MAX_FINGERINGS],
    /// From the valve's closing to the fingers moving: the air stops.
    pub close: Duration,
    /// From the fingers moving to the valve opening: their travel and settling.
    pub settle: Duration,
    /// Which note of a chord it plays.
    pub voice: Voice,
}

impl Wind {
    /// No fingered group.
    pub const NONE: Self = Self {
        channels: ChannelMask(0),
        first: 0,
        fingers: 0,
        range: KeyRange::THESIS,
        out_of_range: OutOfRange::Drop,
        table: [Fingering::NONE; MAX_FINGERINGS],
        close: Duration::ZERO,
        settle: Duration::ZERO,
        voice: Voice::Highest,
    };

    /// Whether the robot has a fingered group.
    #[inline(always)]
    pub const fn is_on(&self) -> bool {
        self.channels.0 != 0
    }

    /// Its outputs: the valve and the fingers (0 without a group).
    pub const fn outputs(&self) -> usize {
        if self.is_on() {
            self.fingers as usize + 1
        } else {
            0
        }
    }

    /// The valve's key.
    #[inline(always)]
    pub const fn valve(&self) -> u8 {
        self.first
    }

    /// The key of finger `i` (bit `i` of a [`Fingering`]).
    #[inline(always)]
    pub const fn finger(&self, i: u8) -> u8 {
        self.first + 1 + i
    }

    /// Whether `key` is one of its outputs.
    #[inline(always)]
    pub fn owns(&self, key: u8) -> bool {
        self.is_on() && (self.first..=self.first + self.fingers).contains(&key)
    }

    /// Where a note on a channel it listens to goes: its table index and octaves folded, or
    /// `None` outside the table (with the drop policy).
    pub fn find(&self, note: Note) -> Option<KeyOf> {
        self.range.key_for(note, self.out_of_range)
    }

    /// The fingering of table index `index`.
    #[inline]
    pub fn fingering(&self, index: u8) -> Fingering {
        self.table
            .get(index as usize)
            .copied()
            .unwrap_or(Fingering::NONE)
    }

    /// Checks the group against the first key after the keyboard's and the strike groups'.
    pub fn validate(&self, first: usize) -> Result<(), WindError> {
        if !self.is_on() {
            return Ok(());
        }
        if self.first as usize != first || self.fingers == 0 {
            return Err(WindError::Span);
        }
        if self.fingers as usize > MAX_FINGERS || first + self.outputs() > 128 {
            return Err(WindError::TooManyFingers);
        }
        if self.range.keys() > MAX_FINGERINGS {
            return Err(WindError::TableTooLong);
        }
        let mask = if self.fingers as usize >= 16 {
            u16::MAX
        } else {
            (1u16 << self.fingers) - 1
        };
        for (i, f) in self.table[..self.range.keys()].iter().enumerate() {
            if f.fingers & !mask != 0 || f.breath == 0 || f.breath > 4095 {
                return Err(WindError::Fingering {
                    note: self.range.low().get() + i as u8,
                });
            }
        }
        if self.settle == Duration::ZERO {
            return Err(WindError::NoSettle);
        }
        Ok(())
    }
}

impl Default for Wind {
    fn default() -> Self {
        Self::NONE
    }
}

/// A fingered group the interpreter cannot run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum WindError {
    /// Its outputs do not follow the keyboard's and the strike groups', or it has no finger.
    Span,
    /// More than [`MAX_FINGERS`] fingers, or past the robot's 128 outputs.
    TooManyFingers,
    /// More than [`MAX_FINGERINGS`] notes.
    TableTooLong,
    /// A note's fingering names a finger the group lacks, or has no breath.
    Fingering {
        /// The note.
        note: u8,
    },
    /// No settle time: the valve would open as the fingers move.
    NoSettle,
    /// The guard is off: it times the valve and the fingers.
    GuardOff,
}

impl core::fmt::Display for WindError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            WindError::Span => f.write_str(
                "its fingers must follow the keyboard's keys and the strike groups' outputs, at least one",
            ),
            WindError::TooManyFingers => write!(f, "more than {MAX_FINGERS} fingers, or past 128 outputs"),
            WindError::TableTooLong => write!(f, "more than {MAX_FINGERINGS} notes in its table"),
            WindError::Fingering { note } => write!(
                f,
                "note {note}: its fingering names a finger the group lacks, or its breath is not 1..=4095"
            ),
            WindError::NoSettle => f.write_str("a settle time of 0: the valve would open as the fingers move"),
            WindError::GuardOff => f.write_str("a fingered group needs the guard on: it times the valve and the fingers"),
        }
    }
}

/// No note (MIDI notes are 0..=127).
pub(crate) const NO_NOTE: u8 = 0x80;

/// Where the group is in playing a note.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub(crate) enum Phase {
    /// Valve closed, fingers released.
    #[default]
    Idle,
    /// The valve is closing; the fingers move once it is closed and written (`until`, low
    /// 32 bits of the clock). To `Idle` if no note is to play.
    Closing { until: u32 },
    /// The fingers are set; the valve opens at `until`.
    Settling { until: u32 },
    /// The valve is open: the note sounds.
    Open,
}

/// The group's state in the interpreter: the notes held, the note it plays and its phase.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct WindState {
    /// The notes held on its channels, one bit each (as written).
    held: [u8; 16],
    /// The held notes in the order they came, the latest last (for [`Voice::Last`]); a note
    /// pushed out of this short memory still counts in `held`.
    order: [u8; 8],
    order_len: u8,
    /// The note it plays or prepares: (written note, table index, velocity, octaves folded).
    pub target: Option<(u8, u8, u8, i8)>,
    /// Whether the target's own Note-Off has come (it still waits to sound).
    pub released: bool,
    pub phase: Phase,
    /// The note the guard cut while it sounded or prepared, until its own Note-Off: the next
    /// note is timed as if its valve had closed then (the performer sent it so).
    /// [`NO_NOTE`] for none (a byte, not an `Option`'s two: the state stays 40 bytes).
    pub cut_note: u8,
}

impl Default for WindState {
    fn default() -> Self {
        Self::NEW
    }
}

impl WindState {
    /// Nothing held, nothing playing.
    pub(crate) const NEW: Self = Self {
        held: [0; 16],
        order: [0; 8],
        order_len: 0,
        target: None,
        released: false,
        phase: Phase::Idle,
        cut_note: NO_NOTE,
    };

    pub(crate) fn holds(&self, note: u8) -> bool {
        self.held[note as usize / 8 % 16] & (1 << (note % 8)) != 0
    }

    pub(crate) fn hold(&mut self, note: u8) {
        self.held[note as usize / 8 % 16] |= 1 << (note % 8);
        self.forget_order(note);
        if self.order_len as usize == self.order.len() {
            self.order.copy_within(1.., 0);
            self.order_len -= 1;
        }
        self.order[self.order_len as usize] = note;
        self.order_len += 1;
    }

    pub(crate) fn let_go(&mut self, note: u8) {
        self.held[note as usize / 8 % 16] &= !(1 << (note % 8));
        self.forget_order(note);
    }

    fn forget_order(&mut self, note: u8) {
        let len = self.order_len as usize;
        if let Some(i) = self.order[..len].iter().position(|&n| n == note) {
            self.order.copy_within(i + 1..len, i);
            self.order_len -= 1;
        }
    }

    /// The held note `voice` picks.
    pub(crate) fn pick(&self, voice: Voice) -> Option<u8> {
        let mut notes = (0u8..128).filter(|&n| self.holds(n));
        match voice {
            Voice::Highest => notes.next_back(),
            Voice::Lowest => notes.next(),
            Voice::Last => self.order[..self.order_len as usize]
                .last()
                .copied()
                .or_else(|| notes.next_back()),
        }
    }

    /// Forgets every note held.
    pub(crate) fn clear_notes(&mut self) {
        self.held = [0; 16];
        self.order_len = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_voice_picks_its_note_of_a_chord() {
        let mut s = WindState::default();
        for n in [64, 72, 60] {
            s.hold(n);
        }
        assert_eq!(s.pick(Voice::Highest), Some(72));
        assert_eq!(s.pick(Voice::Lowest), Some(60));
        assert_eq!(s.pick(Voice::Last), Some(60));
        s.let_go(60);
        assert_eq!(s.pick(Voice::Last), Some(72));
        s.let_go(72);
        s.let_go(64);
        assert_eq!(s.pick(Voice::Highest), None);
        // More notes than the order remembers: the latest still wins.
        for n in 40..60 {
            s.hold(n);
        }
        assert_eq!(s.pick(Voice::Last), Some(59));
        assert_eq!(s.pick(Voice::Lowest), Some(40));
    }
}
