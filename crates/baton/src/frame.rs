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
        if width == 0 || height == 0 {
            return;
        }
        let mono = cb.is_empty() || cr.is_empty() || cw == 0 || ch == 0;
        // Which chroma column each pixel column reads.
        let ccol: Vec<usize> = (0..width)
            .map(|col| {
                if mono {
                    0
                } else {
                    (col * cw / width).min(cw - 1)
                }
            })
            .collect();
        for (row, (out, luma)) in self
            .rgb
            .chunks_exact_mut(3 * width)
            .zip(y_plane.chunks_exact(width))
            .enumerate()
        {
            let (cb_row, cr_row): (&[u8], &[u8]) = if mono {
                (&[128], &[128])
            } else {
                let crow = (row * ch / height).min(ch - 1);
                (&cb[crow * cw..][..cw], &cr[crow * cw..][..cw])
            };
            if !mono && cw == width.div_ceil(2) {
                // Each chroma sample serves two pixels: its terms once for both.
                for ((pair, lumas), (&u, &v)) in out
                    .chunks_mut(6)
                    .zip(luma.chunks(2))
                    .zip(cb_row.iter().zip(cr_row))
                {
                    let (d, e) = (i32::from(u) - 128, i32::from(v) - 128);
                    let (rc, gc, bc) = (409 * e + 128, -100 * d - 208 * e + 128, 516 * d + 128);
                    for (px, &l) in pair.chunks_exact_mut(3).zip(lumas) {
                        let c298 = 298 * (i32::from(l) - 16);
                        px[0] = ((c298 + rc) >> 8).clamp(0, 255) as u8;
                        px[1] = ((c298 + gc) >> 8).clamp(0, 255) as u8;
                        px[2] = ((c298 + bc) >> 8).clamp(0, 255) as u8;
                    }
                }
                continue;
            }
            for ((px, &l), &c) in out.chunks_exact_mut(3).zip(luma).zip(&ccol) {
                let c298 = 298 * (i32::from(l) - 16);
                let d = i32::from(cb_row[c]) - 128;
                let e = i32::from(cr_row[c]) - 128;
                px[0] = ((c298 + 409 * e + 128) >> 8).clamp(0, 255) as u8;
                px[1] = ((c298 - 100 * d - 208 * e + 128) >> 8).clamp(0, 255) as u8;
                px[2] = ((c298 + 516 * d + 128) >> 8).clamp(0, 255) as u8;
            }
        }
    }

    /// The frame as planar Y'CbCr 4:2:0 (BT.601, limited range; each chroma sample the mean
    /// of its 2×2 pixels): (Y, Cb, Cr), chroma planes `ceil(width/2) × ceil(height/2)`.
    pub fn to_ycbcr420(&self) -> (Vec<u8>, Vec<u8>, Vec<u8>) {
        let (w, h) = (self.width, self.height);
        let (cw, ch) = (w.div_ceil(2), h.div_ceil(2));
        let mut yp = vec![0u8; w * h];
        let mut sums = vec![[0i32; 4]; cw * ch];
        for (row, (pixels, luma)) in self
            .rgb
            .chunks_exact(3 * w)
            .zip(yp.chunks_exact_mut(w))
            .enumerate()
        {
            let crow = &mut sums[(row / 2) * cw..][..cw];
            for (col, (px, l)) in pixels.chunks_exact(3).zip(luma).enumerate() {
                let (r, g, b) = (i32::from(px[0]), i32::from(px[1]), i32::from(px[2]));
                *l = (((66 * r + 129 * g + 25 * b + 128) >> 8) + 16) as u8;
                let s = &mut crow[col / 2];
                s[0] += r;
                s[1] += g;
                s[2] += b;
                s[3] += 1;
            }
        }
        let mut cb = vec![0u8; cw * ch];
        let mut cr = vec![0u8; cw * ch];
        for ((s, b), r) in sums.iter().zip(&mut cb).zip(&mut cr) {
            let n = s[3].max(1);
            let [rr, gg, bb] = [s[0], s[1], s[2]].map(|v| (v + n / 2) / n);
            *b = (((-38 * rr - 74 * gg + 112 * bb + 128) >> 8) + 128).clamp(0, 255) as u8;
            *r = (((112 * rr - 94 * gg - 18 * bb + 128) >> 8) + 128).clamp(0, 255) as u8;
        }
        (yp, cb, cr)
    }
}
