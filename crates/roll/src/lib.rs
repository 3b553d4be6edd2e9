//! # orch-roll: pictures of a performance
//!
//! A piano roll of one performance, as SVG text: pitch against time, the score's notes as
//! outlines and the robot's strikes as fills, coloured by outcome. `orch analyze FILE --svg
//! roll.svg` writes it; a web page can serve the same text.
//!
//! - **Input**: a [`Roll`], plain data: the note-by-note account's notes (each with its
//!   Note-Off and its strike), the bar lines, the robot's key range, whether it plays
//!   velocity. [`build::roll`] makes one from a song and its performance on the virtual
//!   robot.
//! - **Output**: [`render`] returns the SVG document (UTF-8, one element a line, numbers to a
//!   tenth of a pixel: the same roll is always the same text).
//!
//! ## What is drawn
//!
//! - **Pitch** bottom to top, one lane a semitone, black keys striped, every C named (C4 =
//!   60) and each octave ruled; the robot's keys shaded blue, with a blue bar on the axis.
//! - **Time** left to right at [`Options::px_per_s`] (80 px a second). A long piece is folded
//!   into rows of at most [`Options::max_row_px`] (1 600 px, 20 s), each ending at a bar line
//!   where one fits, like the systems of a score: the drawing's width stays bounded however
//!   long the piece, and its height grows by a row (about 420 px for 61 keys) every 20 s.
//!   Each row says when it begins (m:ss).
//! - **Bar lines** with their numbers (every bar, or every 2, 4, 5, 10… when bars are narrow,
//!   and always a row's first).
//! - **Notes**: the score's note as an outline at the pitch written, from its score time to
//!   its Note-Off; the robot's own strike as a fill at the key it landed on (a folded note
//!   lands octaves away: a dashed line joins the two), from when it sounded to when its key
//!   was fully up. Colour by outcome: on time green, late shaded amber (just over 1 ms) to
//!   dark red (30 ms or more), early purple, unison blue with a ring, joined teal, dotted,
//!   with a wedge, dropped grey **ghosts** (dashed, faint) with a red cross, a strike with no
//!   sound magenta with a cross, skipped light grey, dotted. Where the robot plays velocity,
//!   a strike's fill opacity is its loudness (velocity 1 faint, 127 solid).
//! - **Hover**: every note has a `<title>`: its name and number, channel, bar:beat,
//!   outcome (a drop's reason in the account's word and in words), score times, when it
//!   sounded and how late, the key it folded to, velocity asked and heard.
//! - **Legend**: each outcome's colour and count, the late shading, the keys, what outline
//!   and fill mean, and loudness where the robot has dynamics.
//!
//! ## Hooks for pages and tests
//!
//! Each note is one `<g class="note OUTCOME" id="note-I">` (`I` its place in the account;
//! dropped and skipped notes also `ghost`) with `data-note`, `data-bar`, `data-beat`,
//! `data-channel`, `data-outcome`, `data-t-ms`, `data-reason` (dropped) and `data-onset-ms`
//! (struck); inside it, `rect.score` (the outline, one a row it crosses), `rect.strike`
//! (the fill), `line.fold`, and `.mark`. Rows are `g.row` (`data-row`, `data-from-ms`,
//! `data-to-ms`), bar lines `g.bar` (`data-bar`), the key range `rect.keys` (`data-low`,
//! `data-high`: MIDI notes), the rows' start times `text.time`, the legend's entries `g.legend-item` (`data-outcome`,
//! `data-count`). Colours are presentation attributes, so the file looks the same with no
//! style sheet (a viewer, `rsvg-convert`); a page may restyle by class.
//!
//! ## Why SVG is written directly
//!
//! The drawing needs seven kinds of element (`svg`, `g`, `rect`, `line`, `path`, `circle`,
//! `text`/`title`); [`svg`]'s writer streams them into one string in about 100 lines, its
//! escaping tested, numbers to a fixed tenth, attributes in the order written (class and
//! `data-` first, where a reader looks), so golden files stay byte-stable and readable, and
//! there is no dependency to keep up. The `svg` crate (0.17, well kept) builds a tree of
//! boxed nodes with attributes in a hash map, sorted by name on output, and writes numbers
//! as `f64`'s `Display` gives them: the rounding would be ours anyway, for a tree we do not
//! need.
//!
//! ```
//! use orch_roll::{render, BarLine, Options, Outcome, Roll, RollNote, Strike};
//!
//! let roll = Roll {
//!     title: "one note".into(),
//!     notes: vec![RollNote {
//!         t_ms: 0.0, end_ms: 500.0, bar: 1, beat: 1, note: 60, channel: 1, velocity: 100,
//!         landed: Some(60), outcome: Outcome::Late,
//!         strike: Some(Strike { sounded_ms: 12.0, up_ms: 530.0, onset_ms: 12.0, velocity: Some(127) }),
//!         lane: None, hit: false,
//!     }],
//!     bars: vec![BarLine { bar: 1, t_ms: 0.0 }],
//!     end_ms: 2000.0,
//!     keys: Some((36, 96)),
//!     dynamics: false,
//!     lanes: Vec::new(),
//!     pitched: true,
//! };
//! let svg = render(&roll, &Options::default());
//! assert!(svg.contains(r#"class="note late""#));
//! assert!(svg.contains("late by 12.0 ms"));
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod build;
mod colour;
mod grid;
mod layout;
mod legend;
mod model;
mod notes;
pub mod svg;

pub use colour::{late as late_colour, note_name, LATE_FULL_MS};
pub use layout::Options;
pub use model::{BarLine, Outcome, Roll, RollNote, Strike};

/// The roll as an SVG document.
pub fn render(roll: &Roll, opts: &Options) -> String {
    let l = layout::Layout::new(roll, opts, legend::HEIGHT);
    let width = l.width.max(legend::MIN_WIDTH);
    let mut w = svg::Writer::default();
    w.raw("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    w.open(
        "svg",
        &[
            svg::a("xmlns", "http://www.w3.org/2000/svg"),
            svg::a("class", "orch-roll"),
            svg::a("width", svg::num(width)),
            svg::a("height", svg::num(l.height)),
            svg::a(
                "viewBox",
                format!("0 0 {} {}", svg::num(width), svg::num(l.height)),
            ),
            svg::a("font-family", "sans-serif"),
            svg::a("font-size", "10"),
        ],
    );
    w.text("title", &[], &format!("Piano roll: {}", roll.title));
    w.empty(
        "rect",
        &[
            svg::a("class", "paper"),
            svg::a("width", svg::num(width)),
            svg::a("height", svg::num(l.height)),
            svg::a("fill", "#ffffff"),
        ],
    );
    legend::legend(&mut w, roll);
    grid::rows(&mut w, roll, &l);
    notes::notes(&mut w, roll, &l);
    w.close("svg");
    w.finish()
}
