//! Each note of a song from its Note-On to its Note-Off: what a piano roll draws as the
//! score's notes.

use crate::song::Song;

/// One note of the song: a Note-On with velocity above 0, and the Note-Off that ends it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NoteSpan {
    /// The 0-based channel.
    pub channel: u8,
    /// The MIDI note number.
    pub note: u8,
    /// Its velocity (1..=127).
    pub velocity: u8,
    /// When its Note-On plays, µs from the start of the song.
    pub on_us: u64,
    /// When its Note-Off plays, µs; the song's end ([`Song::duration_us`]) for a note never
    /// let go.
    pub off_us: u64,
}

impl Song {
    /// Every note, in the order of their Note-Ons (the order [`Song::events`] plays them, so
    /// the *i*-th span is the *i*-th of the [`Song::notes`] Note-Ons), each with the time of
    /// the Note-Off that ends it.
    ///
    /// One note at a time on a channel and note number, as orch-core's interpreter reads a
    /// stream: a Note-Off (0x8n, or 0x9n with velocity 0) ends the note that is on; a Note-On
    /// of a note already on (no Note-Off between) ends it there and begins the next (the
    /// interpreter re-strikes the key); a Note-Off with no note on is ignored. So a file whose
    /// Note-Offs do not match its Note-Ons (a Note-Off written before its Note-On at the same
    /// tick) still gives each note its own length, not one running to the next note's end.
    /// All Notes Off and sustain are not counted: the span is the written note.
    pub fn note_spans(&self) -> Vec<NoteSpan> {
        let mut spans: Vec<NoteSpan> = Vec::with_capacity(self.notes());
        // Per (channel, note): the span that is on.
        let mut open: Vec<Option<usize>> = vec![None; 16 * 128];
        for e in self.events() {
            if let Some((ch, note, velocity)) = e.bytes.note_on() {
                let slot = usize::from(ch) * 128 + usize::from(note & 0x7F);
                if let Some(i) = open[slot].replace(spans.len()) {
                    spans[i].off_us = e.time_us;
                }
                spans.push(NoteSpan {
                    channel: ch,
                    note,
                    velocity,
                    on_us: e.time_us,
                    off_us: self.duration_us().max(e.time_us),
                });
            } else if let Some((ch, note)) = e.bytes.note_off() {
                let slot = usize::from(ch) * 128 + usize::from(note & 0x7F);
                if let Some(i) = open[slot].take() {
                    spans[i].off_us = e.time_us;
                }
            }
        }
        spans
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A format-0 file at 480 ticks a quarter (120 bpm until a tempo event: a quarter is
    /// 500 ms) with `events` as (delta ticks, bytes).
    fn smf(events: &[(u32, &[u8])]) -> Vec<u8> {
        let mut track = Vec::new();
        for (delta, bytes) in events {
            // Deltas here stay below 128² and are written as two-byte VLQs.
            track.push(0x80 | (delta >> 7) as u8);
            track.push((delta & 0x7F) as u8);
            track.extend_from_slice(bytes);
        }
        track.extend_from_slice(&[0x00, 0xFF, 0x2F, 0x00]);
        let mut f = b"MThd\0\0\0\x06\0\0\0\x01\x01\xE0MTrk".to_vec();
        f.extend_from_slice(&(track.len() as u32).to_be_bytes());
        f.extend_from_slice(&track);
        f
    }

    #[test]
    fn note_spans_pair_each_note_on_with_its_note_off() {
        let song = Song::parse(&smf(&[
            (0, &[0x90, 60, 100]),
            (0, &[0x91, 64, 50]),
            (480, &[0x80, 60, 0]),
            // A Note-On with velocity 0 is a Note-Off.
            (480, &[0x91, 64, 0]),
            // A Note-Off with nothing sounding is ignored.
            (0, &[0x80, 70, 0]),
        ]))
        .unwrap();
        let spans = song.note_spans();
        assert_eq!(spans.len(), song.notes());
        assert_eq!(
            spans,
            [
                NoteSpan {
                    channel: 0,
                    note: 60,
                    velocity: 100,
                    on_us: 0,
                    off_us: 500_000
                },
                NoteSpan {
                    channel: 1,
                    note: 64,
                    velocity: 50,
                    on_us: 0,
                    off_us: 1_000_000
                },
            ]
        );
    }

    #[test]
    fn note_spans_a_note_on_again_ends_the_note_that_is_on() {
        // Two Cs on one channel with no Note-Off between: the second ends the first (the
        // interpreter re-strikes), the first Note-Off ends the second, the extra one is
        // ignored.
        let song = Song::parse(&smf(&[
            (0, &[0x90, 60, 100]),
            (240, &[0x90, 60, 90]),
            (240, &[0x80, 60, 0]),
            (480, &[0x80, 60, 0]),
        ]))
        .unwrap();
        let spans = song.note_spans();
        assert_eq!(
            spans
                .iter()
                .map(|s| (s.on_us, s.off_us))
                .collect::<Vec<_>>(),
            [(0, 250_000), (250_000, 500_000)]
        );
    }

    #[test]
    fn note_spans_a_note_off_written_before_its_note_on_does_not_shift_later_notes() {
        // As in a corpus file: at one tick, two Note-Offs and then a Note-On whose own
        // Note-Off was written first. The notes after it keep their own lengths.
        let song = Song::parse(&smf(&[
            (0, &[0x90, 60, 100]),
            (480, &[0x80, 60, 0]),
            (0, &[0x80, 60, 0]),
            (0, &[0x90, 60, 100]),
            (480, &[0x90, 60, 100]),
            (240, &[0x80, 60, 0]),
            (240, &[0x90, 60, 100]),
            (240, &[0x80, 60, 0]),
        ]))
        .unwrap();
        let spans = song.note_spans();
        assert_eq!(
            spans
                .iter()
                .map(|s| (s.on_us, s.off_us))
                .collect::<Vec<_>>(),
            [
                (0, 500_000),
                (500_000, 1_000_000),
                (1_000_000, 1_250_000),
                (1_500_000, 1_750_000)
            ]
        );
    }

    #[test]
    fn note_spans_a_note_never_let_go_ends_with_the_song() {
        let song = Song::parse(&smf(&[(0, &[0x90, 60, 100]), (960, &[0x90, 62, 100])])).unwrap();
        let spans = song.note_spans();
        assert_eq!(spans[0].off_us, song.duration_us());
        assert_eq!(spans[1].off_us, song.duration_us());
        assert_eq!(song.duration_us(), 1_000_000);
    }
}
