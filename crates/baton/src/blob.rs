//! Finding red blobs in a frame: the LED candidates.
//!
//! A pixel is *red* when its red channel is at least [`DetectParams::min_red`] and exceeds
//! both green and blue by at least [`DetectParams::min_excess`]. Red pixels that touch (8
//! neighbours) form a blob. A blob's centroid is weighted by redness (`r - max(g, b)`, less
//! the threshold, plus one), so a saturated core or a smeared streak gives a sub-pixel
//! position at its centre of light.

use crate::Frame;

/// The red-pixel test. Defaults suit a red LED filmed at normal exposure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DetectParams {
    /// Least red channel value (0..=255). Default 120.
    pub min_red: u8,
    /// Least `r - max(g, b)`. Default 60: skin, wood and a brown music stand stay out, a red
    /// LED (even over a white shirt, where its light mixes with the shirt's) stays in.
    pub min_excess: u8,
    /// At most this many blobs are kept per frame, the heaviest first. Default 64.
    pub max_blobs: usize,
}

impl Default for DetectParams {
    fn default() -> Self {
        Self {
            min_red: 120,
            min_excess: 60,
            max_blobs: 64,
        }
    }
}

/// One connected set of red pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blob {
    /// Centroid, weighted by redness, in pixels (pixel centres at integer + 0.5 are not used:
    /// pixel (3, 4) is at x = 3.0, y = 4.0).
    pub x: f64,
    /// See `x`.
    pub y: f64,
    /// Pixels in the blob.
    pub area: u32,
    /// Sum of the weights.
    pub weight: f64,
    /// Highest `r - max(g, b)` in the blob.
    pub peak: u8,
    /// Bounding box, inclusive: x0, y0, x1, y1.
    pub bbox: [u32; 4],
}

impl Blob {
    /// Area over the bounding box's diagonal: about the width of a streak, about 1.1 × the
    /// radius of a round blob. An LED, even smeared by motion, is thin; a sleeve or a sign is
    /// not.
    pub fn thickness(&self) -> f64 {
        let w = f64::from(self.bbox[2].saturating_sub(self.bbox[0])) + 1.0;
        let h = f64::from(self.bbox[3].saturating_sub(self.bbox[1])) + 1.0;
        f64::from(self.area) / (w * w + h * h).sqrt()
    }
}

/// Finds the red blobs of a frame; keeps its buffers between frames.
#[derive(Clone, Debug, Default)]
pub struct Detector {
    params: DetectParams,
    mask: Vec<u8>,
    seeds: Vec<u32>,
    stack: Vec<u32>,
}

impl Detector {
    /// A detector with these thresholds.
    pub fn new(params: DetectParams) -> Self {
        Self {
            params,
            ..Self::default()
        }
    }

    /// The thresholds.
    pub fn params(&self) -> &DetectParams {
        &self.params
    }

    /// The blobs of `frame`, heaviest first, into `out` (cleared first).
    pub fn detect(&mut self, frame: &Frame, out: &mut Vec<Blob>) {
        out.clear();
        let (w, h) = (frame.width, frame.height);
        let n = w * h;
        if n == 0 || frame.rgb.len() < 3 * n {
            return;
        }
        self.mask.clear();
        self.mask.resize(n, 0);
        self.seeds.clear();
        let min_red = self.params.min_red;
        let min_excess = i16::from(self.params.min_excess);
        for (i, px) in frame.rgb[..3 * n].chunks_exact(3).enumerate() {
            let r = px[0];
            if r < min_red {
                continue;
            }
            let e = i16::from(r) - i16::from(px[1].max(px[2]));
            if e >= min_excess {
                // 0 = not red, 1 = red, 2 = red and taken into a blob.
                self.mask[i] = 1;
                self.seeds.push(i as u32);
            }
        }
        for s in 0..self.seeds.len() {
            let seed = self.seeds[s] as usize;
            if self.mask[seed] != 1 {
                continue;
            }
            let mut area = 0u32;
            let (mut sw, mut sx, mut sy) = (0f64, 0f64, 0f64);
            let mut peak = 0u8;
            let mut bbox = [u32::MAX, u32::MAX, 0, 0];
            self.stack.clear();
            self.stack.push(seed as u32);
            self.mask[seed] = 2;
            while let Some(i) = self.stack.pop() {
                let i = i as usize;
                let (x, y) = (i % w, i / w);
                let e =
                    frame.rgb[3 * i] as i16 - frame.rgb[3 * i + 1].max(frame.rgb[3 * i + 2]) as i16;
                let weight = f64::from(e - min_excess + 1);
                area += 1;
                sw += weight;
                sx += weight * x as f64;
                sy += weight * y as f64;
                peak = peak.max(e.clamp(0, 255) as u8);
                bbox[0] = bbox[0].min(x as u32);
                bbox[1] = bbox[1].min(y as u32);
                bbox[2] = bbox[2].max(x as u32);
                bbox[3] = bbox[3].max(y as u32);
                let x0 = x.saturating_sub(1);
                let x1 = (x + 1).min(w - 1);
                let y0 = y.saturating_sub(1);
                let y1 = (y + 1).min(h - 1);
                for ny in y0..=y1 {
                    for nx in x0..=x1 {
                        let j = ny * w + nx;
                        if self.mask[j] == 1 {
                            self.mask[j] = 2;
                            self.stack.push(j as u32);
                        }
                    }
                }
            }
            out.push(Blob {
                x: sx / sw,
                y: sy / sw,
                area,
                weight: sw,
                peak,
                bbox,
            });
        }
        out.sort_by(|a, b| b.weight.total_cmp(&a.weight));
        out.truncate(self.params.max_blobs);
    }
}
