//! Which notes are holding keys: the record that makes release exact.
//!
//! A key goes up only when every note holding it has been released, so the interpreter keeps
//! every (channel, note) that is on. Two stores implement [`HeldNotes`]:
//!
//! - [`NoteTable`] (the default): two channel masks (played, sustained) for each of the 128
//!   notes, 512 bytes. Exact for any number of notes held at once; the host's choice.
//! - [`NotePool`]: up to `N` held notes, 3 bytes each, for small MCUs. A Note-On that finds
//!   the pool full is refused like one past the power budget. With `N` at least twice the
//!   guard's `max_keys_down` it is never the limit in practice, since a note is only kept
//!   while its key is down or about to be.

use crate::keymap::{KeyRange, OutOfRange};
use crate::values::{Channel, Note};

/// A store of the (channel, note) pairs that hold keys, with the key each one holds.
///
/// A note holds its key while it is on (played), and after its Note-Off while its channel's
/// sustain pedal is down (sustained).
pub trait HeldNotes: Clone + core::fmt::Debug {
    /// An empty store.
    const EMPTY: Self;

    /// Whether `note` is on (played, not only sustained) on `channel`.
    fn contains(&self, channel: Channel, note: Note) -> bool;

    /// Records `note` as on on `channel`, holding `key` (a sustained note becomes played
    /// again). Returns `false` if the store is full.
    fn insert(&mut self, channel: Channel, note: Note, key: u8) -> bool;

    /// Forgets `note` on `channel`. Returns whether it was on.
    fn remove(&mut self, channel: Channel, note: Note) -> bool;

    /// Marks the played `note` on `channel` as held by the pedal. Returns whether it was on.
    fn sustain(&mut self, channel: Channel, note: Note) -> bool;

    /// Forgets every note of `channel` that only the pedal holds.
    fn release_sustained(&mut self, channel: Channel);

    /// Marks every played note of `channel` as held by the pedal (All Notes Off while the
    /// pedal is down).
    fn sustain_channel(&mut self, channel: Channel);

    /// Forgets every note of `channel`, played or sustained.
    fn remove_channel(&mut self, channel: Channel);

    /// Forgets every note holding `key`.
    fn remove_key(&mut self, key: u8, range: KeyRange, policy: OutOfRange);

    /// Whether a note holds `key`: a played one, or with `sustained` a sustained one too.
    fn holds_key(&self, key: u8, range: KeyRange, policy: OutOfRange, sustained: bool) -> bool;

    /// Forgets everything.
    fn clear(&mut self);
}

/// Every note on every channel: for each of the 128 notes a mask of the channels playing it
/// and one of the channels sustaining it, 512 bytes. Exact under any load.
#[derive(Clone, Debug)]
pub struct NoteTable {
    played: [u16; 128],
    sustained: [u16; 128],
}

impl HeldNotes for NoteTable {
    const EMPTY: Self = Self {
        played: [0; 128],
        sustained: [0; 128],
    };

    fn contains(&self, channel: Channel, note: Note) -> bool {
        self.played[note.get() as usize] & channel.bit() != 0
    }

    fn insert(&mut self, channel: Channel, note: Note, _key: u8) -> bool {
        self.played[note.get() as usize] |= channel.bit();
        self.sustained[note.get() as usize] &= !channel.bit();
        true
    }

    fn remove(&mut self, channel: Channel, note: Note) -> bool {
        let slot = &mut self.played[note.get() as usize];
        let was = *slot & channel.bit() != 0;
        *slot &= !channel.bit();
        was
    }

    fn sustain(&mut self, channel: Channel, note: Note) -> bool {
        let was = self.remove(channel, note);
        if was {
            self.sustained[note.get() as usize] |= channel.bit();
        }
        was
    }

    fn release_sustained(&mut self, channel: Channel) {
        for slot in self.sustained.iter_mut() {
            *slot &= !channel.bit();
        }
    }

    fn sustain_channel(&mut self, channel: Channel) {
        for (p, s) in self.played.iter_mut().zip(self.sustained.iter_mut()) {
            if *p & channel.bit() != 0 {
                *p &= !channel.bit();
                *s |= channel.bit();
            }
        }
    }

    fn remove_channel(&mut self, channel: Channel) {
        for (p, s) in self.played.iter_mut().zip(self.sustained.iter_mut()) {
            *p &= !channel.bit();
            *s &= !channel.bit();
        }
    }

    fn remove_key(&mut self, key: u8, range: KeyRange, policy: OutOfRange) {
        range.notes_of(key, policy, |n| {
            self.played[n.get() as usize] = 0;
            self.sustained[n.get() as usize] = 0;
        });
    }

    fn holds_key(&self, key: u8, range: KeyRange, policy: OutOfRange, sustained: bool) -> bool {
        let mut held = false;
        range.notes_of(key, policy, |n| {
            let i = n.get() as usize;
            held |= self.played[i] != 0 || (sustained && self.sustained[i] != 0);
        });
        held
    }

    fn clear(&mut self) {
        self.played = [0; 128];
        self.sustained = [0; 128];
    }
}

/// Up to `N` held notes, 3 bytes each, for MCUs with little RAM.
#[derive(Clone, Debug)]
pub struct NotePool<const N: usize> {
    /// The note of each held note…
    notes: [u8; N],
    /// … its channel, with [`SUSTAINED`] set if only the pedal holds it (a byte each, so that
    /// a search compares bytes: no shifts or 16-bit compares on an 8-bit MCU)…
    channels: [u8; N],
    /// … and the key it holds.
    keys: [u8; N],
    len: u8,
}

/// The channel byte's bit of a note that only the sustain pedal holds.
const SUSTAINED: u8 = 0x80;

impl<const N: usize> NotePool<N> {
    #[inline]
    fn find(&self, channel: Channel, note: Note) -> Option<usize> {
        let (channel, note) = (channel.get(), note.get());
        (0..self.len as usize)
            .find(|&i| self.notes[i] == note && self.channels[i] & !SUSTAINED == channel)
    }

    fn retain(&mut self, mut keep: impl FnMut(u8, u8) -> bool) {
        let mut i = 0;
        while i < self.len as usize {
            if keep(self.channels[i], self.keys[i]) {
                i += 1;
            } else {
                self.remove_at(i);
            }
        }
    }

    /// Forgets the note at `i`: the last one takes its place.
    fn remove_at(&mut self, i: usize) {
        let last = self.len as usize - 1;
        self.notes[i] = self.notes[last];
        self.channels[i] = self.channels[last];
        self.keys[i] = self.keys[last];
        self.len -= 1;
    }
}

impl<const N: usize> HeldNotes for NotePool<N> {
    const EMPTY: Self = Self {
        notes: [0; N],
        channels: [0; N],
        keys: [0; N],
        len: 0,
    };

    fn contains(&self, channel: Channel, note: Note) -> bool {
        self.find(channel, note)
            .is_some_and(|i| self.channels[i] & SUSTAINED == 0)
    }

    fn insert(&mut self, channel: Channel, note: Note, key: u8) -> bool {
        if let Some(i) = self.find(channel, note) {
            self.channels[i] &= !SUSTAINED;
            return true;
        }
        let i = self.len as usize;
        if i >= N || i >= u8::MAX as usize {
            return false;
        }
        self.notes[i] = note.get();
        self.channels[i] = channel.get();
        self.keys[i] = key;
        self.len += 1;
        true
    }

    fn remove(&mut self, channel: Channel, note: Note) -> bool {
        let Some(i) = self.find(channel, note) else {
            return false;
        };
        let was = self.channels[i] & SUSTAINED == 0;
        self.remove_at(i);
        was
    }

    fn sustain(&mut self, channel: Channel, note: Note) -> bool {
        match self.find(channel, note) {
            Some(i) if self.channels[i] & SUSTAINED == 0 => {
                self.channels[i] |= SUSTAINED;
                true
            }
            _ => false,
        }
    }

    fn release_sustained(&mut self, channel: Channel) {
        self.retain(|c, _| c != channel.get() | SUSTAINED);
    }

    fn sustain_channel(&mut self, channel: Channel) {
        for c in &mut self.channels[..self.len as usize] {
            if *c & !SUSTAINED == channel.get() {
                *c |= SUSTAINED;
            }
        }
    }

    fn remove_channel(&mut self, channel: Channel) {
        self.retain(|c, _| c & !SUSTAINED != channel.get());
    }

    fn remove_key(&mut self, key: u8, _range: KeyRange, _policy: OutOfRange) {
        self.retain(|_, k| k != key);
    }

    fn holds_key(&self, key: u8, _range: KeyRange, _policy: OutOfRange, sustained: bool) -> bool {
        (0..self.len as usize)
            .any(|i| self.keys[i] == key && (sustained || self.channels[i] & SUSTAINED == 0))
    }

    fn clear(&mut self) {
        self.len = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ch(c: u8) -> Channel {
        Channel::new(c).unwrap()
    }
    fn n(x: u8) -> Note {
        Note::new(x).unwrap()
    }

    /// The two stores answer alike while the pool has room.
    fn exercise<H: HeldNotes>() -> [bool; 8] {
        let r = KeyRange::THESIS;
        let p = OutOfRange::Fold;
        let mut h = H::EMPTY;
        h.insert(ch(0), n(24), 0);
        h.insert(ch(1), n(36), 0);
        h.insert(ch(1), n(60), 24);
        let a = h.holds_key(0, r, p, false);
        h.remove_channel(ch(1));
        let b = h.holds_key(0, r, p, false);
        let c = h.holds_key(24, r, p, false);
        let d = h.remove(ch(0), n(24));
        let e = h.remove(ch(0), n(24));
        h.insert(ch(3), n(48), 12);
        h.insert(ch(4), n(36), 0);
        h.remove_key(12, r, p);
        let f = h.contains(ch(3), n(48));
        let g = h.contains(ch(4), n(36));
        h.clear();
        [a, b, c, d, e, f, g, h.holds_key(0, r, p, true)]
    }

    /// Sustain: a released note holds its key only with `sustained`, until its channel lets go.
    fn exercise_sustain<H: HeldNotes>() -> [bool; 7] {
        let r = KeyRange::THESIS;
        let p = OutOfRange::Fold;
        let mut h = H::EMPTY;
        h.insert(ch(0), n(60), 24);
        h.insert(ch(1), n(62), 26);
        let a = h.sustain(ch(0), n(60));
        let b = h.contains(ch(0), n(60));
        let c = h.holds_key(24, r, p, true) && !h.holds_key(24, r, p, false);
        h.release_sustained(ch(1));
        let d = h.holds_key(24, r, p, true);
        h.release_sustained(ch(0));
        let e = h.holds_key(24, r, p, true);
        let f = h.holds_key(26, r, p, false);
        h.sustain(ch(1), n(62));
        h.insert(ch(1), n(62), 26);
        let g = h.contains(ch(1), n(62));
        [a, b, c, d, e, f, g]
    }

    /// All Notes Off under the pedal: every played note of the channel becomes sustained,
    /// other channels' notes stay played, and the pedal going up lets them go.
    fn exercise_sustain_channel<H: HeldNotes>() -> [bool; 6] {
        let r = KeyRange::THESIS;
        let p = OutOfRange::Fold;
        let mut h = H::EMPTY;
        h.insert(ch(0), n(60), 24);
        h.insert(ch(0), n(64), 28);
        h.insert(ch(1), n(67), 31);
        h.sustain_channel(ch(0));
        let a = !h.contains(ch(0), n(60)) && !h.contains(ch(0), n(64));
        let b = h.holds_key(24, r, p, true) && h.holds_key(28, r, p, true);
        let c = !h.holds_key(24, r, p, false);
        let d = h.contains(ch(1), n(67));
        h.release_sustained(ch(0));
        let e = !h.holds_key(24, r, p, true) && !h.holds_key(28, r, p, true);
        let f = h.holds_key(31, r, p, false);
        [a, b, c, d, e, f]
    }

    #[test]
    fn sustain_channel_holds_a_channels_notes_by_the_pedal_in_both_stores() {
        assert_eq!(exercise_sustain_channel::<NoteTable>(), [true; 6]);
        assert_eq!(exercise_sustain_channel::<NotePool<8>>(), [true; 6]);
    }

    #[test]
    fn pool_and_table_agree() {
        let want = [true, true, false, true, false, false, true, false];
        assert_eq!(exercise::<NoteTable>(), want);
        assert_eq!(exercise::<NotePool<8>>(), want);
        let want = [true, false, true, true, false, true, true];
        assert_eq!(exercise_sustain::<NoteTable>(), want);
        assert_eq!(exercise_sustain::<NotePool<8>>(), want);
    }

    #[test]
    fn a_full_pool_refuses_new_notes_but_not_known_ones() {
        let mut p = NotePool::<2>::EMPTY;
        assert!(p.insert(ch(0), n(60), 24));
        assert!(p.insert(ch(0), n(61), 25));
        assert!(!p.insert(ch(0), n(62), 26));
        assert!(p.insert(ch(0), n(61), 25));
    }
}
