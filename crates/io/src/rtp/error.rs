//! What is wrong with a packet that came from the network.

use std::fmt;

/// Why a received RTP-MIDI or AppleMIDI packet was refused. Parsing never panics and never
/// reads past the datagram: every field is checked against what is there first.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum PacketError {
    /// The datagram ends inside `what`.
    Truncated {
        /// The field being read.
        what: &'static str,
        /// Bytes it needs from where it starts.
        need: usize,
        /// Bytes left there.
        have: usize,
    },
    /// Not RTP version 2.
    Version(u8),
    /// An RTP payload type other than RTP-MIDI's 0x61 (97).
    PayloadType(u8),
    /// A delta time longer than four octets.
    DeltaTime,
    /// A data byte with no running status in force (the first channel command of a packet
    /// must carry its status byte).
    NoStatus {
        /// Its offset in the MIDI list.
        at: usize,
    },
    /// A status byte where a data byte belongs.
    StatusInData {
        /// Its offset in the MIDI list.
        at: usize,
    },
    /// A command the MIDI list may not carry (an undefined system command, an unpaired 0xF7,
    /// a SysEx segment with a bad ending).
    Command {
        /// The status byte.
        status: u8,
        /// Its offset in the MIDI list.
        at: usize,
    },
    /// A length field that does not fit what contains it.
    Length {
        /// The structure.
        what: &'static str,
        /// Its length field.
        length: usize,
        /// Room there is for it.
        room: usize,
    },
    /// Chapter N's LOW and HIGH code no NoteOff bitfield the RFC allows.
    OffBits {
        /// LOW.
        low: u8,
        /// HIGH.
        high: u8,
    },
    /// A chapter N note log with velocity 0 (a NoteOff belongs in the OFFBITS).
    ZeroVelocity {
        /// The note.
        note: u8,
    },
    /// An AppleMIDI command this end does not know.
    UnknownCommand([u8; 2]),
}

impl fmt::Display for PacketError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PacketError::Truncated { what, need, have } => {
                write!(
                    f,
                    "cut short in {what}: it needs {need} bytes, {have} are left"
                )
            }
            PacketError::Version(v) => write!(f, "RTP version {v}, not 2"),
            PacketError::PayloadType(pt) => {
                write!(f, "RTP payload type {pt}, not RTP-MIDI's 97")
            }
            PacketError::DeltaTime => f.write_str("a delta time longer than 4 octets"),
            PacketError::NoStatus { at } => {
                write!(
                    f,
                    "a data byte with no status in force at MIDI list offset {at}"
                )
            }
            PacketError::StatusInData { at } => {
                write!(f, "a status byte inside a command at MIDI list offset {at}")
            }
            PacketError::Command { status, at } => {
                write!(
                    f,
                    "command {status:#04x} may not appear in a MIDI list (offset {at})"
                )
            }
            PacketError::Length { what, length, room } => {
                write!(f, "{what} says {length} bytes, {room} are there")
            }
            PacketError::OffBits { low, high } => {
                write!(
                    f,
                    "chapter N codes LOW {low} > HIGH {high}, which the RFC forbids"
                )
            }
            PacketError::ZeroVelocity { note } => {
                write!(f, "chapter N logs note {note} with velocity 0")
            }
            PacketError::UnknownCommand(c) => write!(
                f,
                "unknown AppleMIDI command {:?}",
                String::from_utf8_lossy(c)
            ),
        }
    }
}

impl std::error::Error for PacketError {}

/// Reads big-endian fields off a byte slice, refusing to read past its end.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Self {
        Reader { bytes, pos: 0 }
    }

    pub(crate) fn pos(&self) -> usize {
        self.pos
    }

    pub(crate) fn left(&self) -> usize {
        self.bytes.len() - self.pos
    }

    pub(crate) fn rest(&self) -> &'a [u8] {
        &self.bytes[self.pos..]
    }

    pub(crate) fn take(&mut self, n: usize, what: &'static str) -> Result<&'a [u8], PacketError> {
        if n > self.left() {
            return Err(PacketError::Truncated {
                what,
                need: n,
                have: self.left(),
            });
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    pub(crate) fn u8(&mut self, what: &'static str) -> Result<u8, PacketError> {
        Ok(self.take(1, what)?[0])
    }

    pub(crate) fn u16(&mut self, what: &'static str) -> Result<u16, PacketError> {
        let b = self.take(2, what)?;
        Ok(u16::from_be_bytes([b[0], b[1]]))
    }

    pub(crate) fn u32(&mut self, what: &'static str) -> Result<u32, PacketError> {
        let b = self.take(4, what)?;
        Ok(u32::from_be_bytes([b[0], b[1], b[2], b[3]]))
    }

    pub(crate) fn u64(&mut self, what: &'static str) -> Result<u64, PacketError> {
        let b = self.take(8, what)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(u64::from_be_bytes(a))
    }
}
