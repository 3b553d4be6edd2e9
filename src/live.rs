//! The terminal's live performance (`orch play`, `orch conduct`): the session played to its
//! end by `orch_stage::watch` while this thread shows the view, takes its keys (`q`, the jump
//! keys, a conductor's taps) and the signals that stop it; and the logging of the live
//! commands.

use std::io::IsTerminal;
use std::path::Path;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Duration;

use orch_perform::Control;
use orch_seq::Song;
use orch_stage::bars;
use orch_stage::conductor::Conducting;
use orch_stage::session::{Ended, Lane, Session, SessionFailure};
use orch_stage::watch::{self, WatchError};

use crate::view::{Key, Scene, View};

/// How a live performance is shown and steered.
pub(crate) struct LiveOptions<'a> {
    /// The command that runs, for the view's head.
    pub command: &'static str,
    /// `--from`: start at this score time (µs), a jump before the first note.
    pub from_us: Option<u64>,
    /// The live view, if standard output is a terminal.
    pub view: bool,
    /// The file played (its name is the view's title).
    pub file: &'a Path,
    /// A conductor (`orch conduct`), steering the performance through its own control; the
    /// view shows its line under its head, and gives it the keys pressed (other than the jump
    /// keys, q and Esc: taps, for a tap source).
    pub conductor: Option<&'a Conducting>,
    /// A control steered from elsewhere (an Ableton Link session), and its clock's zero.
    pub steered: Option<(Arc<Control>, std::time::Instant)>,
}

/// Logging through `tracing` on standard error: warnings (a device or a board lost, and back),
/// everything the outputs do with `--verbose`.
pub(crate) fn init_logging(verbose: bool) {
    let level = if verbose {
        tracing::Level::DEBUG
    } else {
        tracing::Level::WARN
    };
    let _ = tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_max_level(level)
        .with_target(false)
        .try_init();
}

/// Plays in real time: one sender thread per robot (real-time priority where allowed), all on
/// one clock, the view on this thread. `q`, SIGINT, SIGTERM and SIGHUP stop every robot with
/// every key released, and the reports still come; so does a panic, on any thread.
pub(crate) fn play_live(
    song: Song,
    lanes: Vec<Lane>,
    options: LiveOptions<'_>,
) -> anyhow::Result<Vec<Ended>> {
    let from_us = options.from_us;
    let (control, origin) = match (&options.conductor, options.steered.clone()) {
        (Some(c), _) => (Arc::clone(&c.control), c.origin),
        (None, Some(steered)) => steered,
        (None, None) => (Control::new(), std::time::Instant::now()),
    };
    let mut terminal = Terminal::new(options);
    let watched = watch::play(song, lanes, control, origin, from_us, |s| terminal.watch(s));
    // The terminal is given back before anything is said.
    drop(terminal);
    ended(watched.priority_refused, watched.result)
}

/// Says (on standard error) that real-time priority was refused, if it was, and gives every
/// robot's end, or the error of a performance that failed in the binary's words (a panic goes
/// on).
pub(crate) fn ended(
    priority_refused: bool,
    result: Result<Vec<Ended>, WatchError<anyhow::Error>>,
) -> anyhow::Result<Vec<Ended>> {
    note_priority(priority_refused);
    result.map_err(failed)
}

/// Says (on standard error) that real-time priority was refused, if it was.
pub(crate) fn note_priority(refused: bool) {
    if refused {
        eprintln!(
            "orch: note: the OS refused real-time priority to the sender; under load its \
             messages may be late (see lateness in the report)"
        );
    }
}

/// A live performance's failure in the binary's words (a panic goes on).
pub(crate) fn failed(e: WatchError<anyhow::Error>) -> anyhow::Error {
    match e {
        WatchError::Panicked(panic) => std::panic::resume_unwind(panic),
        WatchError::Front(e) => e,
        WatchError::Failed(spec, SessionFailure::Performance(e)) => {
            anyhow::Error::new(e).context(format!("--out {}", spec.text))
        }
        WatchError::Failed(spec, SessionFailure::Panicked) => anyhow::anyhow!(
            "the sender thread of --out {} panicked (its keys were released)",
            spec.text
        ),
    }
}

/// The terminal watching a live performance: the view (if shown), the keys, the signals
/// that stop it. Dropping it gives the terminal back.
pub(crate) struct Terminal<'a> {
    command: &'static str,
    show: bool,
    title: String,
    conductor: Option<&'a Conducting>,
    /// SIGINT, SIGTERM and SIGHUP, once the performance has begun.
    signalled: Option<Arc<std::sync::atomic::AtomicBool>>,
    view: Option<View>,
    /// The bar being typed.
    typed: bars::Typed,
    /// The bar playing (for `[` and `]`).
    bar_now: u32,
}

impl<'a> Terminal<'a> {
    pub(crate) fn new(options: LiveOptions<'a>) -> Self {
        let title = options
            .file
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        Self {
            command: options.command,
            show: options.view && std::io::stdout().is_terminal(),
            title,
            conductor: options.conductor,
            signalled: None,
            view: None,
            typed: bars::Typed::default(),
            bar_now: 1,
        }
    }

    /// Looks once: stops every robot on a signal or `q`, takes the keys, draws the view.
    pub(crate) fn watch(&mut self, session: &Session) -> anyhow::Result<()> {
        let control = session.control();
        // SIGINT, SIGTERM and SIGHUP stop the way `q` does.
        let signalled = match &self.signalled {
            Some(s) => s,
            None => self.signalled.insert(orch_stage::signals::stop_flag()?),
        };
        if signalled.load(Ordering::SeqCst) {
            control.stop();
        }
        if !self.show {
            std::thread::sleep(Duration::from_millis(20));
            return Ok(());
        }
        if self.view.is_none() {
            self.view = Some(View::start()?);
        }
        let (typed, bar_now, conductor) = (&mut self.typed, self.bar_now, self.conductor);
        // The jump keys: digits and Enter go to the bar typed (Backspace takes a digit back),
        // `[` to the bar before the one playing, `]` to the next.
        let mut on_key = |key: Key| {
            let song = session.song();
            let jump = match key {
                Key::Char(c @ '0'..='9') => {
                    typed.digit(c);
                    None
                }
                Key::Backspace => {
                    typed.back();
                    None
                }
                Key::Enter => typed.enter(song),
                Key::Char('[') => bars::before(song, bar_now),
                Key::Char(']') => bars::after(song, bar_now),
                Key::Char(c) => {
                    if let Some(k) = conductor.filter(|_| c != 'q') {
                        k.tap();
                    }
                    None
                }
            };
            if let Some(t) = jump {
                control.jump_to(t);
            }
        };
        // Drawn every 20 ms; a key is taken as it comes.
        if crate::view::keys(Some(&mut on_key), Duration::from_millis(20)) {
            control.stop();
        }
        let Some(snapshot) = session.snapshot() else {
            return Ok(());
        };
        self.bar_now = snapshot.bar;
        let scene = Scene {
            command: self.command,
            title: self.title.clone(),
            now: snapshot,
            conductor: self.conductor.map(Conducting::line),
            prompt: self.typed.shown().map(str::to_string),
        };
        Ok(self.view.as_mut().expect("started").draw(&scene)?)
    }
}
