//! What became of each note: the interpreter's account, one event at a time.
//!
//! Every Note-On (velocity above 0) the interpreter takes gets exactly one first event, at the
//! moment it arrives: [`NoteEvent::Struck`], [`NoteEvent::Waiting`], [`NoteEvent::Joined`] or
//! [`NoteEvent::Dropped`]. A note that waits gets exactly one more, later, naming its key:
//! [`NoteEvent::WaitOver`] (it struck, late) or [`NoteEvent::WaitEnded`] (it never struck).
//! At most one note waits on a key at a time, so the key tells which note a later event is
//! about. Events are handed to a [`NoteSink`] as they happen; the interpreter keeps none, so
//! this costs nothing on an MCU that passes `&mut ()`.

use crate::values::{Channel, Note};

/// Why a note did not play.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DropReason {
    /// On a channel the robot does not listen to.
    Channel,
    /// On channel 10, General MIDI's percussion, which no group of the robot listens to: a
    /// keyboard leaves drum notes alone by default; a strike group (a drum kit) would play
    /// them.
    Percussion,
    /// A strike group listens to its channel but has no output for it: a drum the kit lacks.
    Unmapped,
    /// Outside the keys, with the drop policy (or no key of its pitch class).
    Range,
    /// Past the power budget (`max_keys_down`), or the store of held notes was full.
    Power,
    /// A re-strike that could not sound within the guard's `late_limit` of its arrival: the
    /// key had not rested long enough. On a fingered group: a note whose Note-Off came before
    /// its fingers had settled, taken over by the next note.
    TooFast,
    /// A note of a chord that a one-voice group (a wind instrument: see
    /// [`wind`](crate::wind)) does not play: another note of the chord won.
    Monophonic,
    /// Waiting for its re-strike, it was cancelled: a later note on the key took the strike
    /// over, or a System Reset, the watchdog or the missing Active Sensing released everything.
    Cancelled,
    /// The performance was stopped ([`Interpreter::all_off`](crate::Interpreter::all_off))
    /// before it could strike.
    Stopped,
    /// Its strike was too soft to sound: the duty its velocity gave was below the key's
    /// softest. The robot says so (the virtual robot's mechanics), never the interpreter,
    /// which struck the key as asked ([`dynamics`](crate::dynamics)).
    TooSoft,
    /// A wind robot's note that cracked: its valve opened before its fingers had settled (or a
    /// finger moved while it sounded), so the air found holes half closed and the note sounded
    /// wrong or not at all. The robot says so (the virtual robot's mechanics), never the
    /// interpreter, whose interlock keeps the valve closed for `settle`: a robot whose fingers
    /// travel longer than that cracks.
    Cracked,
}

impl DropReason {
    /// Every reason, in report order.
    pub const ALL: [DropReason; 11] = [
        DropReason::Channel,
        DropReason::Percussion,
        DropReason::Unmapped,
        DropReason::Range,
        DropReason::Power,
        DropReason::TooFast,
        DropReason::Monophonic,
        DropReason::TooSoft,
        DropReason::Cracked,
        DropReason::Cancelled,
        DropReason::Stopped,
    ];

    /// The reason's name in reports: `channel`, `percussion`, `unmapped`, `range`, `power`,
    /// `too_fast`, `monophonic`, `too_soft`, `cracked`, `cancelled`, `stopped`.
    pub const fn name(self) -> &'static str {
        match self {
            DropReason::Channel => "channel",
            DropReason::Percussion => "percussion",
            DropReason::Unmapped => "unmapped",
            DropReason::Range => "range",
            DropReason::Power => "power",
            DropReason::TooFast => "too_fast",
            DropReason::Monophonic => "monophonic",
            DropReason::Cancelled => "cancelled",
            DropReason::Stopped => "stopped",
            DropReason::TooSoft => "too_soft",
            DropReason::Cracked => "cracked",
        }
    }
}

/// Where a note landed: its key and how far it was folded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Landing {
    /// The key, 0 = the lowest key.
    pub key: u8,
    /// Octaves it was moved by to reach a key (+ up, − down, 0 = its own key).
    pub octaves: i8,
}

/// One thing the interpreter decided about a note.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NoteEvent {
    /// The note strikes its key now: the key goes down at the next flush.
    Struck {
        /// The note's channel.
        channel: Channel,
        /// The note.
        note: Note,
        /// Its key.
        at: Landing,
    },
    /// The note's key must rest first (the re-strike gap): it strikes when the rest is over
    /// ([`NoteEvent::WaitOver`]) unless it is cancelled ([`NoteEvent::WaitEnded`]).
    Waiting {
        /// The note's channel.
        channel: Channel,
        /// The note.
        note: Note,
        /// Its key.
        at: Landing,
    },
    /// The note's lead output fired now (an open hi-hat's lift): the note strikes its own
    /// output when the lead time has passed ([`NoteEvent::WaitOver`]) unless it is
    /// cancelled ([`NoteEvent::WaitEnded`]).
    Leading {
        /// The note's channel.
        channel: Channel,
        /// The note.
        note: Note,
        /// Its key (the output it strikes, not the lead).
        at: Landing,
    },
    /// A fingered group's note ([`wind`](crate::wind)): its fingers are being set; it sounds
    /// when the valve opens ([`NoteEvent::WaitOver`]) unless another note takes its place
    /// first ([`NoteEvent::WaitEnded`]).
    Preparing {
        /// The note's channel.
        channel: Channel,
        /// The note.
        note: Note,
        /// Its key: the group's valve.
        at: Landing,
    },
    /// Another note holds the key already (down, or about to strike): this one sounds with
    /// it and makes no strike of its own.
    Joined {
        /// The note's channel.
        channel: Channel,
        /// The note.
        note: Note,
        /// Its key.
        at: Landing,
        /// The key struck less than the guard's `min_press` ago, or is waiting to strike:
        /// the note joined the strike itself (a doubling), not a key held from before.
        with_strike: bool,
    },
    /// The note does not play.
    Dropped {
        /// The note's channel.
        channel: Channel,
        /// The note.
        note: Note,
        /// Its key, if it has one (not for [`DropReason::Channel`],
        /// [`DropReason::Percussion`], [`DropReason::Unmapped`] and [`DropReason::Range`]).
        at: Option<Landing>,
        /// Why.
        reason: DropReason,
    },
    /// The note waiting on `key` struck now, after its rest.
    WaitOver {
        /// The key.
        key: u8,
    },
    /// The note waiting on `key` will not strike.
    WaitEnded {
        /// The key.
        key: u8,
        /// Why: [`DropReason::Cancelled`] or [`DropReason::Stopped`].
        reason: DropReason,
    },
}

/// Takes the interpreter's [`NoteEvent`]s. `()` ignores them; any `FnMut(NoteEvent)` is a
/// sink.
pub trait NoteSink {
    /// One event, as it happens.
    fn note(&mut self, event: NoteEvent);
}

impl NoteSink for () {
    #[inline(always)]
    fn note(&mut self, _event: NoteEvent) {}
}

impl<F: FnMut(NoteEvent)> NoteSink for F {
    #[inline]
    fn note(&mut self, event: NoteEvent) {
        self(event)
    }
}
