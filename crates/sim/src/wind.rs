//! A wind robot's fingers and air on the virtual robot: when a note cracks, and how loud it is.
//!
//! A fingered group ([`WindMechanics`]) is a valve and finger solenoids among the robot's keys.
//! [`Mechanics`](crate::Mechanics) moves each of them as any key (the valve sounds its
//! `press_delay` after it opens: the air's rise), and this module adds what only a wind
//! instrument has:
//!
//! - **Finger travel.** A finger that closes its hole is still after its own `press_delay`;
//!   one that lifts, after its `release_delay`. The fingers are **settled** once the last of
//!   them has stopped.
//! - **A crack.** The valve opening before the fingers have settled, or a finger moving while
//!   the valve is open: the air finds holes half closed and the note sounds wrong (a squeak,
//!   another partial) or not at all. The press is [`Press::cracked`](crate::Press::cracked):
//!   no note is heard for it, counted in [`MechanicsStats::cracked`](crate::MechanicsStats).
//! - **Loudness by breath.** A note needs its breath (the valve's duty at full loudness, by
//!   its fingering: high notes need more air). The valve's duty is heard against it: the
//!   duty the valve would have at the note's full breath, `duty × 4095 / breath`, on the
//!   valve's own loudness scale (its `softest` is the quietest breath that still speaks).
//!   Fingers settled on a fingering the table does not name are heard at the duty as is.

use crate::bus::SimTime;

/// One fingering of a [`WindMechanics`]' table.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Breath {
    /// The fingers closed, bit `i` for finger `i`.
    pub fingers: u16,
    /// The note it sounds.
    pub note: u8,
    /// The valve's duty it needs at full loudness, 4095ths.
    pub breath: u16,
}

/// A fingered group of the virtual robot: its valve, its fingers and its table.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct WindMechanics {
    /// The valve's key.
    pub valve: u8,
    /// How many fingers; finger `i` is key `valve + 1 + i`.
    pub fingers: u8,
    /// The fingerings the instrument knows.
    pub table: Vec<Breath>,
}

impl WindMechanics {
    /// Finger `i` of `key`, if it is one of the group's fingers.
    pub fn finger_of(&self, key: u8) -> Option<u8> {
        let i = key.checked_sub(self.valve.checked_add(1)?)?;
        (i < self.fingers).then_some(i)
    }

    /// The table's fingering of `fingers`, if it has one.
    pub fn fingering(&self, fingers: u16) -> Option<Breath> {
        self.table.iter().copied().find(|b| b.fingers == fingers)
    }
}

/// The valve open: whether the note cracked, and the fingering it opened on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Open {
    cracked: bool,
    fingers: u16,
}

/// The group's state as the pins move.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct WindTrack {
    spec: WindMechanics,
    /// The fingers whose pins are high.
    down: u16,
    /// When the last finger's movement ends.
    still_at: SimTime,
    open: Option<Open>,
}

/// What the valve's press was: whether it cracked, and the duty heard for its loudness.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Blown {
    pub cracked: bool,
    pub heard_duty: u16,
}

impl WindTrack {
    pub(crate) fn new(spec: WindMechanics) -> Self {
        Self {
            spec,
            down: 0,
            still_at: SimTime::ZERO,
            open: None,
        }
    }

    /// `key`'s pin changed level at `time`, its movement taking `travel`: a finger moves
    /// (cracking the note if the valve is open), or the valve opens.
    pub(crate) fn moved(
        &mut self,
        time: SimTime,
        key: u8,
        high: bool,
        travel: orch_core::Duration,
    ) {
        if key == self.spec.valve {
            if high {
                self.open = Some(Open {
                    cracked: time < self.still_at,
                    fingers: self.down,
                });
            }
            return;
        }
        let Some(i) = self.spec.finger_of(key) else {
            return;
        };
        if high {
            self.down |= 1 << i;
        } else {
            self.down &= !(1 << i);
        }
        self.still_at = self.still_at.max(time + travel);
        if let Some(open) = &mut self.open {
            open.cracked = true;
        }
    }

    /// The valve closes: its press at `duty` (4095ths) was this.
    pub(crate) fn closed(&mut self, duty: u16) -> Blown {
        let open = self.open.take().unwrap_or(Open {
            cracked: false,
            fingers: self.down,
        });
        let heard_duty = match self.spec.fingering(open.fingers) {
            Some(b) if b.breath > 0 => {
                (u32::from(duty) * 4095 / u32::from(b.breath)).min(4095) as u16
            }
            _ => duty,
        };
        Blown {
            cracked: open.cracked,
            heard_duty,
        }
    }

    /// Whether `key` is the valve.
    pub(crate) fn is_valve(&self, key: u8) -> bool {
        key == self.spec.valve
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use orch_core::Duration;

    fn track() -> WindTrack {
        WindTrack::new(WindMechanics {
            valve: 3,
            fingers: 2,
            table: vec![Breath {
                fingers: 0b11,
                note: 72,
                breath: 2048,
            }],
        })
    }

    #[test]
    fn the_valve_opening_before_the_fingers_are_still_cracks_the_note() {
        let ms = SimTime::from_millis;
        let travel = Duration::from_millis(15);
        let mut t = track();
        t.moved(ms(0), 4, true, travel);
        t.moved(ms(0), 5, true, travel);
        t.moved(ms(15), 3, true, travel); // still at 15: clean
        let b = t.closed(2048);
        assert!(!b.cracked);
        assert_eq!(b.heard_duty, 4095, "its full breath is full loudness");
        assert_eq!(t.closed(1024).heard_duty, 2047);
        t.moved(ms(100), 5, false, travel);
        t.moved(ms(114), 3, true, travel); // one ms early
        assert!(t.closed(4095).cracked);
        t.moved(ms(200), 3, true, travel);
        t.moved(ms(300), 4, false, travel); // a finger moves while it sounds
        assert!(t.closed(4095).cracked);
    }
}
