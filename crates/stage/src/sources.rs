//! The conductor's tempo sources: where a live session hears its conductor (a baton video or
//! camera through `orch-baton`, tap tempo, incoming MIDI clock from a byte stream or UDP, OSC
//! over UDP), each an [`orch_perform::TempoSource`] whose cues are stamped on the performer's
//! clock, and [`follow`], the loop that hands each cue to the follower and its answer to the
//! performance's [`Control`].

use std::io::Read;
use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use orch_baton::source::{self, FrameSource};
use orch_baton::{Baton, Frame};
use orch_perform::{
    Action, ConductError, Control, Cue, Follower, MidiClock, OscCues, TapTempo, TempoSource, Timed,
};

use crate::SourceError;

/// Where the conductor is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SourceSpec {
    /// `baton:VIDEO`: a video of a baton with a red LED, played in real time from the score's
    /// start.
    Baton(PathBuf),
    /// `camera:DEVICE`: a live camera (V4L2) watching a baton with a red LED; needs the
    /// `camera` feature.
    Camera(PathBuf),
    /// `tap`: the space bar (or any key but q, Esc and the jump keys) in the live view.
    Tap,
    /// `midi-clock:IN`: raw MIDI bytes carrying clock.
    MidiClock(ClockIn),
    /// `osc:PORT` or `osc:HOST:PORT` (127.0.0.1 unless a host is given).
    Osc(SocketAddr),
}

/// Where MIDI clock bytes come from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ClockIn {
    /// `-`: standard input.
    Stdin,
    /// A file, FIFO or raw MIDI device, read as its bytes arrive.
    File(PathBuf),
    /// `udp:PORT` or `udp:HOST:PORT`: datagrams of raw bytes (127.0.0.1 unless a host is given).
    Udp(SocketAddr),
}

fn udp_addr(s: &str) -> Result<SocketAddr, String> {
    if let Ok(port) = s.parse::<u16>() {
        return Ok(SocketAddr::from(([127, 0, 0, 1], port)));
    }
    s.parse::<SocketAddr>()
        .map_err(|_| format!("{s:?} is not PORT or HOST:PORT (such as 9000 or 0.0.0.0:9000)"))
}

impl SourceSpec {
    /// Parses `--source`.
    pub fn parse(s: &str) -> Result<Self, String> {
        if s == "tap" {
            return Ok(SourceSpec::Tap);
        }
        let (kind, rest) = s.split_once(':').ok_or_else(|| {
            format!("--source {s}: give baton:VIDEO, camera:DEVICE, tap, midi-clock:IN or osc:PORT")
        })?;
        let bad = |m: String| format!("--source {s}: {m}");
        match kind {
            "baton" if !rest.is_empty() => Ok(SourceSpec::Baton(PathBuf::from(rest))),
            "camera" if !rest.is_empty() => Ok(SourceSpec::Camera(PathBuf::from(rest))),
            "midi-clock" => Ok(SourceSpec::MidiClock(match rest {
                "-" => ClockIn::Stdin,
                r if r.starts_with("udp:") => ClockIn::Udp(udp_addr(&r[4..]).map_err(bad)?),
                "" => return Err(bad("give IN: -, a file, or udp:PORT".into())),
                r => ClockIn::File(PathBuf::from(r)),
            })),
            "osc" => Ok(SourceSpec::Osc(udp_addr(rest).map_err(bad)?)),
            _ => Err(format!(
                "--source {s}: give baton:VIDEO, camera:DEVICE, tap, midi-clock:IN or osc:PORT"
            )),
        }
    }
}

/// The performer's clock: µs since the instant it holds (the performance's origin).
#[derive(Clone, Copy, Debug)]
pub struct Stamp(pub Instant);

impl Stamp {
    /// µs since the origin.
    pub fn now_us(self) -> u64 {
        self.at_us(Instant::now())
    }

    /// µs from the origin to `at` (0 before it).
    pub fn at_us(self, at: Instant) -> u64 {
        u64::try_from(at.saturating_duration_since(self.0).as_micros()).unwrap_or(u64::MAX)
    }
}

/// MIDI clock from a byte stream, each byte stamped when it is read.
struct ClockBytes<R: Read> {
    reader: R,
    decoder: MidiClock,
    pending: std::collections::VecDeque<Timed>,
    stamp: Stamp,
}

impl<R: Read> TempoSource for ClockBytes<R> {
    fn next_cue(&mut self) -> Result<Option<Timed>, ConductError> {
        let mut buf = [0u8; 256];
        loop {
            if let Some(c) = self.pending.pop_front() {
                return Ok(Some(c));
            }
            let n = match self.reader.read(&mut buf) {
                Ok(0) => return Ok(None),
                Ok(n) => n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e.into()),
            };
            let t_us = self.stamp.now_us();
            for &b in &buf[..n] {
                if let Some(cue) = self.decoder.feed(t_us, b) {
                    self.pending.push_back(Timed { t_us, cue });
                }
            }
        }
    }
}

/// UDP datagrams, each stamped when it arrived (the kernel's time: [`orch_io::arrival`]):
/// MIDI clock bytes or OSC packets.
struct Datagrams {
    socket: UdpSocket,
    kind: Datagram,
    pending: std::collections::VecDeque<Timed>,
    stamp: Stamp,
}

enum Datagram {
    Clock(MidiClock),
    Osc(OscCues),
}

impl TempoSource for Datagrams {
    fn next_cue(&mut self) -> Result<Option<Timed>, ConductError> {
        let mut buf = vec![0u8; 65_536];
        loop {
            if let Some(c) = self.pending.pop_front() {
                return Ok(Some(c));
            }
            let (n, arrived) = orch_io::arrival::recv(&self.socket, &mut buf)?;
            let t_us = self.stamp.at_us(arrived);
            match &mut self.kind {
                Datagram::Clock(d) => {
                    for &b in &buf[..n] {
                        if let Some(cue) = d.feed(t_us, b) {
                            self.pending.push_back(Timed { t_us, cue });
                        }
                    }
                }
                Datagram::Osc(o) => match o.packet(t_us, &buf[..n]) {
                    Ok(cues) => self
                        .pending
                        .extend(cues.into_iter().map(|cue| Timed { t_us, cue })),
                    // One bad packet is said and skipped: the next may be good.
                    Err(e) => tracing::warn!("{e}"),
                },
            }
        }
    }
}

/// A baton video played in real time from the score's start: each beat the tracker finds is
/// a cue at its ictus (the video's time 0 being the score's time 0 on the performer's clock).
struct BatonVideo {
    frames: Box<dyn FrameSource>,
    /// A live camera: frames come when they come (its time 0 is its first frame's arrival);
    /// a file is played in real time from the score's start.
    live: bool,
    baton: Baton,
    frame: Frame,
    control: Arc<Control>,
    start_us: Option<u64>,
    stamp: Stamp,
}

impl TempoSource for BatonVideo {
    fn next_cue(&mut self) -> Result<Option<Timed>, ConductError> {
        let start = match self.start_us {
            Some(s) => s,
            None if self.live => {
                // The first frame's arrival is the camera's time 0.
                let Some(t_ms) = self
                    .frames
                    .next_frame(&mut self.frame)
                    .map_err(|e| ConductError::Input(e.to_string()))?
                else {
                    return Ok(None);
                };
                let s = self
                    .stamp
                    .now_us()
                    .saturating_sub((t_ms * 1000.0).round() as u64);
                self.start_us = Some(s);
                self.baton.push(t_ms, &self.frame);
                s
            }
            None => loop {
                if let Some(m) = self.control.time_map() {
                    let s = m.wall(0).max(0) as u64;
                    self.start_us = Some(s);
                    break s;
                }
                std::thread::sleep(Duration::from_millis(1));
            },
        };
        loop {
            let Some(t_ms) = self
                .frames
                .next_frame(&mut self.frame)
                .map_err(|e| ConductError::Input(e.to_string()))?
            else {
                return Ok(None);
            };
            // A file's frame is seen when it is taken, not before.
            let due = start + (t_ms * 1000.0).round() as u64;
            let now = self.stamp.now_us();
            if !self.live && due > now {
                std::thread::sleep(Duration::from_micros(due - now));
            }
            if let Some(b) = self.baton.push(t_ms, &self.frame) {
                // The ictus's own time (the tracker confirms it two frames later): the
                // follower measures the tempo from these times, as for every source.
                let cue = Cue::Beat {
                    t_us: start + (b.t_ms * 1000.0).round().max(0.0) as u64,
                    bpm: None,
                };
                return Ok(Some(Timed {
                    t_us: self.stamp.now_us(),
                    cue,
                }));
            }
        }
    }
}

/// Taps from the live view.
struct Taps {
    rx: Receiver<u64>,
    tap: TapTempo,
}

impl TempoSource for Taps {
    fn next_cue(&mut self) -> Result<Option<Timed>, ConductError> {
        Ok(self.rx.recv().ok().map(|t_us| Timed {
            t_us,
            cue: self.tap.tap(t_us),
        }))
    }
}

/// What the conductor has done so far, for the view and the summary.
#[derive(Clone, Debug, Default)]
pub struct Status {
    /// Beats heard.
    pub beats: u64,
    /// The conductor's tempo as last heard, quarter notes a minute.
    pub bpm: Option<f64>,
    /// The tempo factor last asked of the performance.
    pub factor: Option<f64>,
    /// Paused by the conductor (MIDI Stop).
    pub paused: bool,
    /// The source ended or failed: why.
    pub ended: Option<String>,
}

impl Status {
    /// One line for the view and the summary, naming the source as `source`.
    pub fn line(&self, source: &str) -> String {
        let mut s = format!("conductor {source}: {} beats", self.beats);
        if let Some(b) = self.bpm {
            s += &format!(", {b:.1} BPM");
        }
        if let Some(f) = self.factor {
            s += &format!(", tempo x{f:.3}");
        }
        if self.paused {
            s += ", paused";
        }
        if let Some(e) = &self.ended {
            s += &format!(" ({e})");
        }
        s
    }
}

/// Hands each cue of `source` to the follower and the follower's answer to `control`, until
/// the source ends; between cues, wakes the follower when it asks ([`Follower::due`], on
/// `stamp`'s clock, the performer's): an early beat that can no longer be an invented one, a
/// beat overdue, a hedge or a pull done.
pub fn follow(
    mut source: Box<dyn TempoSource>,
    follower: Follower,
    control: &Control,
    status: &Mutex<Status>,
    stamp: Stamp,
) {
    let set = |f: &dyn Fn(&mut Status)| f(&mut status.lock().unwrap_or_else(|e| e.into_inner()));
    // The follower, and whether the source has ended; the waker waits on `changed`.
    let shared = Mutex::new((follower, false));
    let changed = Condvar::new();
    let lock = || shared.lock().unwrap_or_else(|e| e.into_inner());
    let answer = |action: Action, bpm: Option<f64>, beat: bool, t_us: u64| {
        action.apply(control, t_us);
        set(&|s| {
            s.beats += u64::from(beat);
            s.bpm = bpm.or(s.bpm);
            if let Action::Tempo(t) = action {
                s.factor = Some(t.get());
            }
            s.paused = control.paused();
        });
    };
    std::thread::scope(|scope| {
        scope.spawn(|| {
            let mut g = lock();
            loop {
                if g.1 || control.stopping() {
                    return;
                }
                let now = stamp.now_us();
                match g.0.due() {
                    None => g = changed.wait(g).unwrap_or_else(|e| e.into_inner()),
                    Some(d) if d > now => {
                        let wait = Duration::from_micros(d - now);
                        g = changed
                            .wait_timeout(g, wait)
                            .unwrap_or_else(|e| e.into_inner())
                            .0;
                    }
                    Some(_) => {
                        let action = g.0.wake(now, control.time_map().as_ref());
                        answer(action, g.0.bpm(), false, now);
                    }
                }
            }
        });
        let end = |why: Option<String>| {
            if let Some(why) = why {
                set(&|s| s.ended = Some(why.clone()));
            }
            lock().1 = true;
            changed.notify_all();
        };
        loop {
            let cue = match source.next_cue() {
                Ok(Some(c)) => c,
                Ok(None) => return end(Some("its input ended".into())),
                Err(e) => {
                    tracing::warn!("{e}");
                    return end(Some(e.to_string()));
                }
            };
            if control.stopping() {
                return end(None);
            }
            let mut g = lock();
            let action = g.0.cue(&cue, control.time_map().as_ref());
            answer(
                action,
                g.0.bpm(),
                matches!(cue.cue, Cue::Beat { .. }),
                cue.t_us,
            );
            drop(g);
            changed.notify_all();
        }
    });
}

/// Opens the source `spec` names for a performance steered by `control`, its cues stamped on
/// `stamp`'s clock; `taps` carries the tap source's key presses (µs on the same clock).
pub fn open_source(
    spec: &SourceSpec,
    control: &Arc<Control>,
    stamp: Stamp,
    taps: Option<Receiver<u64>>,
) -> Result<Box<dyn TempoSource>, SourceError> {
    let pending = std::collections::VecDeque::new();
    Ok(match spec {
        SourceSpec::Baton(path) => {
            let frames = source::open(path, None).map_err(|e| match e {
                source::SourceError::BadInput(m) => SourceError::BadInput(format!("baton: {m}")),
                source::SourceError::Io(e) => SourceError::Io {
                    what: "reading the video".into(),
                    source: e,
                },
            })?;
            Box::new(BatonVideo {
                frames,
                live: false,
                baton: Baton::default(),
                frame: Frame::default(),
                control: Arc::clone(control),
                start_us: None,
                stamp,
            })
        }
        SourceSpec::Camera(device) => Box::new(BatonVideo {
            frames: open_camera(device)?,
            live: true,
            baton: Baton::default(),
            frame: Frame::default(),
            control: Arc::clone(control),
            start_us: None,
            stamp,
        }),
        SourceSpec::Tap => Box::new(Taps {
            rx: taps.ok_or_else(|| {
                SourceError::BadInput("tap: no key presses are wired to it".into())
            })?,
            tap: TapTempo::new(),
        }),
        SourceSpec::MidiClock(ClockIn::Stdin) => Box::new(ClockBytes {
            reader: std::io::stdin(),
            decoder: MidiClock::new(),
            pending,
            stamp,
        }),
        SourceSpec::MidiClock(ClockIn::File(path)) => Box::new(ClockBytes {
            reader: std::fs::File::open(path).map_err(|e| {
                SourceError::BadInput(format!("midi-clock:{}: {e}", path.display()))
            })?,
            decoder: MidiClock::new(),
            pending,
            stamp,
        }),
        SourceSpec::MidiClock(ClockIn::Udp(addr)) | SourceSpec::Osc(addr) => {
            let socket = UdpSocket::bind(addr)
                .map_err(|e| SourceError::BadInput(format!("cannot listen on UDP {addr}: {e}")))?;
            orch_io::arrival::stamp_arrivals(&socket)
                .map_err(|e| SourceError::BadInput(format!("UDP {addr}: {e}")))?;
            let kind = match spec {
                SourceSpec::Osc(_) => Datagram::Osc(OscCues::new()),
                _ => Datagram::Clock(MidiClock::new()),
            };
            Box::new(Datagrams {
                socket,
                kind,
                pending,
                stamp,
            })
        }
    })
}

/// A live camera, with the `camera` feature.
#[cfg(feature = "camera")]
fn open_camera(device: &Path) -> Result<Box<dyn FrameSource>, SourceError> {
    orch_baton::camera::Camera::open(device)
        .map(|c| Box::new(c) as Box<dyn FrameSource>)
        .map_err(|e| SourceError::BadInput(format!("camera: {e}")))
}

/// Without the `camera` feature: said, naming the device.
#[cfg(not(feature = "camera"))]
fn open_camera(device: &Path) -> Result<Box<dyn FrameSource>, SourceError> {
    Err(SourceError::BadInput(format!(
        "camera:{}: this orch was built without the `camera` feature (V4L2); build it with \
         `cargo build --release --features camera`",
        device.display()
    )))
}

/// A short name of the source for the view: "baton take1.y4m", "OSC udp 127.0.0.1:9000".
pub fn source_name(spec: &SourceSpec) -> String {
    let file = |p: &Path| {
        p.file_name()
            .map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into())
    };
    match spec {
        SourceSpec::Baton(p) => format!("baton {}", file(p)),
        SourceSpec::Camera(p) => format!("camera {}", p.display()),
        SourceSpec::Tap => "tap (space)".into(),
        SourceSpec::MidiClock(ClockIn::Stdin) => "MIDI clock on stdin".into(),
        SourceSpec::MidiClock(ClockIn::File(p)) => format!("MIDI clock {}", file(p)),
        SourceSpec::MidiClock(ClockIn::Udp(a)) => format!("MIDI clock udp {a}"),
        SourceSpec::Osc(a) => format!("OSC udp {a}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sources_parse() {
        assert_eq!(SourceSpec::parse("tap"), Ok(SourceSpec::Tap));
        assert_eq!(
            SourceSpec::parse("baton:v.y4m"),
            Ok(SourceSpec::Baton("v.y4m".into()))
        );
        assert_eq!(
            SourceSpec::parse("camera:/dev/video0"),
            Ok(SourceSpec::Camera("/dev/video0".into()))
        );
        assert_eq!(
            SourceSpec::parse("midi-clock:-"),
            Ok(SourceSpec::MidiClock(ClockIn::Stdin))
        );
        assert_eq!(
            SourceSpec::parse("midi-clock:udp:9000"),
            Ok(SourceSpec::MidiClock(ClockIn::Udp(
                "127.0.0.1:9000".parse().unwrap()
            )))
        );
        assert_eq!(
            SourceSpec::parse("osc:0.0.0.0:57120"),
            Ok(SourceSpec::Osc("0.0.0.0:57120".parse().unwrap()))
        );
        for bad in [
            "",
            "osc:",
            "osc:x",
            "baton:",
            "camera:",
            "midi-clock:",
            "clock:3",
            "midi-clock:udp:70000",
        ] {
            assert!(SourceSpec::parse(bad).is_err(), "{bad}");
        }
    }
}
