//! Frames from files, through the same path `orch baton` uses ([`source::open`]).

use orch_baton::source::{self, FrameSource, SourceError, Y4mWriter};
use orch_baton::synth::{self, Script, Video};
use orch_baton::{Baton, Beat, Frame};

fn scratch(name: &str) -> testkit::Scratch {
    testkit::Scratch::new(&format!("baton-{name}"))
}

fn run(src: &mut dyn FrameSource) -> (Vec<Beat>, usize) {
    let mut baton = Baton::default();
    let mut frame = Frame::default();
    let mut beats = Vec::new();
    let mut n = 0;
    while let Some(t) = src.next_frame(&mut frame).unwrap() {
        n += 1;
        beats.extend(baton.push(t, &frame));
    }
    (beats, n)
}

#[test]
fn y4m_round_trip() {
    let video = Video::new(Script::steady("y4m", 160.0, 30.0).beats(5).noise(4.0));
    let frames_in: Vec<(f64, Frame)> = video.frames().collect();
    let dir = scratch("y4m");
    let path = dir.join("clip.y4m");
    {
        let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        let mut w = Y4mWriter::new(file, 640, 480, 30.0).unwrap();
        for (_, f) in &frames_in {
            w.write(f).unwrap();
        }
    }
    let mut src = source::open(&path, None).unwrap();
    assert_eq!(src.fps(), 30.0);
    let (beats, frames) = run(src.as_mut());
    assert_eq!(frames, video.frame_count());
    let score = synth::score(&video, &beats, frames);
    println!("{}", score.row());
    assert_eq!((score.missed, score.invented), (0, 0), "{score:?}");
    assert!(score.beat_err_ms.0 < 1000.0 / 30.0 + 10.0, "{score:?}");
    // Through 4:2:0 and back the LED is where it was, within a pixel.
    let in_memory: Vec<Beat> = {
        let mut b = Baton::default();
        frames_in
            .iter()
            .filter_map(|(t, f)| b.push(*t, f))
            .collect()
    };
    assert_eq!(in_memory.len(), beats.len());
    for (a, b) in in_memory.iter().zip(&beats) {
        assert!((a.t_ms - b.t_ms).abs() < 3.0, "{a:?} {b:?}");
        assert!(
            (a.x - b.x).abs() < 1.0 && (a.y - b.y).abs() < 1.0,
            "{a:?} {b:?}"
        );
        if let (Some(x), Some(y)) = (a.bpm, b.bpm) {
            assert!((x - y).abs() < 1.5, "{a:?} {b:?}");
        } else {
            assert_eq!(a.bpm, b.bpm);
        }
    }
    // --fps wins over the header.
    let src = source::open(&path, Some(60.0)).unwrap();
    assert_eq!(src.fps(), 60.0);
}

#[test]
fn png_folder_in_numeric_order() {
    let video = Video::new(Script::steady("png", 160.0, 30.0).beats(4).noise(0.0));
    let dir = scratch("png");
    // Unpadded numbers: 10 must come after 9; a stray file is ignored.
    for (i, (_, f)) in video.frames().enumerate() {
        let file = std::fs::File::create(dir.join(format!("frame{}.png", i + 1))).unwrap();
        source::write_png(&f, std::io::BufWriter::new(file)).unwrap();
    }
    std::fs::write(dir.join("notes.txt"), "not a frame").unwrap();
    let mut src = source::open(&dir, Some(30.0)).unwrap();
    let (beats, frames) = run(src.as_mut());
    assert_eq!(frames, video.frame_count());
    let score = synth::score(&video, &beats, frames);
    println!("{}", score.row());
    assert_eq!((score.missed, score.invented), (0, 0), "{score:?}");
    assert!(score.beat_err_ms.0 < 1000.0 / 30.0 + 10.0, "{score:?}");
    // Without --fps: a clear refusal.
    let e = source::open(&dir, None).err().unwrap();
    assert!(
        matches!(&e, SourceError::BadInput(m) if m.contains("--fps")),
        "{e}"
    );
}

#[test]
fn bad_input_is_refused_clearly() {
    let dir = scratch("bad");
    let missing = dir.join("nope.y4m");
    let e = source::open(&missing, None).err().unwrap();
    assert!(
        matches!(&e, SourceError::BadInput(m) if m.contains("no such file")),
        "{e}"
    );

    let junk = dir.join("junk.y4m");
    std::fs::write(&junk, b"this is not a video").unwrap();
    let e = source::open(&junk, None).err().unwrap();
    assert!(matches!(e, SourceError::BadInput(_)), "{e}");

    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let e = source::open(&empty, Some(30.0)).err().unwrap();
    assert!(
        matches!(&e, SourceError::BadInput(m) if m.contains("no .png")),
        "{e}"
    );

    let broken = dir.join("broken");
    std::fs::create_dir_all(&broken).unwrap();
    std::fs::write(broken.join("1.png"), b"not a png").unwrap();
    let mut src = source::open(&broken, Some(30.0)).unwrap();
    let e = src.next_frame(&mut Frame::default()).err().unwrap();
    assert!(
        matches!(&e, SourceError::BadInput(m) if m.contains("PNG")),
        "{e}"
    );

    let e = source::open(&dir, Some(0.0)).err().unwrap();
    assert!(matches!(e, SourceError::BadInput(_)), "{e}");

    // Anything else goes to ffmpeg: whether or not it is installed, a junk file is refused
    // as bad input, and without ffmpeg the message says so.
    let mp4 = dir.join("junk.mp4");
    std::fs::write(&mp4, b"not a video either").unwrap();
    let e = source::open(&mp4, None).err().unwrap();
    let SourceError::BadInput(m) = &e else {
        panic!("{e}")
    };
    let have_ffmpeg = std::process::Command::new("ffmpeg")
        .arg("-version")
        .output()
        .is_ok();
    if !have_ffmpeg {
        assert!(m.contains("ffmpeg") && m.contains("not installed"), "{m}");
    }
}

#[test]
fn any_other_video_through_ffmpeg_when_it_is_installed() {
    let have_ffmpeg = std::process::Command::new("ffmpeg")
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !have_ffmpeg {
        eprintln!("ffmpeg is not installed: the ffmpeg path is not tried here");
        return;
    }
    let video = Video::new(Script::steady("ffmpeg", 160.0, 30.0).beats(4).noise(2.0));
    let dir = scratch("ffmpeg");
    let y4m = dir.join("clip.y4m");
    {
        let file = std::io::BufWriter::new(std::fs::File::create(&y4m).unwrap());
        let mut w = Y4mWriter::new(file, 640, 480, 30.0).unwrap();
        for (_, f) in video.frames() {
            w.write(&f).unwrap();
        }
    }
    // Lossless FFV1 in Matroska: a container only ffmpeg reads here.
    let mkv = dir.join("clip.mkv");
    let status = std::process::Command::new("ffmpeg")
        .args(["-v", "error", "-nostdin", "-y", "-i"])
        .arg(&y4m)
        .args(["-c:v", "ffv1"])
        .arg(&mkv)
        .status()
        .unwrap();
    assert!(status.success());
    let mut src = source::open(&mkv, None).unwrap();
    assert!((src.fps() - 30.0).abs() < 1e-9);
    let (beats, frames) = run(src.as_mut());
    assert_eq!(frames, video.frame_count());
    let score = synth::score(&video, &beats, frames);
    assert_eq!((score.missed, score.invented), (0, 0), "{score:?}");
    assert!(score.beat_err_ms.0 < 1000.0 / 30.0 + 10.0, "{score:?}");
}

#[test]
fn garbage_never_panics() {
    let mut rng = synth::Rng::new(77);
    let (mut opened, mut frames) = (0, 0);
    for case in 0..300 {
        let (w, h) = (1 + rng.next_u64() % 40, 1 + rng.next_u64() % 30);
        let cs = ["C420jpeg", "C444", "C422", "Cmono", "C420p10", "Cfoo"][case % 6];
        let mut bytes = format!("YUV4MPEG2 W{w} H{h} F30:1 {cs}\n").into_bytes();
        for _ in 0..rng.next_u64() % 4 {
            if rng.unit() < 0.8 {
                bytes.extend_from_slice(b"FRAME\n");
            }
            let n = rng.next_u64() % (3 * w * h + 20);
            bytes.extend((0..n).map(|_| rng.next_u64() as u8));
        }
        if case % 5 == 0 {
            // Mangle the header too.
            let i = (rng.next_u64() as usize) % bytes.len();
            bytes[i] = rng.next_u64() as u8;
        }
        let Ok(mut src) = source::Y4mSource::new(&bytes[..], None) else {
            continue;
        };
        opened += 1;
        let mut baton = Baton::default();
        let mut frame = Frame::default();
        while let Ok(Some(t)) = src.next_frame(&mut frame) {
            frames += 1;
            assert_eq!(frame.rgb.len(), 3 * frame.width * frame.height);
            if let Some(b) = baton.push(t, &frame) {
                assert!(b.t_ms.is_finite() && b.x.is_finite() && b.y.is_finite());
            }
        }
        let mut junk: Vec<u8> = b"\x89PNG\r\n\x1a\n".to_vec();
        junk.extend((0..rng.next_u64() % 200).map(|_| rng.next_u64() as u8));
        assert!(source::read_png(&junk[..], &mut Frame::default()).is_err());
    }
    // Both paths were taken: headers refused and accepted, frames read.
    assert!(
        opened > 50 && opened < 300 && frames > 50,
        "{opened} {frames}"
    );
}
