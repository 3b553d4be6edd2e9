//! The songs loaded, the queue, the performance playing, and the state every viewer is sent.
//!
//! One [`Player`] a server. A play starts an [`orch_stage::session::Session`] on the
//! configured outputs, and a thread of its own watches it: each snapshot the session tells
//! (at most 30 a second) becomes the [`state`](Player::state) sent to every viewer; at the
//! end every robot's report is worded as `orch play` prints it (`orch_stage::text::reports`),
//! kept for the page with the note-by-note account, and the queue's next song starts (unless
//! the performance was stopped).
//!
//! Commands ([`Command`]) act on the session at once and are acknowledged with the state
//! once the performance shows them (a pause paused, a tempo taken, a stop ended with every
//! key up), or after a second if it does not (a jump asked while paused is taken on resume).

use std::collections::VecDeque;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use orch_io::OutSpec;
use orch_perform::{Control, Setup, Tempo};
use orch_robot::Robot;
use orch_stage::bars::{last_bar, start_of};
use orch_stage::places::Places;
use orch_stage::session::{open_lanes, Session, Snapshot};
use orch_stage::StageError;
use serde::Deserialize;
use serde_json::{json, Value};
use tokio::sync::{broadcast, watch};

use crate::{Analysis, Config};

/// Songs kept loaded: the oldest not playing or queued is forgotten past this.
pub const KEPT_SONGS: usize = 16;

/// The largest library file read: 64 MiB, as `orch play` reads a file.
const MAX_LIBRARY_FILE: u64 = 64 << 20;

/// A song read and analysed, ready to play.
pub struct Loaded {
    /// Its number on this server.
    pub id: u64,
    /// Its file name.
    pub name: String,
    /// What the analysis said.
    pub analysis: Analysis,
}

impl Loaded {
    /// The song as the API gives it: its number, name, bars and length, the analysis as
    /// `orch analyze --json` prints it (`analysis`) and as it prints it in text (`text`).
    pub fn json(&self) -> Value {
        let song = &self.analysis.song;
        json!({
            "id": self.id,
            "name": self.name,
            "bars": last_bar(song),
            "seconds": song.duration_us() as f64 / 1e6,
            "analysis": self.analysis.json,
            "text": self.analysis.text,
            "roll": format!("/api/songs/{}/roll.svg", self.id),
        })
    }
}

/// A command to the player, as the API takes it (`{"cmd": "pause"}`, ...).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(tag = "cmd", rename_all = "snake_case", deny_unknown_fields)]
pub enum Command {
    /// Play a loaded song (from a bar, if given). Refused while another plays.
    Play {
        /// The song's number.
        song: u64,
        /// The bar to start at (1 if not given).
        #[serde(default)]
        bar: Option<u32>,
    },
    /// Pause: every key released, the song waits.
    Pause,
    /// Go on after a pause.
    Resume,
    /// Stop: every key released at once, the rest of the song (and the queue) not played.
    Stop,
    /// The tempo factor (1.0 as written): now, and for the next play.
    Tempo {
        /// A twentieth to twenty.
        factor: f64,
    },
    /// Tap tempo: a beat tapped now.
    Tap,
    /// Jump to the start of a bar.
    Jump {
        /// The bar, from 1.
        bar: u32,
    },
    /// Add a loaded song to the end of the queue.
    Queue {
        /// The song's number.
        song: u64,
    },
    /// Take the queue's entry at `index` (from 0) out.
    Unqueue {
        /// Its place in the queue.
        index: usize,
    },
}

/// Why a request was refused (nothing changed).
#[derive(Clone, Debug, PartialEq)]
pub enum Reject {
    /// Bad input: a song that cannot be played, a bar or tempo out of range (400).
    Bad(String),
    /// No such song or file (404).
    NotFound(String),
    /// Not now: nothing playing, or something already playing (409).
    Conflict(String),
}

impl std::fmt::Display for Reject {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Reject::Bad(m) | Reject::NotFound(m) | Reject::Conflict(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for Reject {}

/// A bar the song lacks, or a tempo out of range, said as the page's command asked it.
fn refused(e: StageError) -> Reject {
    match e {
        StageError::NoSuchBar { bar, .. } => Reject::Bad(format!("bar {bar}: {e}")),
        StageError::Tempo(t) => Reject::Bad(format!("tempo {t}: {e}")),
        e => Reject::Bad(crate::words(&e)),
    }
}

/// The report of the last performance.
struct Ended {
    song: u64,
    name: String,
    stopped: bool,
    text: String,
    json: Value,
    /// The first robot's note-by-note account (as `orch play --notes` writes it), as JSON
    /// text: a line a note of the score, kept compact (tens of thousands for a long piece).
    account: Arc<str>,
    /// When the performance's clock began (ms since the Unix epoch).
    origin_ms: f64,
    /// When the song began on that clock (score time 0; the account's times count from
    /// it), ms.
    start_ms: f64,
}

/// The performance playing.
struct Now {
    song: Arc<Loaded>,
    session: Arc<Session>,
    /// When its clock began (ms since the Unix epoch).
    origin_ms: f64,
    /// The tempo factor it started at.
    tempo: f64,
}

/// What changes, under one lock.
struct Inner {
    songs: Vec<Arc<Loaded>>,
    next_id: u64,
    queue: VecDeque<Arc<Loaded>>,
    now: Option<Now>,
    live: Option<Snapshot>,
    ended: Option<Ended>,
    /// The tempo factor a play starts at (the last one asked).
    tempo: f64,
    /// The last performance that failed (its output), and why.
    failure: Option<String>,
    /// Counts states told.
    seq: u64,
    /// A performance has ended and its report is being made.
    ending: bool,
}

/// The server's player. See the [module notes](self).
pub struct Player {
    robot: Robot,
    setup: Setup,
    outs: Vec<OutSpec>,
    named: bool,
    library: Option<PathBuf>,
    access: crate::Access,
    session: Option<Arc<dyn crate::Session>>,
    inner: Mutex<Inner>,
    /// One song analysed at a time: uploads wait their turn rather than each holding a
    /// 16 MiB file's analysis in memory at once.
    analysing: Mutex<()>,
    states: broadcast::Sender<Arc<str>>,
    closing: watch::Sender<bool>,
}

impl Player {
    /// A player of `config`, nothing loaded.
    /// The shared session the page shows and steers, if any (`orch serve --link`).
    pub fn session(&self) -> Option<&dyn crate::Session> {
        self.session.as_deref()
    }

    pub fn new(config: Config) -> Arc<Self> {
        let tempo = config.setup.tempo.get();
        Arc::new(Self {
            robot: config.robot,
            setup: config.setup,
            outs: config.outs,
            named: config.named,
            library: config.library,
            access: config.access,
            session: config.session,
            inner: Mutex::new(Inner {
                songs: Vec::new(),
                next_id: 1,
                queue: VecDeque::new(),
                now: None,
                live: None,
                ended: None,
                tempo,
                failure: None,
                seq: 0,
                ending: false,
            }),
            analysing: Mutex::new(()),
            states: broadcast::channel(64).0,
            closing: watch::channel(false).0,
        })
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Who may come in.
    pub fn access(&self) -> &crate::Access {
        &self.access
    }

    /// A new viewer of the state: each state told from now on (as JSON text).
    pub fn subscribe(&self) -> broadcast::Receiver<Arc<str>> {
        self.states.subscribe()
    }

    /// Set when the server is shutting down: viewers leave.
    pub fn closing(&self) -> watch::Receiver<bool> {
        self.closing.subscribe()
    }

    /// The state as every viewer sees it (see the README's "The web page").
    pub fn state(&self) -> Value {
        state_of(&self.lock(), self)
    }

    /// Tells every viewer the state.
    fn tell(&self) {
        let mut inner = self.lock();
        inner.seq += 1;
        let text: Arc<str> = state_of(&inner, self).to_string().into();
        drop(inner);
        let _ = self.states.send(text);
    }

    /// Reads and analyses an uploaded song (on this thread: it takes a while for a long one).
    pub fn load(&self, name: &str, bytes: &[u8]) -> Result<Arc<Loaded>, Reject> {
        let name = clean_name(name);
        let _turn = self.analysing.lock().unwrap_or_else(|e| e.into_inner());
        let analysis =
            crate::analyze(&self.robot, &self.setup, &name, bytes).map_err(Reject::Bad)?;
        let mut inner = self.lock();
        let id = inner.next_id;
        inner.next_id += 1;
        let loaded = Arc::new(Loaded { id, name, analysis });
        inner.songs.push(Arc::clone(&loaded));
        // Forget the oldest songs neither playing nor queued.
        while inner.songs.len() > KEPT_SONGS {
            let busy = |s: &Arc<Loaded>| {
                inner.now.as_ref().is_some_and(|n| n.song.id == s.id)
                    || inner.queue.iter().any(|q| q.id == s.id)
            };
            match inner.songs.iter().position(|s| !busy(s)) {
                Some(i) => {
                    inner.songs.remove(i);
                }
                None => break,
            }
        }
        drop(inner);
        self.tell();
        Ok(loaded)
    }

    /// The library's songs: the `.mid` and `.midi` files in its folder, by name (none
    /// without `--library`).
    pub fn library(&self) -> Result<Vec<String>, Reject> {
        let Some(dir) = &self.library else {
            return Ok(Vec::new());
        };
        list_library(dir)
    }

    /// Reads and analyses the library's song `name` (a name [`library`](Self::library)
    /// lists, nothing else).
    pub fn load_from_library(&self, name: &str) -> Result<Arc<Loaded>, Reject> {
        let dir = self.library.as_ref().ok_or_else(|| {
            Reject::NotFound("this orch serve has no library (start it with --library DIR)".into())
        })?;
        if !list_library(dir)?.iter().any(|n| n == name) {
            return Err(Reject::NotFound(format!(
                "the library has no song {name:?}"
            )));
        }
        let path = dir.join(name);
        let mut bytes = Vec::new();
        std::fs::File::open(&path)
            .and_then(|f| f.take(MAX_LIBRARY_FILE + 1).read_to_end(&mut bytes))
            .map_err(|e| Reject::Bad(format!("cannot read {name}: {e}")))?;
        if bytes.len() as u64 > MAX_LIBRARY_FILE {
            return Err(Reject::Bad(format!(
                "{name} is larger than the {} MiB a MIDI file may be",
                MAX_LIBRARY_FILE >> 20
            )));
        }
        self.load(name, &bytes)
    }

    /// The last performance's end: its report (as the state has it) with the first robot's
    /// note-by-note account (`account`, as `orch play --notes` writes it), when its clock
    /// began (`origin_ms`, ms since the Unix epoch) and when the song began on it
    /// (`start_ms`: the account's times count from there).
    /// As JSON text.
    pub fn ended(&self) -> Result<String, Reject> {
        let inner = self.lock();
        let e = inner
            .ended
            .as_ref()
            .ok_or_else(|| Reject::NotFound("no performance has ended yet".into()))?;
        let head = json!({
            "song": e.song,
            "name": e.name,
            "stopped": e.stopped,
            "text": e.text,
            "report": e.json,
            "origin_ms": e.origin_ms,
            "start_ms": e.start_ms,
        })
        .to_string();
        // The account, kept as text, goes in as it is.
        let head = head.strip_suffix('}').unwrap_or(&head);
        Ok(format!("{head},\"account\":{}}}", e.account))
    }

    /// A loaded song.
    pub fn song(&self, id: u64) -> Result<Arc<Loaded>, Reject> {
        find(&self.lock(), id)
    }

    /// Does `command`, and gives the state once the performance shows it (at most a second
    /// or so later). Blocks: call it off the async runtime.
    pub fn command(self: &Arc<Self>, command: Command) -> Result<Value, Reject> {
        let session = || {
            self.lock()
                .now
                .as_ref()
                .map(|n| Arc::clone(&n.session))
                .ok_or_else(|| Reject::Conflict("nothing is playing".into()))
        };
        match command {
            Command::Play { song, bar } => {
                self.start(song, bar)?;
                self.wait_live(|s| s.is_some());
            }
            Command::Pause => {
                let s = session()?;
                s.control().pause();
                self.wait_live(|s| s.is_some_and(|s| s.paused));
            }
            Command::Resume => {
                let s = session()?;
                s.control().resume();
                self.wait_live(|s| s.is_some_and(|s| !s.paused));
            }
            Command::Stop => {
                let s = session()?;
                // The queue goes with it: STOP means everything stops.
                self.lock().queue.clear();
                s.control().stop();
                drop(s);
                // Acknowledged once the performance has ended, every key up, and its report
                // is in.
                let t0 = Instant::now();
                while {
                    let inner = self.lock();
                    inner.now.is_some() || inner.ending
                } && t0.elapsed() < Duration::from_secs(5)
                {
                    std::thread::sleep(Duration::from_millis(2));
                }
            }
            Command::Tempo { factor } => {
                let tempo = orch_stage::setup::tempo(factor).map_err(refused)?;
                self.lock().tempo = tempo.get();
                if let Ok(s) = session() {
                    s.set_tempo(factor).map_err(refused)?;
                    self.wait_live(|s| s.is_some_and(|s| s.tempo == factor));
                }
            }
            Command::Tap => {
                let s = session()?;
                s.tap();
            }
            Command::Jump { bar } => {
                let s = session()?;
                s.jump_to_bar(bar).map_err(refused)?;
                if !s.control().paused() {
                    self.wait_live(|s| s.is_some_and(|s| s.bar == bar));
                }
            }
            Command::Queue { song } => {
                let mut inner = self.lock();
                let loaded = find(&inner, song)?;
                inner.queue.push_back(loaded);
            }
            Command::Unqueue { index } => {
                let mut inner = self.lock();
                if inner.queue.remove(index).is_none() {
                    return Err(Reject::NotFound(format!(
                        "the queue has no entry {index} (it has {})",
                        inner.queue.len()
                    )));
                }
            }
        }
        self.tell();
        Ok(self.state())
    }

    /// Starts song `id` (from `bar`) on the outputs, with a thread to watch it.
    fn start(self: &Arc<Self>, id: u64, bar: Option<u32>) -> Result<Arc<Session>, Reject> {
        let mut inner = self.lock();
        if let Some(now) = &inner.now {
            return Err(Reject::Conflict(format!(
                "{} is playing: stop it first, or queue this song",
                now.song.name
            )));
        }
        let song = find(&inner, id)?;
        let from = match bar {
            None => None,
            Some(bar) => Some(start_of(&song.analysis.song, bar).map_err(refused)?),
        };
        let setup = self
            .setup
            .clone()
            .with_tempo(Tempo::new(inner.tempo).unwrap_or(Tempo::NORMAL));
        let lanes =
            open_lanes(self.outs.clone(), &setup).map_err(|e| Reject::Bad(e.to_string()))?;
        let control = Control::new();
        // Where the keys stand, every 5 ms (not 40): the page is told within a frame or two.
        control.poll_every(5_000);
        if let Some(t) = from {
            control.jump_to(t);
        }
        let origin = Instant::now();
        let origin_ms = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0.0, |d| d.as_secs_f64() * 1e3);
        let session = Arc::new(Session::start(
            song.analysis.song.clone(),
            lanes,
            control,
            origin,
        ));
        let viewer = session.subscribe();
        inner.now = Some(Now {
            song: Arc::clone(&song),
            session: Arc::clone(&session),
            origin_ms,
            tempo: setup.tempo.get(),
        });
        inner.live = None;
        inner.ended = None;
        inner.failure = None;
        drop(inner);
        let (player, watched) = (Arc::clone(self), Arc::clone(&session));
        std::thread::Builder::new()
            .name("orch-serve-player".into())
            .spawn(move || player.watch(song, watched, viewer))
            .map_err(|e| Reject::Bad(format!("cannot start the player: {e}")))?;
        Ok(session)
    }

    /// Follows a performance to its end: each snapshot told; then its report, and the
    /// queue's next song.
    fn watch(
        self: Arc<Self>,
        song: Arc<Loaded>,
        session: Arc<Session>,
        viewer: Receiver<Snapshot>,
    ) {
        loop {
            match viewer.recv_timeout(Duration::from_millis(20)) {
                Ok(s) => {
                    self.lock().live = Some(s);
                    self.tell();
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            if session.is_finished() {
                break;
            }
        }
        let stopped = session.control().stopping();
        let (origin_ms, tempo) = {
            let mut inner = self.lock();
            inner.ending = true;
            inner
                .now
                .take()
                .map_or((0.0, 1.0), |n| (n.origin_ms, n.tempo))
        };
        // The commands that held it a moment let go.
        let mut session = session;
        let session = loop {
            match Arc::try_unwrap(session) {
                Ok(s) => break s,
                Err(s) => {
                    session = s;
                    std::thread::sleep(Duration::from_millis(1));
                }
            }
        };
        let finished = session.finish();
        // The report as `orch play` prints it, and as its --json does.
        let reports = orch_stage::Reports::of(&finished.ended, self.named);
        let text = orch_stage::text::reports(&reports, Path::new(&song.name));
        let report = serde_json::to_value(&reports).unwrap_or(Value::Null);
        let tempo = Tempo::new(tempo).unwrap_or(Tempo::NORMAL);
        let (account, start_ms) = finished.ended.first().map_or(("null".into(), 0.0), |e| {
            // Serialised line by line (`orch_stage::account::account`'s lines, without a JSON
            // tree of tens of thousands of objects on the way).
            let the_song = &song.analysis.song;
            let places = Places::of(the_song, &e.played, e.spec.channels, tempo);
            let lines = e
                .played
                .account(|i, t_ms| places.bar_beat(the_song, i, t_ms));
            let text = serde_json::to_string(&lines).unwrap_or_else(|_| "null".into());
            (Arc::<str>::from(text), e.played.start_us as f64 / 1e3)
        });
        let failure = finished
            .failed
            .as_ref()
            .map(|(spec, why)| format!("--out {}: {why}", spec.text));
        let next = {
            let mut inner = self.lock();
            inner.live = None;
            inner.ended = Some(Ended {
                song: song.id,
                name: song.name.clone(),
                stopped,
                text,
                json: report,
                account,
                origin_ms,
                start_ms,
            });
            inner.failure = failure.clone();
            inner.ending = false;
            if stopped || failure.is_some() {
                None
            } else {
                inner.queue.pop_front()
            }
        };
        self.tell();
        if let Some(next) = next {
            if let Err(e) = self.start(next.id, None) {
                self.lock().failure = Some(format!("{}: {e}", next.name));
                self.tell();
            }
        }
    }

    /// Waits (at most a second) until the performance as the viewers were last told
    /// satisfies `ok`, or has ended.
    fn wait_live(&self, ok: impl Fn(Option<&Snapshot>) -> bool) {
        let t0 = Instant::now();
        while t0.elapsed() < Duration::from_secs(1) {
            let inner = self.lock();
            if inner.now.is_none() || ok(inner.live.as_ref()) {
                return;
            }
            drop(inner);
            std::thread::sleep(Duration::from_millis(2));
        }
    }

    /// Shutting down: viewers leave, any performance stops (every key released) and ends.
    pub fn shut_down(&self) {
        let _ = self.closing.send(true);
        let now = self.lock().now.as_ref().map(|n| Arc::clone(&n.session));
        if let Some(s) = now {
            s.control().stop();
        }
        let t0 = Instant::now();
        while {
            let inner = self.lock();
            inner.now.is_some() || inner.ending
        } && t0.elapsed() < Duration::from_secs(5)
        {
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

fn find(inner: &Inner, id: u64) -> Result<Arc<Loaded>, Reject> {
    inner
        .songs
        .iter()
        .find(|s| s.id == id)
        .cloned()
        .ok_or_else(|| Reject::NotFound(format!("no song {id} is loaded")))
}

/// A file name as given, kept to its last part and to printable characters.
fn clean_name(name: &str) -> String {
    let last = name.rsplit(['/', '\\']).next().unwrap_or("");
    let clean: String = last.chars().filter(|c| !c.is_control()).take(200).collect();
    if clean.trim().is_empty() {
        "upload.mid".into()
    } else {
        clean
    }
}

/// The `.mid` and `.midi` files in `dir`, sorted.
fn list_library(dir: &Path) -> Result<Vec<String>, Reject> {
    let entries = std::fs::read_dir(dir)
        .map_err(|e| Reject::NotFound(format!("cannot read the library {}: {e}", dir.display())))?;
    let mut names: Vec<String> = entries
        .filter_map(Result::ok)
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file() || t.is_symlink()))
        .filter_map(|e| e.file_name().into_string().ok())
        .filter(|n| {
            let lower = n.to_ascii_lowercase();
            lower.ends_with(".mid") || lower.ends_with(".midi")
        })
        .collect();
    names.sort();
    Ok(names)
}

/// The state (see [`Player::state`]).
fn state_of(inner: &Inner, player: &Player) -> Value {
    let setup = &player.setup;
    let range = setup.config.range;
    let playing = inner.now.as_ref().map(|now| {
        let mut p = json!({
            "song": now.song.id,
            "name": now.song.name,
            "origin_ms": now.origin_ms,
            "bars": last_bar(&now.song.analysis.song),
        });
        if let Some(s) = &inner.live {
            let down: Vec<u8> = s
                .keys_down
                .iter()
                .enumerate()
                .filter(|(_, d)| **d)
                .map(|(i, _)| s.low_note.saturating_add(i as u8))
                .collect();
            let st = &s.stats;
            // Where the song is (its own time, whatever the tempo) over its length.
            let length_s = now.song.analysis.song.duration_us() as f64 / 1e6;
            let progress = if length_s > 0.0 {
                (s.elapsed_s * s.tempo / length_s).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let extra = json!({
                "paused": s.paused,
                "bar": s.bar,
                "beat": s.beat,
                "bpm": s.bpm,
                "tempo": s.tempo,
                "elapsed_s": s.elapsed_s,
                "total_s": s.total_s,
                "progress": progress,
                "notes_sent": s.notes_sent,
                "notes": s.notes,
                "down": down,
                "guard": {
                    "note_ons": st.note_ons,
                    "played": st.played,
                    "dropped_power": st.dropped_power,
                    "dropped_too_fast": st.dropped_too_fast,
                    "cut_by_hold_limit": st.cut_by_hold_limit,
                    "cut_by_duty_limit": st.cut_by_duty_limit,
                    "cut_by_watchdog": st.cut_by_watchdog,
                    "peak_keys_down": st.peak_keys_down,
                },
            });
            if let (Some(p), Value::Object(e)) = (p.as_object_mut(), extra) {
                p.extend(e);
            }
        }
        p
    });
    let brief = |s: &Arc<Loaded>| json!({ "id": s.id, "name": s.name });
    json!({
        "seq": inner.seq,
        "keyboard": { "low": range.low().get(), "high": range.high().get() },
        "guard": if setup.config.guard.enabled { "on" } else { "off" },
        "outs": player.outs.iter().map(|o| o.text.as_str()).collect::<Vec<_>>(),
        "tempo": inner.tempo,
        "songs": inner.songs.iter().map(brief).collect::<Vec<_>>(),
        "queue": inner.queue.iter().map(brief).collect::<Vec<_>>(),
        "playing": playing,
        "ended": inner.ended.as_ref().map(|e| json!({
            "song": e.song,
            "name": e.name,
            "stopped": e.stopped,
            "text": e.text,
            "report": e.json,
        })),
        "failure": inner.failure,
    })
}
