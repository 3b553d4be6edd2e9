//! The live terminal view of `orch play`, `orch conduct` and `orch run`: the keyboard with
//! pressed keys lit, bar and beat, tempo, and progress.

use std::io;

use orch_roll::note_name;
use orch_stage::session::Snapshot;
use ratatui::layout::{Constraint, Layout};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Gauge, Paragraph};
use ratatui::{DefaultTerminal, Frame};

/// What the view shows at one moment.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// The command that runs, as its head says: `orch play`, `orch conduct`, `orch run`.
    pub command: &'static str,
    pub title: String,
    /// Where the performance stands: the keys down (from the lowest key's note), bar, beat,
    /// tempo, time and notes (`orch run`: the keys, the time and the notes sent).
    pub now: Snapshot,
    /// `orch conduct`: the conductor's beats and tempo, a line under the head.
    pub conductor: Option<String>,
    /// A bar being typed to jump to (digits, then Enter), shown at the end of the head.
    pub prompt: Option<String>,
}

fn is_black(note: u8) -> bool {
    matches!(note % 12, 1 | 3 | 6 | 8 | 10)
}

fn clock(s: f64) -> String {
    let s = s.max(0.0) as u64;
    format!("{}:{:02}", s / 60, s % 60)
}

/// The terminal, taken over for the view and given back on drop.
pub struct View {
    terminal: DefaultTerminal,
}

impl View {
    pub fn start() -> io::Result<Self> {
        Ok(Self {
            terminal: ratatui::try_init()?,
        })
    }

    pub fn draw(&mut self, scene: &Scene) -> io::Result<()> {
        self.terminal.draw(|f| render(f, scene))?;
        Ok(())
    }
}

/// Whether the person at the terminal asked to stop (q, Esc or Ctrl-C; the view's raw mode
/// turns Ctrl-C into a key press).
pub fn quit_requested() -> bool {
    keys(None, std::time::Duration::ZERO)
}

/// A key pressed in the view, other than those that stop it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Key {
    Char(char),
    Enter,
    Backspace,
}

/// Reads the keys pressed, waiting up to `wait` for the first (a key is taken the moment it
/// comes, so a tap's time is its own): whether one asks to stop (as [`quit_requested`]);
/// every other character key, Enter and Backspace go to `other` (the jump keys of a live
/// performance, the tap key of `orch conduct`).
pub fn keys(mut other: Option<&mut dyn FnMut(Key)>, mut wait: std::time::Duration) -> bool {
    use ratatui::crossterm::event::{self, Event, KeyCode, KeyEventKind, KeyModifiers};
    loop {
        let crossterm_wait = match terminal_input(wait) {
            Input::HungUp => return true,
            Input::Nothing => return false,
            Input::Ready => std::time::Duration::ZERO,
            Input::NotStdin => wait,
        };
        if !event::poll(crossterm_wait).unwrap_or(false) {
            return false;
        }
        wait = std::time::Duration::ZERO;
        if let Ok(Event::Key(k)) = event::read() {
            let ctrl_c =
                k.code == KeyCode::Char('c') && k.modifiers.contains(KeyModifiers::CONTROL);
            if ctrl_c || matches!(k.code, KeyCode::Char('q') | KeyCode::Esc) {
                return true;
            }
            let key = match k.code {
                KeyCode::Char(c) => Key::Char(c),
                KeyCode::Enter => Key::Enter,
                KeyCode::Backspace => Key::Backspace,
                _ => continue,
            };
            if let (Some(f), KeyEventKind::Press) = (other.as_deref_mut(), k.kind) {
                f(key);
            }
        }
    }
}

/// What the terminal has for the view.
enum Input {
    /// Bytes to read.
    Ready,
    /// Standard input is not the terminal (crossterm reads `/dev/tty` itself): no way to tell.
    NotStdin,
    /// Nothing within the wait.
    Nothing,
    /// The terminal has gone (its window closed, tmux killed, an ssh line dropped).
    HungUp,
}

/// Waits up to `wait` for the terminal on standard input. A terminal that hung up counts as a
/// request to stop: crossterm 0.28 would read its end forever (an EIO it retries without
/// end), so the view never hands a hung-up terminal to it.
fn terminal_input(wait: std::time::Duration) -> Input {
    use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
    use std::os::fd::AsFd;
    let stdin = io::stdin();
    if !std::io::IsTerminal::is_terminal(&stdin) {
        return Input::NotStdin;
    }
    let mut fds = [PollFd::new(stdin.as_fd(), PollFlags::POLLIN)];
    let ms = PollTimeout::try_from(wait).unwrap_or(PollTimeout::MAX);
    match poll(&mut fds, ms) {
        Ok(0) => Input::Nothing,
        Ok(_) => {
            let r = fds[0].revents().unwrap_or(PollFlags::empty());
            if r.intersects(PollFlags::POLLHUP | PollFlags::POLLERR | PollFlags::POLLNVAL) {
                Input::HungUp
            } else {
                Input::Ready
            }
        }
        Err(nix::errno::Errno::EINTR) => Input::Nothing,
        Err(_) => Input::HungUp,
    }
}

impl Drop for View {
    fn drop(&mut self) {
        ratatui::restore();
    }
}

fn render(f: &mut Frame, s: &Scene) {
    let n = &s.now;
    let [head, conductor, keys, down, gauge] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Length(u16::from(s.conductor.is_some())),
        Constraint::Length(5),
        Constraint::Length(1),
        Constraint::Length(1),
    ])
    .areas(f.area());
    let mut head_spans = vec![
        Span::styled(
            format!("{} ", s.command),
            Style::default().add_modifier(Modifier::BOLD),
        ),
        Span::raw(format!(
            "{}   bar {} beat {}   {:.1} bpm   notes {}/{}",
            s.title, n.bar, n.beat, n.bpm, n.notes_sent, n.notes
        )),
    ];
    if let Some(p) = &s.prompt {
        head_spans.push(Span::styled(
            format!("   go to bar {p}_"),
            Style::default().fg(Color::Yellow),
        ));
    }
    let head_line = Line::from(head_spans);
    f.render_widget(Paragraph::new(head_line), head);
    if let Some(c) = &s.conductor {
        f.render_widget(Paragraph::new(c.as_str()), conductor);
    }

    // One cell a key; pressed keys lit. Octave labels above.
    let mut labels = String::new();
    let mut cells = Vec::new();
    for (i, &is_down) in n.keys_down.iter().enumerate() {
        let note = n.low_note.saturating_add(i as u8);
        if note % 12 == 0 {
            let name = note_name(note);
            while labels.chars().count() < i {
                labels.push(' ');
            }
            labels.push_str(&name);
        }
        let style = match (is_down, is_black(note)) {
            (true, _) => Style::default().fg(Color::Black).bg(Color::Yellow),
            (false, true) => Style::default().fg(Color::DarkGray),
            (false, false) => Style::default().fg(Color::White),
        };
        let glyph = if is_down {
            "#"
        } else if is_black(note) {
            "|"
        } else {
            "'"
        };
        cells.push(Span::styled(glyph, style));
    }
    let board = Paragraph::new(vec![Line::raw(labels), Line::from(cells)]).block(
        Block::default()
            .borders(Borders::ALL)
            .title(format!(" {} keys ", n.keys_down.len())),
    );
    f.render_widget(board, keys);

    let names: Vec<String> = n
        .keys_down
        .iter()
        .enumerate()
        .filter(|(_, d)| **d)
        .map(|(i, _)| note_name(n.low_note.saturating_add(i as u8)))
        .collect();
    f.render_widget(Paragraph::new(format!("down: {}", names.join(" "))), down);

    let ratio = if n.total_s > 0.0 {
        (n.elapsed_s / n.total_s).clamp(0.0, 1.0)
    } else {
        1.0
    };
    let gauge_widget = Gauge::default()
        .gauge_style(Style::default().fg(Color::Cyan))
        .ratio(ratio)
        .label(format!("{} / {}", clock(n.elapsed_s), clock(n.total_s)));
    f.render_widget(gauge_widget, gauge);
}

#[cfg(test)]
mod tests {
    use super::*;
    use ratatui::backend::TestBackend;
    use ratatui::Terminal;

    #[test]
    fn pressed_keys_are_lit_and_named() {
        let mut t = Terminal::new(TestBackend::new(80, 8)).unwrap();
        let mut down = vec![false; 61];
        down[24] = true;
        down[28] = true;
        let scene = Scene {
            command: "orch conduct",
            title: "t.mid".into(),
            now: Snapshot {
                low_note: 36,
                keys_down: down,
                bar: 3,
                beat: 2,
                bpm: 120.0,
                elapsed_s: 61.0,
                total_s: 122.0,
                notes_sent: 5,
                notes: 10,
                ..Snapshot::default()
            },
            conductor: Some("conductor: beat 7, 96.0 BPM".into()),
            prompt: Some("12".into()),
        };
        t.draw(|f| render(f, &scene)).unwrap();
        let text: String = t
            .backend()
            .buffer()
            .content()
            .iter()
            .map(|c| c.symbol())
            .collect();
        assert!(text.contains("orch conduct t.mid"), "{text}");
        assert!(text.contains("go to bar 12_"), "{text}");
        assert!(text.contains("bar 3 beat 2"), "{text}");
        assert!(text.contains("conductor: beat 7, 96.0 BPM"), "{text}");
        assert!(text.contains("down: C4 E4"), "{text}");
        assert!(text.contains("1:01 / 2:02"), "{text}");
        assert_eq!(note_name(36), "C2");
    }
}
