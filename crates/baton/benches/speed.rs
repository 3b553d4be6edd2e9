//! Tracker speed: 640×480 frames a second on one core, against real time at 60 fps.
//! `cargo bench -p orch-baton --bench speed`
//!
//! The frames are drawn first (a cluttered scene with a red sleeve, an exit sign, a standby
//! light, noise σ 8 and motion blur: the most red pixels the harness makes), then timed
//! through [`Baton::push`] (red blobs, tracker, beats) on this thread alone, and through the
//! conversion a `.y4m` file needs first (4:2:0 Y'CbCr to RGB) plus the tracker.

use std::time::Instant;

use orch_baton::frame::YCbCr;
use orch_baton::synth::{Script, Video};
use orch_baton::{Baton, Frame};

fn main() {
    let fps = 60.0;
    let video = Video::new(
        Script::steady("speed", 120.0, fps)
            .beats(8)
            .clutter()
            .second_red()
            .blur()
            .noise(8.0)
            .seed(3),
    );
    let frames: Vec<(f64, Frame)> = video.frames().take(180).collect();
    let yuv: Vec<(Vec<u8>, Vec<u8>, Vec<u8>)> =
        frames.iter().map(|(_, f)| f.to_ycbcr420()).collect();
    let passes = 8;
    let period = frames.len() as f64 * 1000.0 / fps;

    let mut baton = Baton::default();
    let mut beats = 0;
    let start = Instant::now();
    for pass in 0..passes {
        for (t, f) in &frames {
            beats += usize::from(baton.push(t + pass as f64 * period, f).is_some());
        }
    }
    let n = (passes * frames.len()) as f64;
    let tracker = n / start.elapsed().as_secs_f64();

    let mut baton = Baton::default();
    let mut frame = Frame::default();
    let start = Instant::now();
    for pass in 0..passes {
        for ((t, _), (y, u, v)) in frames.iter().zip(&yuv) {
            let planes = YCbCr {
                y,
                cb: u,
                cr: v,
                chroma_width: 320,
                chroma_height: 240,
            };
            frame.fill_from_ycbcr(640, 480, planes);
            baton.push(t + pass as f64 * period, &frame);
        }
    }
    let with_yuv = n / start.elapsed().as_secs_f64();

    println!(
        "640×480, {} frames, one core ({beats} beats found):",
        n as u64
    );
    println!(
        "  tracker (blobs, track, beats):   {tracker:7.0} frames/s = {:5.1}× real time at 60 fps",
        tracker / 60.0
    );
    println!(
        "  4:2:0 to RGB, then the tracker:  {with_yuv:7.0} frames/s = {:5.1}× real time at 60 fps",
        with_yuv / 60.0
    );
}
