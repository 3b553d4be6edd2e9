//! MIDI messages as people and scripts read them (`orch decode`): the decoder with the
//! System Exclusive payloads it keeps ([`Messages`]), and each message as text in the manner
//! of `aseqdump` or as a JSON line with mido's message names and fields (channels 0-based),
//! then the counters.

use std::io::{self, Write};

use orch_core::{Counters, Decoder, Message};
use serde_json::{json, Value};

/// How much of a System Exclusive message's payload is kept and shown: the first 1 MiB. A
/// longer one is shown with its first 1 MiB and its full length (text: "... (N more not
/// shown)"; JSON: a `"length"` beside `"data"`), so memory stays bounded however long it is.
pub const SYSEX_SHOWN: usize = 1 << 20;

/// A decoder that keeps the start of each System Exclusive payload ([`SYSEX_SHOWN`] bytes) to
/// show it.
#[derive(Debug, Default)]
pub struct Messages {
    decoder: Decoder<0>,
    /// The payload of the System Exclusive message being received (the decoder keeps none).
    sysex: Vec<u8>,
}

impl Messages {
    /// A decoder at the start of a stream.
    pub fn new() -> Self {
        Self::default()
    }

    /// Decodes `byte`, calling `each` with every message it ends (a System Exclusive message
    /// with its payload's start), and stops at `each`'s first error.
    pub fn push<E>(
        &mut self,
        byte: u8,
        mut each: impl FnMut(Shown<'_>) -> Result<(), E>,
    ) -> Result<(), E> {
        if self.decoder.in_sysex() && byte < 0x80 && self.sysex.len() < SYSEX_SHOWN {
            self.sysex.push(byte);
        }
        for message in self.decoder.push(byte) {
            if message == Message::SysExStart {
                self.sysex.clear();
            }
            each(Shown {
                message,
                sysex: &self.sysex,
            })?;
        }
        Ok(())
    }

    /// The end of the stream: the counters, and whether the end cut a message off.
    pub fn finish(&mut self) -> (Counters, bool) {
        let truncated = self.decoder.finish();
        (self.decoder.counters(), truncated)
    }
}

/// A message with the System Exclusive payload the caller collected: all of it, or its start
/// (a [`Message::SysEx`] says the full length).
pub struct Shown<'a> {
    /// The message.
    pub message: Message,
    /// The start of its System Exclusive payload (a [`Message::SysEx`]'s).
    pub sysex: &'a [u8],
}

/// One line of text for a message.
pub fn text(m: &Shown<'_>) -> String {
    use Message::*;
    match m.message {
        NoteOff {
            channel,
            note,
            velocity,
        } => {
            format!("Note off               {channel:2}, note {note}, velocity {velocity}")
        }
        NoteOn {
            channel,
            note,
            velocity,
        } => {
            format!("Note on                {channel:2}, note {note}, velocity {velocity}")
        }
        PolyPressure {
            channel,
            note,
            pressure,
        } => {
            format!("Polyphonic aftertouch  {channel:2}, note {note}, value {pressure}")
        }
        ControlChange {
            channel,
            controller,
            value,
        } => {
            format!("Control change         {channel:2}, controller {controller}, value {value}")
        }
        ProgramChange { channel, program } => {
            format!("Program change         {channel:2}, program {program}")
        }
        ChannelPressure { channel, pressure } => {
            format!("Channel aftertouch     {channel:2}, value {pressure}")
        }
        PitchBend { channel, value } => {
            format!(
                "Pitch bend             {channel:2}, value {}",
                value.centered()
            )
        }
        SysExStart => "System exclusive start".into(),
        SysEx { len, terminated } => {
            let mut s = Vec::new();
            write_sysex_text(&mut s, m.sysex, len, terminated).expect("writing to a Vec");
            String::from_utf8(s).expect("ASCII")
        }
        QuarterFrame(data) => {
            let (t, v) = Message::quarter_frame_parts(data);
            format!("MTC quarter frame      type {t}, value {v}")
        }
        SongPosition(pos) => format!("Song position pointer  value {}", pos.get()),
        SongSelect(song) => format!("Song select            value {song}"),
        TuneRequest => "Tune request".into(),
        Clock => "Clock".into(),
        Start => "Start".into(),
        Continue => "Continue".into(),
        Stop => "Stop".into(),
        ActiveSensing => "Active Sensing".into(),
        Reset => "System reset".into(),
    }
}

/// The message as a mido-style dict, or `None` for the SysEx start notification.
pub fn json(m: &Shown<'_>) -> Option<Value> {
    use Message::*;
    Some(match m.message {
        NoteOff {
            channel,
            note,
            velocity,
        } => {
            json!({"type": "note_off", "channel": channel.get(), "note": note.get(), "velocity": velocity.get()})
        }
        NoteOn {
            channel,
            note,
            velocity,
        } => {
            json!({"type": "note_on", "channel": channel.get(), "note": note.get(), "velocity": velocity.get()})
        }
        PolyPressure {
            channel,
            note,
            pressure,
        } => {
            json!({"type": "polytouch", "channel": channel.get(), "note": note.get(), "value": pressure.get()})
        }
        ControlChange {
            channel,
            controller,
            value,
        } => {
            json!({"type": "control_change", "channel": channel.get(), "control": controller.get(), "value": value.get()})
        }
        ProgramChange { channel, program } => {
            json!({"type": "program_change", "channel": channel.get(), "program": program.get()})
        }
        ChannelPressure { channel, pressure } => {
            json!({"type": "aftertouch", "channel": channel.get(), "value": pressure.get()})
        }
        PitchBend { channel, value } => {
            json!({"type": "pitchwheel", "channel": channel.get(), "pitch": value.centered()})
        }
        SysExStart => return None,
        SysEx { len, .. } if len as usize > m.sysex.len() => {
            json!({"type": "sysex", "data": m.sysex, "length": len})
        }
        SysEx { .. } => json!({"type": "sysex", "data": m.sysex}),
        QuarterFrame(data) => {
            let (t, v) = Message::quarter_frame_parts(data);
            json!({"type": "quarter_frame", "frame_type": t, "frame_value": v})
        }
        SongPosition(pos) => json!({"type": "songpos", "pos": pos.get()}),
        SongSelect(song) => json!({"type": "song_select", "song": song.get()}),
        TuneRequest => json!({"type": "tune_request"}),
        Clock => json!({"type": "clock"}),
        Start => json!({"type": "start"}),
        Continue => json!({"type": "continue"}),
        Stop => json!({"type": "stop"}),
        ActiveSensing => json!({"type": "active_sensing"}),
        Reset => json!({"type": "reset"}),
    })
}

/// Writes a System Exclusive message as one line of text (no newline): `data` is the start of
/// its payload that was kept, `len` its full length.
pub fn write_sysex_text(
    out: &mut impl Write,
    data: &[u8],
    len: u32,
    terminated: bool,
) -> io::Result<()> {
    out.write_all(b"System exclusive       F0")?;
    for b in data {
        write!(out, " {b:02X}")?;
    }
    if data.len() < len as usize {
        write!(out, " ... ({} more not shown)", len as usize - data.len())?;
    }
    if terminated {
        out.write_all(b" F7")?;
    } else {
        out.write_all(b" (cut short by a status byte)")?;
    }
    write!(out, "  [{len} data bytes]")
}

/// Writes a System Exclusive message as one JSON object (no newline), straight from the
/// bytes: `{"type":"sysex","data":[...]}` as mido has it, with `"length"` added when `data`
/// is only the start of a payload of `len` bytes.
pub fn write_sysex_json(out: &mut impl Write, data: &[u8], len: u32) -> io::Result<()> {
    out.write_all(br#"{"type":"sysex","data":"#)?;
    serde_json::to_writer(&mut *out, data)?;
    if data.len() < len as usize {
        write!(out, r#","length":{len}"#)?;
    }
    out.write_all(b"}")
}

/// The counters as the last line of text; `truncated` is whether the end of the input cut a
/// message off.
pub fn counters_text(c: &Counters, truncated: bool) -> String {
    format!(
        "# {} bytes, {} messages, {} dropped, {} abandoned, {} truncated",
        c.bytes,
        c.messages,
        c.dropped,
        c.abandoned,
        u8::from(truncated)
    )
}

/// The counters as the last JSON line; `truncated` as for [`counters_text`].
pub fn counters_json(c: &Counters, truncated: bool) -> Value {
    json!({"type": "summary", "bytes": c.bytes, "messages": c.messages, "dropped": c.dropped, "abandoned": c.abandoned, "truncated": u8::from(truncated)})
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every message of `bytes` as text, a SysEx's payload written out.
    fn shown(bytes: &[u8]) -> (Vec<String>, Vec<Value>, Counters) {
        let mut m = Messages::new();
        let (mut text, mut json) = (Vec::new(), Vec::new());
        for &b in bytes {
            m.push(b, |s| -> io::Result<()> {
                if let Message::SysEx { len, terminated } = s.message {
                    let mut t = Vec::new();
                    write_sysex_text(&mut t, s.sysex, len, terminated)?;
                    text.push(String::from_utf8(t).unwrap());
                    let mut j = Vec::new();
                    write_sysex_json(&mut j, s.sysex, len)?;
                    json.push(serde_json::from_slice(&j).unwrap());
                } else if s.message != Message::SysExStart {
                    text.push(super::text(&s));
                    json.extend(super::json(&s));
                }
                Ok(())
            })
            .unwrap();
        }
        (text, json, m.finish().0)
    }

    #[test]
    fn a_sysex_payload_is_kept_and_each_message_shown_as_text_and_json() {
        let (text, json, c) = shown(&[0xF0, 1, 2, 0xF7, 0x90, 60, 64, 0xF0, 5, 0x80, 60, 0]);
        assert_eq!(
            text,
            [
                "System exclusive       F0 01 02 F7  [2 data bytes]",
                "Note on                 0, note 60, velocity 64",
                "System exclusive       F0 05 (cut short by a status byte)  [1 data bytes]",
                "Note off                0, note 60, velocity 0",
            ]
        );
        assert_eq!(json[0], json!({"type": "sysex", "data": [1, 2]}));
        assert_eq!(
            json[1],
            json!({"type": "note_on", "channel": 0, "note": 60, "velocity": 64})
        );
        assert_eq!(json[2], json!({"type": "sysex", "data": [5]}));
        assert_eq!((c.bytes, c.messages), (12, 4));
        assert_eq!(
            counters_text(&c, false),
            "# 12 bytes, 4 messages, 0 dropped, 0 abandoned, 0 truncated"
        );
    }

    #[test]
    fn a_payload_past_what_is_shown_says_its_length() {
        let mut data = vec![0u8; 10];
        let mut t = Vec::new();
        write_sysex_text(&mut t, &data[..3], 10, true).unwrap();
        assert_eq!(
            String::from_utf8(t).unwrap(),
            "System exclusive       F0 00 00 00 ... (7 more not shown) F7  [10 data bytes]"
        );
        data.truncate(2);
        let mut j = Vec::new();
        write_sysex_json(&mut j, &data, 10).unwrap();
        assert_eq!(
            String::from_utf8(j).unwrap(),
            r#"{"type":"sysex","data":[0,0],"length":10}"#
        );
    }
}
