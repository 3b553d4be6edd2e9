//! Decoded MIDI 1.0 messages.

use crate::values::{Channel, Note, Velocity, U14, U7};

/// One message decoded from a MIDI 1.0 byte stream.
///
/// Every message the specification defines is here, on all 16 channels. A System Exclusive
/// message is reported twice: [`Message::SysExStart`] when its 0xF0 arrives (a notification,
/// not counted as a message) and [`Message::SysEx`] when it ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Message {
    /// 0x8n: a key was released.
    NoteOff {
        /// The channel.
        channel: Channel,
        /// The note.
        note: Note,
        /// The release velocity.
        velocity: Velocity,
    },
    /// 0x9n: a key was pressed. Velocity 0 means release; it is kept as it came on the wire.
    NoteOn {
        /// The channel.
        channel: Channel,
        /// The note.
        note: Note,
        /// The strike velocity; 0 is a Note-Off.
        velocity: Velocity,
    },
    /// 0xAn: polyphonic key pressure.
    PolyPressure {
        /// The channel.
        channel: Channel,
        /// The note.
        note: Note,
        /// The pressure.
        pressure: U7,
    },
    /// 0xBn: a controller changed (channel mode messages are controllers 120..=127).
    ControlChange {
        /// The channel.
        channel: Channel,
        /// The controller number.
        controller: U7,
        /// The new value.
        value: U7,
    },
    /// 0xCn: program change.
    ProgramChange {
        /// The channel.
        channel: Channel,
        /// The program.
        program: U7,
    },
    /// 0xDn: channel pressure (aftertouch).
    ChannelPressure {
        /// The channel.
        channel: Channel,
        /// The pressure.
        pressure: U7,
    },
    /// 0xEn: pitch bend, 0x2000 is the centre.
    PitchBend {
        /// The channel.
        channel: Channel,
        /// The bend.
        value: U14,
    },
    /// 0xF0 arrived: a System Exclusive message begins. Not counted as a message.
    SysExStart,
    /// A System Exclusive message ended.
    SysEx {
        /// Data bytes between 0xF0 and the end, framing excluded.
        len: u32,
        /// `true` if it ended with 0xF7 (EOX); `false` if another status byte cut it short.
        terminated: bool,
    },
    /// 0xF1: MIDI time code quarter frame; the data byte is `0nnndddd`.
    QuarterFrame(U7),
    /// 0xF2: song position pointer, in MIDI beats (sixteenth notes).
    SongPosition(U14),
    /// 0xF3: song select.
    SongSelect(U7),
    /// 0xF6: tune request.
    TuneRequest,
    /// 0xF8: timing clock.
    Clock,
    /// 0xFA: start.
    Start,
    /// 0xFB: continue.
    Continue,
    /// 0xFC: stop.
    Stop,
    /// 0xFE: active sensing.
    ActiveSensing,
    /// 0xFF: system reset.
    Reset,
}

impl Message {
    /// Whether this is a System Real-Time message (0xF8..=0xFF), which may arrive anywhere.
    pub const fn is_realtime(&self) -> bool {
        matches!(
            self,
            Message::Clock
                | Message::Start
                | Message::Continue
                | Message::Stop
                | Message::ActiveSensing
                | Message::Reset
        )
    }

    /// The channel of a channel voice or mode message.
    pub const fn channel(&self) -> Option<Channel> {
        match *self {
            Message::NoteOff { channel, .. }
            | Message::NoteOn { channel, .. }
            | Message::PolyPressure { channel, .. }
            | Message::ControlChange { channel, .. }
            | Message::ProgramChange { channel, .. }
            | Message::ChannelPressure { channel, .. }
            | Message::PitchBend { channel, .. } => Some(channel),
            _ => None,
        }
    }

    /// The quarter frame's message type (0..=7) and value (0..=15).
    pub const fn quarter_frame_parts(data: U7) -> (u8, u8) {
        (data.get() >> 4, data.get() & 0x0F)
    }
}
