//! MIDI inputs: where `orch run --in` reads raw MIDI bytes from.
//!
//! ```text
//! IN = serial:DEVICE | rawmidi:DEVICE | udp:PORT | udp:HOST:PORT | -
//! ```
//!
//! | IN | what |
//! |---|---|
//! | `serial:/dev/ttyUSB0` | a DIN MIDI line through a UART, set to 31 250 baud 8N1 (raw mode) |
//! | `rawmidi:/dev/snd/midiC1D0` | the kernel's raw MIDI device (or any file or FIFO), read as a file |
//! | `udp:5004` | datagrams of raw MIDI bytes on the loopback address, port 5004 |
//! | `udp:0.0.0.0:5004` | the same on every address (or any `HOST:PORT` to bind) |
//! | `-` | standard input |
//!
//! [`MidiIn::open`] starts a reader thread (at real-time priority where the OS allows it)
//! that stamps each read with the host's monotonic
//! clock ([`std::time::Instant`]) the moment it returns, and sends it as an [`InEvent`] on a
//! channel the caller owns, so that the caller can wait on input, its own timers and
//! anything else (signals) in one place. The end of the input (a file or standard input at
//! its end, a serial line hung up) is an [`InEvent::End`]; a read error is
//! [`InEvent::Failed`]. A datagram input never ends by itself.

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
            "--in {}: {} (give serial:DEVICE, rawmidi:DEVICE, udp:PORT, udp:HOST:PORT or -)",
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
            "alsa" => Err(err(
                "ALSA sequencer inputs are not supported yet; rawmidi:/dev/snd/midiCxDy reads \
                 the same hardware"
                    .into(),
            )),
            other => Err(err(format!("unknown input kind `{other}`"))),
        }
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
    /// The input ended (end of file, a serial line hung up).
    End,
    /// The input failed; nothing more comes.
    Failed(io::Error),
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
}

impl Source {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self {
            Source::Serial(p) => p.read(buf),
            Source::File(f) => f.read(buf),
            Source::Udp(s) => s.recv(buf),
            Source::Stdin(s) => s.lock().read(buf),
        }
    }
}

impl MidiIn {
    /// Opens `target` now (an error if it cannot be opened) and starts its reader, which
    /// sends every read through `events` as `T::from(InEvent)`.
    pub fn open<T: From<InEvent> + Send + 'static>(
        target: &InTarget,
        events: Sender<T>,
    ) -> Result<MidiIn, OutError> {
        let open_err = |device: &str, source: io::Error| OutError::Open {
            device: device.to_string(),
            source,
        };
        let mut local = None;
        let (name, source) = match target {
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
                (device, Source::Serial(port))
            }
            InTarget::RawMidi(p) => {
                let device = p.to_string_lossy().into_owned();
                let file = std::fs::File::open(p).map_err(|e| open_err(&device, e))?;
                (device, Source::File(file))
            }
            InTarget::Udp(addr) => {
                let device = format!("udp:{addr}");
                let socket = UdpSocket::bind(addr).map_err(|e| open_err(&device, e))?;
                socket
                    .set_read_timeout(Some(READ_POLL))
                    .map_err(|e| open_err(&device, e))?;
                local = socket.local_addr().ok();
                (device, Source::Udp(socket))
            }
            InTarget::Stdin => ("standard input".to_string(), Source::Stdin(io::stdin())),
        };
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let stop = Arc::clone(&stop);
            let hung_up_ends = matches!(target, InTarget::Serial(_));
            std::thread::Builder::new()
                .name(format!("orch-in {name}"))
                .spawn(move || {
                    // A read stamped late is a byte fed late: the reader runs at real-time
                    // priority where the OS allows it.
                    let priority = orch_perform::realtime::raise_priority();
                    tracing::debug!(?priority, "input reader");
                    read_loop(source, &stop, hung_up_ends, &events)
                })
                .map_err(|e| open_err(&name, e))?
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

/// `EIO`: what reading a terminal whose other end hung up returns on Linux.
const EIO: i32 = 5;

fn read_loop<T: From<InEvent>>(
    mut source: Source,
    stop: &AtomicBool,
    hung_up_ends: bool,
    events: &Sender<T>,
) {
    let mut buf = [0u8; READ_SIZE];
    while !stop.load(Ordering::SeqCst) {
        let event = match source.read(&mut buf) {
            Ok(0) if matches!(source, Source::Udp(_)) => continue,
            Ok(0) => InEvent::End,
            Ok(n) => InEvent::Bytes {
                at: Instant::now(),
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
            Err(e) if hung_up_ends && e.raw_os_error() == Some(EIO) => InEvent::End,
            Err(e) => InEvent::Failed(e),
        };
        let last = !matches!(event, InEvent::Bytes { .. });
        if events.send(T::from(event)).is_err() || last {
            return;
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
            ("alsa:128:0", "rawmidi"),
        ] {
            let e = InTarget::parse(bad).unwrap_err().to_string();
            assert!(e.contains(why), "{bad}: {e}");
        }
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

        let path = std::env::temp_dir().join(format!("orch-in-{}", std::process::id()));
        std::fs::write(&path, [0x80, 60, 0]).unwrap();
        let (tx, rx) = std::sync::mpsc::channel::<InEvent>();
        let _file = MidiIn::open(&InTarget::RawMidi(path.clone()), tx).unwrap();
        let mut got = Vec::new();
        loop {
            match rx.recv_timeout(Duration::from_secs(5)).unwrap() {
                InEvent::Bytes { bytes, .. } => got.extend(bytes),
                InEvent::End => break,
                InEvent::Failed(e) => panic!("{e}"),
            }
        }
        assert_eq!(got, [0x80, 60, 0]);
        std::fs::remove_file(path).unwrap();
    }
}
