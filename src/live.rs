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
    let LiveOptions {
        command,
        from_us,
        view: show,
        file,
        conductor,
        steered,
    } = options;
    // SIGINT, SIGTERM and SIGHUP stop the way `q` does.
    let signalled = orch_stage::signals::stop_flag()?;
    let show = show && std::io::stdout().is_terminal();
    let title = file
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let (control, origin) = match (&conductor, steered) {
        (Some(c), _) => (Arc::clone(&c.control), c.origin),
        (None, Some(steered)) => steered,
        (None, None) => (Control::new(), std::time::Instant::now()),
    };
    let mut view = None;
    // The bar being typed, and the bar playing (for `[` and `]`).
    let mut typed = bars::Typed::default();
    let mut bar_now = 1;
    let watch = |session: &Session| -> anyhow::Result<()> {
        let control = session.control();
        if signalled.load(Ordering::SeqCst) {
            control.stop();
        }
        if !show {
            std::thread::sleep(Duration::from_millis(20));
            return Ok(());
        }
        if view.is_none() {
            view = Some(View::start()?);
        }
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
        bar_now = snapshot.bar;
        let scene = Scene {
            command,
            title: title.clone(),
            now: snapshot,
            conductor: conductor.map(Conducting::line),
            prompt: typed.shown().map(str::to_string),
        };
        Ok(view.as_mut().expect("started").draw(&scene)?)
    };
    let watched = watch::play(song, lanes, control, origin, from_us, watch);
    // The terminal is given back before anything is said.
    drop(view);
    if watched.priority_refused {
        eprintln!(
            "orch: note: the OS refused real-time priority to the sender; under load its \
             messages may be late (see lateness in the report)"
        );
    }
    watched.result.map_err(|e| match e {
        WatchError::Panicked(panic) => std::panic::resume_unwind(panic),
        WatchError::Front(e) => e,
        WatchError::Failed(spec, SessionFailure::Performance(e)) => {
            anyhow::Error::new(e).context(format!("--out {}", spec.text))
        }
        WatchError::Failed(spec, SessionFailure::Panicked) => anyhow::anyhow!(
            "the sender thread of --out {} panicked (its keys were released)",
            spec.text
        ),
    })
}
