//! The interpreter's settings: a plain struct, no allocation.

#[cfg(feature = "dynamics")]
use crate::dynamics::Dynamics;
use crate::dynamics::DynamicsError;
use crate::keymap::{KeyOf, KeyRange, Layout, OutOfRange};
use crate::outcome::DropReason;
#[cfg(feature = "strike")]
use crate::strike::{StrikeError, Strikes};
use crate::time::Duration;
use crate::values::ChannelMask;
use crate::values::{Channel, Note};
#[cfg(feature = "wind")]
use crate::wind::{Wind, WindError};

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
/// | [`late_limit`](Self::late_limit) | 30 ms | A re-strike that would have to wait longer than this for its key's rest is dropped (counted as too fast) instead of sounding late: people hear a note as late from about 20–30 ms, and a late note in a fast repeated figure would push every later one further behind. |
/// | [`duty`](Self::duty) | 30 s in any 60 s | Energised time per key. The hold limit misses a key struck again just before it expires (struck every 9.9 s it is powered 99 % of the time). Small push solenoids are rated for intermittent duty, commonly 25–50 %, and one held on continuously runs hot within a minute: so a key may be on at most half of a minute. Music never comes near it (a legato repeated note is on about 90 % of the time only for a few bars); a stuck stream does. See [`DutyLimit`]. |
/// | [`max_pulse`](Self::max_pulse) | 100 ms | The hard limit on a strike's pulse (feature `strike`). Above the 75 ms that TheDitis/AutoDrum gives its biggest solenoids' loudest strikes and well above the 8–20 ms of the open drum and glockenspiel builds; a beater held against its bar much longer mutes it. |
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
    /// The longest a re-strike may wait for its key's rest; a note that would wait longer is
    /// dropped as too fast. `None`: any wait.
    pub late_limit: Option<Duration>,
    /// The most a key may be energised over time; `None`: no limit. Needs the `duty-limit`
    /// feature (on by default; without it the default is `None` and `Some` is refused).
    pub duty: Option<DutyLimit>,
    /// The longest a strike's pulse may last ([`strike`](crate::strike)): a beater left on
    /// its bar mutes it, and a stuck output burns its coil. No strike output may be given a
    /// longer pulse, and a pulse is ended at this age whatever else happens. At most
    /// [`MAX_PULSE`](crate::strike::MAX_PULSE). Needs the `strike` feature.
    #[cfg(feature = "strike")]
    pub max_pulse: Duration,
}

/// A limit on each key's energised time: at most `max_on` in a window of `window`.
///
/// Kept per key as a leaky bucket of "heat" (2 bytes a key): energised time adds to it, and
/// it drains all the time at the allowed duty, `max_on / window`. When it reaches `max_on`
/// the key is released and its notes forgotten (counted in
/// [`Stats::cut_by_duty_limit`](crate::Stats::cut_by_duty_limit)); a later note strikes
/// afresh and is cut again as soon as the bucket is full, so a key can never be on for more
/// than the duty on average. A key on below the duty is never cut; one held on from cold is
/// cut after `max_on / (1 − duty)` (60 s with the defaults, so the 10 s hold limit acts first);
/// one struck again every 9.9 s (99 % duty) is cut within about a minute.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct DutyLimit {
    /// The window, at most [`MAX_LIMIT`].
    pub window: Duration,
    /// The energised time allowed in it: above 0, at most the window and at most 60 s.
    pub max_on: Duration,
}

impl DutyLimit {
    /// 30 s in any 60 s (50 %).
    pub const DEFAULT: Self = Self {
        window: Duration::from_secs(60),
        max_on: Duration::from_secs(30),
    };

    /// The most `max_on` may be: 60 s (the heat is kept in 16 bits of milliseconds).
    pub const MAX_ON: Duration = Duration::from_secs(60);
}

/// How a key behaves when a second note lands on it while it is down (the same note on
/// another channel, another note folded onto it, or the same note again with no Note-Off
/// between).
///
/// The default is [`Overlap::Restrike`]: the ear follows onsets, so a note that only joins a
/// key already down is a note nobody hears, while a re-struck key is heard, with the earlier
/// note cut a little short (which the ear forgives). A sequencer that knows the future
/// releases the key early so the re-strike still lands on time; a re-strike that cannot
/// sound within `late_limit` is dropped as too fast and the key stays down.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Overlap {
    /// The key stays down for both: the new note joins it without a strike of its own (the
    /// thesis's behaviour, and the DIY pianos' "count overlapping note-ons"). The same note
    /// again on its own channel still re-strikes.
    Hold,
    /// The new note releases the key, lets it rest for the re-strike gap and strikes again.
    /// Notes struck together (within `min_press` of the strike) still join it.
    #[default]
    Restrike,
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
        late_limit: Some(Duration::from_millis(30)),
        duty: if cfg!(feature = "duty-limit") {
            Some(DutyLimit::DEFAULT)
        } else {
            None
        },
        #[cfg(feature = "strike")]
        max_pulse: Duration::from_millis(100),
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
        late_limit: None,
        duty: None,
        #[cfg(feature = "strike")]
        max_pulse: crate::strike::MAX_PULSE,
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
    /// What a second note on a key that is down does. Default: [`Overlap::Restrike`].
    pub overlap: Overlap,
    /// The safety guard. Default: on, see [`GuardConfig`].
    pub guard: GuardConfig,
    /// How a press is played on PWM boards: strike, hold and each key's velocity curve.
    /// Default: [`Dynamics::ON_OFF`] (every key on/off, velocity ignored). See
    /// [`dynamics`](crate::dynamics). Needs the `dynamics` feature (the per-key table is
    /// 768 bytes, kept out of small MCUs' RAM).
    #[cfg(feature = "dynamics")]
    pub dynamics: Dynamics,
    /// The strike groups beside the keyboard (drums, mallets) and their outputs' pulses.
    /// Default: none ([`Strikes::NONE`]). See [`strike`](crate::strike). Needs the `strike`
    /// feature.
    #[cfg(feature = "strike")]
    pub strikes: Strikes,
    /// The fingered group after the keyboard and the strike groups (a recorder): its fingers,
    /// valve and fingering table. Default: none ([`Wind::NONE`]). See [`wind`](crate::wind).
    /// Needs the `wind` feature.
    #[cfg(feature = "wind")]
    pub wind: Wind,
}

impl Config<4> {
    /// The thesis's robot with orch's safety guard.
    pub const THESIS: Self = Self {
        channels: ChannelMask::ALL,
        range: KeyRange::THESIS,
        out_of_range: OutOfRange::Fold,
        layout: Layout::THESIS,
        sustain: false,
        overlap: Overlap::Restrike,
        guard: GuardConfig::DEFAULT,
        #[cfg(feature = "dynamics")]
        dynamics: Dynamics::ON_OFF,
        #[cfg(feature = "strike")]
        strikes: Strikes::NONE,
        #[cfg(feature = "wind")]
        wind: Wind::NONE,
    };
}

impl Default for Config<4> {
    fn default() -> Self {
        Self::THESIS
    }
}

/// Where an [`Interpreter`](crate::Interpreter) finds its configuration.
///
/// - [`Config`] itself (the default): any configuration, checked and chosen at run time, kept
///   in the interpreter's state.
/// - A zero-sized type that hands out a constant, such as [`Thesis`]: the compiler folds the
///   key range, the layout and the guard's limits into the code, and the configuration takes
///   no RAM. For MCUs with a fixed robot.
pub trait ConfigSource<const B: usize>: Clone + core::fmt::Debug {
    /// The configuration.
    fn get(&self) -> &Config<B>;
}

impl<const B: usize> ConfigSource<B> for Config<B> {
    #[inline(always)]
    fn get(&self) -> &Config<B> {
        self
    }
}

/// [`Config::THESIS`] as a constant: `Interpreter<4, 61, H, Thesis>` (built with
/// [`Interpreter::thesis_fixed`](crate::Interpreter::thesis_fixed)) plays exactly like
/// [`Interpreter::thesis`](crate::Interpreter::thesis) with no configuration in RAM, and
/// smaller, faster code.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Thesis;

impl ConfigSource<4> for Thesis {
    #[inline(always)]
    fn get(&self) -> &Config<4> {
        const THESIS: Config<4> = Config::THESIS;
        &THESIS
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
    /// The duty limit's `max_on` is 0, longer than its window, or longer than
    /// [`DutyLimit::MAX_ON`].
    BadDuty,
    /// A duty limit was asked of a build without the `duty-limit` feature.
    DutyUnsupported,
    /// The dynamics cannot be played: see [`DynamicsError`].
    Dynamics(DynamicsError),
    /// The strike groups cannot be played: see [`StrikeError`](crate::StrikeError).
    #[cfg(feature = "strike")]
    Strike(StrikeError),
    /// The fingered group cannot be played.
    #[cfg(feature = "wind")]
    Wind(WindError),
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
            ConfigError::DutyUnsupported => {
                f.write_str("guard duty limit: this build has no duty-limit feature")
            }
            ConfigError::Dynamics(e) => write!(f, "dynamics: {e}"),
            #[cfg(feature = "strike")]
            ConfigError::Strike(e) => write!(f, "strike groups: {e}"),
            #[cfg(feature = "wind")]
            ConfigError::Wind(e) => write!(f, "fingered group: {e}"),
            ConfigError::BadDuty => f.write_str(
                "guard duty limit: max_on must be above 0, at most the window and at most 60 s",
            ),
        }
    }
}

impl core::error::Error for ConfigError {}

impl<const B: usize> Config<B> {
    /// How many keys (outputs) the robot has: the keyboard's, the strike groups' and the
    /// fingered group's.
    #[inline(always)]
    pub fn keys(&self) -> usize {
        self.keys_before_wind() + self.wind_outputs()
    }

    /// The keyboard's keys and the strike groups' outputs: where a fingered group begins.
    #[inline(always)]
    pub fn keys_before_wind(&self) -> usize {
        #[cfg(feature = "strike")]
        if self.strikes.count > 0 || !self.strikes.keyboard {
            return self.keyboard_keys() + self.strikes.outputs();
        }
        self.range.keys()
    }

    /// The fingered group's outputs (0 without one).
    #[inline(always)]
    fn wind_outputs(&self) -> usize {
        #[cfg(feature = "wind")]
        return self.wind.outputs();
        #[cfg(not(feature = "wind"))]
        0
    }

    /// How many keys the keyboard has: `range`'s, or 0 for a robot without one.
    #[inline(always)]
    pub fn keyboard_keys(&self) -> usize {
        #[cfg(feature = "strike")]
        if !self.strikes.keyboard {
            return 0;
        }
        self.range.keys()
    }

    /// Where a note on `channel` lands: a strike group's output, else the keyboard's key (see
    /// [`strike`](crate::strike)), or why it does not play. Channel 10, General MIDI's
    /// percussion, when nothing listens to it: [`DropReason::Percussion`].
    #[inline(always)]
    pub fn land(&self, channel: Channel, note: Note) -> Result<KeyOf, DropReason> {
        #[cfg(feature = "strike")]
        {
            use crate::strike::StrikeMiss;
            let miss = match self.strikes.find(channel, note) {
                Some(Ok(of)) => return Ok(of),
                Some(Err(StrikeMiss::Unmapped)) => Some(DropReason::Unmapped),
                Some(Err(StrikeMiss::Range)) => Some(DropReason::Range),
                None => None,
            };
            self.wind_or_keyboard(channel, note)
                .map_err(|reason| miss.unwrap_or(reason))
        }
        #[cfg(not(feature = "strike"))]
        self.wind_or_keyboard(channel, note)
    }

    /// A note the strike groups leave: the fingered group's (its valve, as every one of its
    /// notes lands) if it listens to the channel, else the keyboard's.
    #[inline(always)]
    fn wind_or_keyboard(&self, channel: Channel, note: Note) -> Result<KeyOf, DropReason> {
        #[cfg(feature = "wind")]
        if self.wind.is_on() && self.wind.channels.contains(channel) {
            return match self.wind.find(note) {
                Some(of) => Ok(KeyOf {
                    key: self.wind.valve(),
                    octaves: of.octaves,
                }),
                None => Err(DropReason::Range),
            };
        }
        self.keyboard_key(channel, note)
    }

    /// Whether `key` is the fingered group's (a finger or its valve).
    #[inline(always)]
    pub fn is_wind(&self, key: u8) -> bool {
        #[cfg(feature = "wind")]
        return self.wind.owns(key);
        #[cfg(not(feature = "wind"))]
        {
            let _ = key;
            false
        }
    }

    /// The keyboard's key for a note on `channel`, or why it has none.
    #[inline(always)]
    fn keyboard_key(&self, channel: Channel, note: Note) -> Result<KeyOf, DropReason> {
        if self.keyboard_keys() == 0 || !self.channels.contains(channel) {
            return Err(if channel.get() == 9 {
                DropReason::Percussion
            } else {
                DropReason::Channel
            });
        }
        self.range
            .key_for(note, self.out_of_range)
            .ok_or(DropReason::Range)
    }

    /// Whether `key` is a strike group's output: a pulse that ends by itself, its Note-Off
    /// ignored.
    #[inline(always)]
    pub fn is_strike(&self, key: u8) -> bool {
        #[cfg(feature = "strike")]
        return self.strikes.pulse(key).is_strike();
        #[cfg(not(feature = "strike"))]
        {
            let _ = key;
            false
        }
    }

    /// Checks that an interpreter with room for `capacity` keys can run this configuration.
    pub fn validate(&self, capacity: usize) -> Result<(), ConfigError> {
        let keys = self.keys();
        if keys > capacity {
            return Err(ConfigError::TooManyKeys { keys, capacity });
        }
        #[cfg(feature = "strike")]
        if self.strikes.count > 0 || !self.strikes.keyboard {
            if self.strikes.count > 0 && !self.guard.enabled {
                return Err(ConfigError::Strike(StrikeError::GuardOff));
            }
            self.strikes
                .validate(
                    self.range.keys(),
                    self.layout.keys() - self.wind_outputs().min(self.layout.keys()),
                    self.guard.max_pulse,
                )
                .map_err(ConfigError::Strike)?;
        }
        #[cfg(feature = "wind")]
        if self.wind.is_on() {
            if !self.guard.enabled {
                return Err(ConfigError::Wind(WindError::GuardOff));
            }
            self.wind
                .validate(self.keys_before_wind())
                .map_err(ConfigError::Wind)?;
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
        #[cfg(feature = "dynamics")]
        if !self.dynamics.is_on_off() {
            let hold = if g.enabled { g.max_hold } else { None };
            self.dynamics
                .validate(keys, hold)
                .map_err(ConfigError::Dynamics)?;
        }
        if g.enabled {
            let too_long = |d: Option<Duration>| d.is_some_and(|d| d > MAX_LIMIT);
            if too_long(g.max_hold)
                || too_long(g.watchdog)
                || g.restrike_gap > MAX_LIMIT
                || g.min_press > MAX_LIMIT
                || too_long(g.late_limit)
                || g.duty.is_some_and(|d| d.window > MAX_LIMIT)
            {
                return Err(ConfigError::LimitTooLong);
            }
            if g.max_keys_down == 0 {
                return Err(ConfigError::NoKeysAllowed);
            }
            if g.duty.is_some() && !cfg!(feature = "duty-limit") {
                return Err(ConfigError::DutyUnsupported);
            }
            if let Some(d) = g.duty {
                if d.max_on == Duration::ZERO || d.max_on > d.window || d.max_on > DutyLimit::MAX_ON
                {
                    return Err(ConfigError::BadDuty);
                }
            }
        }
        Ok(())
    }
}
