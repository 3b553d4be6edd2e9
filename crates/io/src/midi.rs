//! MIDI byte outputs: a DIN line through a UART, a raw MIDI device, UDP datagrams.
//!
//! A serial line is written at the wire's pace (320 µs a byte, [`Port::byte_time`]): a write
//! waits until the bytes before it would have left a DIN line, so a device that does not pace
//! itself gets them when the virtual copy does.
//!
//! Each is a [`MidiPort`] over one [`Port`]: it writes what the performer sends, and when the
//! device goes away (unplugged, its reader gone, a write that cannot finish within
//! [`WRITE_TIMEOUT`]) it says so once, keeps playing the virtual copy, tries to open the
//! device again with backoff, and on its return first sends All Notes Off on every channel
//! and a full status byte, so that no key the robot held before the loss stays down. On the
//! way out, [`finish`](orch_perform::MidiOut::finish) and `Drop` (a panic unwinding too) send
//! All Notes Off on every channel.

use std::io::{self, Write};
use std::net::UdpSocket;
use std::os::unix::fs::OpenOptionsExt;
use std::path::Path;
use std::time::{Duration, Instant};

use orch_perform::MidiOut;

use crate::OutError;

/// The MIDI wire's baud rate.
pub const DIN_BAUD: u32 = 31_250;

/// The longest a write may take before the device counts as gone: a line that takes no
/// bytes for this long is not playing.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(1);

/// The first wait before opening a lost device again; it doubles up to [`MAX_BACKOFF`].
pub const FIRST_BACKOFF: Duration = Duration::from_millis(50);
/// The longest wait between two attempts to open a lost device.
pub const MAX_BACKOFF: Duration = Duration::from_secs(2);

/// All Notes Off (CC 123) on every channel, each with its status byte.
pub fn all_notes_off() -> [u8; 48] {
    let mut b = [0u8; 48];
    for ch in 0..16u8 {
        let i = 3 * ch as usize;
        b[i] = 0xB0 | ch;
        b[i + 1] = 123;
    }
    b
}

/// A device a [`MidiPort`] writes: opened by name, written whole messages at a time.
pub trait Port: Sized {
    /// Opens it.
    fn open(target: &str) -> Result<Self, OutError>;
    /// Writes all of `bytes` (one message, or a few), or fails.
    fn write_bytes(&mut self, bytes: &[u8]) -> io::Result<()>;
    /// Whether each write must carry whole messages with their status byte (a datagram is
    /// read on its own: running status cannot cross it).
    fn whole_messages() -> bool {
        false
    }

    /// The time one byte takes on the line, if the port must not be written faster than
    /// that: a write waits until the bytes before it would have left the wire.
    fn byte_time() -> Option<Duration> {
        None
    }
}

/// A UART at 31 250 baud, 8N1, no flow control (`serialport`; on Linux the rate is set
/// exactly with `termios2` and `BOTHER`, and read back to check). The line is then written
/// through a second, non-blocking descriptor of the same device (the settings belong to the
/// device), so that no write blocks past [`WRITE_TIMEOUT`]: a blocking write to a full tty
/// would wait for every byte, however long.
pub struct Serial {
    _port: Box<dyn serialport::SerialPort>,
    file: std::fs::File,
}

impl Port for Serial {
    fn open(target: &str) -> Result<Self, OutError> {
        let port = serialport::new(target, DIN_BAUD)
            .data_bits(serialport::DataBits::Eight)
            .parity(serialport::Parity::None)
            .stop_bits(serialport::StopBits::One)
            .flow_control(serialport::FlowControl::None)
            .timeout(WRITE_TIMEOUT)
            .open()
            .map_err(|e| OutError::Serial {
                device: target.into(),
                source: e,
            })?;
        let got = port.baud_rate().map_err(|e| OutError::Serial {
            device: target.into(),
            source: e,
        })?;
        if got != DIN_BAUD {
            return Err(OutError::Baud {
                device: target.into(),
                got,
            });
        }
        let file = std::fs::OpenOptions::new()
            .write(true)
            .custom_flags(O_NONBLOCK | O_NOCTTY)
            .open(target)
            .map_err(|e| OutError::Open {
                device: target.into(),
                source: e,
            })?;
        Ok(Serial { _port: port, file })
    }

    fn write_bytes(&mut self, bytes: &[u8]) -> io::Result<()> {
        write_within_timeout(&mut self.file, bytes)
    }

    /// 320 µs: written at the wire's own pace, a device that does not pace itself (a
    /// pseudo-terminal to a simulator, a USB bridge with a deep buffer) gets the bytes when a
    /// DIN line would deliver them, as the virtual copy takes them.
    fn byte_time() -> Option<Duration> {
        Some(Duration::from_micros(320))
    }
}

/// A raw MIDI device (`/dev/snd/midiCxDy`), a FIFO or a file, written as a file. Opened
/// without blocking (a FIFO with no reader fails at once instead of hanging) and never
/// created (a mistyped device path is an error, not a new file).
pub struct RawMidi {
    file: std::fs::File,
}

/// `O_NONBLOCK` on Linux.
const O_NONBLOCK: i32 = 0o4000;
/// `O_NOCTTY` on Linux: a terminal opened by orch never becomes its controlling terminal.
const O_NOCTTY: i32 = 0o400;

/// Writes all of `bytes` to a non-blocking file: a full device buffer is waited for, up to
/// [`WRITE_TIMEOUT`].
fn write_within_timeout(file: &mut std::fs::File, mut bytes: &[u8]) -> io::Result<()> {
    let deadline = Instant::now() + WRITE_TIMEOUT;
    while !bytes.is_empty() {
        match file.write(bytes) {
            Ok(0) => return Err(io::ErrorKind::WriteZero.into()),
            Ok(n) => bytes = &bytes[n..],
            Err(e) if e.kind() == io::ErrorKind::WouldBlock && Instant::now() < deadline => {
                std::thread::sleep(Duration::from_micros(500));
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                return Err(io::Error::new(
                    io::ErrorKind::TimedOut,
                    "the device took no bytes for 1 s",
                ))
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

impl Port for RawMidi {
    fn open(target: &str) -> Result<Self, OutError> {
        let file = std::fs::OpenOptions::new()
            .write(true)
            .custom_flags(O_NONBLOCK | O_NOCTTY)
            .open(target)
            .map_err(|e| OutError::Open {
                device: target.into(),
                source: e,
            })?;
        Ok(RawMidi { file })
    }

    fn write_bytes(&mut self, bytes: &[u8]) -> io::Result<()> {
        write_within_timeout(&mut self.file, bytes)
    }
}

/// UDP: one whole message per datagram, to `HOST:PORT`. A refused datagram (nobody
/// listening yet) is not a lost device: UDP keeps sending.
pub struct Udp(UdpSocket);

impl Port for Udp {
    fn open(target: &str) -> Result<Self, OutError> {
        use std::net::ToSocketAddrs;
        let open = || -> io::Result<UdpSocket> {
            let to = target
                .to_socket_addrs()?
                .next()
                .ok_or_else(|| io::Error::new(io::ErrorKind::NotFound, "no address"))?;
            let local = if to.is_ipv4() { "0.0.0.0:0" } else { "[::]:0" };
            let s = UdpSocket::bind(local)?;
            s.connect(to)?;
            s.set_write_timeout(Some(WRITE_TIMEOUT))?;
            Ok(s)
        };
        open().map(Udp).map_err(|e| OutError::Open {
            device: target.into(),
            source: e,
        })
    }

    fn write_bytes(&mut self, bytes: &[u8]) -> io::Result<()> {
        match self.0.send(bytes) {
            Ok(_) => Ok(()),
            Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => Ok(()),
            Err(e) => Err(e),
        }
    }

    fn whole_messages() -> bool {
        true
    }
}

/// What happened on a port, for the report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PortStats {
    /// Bytes written.
    pub bytes: u64,
    /// Writes (sends) made.
    pub writes: u64,
    /// Times the device went away.
    pub lost: u64,
    /// Times it came back (and was sent All Notes Off first).
    pub reconnected: u64,
    /// Bytes not written because the device was away.
    pub dropped_bytes: u64,
}

/// A MIDI output on a [`Port`], with reconnection. See the [module notes](self).
pub struct MidiPort<P: Port> {
    name: String,
    port: Option<P>,
    /// The channel status in force in the stream the performer sends (running status).
    status: u8,
    /// The device has not seen a status byte since it was opened again.
    need_status: bool,
    next_try: Instant,
    backoff: Duration,
    finished: bool,
    stats: PortStats,
    /// When the bytes written so far have left the wire ([`Port::byte_time`]).
    wire_free: Instant,
    sleeper: spin_sleep::SpinSleeper,
}

/// A DIN line through a UART.
pub type SerialOut = MidiPort<Serial>;
/// A raw MIDI device.
pub type RawMidiOut = MidiPort<RawMidi>;
/// UDP datagrams.
pub type UdpOut = MidiPort<Udp>;

impl<P: Port> MidiPort<P> {
    /// Opens `target`; an error if it cannot be opened now (a performance should not start
    /// on a device that is not there).
    pub fn open(target: &str) -> Result<Self, OutError> {
        let port = P::open(target)?;
        tracing::debug!(device = target, "opened");
        Ok(Self {
            name: target.to_string(),
            port: Some(port),
            status: 0,
            need_status: false,
            next_try: Instant::now(),
            backoff: FIRST_BACKOFF,
            finished: false,
            stats: PortStats::default(),
            wire_free: Instant::now(),
            sleeper: spin_sleep::SpinSleeper::default(),
        })
    }

    /// Opens a file path (a device or a FIFO).
    pub fn open_path(path: &Path) -> Result<Self, OutError> {
        Self::open(&path.to_string_lossy())
    }

    /// What happened so far.
    pub fn stats(&self) -> PortStats {
        self.stats
    }

    /// Whether the device is there now.
    pub fn connected(&self) -> bool {
        self.port.is_some()
    }

    fn write(&mut self, bytes: &[u8]) {
        if self.port.is_none() && !self.reconnect() {
            self.stats.dropped_bytes += bytes.len() as u64;
            return;
        }
        let Some(port) = self.port.as_mut() else {
            return;
        };
        if P::byte_time().is_some() {
            let now = Instant::now();
            if self.wire_free > now {
                self.sleeper.sleep(self.wire_free - now);
            }
        }
        match port.write_bytes(bytes) {
            Ok(()) => {
                self.stats.bytes += bytes.len() as u64;
                self.stats.writes += 1;
                if let Some(byte) = P::byte_time() {
                    self.wire_free = self.wire_free.max(Instant::now()) + byte * bytes.len() as u32;
                }
            }
            Err(e) => {
                self.stats.lost += 1;
                self.stats.dropped_bytes += bytes.len() as u64;
                tracing::warn!(
                    device = %self.name,
                    error = %e,
                    "the MIDI output is gone; playing on, opening it again when it returns"
                );
                self.port = None;
                self.backoff = FIRST_BACKOFF;
                self.next_try = Instant::now() + self.backoff;
            }
        }
    }

    /// Tries to open a lost device again, if its backoff has passed. On success the device
    /// is first told All Notes Off on every channel.
    fn reconnect(&mut self) -> bool {
        let now = Instant::now();
        if now < self.next_try {
            return false;
        }
        match P::open(&self.name) {
            Ok(mut port) => match write_all_off(&mut port) {
                Ok(()) => {
                    self.stats.reconnected += 1;
                    self.stats.bytes += 48;
                    self.need_status = true;
                    tracing::warn!(device = %self.name, "the MIDI output is back: all notes off sent");
                    self.port = Some(port);
                    true
                }
                Err(_) => self.back_off(now),
            },
            Err(e) => {
                tracing::debug!(device = %self.name, error = %e, "still gone");
                self.back_off(now)
            }
        }
    }

    fn back_off(&mut self, now: Instant) -> bool {
        self.backoff = (self.backoff * 2).min(MAX_BACKOFF);
        self.next_try = now + self.backoff;
        false
    }
}

impl<P: Port> std::fmt::Debug for MidiPort<P> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MidiPort")
            .field("name", &self.name)
            .field("connected", &self.port.is_some())
            .field("stats", &self.stats)
            .finish()
    }
}

impl<P: Port> MidiOut for MidiPort<P> {
    type Error = std::convert::Infallible;

    /// Writes the bytes as sent (running status and all), or, on a datagram port or after a
    /// reconnection, with the status byte put back where running status left it out.
    fn send(&mut self, _t_us: u64, bytes: &[u8]) -> Result<(), Self::Error> {
        let Some(&first) = bytes.first() else {
            return Ok(());
        };
        if self.port.is_none() {
            // Opened again (if its backoff has passed), it needs a status byte first.
            self.reconnect();
        }
        match first {
            0x80..=0xEF => {
                self.status = first;
                self.need_status = false;
            }
            0xF0..=0xF7 => self.status = 0,
            _ => {}
        }
        let restore = first < 0x80 && self.status != 0 && (P::whole_messages() || self.need_status);
        if restore {
            let mut whole = Vec::with_capacity(bytes.len() + 1);
            whole.push(self.status);
            whole.extend_from_slice(bytes);
            self.need_status = false;
            self.write(&whole);
        } else {
            self.write(bytes);
        }
        Ok(())
    }

    fn finish(&mut self, _t_us: u64) -> Result<(), Self::Error> {
        // The performer has just sent All Notes Off on every channel; a device that came back
        // only now got its own on reconnection.
        self.finished = true;
        Ok(())
    }
}

impl<P: Port> Drop for MidiPort<P> {
    /// Unless the performance finished (and sent All Notes Off itself), All Notes Off on every
    /// channel: a panic or an error on the way must not leave a key down.
    fn drop(&mut self) {
        if !self.finished {
            if let Some(port) = self.port.as_mut() {
                if write_all_off(port).is_ok() {
                    tracing::debug!(device = %self.name, "all notes off on the way out");
                }
            }
        }
    }
}

/// Writes All Notes Off on every channel: one write, or one a message on a datagram port.
fn write_all_off<P: Port>(port: &mut P) -> io::Result<()> {
    let all = all_notes_off();
    if P::whole_messages() {
        all.chunks(3).try_for_each(|m| port.write_bytes(m))
    } else {
        port.write_bytes(&all)
    }
}
