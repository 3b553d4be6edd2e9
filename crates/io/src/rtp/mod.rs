//! RTP-MIDI (RFC 6295) with Apple's AppleMIDI session protocol, the network MIDI built into
//! macOS and iOS (rtpMIDI on Windows, rtpmidid on Linux speak it too).
//!
//! - [`packet`]: RTP-MIDI packets: the RTP header and the MIDI command section (delta times,
//!   running status, SysEx segments), read and written.
//! - [`journal`]: the recovery journal: chapters N (notes) and C (controllers) read and
//!   written; the others stepped over.
//! - [`control`]: AppleMIDI's invitations, clock sync, receiver feedback and goodbyes.
//! - [`receiver`] and [`sender`]: one stream's state without sockets: what a loss needs
//!   played again, what the journal must carry.
//! - [`listen`]: `orch run --in rtpmidi:[NAME@]PORT`: a session answered, its MIDI handed on.
//! - [`out`]: `orch play --out rtpmidi:HOST:PORT`: a session begun, the performance sent.
//!
//! Everything read from the network is parsed with bounds checks into a typed
//! [`PacketError`]; nothing panics on a hostile datagram (the `rtp_packet` fuzz target
//! checks that).
//!
//! Chosen for it: the `rtpmidi` crate (GPL-3.0, tokio) reads no journal, so a lost
//! Note-Off would stay lost: these few RFC parts are implemented here instead.

pub mod control;
mod error;
pub mod journal;
pub mod listen;
pub mod out;
pub mod packet;
pub mod receiver;
pub mod sender;

pub use error::PacketError;

/// AppleMIDI's clock: 100 µs units since `origin`.
pub(crate) fn clock(origin: std::time::Instant) -> u64 {
    (origin.elapsed().as_micros() / 100) as u64
}

/// Reads a datagram the way every parser here takes it, and checks nothing panics: what the
/// fuzz target calls.
pub fn parse_any(datagram: &[u8]) {
    if control::is_control(datagram) {
        let _ = control::parse(datagram);
    } else {
        let mut r = receiver::Receiver::new();
        let _ = r.receive(&[0x80, 0x61, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]);
        let _ = r.receive(datagram);
        if let Ok(p) = packet::parse(datagram) {
            if let Some(j) = p.journal {
                let _ = journal::parse(j);
            }
        }
        let _ = journal::parse(datagram);
    }
}
