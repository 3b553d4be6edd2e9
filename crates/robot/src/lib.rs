//! `robot.toml`: the configuration of one solenoid robot, read and checked.
//!
//! orch's core ([`orch_core`]) and virtual robot ([`orch_sim`]) take plain settings: a
//! [`Config`], a [`BusClock`], a [`MechanicsConfig`]. This crate is where those settings come
//! from on a host: a commented TOML file (see [`DEFAULT_TOML`], which `orch config` prints)
//! with the robot's key range, channels, finger boards, bus clock, key mechanics and safety
//! guard. Every field is optional. A file that cannot be used is refused with a
//! [`RobotError`] that names the field and says what to write instead; a configuration that
//! is accepted always builds an interpreter.
//!
//! ```
//! use orch_robot::Robot;
//!
//! let robot = Robot::from_toml("[guard]\nmax_hold = \"5s\"\n").unwrap();
//! assert_eq!(robot.boards, 4);
//! let e = Robot::from_toml("[guard]\nmax_hold = \"ten\"\n").unwrap_err();
//! assert_eq!(e.field_name(), Some("guard.max_hold"));
//! ```

use std::path::Path;

use orch_core::{Config, Interpreter};
use orch_sim::{BusClock, MechanicsConfig, SimConfig};

mod error;
mod file;
mod fingered;
mod group;
mod instrument;
mod strike;

pub use error::RobotError;
pub use file::MELODIC;
pub use group::{gm_drum_name, note_name, Group, GroupKind};
pub use instrument::{instrument_toml, Instrument};

/// The most boards a host configuration may have.
pub const MAX_BOARDS: usize = 16;
/// The most keys a host configuration may have: one per MIDI note.
pub const MAX_KEYS: usize = 128;

/// The interpreter as the host runs it: room for any configuration.
pub type HostInterpreter = Interpreter<MAX_BOARDS, MAX_KEYS>;

/// The PCA9685's PWM frequency by default: its highest, 1526 Hz (the driver's
/// [`DEFAULT_FREQUENCY_HZ`](orch_boards::pca9685::DEFAULT_FREQUENCY_HZ), whose docs say why).
pub const DEFAULT_PWM_HZ: u32 = orch_boards::pca9685::DEFAULT_FREQUENCY_HZ;

/// The PWM frequencies a PCA9685 makes from its internal 25 MHz oscillator: PRE_SCALE =
/// round(25 MHz / (4096 × f)) − 1 must lie in 3..=255.
pub const PWM_HZ: std::ops::RangeInclusive<u32> =
    orch_boards::pca9685::MIN_FREQUENCY_HZ..=orch_boards::pca9685::MAX_FREQUENCY_HZ;

pub use orch_core::BoardKind;

/// A robot: the interpreter's configuration, how many of the boards are real, the bus clock
/// and the keys' mechanics.
#[derive(Clone, Debug)]
pub struct Robot {
    /// The interpreter's configuration; only the first [`boards`](Self::boards) entries of
    /// its layout are used.
    pub config: Config<MAX_BOARDS>,
    /// How many finger boards the robot has (1..=[`MAX_BOARDS`]).
    pub boards: usize,
    /// What each board is, in layout order (`boards` entries).
    pub kinds: Vec<BoardKind>,
    /// The PWM frequency of the PCA9685 boards, Hz (in [`PWM_HZ`]).
    pub pwm_hz: u32,
    /// The I2C bus clock to the boards.
    pub clock: BusClock,
    /// How the keys move: press and release delays, shortest pulse that sounds.
    pub mechanics: MechanicsConfig,
    /// Its instruments, in key order: the keyboard (if it has one), then the strike groups.
    pub groups: Vec<Group>,
}

impl Robot {
    /// The thesis's robot ([`DEFAULT_TOML`]).
    pub fn thesis() -> Self {
        Self::from_toml(DEFAULT_TOML).expect("the default configuration is valid")
    }

    /// Reads a configuration file. Errors in it are [`RobotError::InFile`], naming the file.
    pub fn load(path: &Path) -> Result<Self, RobotError> {
        Self::load_with_text(path).map(|(robot, _)| robot)
    }

    /// Reads a configuration file as [`load`](Self::load) does, and gives its text back too
    /// (to write a changed copy of it, keeping its comments: a calibrated robot.toml).
    pub fn load_with_text(path: &Path) -> Result<(Self, String), RobotError> {
        let text = std::fs::read_to_string(path).map_err(|source| RobotError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let robot = Self::from_toml(&text).map_err(|error| RobotError::InFile {
            path: path.to_path_buf(),
            error: Box::new(error),
        })?;
        Ok((robot, text))
    }

    /// Parses and checks a configuration.
    pub fn from_toml(text: &str) -> Result<Self, RobotError> {
        file::parse(text)
    }

    /// The virtual robot's configuration.
    pub fn sim_config(&self) -> SimConfig {
        SimConfig {
            clock: self.clock,
            boards: self.config.layout.boards[..self.boards].to_vec(),
            mechanics: self.mechanics.clone(),
            keep: orch_sim::Keep::Everything,
            kinds: self.kinds.clone(),
            pwm_hz: self.pwm_hz,
        }
    }

    /// The time one board write takes on the bus, in µs: START, 4 bytes of 9 bits, STOP.
    pub fn write_micros(&self) -> f64 {
        self.clock.nanos_for_bits(38) as f64 / 1000.0
    }

    /// Whether any board is a PWM board: the robot is then flushed with
    /// [`Interpreter::flush_duties`](orch_core::Interpreter::flush_duties).
    pub fn has_dynamics(&self) -> bool {
        self.kinds.contains(&BoardKind::Pwm)
    }

    /// The group `key` belongs to.
    pub fn group_of(&self, key: u8) -> Option<&Group> {
        self.groups.iter().find(|g| g.keys().contains(&key))
    }

    /// An interpreter for this robot.
    ///
    /// A robot read by [`Robot::from_toml`] always has one; a robot whose fields were changed
    /// afterwards may not.
    pub fn interpreter(&self) -> Result<HostInterpreter, RobotError> {
        HostInterpreter::new(self.config).map_err(file::config_error)
    }
}

/// The default configuration: the thesis's robot with orch's safety guard.
pub const DEFAULT_TOML: &str = r#"# orch robot configuration (robot.toml)
# Every field is optional; a missing one takes the value shown here.

[keys]
# Whether the robot has a keyboard. false: only its [[strike]] groups play.
enabled = true
# The notes the robot has keys for, as MIDI note numbers (60 is middle C).
low = 36                  # C2
high = 96                 # C7: 61 keys
# Notes outside low..=high: "fold" moves them by octaves into range; "drop" skips them.
out_of_range = "fold"
# Channels listened to, as people count them (1..=16, such as [1, 2]), "all", or "melodic":
# every channel but 10, which General MIDI gives to drums. A keyboard leaves drum notes alone
# by default (they are not pitches: GM note 42 is a closed hi-hat, not F#2); they are dropped
# as "percussion", and a [[strike]] drum group would play them (`orch config --instrument
# drums`).
channels = "melodic"
# Let the sustain pedal (CC 64) hold released keys down. Off by default: a held solenoid heats up.
sustain = false
# A second note on a key that is down (the same note on another channel, a note folded onto
# it, or the same note again): "restrike" lifts the key, rests and strikes again (the
# sequencer releases early so it lands on time); "hold" keeps it down for both, and the new
# note makes no sound of its own. Restrike by default: the ear follows onsets.
overlap = "restrike"

# The finger boards, in key order: each drives `keys` consecutive keys (1 to 16) from output
# `first_bit` (bits 0-7 are port 0, 8-15 port 1). kind: "pca9555" (or "tca9555"): on/off
# outputs, velocity ignored; "pca9685": 16 PWM outputs, velocity played as strike strength
# (see [dynamics]). A robot may mix kinds. `orch config --boards pca9685` prints this file
# for four PCA9685 boards.
[[boards]]
kind = "pca9555"
address = 0x21
keys = 16
first_bit = 0

[[boards]]
kind = "pca9555"
address = 0x22
keys = 16
first_bit = 0

[[boards]]
kind = "pca9555"
address = 0x23
keys = 16
first_bit = 0

[[boards]]
kind = "pca9555"
address = 0x24
keys = 13
first_bit = 0

# The I2C bus to the boards: "83.33kHz" (the thesis's board), "100kHz", "400kHz" or "1MHz"
# (any clock from 1 kHz to 1 MHz, written in Hz, kHz or MHz).
# The PCA9555 and TCA9555 are rated for 400 kHz: a board write then takes 95 us, not 456 us.
# The PCA9685 runs up to 1 MHz (Fast-mode Plus).
[bus]
clock = "400kHz"

# How the keys move, for the virtual robot and for latency compensation. press_delay: from
# the solenoid's power to the key sounding, at full power; release_delay: from power off until
# the key is fully up; min_hold: the shortest pulse that sounds. On PCA9685 boards a softer
# strike travels slower and a too soft one does not sound: softest is the lowest duty whose
# strike sounds (velocity 1's loudness; full power is 127's), soft_press_delay the press delay
# at that duty (it falls linearly to press_delay at full power). Keys that differ are listed by
# note, each note once.
[mechanics]
press_delay = "15ms"
release_delay = "25ms"
min_hold = "8ms"
softest = "45%"
soft_press_delay = "30ms"
# [[mechanics.key]]
# note = 36
# press_delay = "20ms"

# The safety guard. Durations are written like "10s", "60ms" or "2min"; "off" means no limit.
# max_hold and watchdog are "off" or longer than 0; min_press is at most max_hold.
[guard]
enabled = true
max_hold = "10s"          # the longest a key may stay down (more than 0)
max_keys_down = 16        # the power budget: a new note past it is refused
restrike_gap = "60ms"     # the shortest rest before a key strikes again
min_press = "20ms"        # how long a delayed re-strike is held if its note ended while it waited
watchdog = "4s"           # release every key after this long without a byte (more than 0)
late_limit = "30ms"       # a re-strike that would sound later than this is dropped (too fast)
duty_window = "60s"       # the duty limit: a key may be energised at most duty_max_on
duty_max_on = "30s"       #   in any duty_window ("off": no duty limit)
max_pulse = "100ms"       # the longest a strike's pulse may last ([[strike]] groups; at most 250ms)
# With PCA9685 boards, the power budget and the duty limit count energy: max_keys_down is a
# current (keys at full power; a key holding at 35 % counts 0.35), and a key heats by its duty.

# The PCA9685 boards' PWM frequency: 24 Hz to 1526 Hz (what the chip makes from its 25 MHz
# oscillator). Low frequencies click audibly at a hold duty (75 Hz did on an open player
# piano) and delay a new duty by up to a period; even at the top a MOSFET's switching losses
# are tens of mW a channel. So the default is the highest the chip makes.
[pwm]
frequency = "1526Hz"

# Dynamics, for keys on PCA9685 boards (keys on PCA9555 boards play at full power). A press is
# a strike at a duty chosen by velocity, for `strike`, then a hold until the release: velocity
# 1 strikes at `softest` (the softest duty that still sounds: never silence), 127 at
# `loudest`, linearly in between. Duties in per cent of full power. The defaults are the open
# player pianos' (strike 18 ms full + 20-45 ms at velocity, hold at 35 %). Keys that differ are
# listed by note, each note once. Refused: a curve that falls (loudest below softest), a hold
# above softest, a duty over 100 %, a strike longer than guard.max_hold.
[dynamics]
strike = "40ms"
softest = "45%"
loudest = "100%"
hold = "35%"
# [[dynamics.key]]
# note = 36
# softest = "55%"
"#;

/// The default configuration with every board of the `kind` given: [`DEFAULT_TOML`] for
/// on/off boards; for PWM boards, four PCA9685 boards at 0x40..=0x43 (the chip's first
/// addresses) driving the same 61 keys (16/16/16/13), on a 1 MHz bus. What
/// `orch config --boards` prints.
pub fn default_toml(kind: BoardKind) -> String {
    match kind {
        BoardKind::OnOff => DEFAULT_TOML.to_string(),
        BoardKind::Pwm => {
            // A PCA9685 takes Fast-mode Plus: at 1 MHz a chord's write (the run of channels
            // that changed, all switched at its STOP) costs a third of the time it takes at
            // 400 kHz, so chords stay on time.
            let mut text = DEFAULT_TOML
                .replace("kind = \"pca9555\"", "kind = \"pca9685\"")
                .replace("clock = \"400kHz\"", "clock = \"1MHz\"");
            for (from, to) in [(0x21, 0x40), (0x22, 0x41), (0x23, 0x42), (0x24, 0x43)] {
                text = text.replace(
                    &format!("address = {from:#04x}"),
                    &format!("address = {to:#04x}"),
                );
            }
            text
        }
    }
}
