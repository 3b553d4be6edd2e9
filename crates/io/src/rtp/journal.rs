//! The recovery journal (RFC 6295 §5 and appendix A): read, and written for chapters N
//! (NoteOn/NoteOff) and C (controllers). Every other chapter is stepped over by its size,
//! and a channel journal by its LENGTH, so a journal of chapters this end does not use
//! still reads.

use super::error::{PacketError, Reader};

/// The recovery journal of one packet.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Journal {
    /// The top-level S bit: set, nothing in the journal comes from the packet just before.
    pub single: bool,
    /// The checkpoint: the journal covers this packet up to the one before its own.
    pub checkpoint: u16,
    /// One per channel that has something to recover.
    pub channels: Vec<ChannelJournal>,
}

/// One channel's journal: the chapters this end reads.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ChannelJournal {
    /// The channel, 0..=15.
    pub channel: u8,
    /// Chapter C's controller logs, oldest first.
    pub controllers: Vec<ControllerLog>,
    /// Chapter N, if present.
    pub notes: Option<ChapterN>,
}

/// Chapter N: the notes whose latest command was a NoteOn (with its velocity), and those
/// whose latest was a NoteOff.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ChapterN {
    /// The B bit (the NoteOff bitfield's S bit).
    pub b: bool,
    /// Note logs, oldest first.
    pub on: Vec<NoteLog>,
    /// Bit `n` set: note `n`'s latest command was a NoteOff.
    pub off: u128,
}

/// A chapter N note log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NoteLog {
    /// The S bit.
    pub s: bool,
    /// The note.
    pub note: u8,
    /// Its NoteOn's velocity, 1..=127.
    pub velocity: u8,
    /// The Y bit: the sender recommends playing it late.
    pub play: bool,
}

/// A chapter C controller log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ControllerLog {
    /// The S bit.
    pub s: bool,
    /// The controller number.
    pub number: u8,
    /// What it codes.
    pub tool: Tool,
}

/// How a controller log codes its command (RFC 6295 A.3.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tool {
    /// The value of the latest command.
    Value(u8),
    /// The number of off↔on toggles in the session, modulo 64.
    Toggle(u8),
    /// The number of commands in the session, modulo 64.
    Count(u8),
}

const CHAPTER_P: u8 = 0x80;
const CHAPTER_C: u8 = 0x40;
const CHAPTER_M: u8 = 0x20;
const CHAPTER_W: u8 = 0x10;
const CHAPTER_N: u8 = 0x08;
const CHAPTER_E: u8 = 0x04;
const CHAPTER_T: u8 = 0x02;
const CHAPTER_A: u8 = 0x01;

/// Reads a journal section.
pub fn parse(section: &[u8]) -> Result<Journal, PacketError> {
    let mut r = Reader::new(section);
    let head = r.u8("the journal header")?;
    let checkpoint = r.u16("the journal header")?;
    if head & 0x40 != 0 {
        // The system journal: its LENGTH (header included) steps over it.
        let h = r.u16("the system journal header")?;
        skip_counted(&mut r, usize::from(h & 0x03FF), 2, "the system journal")?;
    }
    let mut channels = Vec::new();
    if head & 0x20 != 0 {
        for _ in 0..=(head & 0x0F) {
            channels.push(channel_journal(&mut r)?);
        }
    }
    Ok(Journal {
        single: head & 0x80 != 0,
        checkpoint,
        channels,
    })
}

/// Steps over the rest of a structure whose LENGTH (`length`) counts its `header` bytes,
/// already read.
fn skip_counted(
    r: &mut Reader<'_>,
    length: usize,
    header: usize,
    what: &'static str,
) -> Result<(), PacketError> {
    if length < header || length - header > r.left() {
        return Err(PacketError::Length {
            what,
            length,
            room: r.left() + header,
        });
    }
    r.take(length - header, what).map(|_| ())
}

fn channel_journal(r: &mut Reader<'_>) -> Result<ChannelJournal, PacketError> {
    let h = r.u16("a channel journal header")?;
    let toc = r.u8("a channel journal header")?;
    let length = usize::from(h & 0x03FF);
    if length < 3 || length - 3 > r.left() {
        return Err(PacketError::Length {
            what: "a channel journal",
            length,
            room: r.left() + 3,
        });
    }
    let mut c = Reader::new(r.take(length - 3, "a channel journal")?);
    let mut j = ChannelJournal {
        channel: ((h >> 11) & 0x0F) as u8,
        ..ChannelJournal::default()
    };
    if toc & CHAPTER_P != 0 {
        c.take(3, "chapter P")?;
    }
    if toc & CHAPTER_C != 0 {
        j.controllers = chapter_c(&mut c)?;
    }
    if toc & CHAPTER_M != 0 {
        let mh = c.u16("chapter M")?;
        skip_counted(&mut c, usize::from(mh & 0x03FF), 2, "chapter M")?;
    }
    if toc & CHAPTER_W != 0 {
        c.take(2, "chapter W")?;
    }
    if toc & CHAPTER_N != 0 {
        j.notes = Some(chapter_n(&mut c)?);
    }
    // E, T and A come after N: nothing here reads them, and the LENGTH already bounds them.
    let _ = (CHAPTER_E, CHAPTER_T, CHAPTER_A);
    Ok(j)
}

fn chapter_c(c: &mut Reader<'_>) -> Result<Vec<ControllerLog>, PacketError> {
    let n = usize::from(c.u8("chapter C")? & 0x7F) + 1;
    let logs = c.take(2 * n, "chapter C's controller logs")?;
    Ok(logs
        .chunks_exact(2)
        .map(|l| ControllerLog {
            s: l[0] & 0x80 != 0,
            number: l[0] & 0x7F,
            tool: match (l[1] & 0x80 != 0, l[1] & 0x40 != 0) {
                (false, _) => Tool::Value(l[1] & 0x7F),
                (true, false) => Tool::Toggle(l[1] & 0x3F),
                (true, true) => Tool::Count(l[1] & 0x3F),
            },
        })
        .collect())
}

fn chapter_n(c: &mut Reader<'_>) -> Result<ChapterN, PacketError> {
    let h = c.u16("chapter N's header")?;
    let (b, len) = (h & 0x8000 != 0, usize::from((h >> 8) & 0x7F));
    let (low, high) = (((h >> 4) & 0x0F) as u8, (h & 0x0F) as u8);
    let logs = if len == 127 && low == 15 && high == 0 {
        128
    } else {
        len
    };
    let octets = match (low, high) {
        (l, h) if l <= h => usize::from(h - l) + 1,
        (15, 0) | (15, 1) => 0,
        _ => return Err(PacketError::OffBits { low, high }),
    };
    let mut n = ChapterN {
        b,
        ..ChapterN::default()
    };
    for l in c.take(2 * logs, "chapter N's note logs")?.chunks_exact(2) {
        let (note, velocity) = (l[0] & 0x7F, l[1] & 0x7F);
        if velocity == 0 {
            return Err(PacketError::ZeroVelocity { note });
        }
        n.on.push(NoteLog {
            s: l[0] & 0x80 != 0,
            note,
            velocity,
            play: l[1] & 0x80 != 0,
        });
    }
    for (i, &bits) in c.take(octets, "chapter N's OFFBITS")?.iter().enumerate() {
        for bit in 0..8 {
            if bits & (0x80 >> bit) != 0 {
                n.off |= 1u128 << (8 * (usize::from(low) + i) + bit);
            }
        }
    }
    Ok(n)
}

/// Writes a journal (the system journal never: nothing here codes system commands). The H
/// bits stay 0 (no enhanced chapter C).
pub fn write(j: &Journal) -> Vec<u8> {
    let chans = j.channels.len().min(16);
    let mut out =
        vec![u8::from(j.single) << 7 | u8::from(chans > 0) << 5 | (chans.max(1) - 1) as u8];
    out.extend_from_slice(&j.checkpoint.to_be_bytes());
    for c in &j.channels[..chans] {
        write_channel(&mut out, c);
    }
    out
}

fn write_channel(out: &mut Vec<u8>, c: &ChannelJournal) {
    let mut body = Vec::new();
    let mut toc = 0u8;
    let mut single = true;
    if !c.controllers.is_empty() {
        toc |= CHAPTER_C;
        let logs = &c.controllers[..c.controllers.len().min(128)];
        let s = logs.iter().all(|l| l.s);
        single &= s;
        body.push(u8::from(s) << 7 | (logs.len() - 1) as u8);
        for l in logs {
            body.push(u8::from(l.s) << 7 | l.number & 0x7F);
            body.push(match l.tool {
                Tool::Value(v) => v & 0x7F,
                Tool::Toggle(t) => 0x80 | t & 0x3F,
                Tool::Count(n) => 0xC0 | n & 0x3F,
            });
        }
    }
    if let Some(n) = &c.notes {
        toc |= CHAPTER_N;
        single &= n.b && n.on.iter().all(|l| l.s);
        write_chapter_n(&mut body, n);
    }
    let length = (body.len() + 3).min(0x03FF) as u16;
    let h = u16::from(single) << 15 | u16::from(c.channel & 0x0F) << 11 | length;
    out.extend_from_slice(&h.to_be_bytes());
    out.push(toc);
    out.extend_from_slice(&body[..usize::from(length) - 3]);
}

fn write_chapter_n(out: &mut Vec<u8>, n: &ChapterN) {
    let logs = &n.on[..n.on.len().min(127)];
    let (low, high) = if n.off == 0 {
        (15u8, 1u8)
    } else {
        (
            (n.off.trailing_zeros() / 8) as u8,
            ((127 - n.off.leading_zeros()) / 8) as u8,
        )
    };
    out.push(u8::from(n.b) << 7 | logs.len() as u8);
    out.push(low << 4 | high);
    for l in logs {
        out.push(u8::from(l.s) << 7 | l.note & 0x7F);
        out.push(u8::from(l.play) << 7 | l.velocity.clamp(1, 127));
    }
    if n.off != 0 {
        for octet in low..=high {
            let byte = (n.off >> (8 * u32::from(octet))) as u8;
            out.push(byte.reverse_bits()); // the most significant bit is the lowest note
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// RFC 6295 figure A.6.1's layout, built by hand: channel 1 (0-based 0), chapter N with
    /// B = 1, two note logs (C4 velocity 100 played, E4 velocity 90 not), and OFFBITS for
    /// notes 8·LOW.. with LOW = 7, HIGH = 8: notes 56 and 71 are off.
    fn rfc_chapter_n() -> Vec<u8> {
        let chapter = [
            0x82,       // B = 1, LEN = 2
            0x78,       // LOW = 7, HIGH = 8
            0x80 | 60,  // S = 1, NOTENUM 60
            0x80 | 100, // Y = 1, VELOCITY 100
            64,         // S = 0, NOTENUM 64
            90,         // Y = 0, VELOCITY 90
            0x80,       // OFFBITS octet 7: note 56 (its most significant bit)
            0x01,       // OFFBITS octet 8: note 71 (its least significant bit)
        ];
        let length = 3 + chapter.len() as u16;
        let mut j = vec![0x20, 0x00, 0x05]; // S = 0, A = 1, TOTCHAN = 0, checkpoint 5
        j.extend_from_slice(&(length).to_be_bytes()); // S = 0, CHAN = 0, H = 0
        j.push(CHAPTER_N);
        j.extend_from_slice(&chapter);
        j
    }

    #[test]
    fn chapter_n_as_the_rfc_lays_it_out() {
        let j = parse(&rfc_chapter_n()).unwrap();
        assert_eq!((j.single, j.checkpoint, j.channels.len()), (false, 5, 1));
        let n = j.channels[0].notes.as_ref().unwrap();
        assert!(n.b);
        assert_eq!(
            n.on,
            [
                NoteLog {
                    s: true,
                    note: 60,
                    velocity: 100,
                    play: true
                },
                NoteLog {
                    s: false,
                    note: 64,
                    velocity: 90,
                    play: false
                }
            ]
        );
        assert_eq!(n.off, 1u128 << 56 | 1u128 << 71);
        assert_eq!(write(&j), rfc_chapter_n(), "written back byte for byte");
    }

    #[test]
    fn chapter_n_len_127_with_low_15_high_0_is_128_logs_and_empty_offbits_forms() {
        let mut ch = vec![0x7F, 0xF0];
        for note in 0..128u8 {
            ch.extend_from_slice(&[note, 1]);
        }
        let n = chapter_n(&mut Reader::new(&ch)).unwrap();
        assert_eq!((n.on.len(), n.off), (128, 0));
        let empty = chapter_n(&mut Reader::new(&[0x00, 0xF1])).unwrap();
        assert_eq!((empty.on.len(), empty.off), (0, 0));
        assert_eq!(
            chapter_n(&mut Reader::new(&[0x00, 0x52])),
            Err(PacketError::OffBits { low: 5, high: 2 })
        );
        assert_eq!(
            chapter_n(&mut Reader::new(&[0x01, 0xF1, 60, 0])),
            Err(PacketError::ZeroVelocity { note: 60 })
        );
    }

    /// Chapter C (figure A.3.1) with the three tools, after a chapter P and a chapter W that
    /// are stepped over, then a chapter N; and a system journal skipped by its LENGTH.
    #[test]
    fn chapter_c_tools_and_chapters_stepped_over() {
        let body = [
            0x05,
            0x00,
            0x00, // chapter P
            0x02, // chapter C: S = 0, LEN = 2 (three logs)
            0x80 | 64,
            0x80 | 3, // sustain pedal: toggle tool, 3 toggles
            7,
            100, // volume: value tool
            123,
            0xC0 | 2, // All Notes Off: count tool, 2
            0x40,
            0x00, // chapter W
            0x00,
            0x55,
            0x80, // chapter N: no logs, OFFBITS octet 5: note 40
        ];
        let mut j = vec![0xE1, 0xFF, 0xFF]; // S, Y, A; TOTCHAN = 1; checkpoint 65535
        j.extend_from_slice(&[0x00, 0x04, 0xAA, 0xBB]); // system journal, LENGTH 4
        j.extend_from_slice(&(0x1000u16 | (3 + body.len() as u16)).to_be_bytes()); // channel 2
        j.push(CHAPTER_P | CHAPTER_C | CHAPTER_W | CHAPTER_N);
        j.extend_from_slice(&body);
        // Channel 16: chapters T and A, inside its LENGTH, not read.
        j.extend_from_slice(&[
            0x78,
            0x07,
            CHAPTER_T | CHAPTER_A,
            0x7F,
            0x00,
            0x80 | 60,
            0x40,
        ]);
        let got = parse(&j).unwrap();
        assert!(got.single);
        assert_eq!(got.checkpoint, 0xFFFF);
        assert_eq!(got.channels.len(), 2);
        let c = &got.channels[0];
        assert_eq!(c.channel, 2);
        assert_eq!(
            c.controllers
                .iter()
                .map(|l| (l.number, l.tool))
                .collect::<Vec<_>>(),
            [
                (64, Tool::Toggle(3)),
                (7, Tool::Value(100)),
                (123, Tool::Count(2))
            ]
        );
        assert_eq!(c.notes.as_ref().unwrap().off, 1u128 << 40);
        assert_eq!(got.channels[1].channel, 15);
        assert!(got.channels[1].notes.is_none());
    }

    #[test]
    fn lengths_that_lie_are_refused() {
        let mut j = rfc_chapter_n();
        j[4] += 1; // the channel journal claims a byte more than there is
        assert!(matches!(parse(&j), Err(PacketError::Length { .. })));
        let mut short = rfc_chapter_n();
        short[4] -= 2; // … or too few for chapter N
        assert!(matches!(parse(&short), Err(PacketError::Truncated { .. })));
        assert!(matches!(
            parse(&[0x40, 0, 0, 0x00, 0x01]),
            Err(PacketError::Length { .. })
        ));
        assert!(matches!(
            parse(&[0x21, 0, 0]),
            Err(PacketError::Truncated { .. })
        ));
        for n in 0..rfc_chapter_n().len() {
            assert!(parse(&rfc_chapter_n()[..n]).is_err(), "cut at {n}");
        }
    }

    #[test]
    fn written_journals_read_back() {
        let j = Journal {
            single: false,
            checkpoint: 9,
            channels: vec![ChannelJournal {
                channel: 9,
                controllers: vec![ControllerLog {
                    s: false,
                    number: 64,
                    tool: Tool::Value(0),
                }],
                notes: Some(ChapterN {
                    b: false,
                    on: vec![],
                    off: 1 << 36 | 1 << 96 | 1 << 127,
                }),
            }],
        };
        assert_eq!(parse(&write(&j)).unwrap(), j);
        let empty = Journal {
            single: true,
            checkpoint: 3,
            channels: vec![],
        };
        assert_eq!(write(&empty), [0x80, 0, 3]);
        assert_eq!(parse(&write(&empty)).unwrap(), empty);
    }
}
