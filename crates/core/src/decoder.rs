//! The MIDI 1.0 stream decoder: bytes in, [`Message`]s out, exactly by the specification.
//!
//! The rules it follows (MIDI 1.0 Detailed Specification, "Running Status", "System
//! Real-Time Messages" and "Data Types"):
//!
//! - Running status applies to channel voice messages (0x80..=0xEF). System Exclusive and
//!   System Common status bytes (0xF0..=0xF7) cancel it; real-time bytes (0xF8..=0xFE) do not.
//! - A real-time byte may arrive anywhere, even between the data bytes of a message or inside
//!   a System Exclusive message. It is emitted at once and the interrupted message continues.
//! - System Reset (0xFF) is emitted at once like the others, and like them lets a message it
//!   interrupts finish, but it cancels running status, as a return to the power-up state must:
//!   once the interrupted message (if any) is complete, data bytes need a new status byte.
//! - 0xF4 and 0xF5 are undefined: ignored, and they cancel running status. 0xF9 and 0xFD are
//!   undefined real-time bytes: ignored with no other effect.
//! - A data byte with no status to attach to is dropped (counted in [`Counters::dropped`]).
//! - A status byte other than real-time that arrives before the current message is complete
//!   abandons it: nothing is emitted for it and [`Counters::abandoned`] counts it once.
//! - Any status byte other than real-time ends a System Exclusive message. One ended that way
//!   is still emitted, with `terminated: false`. A lone 0xF7 is ignored.
//! - A stream that ends inside a message (or a System Exclusive message) emits nothing for
//!   it, and it is not counted as abandoned: [`Decoder::finish`] says the input has ended and
//!   whether it cut a message off.

use crate::message::Message;
use crate::values::{Channel, Note, Velocity, U14, U7};

/// What the decoder has seen, for a builder who wants to know whether the line is noisy.
///
/// Counts wrap at 2³² (about 16 days of a saturated DIN line). Kept with the `stats` feature
/// (on by default); without it nothing is counted and every count reads 0 (an 8-bit MCU saves
/// four 32-bit increments' worth of work a byte and 16 bytes of RAM).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// Bytes fed in.
    pub bytes: u32,
    /// Messages emitted ([`Message::SysExStart`] notifications are not counted).
    pub messages: u32,
    /// Data bytes dropped because no status byte was in force.
    pub dropped: u32,
    /// Messages abandoned because a status byte (or System Reset) arrived before they were
    /// complete.
    pub abandoned: u32,
}

/// Up to two messages produced by one byte.
///
/// Most bytes produce none or one. A status byte that ends a System Exclusive message can
/// produce two: the end of the SysEx, then its own message (a Tune Request, or the
/// [`Message::SysExStart`] of a new SysEx).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Decoded {
    first: Option<Message>,
    second: Option<Message>,
}

impl Decoded {
    fn push(&mut self, message: Message) {
        if self.first.is_none() {
            self.first = Some(message);
        } else {
            self.second = Some(message);
        }
    }
}

impl Iterator for Decoded {
    type Item = Message;
    fn next(&mut self) -> Option<Message> {
        match self.first.take() {
            Some(m) => Some(m),
            None => self.second.take(),
        }
    }
}

/// A MIDI 1.0 byte-stream decoder: `no_std`, allocation-free, 28 bytes of state plus the
/// optional System Exclusive buffer of `SYSEX` bytes.
///
/// With `SYSEX > 0`, the first `SYSEX` data bytes of the latest System Exclusive message are
/// kept and can be read with [`Decoder::sysex_data`] once [`Message::SysEx`] is emitted.
/// [`Message::SysEx::len`](Message::SysEx) always gives the full length.
#[derive(Clone, Debug)]
pub struct Decoder<const SYSEX: usize = 0> {
    /// Status byte of the message being collected or of the running status; 0 when none.
    status: u8,
    /// Data bytes collected so far for the current message.
    data: [u8; 2],
    /// How many of `data` are filled.
    have: u8,
    /// How many data bytes the current status takes.
    need: u8,
    /// A message has begun (status or first running-status data byte) and is not complete.
    pending: bool,
    /// A System Reset arrived while the message in progress was incomplete: its status is
    /// not kept as running status once it completes.
    forget_status: bool,
    /// Inside a System Exclusive message.
    in_sysex: bool,
    sysex_len: u32,
    sysex: [u8; SYSEX],
    #[cfg(feature = "stats")]
    counters: Counters,
}

impl<const SYSEX: usize> Default for Decoder<SYSEX> {
    fn default() -> Self {
        Self::new()
    }
}

/// Every count 0.
const NO_COUNTS: Counters = Counters {
    bytes: 0,
    messages: 0,
    dropped: 0,
    abandoned: 0,
};

/// How many data bytes follow `status`, for statuses that take data.
const fn data_len(status: u8) -> u8 {
    match status & 0xF0 {
        0xC0 | 0xD0 => 1,
        0x80 | 0x90 | 0xA0 | 0xB0 | 0xE0 => 2,
        _ => match status {
            0xF1 | 0xF3 => 1,
            0xF2 => 2,
            _ => 0,
        },
    }
}

impl<const SYSEX: usize> Decoder<SYSEX> {
    /// A decoder with no status in force.
    pub const fn new() -> Self {
        Self {
            status: 0,
            data: [0; 2],
            have: 0,
            need: 0,
            pending: false,
            forget_status: false,
            in_sysex: false,
            sysex_len: 0,
            sysex: [0; SYSEX],
            #[cfg(feature = "stats")]
            counters: NO_COUNTS,
        }
    }

    /// The counters so far (all 0 without the `stats` feature).
    pub const fn counters(&self) -> Counters {
        #[cfg(feature = "stats")]
        return self.counters;
        #[cfg(not(feature = "stats"))]
        return NO_COUNTS;
    }

    /// Adds one to a count; nothing without the `stats` feature.
    #[inline(always)]
    fn count(&mut self, f: impl FnOnce(&mut Counters) -> &mut u32) {
        #[cfg(feature = "stats")]
        {
            let n = f(&mut self.counters);
            *n = n.wrapping_add(1);
        }
        #[cfg(not(feature = "stats"))]
        let _ = f;
    }

    /// Whether a System Exclusive message is being received.
    pub const fn in_sysex(&self) -> bool {
        self.in_sysex
    }

    /// Whether a message has begun and is not complete: a status byte (or, under running
    /// status, a first data byte) is waiting for its data, or a System Exclusive message is
    /// open. Running status alone, with no data byte yet, is not pending.
    pub const fn pending(&self) -> bool {
        self.pending || self.in_sysex
    }

    /// A Note-On or Note-Off that waits only for its last data byte (the velocity): its
    /// channel and note. Real-time bytes may come between; anything else ends the wait. A
    /// firmware can address the note's board on the bus while that byte is still on the wire
    /// ([`Interpreter::board_ahead`](crate::Interpreter::board_ahead)).
    pub const fn note_ahead(&self) -> Option<(Channel, Note)> {
        if self.pending && !self.in_sysex && self.have == 1 && self.status & 0xE0 == 0x80 {
            Some((
                Channel::from_status(self.status),
                Note::from_bits(self.data[0] & 0x7F),
            ))
        } else {
            None
        }
    }

    /// Says the input has ended (end of file, a closed port) and returns whether it cut a
    /// message off (a System Exclusive message too): [`pending`](Self::pending) before the
    /// end. Nothing is emitted for that message and it is not counted as abandoned; the
    /// decoder is then as after power-up, ready for a new stream, its counters kept.
    ///
    /// The answer is not kept in [`Counters`], so that the decoder an MCU keeps does not grow
    /// for a count a live line never needs; a host that reads files counts it itself.
    #[must_use = "it says whether the end of the input cut a message off"]
    pub fn finish(&mut self) -> bool {
        let cut = self.pending();
        self.reset();
        cut
    }

    /// The stored start of the latest System Exclusive message: at most `SYSEX` bytes.
    pub fn sysex_data(&self) -> &[u8] {
        let n = (self.sysex_len as usize).min(SYSEX);
        &self.sysex[..n]
    }

    /// Forgets any message in progress and the running status, as after power-up.
    /// The counters are kept.
    pub fn reset(&mut self) {
        #[cfg(feature = "stats")]
        let counters = self.counters;
        *self = Self::new();
        #[cfg(feature = "stats")]
        {
            self.counters = counters;
        }
    }

    /// Feeds every byte of `bytes`, calling `emit` for each message in order.
    pub fn push_slice(&mut self, bytes: &[u8], mut emit: impl FnMut(Message)) {
        for &byte in bytes {
            self.step(byte, &mut emit);
        }
    }

    /// Feeds one byte and returns the messages it completes.
    pub fn push(&mut self, byte: u8) -> Decoded {
        let mut out = Decoded::default();
        self.step(byte, &mut |m| out.push(m));
        out
    }

    /// Decodes `byte`, handing each message it completes to `emit` (at most two: a System
    /// Exclusive message ended by a status byte, then that byte's own SysExStart or Tune
    /// Request).
    #[inline(always)]
    pub(crate) fn step<F: FnMut(Message)>(&mut self, byte: u8, emit: &mut F) {
        self.count(|c| &mut c.bytes);
        if byte < 0x80 {
            self.data_byte(byte, emit);
        } else if byte == 0xFF {
            self.system_reset(emit);
        } else if byte >= 0xF8 {
            if let Some(message) = realtime(byte) {
                self.emit(emit, message);
            }
        } else {
            self.status_byte(byte, emit);
        }
    }

    #[inline(always)]
    fn emit<F: FnMut(Message)>(&mut self, emit: &mut F, message: Message) {
        if message != Message::SysExStart {
            self.count(|c| &mut c.messages);
        }
        emit(message);
    }

    /// System Reset: running status is cancelled, now or, if a message is in progress, once
    /// it is complete. Then [`Message::Reset`].
    fn system_reset<F: FnMut(Message)>(&mut self, out: &mut F) {
        if self.pending {
            self.forget_status = true;
        } else {
            self.status = 0;
        }
        self.emit(out, Message::Reset);
    }

    fn status_byte<F: FnMut(Message)>(&mut self, byte: u8, out: &mut F) {
        if self.in_sysex {
            self.in_sysex = false;
            let terminated = byte == 0xF7;
            self.emit(
                out,
                Message::SysEx {
                    len: self.sysex_len,
                    terminated,
                },
            );
            if terminated {
                return;
            }
        } else if self.pending {
            self.count(|c| &mut c.abandoned);
        }
        self.pending = false;
        self.forget_status = false;
        self.have = 0;
        self.status = 0;
        match byte {
            0x80..=0xEF | 0xF1..=0xF3 => {
                self.status = byte;
                self.need = data_len(byte);
                self.pending = true;
            }
            0xF0 => {
                self.in_sysex = true;
                self.sysex_len = 0;
                self.emit(out, Message::SysExStart);
            }
            0xF6 => self.emit(out, Message::TuneRequest),
            // 0xF4, 0xF5 (undefined) and a lone 0xF7: ignored, running status cancelled.
            _ => {}
        }
    }

    #[inline(always)]
    fn data_byte<F: FnMut(Message)>(&mut self, byte: u8, out: &mut F) {
        if self.in_sysex {
            if let Some(slot) = self.sysex.get_mut(self.sysex_len as usize) {
                *slot = byte;
            }
            self.sysex_len = self.sysex_len.saturating_add(1);
            return;
        }
        if self.status == 0 {
            self.count(|c| &mut c.dropped);
            return;
        }
        self.pending = true;
        self.data[self.have as usize & 1] = byte;
        self.have += 1;
        if self.have < self.need {
            return;
        }
        self.have = 0;
        self.pending = false;
        let message = complete(self.status, self.data);
        if self.status >= 0xF0 || self.forget_status {
            // System Common messages have no running status, and none survives a reset.
            self.status = 0;
            self.forget_status = false;
        }
        self.emit(out, message);
    }
}

fn realtime(byte: u8) -> Option<Message> {
    Some(match byte {
        0xF8 => Message::Clock,
        0xFA => Message::Start,
        0xFB => Message::Continue,
        0xFC => Message::Stop,
        0xFE => Message::ActiveSensing,
        // 0xFF (System Reset) is handled by `system_reset`; 0xF9 and 0xFD are undefined.
        _ => return None,
    })
}

fn complete(status: u8, data: [u8; 2]) -> Message {
    let channel = Channel::from_status(status);
    let [a, b] = data;
    match status & 0xF0 {
        0x80 => Message::NoteOff {
            channel,
            note: Note::from_bits(a),
            velocity: Velocity::from_bits(b),
        },
        0x90 => Message::NoteOn {
            channel,
            note: Note::from_bits(a),
            velocity: Velocity::from_bits(b),
        },
        0xA0 => Message::PolyPressure {
            channel,
            note: Note::from_bits(a),
            pressure: U7::from_bits(b),
        },
        0xB0 => Message::ControlChange {
            channel,
            controller: U7::from_bits(a),
            value: U7::from_bits(b),
        },
        0xC0 => Message::ProgramChange {
            channel,
            program: U7::from_bits(a),
        },
        0xD0 => Message::ChannelPressure {
            channel,
            pressure: U7::from_bits(a),
        },
        0xE0 => Message::PitchBend {
            channel,
            value: U14::from_lsb_msb(a, b),
        },
        _ => match status {
            0xF1 => Message::QuarterFrame(U7::from_bits(a)),
            0xF2 => Message::SongPosition(U14::from_lsb_msb(a, b)),
            _ => Message::SongSelect(U7::from_bits(a)),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode(bytes: &[u8]) -> ([Option<Message>; 16], Counters) {
        let mut d = Decoder::<0>::new();
        let mut out = [None; 16];
        let mut n = 0;
        d.push_slice(bytes, |m| {
            out[n] = Some(m);
            n += 1;
        });
        (out, d.counters())
    }

    #[test]
    fn system_common_cancels_running_status() {
        let (out, c) = decode(&[0x90, 60, 1, 0xF3, 5, 61, 2]);
        assert_eq!(out[1], Some(Message::SongSelect(U7::from_bits(5))));
        assert_eq!(out[2], None);
        assert_eq!(c.dropped, 2);
    }

    #[test]
    fn undefined_f4_cancels_running_status_but_f9_does_not() {
        let (_, c) = decode(&[0x90, 60, 1, 0xF4, 61, 2]);
        assert_eq!((c.messages, c.dropped), (1, 2));
        let (_, c) = decode(&[0x90, 60, 1, 0xF9, 61, 2]);
        assert_eq!((c.messages, c.dropped), (2, 0));
    }

    #[test]
    fn status_in_the_middle_abandons_once() {
        let (out, c) = decode(&[0x90, 60, 0x80, 60, 0]);
        assert_eq!(c.abandoned, 1);
        assert!(matches!(out[0], Some(Message::NoteOff { .. })));
    }

    #[test]
    fn sysex_cut_by_status_is_emitted_unterminated_then_the_status_is_used() {
        let mut d = Decoder::<4>::new();
        let mut got = [None; 4];
        let mut n = 0;
        d.push_slice(&[0xF0, 1, 2, 3, 4, 5, 0x90, 60, 100], |m| {
            got[n] = Some(m);
            n += 1;
        });
        assert_eq!(got[0], Some(Message::SysExStart));
        assert_eq!(
            got[1],
            Some(Message::SysEx {
                len: 5,
                terminated: false
            })
        );
        assert!(matches!(got[2], Some(Message::NoteOn { .. })));
        assert_eq!(d.sysex_data(), &[1, 2, 3, 4]);
        assert_eq!(d.counters().abandoned, 0);
    }

    #[test]
    fn one_byte_can_end_a_sysex_and_start_another() {
        let got: [Option<Message>; 2] = {
            let mut d = Decoder::<0>::new();
            d.push(0xF0);
            d.push(1);
            let mut it = d.push(0xF0);
            [it.next(), it.next()]
        };
        assert_eq!(
            got[0],
            Some(Message::SysEx {
                len: 1,
                terminated: false
            })
        );
        assert_eq!(got[1], Some(Message::SysExStart));
    }

    #[test]
    fn lone_eox_is_ignored() {
        let (out, c) = decode(&[0xF7, 0xF7]);
        assert_eq!(out[0], None);
        assert_eq!((c.bytes, c.messages, c.dropped, c.abandoned), (2, 0, 0, 0));
    }
}
