//! Play a song to a MIDI output from code: a Standard MIDI File read, the performer pacing
//! its messages on the host's clock (each key's press sent early by its mechanical delay),
//! every byte handed to a `MidiOut`, and the report at the end.
//!
//! The output here prints each message; `orch_io::Output` is the same trait on a serial
//! line, raw MIDI, ALSA or UDP. Drop `.clock(..)` and it plays on the virtual clock, as fast
//! as the machine goes.
//!
//! `cargo run -p orch-perform --example to_midi_out [-- FILE.mid]`

use std::convert::Infallible;

use orch_perform::realtime::PreciseClock;
use orch_perform::{song_events, MidiOut, Performer, Setup, Tempo};
use orch_seq::Song;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).unwrap_or_else(|| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/ode-to-joy.mid").into()
    });
    let song = Song::parse(&std::fs::read(&path)?)?;
    // The thesis's robot (`Setup::for_robot` takes yours), eight times as fast as written.
    let setup = Setup::thesis().with_tempo(Tempo::new(8.0).expect("a tempo factor"));
    let mut out = Printed::default();
    let played = Performer::new(&setup, song_events(&song), song.notes())
        .clock(&mut PreciseClock::new())
        .midi(&mut out)
        .run()?;
    let report = played.report(None);
    println!(
        "{} messages sent; {} notes, {} on time",
        out.messages, report.notes, report.outcomes.on_time
    );
    Ok(())
}

/// A MIDI output that prints the first messages it is given, and counts them all.
#[derive(Default)]
struct Printed {
    messages: usize,
}

impl MidiOut for Printed {
    type Error = Infallible;

    fn send(&mut self, t_us: u64, bytes: &[u8]) -> Result<(), Infallible> {
        if self.messages < 4 {
            println!("{:>7.1} ms  {bytes:02X?}", t_us as f64 / 1000.0);
        }
        self.messages += 1;
        Ok(())
    }
}
