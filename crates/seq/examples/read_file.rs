//! Read a Standard MIDI File: its format, length, tempo and notes, and its first notes with
//! the time each plays and the bar and beat it falls on.
//!
//! Every track is merged in playing order with exact times (µs, through the tempo map); a
//! damaged file is an error, never a panic.
//!
//! `cargo run -p orch-seq --example read_file [-- FILE.mid]`

use orch_seq::Song;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).unwrap_or_else(|| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/ode-to-joy.mid").into()
    });
    let song = Song::parse(&std::fs::read(&path)?)?;
    println!(
        "{:?}, {} notes, {:.1} s, {:.0} bpm at the start",
        song.format(),
        song.notes(),
        song.duration_us() as f64 / 1e6,
        song.tempo_at(0).bpm()
    );
    let notes = song.events().iter().filter_map(|e| {
        let (channel, note, velocity) = e.bytes.note_on()?;
        Some((e.time_us, channel, note, velocity))
    });
    for (t_us, channel, note, velocity) in notes.take(6) {
        let (bar, beat) = song.bar_beat(t_us);
        println!(
            "{:>6.3} s  bar {bar} beat {beat}  channel {} note {note} velocity {velocity}",
            t_us as f64 / 1e6,
            channel + 1
        );
    }
    Ok(())
}
