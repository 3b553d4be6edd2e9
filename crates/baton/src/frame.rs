//! A video frame: 8-bit RGB, row by row, and the colour conversions the readers need.

/// Planar Y'CbCr samples of one picture.
#[derive(Clone, Copy, Debug)]
pub struct YCbCr<'a> {
    /// Luma, one sample a pixel, rows top to bottom.
    pub y: &'a [u8],
    /// Blue-difference chroma, `chroma_width × chroma_height`; empty for mono (grey).
    pub cb: &'a [u8],
    /// Red-difference chroma, like `cb`.
    pub cr: &'a [u8],
    /// Chroma samples across: `width`/2 rounded up for 4:2:0 and 4:2:2, `width` for 4:4:4.
    /// Each covers `width / chroma_width` pixels.
    pub chroma_width: usize,
    /// Chroma rows: `height`/2 rounded up for 4:2:0, `height` for 4:2:2 and 4:4:4.
    pub chroma_height: usize,
}

/// One frame: `width × height` pixels, 8-bit RGB interleaved, rows top to bottom.
///
/// Pixel (x, y) starts at byte `3 * (y * width + x)`; y grows downwards, as in every image
/// format, so a baton's downstroke is a growing y.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Frame {
    /// Pixels across.
    pub width: usize,
    /// Pixels down.
    pub height: usize,
    /// `3 * width * height` bytes: R, G, B.
    pub rgb: Vec<u8>,
}

impl Frame {
    /// A black frame.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            rgb: vec![0; 3 * width * height],
        }
    }

    /// The pixel at (x, y).
    pub fn pixel(&self, x: usize, y: usize) -> [u8; 3] {
        let i = 3 * (y * self.width + x);
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }

    /// Fills the frame from planar Y'CbCr (BT.601, limited range, as ffmpeg's `yuv420p` and
    /// most `.y4m` files carry it), `width × height` pixels.
    pub fn fill_from_ycbcr(&mut self, width: usize, height: usize, planes: YCbCr<'_>) {
        let YCbCr {
            y: y_plane,
            cb,
            cr,
            chroma_width: cw,
            chroma_height: ch,
        } = planes;
        self.width = width;
        self.height = height;
        self.rgb.resize(3 * width * height, 0);
        let mono = cb.is_empty() || cr.is_empty() || cw == 0 || ch == 0;
        for row in 0..height {
            let crow = if mono {
                0
            } else {
                (row * ch / height).min(ch - 1)
            };
            for col in 0..width {
                let luma = y_plane[row * width + col] as i32;
                let (u, v) = if mono {
                    (128, 128)
                } else {
                    let ccol = (col * cw / width).min(cw - 1);
                    (cb[crow * cw + ccol] as i32, cr[crow * cw + ccol] as i32)
                };
                let c = 298 * (luma - 16);
                let d = u - 128;
                let e = v - 128;
                let r = (c + 409 * e + 128) >> 8;
                let g = (c - 100 * d - 208 * e + 128) >> 8;
                let b = (c + 516 * d + 128) >> 8;
                let i = 3 * (row * width + col);
                self.rgb[i] = r.clamp(0, 255) as u8;
                self.rgb[i + 1] = g.clamp(0, 255) as u8;
                self.rgb[i + 2] = b.clamp(0, 255) as u8;
            }
        }
    }

    /// The frame as planar Y'CbCr 4:2:0 (BT.601, limited range; each chroma sample the mean
    /// of its 2×2 pixels): (Y, Cb, Cr), chroma planes `ceil(width/2) × ceil(height/2)`.
    pub fn to_ycbcr420(&self) -> (Vec<u8>, Vec<u8>, Vec<u8>) {
        let (w, h) = (self.width, self.height);
        let (cw, ch) = (w.div_ceil(2), h.div_ceil(2));
        let mut yp = vec![0u8; w * h];
        let mut sums = vec![[0i32; 3]; cw * ch];
        let mut counts = vec![0i32; cw * ch];
        for row in 0..h {
            for col in 0..w {
                let [r, g, b] = self.pixel(col, row).map(i32::from);
                yp[row * w + col] = (((66 * r + 129 * g + 25 * b + 128) >> 8) + 16) as u8;
                let c = (row / 2) * cw + col / 2;
                sums[c][0] += r;
                sums[c][1] += g;
                sums[c][2] += b;
                counts[c] += 1;
            }
        }
        let mut cb = vec![0u8; cw * ch];
        let mut cr = vec![0u8; cw * ch];
        for c in 0..cw * ch {
            let n = counts[c].max(1);
            let [r, g, b] = sums[c].map(|s| (s + n / 2) / n);
            cb[c] = (((-38 * r - 74 * g + 112 * b + 128) >> 8) + 128).clamp(0, 255) as u8;
            cr[c] = (((112 * r - 94 * g - 18 * b + 128) >> 8) + 128).clamp(0, 255) as u8;
        }
        (yp, cb, cr)
    }
}
