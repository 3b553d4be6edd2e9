//! A live camera through Video4Linux2 (feature `camera`, off by default): [`Camera`] is a
//! [`FrameSource`] reading a capture device such as `/dev/video0`.
//!
//! The device is asked for YUYV (packed 4:2:2, what nearly every webcam gives uncompressed)
//! at 640×480, or Motion JPEG when it does not offer YUYV; whatever it settles on is
//! converted to the tracker's RGB [`Frame`] ([`yuyv_to_frame`], [`mjpeg_to_frame`]). Each
//! frame's time is its capture time from the driver, in ms from the first frame. Buffers are
//! memory-mapped (four in flight).
//!
//! Through the `v4l` crate with its default `v4l2` backend: the kernel's own API, no
//! libv4l; its bindings are generated at build time, which needs libclang (`libclang-dev`).

use std::path::Path;

use v4l::buffer::Type;
use v4l::io::mmap::Stream;
use v4l::io::traits::CaptureStream;
use v4l::video::Capture;
use v4l::{Device, FourCC};

use crate::frame::YCbCr;
use crate::source::{FrameSource, SourceError};
use crate::Frame;

/// The size asked of the camera (it may give another; its own is used).
pub const ASK_SIZE: (u32, u32) = (640, 480);

/// The pixel formats read, in the order asked.
const YUYV: [u8; 4] = *b"YUYV";
const MJPG: [u8; 4] = *b"MJPG";

/// Fills `frame` from one packed YUYV (4:2:2: Y0 Cb Y1 Cr for each pair of pixels, BT.601
/// limited range) image of `width × height` pixels, rows `stride` bytes apart (at least
/// `2 × width`). A buffer too short for the image is refused.
pub fn yuyv_to_frame(
    frame: &mut Frame,
    width: usize,
    height: usize,
    stride: usize,
    data: &[u8],
) -> Result<(), SourceError> {
    let row = 2 * width;
    let stride = stride.max(row);
    let need = if height == 0 {
        0
    } else {
        stride * (height - 1) + row
    };
    if data.len() < need || width % 2 != 0 {
        return Err(SourceError::BadInput(format!(
            "a YUYV frame of {width}×{height} (rows {stride} bytes apart) needs {need} bytes \
             and an even width; the camera gave {} bytes",
            data.len()
        )));
    }
    let cw = width / 2;
    let mut y = Vec::with_capacity(width * height);
    let mut cb = Vec::with_capacity(cw * height);
    let mut cr = Vec::with_capacity(cw * height);
    for r in 0..height {
        for quad in data[r * stride..][..row].chunks_exact(4) {
            y.extend_from_slice(&[quad[0], quad[2]]);
            cb.push(quad[1]);
            cr.push(quad[3]);
        }
    }
    frame.fill_from_ycbcr(
        width,
        height,
        YCbCr {
            y: &y,
            cb: &cb,
            cr: &cr,
            chroma_width: cw,
            chroma_height: height,
        },
    );
    Ok(())
}

/// Whether a JPEG has no Huffman table (DHT segment) before its scan, as Motion JPEG frames
/// from webcams often have none: they use the standard tables (ITU T.81, K.3).
fn lacks_huffman_tables(jpeg: &[u8]) -> bool {
    let mut at = 2;
    while let (Some(&0xFF), Some(&marker), Some(len)) =
        (jpeg.get(at), jpeg.get(at + 1), jpeg.get(at + 2..at + 4))
    {
        match marker {
            0xC4 => return false,
            0xDA => return true,
            _ => at += 2 + usize::from(u16::from_be_bytes([len[0], len[1]])),
        }
    }
    true
}

/// The APP0 segment that marks a JPEG as an AVI1 Motion JPEG frame: the decoder then uses the
/// standard Huffman tables for a frame that has none.
const AVI1: [u8; 9] = [0xFF, 0xE0, 0x00, 0x07, b'A', b'V', b'I', b'1', 0x00];

/// Fills `frame` from one Motion JPEG image (a JPEG; when it carries no Huffman tables, as
/// webcams often send it, the standard ones). Colour and greyscale JPEGs are read; a damaged
/// one is refused.
pub fn mjpeg_to_frame(frame: &mut Frame, data: &[u8]) -> Result<(), SourceError> {
    let marked;
    let data = if data.starts_with(&[0xFF, 0xD8]) && lacks_huffman_tables(data) {
        marked = [&data[..2], &AVI1[..], &data[2..]].concat();
        &marked[..]
    } else {
        data
    };
    let mut decoder = jpeg_decoder::Decoder::new(data);
    let pixels = decoder
        .decode()
        .map_err(|e| SourceError::BadInput(format!("a Motion JPEG frame: {e}")))?;
    let info = decoder
        .info()
        .ok_or_else(|| SourceError::BadInput("a Motion JPEG frame without a header".into()))?;
    let (width, height) = (usize::from(info.width), usize::from(info.height));
    frame.width = width;
    frame.height = height;
    frame.rgb.clear();
    match info.pixel_format {
        jpeg_decoder::PixelFormat::RGB24 => frame.rgb.extend_from_slice(&pixels),
        jpeg_decoder::PixelFormat::L8 => frame.rgb.extend(pixels.iter().flat_map(|&l| [l; 3])),
        other => {
            return Err(SourceError::BadInput(format!(
                "a Motion JPEG frame in {other:?}: only colour and greyscale are read"
            )))
        }
    }
    if frame.rgb.len() != 3 * width * height {
        return Err(SourceError::BadInput(
            "a Motion JPEG frame shorter than its header says".into(),
        ));
    }
    Ok(())
}

/// What the camera sends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pixels {
    Yuyv { stride: usize },
    Mjpeg,
}

/// A V4L2 capture device. See the [module notes](self).
pub struct Camera {
    // The stream borrows nothing of the device but its handle; the device is kept for as
    // long as the stream runs.
    stream: Stream<'static>,
    _device: Device,
    width: usize,
    height: usize,
    pixels: Pixels,
    fps: f64,
    first_us: Option<i64>,
}

impl Camera {
    /// Opens `path` (such as `/dev/video0`) and starts capturing. A missing device, one that
    /// is not a camera, or one that offers neither YUYV nor Motion JPEG is refused with a
    /// message naming it.
    pub fn open(path: &Path) -> Result<Self, SourceError> {
        let name = path.display();
        if !path.exists() {
            return Err(SourceError::BadInput(format!(
                "camera {name}: no such device (is the camera plugged in? `ls /dev/video*` \
                 lists the capture devices)"
            )));
        }
        let device = Device::with_path(path).map_err(|e| {
            SourceError::BadInput(format!(
                "camera {name}: cannot open it as a V4L2 device: {e}"
            ))
        })?;
        let refused = |what: &str, e: std::io::Error| {
            SourceError::BadInput(format!("camera {name}: {what}: {e}"))
        };
        let mut format = device
            .format()
            .map_err(|e| refused("not a video capture device", e))?;
        format.width = ASK_SIZE.0;
        format.height = ASK_SIZE.1;
        let mut got = None;
        for fourcc in [YUYV, MJPG] {
            format.fourcc = FourCC::new(&fourcc);
            let f = device
                .set_format(&format)
                .map_err(|e| refused("setting its format", e))?;
            if f.fourcc.repr == fourcc {
                got = Some(f);
                break;
            }
        }
        let Some(format) = got else {
            return Err(SourceError::BadInput(format!(
                "camera {name}: it offers neither YUYV nor Motion JPEG"
            )));
        };
        let pixels = if format.fourcc.repr == YUYV {
            Pixels::Yuyv {
                stride: format.stride as usize,
            }
        } else {
            Pixels::Mjpeg
        };
        let fps = device
            .params()
            .ok()
            .map(|p| p.interval)
            .filter(|i| i.numerator > 0 && i.denominator > 0)
            .map_or(30.0, |i| f64::from(i.denominator) / f64::from(i.numerator));
        let stream = Stream::with_buffers(&device, Type::VideoCapture, 4)
            .map_err(|e| refused("starting the capture", e))?;
        Ok(Self {
            stream,
            _device: device,
            width: format.width as usize,
            height: format.height as usize,
            pixels,
            fps,
            first_us: None,
        })
    }
}

impl FrameSource for Camera {
    fn fps(&self) -> f64 {
        self.fps
    }

    fn next_frame(&mut self, frame: &mut Frame) -> Result<Option<f64>, SourceError> {
        let (data, meta) = self.stream.next().map_err(SourceError::Io)?;
        let used = (meta.bytesused as usize).min(data.len());
        let data = &data[..used];
        match self.pixels {
            Pixels::Yuyv { stride } => yuyv_to_frame(frame, self.width, self.height, stride, data)?,
            Pixels::Mjpeg => mjpeg_to_frame(frame, data)?,
        }
        let t_us = meta.timestamp.sec * 1_000_000 + meta.timestamp.usec;
        let first = *self.first_us.get_or_insert(t_us);
        Ok(Some((t_us - first) as f64 / 1000.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Y'CbCr (BT.601, limited range) of an RGB colour, rounded.
    fn ycbcr(rgb: [u8; 3]) -> [u8; 3] {
        let [r, g, b] = rgb.map(f64::from);
        let y = 16.0 + (65.481 * r + 128.553 * g + 24.966 * b) / 255.0;
        let cb = 128.0 + (-37.797 * r - 74.203 * g + 112.0 * b) / 255.0;
        let cr = 128.0 + (112.0 * r - 93.786 * g - 18.214 * b) / 255.0;
        [y, cb, cr].map(|v| v.round() as u8)
    }

    fn close(a: [u8; 3], b: [u8; 3]) -> bool {
        a.iter().zip(b).all(|(&x, y)| x.abs_diff(y) <= 3)
    }

    #[test]
    fn yuyv_converts_to_the_trackers_rgb_frame() {
        // 4×2 pixels: a red pair, a white pair; a black pair, a green pair; rows padded to 12
        // bytes, as drivers may.
        let colours = [[230, 20, 20], [255, 255, 255], [0, 0, 0], [20, 200, 20]];
        let mut data = Vec::new();
        for row in colours.chunks(2) {
            for &c in row {
                let [y, cb, cr] = ycbcr(c);
                data.extend_from_slice(&[y, cb, y, cr]);
            }
            data.extend_from_slice(&[0, 0, 0, 0]);
        }
        let mut frame = Frame::default();
        yuyv_to_frame(&mut frame, 4, 2, 12, &data).unwrap();
        assert_eq!((frame.width, frame.height), (4, 2));
        for (i, &c) in colours.iter().enumerate() {
            let (x, y) = (2 * (i % 2), i / 2);
            for dx in 0..2 {
                let got = frame.pixel(x + dx, y);
                assert!(close(got, c), "pixel ({}, {y}): {got:?} for {c:?}", x + dx);
            }
        }
        // A buffer cut short is refused, saying so.
        let e = yuyv_to_frame(&mut frame, 4, 2, 12, &data[..15]).unwrap_err();
        assert!(e.to_string().contains("needs 20 bytes"), "{e}");
    }

    /// A 16×8 JPEG (4:2:0, standard Huffman tables), left half red, right half blue, made by
    /// a reference encoder.
    fn red_blue_jpeg() -> Vec<u8> {
        let mut rgb = Vec::new();
        for _ in 0..8 {
            for x in 0..16 {
                rgb.extend_from_slice(if x < 8 { &[255, 0, 0] } else { &[0, 0, 255] });
            }
        }
        let mut jpeg = Vec::new();
        jpeg_encoder::Encoder::new(&mut jpeg, 90)
            .encode(&rgb, 16, 8, jpeg_encoder::ColorType::Rgb)
            .unwrap();
        jpeg
    }

    /// The JPEG without its Huffman tables (DHT segments), as webcams send Motion JPEG.
    fn without_huffman_tables(jpeg: &[u8]) -> Vec<u8> {
        let mut out = jpeg[..2].to_vec();
        let mut at = 2;
        while at + 4 <= jpeg.len() && jpeg[at] == 0xFF {
            let marker = jpeg[at + 1];
            if marker == 0xDA {
                break; // the scan: the rest is entropy-coded data
            }
            let len = usize::from(u16::from_be_bytes([jpeg[at + 2], jpeg[at + 3]]));
            if marker != 0xC4 {
                out.extend_from_slice(&jpeg[at..at + 2 + len]);
            }
            at += 2 + len;
        }
        out.extend_from_slice(&jpeg[at..]);
        out
    }

    #[test]
    fn mjpeg_converts_to_the_trackers_rgb_frame() {
        let jpeg = red_blue_jpeg();
        let bare = without_huffman_tables(&jpeg);
        assert!(bare.len() < jpeg.len(), "the tables were taken out");
        let near = |a: [u8; 3], b: [u8; 3]| a.iter().zip(b).all(|(&x, y)| x.abs_diff(y) <= 24);
        for data in [&jpeg, &bare] {
            let mut frame = Frame::default();
            mjpeg_to_frame(&mut frame, data).unwrap();
            assert_eq!((frame.width, frame.height), (16, 8));
            assert!(
                near(frame.pixel(2, 4), [255, 0, 0]),
                "{:?}",
                frame.pixel(2, 4)
            );
            assert!(
                near(frame.pixel(13, 4), [0, 0, 255]),
                "{:?}",
                frame.pixel(13, 4)
            );
        }
        let mut frame = Frame::default();
        assert!(mjpeg_to_frame(&mut frame, &jpeg[..jpeg.len() / 2]).is_err());
        assert!(mjpeg_to_frame(&mut frame, b"not a jpeg").is_err());
    }

    #[test]
    fn a_missing_camera_is_refused_naming_its_device() {
        let Err(e) = Camera::open(Path::new("/dev/video-orch-none")) else {
            panic!("a camera that is not there opened");
        };
        let m = e.to_string();
        assert!(matches!(e, SourceError::BadInput(_)));
        assert!(
            m.contains("/dev/video-orch-none") && m.contains("no such device"),
            "{m}"
        );
    }
}
