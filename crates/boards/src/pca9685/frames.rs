//! The bytes of each PCA9685 transaction and the per-channel cache, in one place for the
//! blocking [`Pca9685`](crate::Pca9685) and the async `Pca9685Async`: pure functions, no bus.

use super::registers::{
    led_on_l, AI, ALL_LED_OFF_H, FULL_ON_OFF, MODE1, MODE2, OUTDRV, PRE_SCALE, RESTART, SLEEP,
};
use super::{Prescale, CHANNELS, FULL_ON, MAX_DUTY, PHASE_STEP};
use crate::Error;

/// `[ALL_LED_OFF_H, FULL_ON_OFF]`: every channel fully off, in one 2-byte write that works
/// with or without auto-increment.
pub(crate) const ALL_OFF: [u8; 2] = [ALL_LED_OFF_H, FULL_ON_OFF];
/// `MODE1` asleep (oscillator off, every output off), auto-increment on, no sub or all-call
/// addresses.
pub(crate) const MODE1_SLEEP: [u8; 2] = [MODE1, SLEEP | AI];
/// `MODE1` awake with auto-increment.
pub(crate) const MODE1_AWAKE: [u8; 2] = [MODE1, AI];
/// `MODE1` awake with auto-increment, and a 1 in `RESTART`: restarts the channels a sleep held.
pub(crate) const MODE1_RESTART: [u8; 2] = [MODE1, RESTART | AI];
/// `MODE2`: totem-pole outputs (a MOSFET gate is driven both ways; the data sheet's table 11
/// optimum for an N-type driver), not inverted, outputs change at the STOP (so a multi-channel write changes every channel at once), every output
/// 0 while `OE` is high (`OUTNE` = 00).
pub(crate) const MODE2_SETTING: [u8; 2] = [MODE2, OUTDRV];
/// The command byte before a one-byte read of `MODE1`.
pub(crate) const READ_MODE1: [u8; 1] = [MODE1];

/// `[PRE_SCALE, value]`.
pub(crate) const fn pre_scale(prescale: Prescale) -> [u8; 2] {
    [PRE_SCALE, prescale.value()]
}

/// Channel `channel`'s four registers for `duty` (0..=4095, checked by the caller):
/// `[ON_L, ON_H, OFF_L, OFF_H]`. 0 is full OFF, [`FULL_ON`] full ON; anything between goes
/// high at the channel's phase (`channel × PHASE_STEP`) and low `duty` counts later, modulo
/// the 4096-count period.
pub(crate) const fn counts(channel: u8, duty: u16) -> [u8; 4] {
    if duty == 0 {
        [0, 0, 0, FULL_ON_OFF]
    } else if duty >= FULL_ON {
        [0, FULL_ON_OFF, 0, 0]
    } else {
        let on = (channel as u16 * PHASE_STEP) % 4096;
        let off = (on + duty) % 4096;
        let [on_l, on_h] = on.to_le_bytes();
        let [off_l, off_h] = off.to_le_bytes();
        [on_l, on_h, off_l, off_h]
    }
}

/// One channel's write: `[LEDn_ON_L, ON_L, ON_H, OFF_L, OFF_H]` (needs auto-increment).
pub(crate) const fn channel(channel: u8, duty: u16) -> [u8; 5] {
    let [a, b, c, d] = counts(channel, duty);
    [led_on_l(channel), a, b, c, d]
}

/// A run of channels in one auto-increment write: `[LEDfirst_ON_L, 4 bytes a channel…]`.
pub(crate) struct Span {
    buf: [u8; 1 + 4 * CHANNELS],
    len: usize,
}

impl Span {
    /// The bytes of the write.
    pub(crate) fn bytes(&self) -> &[u8] {
        &self.buf[..self.len]
    }
}

/// The write of `duties` to channels `first`, `first + 1`, … (at most 16 in all).
pub(crate) fn span(first: u8, duties: &[u16]) -> Span {
    let mut buf = [0; 1 + 4 * CHANNELS];
    buf[0] = led_on_l(first);
    for (i, &duty) in duties.iter().enumerate() {
        let c = counts(first + i as u8, duty);
        buf[1 + 4 * i..5 + 4 * i].copy_from_slice(&c);
    }
    Span {
        buf,
        len: 1 + 4 * duties.len(),
    }
}

/// What the driver knows of the chip: each channel's duty as last written successfully
/// (`None`: unknown, so the next write goes out), and the prescale `init` set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct State {
    pub(crate) duties: [Option<u16>; CHANNELS],
    pub(crate) prescale: Option<Prescale>,
}

impl State {
    pub(crate) const UNKNOWN: Self = Self {
        duties: [None; CHANNELS],
        prescale: None,
    };

    /// Refuses a channel past 15 or a duty past 4095.
    pub(crate) fn check<E>(channel: u8, duty: u16) -> Result<(), Error<E>> {
        if usize::from(channel) >= CHANNELS {
            return Err(Error::UnknownChannel(channel));
        }
        if duty > MAX_DUTY {
            return Err(Error::DutyOutOfRange { channel, duty });
        }
        Ok(())
    }

    /// The write that sets `channel` to `duty`, or `None` when the cache says it holds it.
    pub(crate) fn plan_duty<E>(&self, channel: u8, duty: u16) -> Result<Option<[u8; 5]>, Error<E>> {
        Self::check(channel, duty)?;
        if self.duties[usize::from(channel)] == Some(duty) {
            return Ok(None);
        }
        Ok(Some(self::channel(channel, duty)))
    }

    /// The first and last channel whose duty differs from the cache, and the one write that
    /// sets that run; `None` when nothing changed.
    pub(crate) fn plan_duties<E>(
        &self,
        duties: &[u16; CHANNELS],
    ) -> Result<Option<(usize, usize, Span)>, Error<E>> {
        for (channel, &duty) in duties.iter().enumerate() {
            Self::check(channel as u8, duty)?;
        }
        let changed = |i: &usize| self.duties[*i] != Some(duties[*i]);
        let Some(first) = (0..CHANNELS).find(changed) else {
            return Ok(None);
        };
        let last = (0..CHANNELS).rev().find(changed).unwrap_or(first);
        Ok(Some((
            first,
            last,
            span(first as u8, &duties[first..=last]),
        )))
    }

    /// Before a write to channels `first..=last`: forget them (a failed write leaves them
    /// unknown).
    pub(crate) fn forget(&mut self, first: usize, last: usize) {
        self.duties[first..=last].iter_mut().for_each(|d| *d = None);
    }

    /// After a successful write of `duties` to channels from `first` on.
    pub(crate) fn commit(&mut self, first: usize, duties: &[u16]) {
        for (slot, &d) in self.duties[first..].iter_mut().zip(duties) {
            *slot = Some(d);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn duty_0_is_full_off_4095_full_on_between_is_phase_shifted() {
        assert_eq!(channel(0, 0), [0x06, 0, 0, 0, 0x10]);
        assert_eq!(channel(0, 4095), [0x06, 0, 0x10, 0, 0]);
        assert_eq!(channel(0, 1), [0x06, 0, 0, 1, 0]);
        assert_eq!(channel(0, 4094), [0x06, 0, 0, 0xFE, 0x0F]);
        // Channel 1 goes high at count 256 and low 2048 counts later, at 2304 (0x900).
        assert_eq!(channel(1, 2048), [0x0A, 0x00, 0x01, 0x00, 0x09]);
        // Channel 15 goes high at 3840 (0xF00): 1000 counts later wraps to 744 (0x2E8).
        assert_eq!(channel(15, 1000), [0x42, 0x00, 0x0F, 0xE8, 0x02]);
    }

    #[test]
    fn span_is_the_channels_registers_in_a_row() {
        let s = span(2, &[0, 4095, 100]);
        assert_eq!(s.bytes().len(), 13);
        assert_eq!(s.bytes()[0], 0x0E);
        assert_eq!(&s.bytes()[1..5], &counts(2, 0));
        assert_eq!(&s.bytes()[5..9], &counts(3, 4095));
        assert_eq!(&s.bytes()[9..13], &counts(4, 100));
        assert_eq!(span(0, &[0; 16]).bytes().len(), 65);
    }

    #[test]
    fn plan_duties_writes_only_the_changed_run() {
        let mut state = State::UNKNOWN;
        state.commit(0, &[0; 16]);
        let mut duties = [0; 16];
        assert!(state.plan_duties::<()>(&duties).unwrap().is_none());
        duties[3] = 10;
        duties[6] = 20;
        let (first, last, s) = state.plan_duties::<()>(&duties).unwrap().unwrap();
        assert_eq!((first, last, s.bytes().len()), (3, 6, 17));
        let mut bad = [0; 16];
        bad[15] = 4096;
        assert!(matches!(
            state.plan_duties::<()>(&bad),
            Err(Error::DutyOutOfRange {
                channel: 15,
                duty: 4096
            })
        ));
    }
}
