//! ALSA sequencer ports (`alsa:CLIENT:PORT` outputs, `alsa:` and `alsa:CLIENT:PORT` inputs),
//! behind the `alsa` feature: the one output and input that need a system library (alsa-lib,
//! `libasound2-dev` to build). Inputs: [`AlsaIn`].
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

/// An ALSA sequencer input (`--in alsa:` or `--in alsa:CLIENT:PORT`): a client named `orch`
/// with one writable port, `orch in`, that any client (a DAW, a keyboard, `aconnect`) can
/// connect to; given a source, orch subscribes it to that port itself. Each event's MIDI
/// bytes come out whole, through alsa-lib's own decoder.
pub struct AlsaIn {
    seq: Seq,
    port: i32,
}

impl AlsaIn {
    /// Opens the client and its port; with `source`, subscribes it (`CLIENT:PORT` by numbers
    /// or by the client's name).
    pub fn open(source: Option<&str>) -> Result<AlsaIn, OutError> {
        let device = match source {
            Some(s) => format!("ALSA sequencer port {s}"),
            None => "the ALSA sequencer".to_string(),
        };
        let err = |source: io::Error| OutError::Open {
            device: device.clone(),
            source,
        };
        let seq =
            Seq::open(None, Some(alsa::Direction::Capture), false).map_err(|e| err(other(e)))?;
        let name = CString::new("orch").expect("no NUL");
        seq.set_client_name(&name).map_err(|e| err(other(e)))?;
        let mut info = PortInfo::empty().map_err(|e| err(other(e)))?;
        info.set_capability(PortCap::WRITE | PortCap::SUBS_WRITE);
        info.set_type(PortType::MIDI_GENERIC | PortType::APPLICATION);
        info.set_name(&CString::new("orch in").expect("no NUL"));
        seq.create_port(&info).map_err(|e| err(other(e)))?;
        let port = info.get_port();
        if let Some(source) = source {
            let from = destination(&seq, source)
                .map_err(|e| err(io::Error::new(io::ErrorKind::NotFound, e)))?;
            let subs = PortSubscribe::empty().map_err(|e| err(other(e)))?;
            subs.set_sender(from);
            subs.set_dest(Addr {
                client: seq.client_id().map_err(|e| err(other(e)))?,
                port,
            });
            seq.subscribe_port(&subs).map_err(|e| err(other(e)))?;
        }
        Ok(AlsaIn { seq, port })
    }

    /// The port's address, `CLIENT:PORT`, for `aconnect SOURCE CLIENT:PORT`.
    pub fn address(&self) -> String {
        let client = self.seq.client_id().unwrap_or(-1);
        format!("{client}:{}", self.port)
    }

    /// Waits at most `timeout` for events, and appends the MIDI bytes of every event that
    /// came to `out` (events that are not MIDI, such as port announcements, add nothing).
    pub fn read(&self, out: &mut Vec<u8>, timeout: std::time::Duration) -> io::Result<()> {
        use alsa::poll::Descriptors;
        let fds = (&self.seq, Some(alsa::Direction::Capture));
        let mut pollfds = fds.get().map_err(other)?;
        let ms = timeout.as_millis().min(i32::MAX as u128) as i32;
        if alsa::poll::poll(&mut pollfds, ms).map_err(other)? == 0 {
            return Ok(());
        }
        let decoder = MidiEvent::new(SYSEX_MAX).map_err(other)?;
        decoder.enable_running_status(false);
        let mut input = self.seq.input();
        while input.event_input_pending(true).map_err(other)? > 0 {
            let mut event = input.event_input().map_err(other)?;
            event_bytes(&decoder, &mut event, out);
        }
        Ok(())
    }
}

/// The longest event decoded: a System Exclusive message longer than this is left out.
const SYSEX_MAX: u32 = 64 * 1024;

/// Appends a sequencer event's MIDI bytes to `out`, whole (with its status byte), through
/// alsa-lib's decoder; an event that is not MIDI adds nothing.
pub fn event_bytes(decoder: &MidiEvent, event: &mut Event<'_>, out: &mut Vec<u8>) {
    let mut buf = [0u8; 16];
    match decoder.decode(&mut buf, event) {
        Ok(n) => out.extend_from_slice(&buf[..n]),
        Err(_) => {
            // Longer than 16 bytes (System Exclusive), or not a MIDI event.
            let mut big = vec![0u8; SYSEX_MAX as usize];
            if let Ok(n) = decoder.decode(&mut big, event) {
                out.extend_from_slice(&big[..n]);
            }
        }
    }
}
