//! # orch-serve: the web page of `orch serve`
//!
//! One page, served by the `orch` binary with its assets built in (plain HTML, CSS and
//! JavaScript, [`include_str!`]'d: no build step), to pick a song (from a library folder, or
//! uploaded), read what the robot will make of it before it plays (the report, the notes that
//! will go wrong, the piano roll), play it on the robot and steer it live from a phone (play,
//! pause, resume, a STOP always in view, jump to a bar, tempo factor, tap tempo, a queue), and
//! read the report at the end.
//!
//! - [`Config`]: what to serve (the robot and its setup, the outputs, the library, the
//!   address). [`analyze`] reads and analyses a song as `orch play` and `orch analyze` do,
//!   through `orch-stage`, so that the page says exactly what they print; at the end the
//!   report is `orch play`'s too.
//! - [`serve`]: binds nothing itself; it serves on a listener the caller bound, until a
//!   shutdown future resolves, then stops any performance (every key released).
//! - [`api`]: the JSON API the page itself uses, and the WebSocket of live state (documented
//!   there and in the README's "The web page: `orch serve`").
//! - [`guard`]: the security around it, because the robot moves: a token off loopback, the
//!   `Host` checked (DNS rebinding), commands and WebSocket upgrades from another `Origin`
//!   refused, commands JSON only, uploads at most [`MAX_UPLOAD`] bytes.
//! - [`player`]: the songs loaded, the queue, the performance playing (an
//!   [`orch_stage::session::Session`]) and the state every viewer is sent.
//!
//! - [`check`]: what can be checked before serving (the outputs, the library), and
//!   [`until_set`]: a shutdown when a flag is set (a signal).
//!
//! Errors are [`ServeError`] (the server could not start or run). What a request gets wrong is
//! answered to it (`{"error": "..."}` with a 4xx status) and changes nothing.

pub mod api;
pub mod guard;
pub mod player;
pub mod session;

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use orch_io::OutSpec;
use orch_perform::Setup;
use orch_robot::Robot;
use orch_seq::Song;

pub use guard::Access;
pub use session::{Session, SessionCommand, SessionStatus};

/// The largest upload taken: 16 MiB (larger gets 413 Payload Too Large).
pub const MAX_UPLOAD: usize = 16 << 20;

/// A song read and analysed: what the page shows before it plays.
#[derive(Clone)]
pub struct Analysis {
    /// The song, to play.
    pub song: Song,
    /// The analysis as `orch analyze --json` prints it (the report, `went_wrong`).
    pub json: serde_json::Value,
    /// The analysis as `orch analyze` prints it (the findings, the notes that will go wrong,
    /// the report).
    pub text: String,
    /// The piano roll, SVG (as `orch analyze --svg` writes it).
    pub svg: String,
}

/// Reads `bytes` (a file called `name`) as strictly as `orch play` reads a file, and analyses
/// it on `robot` as `setup` plays it, as `orch analyze` does. A file that cannot be played is
/// `Err` with the message `orch play` gives for it.
pub fn analyze(robot: &Robot, setup: &Setup, name: &str, bytes: &[u8]) -> Result<Analysis, String> {
    let bytes = orch_stage::load::read_midi(bytes, name, orch_stage::load::MAX_MIDI_FILE_BYTES)
        .map_err(|e| words(&e))?;
    let song = orch_stage::load::song(&bytes, name).map_err(|e| words(&e))?;
    // The roll draws each strike to its key-up: the sound events are kept too.
    let setup = setup.clone().with_keep(orch_sim::Keep::Everything);
    let (analysis, played) = orch_stage::analyze(&song, robot, &setup).map_err(|e| words(&e))?;
    let svg = orch_stage::analysis::roll_svg(&song, robot, &played, setup.tempo, name)
        .map_err(|e| words(&e))?;
    let text = orch_stage::text::analysis(&analysis, std::path::Path::new(name));
    let json = analysis.json().map_err(|e| e.to_string())?;
    Ok(Analysis {
        song,
        json,
        text,
        svg,
    })
}

/// An error and its causes, as `orch` prints them (`what: why: why`).
pub fn words(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        s += &format!(": {c}");
        cause = c.source();
    }
    s
}

/// What `orch serve` serves.
pub struct Config {
    /// The robot (robot.toml, or the thesis's).
    pub robot: Robot,
    /// How it plays (its configuration, the virtual robot's figures, compensation); its tempo
    /// is the factor a play starts at until the page sets one.
    pub setup: Setup,
    /// The outputs: one robot each (the virtual robot alone when there is just `sim`).
    pub outs: Vec<OutSpec>,
    /// Whether outputs were named (`--out`): then the report at the end says where each
    /// robot played, as `orch play`'s does.
    pub named: bool,
    /// The folder of songs to pick from (`.mid` and `.midi` files in it), if any.
    pub library: Option<PathBuf>,
    /// Who may come in (the address listened on, the token).
    pub access: Access,
    /// A shared session the page shows and steers (`orch serve --link`), if any.
    pub session: Option<Arc<dyn Session>>,
}

/// Why the server could not run, or start.
#[derive(Debug)]
pub enum ServeError {
    /// Bad input from the user, said in words: a library that is not a folder.
    BadInput(String),
    /// An output that cannot be opened (checked at start, see [`check`]).
    Output(orch_stage::LiveError),
    /// Serving failed (the listener).
    Io(std::io::Error),
}

impl ServeError {
    /// Whether the user's input is at fault (a library, an output as given).
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            ServeError::BadInput(_) | ServeError::Output(orch_stage::LiveError::BadInput(_))
        )
    }
}

impl std::fmt::Display for ServeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ServeError::BadInput(m) => f.write_str(m),
            ServeError::Output(e) => write!(f, "{e}"),
            ServeError::Io(e) => write!(f, "serving the page: {e}"),
        }
    }
}

impl std::error::Error for ServeError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ServeError::BadInput(_) => None,
            // The output's error says itself: what is behind it, as it says it.
            ServeError::Output(e) => e.source(),
            ServeError::Io(e) => Some(e),
        }
    }
}

/// What can be checked before serving, so that it is said at start and not at the first
/// play: every output opened once (for `setup`) and let go, and the library (if any) a
/// folder.
pub fn check(setup: &Setup, outs: &[OutSpec], library: Option<&Path>) -> Result<(), ServeError> {
    drop(orch_stage::session::open_lanes(outs.to_vec(), setup).map_err(ServeError::Output)?);
    if let Some(dir) = library {
        if !dir.is_dir() {
            return Err(ServeError::BadInput(format!(
                "--library {}: not a folder",
                dir.display()
            )));
        }
    }
    Ok(())
}

/// Resolves once `flag` is set (by a signal: [`orch_stage::signals::stop_flag`]): a
/// shutdown for [`serve`], looked at every 50 ms.
pub async fn until_set(flag: Arc<AtomicBool>) {
    while !flag.load(Ordering::SeqCst) {
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// Serves the page and its API on `listener` (bound by the caller, at `config.access`'s
/// address) until `shutdown` resolves; then stops any performance, every key released, and
/// waits for it to end.
pub async fn serve(
    listener: tokio::net::TcpListener,
    config: Config,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> Result<(), ServeError> {
    let players = player::Player::new(config);
    let router = api::router(Arc::clone(&players));
    // On shutdown: every viewer let go (their WebSockets would keep the server waiting) and
    // any performance stopped, every key released, before the last connections are waited
    // for.
    let p = Arc::clone(&players);
    let shutdown = async move {
        shutdown.await;
        let _ = tokio::task::spawn_blocking(move || p.shut_down()).await;
    };
    axum::serve(
        listener,
        router.into_make_service_with_connect_info::<SocketAddr>(),
    )
    .with_graceful_shutdown(shutdown)
    .await
    .map_err(ServeError::Io)
}
