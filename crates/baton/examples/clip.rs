//! Writes one video of the harness's suite as a `.y4m` file, and its true beats as JSON lines
//! beside it (`OUT.truth.jsonl`), to try `orch baton` on:
//! `cargo run --release -p orch-baton --example clip -- "steady 120" 30 clip.y4m`
//! (no arguments: lists the videos).

use std::io::Write;

use orch_baton::source::Y4mWriter;
use orch_baton::synth::{suite, Video};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [name, fps, out] = args.as_slice() else {
        eprintln!("usage: clip NAME FPS OUT.y4m; the videos:");
        for s in suite(30.0) {
            eprintln!("  {}", s.name);
        }
        std::process::exit(2);
    };
    let fps: f64 = fps.parse().expect("FPS: a number");
    let Some(script) = suite(fps).into_iter().find(|s| &s.name == name) else {
        eprintln!("no video named {name:?}");
        std::process::exit(2);
    };
    let video = Video::new(script);
    let file = std::io::BufWriter::new(std::fs::File::create(out).expect("create OUT"));
    let mut w = Y4mWriter::new(file, video.script.width, video.script.height, fps).unwrap();
    let mut n = 0;
    for i in 0..video.frame_count() {
        // A file has every frame: dropped ones are written too (a camera would drop them).
        let (_, f) = video.frame_at(i);
        w.write(&f).unwrap();
        n += 1;
    }
    let mut truth = std::fs::File::create(format!("{out}.truth.jsonl")).expect("create truth");
    for t in &video.truth {
        writeln!(
            truth,
            r#"{{"t_ms":{:.1},"bpm":{:.2},"x":{:.1},"y":{:.1}}}"#,
            t.t_ms, t.bpm, t.x, t.y
        )
        .unwrap();
    }
    eprintln!(
        "{out}: {n} frames at {fps} fps, {} beats",
        video.truth.len()
    );
}
