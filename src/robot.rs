//! `robot.toml`: the robot's configuration, read into the core's plain [`Config`].

use std::path::Path;

use anyhow::Context;
use orch_core::{
    BoardSpan, Channel, ChannelMask, Config, Duration, GuardConfig, Interpreter, KeyRange, Layout,
    Note, OutOfRange,
};
use orch_sim::{BusClock, KeyMechanics, MechanicsConfig, SimConfig};
use serde::Deserialize;

use crate::error::bad_input;

/// The most boards a host configuration may have.
pub const MAX_BOARDS: usize = 16;
/// The most keys a host configuration may have: one per MIDI note.
pub const MAX_KEYS: usize = 128;

/// The interpreter as the host runs it: room for any configuration.
pub type HostInterpreter = Interpreter<MAX_BOARDS, MAX_KEYS>;

/// A robot: the interpreter's configuration, how many of the boards are real, the bus clock
/// and the keys' mechanics.
#[derive(Clone, Debug)]
pub struct Robot {
    pub config: Config<MAX_BOARDS>,
    pub boards: usize,
    pub clock: BusClock,
    pub mechanics: MechanicsConfig,
}

impl Robot {
    /// The thesis's robot.
    pub fn thesis() -> Self {
        Self::from_toml(DEFAULT_TOML).expect("the default configuration is valid")
    }

    /// Reads a configuration file.
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| bad_input(format!("cannot read {}: {e}", path.display())))?;
        Self::from_toml(&text).with_context(|| format!("in robot configuration {}", path.display()))
    }

    /// Parses and checks a configuration.
    pub fn from_toml(text: &str) -> anyhow::Result<Self> {
        let file: File = toml::from_str(text).map_err(|e| bad_input(e.to_string()))?;
        file.into_robot()
    }

    /// The virtual robot's configuration.
    pub fn sim_config(&self) -> SimConfig {
        SimConfig {
            clock: self.clock,
            boards: self.config.layout.boards[..self.boards].to_vec(),
            mechanics: self.mechanics.clone(),
            keep: orch_sim::Keep::Everything,
        }
    }

    /// The time one board write takes on the bus: START, 4 bytes of 9 bits, STOP.
    pub fn write_micros(&self) -> f64 {
        self.clock.nanos_for_bits(38) as f64 / 1000.0
    }

    /// An interpreter for this robot.
    pub fn interpreter(&self) -> anyhow::Result<HostInterpreter> {
        HostInterpreter::new(self.config).map_err(|e| bad_input(e.to_string()))
    }
}

/// Prints the default configuration, commented.
pub fn print_default() -> anyhow::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    out.write_all(DEFAULT_TOML.as_bytes())?;
    Ok(())
}

/// The default configuration: the thesis's robot with orch's safety guard.
pub const DEFAULT_TOML: &str = r#"# orch robot configuration (robot.toml)
# Every field is optional; a missing one takes the value shown here.

[keys]
# The notes the robot has keys for, as MIDI note numbers (60 is middle C).
low = 36                  # C2
high = 96                 # C7: 61 keys
# Notes outside low..=high: "fold" moves them by octaves into range; "drop" skips them.
out_of_range = "fold"
# Channels listened to, as people count them (1..=16), or "all".
channels = "all"
# Let the sustain pedal (CC 64) hold released keys down. Off by default: a held solenoid heats up.
sustain = false
# A second note on a key that is down (the same note on another channel, a note folded onto
# it, or the same note again): "restrike" lifts the key, rests and strikes again (the
# sequencer releases early so it lands on time); "hold" keeps it down for both, and the new
# note makes no sound of its own. Restrike by default: the ear follows onsets.
overlap = "restrike"

# The finger boards (PCA9555 or TCA9555), in key order: each drives `keys` consecutive keys
# from output bit `first_bit` (bits 0-7 are port 0, 8-15 port 1).
[[boards]]
address = 0x21
keys = 16
first_bit = 0

[[boards]]
address = 0x22
keys = 16
first_bit = 0

[[boards]]
address = 0x23
keys = 16
first_bit = 0

[[boards]]
address = 0x24
keys = 13
first_bit = 0

# The I2C bus to the boards: "83.33kHz" (the thesis's board), "100kHz" or "400kHz".
# The PCA9555 and TCA9555 are rated for 400 kHz: a board write then takes 95 us, not 456 us.
[bus]
clock = "400kHz"

# How the keys move, for the virtual robot and for latency compensation. press_delay: from
# the solenoid's power to the key sounding; release_delay: from power off until the key is
# fully up; min_hold: the shortest pulse that sounds. Keys that differ are listed by note.
[mechanics]
press_delay = "15ms"
release_delay = "25ms"
min_hold = "8ms"
# [[mechanics.key]]
# note = 36
# press_delay = "20ms"

# The safety guard. Durations are written like "10s", "60ms" or "2min"; "off" means no limit.
[guard]
enabled = true
max_hold = "10s"          # the longest a key may stay down
max_keys_down = 16        # the power budget: a new note past it is refused
restrike_gap = "60ms"     # the shortest rest before a key strikes again
min_press = "20ms"        # how long a delayed re-strike is held if its note ended while it waited
watchdog = "4s"           # release every key after this long without a byte
late_limit = "30ms"       # a re-strike that would sound later than this is dropped (too fast)
duty_window = "60s"       # the duty limit: a key may be energised at most duty_max_on
duty_max_on = "30s"       #   in any duty_window ("off": no duty limit)
"#;

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct File {
    #[serde(default)]
    keys: Keys,
    boards: Option<Vec<Board>>,
    #[serde(default)]
    bus: Bus,
    #[serde(default)]
    mechanics: Mechanics,
    #[serde(default)]
    guard: Guard,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, default)]
struct Bus {
    clock: String,
}

impl Default for Bus {
    fn default() -> Self {
        Self {
            clock: "400kHz".into(),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, default)]
struct Mechanics {
    press_delay: String,
    release_delay: String,
    min_hold: String,
    key: Vec<KeyFigures>,
}

impl Default for Mechanics {
    fn default() -> Self {
        Self {
            press_delay: "15ms".into(),
            release_delay: "25ms".into(),
            min_hold: "8ms".into(),
            key: Vec::new(),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct KeyFigures {
    note: u8,
    press_delay: Option<String>,
    release_delay: Option<String>,
    min_hold: Option<String>,
}

/// Parses a bus clock: "83.33kHz", "100kHz", "400kHz" (or any "N kHz" / "N Hz" up to 1 MHz).
fn clock(text: &str) -> anyhow::Result<BusClock> {
    let t = text.trim().to_ascii_lowercase().replace(' ', "");
    let hz = if t == "83.33khz" || t == "83.333khz" {
        return Ok(BusClock::THESIS);
    } else if let Some(k) = t.strip_suffix("khz") {
        k.parse::<f64>().ok().map(|k| k * 1e3)
    } else if let Some(h) = t.strip_suffix("hz") {
        h.parse::<f64>().ok()
    } else {
        None
    };
    match hz {
        Some(hz) if (1_000.0..=1_000_000.0).contains(&hz) => {
            Ok(BusClock::from_hz(hz.round() as u32))
        }
        _ => Err(bad_input(format!(
            "bus.clock = {text:?}: write \"83.33kHz\", \"100kHz\" or \"400kHz\" (1 kHz to 1 MHz)"
        ))),
    }
}

/// A duration that must be given (not "off").
fn delay(field: &str, text: &str) -> anyhow::Result<Duration> {
    duration(field, text)?.ok_or_else(|| {
        bad_input(format!(
            "{field} = \"off\": give a duration such as \"15ms\""
        ))
    })
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, default)]
struct Keys {
    low: u8,
    high: u8,
    out_of_range: Policy,
    channels: Channels,
    sustain: bool,
    overlap: OverlapWord,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum OverlapWord {
    Hold,
    Restrike,
}

impl Default for Keys {
    fn default() -> Self {
        Self {
            low: 36,
            high: 96,
            out_of_range: Policy::Fold,
            channels: Channels::All(AllWord::All),
            sustain: false,
            overlap: OverlapWord::Restrike,
        }
    }
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum Policy {
    Fold,
    Drop,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Channels {
    All(AllWord),
    List(Vec<u8>),
}

#[derive(Deserialize)]
#[serde(rename_all = "lowercase")]
enum AllWord {
    All,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Board {
    address: u8,
    keys: u8,
    #[serde(default)]
    first_bit: u8,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, default)]
struct Guard {
    enabled: bool,
    max_hold: String,
    max_keys_down: u8,
    restrike_gap: String,
    min_press: String,
    watchdog: String,
    late_limit: String,
    duty_window: String,
    duty_max_on: String,
}

impl Default for Guard {
    fn default() -> Self {
        Self {
            enabled: true,
            max_hold: "10s".into(),
            max_keys_down: 16,
            restrike_gap: "60ms".into(),
            min_press: "20ms".into(),
            watchdog: "4s".into(),
            late_limit: "30ms".into(),
            duty_window: "60s".into(),
            duty_max_on: "30s".into(),
        }
    }
}

/// Parses "10s", "60ms", "2min", "1500us" or "off".
fn duration(field: &str, text: &str) -> anyhow::Result<Option<Duration>> {
    let t = text.trim();
    if t == "off" {
        return Ok(None);
    }
    let split = t
        .find(|c: char| !c.is_ascii_digit() && c != '.')
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let scale = match unit.trim() {
        "us" | "µs" => 1.0,
        "ms" => 1e3,
        "s" => 1e6,
        "min" => 60e6,
        _ => {
            return Err(bad_input(format!(
            "{field} = {text:?}: write a duration like \"60ms\", \"10s\" or \"2min\", or \"off\""
        )))
        }
    };
    let value: f64 = number
        .parse()
        .map_err(|_| bad_input(format!("{field} = {text:?}: {number:?} is not a number")))?;
    let micros = value * scale;
    if !(0.0..=orch_core::MAX_LIMIT.as_micros() as f64).contains(&micros) {
        return Err(bad_input(format!(
            "{field} = {text:?}: must be between 0 and 30min"
        )));
    }
    Ok(Some(Duration::from_micros(micros.round() as u32)))
}

impl File {
    fn into_robot(self) -> anyhow::Result<Robot> {
        let k = &self.keys;
        let low = Note::new(k.low)
            .ok_or_else(|| bad_input(format!("keys.low = {}: a MIDI note is 0..=127", k.low)))?;
        let high = Note::new(k.high)
            .ok_or_else(|| bad_input(format!("keys.high = {}: a MIDI note is 0..=127", k.high)))?;
        let range = KeyRange::new(low, high).ok_or_else(|| {
            bad_input(format!(
                "keys.low = {} is above keys.high = {}",
                k.low, k.high
            ))
        })?;
        let channels = match &k.channels {
            Channels::All(_) => ChannelMask::ALL,
            Channels::List(list) => {
                let mut mask = ChannelMask::NONE;
                for &c in list {
                    let ch = c.checked_sub(1).and_then(Channel::new).ok_or_else(|| {
                        bad_input(format!(
                            "keys.channels: {c} is not a channel; channels are 1..=16"
                        ))
                    })?;
                    mask = mask.with(ch);
                }
                mask
            }
        };
        let boards = self.boards.unwrap_or_else(|| {
            [(0x21, 16), (0x22, 16), (0x23, 16), (0x24, 13)]
                .into_iter()
                .map(|(address, keys)| Board {
                    address,
                    keys,
                    first_bit: 0,
                })
                .collect()
        });
        if boards.is_empty() || boards.len() > MAX_BOARDS {
            return Err(bad_input(format!(
                "boards: {} boards; orch drives 1 to {MAX_BOARDS}",
                boards.len()
            )));
        }
        let mut spans = [BoardSpan {
            address: 0,
            keys: 0,
            first_bit: 0,
        }; MAX_BOARDS];
        for (i, b) in boards.iter().enumerate() {
            if !(0x08..=0x77).contains(&b.address) {
                return Err(bad_input(format!(
                    "boards[{i}].address = {:#04x}: not a 7-bit I2C device address (0x08..=0x77)",
                    b.address
                )));
            }
            if boards[..i].iter().any(|o| o.address == b.address) {
                return Err(bad_input(format!(
                    "boards[{i}].address = {:#04x} is used twice",
                    b.address
                )));
            }
            if b.first_bit as usize + b.keys as usize > 16 {
                return Err(bad_input(format!(
                    "boards[{i}]: first_bit {} + keys {} runs past output bit 15",
                    b.first_bit, b.keys
                )));
            }
            spans[i] = BoardSpan {
                address: b.address,
                keys: b.keys,
                first_bit: b.first_bit,
            };
        }
        let layout = Layout { boards: spans };
        if layout.keys() != range.keys() {
            return Err(bad_input(format!(
                "boards drive {} keys in all, but keys.low..=keys.high has {}",
                layout.keys(),
                range.keys()
            )));
        }
        let g = &self.guard;
        if g.max_keys_down == 0 {
            return Err(bad_input("guard.max_keys_down = 0: no key could ever play"));
        }
        let guard = GuardConfig {
            enabled: g.enabled,
            max_hold: duration("guard.max_hold", &g.max_hold)?,
            max_keys_down: g.max_keys_down,
            restrike_gap: duration("guard.restrike_gap", &g.restrike_gap)?
                .unwrap_or(Duration::ZERO),
            min_press: duration("guard.min_press", &g.min_press)?.unwrap_or(Duration::ZERO),
            watchdog: duration("guard.watchdog", &g.watchdog)?,
            late_limit: duration("guard.late_limit", &g.late_limit)?,
            duty: match (
                duration("guard.duty_window", &g.duty_window)?,
                duration("guard.duty_max_on", &g.duty_max_on)?,
            ) {
                (Some(window), Some(max_on)) => {
                    if max_on == Duration::ZERO
                        || max_on > window
                        || max_on > orch_core::DutyLimit::MAX_ON
                    {
                        return Err(bad_input(format!(
                            "guard.duty_max_on = {:?}: must be above 0, at most guard.duty_window ({:?}) and at most 60s",
                            g.duty_max_on, g.duty_window
                        )));
                    }
                    Some(orch_core::DutyLimit { window, max_on })
                }
                _ => None,
            },
        };
        let config = Config {
            channels,
            range,
            out_of_range: match k.out_of_range {
                Policy::Fold => OutOfRange::Fold,
                Policy::Drop => OutOfRange::Drop,
            },
            layout,
            sustain: k.sustain,
            overlap: match k.overlap {
                OverlapWord::Hold => orch_core::Overlap::Hold,
                OverlapWord::Restrike => orch_core::Overlap::Restrike,
            },
            guard,
        };
        config
            .validate(MAX_KEYS)
            .map_err(|e| bad_input(e.to_string()))?;
        let m = &self.mechanics;
        let default = KeyMechanics {
            press_delay: delay("mechanics.press_delay", &m.press_delay)?,
            release_delay: delay("mechanics.release_delay", &m.release_delay)?,
            min_hold: delay("mechanics.min_hold", &m.min_hold)?,
        };
        let mut mechanics = MechanicsConfig::uniform(default);
        for (i, k) in m.key.iter().enumerate() {
            let field = |name: &str| format!("mechanics.key[{i}].{name}");
            if !(low.get()..=high.get()).contains(&k.note) {
                return Err(bad_input(format!(
                    "{} = {}: the robot has keys for notes {}..={} only",
                    field("note"),
                    k.note,
                    low,
                    high
                )));
            }
            let mut figures = default;
            if let Some(t) = &k.press_delay {
                figures.press_delay = delay(&field("press_delay"), t)?;
            }
            if let Some(t) = &k.release_delay {
                figures.release_delay = delay(&field("release_delay"), t)?;
            }
            if let Some(t) = &k.min_hold {
                figures.min_hold = delay(&field("min_hold"), t)?;
            }
            mechanics = mechanics.with_key(k.note - low.get(), figures);
        }
        Ok(Robot {
            config,
            boards: boards.len(),
            clock: clock(&self.bus.clock)?,
            mechanics,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_toml_is_the_thesis_robot() {
        let r = Robot::thesis();
        let t = Config::THESIS;
        assert_eq!(r.boards, 4);
        assert_eq!(r.config.range, t.range);
        assert_eq!(r.config.guard, t.guard);
        assert_eq!(r.config.overlap, t.overlap);
        assert_eq!(r.config.channels, t.channels);
        assert_eq!(&r.config.layout.boards[..4], &t.layout.boards[..]);
        assert_eq!(Robot::from_toml("").unwrap().config, r.config);
        assert_eq!(r.clock, BusClock::FAST);
        assert_eq!(r.mechanics, MechanicsConfig::default());
    }

    #[test]
    fn bad_fields_are_named() {
        let e = format!(
            "{:#}",
            Robot::from_toml("[guard]\nmax_hold = \"ten\"").unwrap_err()
        );
        assert!(e.contains("guard.max_hold"), "{e}");
        let e = format!("{:#}", Robot::from_toml("[keys]\nlow = 200").unwrap_err());
        assert!(e.contains("keys.low"), "{e}");
        let e = format!(
            "{:#}",
            Robot::from_toml("[guard]\nmax_hld = \"1s\"").unwrap_err()
        );
        assert!(e.contains("max_hld"), "{e}");
        let e = format!(
            "{:#}",
            Robot::from_toml("[[boards]]\naddress = 0x21\nkeys = 16").unwrap_err()
        );
        assert!(e.contains("boards drive 16 keys"), "{e}");
    }

    #[test]
    fn bus_clock_and_per_key_mechanics_are_read() {
        let r = Robot::from_toml(
            "[bus]\nclock = \"83.33kHz\"\n[mechanics]\npress_delay = \"10ms\"\n[[mechanics.key]]\nnote = 60\nrelease_delay = \"40ms\"\n",
        )
        .unwrap();
        assert_eq!(r.clock, BusClock::THESIS);
        assert_eq!(
            r.mechanics.for_key(0).press_delay,
            Duration::from_millis(10)
        );
        assert_eq!(
            r.mechanics.for_key(24).release_delay,
            Duration::from_millis(40)
        );
        assert_eq!(
            r.mechanics.for_key(24).press_delay,
            Duration::from_millis(10)
        );
        let e = format!(
            "{:#}",
            Robot::from_toml("[[mechanics.key]]\nnote = 20").unwrap_err()
        );
        assert!(e.contains("mechanics.key[0].note"), "{e}");
        let e = format!(
            "{:#}",
            Robot::from_toml("[bus]\nclock = \"fast\"").unwrap_err()
        );
        assert!(e.contains("bus.clock"), "{e}");
    }

    #[test]
    fn durations_parse_in_units_and_off() {
        assert_eq!(
            duration("f", "60ms").unwrap(),
            Some(Duration::from_millis(60))
        );
        assert_eq!(
            duration("f", "1.5s").unwrap(),
            Some(Duration::from_millis(1500))
        );
        assert_eq!(duration("f", "off").unwrap(), None);
        assert!(duration("f", "31min").is_err());
    }
}
