//! The interpreter's settings: a plain struct, no allocation.

use crate::keymap::{KeyRange, Layout, OutOfRange};
use crate::time::Duration;
use crate::values::ChannelMask;

/// The longest any guard limit may be: 30 minutes. Per-key times are kept in 32 bits of
/// microseconds (71 minutes), and the guard needs half that range to tell old from new.
pub const MAX_LIMIT: Duration = Duration::from_secs(30 * 60);

/// Limits that keep solenoids from sticking, overheating or smearing repeated notes.
///
/// The defaults, and why:
///
/// | limit | default | why |
/// |---|---|---|
/// | [`max_hold`](Self::max_hold) | 10 s | The open DIY player pianos switch a key off after 10 s; a small solenoid held on runs hot within a minute. Piano music rarely holds a key longer (a whole note at 30 bpm is 8 s). |
/// | [`max_keys_down`](Self::max_keys_down) | 16 | The power budget. More than two hands (10 fingers), below the 22–26 keys per supply of the DIY pianos, and one board's worth of outputs. When it is reached the **new note is refused** (counted in [`Stats::dropped_power`](crate::Stats::dropped_power)); keys already down are never cut for it, because a cut note is heard as a mistake twice, and a late one would be too. |
/// | [`restrike_gap`](Self::restrike_gap) | 60 ms | A key must be up this long before it strikes again, so a repeated note releases, waits and presses again instead of smearing. The DIY pianos re-strike after 52–80 ms; a grand's action repeats about 14 times a second (71 ms a cycle). |
/// | [`min_press`](Self::min_press) | 20 ms | How long a delayed re-strike is held when its note was already released before it could strike (a note shorter than the rest it had to wait for). It still sounds, rather than being lost: the DIY pianos strike at full power for about 18 ms. Notes that strike on time are released when their Note-Off says. |
/// | [`watchdog`](Self::watchdog) | 4 s | If no byte arrives this long while keys are down, the sender is taken as gone and every key is released. Longer than the silences of held chords in slow music, much shorter than the minute in which a held solenoid overheats. Once an Active Sensing byte (0xFE) has been seen, the specification's 300 ms applies as well. |
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct GuardConfig {
    /// Whether the guard runs at all. Off gives the bare note-to-finger mapping, with no
    /// timers: for inspection, never for a robot.
    pub enabled: bool,
    /// The longest a key may stay down; `None` for no limit.
    pub max_hold: Option<Duration>,
    /// The most keys down at once (keys waiting for their re-strike gap count as down).
    pub max_keys_down: u8,
    /// The shortest time a key stays up before it strikes again.
    pub restrike_gap: Duration,
    /// How long a delayed re-strike is held when its note was released before it struck.
    pub min_press: Duration,
    /// Release every key if no byte arrives for this long while keys are down; `None` for never.
    pub watchdog: Option<Duration>,
}

impl GuardConfig {
    /// The defaults in the table above.
    pub const DEFAULT: Self = Self {
        enabled: true,
        max_hold: Some(Duration::from_secs(10)),
        max_keys_down: 16,
        restrike_gap: Duration::from_millis(60),
        min_press: Duration::from_millis(20),
        watchdog: Some(Duration::from_secs(4)),
    };

    /// The guard switched off.
    pub const OFF: Self = Self {
        enabled: false,
        ..Self::DEFAULT
    };

    /// The guard on, with no limit at all (only `all_off` and system reset act).
    pub const UNLIMITED: Self = Self {
        enabled: true,
        max_hold: None,
        max_keys_down: u8::MAX,
        restrike_gap: Duration::ZERO,
        min_press: Duration::ZERO,
        watchdog: None,
    };
}

impl Default for GuardConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Everything the interpreter needs to know about the instrument and how to play it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Config<const B: usize> {
    /// Channels listened to. Default: all 16.
    pub channels: ChannelMask,
    /// Notes with keys. Default: 36..=96.
    pub range: KeyRange,
    /// What happens to notes outside `range`. Default: fold by octaves.
    pub out_of_range: OutOfRange,
    /// Which board and bit each key is on. Default: the thesis's 16/16/16/13 on 0x21..=0x24.
    pub layout: Layout<B>,
    /// Whether the sustain pedal (CC 64) holds released keys down. Default: off, because a
    /// held solenoid heats up.
    pub sustain: bool,
    /// The safety guard. Default: on, see [`GuardConfig`].
    pub guard: GuardConfig,
}

impl Config<4> {
    /// The thesis's robot with orch's safety guard.
    pub const THESIS: Self = Self {
        channels: ChannelMask::ALL,
        range: KeyRange::THESIS,
        out_of_range: OutOfRange::Fold,
        layout: Layout::THESIS,
        sustain: false,
        guard: GuardConfig::DEFAULT,
    };
}

impl Default for Config<4> {
    fn default() -> Self {
        Self::THESIS
    }
}

/// A configuration the interpreter cannot run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConfigError {
    /// The layout's boards drive a different number of keys than the range has.
    LayoutKeys {
        /// Keys in the range.
        range: usize,
        /// Keys the boards drive.
        layout: usize,
    },
    /// A board's keys run past output bit 15.
    BoardBits {
        /// Index of the board.
        board: u8,
    },
    /// The range has more keys than the interpreter was built for.
    TooManyKeys {
        /// Keys in the range.
        keys: usize,
        /// The interpreter's capacity.
        capacity: usize,
    },
    /// A guard limit is longer than [`MAX_LIMIT`].
    LimitTooLong,
    /// `max_keys_down` is 0: nothing could ever play.
    NoKeysAllowed,
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            ConfigError::LayoutKeys { range, layout } => write!(
                f,
                "the boards drive {layout} keys but the key range has {range}"
            ),
            ConfigError::BoardBits { board } => {
                write!(f, "board {board}: its keys run past output bit 15")
            }
            ConfigError::TooManyKeys { keys, capacity } => write!(
                f,
                "the key range has {keys} keys; this build handles at most {capacity}"
            ),
            ConfigError::LimitTooLong => f.write_str("a guard limit is longer than 30 minutes"),
            ConfigError::NoKeysAllowed => {
                f.write_str("guard.max_keys_down is 0: no key could play")
            }
        }
    }
}

impl core::error::Error for ConfigError {}

impl<const B: usize> Config<B> {
    /// Checks that an interpreter with room for `capacity` keys can run this configuration.
    pub fn validate(&self, capacity: usize) -> Result<(), ConfigError> {
        let keys = self.range.keys();
        if keys > capacity {
            return Err(ConfigError::TooManyKeys { keys, capacity });
        }
        if self.layout.keys() != keys {
            return Err(ConfigError::LayoutKeys {
                range: keys,
                layout: self.layout.keys(),
            });
        }
        for (i, span) in self.layout.boards.iter().enumerate() {
            if span.first_bit as usize + span.keys as usize > 16 {
                return Err(ConfigError::BoardBits { board: i as u8 });
            }
        }
        let g = &self.guard;
        if g.enabled {
            let too_long = |d: Option<Duration>| d.is_some_and(|d| d > MAX_LIMIT);
            if too_long(g.max_hold)
                || too_long(g.watchdog)
                || g.restrike_gap > MAX_LIMIT
                || g.min_press > MAX_LIMIT
            {
                return Err(ConfigError::LimitTooLong);
            }
            if g.max_keys_down == 0 {
                return Err(ConfigError::NoKeysAllowed);
            }
        }
        Ok(())
    }
}
