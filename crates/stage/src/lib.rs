//! # orch-stage: one live session of orch
//!
//! What every front end of orch drives and watches while a robot plays: the terminal
//! (`orch play`, `orch analyze`, `orch conduct`, `orch run`, `orch decode`,
//! `orch interpret`), a daemon, a web page. The front end parses its arguments, prints and
//! draws; everything else lives here, so that a second front end says and does exactly what
//! the first does.
//!
//! ```
//! use orch_stage::play::Play;
//!
//! let song = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/ode-to-joy.mid");
//! let song = std::path::Path::new(song);
//! // The thesis's robot, on the virtual clock (as fast as the machine goes); without
//! // `.fast(true)` it plays live, and `.watch(..)` looks on.
//! let performed = Play::file(song).fast(true).run()?;
//! print!("{}", orch_stage::text::reports(&performed.reports(), song));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! A song and a robot:
//!
//! - [`load`]: a Standard MIDI File read and checked ([`load_song`]: its first bytes before
//!   the rest, its size capped) and the robot ([`load_robot`]: robot.toml, or the thesis's;
//!   [`load::load_robot_text`] with its text, for a calibrated copy).
//! - [`setup`]: how a robot plays (the performance's `Setup`), the tempo factors allowed,
//!   and a performance on the virtual clock, as fast as the machine goes.
//! - [`bars`]: bars as people count them, where each begins (for a jump there), and a bar
//!   typed a digit at a time.
//! - [`signals`]: SIGINT, SIGTERM and SIGHUP as a flag that stops a live front end, and the
//!   signals as the live robot's loop events (SIGHUP reads the robot again, SIGUSR1 asks for
//!   the counters).
//!
//! Playing it, live or on the virtual clock:
//!
//! - [`play`]: the one builder a front end needs ([`play::Play`]): told once the file, the
//!   robot, the outputs, the tempo, the bar, the virtual or the real clock, who watches and
//!   which files it leaves, it loads, sets up, plays and gives back every robot's end for the
//!   report. `orch play` is this builder with the terminal's view as its watcher.
//! - [`session`]: a song played live on one or more robots ([`session::Session`]: a sender
//!   thread a robot, one clock, one `Control` for stop, pause, jump, tempo and a conductor;
//!   jump to a bar, a checked tempo factor and tap tempo on the session itself),
//!   a [`session::Snapshot`] of where it stands for any front end, every robot's report and
//!   note-by-note account at the end; [`watch`]: a session played to its end with a front
//!   end watching on its own thread (every robot stopped if it fails or panics).
//! - [`sources`]: the conductor's tempo sources (a baton video or camera, tap tempo, MIDI
//!   clock from a byte stream or UDP, OSC over UDP), parsed from a `--source` text
//!   ([`sources::SourceSpec`]), opened ([`sources::open_source`]) and followed
//!   ([`sources::follow`]: each cue to the follower, its answer to the performance's
//!   `Control`, and the follower woken between cues when it asks), with what the conductor
//!   did ([`sources::Status`]); [`conductor`]: a source opened and followed on a thread of
//!   its own ([`conductor::Conducting`]: for a song, with its taps and its status line).
//! - [`live`]: the live interpreter ([`LiveRobot`]): live MIDI bytes in, orch-core's
//!   interpreter and guard, finger boards out (the virtual robot, or boards on a Linux I2C
//!   bus), the stream passed on ([`thru`], re-framed by [`framer`]), a robot read again
//!   swapped in when every key is up; every board write shown to whoever watches
//!   ([`BoardWrite`]); [`run`]: its loop (input events and a front end's requests in, what
//!   happened out, the guard's deadlines kept).
//!
//! Raw MIDI bytes, off line:
//!
//! - [`bytes`]: bytes from a reader as they arrive, raw or hex text ([`hex`]), in bounded
//!   memory.
//! - [`messages`]: the decoded messages as text (as `aseqdump`) or JSON (as mido), with the
//!   decoder's counters; [`interpret`]: bytes through the interpreter and the guard at DIN
//!   wire speed, every board write ([`writes`]: as text or JSON) and the boards' end state.
//!
//! What a performance leaves:
//!
//! - [`report`]: every robot's report ([`Reports`], JSON through serde), and [`text`]: the
//!   reports and the analysis as people read them, exactly as `orch play` and `orch analyze`
//!   print them.
//! - [`analysis`]: whether a robot can play a song and what will go wrong, without playing
//!   it live ([`analyze`] gives an [`Analysis`]: the report, the notes that will go wrong,
//!   the [`findings`] in words; the piano roll as SVG).
//! - [`account`]: the note-by-note account and the board writes, a JSON line each; each
//!   note's bar and beat its own whatever the tempo did ([`places`]).
//!
//! Errors ([`error`]) are [`StageError`] (a song, a bar, a tempo, a performance),
//! [`SourceError`] (a tempo source: bad input, named, or the I/O failure behind it),
//! [`LiveError`] (the live loop), and the readers' own ([`bytes::ReadError`],
//! [`hex::HexError`]); each says whether the user's input is at fault.
//!
//! ## Cargo features
//!
//! - `camera` (off by default): a live camera (V4L2) as a tempo source, through `orch-baton`'s
//!   own `camera` feature (building it needs libclang). Without it a camera source is refused,
//!   saying how to build with it.

pub mod account;
pub mod analysis;
pub mod bars;
pub mod bytes;
pub mod conductor;
pub mod error;
pub mod findings;
pub mod framer;
pub mod hex;
pub mod interpret;
pub mod live;
pub mod load;
pub mod messages;
pub mod places;
pub mod play;
pub mod report;
pub mod run;
pub mod session;
pub mod setup;
pub mod signals;
pub mod sources;
pub mod text;
pub mod thru;
pub mod watch;
pub mod writes;

pub use analysis::{analyze, Analysis, Wrong};
pub use error::{LiveError, SourceError, StageError};
pub use live::{BoardWrite, LiveBoards, LiveRobot, ReloadRefused, Totals};
pub use load::{load_robot, load_song};
pub use report::{LinkFigures, Reports, RobotReport};
