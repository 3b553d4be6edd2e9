//! The file's shape (serde) and how it becomes a [`Robot`].

use orch_core::{
    BoardSpan, Channel, ChannelMask, Config, ConfigError, Duration, GuardConfig, KeyRange, Layout,
    Note, OutOfRange,
};
use orch_sim::{BusClock, KeyMechanics, MechanicsConfig};
use serde::Deserialize;

use crate::{Robot, RobotError, MAX_BOARDS, MAX_KEYS};

/// Parses and checks a configuration.
pub(crate) fn parse(text: &str) -> Result<Robot, RobotError> {
    let file: File = toml::from_str(text).map_err(|e| RobotError::Syntax(e.to_string()))?;
    file.into_robot()
}

/// The field at fault when the core refuses a configuration.
pub(crate) fn config_error(e: ConfigError) -> RobotError {
    let field = match e {
        ConfigError::LayoutKeys { .. } => "boards".to_string(),
        ConfigError::BoardBits { board } => format!("boards[{board}]"),
        ConfigError::TooManyKeys { .. } => "keys".to_string(),
        ConfigError::LimitTooLong => "guard".to_string(),
        ConfigError::NoKeysAllowed => "guard.max_keys_down".to_string(),
    };
    RobotError::field(field, e.to_string())
}

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
fn clock(text: &str) -> Result<BusClock, RobotError> {
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
        _ => Err(RobotError::field(
            "bus.clock",
            format!("{text:?}: write \"83.33kHz\", \"100kHz\" or \"400kHz\" (1 kHz to 1 MHz)"),
        )),
    }
}

/// A duration that must be given (not "off").
fn delay(field: &str, text: &str) -> Result<Duration, RobotError> {
    duration(field, text)?
        .ok_or_else(|| RobotError::field(field, "\"off\": give a duration such as \"15ms\""))
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, default)]
struct Keys {
    low: u8,
    high: u8,
    out_of_range: Policy,
    channels: Channels,
    sustain: bool,
}

impl Default for Keys {
    fn default() -> Self {
        Self {
            low: 36,
            high: 96,
            out_of_range: Policy::Fold,
            channels: Channels::All(AllWord::All),
            sustain: false,
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
        }
    }
}

/// Parses "10s", "60ms", "2min", "1500us" or "off".
fn duration(field: &str, text: &str) -> Result<Option<Duration>, RobotError> {
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
            return Err(RobotError::field(
                field,
                format!(
                    "{text:?}: write a duration like \"60ms\", \"10s\" or \"2min\", or \"off\""
                ),
            ))
        }
    };
    let value: f64 = number
        .parse()
        .map_err(|_| RobotError::field(field, format!("{text:?}: {number:?} is not a number")))?;
    let micros = value * scale;
    if !(0.0..=orch_core::MAX_LIMIT.as_micros() as f64).contains(&micros) {
        return Err(RobotError::field(
            field,
            format!("{text:?}: must be between 0 and 30min"),
        ));
    }
    Ok(Some(Duration::from_micros(micros.round() as u32)))
}

impl File {
    fn into_robot(self) -> Result<Robot, RobotError> {
        let k = &self.keys;
        let low = Note::new(k.low).ok_or_else(|| {
            RobotError::field("keys.low", format!("{}: a MIDI note is 0..=127", k.low))
        })?;
        let high = Note::new(k.high).ok_or_else(|| {
            RobotError::field("keys.high", format!("{}: a MIDI note is 0..=127", k.high))
        })?;
        let range = KeyRange::new(low, high).ok_or_else(|| {
            RobotError::field(
                "keys.low",
                format!("{} is above keys.high = {}", k.low, k.high),
            )
        })?;
        let channels = match &k.channels {
            Channels::All(_) => ChannelMask::ALL,
            Channels::List(list) => {
                let mut mask = ChannelMask::NONE;
                for &c in list {
                    let ch = c.checked_sub(1).and_then(Channel::new).ok_or_else(|| {
                        RobotError::field(
                            "keys.channels",
                            format!("{c} is not a channel; channels are 1..=16"),
                        )
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
            return Err(RobotError::field(
                "boards",
                format!("{} boards; orch drives 1 to {MAX_BOARDS}", boards.len()),
            ));
        }
        let mut spans = [BoardSpan {
            address: 0,
            keys: 0,
            first_bit: 0,
        }; MAX_BOARDS];
        for (i, b) in boards.iter().enumerate() {
            if !(0x08..=0x77).contains(&b.address) {
                return Err(RobotError::field(
                    format!("boards[{i}].address"),
                    format!(
                        "{:#04x} is not a 7-bit I2C device address (0x08..=0x77)",
                        b.address
                    ),
                ));
            }
            if boards[..i].iter().any(|o| o.address == b.address) {
                return Err(RobotError::field(
                    format!("boards[{i}].address"),
                    format!("{:#04x} is used twice", b.address),
                ));
            }
            if b.first_bit as usize + b.keys as usize > 16 {
                return Err(RobotError::field(
                    format!("boards[{i}]"),
                    format!(
                        "first_bit {} + keys {} runs past output bit 15",
                        b.first_bit, b.keys
                    ),
                ));
            }
            spans[i] = BoardSpan {
                address: b.address,
                keys: b.keys,
                first_bit: b.first_bit,
            };
        }
        let layout = Layout { boards: spans };
        if layout.keys() != range.keys() {
            return Err(RobotError::field(
                "boards",
                format!(
                    "the boards drive {} keys in all, but keys.low..=keys.high has {}",
                    layout.keys(),
                    range.keys()
                ),
            ));
        }
        let g = &self.guard;
        if g.max_keys_down == 0 {
            return Err(RobotError::field(
                "guard.max_keys_down",
                "0: no key could ever play",
            ));
        }
        let guard = GuardConfig {
            enabled: g.enabled,
            max_hold: duration("guard.max_hold", &g.max_hold)?,
            max_keys_down: g.max_keys_down,
            restrike_gap: duration("guard.restrike_gap", &g.restrike_gap)?
                .unwrap_or(Duration::ZERO),
            min_press: duration("guard.min_press", &g.min_press)?.unwrap_or(Duration::ZERO),
            watchdog: duration("guard.watchdog", &g.watchdog)?,
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
            guard,
        };
        config.validate(MAX_KEYS).map_err(config_error)?;
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
                return Err(RobotError::field(
                    field("note"),
                    format!(
                        "{}: the robot has keys for notes {}..={} only",
                        k.note, low, high
                    ),
                ));
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
        assert_eq!(r.config.channels, t.channels);
        assert_eq!(&r.config.layout.boards[..4], &t.layout.boards[..]);
        assert_eq!(Robot::from_toml("").unwrap().config, r.config);
        assert_eq!(r.clock, BusClock::FAST);
        assert_eq!(r.mechanics, MechanicsConfig::default());
    }

    #[test]
    fn bad_fields_are_named() {
        let e = Robot::from_toml("[guard]\nmax_hold = \"ten\"").unwrap_err();
        assert_eq!(e.field_name(), Some("guard.max_hold"));
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
