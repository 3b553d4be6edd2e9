//! Where frames come from: a `.y4m` file, a folder of numbered PNGs, or any video through an
//! `ffmpeg` subprocess. Each frame comes with its time: frame *i* is at *i* × 1000 / fps ms.
//!
//! A live camera (V4L2) is one more [`FrameSource`]: `camera::Camera`, behind the `camera`
//! feature.

use std::fmt;
use std::io::{self, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdout, Command, Stdio};

use crate::frame::YCbCr;
use crate::Frame;

/// Why frames could not be read.
#[derive(Debug)]
pub enum SourceError {
    /// The input cannot be used (a missing file, a bad header, no frames, no fps): the
    /// user's input. The text says what and why.
    BadInput(String),
    /// Reading failed on the way.
    Io(io::Error),
}

impl fmt::Display for SourceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SourceError::BadInput(m) => f.write_str(m),
            SourceError::Io(e) => write!(f, "reading frames: {e}"),
        }
    }
}

impl std::error::Error for SourceError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            SourceError::Io(e) => Some(e),
            SourceError::BadInput(_) => None,
        }
    }
}

fn bad(m: impl Into<String>) -> SourceError {
    SourceError::BadInput(m.into())
}

/// A stream of timed frames.
pub trait FrameSource {
    /// Frames per second (what frame times are computed from).
    fn fps(&self) -> f64;
    /// Reads the next frame into `frame`; its time in ms, or `None` at the end.
    fn next_frame(&mut self, frame: &mut Frame) -> Result<Option<f64>, SourceError>;
}

/// Frames from a YUV4MPEG2 (`.y4m`) stream: 8-bit 4:2:0, 4:2:2, 4:4:4 or mono.
pub struct Y4mSource<R: Read> {
    decoder: y4m::Decoder<R>,
    fps: f64,
    index: u64,
}

impl<R: Read> Y4mSource<R> {
    /// Reads the header; `fps` overrides the header's frame rate.
    pub fn new(reader: R, fps: Option<f64>) -> Result<Self, SourceError> {
        let decoder = y4m::Decoder::new(reader)
            .map_err(|e| bad(format!("not a readable YUV4MPEG2 stream: {e}")))?;
        if decoder.get_bit_depth() != 8 {
            return Err(bad(format!(
                "{}-bit YUV4MPEG2 is not supported (8-bit only)",
                decoder.get_bit_depth()
            )));
        }
        let r = decoder.get_framerate();
        let fps = match fps {
            Some(f) => f,
            None if r.num > 0 && r.den > 0 => r.num as f64 / r.den as f64,
            None => return Err(bad("the YUV4MPEG2 header has no frame rate: give --fps")),
        };
        check_fps(fps)?;
        Ok(Self {
            decoder,
            fps,
            index: 0,
        })
    }
}

fn check_fps(fps: f64) -> Result<(), SourceError> {
    if fps.is_finite() && fps > 0.0 && fps <= 10_000.0 {
        Ok(())
    } else {
        Err(bad(format!(
            "frame rate {fps} is not a number of frames per second above 0"
        )))
    }
}

impl<R: Read> FrameSource for Y4mSource<R> {
    fn fps(&self) -> f64 {
        self.fps
    }

    fn next_frame(&mut self, frame: &mut Frame) -> Result<Option<f64>, SourceError> {
        let (w, h) = (self.decoder.get_width(), self.decoder.get_height());
        let cs = self.decoder.get_colorspace();
        let (cw, ch) = match cs {
            y4m::Colorspace::Cmono => (0, 0),
            y4m::Colorspace::C422 => (w.div_ceil(2), h),
            y4m::Colorspace::C444 => (w, h),
            _ => (w.div_ceil(2), h.div_ceil(2)),
        };
        match self.decoder.read_frame() {
            Ok(f) => {
                frame.fill_from_ycbcr(
                    w,
                    h,
                    YCbCr {
                        y: f.get_y_plane(),
                        cb: f.get_u_plane(),
                        cr: f.get_v_plane(),
                        chroma_width: cw,
                        chroma_height: ch,
                    },
                );
                let t = self.index as f64 * 1000.0 / self.fps;
                self.index += 1;
                Ok(Some(t))
            }
            Err(y4m::Error::EOF) => Ok(None),
            Err(y4m::Error::IoError(e)) if e.kind() == io::ErrorKind::UnexpectedEof => Ok(None),
            Err(y4m::Error::IoError(e)) => Err(SourceError::Io(e)),
            Err(e) => Err(bad(format!("bad YUV4MPEG2 frame {}: {e}", self.index))),
        }
    }
}

/// Frames from a folder of PNG files, in the order of the number in their names
/// (`frame_0001.png`, `2.png`, …; names without a number sort after, by name).
pub struct PngFolder {
    files: Vec<PathBuf>,
    fps: f64,
    index: usize,
}

impl PngFolder {
    /// Lists the folder's `.png` files.
    pub fn new(dir: &Path, fps: f64) -> Result<Self, SourceError> {
        check_fps(fps)?;
        let entries = std::fs::read_dir(dir)
            .map_err(|e| bad(format!("cannot read the folder {}: {e}", dir.display())))?;
        let mut files: Vec<(Option<u64>, String, PathBuf)> = Vec::new();
        for entry in entries {
            let path = entry.map_err(SourceError::Io)?.path();
            let is_png = path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("png"));
            if !is_png {
                continue;
            }
            let name = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            let digits: String = name
                .chars()
                .rev()
                .skip_while(|c| !c.is_ascii_digit())
                .take_while(|c| c.is_ascii_digit())
                .collect::<Vec<_>>()
                .into_iter()
                .rev()
                .collect();
            files.push((digits.parse().ok(), name, path));
        }
        if files.is_empty() {
            return Err(bad(format!("no .png files in {}", dir.display())));
        }
        files.sort_by(|a, b| match (a.0, b.0) {
            (Some(x), Some(y)) => x.cmp(&y).then_with(|| a.1.cmp(&b.1)),
            (Some(_), None) => std::cmp::Ordering::Less,
            (None, Some(_)) => std::cmp::Ordering::Greater,
            (None, None) => a.1.cmp(&b.1),
        });
        Ok(Self {
            files: files.into_iter().map(|f| f.2).collect(),
            fps,
            index: 0,
        })
    }

    /// How many frames.
    pub fn len(&self) -> usize {
        self.files.len()
    }

    /// Whether there are none (never, once made).
    pub fn is_empty(&self) -> bool {
        self.files.is_empty()
    }
}

/// Decodes one PNG (any colour type and depth) into `frame` as 8-bit RGB.
pub fn read_png(reader: impl Read, frame: &mut Frame) -> Result<(), String> {
    let mut decoder = png::Decoder::new(reader);
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = decoder.read_info().map_err(|e| e.to_string())?;
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).map_err(|e| e.to_string())?;
    let (w, h) = (info.width as usize, info.height as usize);
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => return Err("indexed colour was not expanded".into()),
    };
    frame.width = w;
    frame.height = h;
    frame.rgb.resize(3 * w * h, 0);
    let row_bytes = info.line_size;
    for y in 0..h {
        let row = &buf[y * row_bytes..];
        for x in 0..w {
            let p = &row[x * channels..];
            let rgb = if channels < 3 {
                [p[0]; 3]
            } else {
                [p[0], p[1], p[2]]
            };
            frame.rgb[3 * (y * w + x)..3 * (y * w + x) + 3].copy_from_slice(&rgb);
        }
    }
    Ok(())
}

/// Encodes `frame` as an 8-bit RGB PNG.
pub fn write_png(frame: &Frame, writer: impl io::Write) -> Result<(), String> {
    let mut encoder = png::Encoder::new(writer, frame.width as u32, frame.height as u32);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::Fast);
    let mut w = encoder.write_header().map_err(|e| e.to_string())?;
    w.write_image_data(&frame.rgb).map_err(|e| e.to_string())
}

impl FrameSource for PngFolder {
    fn fps(&self) -> f64 {
        self.fps
    }

    fn next_frame(&mut self, frame: &mut Frame) -> Result<Option<f64>, SourceError> {
        let Some(path) = self.files.get(self.index) else {
            return Ok(None);
        };
        let file = std::fs::File::open(path)
            .map_err(|e| bad(format!("cannot open {}: {e}", path.display())))?;
        read_png(BufReader::new(file), frame)
            .map_err(|e| bad(format!("{} is not a readable PNG: {e}", path.display())))?;
        let t = self.index as f64 * 1000.0 / self.fps;
        self.index += 1;
        Ok(Some(t))
    }
}

/// Any video ffmpeg can read, decoded by an `ffmpeg` subprocess to YUV4MPEG2 on a pipe.
pub struct FfmpegSource {
    child: Child,
    inner: Y4mSource<BufReader<ChildStdout>>,
    stderr: Option<std::thread::JoinHandle<String>>,
    path: PathBuf,
}

/// Reads a child's stderr on a thread (so a chatty ffmpeg never blocks on a full pipe),
/// keeping its last 4 KB.
fn drain(mut err: std::process::ChildStderr) -> std::thread::JoinHandle<String> {
    std::thread::spawn(move || {
        let mut kept: Vec<u8> = Vec::new();
        let mut buf = [0u8; 4096];
        while let Ok(n) = err.read(&mut buf) {
            if n == 0 {
                break;
            }
            kept.extend_from_slice(&buf[..n]);
            if kept.len() > 4096 {
                kept.drain(..kept.len() - 4096);
            }
        }
        String::from_utf8_lossy(&kept).trim().to_string()
    })
}

impl FfmpegSource {
    /// Starts `ffmpeg -v error -i PATH -f yuv4mpegpipe -pix_fmt yuv420p -`. A clear error
    /// when ffmpeg is not installed.
    pub fn new(path: &Path, fps: Option<f64>) -> Result<Self, SourceError> {
        let mut child = Command::new("ffmpeg")
            .arg("-nostdin")
            .args(["-v", "error", "-i"])
            .arg(path)
            .args(["-f", "yuv4mpegpipe", "-pix_fmt", "yuv420p", "-"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| {
                if e.kind() == io::ErrorKind::NotFound {
                    bad(format!(
                        "{} is not a .y4m file or a folder of PNG frames, and ffmpeg (needed for \
                         other videos) is not installed: install ffmpeg, or convert it with \
                         `ffmpeg -i VIDEO -pix_fmt yuv420p out.y4m` elsewhere",
                        path.display()
                    ))
                } else {
                    SourceError::Io(e)
                }
            })?;
        let stdout = child
            .stdout
            .take()
            .ok_or_else(|| bad("ffmpeg gave no output"))?;
        let stderr = child.stderr.take().map(drain);
        match Y4mSource::new(BufReader::new(stdout), fps) {
            Ok(inner) => Ok(Self {
                child,
                inner,
                stderr,
                path: path.to_path_buf(),
            }),
            Err(e) => {
                let _ = child.wait();
                let msg = stderr.and_then(|h| h.join().ok()).unwrap_or_default();
                Err(bad(format!(
                    "ffmpeg cannot read {}: {}",
                    path.display(),
                    if msg.is_empty() { e.to_string() } else { msg }
                )))
            }
        }
    }
}

impl FrameSource for FfmpegSource {
    fn fps(&self) -> f64 {
        self.inner.fps()
    }

    fn next_frame(&mut self, frame: &mut Frame) -> Result<Option<f64>, SourceError> {
        let got = self.inner.next_frame(frame)?;
        if got.is_none() {
            // The end of the stream: ffmpeg says whether it was the end of the video.
            let status = self.child.wait().map_err(SourceError::Io)?;
            if !status.success() {
                let msg = self
                    .stderr
                    .take()
                    .and_then(|h| h.join().ok())
                    .unwrap_or_default();
                return Err(bad(format!(
                    "ffmpeg failed on {} ({status}): {msg}",
                    self.path.display()
                )));
            }
        }
        Ok(got)
    }
}

impl Drop for FfmpegSource {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Opens a video the way `orch baton` does: a folder is PNG frames (needs `fps`), a `.y4m`
/// file is read directly, anything else goes through ffmpeg.
pub fn open(path: &Path, fps: Option<f64>) -> Result<Box<dyn FrameSource>, SourceError> {
    if path.is_dir() {
        let fps = fps.ok_or_else(|| {
            bad(format!(
                "{} is a folder of PNG frames: give their rate with --fps",
                path.display()
            ))
        })?;
        return Ok(Box::new(PngFolder::new(path, fps)?));
    }
    if !path.exists() {
        return Err(bad(format!("{}: no such file or folder", path.display())));
    }
    let is_y4m = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("y4m"));
    if is_y4m {
        let file = std::fs::File::open(path)
            .map_err(|e| bad(format!("cannot open {}: {e}", path.display())))?;
        return Ok(Box::new(Y4mSource::new(BufReader::new(file), fps)?));
    }
    Ok(Box::new(FfmpegSource::new(path, fps)?))
}

/// Writes frames as a YUV4MPEG2 (4:2:0) stream: for tests and for handing generated videos
/// to other tools.
pub struct Y4mWriter<W: io::Write> {
    encoder: y4m::Encoder<W>,
}

impl<W: io::Write> Y4mWriter<W> {
    /// Writes the header: `width × height` at `fps` (kept as a ratio over 1000).
    pub fn new(writer: W, width: usize, height: usize, fps: f64) -> Result<Self, String> {
        let ratio = y4m::Ratio::new((fps * 1000.0).round() as usize, 1000);
        let encoder = y4m::encode(width, height, ratio)
            .with_colorspace(y4m::Colorspace::C420jpeg)
            .write_header(writer)
            .map_err(|e| e.to_string())?;
        Ok(Self { encoder })
    }

    /// Writes one frame.
    pub fn write(&mut self, frame: &Frame) -> Result<(), String> {
        let (y, u, v) = frame.to_ycbcr420();
        let f = y4m::Frame::new([&y, &u, &v], None);
        self.encoder.write_frame(&f).map_err(|e| e.to_string())
    }
}
