//! RTP-MIDI packets (RFC 6295 §2–3): the RTP header, and the MIDI command section with its
//! delta times, running status and SysEx segments, read into whole MIDI messages with their
//! status bytes (what a DIN line would carry), and written back.

use super::error::{PacketError, Reader};

/// RTP-MIDI's payload type (dynamic, 97, as AppleMIDI uses it).
pub const PAYLOAD_TYPE: u8 = 0x61;

/// The fixed RTP header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RtpHeader {
    /// The sequence number.
    pub seq: u16,
    /// The RTP timestamp (AppleMIDI: units of 100 µs).
    pub timestamp: u32,
    /// The sender's synchronisation source.
    pub ssrc: u32,
}

/// One command of the MIDI list: when (its timestamp less the packet's, in RTP units) and
/// its bytes as they go on a DIN line, status byte included.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Command {
    /// The sum of the delta times up to it (modulo 2^32).
    pub delta: u32,
    /// The message, with its status byte (a SysEx segment as its part of the stream).
    pub bytes: Vec<u8>,
}

/// A parsed RTP-MIDI packet; the journal is parsed on its own ([`super::journal`]), only
/// when a loss needs it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MidiPacket<'a> {
    /// The RTP header.
    pub header: RtpHeader,
    /// The P flag: the first command's status byte was not in the source stream.
    pub phantom: bool,
    /// The MIDI list.
    pub commands: Vec<Command>,
    /// The journal section, if the J flag says there is one.
    pub journal: Option<&'a [u8]>,
}

/// Whether a datagram on the data port looks like RTP (not an AppleMIDI command, which
/// starts with 0xFFFF).
pub fn is_rtp(datagram: &[u8]) -> bool {
    datagram.first().is_some_and(|b| b >> 6 == 2) && !datagram.starts_with(&[0xFF, 0xFF])
}

/// Reads one datagram.
pub fn parse(datagram: &[u8]) -> Result<MidiPacket<'_>, PacketError> {
    let mut r = Reader::new(datagram);
    let (header, payload) = rtp_header(&mut r)?;
    let mut r = Reader::new(payload);
    let flags = r.u8("the command section header")?;
    let long = flags & 0x80 != 0;
    let mut len = usize::from(flags & 0x0F);
    if long {
        len = len << 8 | usize::from(r.u8("the command section header")?);
    }
    let list = r.take(len, "the MIDI list")?;
    let commands = midi_list(list, flags & 0x20 != 0)?;
    let journal = (flags & 0x40 != 0).then(|| r.rest());
    Ok(MidiPacket {
        header,
        phantom: flags & 0x10 != 0,
        commands,
        journal,
    })
}

/// The RTP header, and the payload after it (CSRCs, extension and padding taken off).
fn rtp_header<'a>(r: &mut Reader<'a>) -> Result<(RtpHeader, &'a [u8]), PacketError> {
    let b0 = r.u8("the RTP header")?;
    if b0 >> 6 != 2 {
        return Err(PacketError::Version(b0 >> 6));
    }
    let pt = r.u8("the RTP header")? & 0x7F;
    if pt != PAYLOAD_TYPE {
        return Err(PacketError::PayloadType(pt));
    }
    let header = RtpHeader {
        seq: r.u16("the RTP header")?,
        timestamp: r.u32("the RTP header")?,
        ssrc: r.u32("the RTP header")?,
    };
    r.take(4 * usize::from(b0 & 0x0F), "the CSRC list")?;
    if b0 & 0x10 != 0 {
        r.take(2, "the header extension")?;
        let words = usize::from(r.u16("the header extension")?);
        r.take(4 * words, "the header extension")?;
    }
    let mut payload = r.rest();
    if b0 & 0x20 != 0 {
        let pad = usize::from(payload.last().copied().unwrap_or(0));
        if pad == 0 || pad > payload.len() {
            return Err(PacketError::Length {
                what: "the RTP padding",
                length: pad,
                room: payload.len(),
            });
        }
        payload = &payload[..payload.len() - pad];
    }
    Ok((header, payload))
}

/// Reads a delta time: 1 to 4 octets, 7 bits each, most significant first.
fn delta_time(r: &mut Reader<'_>) -> Result<u32, PacketError> {
    let mut v = 0u32;
    for _ in 0..4 {
        let b = r.u8("a delta time")?;
        v = v << 7 | u32::from(b & 0x7F);
        if b & 0x80 == 0 {
            return Ok(v);
        }
    }
    Err(PacketError::DeltaTime)
}

/// Writes a delta time in as few octets as it takes (at most 2^28 − 1).
pub fn write_delta(out: &mut Vec<u8>, delta: u32) {
    let delta = delta.min((1 << 28) - 1);
    let mut started = false;
    for shift in [21u32, 14, 7] {
        let group = (delta >> shift) & 0x7F;
        if started || group != 0 {
            out.push(0x80 | group as u8);
            started = true;
        }
    }
    out.push((delta & 0x7F) as u8);
}

/// The data bytes after a channel or system common status byte.
fn data_len(status: u8) -> Option<usize> {
    match status {
        0x80..=0xBF | 0xE0..=0xEF => Some(2),
        0xC0..=0xDF => Some(1),
        0xF1 | 0xF3 => Some(1),
        0xF2 => Some(2),
        0xF6 => Some(0),
        _ => None,
    }
}

/// Reads the MIDI list: commands with cumulative delta times, status bytes restored.
fn midi_list(list: &[u8], z: bool) -> Result<Vec<Command>, PacketError> {
    let mut r = Reader::new(list);
    let mut commands = Vec::new();
    let mut running = 0u8;
    let mut t = 0u32;
    let mut first = true;
    while r.left() > 0 {
        if !first || z {
            t = t.wrapping_add(delta_time(&mut r)?);
            if r.left() == 0 {
                break; // a final delta time with no command: legal padding
            }
        }
        first = false;
        let bytes = command(&mut r, &mut running)?;
        if !bytes.is_empty() {
            // (An empty last SysEx segment whose 0xF7 was dropped, `F7 F5`, carries nothing.)
            commands.push(Command { delta: t, bytes });
        }
    }
    Ok(commands)
}

/// Reads one command at `r`, under (and updating) the running status.
fn command(r: &mut Reader<'_>, running: &mut u8) -> Result<Vec<u8>, PacketError> {
    let at = r.pos();
    let status = r.rest()[0];
    match status {
        0xF8..=0xFF => {
            r.take(1, "a real-time command")?;
            if matches!(status, 0xF9 | 0xFD) {
                return Err(PacketError::Command { status, at });
            }
            Ok(vec![status])
        }
        0xF0 | 0xF7 => {
            *running = 0;
            sysex(r)
        }
        0xF1..=0xF6 => {
            *running = 0;
            let n = data_len(status).ok_or(PacketError::Command { status, at })?;
            r.take(1, "a system common command")?;
            with_data(r, status, n)
        }
        0x80..=0xEF => {
            *running = status;
            r.take(1, "a channel command")?;
            with_data(r, status, data_len(status).unwrap_or(0))
        }
        _ if *running == 0 => Err(PacketError::NoStatus { at }),
        _ => with_data(r, *running, data_len(*running).unwrap_or(0)),
    }
}

/// `status` and its `n` data bytes read from `r`.
fn with_data(r: &mut Reader<'_>, status: u8, n: usize) -> Result<Vec<u8>, PacketError> {
    let at = r.pos();
    let data = r.take(n, "a command's data bytes")?;
    if let Some(i) = data.iter().position(|&b| b >= 0x80) {
        return Err(PacketError::StatusInData { at: at + i });
    }
    let mut m = Vec::with_capacity(n + 1);
    m.push(status);
    m.extend_from_slice(data);
    Ok(m)
}

/// A SysEx command or segment (RFC 6295 figure 5), as its part of the DIN stream: whole
/// `F0 … F7` as is; a first segment `F0 … F0` as `F0 …`; a middle one `F7 … F0` as its data;
/// the last `F7 … F7` as its data and `F7`; a cancel `F7 F4` as `F7` (which ends the
/// command early, so that the device drops it); a dropped `F7` (`… F5`) left dropped.
fn sysex(r: &mut Reader<'_>) -> Result<Vec<u8>, PacketError> {
    let at = r.pos();
    let body = r.rest();
    let head = body[0];
    let end = body[1..]
        .iter()
        .position(|&b| b >= 0x80)
        .map(|i| i + 1)
        .ok_or(PacketError::Truncated {
            what: "a SysEx command",
            need: body.len() + 1,
            have: body.len(),
        })?;
    let (data, tail) = (&body[1..end], body[end]);
    let mut out = Vec::with_capacity(data.len() + 2);
    match (head, tail) {
        (0xF0, 0xF7) | (0xF0, 0xF0) | (0xF0, 0xF5) => out.push(0xF0),
        (0xF7, 0xF0) | (0xF7, 0xF7) | (0xF7, 0xF5) if !data.is_empty() || tail != 0xF0 => {}
        (0xF7, 0xF4) if data.is_empty() => {
            r.take(end + 1, "a SysEx cancel")?;
            return Ok(vec![0xF7]);
        }
        _ => {
            return Err(PacketError::Command {
                status: tail,
                at: at + end,
            })
        }
    }
    out.extend_from_slice(data);
    if tail == 0xF7 {
        out.push(0xF7);
    }
    r.take(end + 1, "a SysEx command")?;
    Ok(out)
}

/// Writes a packet: the RTP header (marker bit set), a command section of `commands` (each
/// a whole message with its status byte, and its delta time from the packet's timestamp),
/// and `journal` after it if given (the J flag set).
pub fn write(header: RtpHeader, commands: &[(u32, &[u8])], journal: Option<&[u8]>) -> Vec<u8> {
    let mut list = Vec::new();
    let mut last = 0u32;
    for (i, (t, bytes)) in commands.iter().enumerate() {
        if i > 0 {
            write_delta(&mut list, t.wrapping_sub(last));
        }
        last = *t;
        list.extend_from_slice(bytes);
    }
    let first_delta = commands.first().map_or(0, |c| c.0);
    let mut out = Vec::with_capacity(16 + list.len() + journal.map_or(0, <[u8]>::len));
    out.extend_from_slice(&[0x80, 0x80 | PAYLOAD_TYPE]);
    out.extend_from_slice(&header.seq.to_be_bytes());
    // The packet's timestamp is its first command's: Z stays 0 (no Delta Time 0).
    out.extend_from_slice(&header.timestamp.wrapping_add(first_delta).to_be_bytes());
    out.extend_from_slice(&header.ssrc.to_be_bytes());
    let j = if journal.is_some() { 0x40 } else { 0 };
    let len = list.len().min(0x0FFF);
    if len > 15 {
        out.push(0x80 | j | (len >> 8) as u8);
        out.push(len as u8);
    } else {
        out.push(j | len as u8);
    }
    out.extend_from_slice(&list[..len]);
    if let Some(j) = journal {
        out.extend_from_slice(j);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> RtpHeader {
        RtpHeader {
            seq: 0x1234,
            timestamp: 1000,
            ssrc: 0xDEADBEEF,
        }
    }

    /// The commands' bytes of a packet with this command section.
    fn bytes_of(section: &[u8]) -> Vec<Vec<u8>> {
        let p = rtp(section);
        let m = parse(&p).unwrap();
        m.commands.into_iter().map(|c| c.bytes).collect()
    }

    fn rtp(list_section: &[u8]) -> Vec<u8> {
        let mut p = vec![
            0x80, 0x61, 0x12, 0x34, 0, 0, 0x03, 0xE8, 0xDE, 0xAD, 0xBE, 0xEF,
        ];
        p.extend_from_slice(list_section);
        p
    }

    #[test]
    fn delta_times_as_figure_4_decodes_them() {
        for (enc, v) in [
            (&[0x00][..], 0u32),
            (&[0x80, 0x00], 0),
            (&[0x80, 0x80, 0x80, 0x00], 0),
            (&[0x7F], 127),
            (&[0x81, 0x00], 128),
            (&[0xFF, 0xFF, 0xFF, 0x7F], (1 << 28) - 1),
        ] {
            assert_eq!(delta_time(&mut Reader::new(enc)).unwrap(), v, "{enc:?}");
            if enc.len() == 1 || v != 0 {
                let mut out = Vec::new();
                write_delta(&mut out, v);
                assert_eq!(out, enc);
            }
        }
        let five = [0x80, 0x80, 0x80, 0x80, 0x00];
        assert_eq!(
            delta_time(&mut Reader::new(&five)),
            Err(PacketError::DeltaTime)
        );
    }

    #[test]
    fn short_header_running_status_and_delta_times() {
        // Z = 0, LEN = 10: Note-On C4, delta 5, E4 (running status), delta 0x81 0x00 (128),
        // Note-Off C4 (its own status).
        let p = rtp(&[0x0A, 0x90, 60, 100, 5, 64, 90, 0x81, 0x00, 0x80, 60]);
        assert!(parse(&p).is_err(), "a Note-Off cut short is refused");
        let p = rtp(&[0x0B, 0x90, 60, 100, 5, 64, 90, 0x81, 0x00, 0x80, 60, 0]);
        let m = parse(&p).unwrap();
        assert_eq!(m.header, header());
        assert_eq!(m.journal, None);
        let got: Vec<(u32, Vec<u8>)> = m.commands.into_iter().map(|c| (c.delta, c.bytes)).collect();
        assert_eq!(
            got,
            [
                (0, vec![0x90, 60, 100]),
                (5, vec![0x90, 64, 90]),
                (133, vec![0x80, 60, 0])
            ]
        );
    }

    #[test]
    fn long_header_z_flag_journal_and_realtime_keeping_running_status() {
        let mut list = vec![3, 0x91, 60, 100, 0, 0xF8, 0, 62, 101];
        for n in 0..4u8 {
            list.extend_from_slice(&[0, 70 + n, 1]);
        }
        let len = list.len();
        let mut section = vec![0xE0 | (len >> 8) as u8, len as u8]; // B, J, Z
        section.extend_from_slice(&list);
        section.extend_from_slice(&[0x20, 0x12, 0x30]); // a journal, not read here
        let p = rtp(&section);
        let m = parse(&p).unwrap();
        assert_eq!(m.commands.len(), 7);
        assert_eq!(m.commands[0].delta, 3);
        assert_eq!(m.commands[1].bytes, [0xF8]);
        assert_eq!(m.commands[2].bytes, [0x91, 62, 101]);
        assert_eq!(m.commands[6].bytes, [0x91, 73, 1]);
        assert_eq!(m.journal, Some(&[0x20, 0x12, 0x30][..]));
    }

    #[test]
    fn sysex_whole_segmented_and_cancelled() {
        let m = parse(&rtp(&[0x06, 0x90, 0xF0, 1, 0xF7, 0x00, 0x7F])).err();
        assert_eq!(m, Some(PacketError::StatusInData { at: 1 }));
        let m = parse(&rtp(&[0x06, 0xF0, 1, 2, 0xF7, 0x00, 0x7F])).err();
        assert_eq!(
            m,
            Some(PacketError::NoStatus { at: 5 }),
            "SysEx ends running status"
        );
        assert_eq!(bytes_of(&[0x04, 0xF0, 1, 2, 0xF0]), [vec![0xF0, 1, 2]]);
        assert_eq!(
            bytes_of(&[0x09, 0xF7, 3, 0xF0, 0, 0xF7, 4, 0xF7, 0, 0xF8]),
            [vec![3], vec![4, 0xF7], vec![0xF8]]
        );
        assert_eq!(bytes_of(&[0x02, 0xF7, 0xF4]), [vec![0xF7]]);
        assert!(parse(&rtp(&[0x03, 0xF0, 1, 0xF4])).is_err());
        assert!(parse(&rtp(&[0x02, 0xF0, 1])).is_err(), "unterminated");
    }

    #[test]
    fn hostile_packets_are_refused_with_a_reason() {
        assert!(matches!(
            parse(&[0x80, 0x61, 0]),
            Err(PacketError::Truncated { .. })
        ));
        assert_eq!(
            parse(&rtp(&[0x01, 60])).err(),
            Some(PacketError::NoStatus { at: 0 })
        );
        assert_eq!(
            parse(&rtp(&[0x03, 0x90, 60, 0x90])).err(),
            Some(PacketError::StatusInData { at: 2 })
        );
        assert!(matches!(
            parse(&rtp(&[0x0F, 0x90])),
            Err(PacketError::Truncated { .. })
        ));
        assert_eq!(
            parse(&rtp(&[0x01, 0xF4])).err(),
            Some(PacketError::Command {
                status: 0xF4,
                at: 0
            })
        );
        let mut v1 = rtp(&[0x00]);
        v1[0] = 0x40;
        assert_eq!(parse(&v1).err(), Some(PacketError::Version(1)));
        let mut pt = rtp(&[0x00]);
        pt[1] = 0x60;
        assert_eq!(parse(&pt).err(), Some(PacketError::PayloadType(0x60)));
        let mut pad = rtp(&[0x00, 9]);
        pad[0] |= 0x20;
        assert!(matches!(parse(&pad), Err(PacketError::Length { .. })));
    }

    #[test]
    fn written_packets_read_back() {
        let cmds: [(u32, &[u8]); 3] = [
            (10, &[0x90, 60, 100]),
            (10, &[0xB0, 64, 127]),
            (400, &[0x80, 60, 0]),
        ];
        let p = write(header(), &cmds, Some(&[0x00, 0x12, 0x34]));
        let m = parse(&p).unwrap();
        assert_eq!(m.header.timestamp, 1010);
        let got: Vec<(u32, &[u8])> = m
            .commands
            .iter()
            .map(|c| (c.delta, c.bytes.as_slice()))
            .collect();
        assert_eq!(got, [(0, cmds[0].1), (0, cmds[1].1), (390, cmds[2].1)]);
        assert_eq!(m.journal, Some(&[0x00, 0x12, 0x34][..]));
        assert!(p[12] & 0x80 == 0, "12 bytes: the short header");
        let six = [(0, &[0x90, 60, 1][..]); 6];
        let long = write(header(), &six, None);
        assert_eq!(long[12..14], [0x80, 23], "23 bytes: the long header, no J");
        assert_eq!(parse(&long).unwrap().commands.len(), 6);
        assert!(is_rtp(&p) && !is_rtp(&[0xFF, 0xFF, b'C', b'K']));
    }
}
