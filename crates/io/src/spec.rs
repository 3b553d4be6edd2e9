//! `--out` specifications: where a performance goes, and which channels it takes.
//!
//! ```text
//! OUT      = KIND [":" TARGET] [":ch=" CHANNELS]
//! KIND     = sim | serial | rawmidi | udp | rtpmidi | i2c | alsa
//! CHANNELS = a comma-separated list of channels 1..=16 and ranges: 1   2,3   1-4,10
//! ```
//!
//! | OUT | what |
//! |---|---|
//! | `sim` | the virtual robot alone (no target) |
//! | `serial:/dev/ttyUSB0` | a DIN MIDI line through a UART at 31 250 baud, 8N1 |
//! | `rawmidi:/dev/snd/midiC1D0` | the kernel's raw MIDI device, written as a file |
//! | `udp:HOST:PORT` | raw MIDI bytes, one whole message per datagram |
//! | `rtpmidi:HOST:PORT` | an RTP-MIDI (AppleMIDI) session orch begins with the peer whose control port is PORT, with a recovery journal ([`crate::rtp::out`]) |
//! | `i2c:/dev/i2c-1` | PCA9555 finger boards on the host's I2C bus, driven by this host |
//! | `alsa:128:0` | an ALSA sequencer port (with the `alsa` feature) |
//!
//! `:ch=` at the end keeps only those channels' messages for that output: one file on several
//! robots, `--out serial:/dev/ttyUSB0:ch=1 --out udp:127.0.0.1:9000:ch=2`.

use std::fmt;
use std::path::PathBuf;

/// What went wrong reading an `--out` specification.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SpecError {
    /// The specification as given.
    pub spec: String,
    /// Why it was refused.
    pub reason: String,
}

impl fmt::Display for SpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "--out {}: {} (give sim, serial:DEVICE, rawmidi:DEVICE, udp:HOST:PORT, \
             rtpmidi:HOST:PORT, i2c:DEVICE or alsa:CLIENT:PORT, optionally followed by \
             :ch=1,2-4)",
            self.spec, self.reason
        )
    }
}

impl std::error::Error for SpecError {}

/// Where the bytes go.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Target {
    /// The virtual robot alone.
    Sim,
    /// A UART carrying a DIN MIDI line.
    Serial(PathBuf),
    /// A raw MIDI device (or any file or FIFO), written byte for byte.
    RawMidi(PathBuf),
    /// A UDP destination, `HOST:PORT`.
    Udp(String),
    /// An RTP-MIDI peer's control port, `HOST:PORT`.
    RtpMidi(String),
    /// An I2C bus with finger boards on it.
    I2c(PathBuf),
    /// An ALSA sequencer port, `CLIENT:PORT` (numbers or the client's name).
    #[cfg(feature = "alsa")]
    Alsa(String),
}

/// MIDI channels, 0-based bits (bit 0 is channel 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Channels(u16);

impl Channels {
    /// Every channel.
    pub const ALL: Channels = Channels(0xFFFF);

    /// Whether 0-based `channel` is in the set.
    pub fn contains(self, channel: u8) -> bool {
        channel < 16 && self.0 & (1 << channel) != 0
    }

    /// The set as a bit mask (bit 0 is channel 1).
    pub fn bits(self) -> u16 {
        self.0
    }

    /// Whether a message (status first) belongs to the set: channel messages by their
    /// channel, everything else always.
    pub fn passes(self, message: &[u8]) -> bool {
        match message.first() {
            Some(&s @ 0x80..=0xEF) => self.contains(s & 0x0F),
            _ => true,
        }
    }

    fn parse(text: &str) -> Result<Channels, String> {
        let mut bits = 0u16;
        for part in text.split(',') {
            let one = |s: &str| -> Result<u8, String> {
                match s.trim().parse::<u8>() {
                    Ok(c @ 1..=16) => Ok(c - 1),
                    _ => Err(format!("channel `{s}` is not 1 to 16")),
                }
            };
            let (lo, hi) = match part.split_once('-') {
                Some((a, b)) => (one(a)?, one(b)?),
                None => {
                    let c = one(part)?;
                    (c, c)
                }
            };
            if lo > hi {
                return Err(format!("channel range `{part}` runs backwards"));
            }
            for c in lo..=hi {
                bits |= 1 << c;
            }
        }
        Ok(Channels(bits))
    }
}

impl fmt::Display for Channels {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let list: Vec<String> = (0..16u8)
            .filter(|&c| self.contains(c))
            .map(|c| (c + 1).to_string())
            .collect();
        f.write_str(&list.join(","))
    }
}

/// One `--out`: a target and the channels it takes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutSpec {
    /// Where.
    pub target: Target,
    /// Which channels' messages go there.
    pub channels: Channels,
    /// The specification as given, to name it in reports.
    pub text: String,
}

impl OutSpec {
    /// Reads one specification (see the [module notes](self)).
    pub fn parse(spec: &str) -> Result<OutSpec, SpecError> {
        let err = |reason: String| SpecError {
            spec: spec.to_string(),
            reason,
        };
        let (rest, channels) = match spec.rsplit_once(":ch=") {
            Some((rest, list)) => (rest, Channels::parse(list).map_err(err)?),
            None => match spec.strip_prefix("sim") {
                Some(list) if list.starts_with("ch=") => {
                    ("sim", { Channels::parse(&list[3..]).map_err(err)? })
                }
                _ => (spec, Channels::ALL),
            },
        };
        let (kind, target) = match rest.split_once(':') {
            Some((k, t)) => (k, Some(t)),
            None => (rest, None),
        };
        let need = |what: &str| -> Result<&str, SpecError> {
            match target {
                Some(t) if !t.is_empty() => Ok(t),
                _ => Err(err(format!("{kind} needs {what} after `{kind}:`"))),
            }
        };
        let target = match kind {
            "sim" => match target {
                None => Target::Sim,
                Some(_) => return Err(err("sim takes no target".into())),
            },
            "serial" => Target::Serial(need("a device")?.into()),
            "rawmidi" => Target::RawMidi(need("a device")?.into()),
            "i2c" => Target::I2c(need("a device")?.into()),
            "udp" | "rtpmidi" => {
                let t = need("HOST:PORT")?;
                match t.rsplit_once(':').map(|(h, p)| (h, p.parse::<u16>())) {
                    Some((host, Ok(port))) if !host.is_empty() => {
                        if kind == "udp" {
                            Target::Udp(t.to_string())
                        } else if port == u16::MAX {
                            return Err(err("the data port is PORT + 1: give a port below \
                                 65535"
                                .into()));
                        } else {
                            Target::RtpMidi(t.to_string())
                        }
                    }
                    _ => return Err(err(format!("`{t}` is not HOST:PORT"))),
                }
            }
            #[cfg(feature = "alsa")]
            "alsa" => Target::Alsa(need("CLIENT:PORT")?.to_string()),
            #[cfg(not(feature = "alsa"))]
            "alsa" => {
                return Err(err(
                    "ALSA sequencer ports need orch built with the `alsa` feature; \
                     rawmidi:/dev/snd/midiCxDy reaches the same hardware without it"
                        .into(),
                ))
            }
            other => return Err(err(format!("unknown output kind `{other}`"))),
        };
        Ok(OutSpec {
            target,
            channels,
            text: spec.to_string(),
        })
    }

    /// Whether the robot at the far end interprets MIDI itself over a DIN line (its timing
    /// counts 320 µs a byte).
    pub fn is_din(&self) -> bool {
        matches!(self.target, Target::Serial(_))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_and_channel_filters() {
        let s = OutSpec::parse("serial:/dev/ttyUSB0:ch=1").unwrap();
        assert_eq!(s.target, Target::Serial("/dev/ttyUSB0".into()));
        assert_eq!(s.channels.bits(), 1);
        let u = OutSpec::parse("udp:127.0.0.1:9000:ch=2,4-5").unwrap();
        assert_eq!(u.target, Target::Udp("127.0.0.1:9000".into()));
        assert_eq!(u.channels.to_string(), "2,4,5");
        assert!(u.channels.passes(&[0x91, 60, 1]));
        assert!(!u.channels.passes(&[0x90, 60, 1]));
        assert!(u.channels.passes(&[0xFE]));
        assert_eq!(OutSpec::parse("sim").unwrap().target, Target::Sim);
        assert_eq!(OutSpec::parse("sim:ch=3").unwrap().channels.bits(), 4);
        assert_eq!(
            OutSpec::parse("rawmidi:/dev/snd/midiC1D0").unwrap().target,
            Target::RawMidi("/dev/snd/midiC1D0".into())
        );
        assert_eq!(
            OutSpec::parse("i2c:/dev/i2c-1").unwrap().target,
            Target::I2c("/dev/i2c-1".into())
        );
        assert_eq!(
            OutSpec::parse("udp:[::1]:9000").unwrap().channels,
            Channels::ALL
        );
        assert_eq!(
            OutSpec::parse("rtpmidi:192.168.1.5:5004:ch=1")
                .unwrap()
                .target,
            Target::RtpMidi("192.168.1.5:5004".into())
        );
    }

    #[test]
    fn bad_specs_say_why() {
        for (bad, why) in [
            ("serial", "needs a device"),
            ("serial:", "needs a device"),
            ("udp:localhost", "not HOST:PORT"),
            ("udp:localhost:99999", "not HOST:PORT"),
            ("rtpmidi:localhost", "not HOST:PORT"),
            ("rtpmidi:localhost:65535", "below 65535"),
            ("tcp:x", "unknown output kind"),
            ("serial:/dev/x:ch=0", "not 1 to 16"),
            ("serial:/dev/x:ch=17", "not 1 to 16"),
            ("serial:/dev/x:ch=4-2", "backwards"),
            ("sim:foo", "no target"),
            #[cfg(not(feature = "alsa"))]
            ("alsa:128:0", "the `alsa` feature"),
            #[cfg(feature = "alsa")]
            ("alsa", "needs CLIENT:PORT"),
        ] {
            let e = OutSpec::parse(bad).unwrap_err().to_string();
            assert!(e.contains(why), "{bad}: {e}");
        }
    }
}
