//! The evaluation harness: scores the tracker on every generated video at 30 and 60 fps and
//! prints the table (Markdown). `cargo bench -p orch-baton --bench harness`
//! (`-- 30` for one frame rate only).

use orch_baton::{synth, Params};

fn main() {
    let rates: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let rates = if rates.is_empty() {
        vec![30.0, 60.0]
    } else {
        rates
    };
    let scripts: Vec<synth::Script> = rates.iter().flat_map(|&f| synth::suite(f)).collect();
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let scores = synth::run(&scripts, Params::default(), threads);
    println!("{}", synth::Score::header());
    let mut failed = 0;
    for s in &scores {
        println!("{}", s.row());
        if let Err(e) = s.check() {
            eprintln!("below the bar: {e}");
            failed += 1;
        }
    }
    println!(
        "\n{} videos, {} below the bar (steady: tempo median < 1 BPM, changing: < 3 BPM; beat median ≤ 1 frame + 10 ms; missed + invented ≤ 5 %)",
        scores.len(),
        failed
    );
    if failed > 0 {
        std::process::exit(1);
    }
}
