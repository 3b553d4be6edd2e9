//! How fast `orch render` renders against real time: a corpus file performed on the virtual
//! thesis robot and rendered through the installed soundfont (the performance and the
//! synthesis timed apart), and the score itself.
//!
//! `cargo bench -p orch-render --bench render_speed -- [FILE.mid] [SF2]`
//! (default: `../shared/midi/bach-bwv846-prelude.mid` from the repository, the soundfont
//! `orch render` would choose).

use std::path::{Path, PathBuf};
use std::time::Instant;

use orch_perform::{song_events, Performer, Setup};
use orch_render::{events, soundfont, synth, Settings};
use orch_seq::Song;

fn main() {
    // `cargo bench` adds `--bench`.
    let mut args = std::env::args().skip(1).filter(|a| a != "--bench");
    let file = args.next().map_or_else(
        || {
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../../shared/midi/bach-bwv846-prelude.mid")
        },
        PathBuf::from,
    );
    let sf2 = args.next().map(PathBuf::from);
    let font_path = soundfont::find(sf2.as_deref()).unwrap_or_else(|e| panic!("{e}"));
    let t = Instant::now();
    let font = soundfont::load(&font_path).unwrap();
    let load = t.elapsed().as_secs_f64();
    let bytes = std::fs::read(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    let song = Song::parse(&bytes).unwrap();
    let setup = Setup::thesis().with_keep(orch_sim::Keep::Everything);
    println!(
        "{} ({} notes), soundfont {} (loaded in {:.3} s)",
        file.display(),
        song.notes(),
        font_path.display(),
        load
    );
    let t = Instant::now();
    let played = Performer::new(&setup, song_events(&song), song.notes())
        .run()
        .unwrap();
    let keys = events::from_performance(&played.performance, played.start_us, 36).unwrap();
    let perform_s = t.elapsed().as_secs_f64();
    for (what, keys, before) in [
        ("the robot", keys, perform_s),
        ("the score", events::from_song(&song), 0.0),
    ] {
        let settings = Settings::default();
        let t = Instant::now();
        let mut sum = 0f64; // consume the samples as a writer would
        let out = synth::render(&font, &keys, &settings, |l, r| {
            sum += f64::from(l[0]) + f64::from(r[0]);
            Ok(())
        })
        .unwrap();
        let synth_s = t.elapsed().as_secs_f64();
        let audio = out.frames as f64 / f64::from(settings.sample_rate);
        let total = before + synth_s;
        println!(
            "{what}: {audio:.1} s of audio, {} strikes, peak {:.1} dBFS: performed in {before:.3} s, \
             synthesised in {synth_s:.3} s: {:.0}x real time ({:.0}x the synthesis alone){}",
            out.strikes,
            20.0 * f64::from(out.peak).log10(),
            audio / total,
            audio / synth_s,
            if sum.is_nan() { " (NaN!)" } else { "" }
        );
    }
}
