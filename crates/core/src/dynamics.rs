//! Dynamics: a press played as a profile of PWM duties, from the note's velocity.
//!
//! On a PWM finger board (a PCA9685: 16 channels, 12-bit duty) a key is not only on or off.
//! A press is played as **strike, then hold**:
//!
//! ```text
//!  duty
//!  strike(v) ┌──────┐
//!            │      │
//!  hold      │      └──────────────────┐
//!            │                         │
//!  0 ────────┘ ◀ strike ▶               └──── release
//! ```
//!
//! - **strike**: for [`Dynamics::strike`] from the press, the duty that the note's velocity
//!   gives on the key's [`Touch`] curve: velocity 1 gives [`Touch::softest`] (the softest
//!   duty that still sounds: velocity 1 is the softest sound, never silence), 127 gives
//!   [`Touch::loudest`], linearly in between ([`Touch::strike_duty`]);
//! - **hold**: [`Touch::hold`] until the key is released, so the coil stays cool;
//! - **release**: 0.
//!
//! A key on an on/off board (PCA9555) ignores velocity exactly as before: its [`Touch`] is
//! [`Touch::FULL`] (strike and hold at 100 %), which is every key's touch in
//! [`Dynamics::ON_OFF`], the default. A robot's loader gives PWM keys their curves.
//!
//! The safety guard counts **energy** with dynamics: the power budget
//! ([`GuardConfig::max_keys_down`](crate::GuardConfig::max_keys_down)) is a current, the sum
//! of every key's present duty in full-power keys, and the duty limit
//! ([`DutyLimit`](crate::DutyLimit)) heats a key by its duty, not by the time it is down. So a
//! key held at a 35 % hold duty heats at about a third of the rate of one held at full power,
//! and ten soft notes cost less of the budget than ten loud ones. On/off keys cost 100 %
//! while down: the budget is then exactly "keys down", as without dynamics.
//!
//! [`Config::dynamics`](crate::Config) needs the `dynamics` feature (on by default); without it
//! every key is on/off.
//!
//! # Defaults, from the open player pianos (see [`Touch::PWM`])
//!
//! | setting | default | why |
//! |---|---|---|
//! | [`Dynamics::strike`] | 40 ms | japhillips87/player_piano strikes 18 ms at full power and then 20–45 ms at a velocity duty; RCPilot1604 5 ms full and 10–35 ms at velocity. One phase at the velocity's duty that lasts about as long as those two together (a hammer is thrown within it) lets the softest strikes still reach the string. |
//! | [`Touch::softest`] | 45 % | japhillips87's velocity phase starts at a duty of 115/255 (45 %) for velocity 0: below about that a solenoid does not throw the hammer at all. A robot's own value comes from measuring it (`orch calibrate`). |
//! | [`Touch::loudest`] | 100 % | full power for velocity 127. |
//! | [`Touch::hold`] | 35 % | japhillips87 holds at 90/255 (35 %); RCPilot1604 at 50 %. Enough to keep a pressed key down against its spring, a third of the heat. |
use crate::time::Duration;
use crate::values::Velocity;

/// A PWM duty in 4095ths: 0 is off, [`Duty::FULL`] (4095) fully on. The PCA9685's 12 bits;
/// its driver writes 4095 as the chip's "fully on" bit, 0 as "fully off".
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Duty(u16);

impl Duty {
    /// Off.
    pub const OFF: Self = Self(0);
    /// Fully on (100 %).
    pub const FULL: Self = Self(4095);

    /// The duty `value` (0..=4095), or `None` above 4095 (over 100 %).
    pub const fn new(value: u16) -> Option<Self> {
        if value <= 4095 {
            Some(Self(value))
        } else {
            None
        }
    }

    /// `percent` of full power, rounded to the nearest step; `None` outside 0..=100 (or not
    /// a number).
    pub fn from_percent(percent: f32) -> Option<Self> {
        if !(0.0..=100.0).contains(&percent) {
            return None;
        }
        // Rounded half up; `as` saturates, and 0..=100 % maps into 0..=4095.
        Some(Self((percent * 4095.0 / 100.0 + 0.5) as u16))
    }

    /// The duty in 4095ths.
    pub const fn get(self) -> u16 {
        self.0
    }

    /// The duty in per cent of full power.
    pub fn percent(self) -> f32 {
        self.0 as f32 * 100.0 / 4095.0
    }
}

/// How one key plays velocity: its strike duties and its hold duty.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Touch {
    /// The strike duty of velocity 1: the softest duty that sounds on this key.
    pub softest: Duty,
    /// The strike duty of velocity 127.
    pub loudest: Duty,
    /// The duty that holds the key down after the strike, until its release.
    pub hold: Duty,
}

impl Touch {
    /// An on/off key: strike and hold at full power, whatever the velocity.
    pub const FULL: Self = Self {
        softest: Duty::FULL,
        loudest: Duty::FULL,
        hold: Duty::FULL,
    };

    /// The defaults for a key on a PWM board (see the [module docs](self)): 45 % to 100 %,
    /// held at 35 %.
    pub const PWM: Self = Self {
        softest: Duty(1843), // 45 %
        loudest: Duty::FULL,
        hold: Duty(1433), // 35 %
    };

    /// The strike duty of `velocity`: [`softest`](Self::softest) at 1, [`loudest`](Self::loudest)
    /// at 127, linear in between (rounded to the nearest step), never falling; 0 (a Note-Off)
    /// is [`Duty::OFF`].
    pub const fn strike_duty(&self, velocity: Velocity) -> Duty {
        let v = velocity.get() as u32;
        if v == 0 {
            return Duty::OFF;
        }
        let (lo, hi) = (self.softest.0 as u32, self.loudest.0 as u32);
        if hi <= lo {
            return self.softest;
        }
        Duty((lo + ((hi - lo) * (v - 1) + 63) / 126) as u16)
    }

    /// Whether velocity makes no difference and the strike never changes to a lower hold:
    /// an on/off key's touch.
    pub const fn is_full(&self) -> bool {
        self.softest.0 == Duty::FULL.0
            && self.loudest.0 == Duty::FULL.0
            && self.hold.0 == Duty::FULL.0
    }
}

/// How the robot plays a press: the strike time and every key's [`Touch`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Dynamics {
    /// How long the strike duty lasts from the press before the hold duty takes over.
    pub strike: Duration,
    /// Each key's touch, by key (0 = lowest key of the range); keys past the range are unused.
    pub keys: [Touch; 128],
}

impl Dynamics {
    /// The strike time's default: 40 ms (see the [module docs](self)).
    pub const STRIKE: Duration = Duration::from_millis(40);

    /// Every key on/off: the robot without dynamics (the default).
    pub const ON_OFF: Self = Self {
        strike: Self::STRIKE,
        keys: [Touch::FULL; 128],
    };

    /// Every key on a PWM board with the default [`Touch::PWM`].
    pub const PWM: Self = Self {
        strike: Self::STRIKE,
        keys: [Touch::PWM; 128],
    };

    /// Whether every key is on/off ([`Touch::FULL`]): velocity plays no part.
    pub fn is_on_off(&self) -> bool {
        self.keys.iter().all(Touch::is_full)
    }

    /// The touch of `key` ([`Touch::FULL`] past the table).
    #[inline]
    pub fn touch(&self, key: u8) -> Touch {
        self.keys.get(key as usize).copied().unwrap_or(Touch::FULL)
    }

    /// The duty of `key` struck with `velocity`, `age` µs after its press: the strike duty
    /// within the strike time, the hold duty after it.
    #[inline]
    pub fn duty_at(&self, key: u8, velocity: Velocity, age: u32) -> Duty {
        let touch = self.touch(key);
        if age < self.strike.as_micros() {
            touch.strike_duty(velocity)
        } else {
            touch.hold
        }
    }

    /// The energy `key` struck with `velocity` takes in its first `age` µs down, in µs at
    /// full power (a key on at 100 % for 1 ms takes 1 000).
    pub fn energy(&self, key: u8, velocity: Velocity, age: u32) -> u64 {
        let touch = self.touch(key);
        let strike = self.strike.as_micros().min(age) as u64;
        let hold = age.saturating_sub(self.strike.as_micros()) as u64;
        let full = Duty::FULL.0 as u64;
        (strike * touch.strike_duty(velocity).0 as u64 + hold * touch.hold.0 as u64).div_ceil(full)
    }

    /// Checks the settings against `keys` keys and the guard's hold limit.
    pub fn validate(&self, keys: usize, max_hold: Option<Duration>) -> Result<(), DynamicsError> {
        if max_hold.is_some_and(|h| self.strike > h) {
            return Err(DynamicsError::StrikeLongerThanHold);
        }
        for (key, t) in self.keys.iter().enumerate().take(keys) {
            let key = key as u8;
            if t.softest == Duty::OFF {
                return Err(DynamicsError::SilentSoftest { key });
            }
            if t.loudest < t.softest {
                return Err(DynamicsError::CurveFalls { key });
            }
            if t.hold > t.softest {
                return Err(DynamicsError::HoldAboveStrike { key });
            }
        }
        Ok(())
    }
}

impl Default for Dynamics {
    fn default() -> Self {
        Self::ON_OFF
    }
}

/// A [`Dynamics`] the interpreter cannot play (see [`ConfigError::Dynamics`](crate::ConfigError::Dynamics)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DynamicsError {
    /// `key`'s loudest duty is below its softest: its curve falls.
    CurveFalls {
        /// The key (0 = lowest of the range).
        key: u8,
    },
    /// `key`'s hold duty is above its softest strike duty: a hold would push harder than a
    /// soft strike.
    HoldAboveStrike {
        /// The key.
        key: u8,
    },
    /// `key`'s softest duty is 0: velocity 1 would be silence.
    SilentSoftest {
        /// The key.
        key: u8,
    },
    /// The strike time is longer than the guard's hold limit.
    StrikeLongerThanHold,
}

impl core::fmt::Display for DynamicsError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            DynamicsError::CurveFalls { key } => {
                write!(
                    f,
                    "key {key}: the loudest duty is below the softest (the velocity curve falls)"
                )
            }
            DynamicsError::HoldAboveStrike { key } => {
                write!(
                    f,
                    "key {key}: the hold duty is above the softest strike duty"
                )
            }
            DynamicsError::SilentSoftest { key } => {
                write!(
                    f,
                    "key {key}: the softest duty is 0 (velocity 1 would not sound)"
                )
            }
            DynamicsError::StrikeLongerThanHold => {
                f.write_str("the strike time is longer than the guard's hold limit")
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: u8) -> Velocity {
        Velocity::new(x).unwrap()
    }

    #[test]
    fn a_velocity_sweep_never_falls_and_starts_at_the_softest() {
        for touch in [
            Touch::PWM,
            Touch::FULL,
            Touch {
                softest: Duty(1),
                loudest: Duty(4095),
                hold: Duty(0),
            },
        ] {
            assert_eq!(touch.strike_duty(v(1)), touch.softest);
            assert_eq!(touch.strike_duty(v(127)), touch.loudest);
            assert_eq!(touch.strike_duty(v(0)), Duty::OFF);
            let mut last = Duty::OFF;
            for x in 1..=127 {
                let d = touch.strike_duty(v(x));
                assert!(d >= last, "{touch:?}: velocity {x} fell");
                assert!(d >= touch.softest && d <= touch.loudest);
                last = d;
            }
        }
    }

    #[test]
    fn percent_round_trips_and_refuses_over_100() {
        assert_eq!(Duty::from_percent(100.0), Some(Duty::FULL));
        assert_eq!(Duty::from_percent(0.0), Some(Duty::OFF));
        assert_eq!(Duty::from_percent(45.0), Some(Touch::PWM.softest));
        assert_eq!(Duty::from_percent(35.0), Some(Touch::PWM.hold));
        assert_eq!(Duty::from_percent(100.1), None);
        assert_eq!(Duty::from_percent(-1.0), None);
        assert_eq!(Duty::from_percent(f32::NAN), None);
        assert_eq!(Duty::new(4096), None);
    }

    #[test]
    fn energy_counts_strike_then_hold() {
        let d = Dynamics::PWM;
        // 2 s at full power on an on/off key.
        assert_eq!(Dynamics::ON_OFF.energy(0, v(64), 2_000_000), 2_000_000);
        // Velocity 127: 40 ms at 100 %, then 1.96 s at 35 %.
        let e = d.energy(0, v(127), 2_000_000);
        let want = 40_000 + 1_960_000 * 1433 / 4095;
        assert!(e.abs_diff(want) <= 1, "{e} vs {want}");
    }

    #[test]
    fn bad_settings_are_refused_naming_the_key() {
        let mut d = Dynamics::PWM;
        assert_eq!(d.validate(61, Some(Duration::from_secs(10))), Ok(()));
        d.keys[3].loudest = Duty(1000);
        assert_eq!(
            d.validate(61, None),
            Err(DynamicsError::CurveFalls { key: 3 })
        );
        d.keys[3] = Touch::PWM;
        d.keys[60].hold = Duty(2000);
        assert_eq!(
            d.validate(61, None),
            Err(DynamicsError::HoldAboveStrike { key: 60 })
        );
        assert_eq!(d.validate(60, None), Ok(()), "past the range: unused");
        d.keys[60] = Touch::PWM;
        d.keys[0].softest = Duty::OFF;
        d.keys[0].hold = Duty::OFF;
        assert_eq!(
            d.validate(61, None),
            Err(DynamicsError::SilentSoftest { key: 0 })
        );
        d.keys[0] = Touch::PWM;
        d.strike = Duration::from_secs(11);
        assert_eq!(
            d.validate(61, Some(Duration::from_secs(10))),
            Err(DynamicsError::StrikeLongerThanHold)
        );
    }
}
