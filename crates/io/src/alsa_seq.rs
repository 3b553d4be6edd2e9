//! ALSA sequencer ports (`alsa:CLIENT:PORT`), behind the `alsa` feature: the one output that
//! needs a system library (alsa-lib, `libasound2-dev` to build).
//!
//! orch opens a sequencer client named `orch` with one output port, subscribes the
//! destination to it, and sends each message as a sequencer event, directly (no queue: the
//! performer does the timing). Bytes become events through alsa-lib's own MIDI encoder
//! ([`seq_events`]), each message whole (the status byte put back where running status left
//! it out). The destination is `CLIENT:PORT` by numbers (`128:0`, as `aconnect -l` lists them)
//! or by the client's name (`Midi Through:0`).
//!
//! A destination that goes away takes its subscription with it; ALSA then delivers to nobody
//! without an error, so a lost port is not seen here (the report's byte count still says what
//! was sent).

use std::ffi::CString;
use std::io;

use alsa::seq::{Addr, ClientIter, Event, MidiEvent, PortCap, PortInfo, PortSubscribe, PortType};
use alsa::Seq;

use crate::midi::{MidiPort, Port};
use crate::OutError;

/// An ALSA sequencer output port subscribed to a destination.
pub struct AlsaSeq {
    seq: Seq,
    port: i32,
}

/// ALSA sequencer events.
pub type AlsaOut = MidiPort<AlsaSeq>;

fn other(e: alsa::Error) -> io::Error {
    io::Error::other(e)
}

/// The sequencer address `target` names: `CLIENT:PORT` by numbers or by the client's name.
fn destination(seq: &Seq, target: &str) -> Result<Addr, String> {
    if let Ok(a) = target.parse::<Addr>() {
        return Ok(a);
    }
    let (name, port) = target
        .rsplit_once(':')
        .ok_or_else(|| format!("`{target}` is not CLIENT:PORT"))?;
    let port: i32 = port
        .parse()
        .map_err(|_| format!("`{port}` is not a port number"))?;
    ClientIter::new(seq)
        .find(|c| c.get_name().is_ok_and(|n| n == name))
        .map(|c| Addr {
            client: c.get_client(),
            port,
        })
        .ok_or_else(|| format!("no sequencer client is named `{name}` (see `aconnect -l`)"))
}

impl Port for AlsaSeq {
    fn open(target: &str) -> Result<Self, OutError> {
        let err = |source: io::Error| OutError::Open {
            device: format!("ALSA sequencer port {target}"),
            source,
        };
        let seq =
            Seq::open(None, Some(alsa::Direction::Playback), false).map_err(|e| err(other(e)))?;
        let name = CString::new("orch").expect("no NUL");
        seq.set_client_name(&name).map_err(|e| err(other(e)))?;
        let dest = destination(&seq, target)
            .map_err(|e| err(io::Error::new(io::ErrorKind::NotFound, e)))?;
        let info = PortInfo::empty().map_err(|e| err(other(e)))?;
        info.set_capability(PortCap::READ | PortCap::SUBS_READ);
        info.set_type(PortType::MIDI_GENERIC | PortType::APPLICATION);
        seq.create_port(&info).map_err(|e| err(other(e)))?;
        let port = info.get_port();
        let subs = PortSubscribe::empty().map_err(|e| err(other(e)))?;
        subs.set_sender(Addr {
            client: seq.client_id().map_err(|e| err(other(e)))?,
            port,
        });
        subs.set_dest(dest);
        seq.subscribe_port(&subs).map_err(|e| err(other(e)))?;
        Ok(AlsaSeq { seq, port })
    }

    fn write_bytes(&mut self, bytes: &[u8]) -> io::Result<()> {
        let (seq, port) = (&self.seq, self.port);
        seq_events(bytes, |ev| {
            ev.set_source(port);
            ev.set_subs();
            ev.set_direct();
            seq.event_output_direct(ev).map(|_| ())
        })
        .map_err(other)
    }

    fn whole_messages() -> bool {
        true
    }
}

/// Turns whole MIDI messages into sequencer events with alsa-lib's encoder and hands each
/// to `f`, in order.
pub fn seq_events(
    bytes: &[u8],
    mut f: impl FnMut(&mut Event<'_>) -> alsa::Result<()>,
) -> alsa::Result<()> {
    let mut encoder = MidiEvent::new(256)?;
    let mut rest = bytes;
    while !rest.is_empty() {
        let (used, event) = encoder.encode(rest)?;
        if let Some(mut event) = event {
            f(&mut event)?;
        }
        if used == 0 {
            break;
        }
        rest = &rest[used..];
    }
    Ok(())
}
