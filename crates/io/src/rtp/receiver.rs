//! The receiving side of one RTP-MIDI stream, without sockets: packets in, MIDI messages out,
//! and after a loss the messages the journal says were lost (RFC 6295 §4, appendix A).
//!
//! It keeps what it has handed on: which notes are on, on each channel, and each
//! controller's value, toggle count and command count. When a sequence number shows that
//! packets were lost, the next packet's journal is compared with that, and only what differs
//! is played: a note it holds that chapter N lists as off gets a Note-Off; a note it does not
//! hold that chapter N lists as on gets its Note-On if the sender recommends playing it (Y);
//! a controller that chapter C shows changed (the sustain pedal's toggle count, a value, an
//! All Notes Off's count) gets its command. Note-Offs come first, then the controllers, so a
//! pedal that should be up is lifted (the RFC's advice: "err on the side of silencing").

use super::error::PacketError;
use super::journal::{self, ChannelJournal, Tool};
use super::packet::{self, RtpHeader};

/// What one packet gives.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Delivery {
    /// Messages recovered from the journal, to play before the packet's own.
    pub recovered: Vec<Vec<u8>>,
    /// The packet's own commands: each message with its delta time (RTP units).
    pub commands: Vec<(u32, Vec<u8>)>,
    /// Packets lost just before this one (0: none).
    pub lost: u16,
    /// The journal could not be read (the loss is then not repaired).
    pub journal_error: Option<PacketError>,
}

/// Counters of a stream.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReceiverStats {
    /// Packets played.
    pub packets: u64,
    /// Packets lost (sequence number gaps).
    pub lost: u64,
    /// Packets come too late or twice, dropped.
    pub late: u64,
    /// Messages recovered from journals.
    pub recovered: u64,
}

#[derive(Clone, Copy, Debug, Default)]
struct Controller {
    value: u8,
    toggles: u8,
    count: u8,
}

/// One stream's receiver.
#[derive(Clone, Debug)]
pub struct Receiver {
    expected: Option<u16>,
    /// Bit `n` of channel `c`: note `n` is on, as handed on.
    notes: [u128; 16],
    controllers: Box<[[Controller; 128]; 16]>,
    stats: ReceiverStats,
}

impl Default for Receiver {
    fn default() -> Self {
        Receiver {
            expected: None,
            notes: [0; 16],
            controllers: Box::new([[Controller::default(); 128]; 16]),
            stats: ReceiverStats::default(),
        }
    }
}

impl Receiver {
    /// A receiver that has seen nothing.
    pub fn new() -> Self {
        Self::default()
    }

    /// Its counters.
    pub fn stats(&self) -> ReceiverStats {
        self.stats
    }

    /// The last sequence number taken, for receiver feedback.
    pub fn last_seq(&self) -> Option<u16> {
        self.expected.map(|e| e.wrapping_sub(1))
    }

    /// Whether `note` is on on `channel`, as handed on.
    pub fn is_on(&self, channel: u8, note: u8) -> bool {
        self.notes[usize::from(channel & 0x0F)] >> (note & 0x7F) & 1 != 0
    }

    /// Takes one RTP datagram. A packet that cannot be read is an error and changes
    /// nothing (its loss shows as a gap at the next one, whose journal repairs it). A packet
    /// older than the last one taken (late, or twice) gives nothing.
    pub fn receive(&mut self, datagram: &[u8]) -> Result<Delivery, PacketError> {
        let p = packet::parse(datagram)?;
        let mut d = Delivery::default();
        let RtpHeader { seq, .. } = p.header;
        if let Some(expected) = self.expected {
            let ahead = seq.wrapping_sub(expected) as i16;
            if ahead < 0 {
                self.stats.late += 1;
                return Ok(d);
            }
            d.lost = ahead as u16;
        }
        self.expected = Some(seq.wrapping_add(1));
        if d.lost > 0 {
            self.stats.lost += u64::from(d.lost);
            match p.journal.map(journal::parse) {
                Some(Ok(j)) => d.recovered = self.recover(&j.channels),
                Some(Err(e)) => d.journal_error = Some(e),
                None => {}
            }
            self.stats.recovered += d.recovered.len() as u64;
        }
        for c in p.commands {
            self.track(&c.bytes);
            d.commands.push((c.delta, c.bytes));
        }
        self.stats.packets += 1;
        Ok(d)
    }

    /// The messages that bring what was handed on to what the journal says.
    fn recover(&mut self, channels: &[ChannelJournal]) -> Vec<Vec<u8>> {
        let mut out = Vec::new();
        for c in channels {
            let ch = c.channel & 0x0F;
            if let Some(n) = &c.notes {
                let stuck = self.notes[usize::from(ch)] & n.off;
                for note in (0..128u8).filter(|&k| stuck >> k & 1 != 0) {
                    out.push(vec![0x80 | ch, note, 0]);
                }
                for log in &n.on {
                    if log.play && !self.is_on(ch, log.note) {
                        out.push(vec![0x90 | ch, log.note, log.velocity]);
                    }
                }
            }
            for log in &c.controllers {
                self.recover_controller(ch, log.number, log.tool, &mut out);
            }
        }
        for m in &out {
            self.track(m);
        }
        out
    }

    fn recover_controller(&mut self, ch: u8, number: u8, tool: Tool, out: &mut Vec<Vec<u8>>) {
        let now = self.controllers[usize::from(ch)][usize::from(number & 0x7F)];
        let cc = |v: u8| vec![0xB0 | ch, number & 0x7F, v];
        match tool {
            Tool::Value(v) if v != now.value => out.push(cc(v)),
            Tool::Toggle(t) if t != now.toggles % 64 => {
                let want_on = t % 2 == 1;
                if want_on == (now.value >= 64) {
                    // An even number of toggles lost: off and on again (or on and off).
                    out.push(cc(if want_on { 0 } else { 127 }));
                }
                out.push(cc(if want_on { 127 } else { 0 }));
            }
            Tool::Count(n) if n != now.count % 64 && (120..=127).contains(&number) => {
                out.push(cc(0));
            }
            _ => {}
        }
    }

    /// Notes what a message handed on changes.
    fn track(&mut self, m: &[u8]) {
        let Some(&status) = m.first() else {
            return;
        };
        let ch = usize::from(status & 0x0F);
        match (status & 0xF0, m.get(1).copied(), m.get(2).copied()) {
            (0x90, Some(n), Some(v)) if v > 0 => self.notes[ch] |= 1u128 << (n & 0x7F),
            (0x80 | 0x90, Some(n), Some(_)) => self.notes[ch] &= !(1u128 << (n & 0x7F)),
            (0xB0, Some(n), Some(v)) => {
                let c = &mut self.controllers[ch][usize::from(n & 0x7F)];
                if (v >= 64) != (c.value >= 64) {
                    c.toggles = c.toggles.wrapping_add(1) % 64;
                }
                c.value = v;
                c.count = c.count.wrapping_add(1) % 64;
                if n == 120 || n >= 123 {
                    self.notes[ch] = 0;
                }
            }
            (0xF0, _, _) if status == 0xFF => self.notes = [0; 16],
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rtp::journal::{ChapterN, ControllerLog, Journal, NoteLog};

    fn pkt(seq: u16, cmds: &[&[u8]], j: Option<&Journal>) -> Vec<u8> {
        let c: Vec<(u32, &[u8])> = cmds.iter().map(|b| (0, *b)).collect();
        let journal = j.map(journal::write);
        packet::write(
            RtpHeader {
                seq,
                timestamp: 0,
                ssrc: 1,
            },
            &c,
            journal.as_deref(),
        )
    }

    fn channel(notes: Option<ChapterN>, controllers: Vec<ControllerLog>) -> Journal {
        Journal {
            single: false,
            checkpoint: 0,
            channels: vec![ChannelJournal {
                channel: 0,
                controllers,
                notes,
            }],
        }
    }

    #[test]
    fn in_order_packets_play_and_their_journals_are_not_read() {
        let mut r = Receiver::new();
        let d = r.receive(&pkt(10, &[&[0x90, 60, 100]], None)).unwrap();
        assert_eq!(d.commands, [(0, vec![0x90, 60, 100])]);
        assert!(r.is_on(0, 60));
        let j = channel(
            Some(ChapterN {
                b: true,
                on: vec![],
                off: 1 << 60,
            }),
            vec![],
        );
        let d = r.receive(&pkt(11, &[], Some(&j))).unwrap();
        assert_eq!((d.lost, d.recovered.len()), (0, 0));
        assert!(r.is_on(0, 60), "no loss: the journal is not acted on");
        assert_eq!(r.last_seq(), Some(11));
    }

    #[test]
    fn a_lost_note_off_is_played_from_chapter_n() {
        let mut r = Receiver::new();
        r.receive(&pkt(65535, &[&[0x90, 60, 100], &[0x90, 64, 100]], None))
            .unwrap();
        // Packet 0 (Note-Off 60) is lost; packet 1 carries a journal saying 60 is off and 64
        // still on, and its own Note-On 67.
        let j = channel(
            Some(ChapterN {
                b: false,
                on: vec![NoteLog {
                    s: true,
                    note: 64,
                    velocity: 100,
                    play: true,
                }],
                off: 1 << 60,
            }),
            vec![],
        );
        let d = r.receive(&pkt(1, &[&[0x90, 67, 90]], Some(&j))).unwrap();
        assert_eq!(d.lost, 1);
        assert_eq!(d.recovered, [vec![0x80, 60, 0]]);
        assert_eq!(d.commands, [(0, vec![0x90, 67, 90])]);
        assert!(!r.is_on(0, 60) && r.is_on(0, 64) && r.is_on(0, 67));
        assert_eq!(r.stats().lost, 1);
    }

    #[test]
    fn a_lost_note_on_is_played_only_if_the_sender_says_so() {
        for play in [true, false] {
            let mut r = Receiver::new();
            r.receive(&pkt(5, &[], None)).unwrap();
            let log = NoteLog {
                s: false,
                note: 62,
                velocity: 80,
                play,
            };
            let j = channel(
                Some(ChapterN {
                    b: true,
                    on: vec![log],
                    off: 0,
                }),
                vec![],
            );
            let d = r.receive(&pkt(7, &[], Some(&j))).unwrap();
            let want: Vec<Vec<u8>> = if play {
                vec![vec![0x90, 62, 80]]
            } else {
                vec![]
            };
            assert_eq!(d.recovered, want);
        }
    }

    #[test]
    fn a_lost_pedal_release_is_played_from_chapter_c_by_either_tool() {
        for tool in [Tool::Value(0), Tool::Toggle(2)] {
            let mut r = Receiver::new();
            r.receive(&pkt(1, &[&[0xB0, 64, 127]], None)).unwrap();
            let log = ControllerLog {
                s: false,
                number: 64,
                tool,
            };
            let d = r
                .receive(&pkt(3, &[], Some(&channel(None, vec![log]))))
                .unwrap();
            assert_eq!(d.recovered, [vec![0xB0, 64, 0]], "{tool:?}");
        }
        // Up, then down-up-down lost (3 toggles): the pedal is down as handed on too, but
        // it went up in between: lifted and put down again.
        let mut r = Receiver::new();
        r.receive(&pkt(1, &[&[0xB0, 64, 127]], None)).unwrap();
        let log = ControllerLog {
            s: false,
            number: 64,
            tool: Tool::Toggle(3),
        };
        let d = r
            .receive(&pkt(4, &[], Some(&channel(None, vec![log]))))
            .unwrap();
        assert_eq!(d.recovered, [vec![0xB0, 64, 0], vec![0xB0, 64, 127]]);
    }

    #[test]
    fn late_duplicate_and_unreadable_packets() {
        let mut r = Receiver::new();
        r.receive(&pkt(100, &[&[0x90, 60, 1]], None)).unwrap();
        let d = r.receive(&pkt(100, &[&[0x90, 61, 1]], None)).unwrap();
        assert!(d.commands.is_empty());
        assert_eq!(r.stats().late, 1);
        assert!(r.receive(&[0x80, 0x61, 0, 101]).is_err());
        assert_eq!(
            r.last_seq(),
            Some(100),
            "an unreadable packet changes nothing"
        );
        let mut bad = pkt(101, &[&[0x80, 60, 0]], None);
        bad[12] |= 0x40; // J set, and a journal that is not there
        bad.extend_from_slice(&[0x20, 0, 0]);
        let d = r.receive(&pkt(102, &[], None)).unwrap();
        assert_eq!(d.lost, 1);
        let mut r2 = r.clone();
        let d = r2.receive(&bad).unwrap();
        assert!(d.commands.is_empty(), "late");
        let mut r3 = Receiver::new();
        r3.receive(&pkt(99, &[], None)).unwrap();
        let d = r3.receive(&bad).unwrap();
        assert!(d.journal_error.is_some() && d.commands.len() == 1, "{d:?}");
    }

    #[test]
    fn all_notes_off_and_reset_forget_held_notes() {
        let mut r = Receiver::new();
        r.receive(&pkt(1, &[&[0x91, 60, 1], &[0x92, 61, 1]], None))
            .unwrap();
        r.receive(&pkt(2, &[&[0xB1, 123, 0]], None)).unwrap();
        assert!(!r.is_on(1, 60) && r.is_on(2, 61));
        r.receive(&pkt(3, &[&[0xFF]], None)).unwrap();
        assert!(!r.is_on(2, 61));
    }
}
