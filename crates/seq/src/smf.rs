//! Strict framing of a Standard MIDI File: chunks, and the boundaries of each track event.
//!
//! midly decodes the header and every event, but without its `strict` feature (which would
//! change midly for every crate in the workspace) it quietly accepts damage: a chunk that runs
//! past the end of the file is cut to what is there, a malformed event ends its track
//! silently, a SysEx or meta event longer than its track is shortened. A player must not
//! pretend a damaged file is whole, so this module checks the framing first and reports the
//! first fault with its byte offset; midly then decodes each event the framing vouches for.
//!
//! The rules follow the SMF 1.0 specification and what mido (the reference for the corpus)
//! accepts:
//! - the file starts with `MThd`; its length is at least 6 (longer headers are skipped over);
//! - formats 0, 1 and 2; a format-0 file with several tracks is played like format 1;
//! - every track the header declares must be there, whole; chunks with other ids are skipped
//!   (the specification says so; mido refuses them); bytes after the last declared track are
//!   ignored;
//! - in a track: variable-length quantities of at most 4 bytes, every event complete inside
//!   its chunk, data bytes of channel messages below 0x80, a data byte where a status must be
//!   only while a channel status is in force (running status). Meta events leave running
//!   status alone (mido and real files do so); SysEx and escape events cancel it. System common
//!   and real-time status bytes (0xF1–0xF6, 0xF8–0xFE) are not allowed in a file.

use crate::error::SeqError;

/// The header and the declared tracks' bytes.
pub(crate) struct Chunks<'a> {
    pub header: midly::Header,
    pub tracks: Vec<TrackBytes<'a>>,
}

/// One track chunk's data.
pub(crate) struct TrackBytes<'a> {
    pub data: &'a [u8],
    /// File offset of `data[0]`.
    pub offset: usize,
}

fn be_u32(b: &[u8]) -> u32 {
    u32::from_be_bytes([b[0], b[1], b[2], b[3]])
}

/// Checks the header and splits out the declared tracks.
pub(crate) fn split(bytes: &[u8]) -> Result<Chunks<'_>, SeqError> {
    if bytes.is_empty() {
        return Err(SeqError::Empty);
    }
    if bytes.len() < 4 || &bytes[..4] != b"MThd" {
        return Err(SeqError::NotMidi);
    }
    if bytes.len() < 8 {
        return Err(SeqError::BadHeader("the file ends inside the header chunk"));
    }
    let header_len = be_u32(&bytes[4..8]) as usize;
    if header_len < 6 {
        return Err(SeqError::BadHeader(
            "the header chunk is shorter than 6 bytes",
        ));
    }
    if bytes.len() - 8 < header_len {
        return Err(SeqError::BadHeader("the file ends inside the header chunk"));
    }
    let format = u16::from_be_bytes([bytes[8], bytes[9]]);
    if format > 2 {
        return Err(SeqError::UnsupportedFormat(format));
    }
    let declared = u16::from_be_bytes([bytes[10], bytes[11]]);
    let division = u16::from_be_bytes([bytes[12], bytes[13]]);
    if division & 0x8000 == 0 {
        if division == 0 {
            return Err(SeqError::BadDivision("0 ticks per quarter note"));
        }
    } else {
        let fps = (division >> 8) as u8 as i8;
        if !matches!(fps, -24 | -25 | -29 | -30) {
            return Err(SeqError::BadDivision(
                "SMPTE frame rate is not 24, 25, 29.97 or 30",
            ));
        }
        if division & 0xFF == 0 {
            return Err(SeqError::BadDivision("0 ticks per SMPTE frame"));
        }
    }
    // midly reads the header we have just checked.
    let (header, _) = midly::parse(&bytes[..8 + header_len])
        .map_err(|_| SeqError::BadHeader("midly could not read the header"))?;

    let mut tracks = Vec::new();
    let mut pos = 8 + header_len;
    while tracks.len() < declared as usize {
        if pos == bytes.len() {
            return Err(SeqError::MissingTracks {
                declared,
                found: tracks.len() as u16,
            });
        }
        if bytes.len() - pos < 8 {
            return Err(SeqError::ChunkHeaderCut { offset: pos });
        }
        let len = be_u32(&bytes[pos + 4..pos + 8]);
        let available = bytes.len() - pos - 8;
        if len as usize > available {
            return Err(SeqError::ChunkPastEnd {
                offset: pos,
                declared: len,
                available,
            });
        }
        let data = &bytes[pos + 8..pos + 8 + len as usize];
        if &bytes[pos..pos + 4] == b"MTrk" {
            tracks.push(TrackBytes {
                data,
                offset: pos + 8,
            });
        }
        pos += 8 + len as usize;
    }
    Ok(Chunks { header, tracks })
}

/// One event's place in its track.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Framed {
    /// Index of the event's delta time in the track data.
    pub start: usize,
    /// Index just past the event.
    pub end: usize,
    /// The delta time in ticks.
    pub delta: u32,
    /// The running status in force before the event.
    pub running_before: Option<u8>,
    /// The event's status (resolved through running status).
    pub status: u8,
}

/// Iterates the framed events of one track; stops after the first error.
pub(crate) struct Frames<'a> {
    data: &'a [u8],
    pos: usize,
    running: Option<u8>,
    track: u16,
    offset: usize,
    failed: bool,
}

impl<'a> Frames<'a> {
    pub(crate) fn new(track: u16, bytes: &TrackBytes<'a>) -> Self {
        Self {
            data: bytes.data,
            pos: 0,
            running: None,
            track,
            offset: bytes.offset,
            failed: false,
        }
    }

    fn err(&mut self, at: usize, reason: &'static str) -> SeqError {
        self.failed = true;
        SeqError::Event {
            track: self.track,
            offset: self.offset + at,
            reason,
        }
    }

    /// Reads a variable-length quantity at `self.pos`.
    fn vlq(&mut self, what_cut: &'static str) -> Result<u32, SeqError> {
        let mut value: u32 = 0;
        for i in 0..4 {
            let Some(&b) = self.data.get(self.pos) else {
                return Err(self.err(self.pos, what_cut));
            };
            self.pos += 1;
            value = (value << 7) | u32::from(b & 0x7F);
            if b & 0x80 == 0 {
                return Ok(value);
            }
            if i == 3 {
                break;
            }
        }
        Err(self.err(self.pos - 1, "variable-length number longer than 4 bytes"))
    }

    /// Skips a length-prefixed body (SysEx, escape, meta data).
    fn body(&mut self, what: &'static str) -> Result<(), SeqError> {
        let len = self.vlq(what)? as usize;
        if self.data.len() - self.pos < len {
            return Err(self.err(self.pos, what));
        }
        self.pos += len;
        Ok(())
    }

    fn frame(&mut self) -> Result<Framed, SeqError> {
        let start = self.pos;
        let running_before = self.running;
        let delta = self.vlq("delta time cut short at the end of the track")?;
        let Some(&first) = self.data.get(self.pos) else {
            return Err(self.err(self.pos, "event missing after its delta time"));
        };
        let status = if first < 0x80 {
            match self.running {
                Some(s) => s,
                None => {
                    return Err(self.err(
                        self.pos,
                        "data byte where a status byte must be, with no running status",
                    ))
                }
            }
        } else {
            self.pos += 1;
            first
        };
        match status {
            0x80..=0xEF => {
                self.running = Some(status);
                let need = if matches!(status & 0xF0, 0xC0 | 0xD0) {
                    1
                } else {
                    2
                };
                for _ in 0..need {
                    match self.data.get(self.pos) {
                        None => {
                            return Err(self.err(
                                self.pos,
                                "channel message cut short by the end of the track",
                            ))
                        }
                        Some(&b) if b >= 0x80 => {
                            return Err(self.err(
                                self.pos,
                                "status byte inside a channel message (message cut short)",
                            ))
                        }
                        Some(_) => self.pos += 1,
                    }
                }
            }
            0xFF => {
                if self.pos >= self.data.len() {
                    return Err(self.err(self.pos, "meta event cut short by the end of the track"));
                }
                self.pos += 1; // type
                self.body("meta event longer than the rest of its track")?;
            }
            0xF0 | 0xF7 => {
                self.running = None;
                self.body("SysEx event longer than the rest of its track")?;
            }
            _ => {
                return Err(self.err(
                    self.pos - 1,
                    "system common or real-time status byte, not allowed in a MIDI file",
                ))
            }
        }
        Ok(Framed {
            start,
            end: self.pos,
            delta,
            running_before,
            status,
        })
    }
}

impl Iterator for Frames<'_> {
    type Item = Result<Framed, SeqError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed || self.pos >= self.data.len() {
            return None;
        }
        Some(self.frame())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(data: &[u8]) -> Vec<Result<Framed, SeqError>> {
        Frames::new(0, &TrackBytes { data, offset: 0 }).collect()
    }

    #[test]
    fn running_status_survives_meta_but_not_sysex() {
        let ok = track(&[0, 0x90, 60, 100, 0, 0xFF, 0x01, 1, b'x', 0, 60, 0]);
        assert!(ok.iter().all(Result::is_ok));
        assert_eq!(ok.len(), 3);
        let bad = track(&[0, 0x90, 60, 100, 0, 0xF0, 1, 0xF7, 0, 60, 0]);
        assert!(bad.last().unwrap().is_err());
    }

    #[test]
    fn five_byte_vlq_is_refused() {
        let r = track(&[0x81, 0x81, 0x81, 0x81, 0x01, 0x90, 60, 100]);
        assert!(matches!(r[0], Err(SeqError::Event { .. })));
    }

    #[test]
    fn status_inside_channel_message_is_refused() {
        let r = track(&[0, 0x90, 60, 0x80]);
        assert!(r[0].is_err());
    }

    #[test]
    fn sysex_longer_than_track_is_refused() {
        let r = track(&[0, 0xF0, 0x7F, 1, 2, 3]);
        assert!(r[0].is_err());
    }

    #[test]
    fn system_common_in_track_is_refused() {
        let r = track(&[0, 0xF2, 1, 2]);
        assert!(r[0].is_err());
    }
}
