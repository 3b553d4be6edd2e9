//! Which notes are holding keys: the record that makes release exact.
//!
//! A key goes up only when every note holding it has been released, so the interpreter keeps
//! every (channel, note) that is on. Two stores implement [`HeldNotes`]:
//!
//! - [`NoteTable`] (the default): a channel mask for each of the 128 notes, 256 bytes. Exact
//!   for any number of notes held at once; the host's choice.
//! - [`NotePool`]: up to `N` held notes, 3 bytes each, for small MCUs. A Note-On that finds
//!   the pool full is refused like one past the power budget. With `N` at least twice the
//!   guard's `max_keys_down` it is never the limit in practice, since a note is only kept
//!   while its key is down or about to be.

use crate::keymap::{KeyRange, OutOfRange};
use crate::values::{Channel, Note};

/// A store of the (channel, note) pairs that are on, with the key each one holds.
pub trait HeldNotes: Clone + core::fmt::Debug {
    /// An empty store.
    const EMPTY: Self;

    /// Whether `note` is on on `channel`.
    fn contains(&self, channel: Channel, note: Note) -> bool;

    /// Records `note` on `channel`, holding `key`. Returns `false` if the store is full.
    fn insert(&mut self, channel: Channel, note: Note, key: u8) -> bool;

    /// Forgets `note` on `channel`. Returns whether it was on.
    fn remove(&mut self, channel: Channel, note: Note) -> bool;

    /// Forgets every note of `channel`.
    fn remove_channel(&mut self, channel: Channel);

    /// Forgets every note holding `key`.
    fn remove_key(&mut self, key: u8, range: KeyRange, policy: OutOfRange);

    /// Whether any note holds `key`.
    fn holds_key(&self, key: u8, range: KeyRange, policy: OutOfRange) -> bool;

    /// Forgets everything.
    fn clear(&mut self);
}

/// Every note on every channel: 128 channel masks, 256 bytes. Exact under any load.
#[derive(Clone, Debug)]
pub struct NoteTable([u16; 128]);

impl HeldNotes for NoteTable {
    const EMPTY: Self = Self([0; 128]);

    fn contains(&self, channel: Channel, note: Note) -> bool {
        self.0[note.get() as usize] & channel.bit() != 0
    }

    fn insert(&mut self, channel: Channel, note: Note, _key: u8) -> bool {
        self.0[note.get() as usize] |= channel.bit();
        true
    }

    fn remove(&mut self, channel: Channel, note: Note) -> bool {
        let slot = &mut self.0[note.get() as usize];
        let was = *slot & channel.bit() != 0;
        *slot &= !channel.bit();
        was
    }

    fn remove_channel(&mut self, channel: Channel) {
        for slot in self.0.iter_mut() {
            *slot &= !channel.bit();
        }
    }

    fn remove_key(&mut self, key: u8, range: KeyRange, policy: OutOfRange) {
        range.notes_of(key, policy, |n| self.0[n.get() as usize] = 0);
    }

    fn holds_key(&self, key: u8, range: KeyRange, policy: OutOfRange) -> bool {
        let mut held = false;
        range.notes_of(key, policy, |n| held |= self.0[n.get() as usize] != 0);
        held
    }

    fn clear(&mut self) {
        self.0 = [0; 128];
    }
}

/// Up to `N` held notes, 3 bytes each, for MCUs with little RAM.
#[derive(Clone, Debug)]
pub struct NotePool<const N: usize> {
    /// `channel << 7 | note` of each held note.
    notes: [u16; N],
    /// The key each one holds.
    keys: [u8; N],
    len: u8,
}

impl<const N: usize> NotePool<N> {
    fn find(&self, channel: Channel, note: Note) -> Option<usize> {
        let tag = (channel.get() as u16) << 7 | note.get() as u16;
        self.notes[..self.len as usize]
            .iter()
            .position(|&t| t == tag)
    }

    fn retain(&mut self, mut keep: impl FnMut(u16, u8) -> bool) {
        let mut i = 0;
        while i < self.len as usize {
            if keep(self.notes[i], self.keys[i]) {
                i += 1;
            } else {
                let last = self.len as usize - 1;
                self.notes[i] = self.notes[last];
                self.keys[i] = self.keys[last];
                self.len -= 1;
            }
        }
    }
}

impl<const N: usize> HeldNotes for NotePool<N> {
    const EMPTY: Self = Self {
        notes: [0; N],
        keys: [0; N],
        len: 0,
    };

    fn contains(&self, channel: Channel, note: Note) -> bool {
        self.find(channel, note).is_some()
    }

    fn insert(&mut self, channel: Channel, note: Note, key: u8) -> bool {
        if self.contains(channel, note) {
            return true;
        }
        let i = self.len as usize;
        if i >= N || i >= u8::MAX as usize {
            return false;
        }
        self.notes[i] = (channel.get() as u16) << 7 | note.get() as u16;
        self.keys[i] = key;
        self.len += 1;
        true
    }

    fn remove(&mut self, channel: Channel, note: Note) -> bool {
        let Some(i) = self.find(channel, note) else {
            return false;
        };
        let last = self.len as usize - 1;
        self.notes[i] = self.notes[last];
        self.keys[i] = self.keys[last];
        self.len -= 1;
        true
    }

    fn remove_channel(&mut self, channel: Channel) {
        self.retain(|tag, _| (tag >> 7) as u8 != channel.get());
    }

    fn remove_key(&mut self, key: u8, _range: KeyRange, _policy: OutOfRange) {
        self.retain(|_, k| k != key);
    }

    fn holds_key(&self, key: u8, _range: KeyRange, _policy: OutOfRange) -> bool {
        self.keys[..self.len as usize].contains(&key)
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
        let a = h.holds_key(0, r, p);
        h.remove_channel(ch(1));
        let b = h.holds_key(0, r, p);
        let c = h.holds_key(24, r, p);
        let d = h.remove(ch(0), n(24));
        let e = h.remove(ch(0), n(24));
        h.insert(ch(3), n(48), 12);
        h.insert(ch(4), n(36), 0);
        h.remove_key(12, r, p);
        let f = h.contains(ch(3), n(48));
        let g = h.contains(ch(4), n(36));
        h.clear();
        [a, b, c, d, e, f, g, h.holds_key(0, r, p)]
    }

    #[test]
    fn pool_and_table_agree() {
        let want = [true, true, false, true, false, false, true, false];
        assert_eq!(exercise::<NoteTable>(), want);
        assert_eq!(exercise::<NotePool<8>>(), want);
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
