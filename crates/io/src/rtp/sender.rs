//! The sending side of one RTP-MIDI stream, without sockets: messages in, packets out, each
//! with a recovery journal of chapters N and C covering every packet since the checkpoint
//! (RFC 6295 §4–5, appendix A.3 and A.6). Receiver feedback (RS) moves the checkpoint
//! forward, so the journal holds only what the receiver may not have.
//!
//! What is kept per channel is bounded whatever the length of the performance: each note's
//! latest Note-On or Note-Off and each controller's latest value and toggle count, with the
//! sequence number of the packet that carried it. A note's Note-On older than the latest All
//! Notes Off (or All Sound Off, or a Reset) is no longer N-active and is not journalled.

use super::journal::{self, ChannelJournal, ChapterN, ControllerLog, Journal, NoteLog, Tool};
use super::packet::{self, RtpHeader};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum NoteState {
    On(u8),
    Off,
}

#[derive(Clone, Copy, Debug)]
struct Entry<T> {
    what: T,
    seq: u16,
}

#[derive(Clone, Copy, Debug, Default)]
struct Ctl {
    value: u8,
    toggles: u8,
}

/// One stream's sender.
#[derive(Clone, Debug)]
pub struct Sender {
    ssrc: u32,
    seq: u16,
    checkpoint: u16,
    notes: Box<[[Option<Entry<NoteState>>; 128]; 16]>,
    controllers: Box<[[Option<Entry<Ctl>>; 128]; 16]>,
}

impl Sender {
    /// A stream from `ssrc` whose first packet has sequence number `first_seq`.
    pub fn new(ssrc: u32, first_seq: u16) -> Self {
        Sender {
            ssrc,
            seq: first_seq,
            checkpoint: first_seq,
            notes: Box::new([[None; 128]; 16]),
            controllers: Box::new([[None; 128]; 16]),
        }
    }

    /// The sequence number the next packet gets.
    pub fn next_seq(&self) -> u16 {
        self.seq
    }

    /// The checkpoint in force.
    pub fn checkpoint(&self) -> u16 {
        self.checkpoint
    }

    /// The receiver has every packet up to `seq`: the journal need not cover them again. An
    /// answer about a packet not sent, or older than the checkpoint, is ignored.
    pub fn feedback(&mut self, seq: u16) {
        let sent = self.seq.wrapping_sub(self.checkpoint);
        let acked = seq.wrapping_sub(self.checkpoint);
        if acked < sent {
            self.checkpoint = seq.wrapping_add(1);
        }
    }

    /// The next packet: `messages` (each whole, status byte first, with its delta time from
    /// `timestamp`), and the journal of the packets before it since the checkpoint.
    pub fn packet(&mut self, timestamp: u32, messages: &[(u32, &[u8])]) -> Vec<u8> {
        let journal = journal::write(&self.journal());
        let header = RtpHeader {
            seq: self.seq,
            timestamp,
            ssrc: self.ssrc,
        };
        let out = packet::write(header, messages, Some(&journal));
        for (_, m) in messages {
            self.track(m);
        }
        self.seq = self.seq.wrapping_add(1);
        out
    }

    /// Whether `seq` is in the checkpoint history (checkpoint ..= the packet before the next).
    fn covered(&self, seq: u16) -> bool {
        seq.wrapping_sub(self.checkpoint) < self.seq.wrapping_sub(self.checkpoint)
    }

    /// The journal for the next packet. The top-level S bit is always 0 (it claims nothing
    /// about packet I − 1; a receiver then simply reads every chapter): pymidi 0.5.0 reads
    /// that bit as the system journal's Y and cannot parse a journal that sets it.
    fn journal(&self) -> Journal {
        let prev = self.seq.wrapping_sub(1);
        let channels = (0..16u8)
            .filter_map(|ch| {
                let notes = self.chapter_n(ch, prev);
                let controllers = self.chapter_c(ch, prev);
                (notes.is_some() || !controllers.is_empty()).then_some(ChannelJournal {
                    channel: ch,
                    controllers,
                    notes,
                })
            })
            .collect();
        Journal {
            single: false,
            checkpoint: self.checkpoint,
            channels,
        }
    }

    fn chapter_n(&self, ch: u8, prev: u16) -> Option<ChapterN> {
        let mut n = ChapterN {
            b: true,
            on: Vec::new(),
            off: 0,
        };
        let mut logs: Vec<(u16, NoteLog)> = Vec::new();
        for (note, e) in self.notes[usize::from(ch)].iter().enumerate() {
            let Some(e) = e.filter(|e| self.covered(e.seq)) else {
                continue;
            };
            match e.what {
                NoteState::On(velocity) => logs.push((
                    e.seq.wrapping_sub(self.checkpoint),
                    NoteLog {
                        s: e.seq != prev,
                        note: note as u8,
                        velocity,
                        play: true,
                    },
                )),
                NoteState::Off => {
                    n.off |= 1u128 << note;
                    n.b &= e.seq != prev;
                }
            }
        }
        logs.sort_by_key(|l| l.0); // oldest first
        n.on = logs.into_iter().map(|l| l.1).collect();
        (!n.on.is_empty() || n.off != 0).then_some(n)
    }

    /// Chapter C: the value of each controller seen since the checkpoint, and for the
    /// sustain pedal (and the other switches, 64–69) its toggle count as well.
    fn chapter_c(&self, ch: u8, prev: u16) -> Vec<ControllerLog> {
        let mut logs: Vec<(u16, ControllerLog)> = Vec::new();
        for (number, e) in self.controllers[usize::from(ch)].iter().enumerate() {
            let Some(e) = e.filter(|e| self.covered(e.seq)) else {
                continue;
            };
            let (age, s, number) = (
                e.seq.wrapping_sub(self.checkpoint),
                e.seq != prev,
                number as u8,
            );
            let log = |tool| (age, ControllerLog { s, number, tool });
            logs.push(log(Tool::Value(e.what.value)));
            if (64..=69).contains(&number) {
                logs.push(log(Tool::Toggle(e.what.toggles)));
            }
        }
        logs.sort_by_key(|l| l.0);
        logs.into_iter().map(|l| l.1).collect()
    }

    /// Records a message sent in the packet about to go out.
    fn track(&mut self, m: &[u8]) {
        let Some(&status) = m.first() else {
            return;
        };
        let (ch, seq) = (usize::from(status & 0x0F), self.seq);
        match (status & 0xF0, m.get(1).copied(), m.get(2).copied()) {
            (0x90, Some(n), Some(v)) if v > 0 => {
                self.notes[ch][usize::from(n & 0x7F)] = Some(Entry {
                    what: NoteState::On(v),
                    seq,
                })
            }
            (0x80 | 0x90, Some(n), Some(_)) => {
                self.notes[ch][usize::from(n & 0x7F)] = Some(Entry {
                    what: NoteState::Off,
                    seq,
                })
            }
            (0xB0, Some(n), Some(v)) => {
                let slot = &mut self.controllers[ch][usize::from(n & 0x7F)];
                let mut c = slot.map(|e| e.what).unwrap_or_default();
                if (v >= 64) != (c.value >= 64) {
                    c.toggles = (c.toggles + 1) % 64;
                }
                c.value = v;
                *slot = Some(Entry { what: c, seq });
                if n == 120 || n >= 123 {
                    // Earlier notes are no longer N-active.
                    self.notes[ch] = [None; 128];
                }
            }
            (0xF0, _, _) if status == 0xFF => {
                *self.notes = [[None; 128]; 16];
                *self.controllers = [[None; 128]; 16];
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rtp::receiver::Receiver;

    fn journal_of(p: &[u8]) -> Journal {
        journal::parse(packet::parse(p).unwrap().journal.unwrap()).unwrap()
    }

    #[test]
    fn the_journal_covers_the_packets_since_the_checkpoint() {
        let mut s = Sender::new(9, 65534);
        let first = s.packet(0, &[(0, &[0x90, 60, 100])]);
        let j = journal_of(&first);
        assert_eq!(
            (j.checkpoint, j.channels.len()),
            (65534, 0),
            "nothing before it"
        );
        s.packet(10, &[(0, &[0x90, 64, 90]), (0, &[0xB0, 64, 127])]);
        let third = s.packet(20, &[(0, &[0x80, 60, 0])]);
        let j = journal_of(&third);
        let c = &j.channels[0];
        let n = c.notes.as_ref().unwrap();
        assert_eq!(
            n.on.iter()
                .map(|l| (l.note, l.velocity, l.s))
                .collect::<Vec<_>>(),
            [(60, 100, true), (64, 90, false)],
            "oldest first; 64 came in the packet just before"
        );
        assert_eq!(
            c.controllers
                .iter()
                .map(|l| (l.number, l.tool))
                .collect::<Vec<_>>(),
            [(64, Tool::Value(127)), (64, Tool::Toggle(1))]
        );
        let fourth = s.packet(30, &[]);
        let n = journal_of(&fourth).channels[0].notes.clone().unwrap();
        assert_eq!((n.off, n.b), (1u128 << 60, false));
        // The receiver has everything up to the third packet (seq 0): only the fourth's
        // history remains.
        s.feedback(0);
        assert_eq!(s.checkpoint(), 1);
        let j = journal_of(&s.packet(40, &[]));
        assert_eq!(j.checkpoint, 1);
        assert!(j.channels.is_empty(), "{j:?}");
        s.feedback(500); // never sent: ignored
        assert_eq!(s.checkpoint(), 1);
    }

    #[test]
    fn all_notes_off_ends_the_notes_before_it() {
        let mut s = Sender::new(1, 0);
        s.packet(0, &[(0, &[0x92, 60, 1])]);
        s.packet(0, &[(0, &[0xB2, 123, 0])]);
        let j = journal_of(&s.packet(0, &[]));
        assert!(j.channels[0].notes.is_none());
        assert_eq!(j.channels[0].channel, 2);
    }

    /// Every packet but one reaches a receiver: whichever is lost, the receiver ends with the
    /// sender's notes and pedal.
    #[test]
    fn any_single_loss_is_repaired_by_the_next_packet() {
        let script: Vec<Vec<u8>> = vec![
            vec![0x90, 60, 100],
            vec![0xB0, 64, 127],
            vec![0x90, 64, 90],
            vec![0x80, 60, 0],
            vec![0xB0, 64, 0],
            vec![0x90, 64, 0],
            vec![0x91, 70, 20],
            vec![0x81, 70, 0],
        ];
        for lost in 0..script.len() {
            let mut s = Sender::new(3, 65530);
            let mut r = Receiver::new();
            for (i, m) in script.iter().enumerate() {
                let p = s.packet(i as u32, &[(0, m)]);
                if i != lost {
                    r.receive(&p).unwrap();
                }
            }
            r.receive(&s.packet(99, &[])).unwrap();
            for (ch, note) in [(0, 60), (0, 64), (1, 70)] {
                assert!(!r.is_on(ch, note), "lost {lost}: {ch}/{note} still on");
            }
        }
    }
}
