//! The file's shape (serde) and how it becomes a [`Robot`].

use orch_core::{
    BoardSpan, Channel, ChannelMask, Config, ConfigError, Duration, GuardConfig, KeyRange, Layout,
    Note, OutOfRange,
};
use orch_sim::{BusClock, KeyMechanics, MechanicsConfig};
use serde::Deserialize;

use crate::{BoardKind, Robot, RobotError, MAX_BOARDS, MAX_KEYS};

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
        ConfigError::BadDuty | ConfigError::DutyUnsupported => "guard.duty_max_on".to_string(),
        ConfigError::Dynamics(d) => dynamics_field(d),
        ConfigError::Strike(_) => "strike".to_string(),
        ConfigError::Wind(_) => "fingered".to_string(),
    };
    RobotError::field(field, e.to_string())
}

/// The field at fault when the core refuses the dynamics (the loader checks them first and
/// names the `[[dynamics.key]]` entry; this is for a configuration changed after loading).
fn dynamics_field(e: orch_core::DynamicsError) -> String {
    use orch_core::DynamicsError as D;
    match e {
        D::CurveFalls { .. } => "dynamics.loudest",
        D::HoldAboveStrike { .. } => "dynamics.hold",
        D::SilentSoftest { .. } => "dynamics.softest",
        D::StrikeLongerThanHold => "dynamics.strike",
    }
    .to_string()
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
    #[serde(default)]
    pwm: Pwm,
    #[serde(default)]
    dynamics: DynamicsFile,
    #[serde(default)]
    strike: Vec<crate::strike::StrikeFile>,
    #[serde(default)]
    fingered: Vec<crate::fingered::FingeredFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, default)]
struct Pwm {
    frequency: String,
}

impl Default for Pwm {
    fn default() -> Self {
        Self {
            frequency: format!("{}Hz", crate::DEFAULT_PWM_HZ),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, default)]
struct DynamicsFile {
    strike: String,
    softest: String,
    loudest: String,
    hold: String,
    key: Vec<KeyTouch>,
}

impl Default for DynamicsFile {
    fn default() -> Self {
        Self {
            strike: "40ms".into(),
            softest: "45%".into(),
            loudest: "100%".into(),
            hold: "35%".into(),
            key: Vec::new(),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct KeyTouch {
    note: i64,
    softest: Option<String>,
    loudest: Option<String>,
    hold: Option<String>,
}

// Integers are read as TOML's own i64 and checked here, so that a value out of range is
// refused naming the field and the range, not with serde's "expected u8".

#[derive(Deserialize)]
#[serde(deny_unknown_fields, default)]
struct Keys {
    enabled: bool,
    low: i64,
    high: i64,
    out_of_range: Policy,
    // "all" or a list of 1..=16: read as any TOML value and checked here, so that a wrong
    // one gets a message saying what to write.
    channels: toml::Value,
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
            enabled: true,
            low: 36,
            high: 96,
            out_of_range: Policy::Fold,
            channels: toml::Value::String("melodic".into()),
            sustain: false,
            overlap: OverlapWord::Restrike,
        }
    }
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
pub(crate) enum Policy {
    Fold,
    Drop,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Board {
    #[serde(default)]
    kind: KindWord,
    address: i64,
    keys: i64,
    #[serde(default)]
    first_bit: i64,
}

#[derive(Deserialize, Clone, Copy, Default, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum KindWord {
    #[default]
    Pca9555,
    Tca9555,
    Pca9685,
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
    softest: String,
    soft_press_delay: String,
    key: Vec<KeyFigures>,
}

impl Default for Mechanics {
    fn default() -> Self {
        Self {
            press_delay: "15ms".into(),
            release_delay: "25ms".into(),
            min_hold: "8ms".into(),
            softest: "45%".into(),
            soft_press_delay: "30ms".into(),
            key: Vec::new(),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct KeyFigures {
    note: i64,
    press_delay: Option<String>,
    release_delay: Option<String>,
    min_hold: Option<String>,
    softest: Option<String>,
    soft_press_delay: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, default)]
struct Guard {
    enabled: bool,
    max_hold: String,
    max_keys_down: i64,
    restrike_gap: String,
    min_press: String,
    watchdog: String,
    late_limit: String,
    duty_window: String,
    duty_max_on: String,
    max_pulse: String,
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
            max_pulse: "100ms".into(),
        }
    }
}

/// An integer field that must lie in `lo..=hi`; `what` says what the number is.
pub(crate) fn int(field: &str, value: i64, lo: u8, hi: u8, what: &str) -> Result<u8, RobotError> {
    if (i64::from(lo)..=i64::from(hi)).contains(&value) {
        Ok(value as u8)
    } else {
        Err(RobotError::field(
            field,
            format!("{value} is out of range: {what} is {lo}..={hi}"),
        ))
    }
}

/// What a `channels` field accepts.
const CHANNELS_HELP: &str = "write \"all\", \"melodic\" (every channel but 10, General MIDI's \
     drums) or a list of channels as people count them, 1..=16, such as [1, 2, 10]";

/// Every channel but 10 (General MIDI's percussion).
pub const MELODIC: ChannelMask = ChannelMask(!(1 << 9));

/// Reads a `channels` field (`FIELD`): `"all"`, `"melodic"` or a non-empty list of channels
/// 1..=16.
pub(crate) fn channels(value: &toml::Value, field: &str) -> Result<ChannelMask, RobotError> {
    let field = |suffix: &str| format!("{field}{suffix}");
    match value {
        toml::Value::String(s) if s == "all" => Ok(ChannelMask::ALL),
        toml::Value::String(s) if s == "melodic" => Ok(MELODIC),
        toml::Value::Array(list) if list.is_empty() => Err(RobotError::field(
            field(""),
            format!("[] listens to no channel at all; {CHANNELS_HELP}"),
        )),
        toml::Value::Array(list) => {
            let mut mask = ChannelMask::NONE;
            for (i, item) in list.iter().enumerate() {
                let ch = item
                    .as_integer()
                    .filter(|c| (1..=16).contains(c))
                    .and_then(|c| Channel::new(c as u8 - 1))
                    .ok_or_else(|| {
                        RobotError::field(
                            field(&format!("[{i}]")),
                            format!("{item} is not a channel; {CHANNELS_HELP}"),
                        )
                    })?;
                mask = mask.with(ch);
            }
            Ok(mask)
        }
        other => Err(RobotError::field(
            field(""),
            format!("{other} is not a channel list; {CHANNELS_HELP}"),
        )),
    }
}

/// What `bus.clock` accepts.
const CLOCK_HELP: &str = "write \"83.33kHz\" (the thesis's board), \"100kHz\", \"400kHz\" or \
     \"1MHz\", or any clock from 1 kHz to 1 MHz in Hz, kHz or MHz (\"100000Hz\", \"0.4MHz\")";

/// Parses a bus clock: "83.33kHz", "100kHz", "400kHz", "1MHz", or any "N Hz" / "N kHz" /
/// "N MHz" from 1 kHz to 1 MHz.
fn clock(text: &str) -> Result<BusClock, RobotError> {
    let t = text.trim().to_ascii_lowercase().replace(' ', "");
    let hz = if t == "83.33khz" || t == "83.333khz" {
        return Ok(BusClock::THESIS);
    } else if let Some(m) = t.strip_suffix("mhz") {
        m.parse::<f64>().ok().map(|m| m * 1e6)
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
            format!("{text:?}: {CLOCK_HELP}"),
        )),
    }
}

/// A duration that must be given (not "off").
pub(crate) fn delay(field: &str, text: &str) -> Result<Duration, RobotError> {
    duration(field, text)?
        .ok_or_else(|| RobotError::field(field, "\"off\": give a duration such as \"15ms\""))
}

/// A limit that is either "off" or longer than zero: zero would act at once, every time.
fn limit(field: &str, text: &str, zero_means: &str) -> Result<Option<Duration>, RobotError> {
    let d = duration(field, text)?;
    if d == Some(Duration::ZERO) {
        return Err(RobotError::field(
            field,
            format!("{text:?} {zero_means}; give a longer time, or \"off\" for no limit"),
        ));
    }
    Ok(d)
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

/// Reads `[guard]`.
fn guard(g: &Guard) -> Result<GuardConfig, RobotError> {
    if g.max_keys_down == 0 {
        return Err(RobotError::field(
            "guard.max_keys_down",
            "0: no key could ever play; the most keys down at once is 1..=255",
        ));
    }
    let max_keys_down = int(
        "guard.max_keys_down",
        g.max_keys_down,
        1,
        u8::MAX,
        "the most keys down at once",
    )?;
    let max_hold = limit(
        "guard.max_hold",
        &g.max_hold,
        "would release every key the moment it goes down, so no note could sound",
    )?;
    let watchdog = limit(
        "guard.watchdog",
        &g.watchdog,
        "would release every key at once, before the next byte could arrive",
    )?;
    let restrike_gap = duration("guard.restrike_gap", &g.restrike_gap)?.unwrap_or(Duration::ZERO);
    let min_press = duration("guard.min_press", &g.min_press)?.unwrap_or(Duration::ZERO);
    if let Some(hold) = max_hold {
        if min_press > hold {
            return Err(RobotError::field(
                "guard.min_press",
                format!(
                    "{:?} is longer than guard.max_hold = {:?}: a key held for its shortest \
                     strike would be cut by the hold limit; make min_press shorter or max_hold \
                     longer",
                    g.min_press, g.max_hold
                ),
            ));
        }
    }
    let late_limit = duration("guard.late_limit", &g.late_limit)?;
    let duty = match (
        duration("guard.duty_window", &g.duty_window)?,
        duration("guard.duty_max_on", &g.duty_max_on)?,
    ) {
        (Some(window), Some(max_on)) => {
            if max_on == Duration::ZERO || max_on > window || max_on > orch_core::DutyLimit::MAX_ON
            {
                return Err(RobotError::field(
                    "guard.duty_max_on",
                    format!(
                        "{:?}: must be above 0, at most guard.duty_window ({:?}) and at most \
                         60s, or \"off\"",
                        g.duty_max_on, g.duty_window
                    ),
                ));
            }
            Some(orch_core::DutyLimit { window, max_on })
        }
        _ => None,
    };
    let max_pulse = delay("guard.max_pulse", &g.max_pulse)?;
    if max_pulse == Duration::ZERO || max_pulse > orch_core::strike::MAX_PULSE {
        return Err(RobotError::field(
            "guard.max_pulse",
            format!(
                "{:?}: a strike's pulse limit is above 0 and at most 250ms",
                g.max_pulse
            ),
        ));
    }
    Ok(GuardConfig {
        max_pulse,
        enabled: g.enabled,
        max_hold,
        max_keys_down,
        restrike_gap,
        min_press,
        watchdog,
        late_limit,
        duty,
    })
}

/// Reads `[[boards]]`, or the thesis's four boards if there are none.
fn boards(list: Option<&[Board]>) -> Result<(Layout<MAX_BOARDS>, Vec<BoardKind>), RobotError> {
    const THESIS: [Board; 4] = [
        Board {
            kind: KindWord::Pca9555,
            address: 0x21,
            keys: 16,
            first_bit: 0,
        },
        Board {
            kind: KindWord::Pca9555,
            address: 0x22,
            keys: 16,
            first_bit: 0,
        },
        Board {
            kind: KindWord::Pca9555,
            address: 0x23,
            keys: 16,
            first_bit: 0,
        },
        Board {
            kind: KindWord::Pca9555,
            address: 0x24,
            keys: 13,
            first_bit: 0,
        },
    ];
    let boards = list.unwrap_or(&THESIS);
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
        let field = |name: &str| format!("boards[{i}].{name}");
        if !(0x08..=0x77).contains(&b.address) {
            return Err(RobotError::field(
                field("address"),
                format!(
                    "{:#04x} is not a 7-bit I2C device address (0x08..=0x77)",
                    b.address
                ),
            ));
        }
        if let Some(j) = boards[..i].iter().position(|o| o.address == b.address) {
            return Err(RobotError::field(
                field("address"),
                format!("{:#04x} is used twice (also boards[{j}])", b.address),
            ));
        }
        let keys = int(
            &field("keys"),
            b.keys,
            1,
            16,
            "the number of keys on one board",
        )?;
        let first_bit = int(&field("first_bit"), b.first_bit, 0, 15, "an output bit")?;
        if first_bit + keys > 16 {
            return Err(RobotError::field(
                format!("boards[{i}]"),
                format!("first_bit {first_bit} + keys {keys} runs past output bit 15"),
            ));
        }
        spans[i] = BoardSpan {
            address: b.address as u8,
            keys,
            first_bit,
        };
    }
    let kinds = boards
        .iter()
        .map(|b| match b.kind {
            KindWord::Pca9555 | KindWord::Tca9555 => BoardKind::OnOff,
            KindWord::Pca9685 => BoardKind::Pwm,
        })
        .collect();
    Ok((Layout { boards: spans }, kinds))
}

impl File {
    fn into_robot(self) -> Result<Robot, RobotError> {
        let k = &self.keys;
        let low = Note::new(int("keys.low", k.low, 0, 127, "a MIDI note")?).expect("0..=127");
        let high = Note::new(int("keys.high", k.high, 0, 127, "a MIDI note")?).expect("0..=127");
        let range = KeyRange::new(low, high).ok_or_else(|| {
            RobotError::field(
                "keys.low",
                format!("{} is above keys.high = {}", k.low, k.high),
            )
        })?;
        let channels = channels(&k.channels, "keys.channels")?;
        let (layout, kinds) = boards(self.boards.as_deref())?;
        let strikes = crate::strike::read(&self.strike, k.enabled, range.keys())?;
        if !k.enabled && self.strike.is_empty() && self.fingered.is_empty() {
            return Err(RobotError::field(
                "keys.enabled",
                "false, and the robot has no [[strike]] or [[fingered]] group: it would play nothing",
            ));
        }
        let keyboard_keys = if k.enabled { range.keys() } else { 0 };
        let before_wind = keyboard_keys + strikes.strikes.outputs();
        let wind = crate::fingered::read(&self.fingered, before_wind)?;
        let wind_outputs = wind.as_ref().map_or(0, |w| w.wind.outputs());
        let outputs = before_wind + wind_outputs;
        if layout.keys() != outputs {
            let what = if self.strike.is_empty() && wind.is_none() {
                format!("keys.low..=keys.high has {}", range.keys())
            } else {
                format!(
                    "the keyboard has {keyboard_keys} keys, the strike groups {} outputs and the fingered group {wind_outputs}",
                    strikes.strikes.outputs()
                )
            };
            return Err(RobotError::field(
                "boards",
                format!("the boards drive {} keys in all, but {what}", layout.keys()),
            ));
        }
        let guard = guard(&self.guard)?;
        let dynamics = dynamics(&self.dynamics, range, &layout, &kinds, &guard)?;
        let pwm_hz = pwm_frequency(&self.pwm.frequency)?;
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
            dynamics,
            strikes: strikes.strikes,
            wind: wind.as_ref().map_or(orch_core::Wind::NONE, |w| w.wind),
        };
        let mut groups = Vec::new();
        if k.enabled {
            groups.push(crate::Group::keyboard(range, channels));
        }
        groups.extend(strikes.groups);
        let mut outputs_mechanics = strikes.mechanics;
        let mut wind_sim = None;
        if let Some(w) = wind {
            groups.push(w.group);
            outputs_mechanics.extend(w.mechanics);
            wind_sim = Some(w.sim);
        }
        config
            .validate(MAX_KEYS)
            .map_err(|e| crate::strike::named(e, &groups).unwrap_or_else(|| config_error(e)))?;
        Ok(Robot {
            config,
            boards: kinds.len(),
            kinds,
            pwm_hz,
            clock: clock(&self.bus.clock)?,
            mechanics: orch_sim::MechanicsConfig {
                wind: wind_sim,
                ..crate::strike::with_outputs(
                    mechanics(&self.mechanics, range)?,
                    &outputs_mechanics,
                )
            },
            groups,
        })
    }
}

/// What `pwm.frequency` accepts.
fn pwm_help() -> String {
    format!(
        "the PCA9685 makes {}..={} Hz from its 25 MHz oscillator (PRE_SCALE 3..=255); write          it in Hz or kHz, such as \"1kHz\" or \"200Hz\"",
        crate::PWM_HZ.start(),
        crate::PWM_HZ.end()
    )
}

/// Reads `pwm.frequency`: a frequency the PCA9685 can make.
fn pwm_frequency(text: &str) -> Result<u32, RobotError> {
    let t = text.trim().to_ascii_lowercase().replace(' ', "");
    let hz = if let Some(k) = t.strip_suffix("khz") {
        k.parse::<f64>().ok().map(|k| k * 1e3)
    } else if let Some(h) = t.strip_suffix("hz") {
        h.parse::<f64>().ok()
    } else {
        None
    };
    match hz.map(f64::round) {
        Some(hz)
            if hz >= 1.0
                && hz <= u32::MAX as f64
                && orch_boards::pca9685::Prescale::from_hz(hz as u32).is_some() =>
        {
            Ok(hz as u32)
        }
        _ => Err(RobotError::field(
            "pwm.frequency",
            format!("{text:?}: {}", pwm_help()),
        )),
    }
}

/// Parses a duty written in per cent, "45%", 0..=100.
pub(crate) fn duty(field: &str, text: &str) -> Result<orch_core::Duty, RobotError> {
    let t = text.trim();
    let Some(number) = t.strip_suffix('%') else {
        return Err(RobotError::field(
            field,
            format!("{text:?}: write a duty in per cent of full power, such as \"45%\""),
        ));
    };
    let value: f32 = number
        .trim()
        .parse()
        .map_err(|_| RobotError::field(field, format!("{text:?}: {number:?} is not a number")))?;
    orch_core::Duty::from_percent(value).ok_or_else(|| {
        RobotError::field(
            field,
            format!("{text:?}: a duty is 0% to 100% of full power"),
        )
    })
}

/// Reads `[dynamics]` and its `[[dynamics.key]]` entries: keys on PWM boards get their
/// touch, keys on on/off boards [`Touch::FULL`](orch_core::Touch::FULL).
fn dynamics(
    d: &DynamicsFile,
    range: KeyRange,
    layout: &Layout<MAX_BOARDS>,
    kinds: &[BoardKind],
    guard: &GuardConfig,
) -> Result<orch_core::Dynamics, RobotError> {
    use orch_core::{Dynamics, Touch};
    let strike = delay("dynamics.strike", &d.strike)?;
    if strike == Duration::ZERO {
        return Err(RobotError::field(
            "dynamics.strike",
            "\"0ms\": a strike needs time to throw the hammer; give a duration such as \"40ms\"",
        ));
    }
    // The strike time matters only where a board plays it.
    let any_pwm = kinds.contains(&BoardKind::Pwm);
    if let Some(hold) = guard.max_hold.filter(|_| guard.enabled && any_pwm) {
        if strike > hold {
            return Err(RobotError::field(
                "dynamics.strike",
                format!(
                    "{:?} is longer than guard.max_hold: the hold limit would cut every \
                     strike; make it shorter",
                    d.strike
                ),
            ));
        }
    }
    let default = Touch {
        softest: duty("dynamics.softest", &d.softest)?,
        loudest: duty("dynamics.loudest", &d.loudest)?,
        hold: duty("dynamics.hold", &d.hold)?,
    };
    check_touch(&default, "dynamics.")?;
    let low = range.low().get();
    let mut keys = [default; 128];
    for (i, k) in d.key.iter().enumerate() {
        let field = |name: &str| format!("dynamics.key[{i}].{name}");
        let notes: Vec<i64> = d.key.iter().map(|k| k.note).collect();
        key_entry("dynamics.key", &notes, i, range)?;
        let mut t = default;
        if let Some(x) = &k.softest {
            t.softest = duty(&field("softest"), x)?;
        }
        if let Some(x) = &k.loudest {
            t.loudest = duty(&field("loudest"), x)?;
        }
        if let Some(x) = &k.hold {
            t.hold = duty(&field("hold"), x)?;
        }
        check_touch(&t, &format!("dynamics.key[{i}]."))?;
        keys[(k.note as u8 - low) as usize] = t;
    }
    // Keys on on/off boards play at full power whatever the velocity.
    for (key, t) in keys.iter_mut().enumerate() {
        let pwm = (key < layout.keys())
            .then(|| layout.finger(key as u8))
            .flatten()
            .is_some_and(|f| kinds.get(f.board as usize) == Some(&BoardKind::Pwm));
        if !pwm {
            *t = Touch::FULL;
        }
    }
    Ok(Dynamics { strike, keys })
}

/// Checks entry `i` of a per-key table (`table` = "mechanics.key", whose entries name these
/// `notes`): a note the robot has a key for, listed once.
fn key_entry(table: &str, notes: &[i64], i: usize, range: KeyRange) -> Result<(), RobotError> {
    let (low, high) = (range.low().get(), range.high().get());
    let note = notes[i];
    let field = format!("{table}[{i}].note");
    if !(i64::from(low)..=i64::from(high)).contains(&note) {
        return Err(RobotError::field(
            field,
            format!("{note} is out of range: the robot has keys for notes {low}..={high} only"),
        ));
    }
    if let Some(j) = notes[..i].iter().position(|&o| o == note) {
        return Err(RobotError::field(
            field,
            format!("note {note} is already given in {table}[{j}]; list each key once"),
        ));
    }
    Ok(())
}

/// Refuses a touch whose curve falls, whose hold is above its softest strike, or whose softest
/// strike is silence; `prefix` names its table.
fn check_touch(t: &orch_core::Touch, prefix: &str) -> Result<(), RobotError> {
    let pct = |d: orch_core::Duty| format!("{:.1}%", d.percent());
    if t.softest == orch_core::Duty::OFF {
        return Err(RobotError::field(
            format!("{prefix}softest"),
            "0%: velocity 1 would make no sound; give the softest duty that still sounds",
        ));
    }
    if t.loudest < t.softest {
        return Err(RobotError::field(
            format!("{prefix}loudest"),
            format!(
                "{} is below softest = {}: the velocity curve would fall (louder notes struck \
                 softer)",
                pct(t.loudest),
                pct(t.softest)
            ),
        ));
    }
    if t.hold > t.softest {
        return Err(RobotError::field(
            format!("{prefix}hold"),
            format!(
                "{} is above softest = {}: a hold must not push harder than the softest strike",
                pct(t.hold),
                pct(t.softest)
            ),
        ));
    }
    Ok(())
}

/// Reads `[mechanics]` and its `[[mechanics.key]]` entries, one at most per note.
fn mechanics(m: &Mechanics, range: KeyRange) -> Result<MechanicsConfig, RobotError> {
    let default = KeyMechanics {
        press_delay: delay("mechanics.press_delay", &m.press_delay)?,
        release_delay: delay("mechanics.release_delay", &m.release_delay)?,
        min_hold: delay("mechanics.min_hold", &m.min_hold)?,
        softest: duty("mechanics.softest", &m.softest)?.get(),
        soft_press_delay: delay("mechanics.soft_press_delay", &m.soft_press_delay)?,
        mute_after: None,
    };
    let low = range.low().get();
    let mut mechanics = MechanicsConfig::uniform(default);
    for (i, k) in m.key.iter().enumerate() {
        let field = |name: &str| format!("mechanics.key[{i}].{name}");
        let notes: Vec<i64> = m.key.iter().map(|k| k.note).collect();
        key_entry("mechanics.key", &notes, i, range)?;
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
        if let Some(t) = &k.softest {
            figures.softest = duty(&field("softest"), t)?.get();
        }
        if let Some(t) = &k.soft_press_delay {
            figures.soft_press_delay = delay(&field("soft_press_delay"), t)?;
        }
        mechanics = mechanics.with_key(k.note as u8 - low, figures);
    }
    Ok(mechanics)
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
        // The thesis's robot with one change: a keyboard leaves channel 10 (drums) alone.
        assert_eq!(r.config.channels, MELODIC);
        assert_eq!(t.channels, ChannelMask::ALL);
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
