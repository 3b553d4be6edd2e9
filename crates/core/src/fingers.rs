//! Per-key physical state: which fingers are down, waiting or resting, since when.
//!
//! This is the safety guard's memory. Each key is in one of four phases:
//!
//! ```text
//!            press (gap passed)             release
//!   Ready ───────────────────────▶ Down ───────────────▶ Releasing ──(gap passes)──▶ Ready
//!                                   ▲                        │
//!                                   │ gap passes             │ press before the gap has passed
//!                                   └────── Pending ◀────────┘
//! ```
//!
//! A note released while its key is `Pending` still strikes when the gap has passed, and is
//! released again after the guard's `min_press` (flag `RELEASE_AFTER`).
//!
//! Times are kept per key as the low 32 bits of the microsecond clock (4 bytes a key instead
//! of 8). An age is `now − stamp` in wrapping arithmetic; ages are clamped to [`AGE_CAP`]
//! (35 minutes) before they could wrap, which is safe because every guard limit is at most
//! 30 minutes ([`MAX_LIMIT`](crate::MAX_LIMIT)).

use crate::bits::bit8;

/// The age every stamp is clamped to: 2³¹ µs, about 35.8 minutes.
pub(crate) const AGE_CAP: u32 = 1 << 31;

pub(crate) const READY: u8 = 0;
pub(crate) const RELEASING: u8 = 1;
pub(crate) const PENDING: u8 = 2;
pub(crate) const DOWN: u8 = 3;
const PHASE: u8 = 0b11;
/// The note waiting in `PENDING` was folded.
pub(crate) const FOLDED: u8 = 0b1000;
/// The note of a delayed strike was released before it struck: release after `min_press`.
pub(crate) const RELEASE_AFTER: u8 = 0b1_0000;
/// The key struck late (after waiting for its re-strike gap): it is held at least `min_press`.
pub(crate) const LATE: u8 = 0b10_0000;

/// The most keys the timed-key mask covers: every note of MIDI has at most one key.
const MASK_KEYS: usize = 128;

/// Physical state of `K` keys: 8 bytes a key (6 without the `duty-limit` feature), and a
/// 16-byte mask of the keys whose timers run.
#[derive(Clone, Debug)]
pub(crate) struct Fingers<const K: usize> {
    flags: [u8; K],
    /// One bit a key: set while the key is `DOWN` or `PENDING` (the only phases with a
    /// timer), so the guard visits those keys only. A key range has at most 128 keys.
    timed: [u8; MASK_KEYS / 8],
    stamp: [u32; K],
    velocity: [u8; K],
    /// The duty limit's heat, in ms (see [`DutyLimit`](crate::DutyLimit)), as of the key's
    /// last press or release.
    #[cfg(feature = "duty-limit")]
    heat: [u16; K],
    /// Keys in `DOWN`.
    pub down: u8,
    /// Keys in `PENDING`.
    pub pending: u8,
}

impl<const K: usize> Fingers<K> {
    pub const fn new() -> Self {
        Self {
            flags: [READY; K],
            timed: [0; MASK_KEYS / 8],
            stamp: [0; K],
            velocity: [0; K],
            #[cfg(feature = "duty-limit")]
            heat: [0; K],
            down: 0,
            pending: 0,
        }
    }

    pub fn phase(&self, key: u8) -> u8 {
        self.flags[key as usize] & PHASE
    }

    pub fn has(&self, key: u8, flag: u8) -> bool {
        self.flags[key as usize] & flag != 0
    }

    pub fn set_flag(&mut self, key: u8, flag: u8, on: bool) {
        if on {
            self.flags[key as usize] |= flag;
        } else {
            self.flags[key as usize] &= !flag;
        }
    }

    pub fn velocity(&self, key: u8) -> u8 {
        self.velocity[key as usize]
    }

    /// Microseconds since the key's stamp at `now` (the low 32 bits of the clock), at most
    /// [`AGE_CAP`].
    pub fn age(&self, key: u8, now: u32) -> u32 {
        let age = now.wrapping_sub(self.stamp[key as usize]);
        // `age.min(AGE_CAP)`: the cap is 2³¹, so the sign bit says it (one bit test on an
        // 8-bit MCU, not a 32-bit compare and select).
        if (age as i32) < 0 {
            AGE_CAP
        } else {
            age
        }
    }

    /// Moves `key` to `phase`, stamped `now` (the low 32 bits of the clock), keeping the
    /// down/pending counts.
    pub fn enter(&mut self, key: u8, phase: u8, now: u32) {
        self.set_phase(key, phase);
        self.stamp[key as usize] = now;
    }

    /// Moves `key` to `phase` without touching its stamp.
    pub fn set_phase(&mut self, key: u8, phase: u8) {
        let k = key as usize;
        match self.flags[k] & PHASE {
            DOWN => self.down -= 1,
            PENDING => self.pending -= 1,
            _ => {}
        }
        match phase {
            DOWN => self.down += 1,
            PENDING => self.pending += 1,
            _ => {}
        }
        let bit = bit8(key);
        let keep = if phase == DOWN || phase == PENDING {
            self.timed[k / 8 % (MASK_KEYS / 8)] |= bit;
            self.flags[k] & (FOLDED | RELEASE_AFTER | LATE)
        } else {
            self.timed[k / 8 % (MASK_KEYS / 8)] &= !bit;
            0
        };
        self.flags[k] = phase | keep;
    }

    /// The first key from `from` on that is `DOWN` or `PENDING`, in key order.
    pub fn next_timed(&self, from: u8) -> Option<u8> {
        let end = K.min(MASK_KEYS);
        let mut k = from as usize;
        while k < end {
            // The bits of keys `k` and up in `k`'s byte (no shift by `k % 8`: see `bits`).
            let bits = self.timed[k / 8] & bit8(k as u8).wrapping_neg();
            if bits == 0 {
                k = (k | 7) + 1;
            } else {
                k = (k & !7) + bits.trailing_zeros() as usize;
                return (k < end).then_some(k as u8);
            }
        }
        None
    }

    #[cfg(feature = "duty-limit")]
    pub fn heat_ms(&self, key: u8) -> u16 {
        self.heat[key as usize]
    }

    #[cfg(feature = "duty-limit")]
    pub fn set_heat_ms(&mut self, key: u8, heat: u64) {
        self.heat[key as usize] = heat.min(u16::MAX as u64) as u16;
    }

    #[cfg(not(feature = "duty-limit"))]
    pub fn heat_ms(&self, _key: u8) -> u16 {
        0
    }

    #[cfg(not(feature = "duty-limit"))]
    pub fn set_heat_ms(&mut self, _key: u8, _heat: u64) {}

    pub fn set_velocity(&mut self, key: u8, velocity: u8) {
        self.velocity[key as usize] = velocity;
    }

    /// Clamps every stamp older than [`AGE_CAP`] at `before`, then at `now` (the low 32 bits
    /// of the clock before and after it passed a multiple of 2³⁰ µs), so that no age can
    /// wrap. With `far`, every stamp is taken as at least that old at `now` (the clock jumped
    /// by more than the cap). One pass over the keys.
    pub fn clamp_ages(&mut self, before: u32, now: u32, far: bool) {
        for stamp in self.stamp.iter_mut() {
            *stamp = clamp_across(*stamp, before, now, far);
        }
    }
}

/// A stamp after the clock passed a multiple of 2³⁰ µs from `before` to `now` (see
/// [`Fingers::clamp_ages`]): clamped at `before`, then at `now`, or, with `far`, as old as the
/// cap at `now`. Out of line: it runs every 18 minutes, and its 32-bit compares are large on
/// an 8-bit MCU, so the keys and the last input's time share one copy.
#[inline(never)]
pub(crate) fn clamp_across(stamp: u32, before: u32, now: u32, far: bool) -> u32 {
    if far {
        now.wrapping_sub(AGE_CAP)
    } else {
        clamp_stamp(clamp_stamp(stamp, before), now)
    }
}

/// `stamp`, or `at − AGE_CAP` if it is older than that at `at`.
#[inline(always)]
fn clamp_stamp(stamp: u32, at: u32) -> u32 {
    if at.wrapping_sub(stamp) >= AGE_CAP {
        at.wrapping_sub(AGE_CAP)
    } else {
        stamp
    }
}
