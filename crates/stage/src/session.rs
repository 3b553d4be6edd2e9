//! A song played live on one or more robots: one sender thread a robot (real-time priority
//! where the OS allows it), all on one clock and one [`Control`] (stop, pause, jump, tempo,
//! and a conductor through it), with a [`Snapshot`] of where the performance stands for any
//! front end to show, and every robot's [`Played`] (report and note-by-note account) at the
//! end.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, Sender as Tx};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use orch_io::{Channels, OutSpec, OutStats, Output};
use orch_perform::{
    realtime, song_events, Control, Cue, Follow, Follower, Link, Live, PerformError, Performer,
    Played, ScoreBeats, ScoreEvent, Setup, TapTempo, Tempo, Timed,
};
use orch_seq::{Clock, Song};

use crate::{LiveError, StageError};

/// Makes each robot's clock (one a sender thread, called on the session's thread at its
/// start): every clock it makes must count from the same zero, the session's origin, so the
/// robots play in step. [`Session::start`] gives each robot the host's precise clock
/// ([`realtime::PreciseClock`]) from the origin; a front end plugs in another (a shared
/// network clock, say) with [`Session::start_clocked`].
pub type MakeClock = Arc<dyn Fn() -> Box<dyn Clock + Send> + Send + Sync>;

/// [`MakeClock`] for the host's precise clock whose zero is `origin`.
pub fn precise_clocks(origin: Instant) -> MakeClock {
    Arc::new(move || Box::new(realtime::PreciseClock::starting_at(origin)))
}

/// One robot of a session: where it plays and how it is set up.
pub struct Lane {
    /// The output as given (`sim`, `serial:…`, `i2c:…`, with its channels).
    pub spec: OutSpec,
    /// The performance's setup for it (its link: a DIN line or direct).
    pub setup: Setup,
    /// The output, or `None` for the virtual robot alone.
    pub out: Option<Output>,
}

/// The outputs `texts` name (`--out`), each parsed as [`OutSpec::parse`] takes it; the
/// virtual robot alone (`sim`) when there is none. Bad input ([`LiveError::BadInput`]) for
/// one that is not an output.
pub fn out_specs(texts: &[String]) -> Result<Vec<OutSpec>, LiveError> {
    if texts.is_empty() {
        return Ok(vec![OutSpec::parse("sim").expect("sim is an output")]);
    }
    texts
        .iter()
        .map(|o| OutSpec::parse(o).map_err(|e| LiveError::BadInput(e.to_string())))
        .collect()
}

/// Opens every output in `specs`: one robot (a lane) each, set up as `setup` with its link.
pub fn open_lanes(specs: Vec<OutSpec>, setup: &Setup) -> Result<Vec<Lane>, LiveError> {
    let mut lanes = Vec::new();
    for spec in specs {
        let setup = setup.clone().with_link(if spec.is_din() {
            Link::Din
        } else {
            Link::Direct
        });
        let out = Output::open(
            &spec.target,
            &setup.config,
            &setup.sim.kinds,
            setup.sim.pwm_hz,
        )
        .map_err(|e| LiveError::BadInput(format!("--out {}: {e}", spec.text)))?;
        lanes.push(Lane { spec, setup, out });
    }
    Ok(lanes)
}

/// The song's events for a robot that takes `channels`, and its notes.
pub fn lane_events(song: &Song, channels: Channels) -> (Vec<ScoreEvent>, usize) {
    if channels == Channels::ALL {
        return (song_events(song).collect(), song.notes());
    }
    let events: Vec<_> = song_events(song)
        .filter(|e| channels.passes(&e.bytes))
        .collect();
    let notes = events
        .iter()
        .filter(|e| e.bytes.note_on().is_some())
        .count();
    (events, notes)
}

/// Where a live session stands: every robot's keys together, where the first robot is in the
/// song.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Snapshot {
    /// The MIDI note of the lowest key.
    pub low_note: u8,
    /// Whether each key is down on any robot.
    pub keys_down: Vec<bool>,
    /// The bar and beat playing, counted from 1 by the song's time signatures.
    pub bar: u32,
    /// The beat in the bar.
    pub beat: u32,
    /// The tempo now, quarter notes a minute (the song's, times the tempo factor).
    pub bpm: f64,
    /// Seconds of the song played, at the tempo played.
    pub elapsed_s: f64,
    /// The song's length at the tempo it started at, seconds.
    pub total_s: f64,
    /// Notes sent so far, every robot's.
    pub notes_sent: u64,
    /// The notes there are to send, every robot's.
    pub notes: u64,
    /// The tempo factor (1.0: as written).
    pub tempo: f64,
    /// Paused.
    pub paused: bool,
    /// The first robot's interpreter counters: the guard's among them (keys cut by the hold
    /// limit, the duty limit, the watchdog; notes refused by the power budget).
    pub stats: orch_core::Stats,
}

/// How often a session's watcher looks for a change to tell its viewers: 30 times a second.
pub const WATCH_EVERY: Duration = Duration::from_millis(33);

type LaneResult = Result<(Played, Option<OutStats>), PerformError>;

/// A robot's sender thread.
struct Sender {
    spec: OutSpec,
    thread: JoinHandle<(realtime::Priority, LaneResult)>,
}

/// Where every robot stands, as each sender last said, and the viewers to tell.
struct Watch {
    song: Arc<Song>,
    lives: Vec<Arc<Mutex<Option<Live>>>>,
    low_note: u8,
    total_s: f64,
    notes: u64,
    viewers: Mutex<Vec<Tx<Snapshot>>>,
    /// The last snapshot told.
    last: Mutex<Option<Snapshot>>,
}

impl Watch {
    fn snapshot(&self) -> Option<Snapshot> {
        let mut all: Option<Live> = None;
        let mut sent = 0;
        for live in &self.lives {
            let Some(l) = live.lock().unwrap_or_else(|e| e.into_inner()).clone() else {
                continue;
            };
            sent += l.notes_sent;
            match all.as_mut() {
                None => all = Some(l),
                Some(a) => {
                    for (d, k) in a.keys_down.iter_mut().zip(&l.keys_down) {
                        *d |= *k;
                    }
                }
            }
        }
        let l = all?;
        let (bar, beat) = self.song.bar_beat(l.song_us);
        Some(Snapshot {
            low_note: self.low_note,
            keys_down: l.keys_down,
            bar,
            beat,
            bpm: self.song.tempo_at(l.song_us).bpm() * l.tempo,
            elapsed_s: l.song_us as f64 / 1e6 / l.tempo,
            total_s: self.total_s,
            notes_sent: sent,
            notes: self.notes,
            tempo: l.tempo,
            paused: l.paused,
            stats: l.stats,
        })
    }

    /// Tells every viewer the snapshot if it changed; forgets viewers that went away.
    fn tell(&self) {
        let Some(now) = self.snapshot() else { return };
        let mut last = self.last.lock().unwrap_or_else(|e| e.into_inner());
        if last.as_ref() == Some(&now) {
            return;
        }
        self.viewers
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .retain(|v| v.send(now.clone()).is_ok());
        *last = Some(now);
    }
}

/// Stops every robot when the thread it lives on panics (its output, dropped on the way, has
/// let go of its keys).
struct StopOnPanic(Arc<Control>);

impl Drop for StopOnPanic {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.stop();
        }
    }
}

/// One robot's end of a session.
pub struct Ended {
    /// Its output.
    pub spec: OutSpec,
    /// The performance: its report and its account.
    pub played: Played,
    /// What happened on its output (none for the virtual robot alone).
    pub stats: Option<OutStats>,
}

/// How a session ended for its robots.
pub struct Finished {
    /// Every robot that played to its end (or was stopped), in lane order.
    pub ended: Vec<Ended>,
    /// The first robot that failed, if any: its output and why.
    pub failed: Option<(OutSpec, SessionFailure)>,
    /// Whether the OS refused real-time priority to a sender (its messages may then be late
    /// under load; the report's lateness says).
    pub priority_refused: bool,
}

/// Why a robot's performance failed.
#[derive(Debug)]
pub enum SessionFailure {
    /// Its performance stopped with an error (its output failed).
    Performance(PerformError),
    /// Its sender thread panicked (its keys were released on the way).
    Panicked,
}

impl std::fmt::Display for SessionFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SessionFailure::Performance(e) => write!(f, "{e}"),
            SessionFailure::Panicked => {
                f.write_str("its sender thread panicked (its keys were released)")
            }
        }
    }
}

/// Tap tempo on a session: each tap a beat, the follower's rate taken as the tempo.
struct Taps {
    tap: TapTempo,
    follower: Follower,
}

/// A song playing live on its robots. See the [module notes](self).
pub struct Session {
    control: Arc<Control>,
    /// The performers' clock's zero: taps are timed on it.
    origin: Instant,
    taps: Mutex<Taps>,
    senders: Vec<Sender>,
    watch: Arc<Watch>,
    /// Set when every robot has ended: the watcher tells a last time and ends.
    done: Arc<AtomicBool>,
    watcher: Option<JoinHandle<()>>,
}

impl Session {
    /// Starts `song` on every lane, steered by `control`, on a clock whose zero is `origin`
    /// (a conductor's cues are timed on it). A jump asked of `control` before the start
    /// (`--from`) is taken before the first note.
    pub fn start(song: Song, lanes: Vec<Lane>, control: Arc<Control>, origin: Instant) -> Self {
        Self::start_clocked(song, lanes, control, origin, precise_clocks(origin))
    }

    /// Starts `song` as [`start`](Self::start) does, each robot paced by a clock `clocks`
    /// makes (counting from `origin`, as the taps are timed).
    pub fn start_clocked(
        song: Song,
        lanes: Vec<Lane>,
        control: Arc<Control>,
        origin: Instant,
        clocks: MakeClock,
    ) -> Self {
        let song = Arc::new(song);
        let taps = Mutex::new(Taps {
            tap: TapTempo::new(),
            follower: Follower::new(ScoreBeats::of(&song), Follow::Immediate),
        });
        let (low_note, tempo) = lanes.first().map_or((0, 1.0), |l| {
            (l.setup.config.range.low().get(), l.setup.tempo.get())
        });
        let mut senders = Vec::new();
        let mut lives = Vec::new();
        let mut notes_total = 0u64;
        for lane in lanes {
            let Lane {
                spec,
                setup,
                mut out,
            } = lane;
            let (events, notes) = lane_events(&song, spec.channels);
            notes_total += notes as u64;
            let live: Arc<Mutex<Option<Live>>> = Arc::new(Mutex::new(None));
            let (control, live_in) = (Arc::clone(&control), Arc::clone(&live));
            let mut clock = clocks();
            let thread = realtime::spawn(move || -> LaneResult {
                let _guard = StopOnPanic(Arc::clone(&control));
                let mut on_live = |l: &Live| {
                    *live_in.lock().unwrap_or_else(|e| e.into_inner()) = Some(l.clone());
                };
                let mut performer = Performer::new(&setup, events.into_iter(), notes)
                    .clock(&mut *clock)
                    .control(&control)
                    .live(&mut on_live);
                if let Some(out) = out.as_mut() {
                    performer = performer.midi(out);
                }
                let played = performer.run()?;
                Ok((played, out.as_ref().map(Output::stats)))
            });
            senders.push(Sender { spec, thread });
            lives.push(live);
        }
        let watch = Arc::new(Watch {
            total_s: song.duration_us() as f64 / 1e6 / tempo,
            song,
            lives,
            low_note,
            notes: notes_total,
            viewers: Mutex::new(Vec::new()),
            last: Mutex::new(None),
        });
        let done = Arc::new(AtomicBool::new(false));
        let watcher = {
            let (watch, done) = (Arc::clone(&watch), Arc::clone(&done));
            std::thread::Builder::new()
                .name("orch-session-watch".into())
                .spawn(move || {
                    while !done.load(Ordering::SeqCst) {
                        watch.tell();
                        std::thread::sleep(WATCH_EVERY);
                    }
                    watch.tell();
                })
                .ok()
        };
        Self {
            control,
            origin,
            taps,
            senders,
            watch,
            done,
            watcher,
        }
    }

    /// A new viewer: it gets the snapshot as it stands now (if the performance has begun),
    /// then each change, at most 30 times a second ([`WATCH_EVERY`]). Any number of viewers
    /// may watch; one that goes away (drops its receiver) is forgotten. The channel closes when
    /// the session has finished.
    pub fn subscribe(&self) -> Receiver<Snapshot> {
        let (tx, rx) = mpsc::channel();
        // Under the lock that the watcher tells under: the viewer misses no change between
        // the snapshot it is given and the next one told.
        let last = self.watch.last.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(s) = last.clone().or_else(|| self.watch.snapshot()) {
            let _ = tx.send(s);
        }
        self.watch
            .viewers
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(tx);
        drop(last);
        rx
    }

    /// The control every robot follows: stop, pause, resume, jump, tempo.
    pub fn control(&self) -> &Arc<Control> {
        &self.control
    }

    /// Jump to the start of bar `bar` (see [`Control::jump_to`]); a bar the song does not
    /// have is refused and changes nothing. Returns the target, µs of score time.
    pub fn jump_to_bar(&self, bar: u32) -> Result<u64, StageError> {
        let t = crate::bars::start_of(&self.watch.song, bar)?;
        self.control.jump_to(t);
        Ok(t)
    }

    /// Play at tempo factor `factor` (1.0: as written) from now on; a factor out of
    /// [`FACTOR_RANGE`](orch_perform::follow::FACTOR_RANGE) is refused and changes nothing.
    pub fn set_tempo(&self, factor: f64) -> Result<Tempo, StageError> {
        let tempo = crate::setup::tempo(factor)?;
        self.control.set_tempo(tempo);
        Ok(tempo)
    }

    /// Tap tempo: a beat tapped now. See [`tap_at`](Self::tap_at).
    pub fn tap(&self) -> Option<f64> {
        self.tap_at(self.origin.elapsed().as_micros() as u64)
    }

    /// Tap tempo: a beat tapped at `t_us` on the performers' clock (µs since the session's
    /// origin). The taps go through the conductor's follower (rate only, as `orch conduct
    /// --source tap` measures them): from the second tap on, the song plays at the tempo they
    /// beat, each a quarter note; one odd tap moves nothing. Returns the tempo tapped so far,
    /// quarter notes a minute (none before there is one).
    pub fn tap_at(&self, t_us: u64) -> Option<f64> {
        let mut taps = self.taps.lock().unwrap_or_else(|e| e.into_inner());
        let cue: Cue = taps.tap.tap(t_us);
        let action = taps
            .follower
            .cue(&Timed { t_us, cue }, self.control.time_map().as_ref());
        action.apply(&self.control, t_us);
        taps.follower.bpm()
    }

    /// The song.
    pub fn song(&self) -> &Song {
        &self.watch.song
    }

    /// Whether every robot has finished (played to the end, or stopped).
    pub fn is_finished(&self) -> bool {
        self.senders.iter().all(|s| s.thread.is_finished())
    }

    /// Where the performance stands now (none before the first robot has said).
    pub fn snapshot(&self) -> Option<Snapshot> {
        self.watch.snapshot()
    }

    /// Waits for every robot to end and gives each one's performance.
    pub fn finish(mut self) -> Finished {
        let mut finished = Finished {
            ended: Vec::new(),
            failed: None,
            priority_refused: false,
        };
        for s in std::mem::take(&mut self.senders) {
            match s.thread.join() {
                Ok((priority, Ok((played, stats)))) => {
                    finished.priority_refused |= priority != realtime::Priority::Realtime;
                    finished.ended.push(Ended {
                        spec: s.spec,
                        played,
                        stats,
                    });
                }
                Ok((_, Err(e))) => {
                    finished
                        .failed
                        .get_or_insert((s.spec, SessionFailure::Performance(e)));
                }
                Err(_) => {
                    finished
                        .failed
                        .get_or_insert((s.spec, SessionFailure::Panicked));
                }
            }
        }
        self.end_watch();
        finished
    }

    /// Ends the watcher: it tells a last time, then every viewer's channel closes.
    fn end_watch(&mut self) {
        self.done.store(true, Ordering::SeqCst);
        if let Some(w) = self.watcher.take() {
            let _ = w.join();
        }
        self.watch
            .viewers
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clear();
    }
}

impl Drop for Session {
    fn drop(&mut self) {
        self.end_watch();
    }
}
