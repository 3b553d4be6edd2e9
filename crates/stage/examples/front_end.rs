//! A minimal front end on orch-stage: load a song and a robot, set up, play live on the
//! virtual robot, watch where it stands, and print the report, as `orch play` does.
//!
//! `Play` is told once what to do; `.robot(path)`, `.outs(["serial:/dev/ttyUSB0"])`,
//! `.from_bar(n)` or `.fast(true)` (the virtual clock) change it. The watcher is called over
//! and over with the live session until the song ends.
//!
//! `cargo run -p orch-stage --example front_end [-- FILE.mid]`

use std::path::PathBuf;
use std::time::Duration;

use orch_stage::play::Play;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let file: PathBuf = std::env::args().nth(1).map_or_else(
        || concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/ode-to-joy.mid").into(),
        PathBuf::from,
    );
    let mut bar_shown = 0;
    let performed = Play::file(&file)
        .tempo(4.0)
        .watch(|session| {
            if let Some(now) = session.snapshot().filter(|s| s.bar > bar_shown) {
                println!(
                    "bar {:>2}  {:>5.1} s of {:.1}",
                    now.bar, now.elapsed_s, now.total_s
                );
                bar_shown = now.bar;
            }
            std::thread::sleep(Duration::from_millis(20));
            Ok::<_, std::io::Error>(())
        })
        .run()?;
    print!("{}", orch_stage::text::reports(&performed.reports(), &file));
    Ok(())
}
