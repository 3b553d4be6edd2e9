//! MIDI inputs: where `orch run --in` reads raw MIDI bytes from.
//!
//! ```text
//! IN = serial:DEVICE | rawmidi:DEVICE | udp:PORT | udp:HOST:PORT | - | alsa: | alsa:CLIENT:PORT
//!    | rtpmidi:[NAME@]PORT | rtpmidi:[NAME@]HOST:PORT
//! ```
//!
//! | IN | what |
//! |---|---|
//! | `serial:/dev/ttyUSB0` | a DIN MIDI line through a UART, set to 31 250 baud 8N1 (raw mode) |
//! | `rawmidi:/dev/snd/midiC1D0` | the kernel's raw MIDI device (or any file or FIFO), read as a file |
//! | `udp:5004` | datagrams of raw MIDI bytes on the loopback address, port 5004 |
//! | `udp:0.0.0.0:5004` | the same on every address (or any `HOST:PORT` to bind) |
//! | `-` | standard input |
//! | `rtpmidi:5004`, `rtpmidi:piano@5004` | an RTP-MIDI (AppleMIDI) session answered as NAME (default `orch`) on every address: control port 5004, data port 5005 ([`crate::rtp::listen`]); `HOST:PORT` binds one address |
//! | `alsa:`, `alsa:CLIENT:PORT` | (the `alsa` feature) orch's own ALSA sequencer port, `orch in`, for any client to connect to; given a source, orch subscribes it |
//!
//! [`MidiIn::open`] starts a reader thread (at real-time priority where the OS allows it)
//! that stamps each read with the host's monotonic
//! clock ([`std::time::Instant`]) the moment it returns, and sends it as an [`InEvent`] on a
//! channel the caller owns, so that the caller can wait on input, its own timers and
//! anything else (signals) in one place. The end of the input (a file or standard input at
//! its end) is an [`InEvent::End`]; a read error is [`InEvent::Failed`]. A datagram input
//! never ends by itself.
//!
//! A device can go away and come back: a USB-MIDI interface or a USB serial adapter
//! unplugged, a serial line hung up. A `serial:` input, and a `rawmidi:` input that is a
//! character device, then send [`InEvent::Lost`] (the caller releases every key) and try to
//! open the same path again every [`RECONNECT_EVERY`]; when it opens, [`InEvent::Back`], and
//! the bytes flow again. (Name the device by a path that comes back the same, such as
//! `/dev/serial/by-id/…`.) A FIFO or a regular file at its end, and standard input, end.

use std::fmt;
use std::io::{self, Read};
use std::net::{SocketAddr, ToSocketAddrs, UdpSocket};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::midi::DIN_BAUD;
use crate::OutError;

/// How long a reader that can time out waits before it looks whether it should stop.
pub const READ_POLL: Duration = Duration::from_millis(100);

/// The largest read: 256 bytes are 82 ms of a DIN line.
pub const READ_SIZE: usize = 256;

/// How often a device that went away is tried again.
pub const RECONNECT_EVERY: Duration = Duration::from_millis(250);

/// What went wrong reading an `--in` specification.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InSpecError {
    /// The specification as given.
    pub spec: String,
    /// Why it was refused.
    pub reason: String,
}

impl fmt::Display for InSpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "--in {}: {} (give serial:DEVICE, rawmidi:DEVICE, udp:PORT, udp:HOST:PORT, \
             rtpmidi:[NAME@]PORT, alsa:, alsa:CLIENT:PORT or -)",
            self.spec, self.reason
        )
    }
}

impl std::error::Error for InSpecError {}

/// Where the bytes come from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum InTarget {
    /// A UART carrying a DIN MIDI line.
    Serial(PathBuf),
    /// A raw MIDI device, a FIFO or a file.
    RawMidi(PathBuf),
    /// A UDP address to bind and receive datagrams on.
    Udp(SocketAddr),
    /// Standard input.
    Stdin,
    /// An RTP-MIDI session answered as `name`, its control port at `addr` (the data port
    /// after it).
    RtpMidi {
        /// The name orch gives itself.
        name: String,
        /// The control port's address.
        addr: SocketAddr,
    },
    /// An ALSA sequencer port of orch's own, with a source to subscribe to it if given
    /// (`alsa:` or `alsa:CLIENT:PORT`; the `alsa` feature).
    Alsa(Option<String>),
}

impl InTarget {
    /// Reads one specification (see the [module notes](self)).
    pub fn parse(spec: &str) -> Result<InTarget, InSpecError> {
        let err = |reason: String| InSpecError {
            spec: spec.to_string(),
            reason,
        };
        if spec == "-" {
            return Ok(InTarget::Stdin);
        }
        if spec == "alsa" || spec == "alsa:" {
            return alsa_input(None).map_err(err);
        }
        let (kind, rest) = spec
            .split_once(':')
            .ok_or_else(|| err("no kind: it has no `:`".into()))?;
        if rest.is_empty() {
            return Err(err(format!("{kind} needs a target after `{kind}:`")));
        }
        match kind {
            "serial" => Ok(InTarget::Serial(rest.into())),
            "rawmidi" => Ok(InTarget::RawMidi(rest.into())),
            "udp" => {
                if let Ok(port) = rest.parse::<u16>() {
                    return Ok(InTarget::Udp(SocketAddr::from(([127, 0, 0, 1], port))));
                }
                rest.to_socket_addrs()
                    .ok()
                    .and_then(|mut a| a.next())
                    .map(InTarget::Udp)
                    .ok_or_else(|| err(format!("`{rest}` is not PORT or HOST:PORT")))
            }
            "alsa" => alsa_input(Some(rest)).map_err(err),
            "rtpmidi" => rtpmidi_input(rest).map_err(err),
            other => Err(err(format!("unknown input kind `{other}`"))),
        }
    }
}

/// `rtpmidi:[NAME@]PORT` (every address) or `rtpmidi:[NAME@]HOST:PORT`.
fn rtpmidi_input(rest: &str) -> Result<InTarget, String> {
    let (name, at) = match rest.rsplit_once('@') {
        Some((n, a)) if !n.is_empty() => (n.to_string(), a),
        Some((_, a)) => (crate::rtp::out::NAME.to_string(), a),
        None => (crate::rtp::out::NAME.to_string(), rest),
    };
    let addr = match at.parse::<u16>() {
        Ok(port) => SocketAddr::from(([0, 0, 0, 0], port)),
        Err(_) => at
            .to_socket_addrs()
            .ok()
            .and_then(|mut a| a.next())
            .ok_or_else(|| format!("`{at}` is not PORT or HOST:PORT"))?,
    };
    if addr.port() == u16::MAX {
        return Err("the data port is the control port + 1: give a port below 65535".into());
    }
    Ok(InTarget::RtpMidi { name, addr })
}

/// `alsa:` and `alsa:SOURCE`: an input with the `alsa` feature, a clear refusal without.
fn alsa_input(source: Option<&str>) -> Result<InTarget, String> {
    if cfg!(feature = "alsa") {
        Ok(InTarget::Alsa(source.map(str::to_string)))
    } else {
        Err(
            "this orch was built without the `alsa` feature (cargo build --release --features \
             alsa; it links alsa-lib); rawmidi:/dev/snd/midiCxDy reads the same hardware \
             with no system library"
                .into(),
        )
    }
}

/// What a reader thread sends.
#[derive(Debug)]
pub enum InEvent {
    /// Bytes read, and when the read returned.
    Bytes {
        /// The host's monotonic clock when the read returned.
        at: Instant,
        /// The bytes, as read.
        bytes: Vec<u8>,
    },
    /// The input ended (end of file); nothing more comes.
    End,
    /// The input failed; nothing more comes.
    Failed(io::Error),
    /// The device went away (hung up, unplugged, a read error); the reader tries to open it
    /// again every [`RECONNECT_EVERY`]. A message it cut off is lost with it.
    Lost(io::Error),
    /// The device that went away is open again and read.
    Back,
    /// A network session began (RTP-MIDI): who, for messages.
    Joined(String),
    /// The network session ended (the peer's goodbye, or another took its place): every key
    /// is released, as when a device goes away; another session may begin.
    Left(String),
}

/// A reader thread on one input. Dropping it asks the thread to stop (readers that can time
/// out stop within [`READ_POLL`]; a blocking file or standard input stops at its next byte).
#[derive(Debug)]
pub struct MidiIn {
    name: String,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    local: Option<SocketAddr>,
}

enum Source {
    Serial(Box<dyn serialport::SerialPort>),
    File(std::fs::File),
    Udp(UdpSocket),
    Stdin(io::Stdin),
    /// A device gone away, closed while it is tried again.
    Closed,
    /// orch's ALSA sequencer port, and the bytes of events read but not handed on yet.
    #[cfg(feature = "alsa")]
    Alsa(crate::alsa_seq::AlsaIn, std::collections::VecDeque<u8>),
}

impl Source {
    /// Reads what is there: its length and when it came (a datagram's arrival in the kernel,
    /// else the read's time).
    fn read(&mut self, buf: &mut [u8]) -> io::Result<(usize, Instant)> {
        let n = match self {
            Source::Serial(p) => p.read(buf),
            Source::File(f) => f.read(buf),
            Source::Udp(s) => return crate::arrival::recv(s, buf),
            Source::Stdin(s) => s.lock().read(buf),
            Source::Closed => Err(io::Error::from(io::ErrorKind::NotConnected)),
            #[cfg(feature = "alsa")]
            Source::Alsa(port, pending) => {
                if pending.is_empty() {
                    let mut got = Vec::new();
                    port.read(&mut got, READ_POLL)?;
                    if got.is_empty() {
                        return Err(io::Error::from(io::ErrorKind::TimedOut));
                    }
                    pending.extend(got);
                }
                let n = pending.len().min(buf.len());
                for (b, p) in buf.iter_mut().zip(pending.drain(..n)) {
                    *b = p;
                }
                Ok(n)
            }
        }?;
        Ok((n, Instant::now()))
    }
}

impl MidiIn {
    /// Opens `target` now (an error if it cannot be opened) and starts its reader, which
    /// sends every read through `events` as `T::from(InEvent)`.
    pub fn open<T: From<InEvent> + Send + 'static>(
        target: &InTarget,
        events: Sender<T>,
    ) -> Result<MidiIn, OutError> {
        let stop = Arc::new(AtomicBool::new(false));
        if let InTarget::RtpMidi { name, addr } = target {
            let (label, local, thread) =
                crate::rtp::listen::start(name, *addr, Arc::clone(&stop), events)?;
            return Ok(MidiIn {
                name: label,
                stop,
                thread: Some(thread),
                local: Some(local),
            });
        }
        let (name, source, local) = open_source(target)?;
        let reconnects = match (target, &source) {
            (InTarget::Serial(_), _) => true,
            (InTarget::RawMidi(_), Source::File(f)) => {
                use std::os::unix::fs::FileTypeExt;
                f.metadata().is_ok_and(|m| m.file_type().is_char_device())
            }
            _ => false,
        };
        let thread = {
            let stop = Arc::clone(&stop);
            let target = target.clone();
            std::thread::Builder::new()
                .name(format!("orch-in {name}"))
                .spawn(move || {
                    // A read stamped late is a byte fed late: the reader runs at real-time
                    // priority where the OS allows it.
                    let priority = orch_perform::realtime::raise_priority();
                    tracing::debug!(?priority, "input reader");
                    read_loop(source, &stop, reconnects.then_some(&target), &events)
                })
                .map_err(|e| OutError::Open {
                    device: name.clone(),
                    source: e,
                })?
        };
        Ok(MidiIn {
            name,
            stop,
            thread: Some(thread),
            local,
        })
    }

    /// The input's name, for messages.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The address a datagram input is bound to (its port, if 0 was asked for).
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.local
    }
}

impl Drop for MidiIn {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        // A reader blocked on a file or standard input cannot be woken: it is left to end
        // with the process rather than waited for.
        if let Some(t) = self.thread.take() {
            if t.is_finished() {
                let _ = t.join();
            }
        }
    }
}

/// Opens an input: its name for messages, the source, and a datagram input's address.
fn open_source(target: &InTarget) -> Result<(String, Source, Option<SocketAddr>), OutError> {
    let open_err = |device: &str, source: io::Error| OutError::Open {
        device: device.to_string(),
        source,
    };
    Ok(match target {
        InTarget::Serial(p) => {
            let device = p.to_string_lossy().into_owned();
            let port = serialport::new(&device, DIN_BAUD)
                .data_bits(serialport::DataBits::Eight)
                .parity(serialport::Parity::None)
                .stop_bits(serialport::StopBits::One)
                .flow_control(serialport::FlowControl::None)
                .timeout(READ_POLL)
                .open()
                .map_err(|e| OutError::Serial {
                    device: device.clone(),
                    source: e,
                })?;
            let got = port.baud_rate().map_err(|e| OutError::Serial {
                device: device.clone(),
                source: e,
            })?;
            if got != DIN_BAUD {
                return Err(OutError::Baud { device, got });
            }
            (device, Source::Serial(port), None)
        }
        InTarget::RawMidi(p) => {
            let device = p.to_string_lossy().into_owned();
            let file = std::fs::File::open(p).map_err(|e| open_err(&device, e))?;
            (device, Source::File(file), None)
        }
        InTarget::Udp(addr) => {
            let device = format!("udp:{addr}");
            let socket = UdpSocket::bind(addr).map_err(|e| open_err(&device, e))?;
            socket
                .set_read_timeout(Some(READ_POLL))
                .map_err(|e| open_err(&device, e))?;
            crate::arrival::stamp_arrivals(&socket).map_err(|e| open_err(&device, e))?;
            let local = socket.local_addr().ok();
            (device, Source::Udp(socket), local)
        }
        InTarget::Stdin => (
            "standard input".to_string(),
            Source::Stdin(io::stdin()),
            None,
        ),
        #[cfg(feature = "alsa")]
        InTarget::Alsa(source) => {
            let port = crate::alsa_seq::AlsaIn::open(source.as_deref())?;
            let name = match source {
                Some(s) => format!("ALSA sequencer port {} (from {s})", port.address()),
                None => format!(
                    "ALSA sequencer port {} (connect a source: aconnect SOURCE {})",
                    port.address(),
                    port.address()
                ),
            };
            (name, Source::Alsa(port, Default::default()), None)
        }
        InTarget::RtpMidi { addr, .. } => {
            // Sessions have their own reader threads (MidiIn::open); never a plain source.
            return Err(OutError::Open {
                device: format!("rtpmidi:{addr}"),
                source: io::Error::new(io::ErrorKind::Unsupported, "not a byte source"),
            });
        }
        #[cfg(not(feature = "alsa"))]
        InTarget::Alsa(_) => {
            return Err(OutError::Open {
                device: "the ALSA sequencer".into(),
                source: io::Error::new(
                    io::ErrorKind::Unsupported,
                    "this orch was built without the `alsa` feature",
                ),
            })
        }
    })
}

/// Reads until the end, a failure or `stop`. With `reconnect` (a device that can come back),
/// an end or a failure is [`InEvent::Lost`], and the device is opened again every
/// [`RECONNECT_EVERY`] until it opens ([`InEvent::Back`]) or `stop`.
fn read_loop<T: From<InEvent>>(
    mut source: Source,
    stop: &AtomicBool,
    reconnect: Option<&InTarget>,
    events: &Sender<T>,
) {
    let mut buf = [0u8; READ_SIZE];
    while !stop.load(Ordering::SeqCst) {
        let event = match source.read(&mut buf) {
            Ok((0, _)) if matches!(source, Source::Udp(_)) => continue,
            Ok((0, _)) => InEvent::End,
            Ok((n, at)) => InEvent::Bytes {
                at,
                bytes: buf[..n].to_vec(),
            },
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut
                        | io::ErrorKind::WouldBlock
                        | io::ErrorKind::Interrupted
                ) =>
            {
                continue
            }
            Err(e) => InEvent::Failed(e),
        };
        let event = match (event, reconnect) {
            (InEvent::End, Some(_)) => InEvent::Lost(io::Error::new(
                io::ErrorKind::UnexpectedEof,
                "the device hung up",
            )),
            (InEvent::Failed(e), Some(_)) => InEvent::Lost(e),
            (event, _) => event,
        };
        let lost = matches!(event, InEvent::Lost(_));
        let last = matches!(event, InEvent::End | InEvent::Failed(_));
        if events.send(T::from(event)).is_err() || last {
            return;
        }
        if let (true, Some(target)) = (lost, reconnect) {
            // The device is gone: its descriptor goes with it, and the path is tried again.
            drop(std::mem::replace(&mut source, Source::Closed));
            match reopen(target, stop) {
                Some(s) => source = s,
                None => return,
            }
            if events.send(T::from(InEvent::Back)).is_err() {
                return;
            }
        }
    }
}

/// Opens `target` again every [`RECONNECT_EVERY`] until it opens; `None` once `stop` is set.
fn reopen(target: &InTarget, stop: &AtomicBool) -> Option<Source> {
    loop {
        let until = Instant::now() + RECONNECT_EVERY;
        while Instant::now() < until {
            if stop.load(Ordering::SeqCst) {
                return None;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        if let Ok((_, source, _)) = open_source(target) {
            return Some(source);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_and_bad_ones() {
        assert_eq!(InTarget::parse("-").unwrap(), InTarget::Stdin);
        assert_eq!(
            InTarget::parse("serial:/dev/ttyS0").unwrap(),
            InTarget::Serial("/dev/ttyS0".into())
        );
        assert_eq!(
            InTarget::parse("rawmidi:/dev/snd/midiC1D0").unwrap(),
            InTarget::RawMidi("/dev/snd/midiC1D0".into())
        );
        assert_eq!(
            InTarget::parse("udp:5004").unwrap(),
            InTarget::Udp("127.0.0.1:5004".parse().unwrap())
        );
        assert_eq!(
            InTarget::parse("udp:0.0.0.0:9").unwrap(),
            InTarget::Udp("0.0.0.0:9".parse().unwrap())
        );
        for (bad, why) in [
            ("serial", "no kind"),
            ("serial:", "needs a target"),
            ("udp:99999", "not PORT"),
            ("tcp:1", "unknown input kind"),
            #[cfg(not(feature = "alsa"))]
            ("alsa:128:0", "rawmidi"),
        ] {
            let e = InTarget::parse(bad).unwrap_err().to_string();
            assert!(e.contains(why), "{bad}: {e}");
        }
    }

    /// A pseudo-terminal pair: the master, and the slave's path (a character device).
    fn pty() -> (nix::pty::PtyMaster, String) {
        use nix::fcntl::OFlag;
        let m = nix::pty::posix_openpt(OFlag::O_RDWR | OFlag::O_NOCTTY | OFlag::O_CLOEXEC).unwrap();
        nix::pty::grantpt(&m).unwrap();
        nix::pty::unlockpt(&m).unwrap();
        let path = nix::pty::ptsname_r(&m).unwrap();
        let mut t = nix::sys::termios::tcgetattr(&m).unwrap();
        nix::sys::termios::cfmakeraw(&mut t);
        nix::sys::termios::tcsetattr(&m, nix::sys::termios::SetArg::TCSANOW, &t).unwrap();
        (m, path)
    }

    fn next_bytes(rx: &std::sync::mpsc::Receiver<InEvent>) -> Vec<u8> {
        match rx.recv_timeout(Duration::from_secs(5)).unwrap() {
            InEvent::Bytes { bytes, .. } => bytes,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_raw_midi_device_that_goes_away_is_lost_then_back_at_the_same_path() {
        use std::io::Write;
        let link = testkit::in_test("dev");
        let (mut first, path) = pty();
        std::os::unix::fs::symlink(&path, &link).unwrap();
        let (tx, rx) = std::sync::mpsc::channel::<InEvent>();
        let input = MidiIn::open(&InTarget::RawMidi(link.clone()), tx).unwrap();
        first.write_all(&[0x90, 60, 100]).unwrap();
        assert_eq!(next_bytes(&rx), [0x90, 60, 100]);
        drop(first);
        match rx.recv_timeout(Duration::from_secs(5)).unwrap() {
            InEvent::Lost(_) => {}
            other => panic!("{other:?}"),
        }
        // Nothing while it is away (tried every RECONNECT_EVERY).
        assert!(rx.recv_timeout(RECONNECT_EVERY * 2).is_err());
        let (mut second, path) = pty();
        std::fs::remove_file(&link).unwrap();
        std::os::unix::fs::symlink(&path, &link).unwrap();
        match rx.recv_timeout(Duration::from_secs(5)).unwrap() {
            InEvent::Back => {}
            other => panic!("{other:?}"),
        }
        second.write_all(&[0x80, 60, 0]).unwrap();
        assert_eq!(next_bytes(&rx), [0x80, 60, 0]);
        drop(input);
        std::fs::remove_file(&link).unwrap();
    }

    #[test]
    fn udp_datagrams_arrive_stamped_and_a_file_ends() {
        let (tx, rx) = std::sync::mpsc::channel::<InEvent>();
        let input = MidiIn::open(&InTarget::Udp("127.0.0.1:0".parse().unwrap()), tx).unwrap();
        let to = input.local_addr().unwrap();
        let s = UdpSocket::bind("127.0.0.1:0").unwrap();
        let before = Instant::now();
        s.send_to(&[0x90, 60, 100], to).unwrap();
        match rx.recv_timeout(Duration::from_secs(5)).unwrap() {
            InEvent::Bytes { at, bytes } => {
                assert_eq!(bytes, [0x90, 60, 100]);
                assert!(at >= before);
            }
            other => panic!("{other:?}"),
        }

        let path = testkit::in_test("in");
        std::fs::write(&path, [0x80, 60, 0]).unwrap();
        let (tx, rx) = std::sync::mpsc::channel::<InEvent>();
        let _file = MidiIn::open(&InTarget::RawMidi(path.clone()), tx).unwrap();
        let mut got = Vec::new();
        loop {
            match rx.recv_timeout(Duration::from_secs(5)).unwrap() {
                InEvent::Bytes { bytes, .. } => got.extend(bytes),
                InEvent::End => break,
                other => panic!("{other:?}"),
            }
        }
        assert_eq!(got, [0x80, 60, 0]);
        std::fs::remove_file(path).unwrap();
    }
}
