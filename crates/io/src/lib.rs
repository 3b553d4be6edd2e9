//! # orch-io: the host's outputs
//!
//! Where `orch play --out` sends a performance, each as an [`orch_perform::MidiOut`] that the
//! performer drives beside its virtual robot:
//!
//! - MIDI byte outputs for a robot that interprets MIDI itself ([`midi`]): a DIN line through
//!   a UART at 31 250 baud ([`SerialOut`]), the kernel's raw MIDI device written as a file
//!   ([`RawMidiOut`]), UDP datagrams of one message each ([`UdpOut`]). A device that goes away
//!   is said once and opened again when it returns, All Notes Off first.
//! - Finger boards on the host's own I2C bus ([`boards`]): orch-core's interpreter and guard
//!   on `orch-boards`' PCA9555 driver ([`BoardsOut`]), with retries, lost boards played
//!   around and re-initialised when they answer again ([`ResilientBoards`]).
//! - MIDI inputs for `orch run --in` ([`input`]): a UART at 31 250 baud, a raw MIDI device
//!   or file, UDP datagrams, an RTP-MIDI session, standard input; each read stamped with the
//!   host's monotonic clock (a UDP datagram with the kernel's arrival time: [`arrival`]).
//! - RTP-MIDI with AppleMIDI sessions ([`rtp`]), in (`--in rtpmidi:PORT`) and out
//!   (`--out rtpmidi:HOST:PORT`), with the recovery journal's chapters N and C.
//! - `--out` specifications ([`spec`]): `serial:/dev/ttyUSB0`, `udp:HOST:PORT:ch=2`, …
//!
//! Every output lets go of every key when the performance ends, when it is stopped and when
//! it is dropped on the way out of a panic. Logging goes through `tracing` (nothing is
//! printed unless the program installs a subscriber).
//!
//! ```
//! use orch_io::{OutSpec, Target};
//!
//! let out = OutSpec::parse("udp:127.0.0.1:9000:ch=2").unwrap();
//! assert_eq!(out.target, Target::Udp("127.0.0.1:9000".into()));
//! assert!(out.channels.contains(1) && !out.channels.contains(0));
//! ```
//!
//! ## Cargo features
//!
//! - `alsa` (off by default): `alsa:CLIENT:PORT` outputs and `alsa:` / `alsa:CLIENT:PORT`
//!   inputs, ALSA sequencer ports (the `alsa_seq` module). It links alsa-lib (`libasound2-dev` to
//!   build).
//!
//! Without it no system library is needed: serial ports through `serialport` without
//! libudev, I2C through the kernel's `i2c-dev` interface, raw MIDI as a file.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

#[cfg(feature = "alsa")]
pub mod alsa_seq;
pub mod arrival;
pub mod boards;
pub mod input;
pub mod midi;
pub mod rtp;
pub mod spec;

use std::fmt;

pub use boards::{open_i2c, BoardStats, BoardsOut, LinuxI2c, ResilientBoards, TimedBus};
pub use input::{InEvent, InSpecError, InTarget, MidiIn, RECONNECT_EVERY};
pub use midi::{MidiPort, Port, PortStats, RawMidiOut, SerialOut, UdpOut};
pub use rtp::out::RtpMidiOut;
pub use spec::{Channels, OutSpec, SpecError, Target};

use orch_perform::{MidiOut, MAX_BOARDS};

/// What goes wrong with an output.
#[derive(Debug)]
#[non_exhaustive]
pub enum OutError {
    /// A device could not be opened.
    Open {
        /// The device.
        device: String,
        /// Why.
        source: std::io::Error,
    },
    /// A serial port could not be opened or set up.
    Serial {
        /// The device.
        device: String,
        /// Why.
        source: serialport::Error,
    },
    /// A serial port did not take 31 250 baud.
    Baud {
        /// The device.
        device: String,
        /// The rate it reports instead.
        got: u32,
    },
    /// More boards than a host robot may have.
    TooManyBoards {
        /// How many were asked for.
        boards: usize,
    },
    /// No finger board answered.
    NoBoard {
        /// The addresses tried.
        addresses: String,
    },
    /// The robot on the boards failed (its configuration, or a driver error that is not the
    /// bus's).
    Board(String),
}

impl fmt::Display for OutError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OutError::Open { device, source } => write!(f, "cannot open {device}: {source}"),
            OutError::Serial { device, source } => {
                write!(f, "cannot open serial port {device}: {source}")
            }
            OutError::Baud { device, got } => write!(
                f,
                "serial port {device} runs at {got} baud, not MIDI's 31250: its driver cannot \
                 set the rate"
            ),
            OutError::TooManyBoards { boards } => {
                write!(f, "{boards} boards: a host robot has at most {MAX_BOARDS}")
            }
            OutError::NoBoard { addresses } => write!(
                f,
                "no finger board answered at {addresses}: check the bus, its power and the \
                 addresses in robot.toml"
            ),
            OutError::Board(e) => write!(f, "the finger boards: {e}"),
        }
    }
}

impl std::error::Error for OutError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            OutError::Open { source, .. } => Some(source),
            OutError::Serial { source, .. } => Some(source),
            _ => None,
        }
    }
}

/// One opened output of any kind (not the virtual robot alone, which needs none).
#[derive(Debug)]
pub enum Output {
    /// A DIN line through a UART.
    Serial(SerialOut),
    /// A raw MIDI device.
    RawMidi(RawMidiOut),
    /// UDP datagrams.
    Udp(UdpOut),
    /// An RTP-MIDI session orch began.
    RtpMidi(Box<RtpMidiOut>),
    /// An ALSA sequencer port.
    #[cfg(feature = "alsa")]
    Alsa(alsa_seq::AlsaOut),
    /// Finger boards on a Linux I2C bus.
    I2c(Box<BoardsOut<LinuxI2c>>),
}

impl Output {
    /// Opens `target` for a robot configured as `config` (for I2C: the boards' addresses,
    /// each board's kind in `kinds` (on/off past its end) and the PCA9685s' `pwm_hz`). `None`
    /// for [`Target::Sim`].
    pub fn open(
        target: &Target,
        config: &orch_core::Config<MAX_BOARDS>,
        kinds: &[orch_core::BoardKind],
        pwm_hz: u32,
    ) -> Result<Option<Output>, OutError> {
        let path = |p: &std::path::Path| p.to_string_lossy().into_owned();
        Ok(Some(match target {
            Target::Sim => return Ok(None),
            Target::Serial(p) => Output::Serial(SerialOut::open(&path(p))?),
            Target::RawMidi(p) => Output::RawMidi(RawMidiOut::open(&path(p))?),
            Target::Udp(a) => Output::Udp(UdpOut::open(a)?),
            Target::RtpMidi(a) => Output::RtpMidi(Box::new(RtpMidiOut::open(a)?)),
            #[cfg(feature = "alsa")]
            Target::Alsa(a) => Output::Alsa(alsa_seq::AlsaOut::open(a)?),
            Target::I2c(p) => Output::I2c(Box::new(BoardsOut::with_kinds(
                *config,
                kinds,
                pwm_hz,
                open_i2c(&path(p))?,
            )?)),
        }))
    }

    /// What happened on it so far.
    pub fn stats(&self) -> OutStats {
        match self {
            Output::Serial(p) => OutStats::Port(p.stats()),
            Output::RawMidi(p) => OutStats::Port(p.stats()),
            Output::Udp(p) => OutStats::Port(p.stats()),
            Output::RtpMidi(p) => OutStats::Port(p.stats()),
            #[cfg(feature = "alsa")]
            Output::Alsa(p) => OutStats::Port(p.stats()),
            Output::I2c(b) => OutStats::Boards(b.boards().stats()),
        }
    }
}

/// What happened on an output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutStats {
    /// A MIDI byte output.
    Port(PortStats),
    /// Finger boards.
    Boards(BoardStats),
}

impl MidiOut for Output {
    type Error = OutError;

    fn send(&mut self, t_us: u64, bytes: &[u8]) -> Result<(), OutError> {
        match self {
            Output::Serial(p) => p.send(t_us, bytes).map_err(|e| match e {}),
            Output::RawMidi(p) => p.send(t_us, bytes).map_err(|e| match e {}),
            Output::Udp(p) => p.send(t_us, bytes).map_err(|e| match e {}),
            Output::RtpMidi(p) => p.send(t_us, bytes).map_err(|e| match e {}),
            #[cfg(feature = "alsa")]
            Output::Alsa(p) => p.send(t_us, bytes).map_err(|e| match e {}),
            Output::I2c(b) => b.send(t_us, bytes),
        }
    }

    fn next_deadline(&self) -> Option<u64> {
        match self {
            Output::I2c(b) => b.next_deadline(),
            _ => None,
        }
    }

    fn poll(&mut self, t_us: u64) -> Result<(), OutError> {
        match self {
            Output::I2c(b) => b.poll(t_us),
            _ => Ok(()),
        }
    }

    fn finish(&mut self, t_us: u64) -> Result<(), OutError> {
        match self {
            Output::Serial(p) => p.finish(t_us).map_err(|e| match e {}),
            Output::RawMidi(p) => p.finish(t_us).map_err(|e| match e {}),
            Output::Udp(p) => p.finish(t_us).map_err(|e| match e {}),
            Output::RtpMidi(p) => p.finish(t_us).map_err(|e| match e {}),
            #[cfg(feature = "alsa")]
            Output::Alsa(p) => p.finish(t_us).map_err(|e| match e {}),
            Output::I2c(b) => b.finish(t_us),
        }
    }
}
