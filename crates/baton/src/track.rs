//! Following the LED from frame to frame among the red blobs.
//!
//! - **LED-like**: a blob is a candidate when its area is within
//!   [`TrackParams::min_area`]..=[`TrackParams::max_area`] and its
//!   [thickness](crate::Blob::thickness) is at most [`TrackParams::max_thickness`]: an LED is
//!   small, and motion blur makes it a thin streak, never a wide patch. A sleeve, an exit
//!   sign or a red score cover is too big or too thick; single noisy pixels are too small.
//! - **Gate**: while a track runs, its next position is predicted at constant velocity (for
//!   at most [`TrackParams::coast_ms`]), and
//!   only candidates within `gate_px + max_speed × dt + gate_growth_px × missed` of the
//!   prediction can continue it (the baton reverses at every ictus, so the gate allows for
//!   the fastest plausible move since the last sighting, and widens with every frame
//!   missed). The nearest one does: **the
//!   track is preferred** over any brighter blob elsewhere.
//! - **Missed frames**: a frame without a gated candidate is a miss; the track coasts on its
//!   prediction for up to [`TrackParams::lost_ms`], then is dropped. The LED leaving the
//!   frame is a run of misses; when it comes back within the widened gate the track goes on,
//!   else a new one starts.
//! - **Static spots**: candidates that are not the track are remembered by position; one
//!   seen [`TrackParams::static_hits`] times within [`TrackParams::static_px`] of the same
//!   place is *static* (a red standby light, a reflection). A new track starts on the
//!   brightest non-static candidate (static ones only when there is nothing else).
//! - **Switching**: if the track has stood still (under [`TrackParams::still_px`] a frame)
//!   for [`TrackParams::switch_still_ms`] while another candidate has moved for
//!   [`TrackParams::switch_frames`] frames in a row, the track moves to it: a start on the
//!   wrong light is put right. A baton held still (a fermata) keeps its track as long as no
//!   other LED-like object moves.

use crate::Blob;

/// The tracker's parameters; pixel figures are for 640×480 (scale them with the image).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackParams {
    /// Smallest LED blob, pixels. Default 4.
    pub min_area: u32,
    /// Largest LED blob (a motion-blurred streak included), pixels. Default 1500.
    pub max_area: u32,
    /// Thickest LED blob ([`Blob::thickness`]), pixels. Default 14.
    pub max_thickness: f64,
    /// Gate radius at rest, pixels. Default 40.
    pub gate_px: f64,
    /// Fastest the LED moves, pixels per ms (a big rebound at 160 BPM reaches about 2). The
    /// gate grows by this times the time since the last sighting: the baton can reverse at
    /// any moment, so the prediction alone is not enough. Default 3.
    pub max_speed: f64,
    /// The prediction carries the last velocity on for at most this long, ms: a baton out of
    /// sight turns round (at the top of a rebound), it does not fly on. Default 60.
    pub coast_ms: f64,
    /// Gate growth per missed frame, pixels. Default 30.
    pub gate_growth_px: f64,
    /// Largest gate, pixels. Default 320.
    pub max_gate_px: f64,
    /// A track with no blob for this long is dropped, ms. Default 700.
    pub lost_ms: f64,
    /// A static spot is this small, pixels. Default 3.
    pub static_px: f64,
    /// Sightings that make a spot static. Default 8.
    pub static_hits: u32,
    /// Below this many pixels a frame the track is standing still. Default 1.5.
    pub still_px: f64,
    /// The track must stand still this long before another candidate may take over, ms.
    /// Default 500.
    pub switch_still_ms: f64,
    /// Frames in a row the other candidate must have moved. Default 4.
    pub switch_frames: u32,
}

impl Default for TrackParams {
    fn default() -> Self {
        Self {
            min_area: 4,
            max_area: 1500,
            max_thickness: 14.0,
            gate_px: 40.0,
            max_speed: 3.0,
            coast_ms: 60.0,
            gate_growth_px: 30.0,
            max_gate_px: 320.0,
            lost_ms: 700.0,
            static_px: 3.0,
            static_hits: 8,
            still_px: 1.5,
            switch_still_ms: 500.0,
            switch_frames: 4,
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Track {
    x: f64,
    y: f64,
    vx: f64,
    vy: f64,
    t_ms: f64,
    missed: u32,
    still_since: Option<f64>,
}

#[derive(Clone, Copy, Debug)]
struct Spot {
    x: f64,
    y: f64,
    hits: u32,
    last_ms: f64,
}

#[derive(Clone, Copy, Debug)]
struct Mover {
    x: f64,
    y: f64,
    frames: u32,
}

/// What the tracker made of one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Seen {
    /// The LED's position, if it was found in this frame.
    pub at: Option<(f64, f64)>,
    /// The track is new (started, restarted after a loss, or switched to another blob): any
    /// stroke under way belongs to the old one.
    pub new_track: bool,
}

/// The LED tracker. Feed it each frame's blobs with the frame's time.
#[derive(Clone, Debug, Default)]
pub struct Tracker {
    params: TrackParams,
    track: Option<Track>,
    spots: Vec<Spot>,
    mover: Option<Mover>,
}

impl Tracker {
    /// A tracker with these parameters.
    pub fn new(params: TrackParams) -> Self {
        Self {
            params,
            ..Self::default()
        }
    }

    /// Whether a blob could be the LED.
    pub fn led_like(&self, b: &Blob) -> bool {
        b.area >= self.params.min_area
            && b.area <= self.params.max_area
            && b.thickness() <= self.params.max_thickness
    }

    /// Whether a track is running.
    pub fn tracking(&self) -> bool {
        self.track.is_some()
    }

    fn is_static(&self, b: &Blob) -> bool {
        let r2 = self.params.static_px * self.params.static_px;
        self.spots.iter().any(|s| {
            s.hits >= self.params.static_hits && (s.x - b.x).powi(2) + (s.y - b.y).powi(2) <= r2
        })
    }

    /// One frame at `t_ms` with its blobs (from [`crate::Detector`]).
    pub fn update(&mut self, t_ms: f64, blobs: &[Blob]) -> Seen {
        let candidates: Vec<usize> = (0..blobs.len())
            .filter(|&i| self.led_like(&blobs[i]))
            .collect();
        let mut new_track = false;
        let mut chosen = self.gated(t_ms, blobs, &candidates);
        if self.track.is_none() {
            chosen = self.start(t_ms, blobs, &candidates);
            new_track = chosen.is_some();
        } else if let Some(i) = chosen {
            self.follow(t_ms, &blobs[i]);
        } else if let Some(tr) = self.track.as_mut() {
            tr.missed += 1;
        }
        self.watch_others(t_ms, blobs, &candidates, chosen);
        if let Some(seen) = self.switch(t_ms) {
            return seen;
        }
        Seen {
            at: chosen.map(|i| (blobs[i].x, blobs[i].y)),
            new_track,
        }
    }

    /// The candidate that continues the running track: the nearest within its gate. A track
    /// with none for too long is dropped.
    fn gated(&mut self, t_ms: f64, blobs: &[Blob], candidates: &[usize]) -> Option<usize> {
        let p = self.params;
        let tr = self.track?;
        let dt = t_ms - tr.t_ms;
        let coast = dt.min(p.coast_ms);
        let (px, py) = (tr.x + tr.vx * coast, tr.y + tr.vy * coast);
        let gate = (p.gate_px + p.max_speed * dt + p.gate_growth_px * f64::from(tr.missed))
            .min(p.max_gate_px);
        let mut best = f64::INFINITY;
        let mut chosen = None;
        for &i in candidates {
            let d = ((blobs[i].x - px).powi(2) + (blobs[i].y - py).powi(2)).sqrt();
            // Within the gate; a static spot only close to where the track is.
            let ok = d <= gate && (d <= p.gate_px || !self.is_static(&blobs[i]));
            if ok && d < best {
                best = d;
                chosen = Some(i);
            }
        }
        if chosen.is_none() && t_ms - tr.t_ms > p.lost_ms {
            self.track = None;
        }
        chosen
    }

    /// Starts a track on the brightest non-static candidate (a static one only when there is
    /// nothing else).
    fn start(&mut self, t_ms: f64, blobs: &[Blob], candidates: &[usize]) -> Option<usize> {
        let i = candidates
            .iter()
            .copied()
            .filter(|&i| !self.is_static(&blobs[i]))
            .max_by(|&a, &b| {
                (blobs[a].peak, blobs[a].weight)
                    .partial_cmp(&(blobs[b].peak, blobs[b].weight))
                    .unwrap_or(std::cmp::Ordering::Equal)
            })
            .or_else(|| candidates.first().copied())?;
        self.track = Some(Track::at(blobs[i].x, blobs[i].y, t_ms, Some(t_ms)));
        self.mover = None;
        Some(i)
    }

    /// The running track goes on to `b`.
    fn follow(&mut self, t_ms: f64, b: &Blob) {
        let still_px = self.params.still_px;
        let Some(tr) = self.track.as_mut() else {
            return;
        };
        let dt = (t_ms - tr.t_ms).max(1e-3);
        let (vx, vy) = ((b.x - tr.x) / dt, (b.y - tr.y) / dt);
        let moved = ((b.x - tr.x).powi(2) + (b.y - tr.y).powi(2)).sqrt();
        let frames = 1.0 + f64::from(tr.missed);
        if moved / frames >= still_px {
            tr.still_since = None;
        } else if tr.still_since.is_none() {
            tr.still_since = Some(t_ms);
        }
        *tr = Track {
            vx,
            vy,
            ..Track::at(b.x, b.y, t_ms, tr.still_since)
        };
    }

    /// The candidates other than the track's: remember static spots, follow the fastest
    /// mover.
    fn watch_others(
        &mut self,
        t_ms: f64,
        blobs: &[Blob],
        candidates: &[usize],
        chosen: Option<usize>,
    ) {
        let mut mover_next: Option<Mover> = None;
        for &i in candidates.iter().filter(|&&i| Some(i) != chosen) {
            let b = &blobs[i];
            self.remember(b, t_ms);
            if let Some(m) = self.moved_on(b) {
                if mover_next.is_none_or(|n| m.frames > n.frames) {
                    mover_next = Some(m);
                }
                continue;
            }
            if mover_next.is_none() && !self.is_static(b) {
                mover_next = Some(Mover {
                    x: b.x,
                    y: b.y,
                    frames: 0,
                });
            }
        }
        self.spots.retain(|s| t_ms - s.last_ms <= 2000.0);
        self.mover = mover_next;
    }

    /// Counts a sighting of `b` at its spot (a new spot, the oldest forgotten past 64).
    fn remember(&mut self, b: &Blob, t_ms: f64) {
        let r2 = self.params.static_px * self.params.static_px;
        if let Some(s) = self
            .spots
            .iter_mut()
            .find(|s| (s.x - b.x).powi(2) + (s.y - b.y).powi(2) <= r2)
        {
            s.hits += 1;
            s.last_ms = t_ms;
            return;
        }
        if self.spots.len() >= 64 {
            let oldest = (0..self.spots.len())
                .min_by(|&a, &c| self.spots[a].last_ms.total_cmp(&self.spots[c].last_ms))
                .unwrap_or(0);
            self.spots.swap_remove(oldest);
        }
        self.spots.push(Spot {
            x: b.x,
            y: b.y,
            hits: 1,
            last_ms: t_ms,
        });
    }

    /// The mover gone on to `b`, if `b` is a move of it (not standing, not a leap).
    fn moved_on(&self, b: &Blob) -> Option<Mover> {
        let p = self.params;
        let m = self.mover?;
        let d = ((b.x - m.x).powi(2) + (b.y - m.y).powi(2)).sqrt();
        (d >= p.still_px && d <= p.max_gate_px / 2.0).then_some(Mover {
            x: b.x,
            y: b.y,
            frames: m.frames + 1,
        })
    }

    /// A track standing still while something else keeps moving: the track moves to it.
    fn switch(&mut self, t_ms: f64) -> Option<Seen> {
        let p = self.params;
        let (tr, m) = (self.track?, self.mover?);
        let still = tr
            .still_since
            .is_some_and(|s| t_ms - s >= p.switch_still_ms);
        if !(still && m.frames >= p.switch_frames) {
            return None;
        }
        self.track = Some(Track::at(m.x, m.y, t_ms, None));
        self.mover = None;
        Some(Seen {
            at: Some((m.x, m.y)),
            new_track: true,
        })
    }
}

impl Track {
    /// A track at rest at (`x`, `y`) at `t_ms`.
    fn at(x: f64, y: f64, t_ms: f64, still_since: Option<f64>) -> Self {
        Self {
            x,
            y,
            vx: 0.0,
            vy: 0.0,
            t_ms,
            missed: 0,
            still_since,
        }
    }
}
