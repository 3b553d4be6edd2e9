//! The files a performance leaves, one JSON object a line: the note-by-note account (every
//! note of the score with its outcome) and the board writes (every write to every robot's
//! finger boards).

use std::io::{self, Write};

use orch_io::Channels;
use orch_perform::{Played, Tempo};
use orch_seq::Song;
use serde_json::{json, Map, Value};

use crate::places::Places;
use crate::session::Ended;

/// The note-by-note account of `played` (a performance of `song`'s `channels` begun at
/// `tempo`), a JSON object a note in score order, with `"out"` first when `out` names the
/// robot. Bars and beats are the song's own, whatever the tempo did ([`Places`]).
pub fn account(
    song: &Song,
    played: &Played,
    channels: Channels,
    tempo: Tempo,
    out: Option<&str>,
) -> Vec<Value> {
    let places = Places::of(song, played, channels, tempo);
    played
        .account(|i, t_ms| places.bar_beat(song, i, t_ms))
        .into_iter()
        .map(|line| {
            let mut value = serde_json::to_value(&line).expect("an account line is JSON");
            if let (Some(out), Some(map)) = (out, value.as_object_mut()) {
                let mut with = Map::new();
                with.insert("out".into(), out.into());
                with.extend(std::mem::take(map));
                *map = with;
            }
            value
        })
        .collect()
}

/// Writes [`account`], a line a note.
pub fn write_account(
    file: &mut impl Write,
    song: &Song,
    played: &Played,
    channels: Channels,
    tempo: Tempo,
    out: Option<&str>,
) -> io::Result<()> {
    for line in account(song, played, channels, tempo, out) {
        writeln!(file, "{line}")?;
    }
    file.flush()
}

/// Writes every robot's account (`--notes`), robot after robot, a line a note; each line
/// says its robot's output when there are several.
pub fn write_accounts(
    file: &mut impl Write,
    song: &Song,
    ended: &[Ended],
    tempo: Tempo,
) -> io::Result<()> {
    let several = ended.len() > 1;
    for e in ended {
        let out = several.then_some(e.spec.text.as_str());
        write_account(file, song, &e.played, e.spec.channels, tempo, out)?;
    }
    Ok(())
}

/// Every robot's board writes, robot after robot, a JSON object a write: `out`, `t_us`,
/// `address`, and the 16 pins a PCA9555 drives after it (`outputs`) or a PCA9685's 16
/// duties (`duty`, 0..=4095).
pub fn board_writes(ended: &[Ended]) -> impl Iterator<Item = Value> + '_ {
    ended.iter().flat_map(|e| {
        e.played
            .performance
            .writes
            .iter()
            .map(move |w| match w.duty {
                Some(duty) => json!({
                    "out": e.spec.text,
                    "t_us": w.end.as_micros(),
                    "address": w.address,
                    "duty": duty,
                }),
                None => json!({
                    "out": e.spec.text,
                    "t_us": w.end.as_micros(),
                    "address": w.address,
                    "outputs": w.driven,
                }),
            })
    })
}

/// Writes [`board_writes`] (`--writes`), a line each.
pub fn write_board_writes(file: &mut impl Write, ended: &[Ended]) -> io::Result<()> {
    for line in board_writes(ended) {
        writeln!(file, "{line}")?;
    }
    file.flush()
}
