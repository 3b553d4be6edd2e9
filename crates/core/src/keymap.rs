//! From a MIDI note to a key, and from a key to a finger: board and bit.
//!
//! The default is the thesis's robot: notes 36..=96 (C2..C7, 61 keys), out-of-range notes
//! folded by octaves into range, and key `k = note − 36` on board `k / 16`, bit `k % 16`, with
//! boards of 16, 16, 16 and 13 keys at I2C addresses 0x21..=0x24.

use crate::values::Note;

/// What to do with a note outside the key range.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum OutOfRange {
    /// Move it by whole octaves until it is in range, as the thesis's interpreter did.
    #[default]
    Fold,
    /// Do not play it.
    Drop,
}

/// The notes the instrument has keys for: `low..=high`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct KeyRange {
    low: u8,
    high: u8,
}

impl KeyRange {
    /// The thesis's 61-key keyboard, C2..=C7.
    pub const THESIS: Self = Self { low: 36, high: 96 };

    /// The range `low..=high`, if `low <= high`.
    pub const fn new(low: Note, high: Note) -> Option<Self> {
        if low.get() <= high.get() {
            Some(Self {
                low: low.get(),
                high: high.get(),
            })
        } else {
            None
        }
    }

    /// The lowest note with a key.
    pub const fn low(self) -> Note {
        Note::from_bits(self.low)
    }

    /// The highest note with a key.
    pub const fn high(self) -> Note {
        Note::from_bits(self.high)
    }

    /// How many keys: `high − low + 1`.
    pub const fn keys(self) -> usize {
        (self.high - self.low) as usize + 1
    }

    /// The key that plays `note`, or `None` if the note is dropped.
    ///
    /// Folding needs a range of at least an octave (12 keys) to land every note; with a
    /// narrower range a note whose pitch class has no key is dropped.
    #[inline]
    pub const fn key_for(self, note: Note, policy: OutOfRange) -> Option<KeyOf> {
        // Most notes are in range: one subtraction and compare (an 8-bit MCU does this on
        // every note message); folding, out of line.
        let key = note.get().wrapping_sub(self.low);
        if key <= self.high - self.low {
            return Some(KeyOf { key, octaves: 0 });
        }
        self.fold(note, policy)
    }

    /// [`key_for`](Self::key_for) for a note outside the range: moved by whole octaves to the
    /// nearest one inside (8-bit arithmetic and a division by a constant: the loops it replaces
    /// became 32-bit multiplications on an 8-bit MCU).
    #[inline(never)]
    // `(x + 11) / 12`, not `div_ceil`: 32 bytes smaller on the AVR.
    #[allow(clippy::manual_div_ceil)]
    const fn fold(self, note: Note, policy: OutOfRange) -> Option<KeyOf> {
        let n = note.get();
        if n >= self.low && n <= self.high {
            return Some(KeyOf {
                key: n - self.low,
                octaves: 0,
            });
        }
        if let OutOfRange::Drop = policy {
            return None;
        }
        if n < self.low {
            // The fewest octaves up that reach the range (n + 12 · up < low + 12 ≤ 139).
            let up = (self.low - n + 11) / 12;
            let m = n + 12 * up;
            if m > self.high {
                return None; // a range narrower than an octave has no key for this note
            }
            Some(KeyOf {
                key: m - self.low,
                octaves: up as i8,
            })
        } else {
            // The fewest octaves down that reach the range.
            let down = (n - self.high + 11) / 12;
            match n.checked_sub(12 * down) {
                Some(m) if m >= self.low => Some(KeyOf {
                    key: m - self.low,
                    octaves: -(down as i8),
                }),
                _ => None,
            }
        }
    }

    /// Calls `f` with every note that `key` plays under `policy` (at most 11 of them).
    pub fn notes_of(self, key: u8, policy: OutOfRange, mut f: impl FnMut(Note)) {
        let note = self.low as u16 + key as u16;
        if note > self.high as u16 {
            return;
        }
        match policy {
            OutOfRange::Drop => f(Note::from_bits(note as u8)),
            OutOfRange::Fold => {
                let mut n = note % 12;
                while n <= 127 {
                    let candidate = Note::from_bits(n as u8);
                    if let Some(k) = self.key_for(candidate, policy) {
                        if k.key == key {
                            f(candidate);
                        }
                    }
                    n += 12;
                }
            }
        }
    }
}

impl Default for KeyRange {
    fn default() -> Self {
        Self::THESIS
    }
}

/// The key a note lands on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct KeyOf {
    /// Key index, 0 for the lowest key of the range.
    pub key: u8,
    /// Octaves the note was moved by: positive up, negative down, 0 if in range.
    pub octaves: i8,
}

/// One finger board's share of the keys.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BoardSpan {
    /// The board's 7-bit I2C address.
    pub address: u8,
    /// How many consecutive keys it drives.
    pub keys: u8,
    /// The output bit of its first key; the next keys take the following bits.
    pub first_bit: u8,
}

/// Where each key's finger is: `B` boards, each driving a run of consecutive keys.
///
/// Keys are dealt out in order: the first `boards[0].keys` keys to board 0, and so on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Layout<const B: usize> {
    /// The boards, in key order.
    pub boards: [BoardSpan; B],
}

impl Layout<4> {
    /// The thesis's robot: 16/16/16/13 keys on boards 0x21..=0x24, from bit 0.
    pub const THESIS: Self = Self {
        boards: [
            BoardSpan {
                address: 0x21,
                keys: 16,
                first_bit: 0,
            },
            BoardSpan {
                address: 0x22,
                keys: 16,
                first_bit: 0,
            },
            BoardSpan {
                address: 0x23,
                keys: 16,
                first_bit: 0,
            },
            BoardSpan {
                address: 0x24,
                keys: 13,
                first_bit: 0,
            },
        ],
    };
}

impl Default for Layout<4> {
    fn default() -> Self {
        Self::THESIS
    }
}

/// A finger: the board (index into the layout) and its output bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Finger {
    /// Index of the board in the layout.
    pub board: u8,
    /// Output bit, 0..=15 (0..=7 port 0, 8..=15 port 1).
    pub bit: u8,
}

impl<const B: usize> Layout<B> {
    /// Every board 16 keys from bit 0, at `addresses`, as long as `keys` lasts.
    pub const fn sequential(addresses: [u8; B], mut keys: usize) -> Self {
        let mut boards = [BoardSpan {
            address: 0,
            keys: 0,
            first_bit: 0,
        }; B];
        let mut i = 0;
        while i < B {
            let n = if keys > 16 { 16 } else { keys };
            boards[i] = BoardSpan {
                address: addresses[i],
                keys: n as u8,
                first_bit: 0,
            };
            keys -= n;
            i += 1;
        }
        Self { boards }
    }

    /// The total number of keys the boards drive.
    pub const fn keys(&self) -> usize {
        let mut total = 0;
        let mut i = 0;
        while i < B {
            total += self.boards[i].keys as usize;
            i += 1;
        }
        total
    }

    /// The finger of `key`, or `None` past the last board.
    pub const fn finger(&self, key: u8) -> Option<Finger> {
        let mut first = 0u16;
        let mut i = 0;
        while i < B {
            let span = self.boards[i];
            if (key as u16) < first + span.keys as u16 {
                return Some(Finger {
                    board: i as u8,
                    bit: span.first_bit + (key as u16 - first) as u8,
                });
            }
            first += span.keys as u16;
            i += 1;
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The octave steps one by one, as the fold was first written: the reference.
    fn fold_by_steps(r: KeyRange, note: u8, policy: OutOfRange) -> Option<KeyOf> {
        let (low, high) = (r.low as i16, r.high as i16);
        let mut n = note as i16;
        let mut octaves: i8 = 0;
        if policy == OutOfRange::Drop && (n < low || n > high) {
            return None;
        }
        while n < low {
            n += 12;
            octaves += 1;
        }
        while n > high {
            n -= 12;
            octaves -= 1;
        }
        (n >= low).then_some(KeyOf {
            key: (n - low) as u8,
            octaves,
        })
    }

    #[test]
    fn every_note_folds_into_every_range_as_octave_steps_would() {
        for low in 0..=127u8 {
            for high in low..=127u8 {
                let r = KeyRange { low, high };
                for note in 0..=127u8 {
                    for policy in [OutOfRange::Fold, OutOfRange::Drop] {
                        assert_eq!(
                            r.key_for(Note::from_bits(note), policy),
                            fold_by_steps(r, note, policy),
                            "{low}..={high}, note {note}, {policy:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn folding_lands_notes_0_and_127_on_their_octave() {
        let r = KeyRange::THESIS;
        assert_eq!(
            r.key_for(Note::from_bits(0), OutOfRange::Fold),
            Some(KeyOf { key: 0, octaves: 3 })
        );
        assert_eq!(
            r.key_for(Note::from_bits(127), OutOfRange::Fold),
            Some(KeyOf {
                key: 55,
                octaves: -3
            })
        );
        assert_eq!(
            r.key_for(Note::from_bits(96), OutOfRange::Fold),
            Some(KeyOf {
                key: 60,
                octaves: 0
            })
        );
        assert_eq!(r.key_for(Note::from_bits(35), OutOfRange::Drop), None);
    }

    #[test]
    fn notes_of_a_key_are_its_preimage() {
        let r = KeyRange::THESIS;
        let mut seen = [false; 128];
        r.notes_of(0, OutOfRange::Fold, |n| seen[n.get() as usize] = true);
        let expected: [u8; 3] = [0, 12, 24];
        for n in 0..128u8 {
            let folded_here = expected.contains(&n) || n == 36;
            assert_eq!(seen[n as usize], folded_here, "note {n}");
        }
    }

    #[test]
    fn thesis_layout_puts_note_76_on_bit_8_of_the_third_board() {
        let f = Layout::THESIS.finger(76 - 36).unwrap();
        assert_eq!((f.board, f.bit), (2, 8));
        assert_eq!(Layout::THESIS.finger(61), None);
        assert_eq!(Layout::THESIS.keys(), 61);
    }

    #[test]
    fn narrow_range_drops_pitch_classes_it_lacks() {
        let r = KeyRange::new(Note::from_bits(60), Note::from_bits(64)).unwrap();
        assert_eq!(
            r.key_for(Note::from_bits(48), OutOfRange::Fold)
                .map(|k| k.key),
            Some(0)
        );
        assert_eq!(r.key_for(Note::from_bits(67), OutOfRange::Fold), None);
    }
}
