//! The baseline for `scripts/bench-play.sh`: reads a Standard MIDI File with midly alone and
//! walks every event of every track, doing the least a player must (reading each event and
//! adding up its delta time), and nothing orch does (no strict framing, tempo map, merge,
//! planner, interpreter or virtual robot).
//!
//! ```sh
//! cargo bench --bench midly_parse -- FILE
//! ```
//!
//! Prints one line: tracks, events, Note-Ons with velocity above 0, and the longest track in
//! ticks. Exit code 2 if the file cannot be read or midly refuses it.

use std::process::ExitCode;

use midly::{MidiMessage, Smf, TrackEventKind};

fn main() -> ExitCode {
    let Some(path) = std::env::args_os().nth(1) else {
        eprintln!("usage: midly_parse FILE");
        return ExitCode::from(2);
    };
    let bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("cannot read {}: {e}", path.to_string_lossy());
            return ExitCode::from(2);
        }
    };
    let smf = match Smf::parse(&bytes) {
        Ok(smf) => smf,
        Err(e) => {
            eprintln!("{}: {e}", path.to_string_lossy());
            return ExitCode::from(2);
        }
    };
    let (mut events, mut note_ons, mut longest) = (0usize, 0usize, 0u64);
    for track in &smf.tracks {
        let mut tick = 0u64;
        for event in track {
            events += 1;
            tick += u64::from(event.delta.as_int());
            if let TrackEventKind::Midi {
                message: MidiMessage::NoteOn { vel, .. },
                ..
            } = event.kind
            {
                if vel > 0 {
                    note_ons += 1;
                }
            }
        }
        longest = longest.max(tick);
    }
    println!(
        "tracks {} events {events} note_ons {note_ons} ticks {longest}",
        smf.tracks.len()
    );
    ExitCode::SUCCESS
}
