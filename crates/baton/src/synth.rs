//! The evaluation harness: conductor videos drawn with known beats, and the tracker's score
//! on them.
//!
//! A [`Script`] says what to film: the tempo (steady, or a linear change per beat from one
//! BPM to another: an accelerando or a ritardando), how many beats, a fermata, and what makes
//! it hard (clutter, a second red object, motion blur, sensor noise, dropped frames, the LED
//! leaving the picture). A [`Video`] draws it at 640×480: the LED conducts a 4/4 pattern
//! (down, left, right, up; a bigger rebound before each downbeat), each beat a stroke that
//! falls faster and faster into the ictus (as under gravity) and rebounds, slowing, to the
//! next height: y(t) is a sharp V at the ictus, not a sine. Its `truth` is every ictus's time,
//! the tempo there and the LED's position. [`evaluate`] runs a [`Baton`] over the frames and
//! matches the beats it finds to the truth: tempo error (BPM; median and 95th percentile,
//! from the third beat on), beat time error (ms from the true ictus), beats missed and
//! invented. [`suite`] is the standard set, at any frame rate.
//!
//! How a frame is drawn: a dim background (a gradient; with clutter, muted rectangles, a
//! white shirt the baton passes over, a bright lamp, a brown music stand); the LED a
//! Gaussian spot (σ 2 px) three times brighter than the sensor's white, so its core
//! saturates as a real LED's does (overexposed, its core burns out to white and only the halo
//! stays red); with motion blur, the average of nine positions over 90 %
//! of the frame time (the frame's time is the middle of its exposure); noise added to every
//! channel of every pixel (Gaussian, σ in 8-bit steps). A dropped frame is not delivered at
//! all (the next frame keeps its own time); an occluded one is delivered without the LED.

use crate::{Baton, Frame, Params};

/// What to film. Build one with [`Script::steady`] or [`Script::ramp`] and the methods.
#[derive(Clone, Debug, PartialEq)]
pub struct Script {
    /// Its name in the tables.
    pub name: String,
    /// Frames per second.
    pub fps: f64,
    /// Pixels across (640).
    pub width: usize,
    /// Pixels down (480).
    pub height: usize,
    /// Tempo at the first beat, BPM.
    pub from_bpm: f64,
    /// Tempo at the last beat, BPM (the tempo changes linearly per beat in between).
    pub to_bpm: f64,
    /// Beats conducted (default 24).
    pub beats: usize,
    /// A fermata: after this beat the baton rebounds and holds still this many ms longer,
    /// then prepares and goes on at the tempo.
    pub fermata: Option<(usize, f64)>,
    /// Clutter in the background.
    pub clutter: bool,
    /// Red things that are not the LED: the conductor's red sleeve (moving with the hand),
    /// an exit sign, a small red standby light.
    pub second_red: bool,
    /// Motion blur (exposure of 90 % of the frame time).
    pub blur: bool,
    /// Sensor noise, σ in 8-bit steps (0 for none).
    pub noise: f64,
    /// Fraction of frames dropped (not delivered).
    pub drop: f64,
    /// Fraction of frames with the LED hidden.
    pub occlude: f64,
    /// The pattern is drawn higher, so its big rebounds leave the picture at the top.
    pub leave_frame: bool,
    /// The LED overexposed: its core burns out to white, only its halo is red.
    pub bloom: bool,
    /// Seed of everything random.
    pub seed: u64,
}

impl Script {
    /// A steady tempo, nothing hard, 24 beats, 640×480, a little noise (σ 2).
    pub fn steady(name: &str, bpm: f64, fps: f64) -> Self {
        Self::ramp(name, bpm, bpm, fps)
    }

    /// A tempo going from `from` to `to` BPM over the beats.
    pub fn ramp(name: &str, from: f64, to: f64, fps: f64) -> Self {
        Self {
            name: name.to_string(),
            fps,
            width: 640,
            height: 480,
            from_bpm: from,
            to_bpm: to,
            beats: 24,
            fermata: None,
            clutter: false,
            second_red: false,
            blur: false,
            noise: 2.0,
            drop: 0.0,
            occlude: 0.0,
            leave_frame: false,
            bloom: false,
            seed: 1,
        }
    }

    /// This many beats.
    pub fn beats(mut self, n: usize) -> Self {
        self.beats = n.max(2);
        self
    }

    /// A fermata after beat `after`, held `hold_ms` longer.
    pub fn fermata(mut self, after: usize, hold_ms: f64) -> Self {
        self.fermata = Some((after, hold_ms));
        self
    }

    /// Background clutter.
    pub fn clutter(mut self) -> Self {
        self.clutter = true;
        self
    }

    /// A red sleeve, an exit sign and a red standby light.
    pub fn second_red(mut self) -> Self {
        self.second_red = true;
        self
    }

    /// Motion blur.
    pub fn blur(mut self) -> Self {
        self.blur = true;
        self
    }

    /// Sensor noise of σ steps.
    pub fn noise(mut self, sigma: f64) -> Self {
        self.noise = sigma;
        self
    }

    /// Drop this fraction of frames and hide the LED in `occlude` of them.
    pub fn drop(mut self, drop: f64, occlude: f64) -> Self {
        self.drop = drop;
        self.occlude = occlude;
        self
    }

    /// Big rebounds leave the picture.
    pub fn leave_frame(mut self) -> Self {
        self.leave_frame = true;
        self
    }

    /// An overexposed LED (white core, red halo).
    pub fn bloom(mut self) -> Self {
        self.bloom = true;
        self
    }

    /// Another seed.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Whether the tempo changes (then the looser tempo bar applies).
    pub fn changing(&self) -> bool {
        self.from_bpm != self.to_bpm
    }
}

/// The standard set at `fps`: steady 60, 90, 120, 160; accelerando 80→140; ritardando
/// 140→70; a fermata; clutter; a second red object; motion blur; noise; dropped frames; the
/// LED leaving the picture; an overexposed LED; all of the hard ones at once.
pub fn suite(fps: f64) -> Vec<Script> {
    vec![
        Script::steady("steady 60", 60.0, fps).beats(16),
        Script::steady("steady 90", 90.0, fps),
        Script::steady("steady 120", 120.0, fps),
        Script::steady("steady 160", 160.0, fps).beats(32),
        Script::ramp("accelerando 80-140", 80.0, 140.0, fps).beats(32),
        Script::ramp("ritardando 140-70", 140.0, 70.0, fps).beats(32),
        Script::steady("fermata 90", 90.0, fps).fermata(11, 2500.0),
        Script::steady("clutter 120", 120.0, fps).clutter().seed(2),
        Script::steady("second red 100", 100.0, fps)
            .clutter()
            .second_red()
            .seed(3),
        Script::steady("motion blur 140", 140.0, fps).blur().seed(4),
        Script::steady("noise 110", 110.0, fps).noise(12.0).seed(5),
        Script::steady("dropped frames 120", 120.0, fps)
            .drop(0.08, 0.04)
            .seed(6),
        Script::steady("leaves frame 100", 100.0, fps)
            .leave_frame()
            .seed(7),
        Script::steady("overexposed 130", 130.0, fps)
            .bloom()
            .seed(10),
        Script::ramp("all at once 90-130", 90.0, 130.0, fps)
            .beats(32)
            .clutter()
            .second_red()
            .blur()
            .noise(8.0)
            .drop(0.05, 0.02)
            .seed(8),
    ]
}

/// One true beat.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrueBeat {
    /// Time of the ictus, ms.
    pub t_ms: f64,
    /// The tempo there, BPM.
    pub bpm: f64,
    /// The LED at the ictus, pixels.
    pub x: f64,
    /// See `x`.
    pub y: f64,
}

/// A small, fast, seeded random generator (SplitMix64), so the harness needs no crate.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        Self(seed ^ 0x9E37_79B9_7F4A_7C15)
    }

    /// 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Roughly standard normal (sum of four uniforms, scaled).
    pub fn normal(&mut self) -> f64 {
        let s: f64 = (0..4).map(|_| self.unit()).sum();
        (s - 2.0) * 3f64.sqrt()
    }
}

#[derive(Clone, Copy, Debug)]
struct Segment {
    t0: f64,
    rebound: f64,
    hold: f64,
    fall: f64,
    x0: f64,
    y0: f64,
    top: f64,
    x1: f64,
    y1: f64,
}

/// A drawn conductor video: its frames on demand, and the truth.
#[derive(Clone, Debug)]
pub struct Video {
    /// What was filmed.
    pub script: Script,
    /// Every ictus.
    pub truth: Vec<TrueBeat>,
    /// Length, ms.
    pub duration_ms: f64,
    segments: Vec<Segment>,
    background: Frame,
    noise: Vec<i8>,
}

const REBOUND: f64 = 0.4;
const LED: [f64; 3] = [255.0, 45.0, 35.0];
const LED_SIGMA: f64 = 2.0;
const LED_GAIN: f64 = 3.0;

impl Video {
    /// Draws the script's background and works out the baton's path and the truth.
    pub fn new(script: Script) -> Self {
        let mut rng = Rng::new(script.seed);
        let n = script.beats;
        let slope = if n > 1 {
            (script.to_bpm - script.from_bpm) / (n - 1) as f64
        } else {
            0.0
        };
        let bpm_at = |k: f64| script.from_bpm + slope * k;
        let t_first = 700.0;
        let time_at = |k: f64| {
            if slope.abs() < 1e-12 {
                t_first + 60_000.0 * k / script.from_bpm
            } else {
                t_first + 60_000.0 / slope * (bpm_at(k) / script.from_bpm).ln()
            }
        };
        let (cx, base, scale) = if script.leave_frame {
            (330.0, 200.0, 1.6)
        } else {
            (300.0, 340.0, 1.0)
        };
        let pattern_x = [0.0, -110.0, 120.0, 20.0];
        let pattern_y = [0.0, 8.0, 8.0, -6.0];
        let pattern_h = [95.0, 85.0, 105.0, 150.0];
        let mut truth = Vec::with_capacity(n);
        let mut heights = Vec::with_capacity(n);
        let mut shift = 0.0;
        for k in 0..n {
            let b = k % 4;
            let t = time_at(k as f64) + shift;
            if script.fermata.is_some_and(|(after, _)| after == k) {
                shift += script.fermata.map_or(0.0, |f| f.1);
            }
            truth.push(TrueBeat {
                t_ms: t,
                bpm: bpm_at(k as f64),
                x: cx + pattern_x[b] + 6.0 * rng.normal(),
                y: base + pattern_y[b] + 3.0 * rng.normal(),
            });
            heights.push(scale * pattern_h[b] * (1.0 + 0.08 * rng.normal()));
        }
        let mut segments = Vec::with_capacity(n + 1);
        // The preparation: held at the top, then the fall into the first beat.
        let period0 = 60_000.0 / script.from_bpm;
        let prep_fall = (1.0 - REBOUND) * period0;
        let first = truth[0];
        segments.push(Segment {
            t0: first.t_ms - prep_fall - 1e6,
            rebound: 0.0,
            hold: 1e6,
            fall: prep_fall,
            x0: first.x - 40.0,
            y0: first.y - scale * 150.0,
            top: first.y - scale * 150.0,
            x1: first.x,
            y1: first.y,
        });
        for k in 0..n {
            let here = truth[k];
            let (next, interval) = match truth.get(k + 1) {
                Some(nx) => (*nx, nx.t_ms - here.t_ms),
                None => (here, 60_000.0 / here.bpm),
            };
            let nominal = if script.fermata.is_some_and(|(a, _)| a == k) {
                interval - script.fermata.map_or(0.0, |f| f.1)
            } else {
                interval
            };
            let last = k + 1 == n;
            segments.push(Segment {
                t0: here.t_ms,
                rebound: REBOUND * nominal,
                hold: if last { 1e9 } else { interval - nominal },
                fall: (1.0 - REBOUND) * nominal,
                x0: here.x,
                y0: here.y,
                top: here.y - heights[k],
                x1: if last { here.x + 30.0 } else { next.x },
                y1: next.y,
            });
        }
        let duration_ms = truth[n - 1].t_ms + 60_000.0 / truth[n - 1].bpm;
        let background = draw_background(&script, &mut rng);
        let noise = if script.noise > 0.0 {
            (0..1 << 20)
                .map(|_| (rng.normal() * script.noise).round().clamp(-127.0, 127.0) as i8)
                .collect()
        } else {
            Vec::new()
        };
        Self {
            script,
            truth,
            duration_ms,
            segments,
            background,
            noise,
        }
    }

    /// Where the LED is at `t_ms` (before blur).
    pub fn led_at(&self, t_ms: f64) -> (f64, f64) {
        let i = self
            .segments
            .partition_point(|s| s.t0 <= t_ms)
            .saturating_sub(1);
        let s = self.segments[i];
        let tau = t_ms - s.t0;
        let total = s.rebound + s.hold + s.fall;
        let y = if tau < s.rebound {
            let u = 1.0 - tau / s.rebound;
            s.top + (s.y0 - s.top) * u * u
        } else if tau < s.rebound + s.hold {
            s.top
        } else {
            let u = ((tau - s.rebound - s.hold) / s.fall).min(1.0);
            s.top + (s.y1 - s.top) * u * u
        };
        let u = (tau / total).clamp(0.0, 1.0);
        let smooth = u * u * (3.0 - 2.0 * u);
        let x = s.x0 + (s.x1 - s.x0) * smooth + 12.0 * (std::f64::consts::PI * u).sin();
        (x, y)
    }

    /// Frames in the video (dropped ones included).
    pub fn frame_count(&self) -> usize {
        (self.duration_ms * self.script.fps / 1000.0).ceil() as usize
    }

    /// Frame `i` as filmed (dropped or not): its time, and whether the LED is hidden.
    pub fn frame_at(&self, i: usize) -> (f64, Frame) {
        let t = i as f64 * 1000.0 / self.script.fps;
        let mut rng = Rng::new(self.script.seed.wrapping_mul(0x1000_0001) ^ i as u64);
        let _drop = rng.unit();
        let hidden = rng.unit() < self.script.occlude;
        let mut frame = self.background.clone();
        if self.script.second_red {
            let (lx, ly) = self.led_at(t);
            // The sleeve: at the wrist, down and right of the tip.
            fill_ellipse(&mut frame, lx + 75.0, ly + 125.0, 32.0, 22.0, [200, 28, 40]);
        }
        if !hidden {
            self.draw_led(&mut frame, t);
        }
        if !self.noise.is_empty() {
            let offset = (rng.next_u64() as usize) & (self.noise.len() - 1);
            let mask = self.noise.len() - 1;
            for (j, c) in frame.rgb.iter_mut().enumerate() {
                let v = i16::from(*c) + i16::from(self.noise[(j + offset) & mask]);
                *c = v.clamp(0, 255) as u8;
            }
        }
        (t, frame)
    }

    /// Whether frame `i` is dropped.
    pub fn dropped(&self, i: usize) -> bool {
        let mut rng = Rng::new(self.script.seed.wrapping_mul(0x1000_0001) ^ i as u64);
        rng.unit() < self.script.drop
    }

    /// The delivered frames, in order, each with its time in ms.
    pub fn frames(&self) -> impl Iterator<Item = (f64, Frame)> + '_ {
        (0..self.frame_count())
            .filter(|&i| !self.dropped(i))
            .map(|i| self.frame_at(i))
    }

    fn draw_led(&self, frame: &mut Frame, t: f64) {
        let fps = self.script.fps;
        let positions: Vec<(f64, f64)> = if self.script.blur {
            let exposure = 0.9 * 1000.0 / fps;
            (0..9)
                .map(|j| self.led_at(t + exposure * ((j as f64 + 0.5) / 9.0 - 0.5)))
                .collect()
        } else {
            vec![self.led_at(t)]
        };
        let r = (4.0 * LED_SIGMA).ceil();
        let x0 = positions.iter().map(|p| p.0).fold(f64::INFINITY, f64::min) - r;
        let x1 = positions
            .iter()
            .map(|p| p.0)
            .fold(f64::NEG_INFINITY, f64::max)
            + r;
        let y0 = positions.iter().map(|p| p.1).fold(f64::INFINITY, f64::min) - r;
        let y1 = positions
            .iter()
            .map(|p| p.1)
            .fold(f64::NEG_INFINITY, f64::max)
            + r;
        let (w, h) = (frame.width as f64, frame.height as f64);
        let (xa, xb) = (
            x0.max(0.0).floor() as usize,
            x1.min(w - 1.0).max(-1.0).ceil(),
        );
        let (ya, yb) = (
            y0.max(0.0).floor() as usize,
            y1.min(h - 1.0).max(-1.0).ceil(),
        );
        if xb < 0.0 || yb < 0.0 {
            return;
        }
        let (xb, yb) = (xb as usize, yb as usize);
        let k = LED_GAIN / positions.len() as f64;
        let inv = 1.0 / (2.0 * LED_SIGMA * LED_SIGMA);
        for py in ya..=yb.min(frame.height - 1) {
            for px in xa..=xb.min(frame.width - 1) {
                let a: f64 = positions
                    .iter()
                    .map(|&(lx, ly)| {
                        let d2 = (px as f64 - lx).powi(2) + (py as f64 - ly).powi(2);
                        (-d2 * inv).exp()
                    })
                    .sum::<f64>()
                    * k;
                if a < 0.004 {
                    continue;
                }
                // Overexposed, the light past the sensor's full scale spills into green and
                // blue: the core turns white.
                let mut led = LED;
                if self.script.bloom && a > 1.0 {
                    let spill = ((a - 1.0) / 1.2).min(1.0);
                    led[1] += (255.0 - led[1]) * spill;
                    led[2] += (255.0 - led[2]) * spill;
                }
                let a = a.min(1.0);
                let i = 3 * (py * frame.width + px);
                for (px, led) in frame.rgb[i..i + 3].iter_mut().zip(led) {
                    *px = (f64::from(*px) * (1.0 - a) + led * a).round() as u8;
                }
            }
        }
    }
}

fn fill_rect(frame: &mut Frame, x0: f64, y0: f64, w: f64, h: f64, c: [u8; 3]) {
    let xa = x0.max(0.0) as usize;
    let ya = y0.max(0.0) as usize;
    let xb = ((x0 + w).max(0.0) as usize).min(frame.width);
    let yb = ((y0 + h).max(0.0) as usize).min(frame.height);
    for y in ya..yb {
        for x in xa..xb {
            let i = 3 * (y * frame.width + x);
            frame.rgb[i..i + 3].copy_from_slice(&c);
        }
    }
}

fn fill_ellipse(frame: &mut Frame, cx: f64, cy: f64, rx: f64, ry: f64, c: [u8; 3]) {
    let ya = (cy - ry).max(0.0) as usize;
    let yb = ((cy + ry).max(0.0) as usize).min(frame.height.saturating_sub(1));
    let xa = (cx - rx).max(0.0) as usize;
    let xb = ((cx + rx).max(0.0) as usize).min(frame.width.saturating_sub(1));
    for y in ya..=yb {
        for x in xa..=xb {
            let (dx, dy) = ((x as f64 - cx) / rx, (y as f64 - cy) / ry);
            if dx * dx + dy * dy <= 1.0 {
                let i = 3 * (y * frame.width + x);
                frame.rgb[i..i + 3].copy_from_slice(&c);
            }
        }
    }
}

fn draw_background(script: &Script, rng: &mut Rng) -> Frame {
    let (w, h) = (script.width, script.height);
    let mut f = Frame::new(w, h);
    for y in 0..h {
        let g = 38.0 + 30.0 * y as f64 / h as f64;
        let c = [g as u8, (g + 2.0) as u8, (g + 8.0) as u8];
        for x in 0..w {
            let i = 3 * (y * w + x);
            f.rgb[i..i + 3].copy_from_slice(&c);
        }
    }
    if script.clutter {
        for _ in 0..40 {
            let (x, y) = (rng.unit() * w as f64, rng.unit() * h as f64);
            let (rw, rh) = (10.0 + rng.unit() * 90.0, 10.0 + rng.unit() * 70.0);
            let g = 40.0 + rng.unit() * 160.0;
            let b = 40.0 + rng.unit() * 160.0;
            // Muted: red never more than 35 above green and blue.
            let r = (30.0 + rng.unit() * 170.0).min(g.max(b) + 35.0);
            fill_rect(&mut f, x, y, rw, rh, [r as u8, g as u8, b as u8]);
        }
        // The conductor's white shirt, which the baton passes in front of.
        fill_rect(&mut f, 330.0, 300.0, 150.0, 180.0, [232, 232, 226]);
        // A bright lamp and a brown music stand.
        fill_ellipse(&mut f, 585.0, 150.0, 14.0, 14.0, [255, 250, 225]);
        fill_rect(&mut f, 40.0, 380.0, 140.0, 12.0, [110, 72, 48]);
    }
    if script.second_red {
        // An exit sign with white letters, and a red standby light.
        fill_rect(&mut f, 500.0, 25.0, 96.0, 34.0, [225, 30, 30]);
        for k in 0..4 {
            fill_rect(
                &mut f,
                510.0 + 21.0 * k as f64,
                33.0,
                12.0,
                18.0,
                [240, 240, 235],
            );
        }
        fill_ellipse(&mut f, 90.0, 440.0, 2.6, 2.6, [185, 50, 45]);
    }
    f
}

/// The tracker's score on one video.
#[derive(Clone, Debug, PartialEq)]
pub struct Score {
    /// The script's name.
    pub name: String,
    /// Frames per second.
    pub fps: f64,
    /// Whether the tempo changes.
    pub changing: bool,
    /// True beats.
    pub beats: usize,
    /// Beats found.
    pub found: usize,
    /// True beats with no beat found near them.
    pub missed: usize,
    /// Beats found near no true beat.
    pub invented: usize,
    /// Tempo error, BPM, median and 95th percentile (matched beats from the third on).
    pub tempo_err: (f64, f64),
    /// Beat time error, ms from the true ictus, median and 95th percentile.
    pub beat_err_ms: (f64, f64),
    /// Mean signed beat time error, ms (positive: found late).
    pub beat_bias_ms: f64,
    /// Frames delivered.
    pub frames: usize,
}

impl Score {
    /// Checks the bars: tempo error median under 1 BPM (steady) or 3 BPM (changing); beat
    /// time error median within one frame plus 10 ms; at most 5 % of the beats missed or
    /// invented (together). The reason when not.
    pub fn check(&self) -> Result<(), String> {
        let tempo_bar = if self.changing { 3.0 } else { 1.0 };
        let beat_bar = 1000.0 / self.fps + 10.0;
        let wrong = (self.missed + self.invented) as f64;
        let mut why = Vec::new();
        if self.tempo_err.0.is_nan() || self.tempo_err.0 >= tempo_bar {
            why.push(format!(
                "tempo error median {:.2} ≥ {tempo_bar} BPM",
                self.tempo_err.0
            ));
        }
        if self.beat_err_ms.0.is_nan() || self.beat_err_ms.0 > beat_bar {
            why.push(format!(
                "beat error median {:.1} > {beat_bar:.1} ms",
                self.beat_err_ms.0
            ));
        }
        if wrong > 0.05 * self.beats as f64 {
            why.push(format!(
                "{} missed + {} invented > 5 % of {}",
                self.missed, self.invented, self.beats
            ));
        }
        if why.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "{} @ {} fps: {}",
                self.name,
                self.fps,
                why.join("; ")
            ))
        }
    }

    /// The table's header (Markdown).
    pub fn header() -> &'static str {
        "| video | fps | beats | tempo err median / p95 (BPM) | beat err median / p95 (ms) | bias (ms) | missed | invented |\n|---|---|---|---|---|---|---|---|"
    }

    /// This score as a row of the table.
    pub fn row(&self) -> String {
        format!(
            "| {} | {} | {} | {:.2} / {:.2} | {:.1} / {:.1} | {:+.1} | {} | {} |",
            self.name,
            self.fps,
            self.beats,
            self.tempo_err.0,
            self.tempo_err.1,
            self.beat_err_ms.0,
            self.beat_err_ms.1,
            self.beat_bias_ms,
            self.missed,
            self.invented
        )
    }
}

/// The value at quantile `q` (0..=1) of `v` (nearest rank); NaN when empty.
pub fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    let i = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
    v[i]
}

/// Runs a [`Baton`] with `params` over the video and scores it against the truth.
///
/// A found beat matches the nearest unmatched true beat within 40 % of the local interval
/// (at most 200 ms); the rest are missed or invented.
pub fn evaluate(video: &Video, params: Params) -> Score {
    let mut baton = Baton::new(params);
    let mut found = Vec::new();
    let mut frames = 0;
    for (t, f) in video.frames() {
        frames += 1;
        if let Some(b) = baton.push(t, &f) {
            found.push(b);
        }
    }
    score(video, &found, frames)
}

/// Scores beats found (by any means) against the video's truth.
pub fn score(video: &Video, found: &[crate::Beat], frames: usize) -> Score {
    let truth = &video.truth;
    let mut taken = vec![false; found.len()];
    let (mut tempo, mut beat, mut signed) = (Vec::new(), Vec::new(), Vec::new());
    let mut missed = 0;
    for (k, tb) in truth.iter().enumerate() {
        let tol = (0.4 * 60_000.0 / tb.bpm).min(200.0);
        let best = (0..found.len())
            .filter(|&j| !taken[j] && (found[j].t_ms - tb.t_ms).abs() <= tol)
            .min_by(|&a, &b| {
                (found[a].t_ms - tb.t_ms)
                    .abs()
                    .total_cmp(&(found[b].t_ms - tb.t_ms).abs())
            });
        match best {
            Some(j) => {
                taken[j] = true;
                let d = found[j].t_ms - tb.t_ms;
                beat.push(d.abs());
                signed.push(d);
                if k >= 2 {
                    if let Some(bpm) = found[j].bpm {
                        tempo.push((bpm - tb.bpm).abs());
                    } else {
                        tempo.push(f64::INFINITY);
                    }
                }
            }
            None => missed += 1,
        }
    }
    let invented = taken.iter().filter(|t| !**t).count();
    Score {
        name: video.script.name.clone(),
        fps: video.script.fps,
        changing: video.script.changing(),
        beats: truth.len(),
        found: found.len(),
        missed,
        invented,
        tempo_err: (quantile(&tempo, 0.5), quantile(&tempo, 0.95)),
        beat_err_ms: (quantile(&beat, 0.5), quantile(&beat, 0.95)),
        beat_bias_ms: if signed.is_empty() {
            f64::NAN
        } else {
            signed.iter().sum::<f64>() / signed.len() as f64
        },
        frames,
    }
}

/// Scores every script on `threads` threads, in the order given.
pub fn run(scripts: &[Script], params: Params, threads: usize) -> Vec<Score> {
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results = std::sync::Mutex::new(vec![None; scripts.len()]);
    std::thread::scope(|s| {
        for _ in 0..threads.max(1) {
            s.spawn(|| loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(script) = scripts.get(i) else { break };
                let score = evaluate(&Video::new(script.clone()), params);
                results.lock().unwrap_or_else(|e| e.into_inner())[i] = Some(score);
            });
        }
    });
    results
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .into_iter()
        .flatten()
        .collect()
}
