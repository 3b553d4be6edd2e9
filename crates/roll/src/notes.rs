//! The notes: for each, one `<g class="note OUTCOME">` holding its hover text, its score
//! outline, its strike's fill and its mark.

use crate::colour::{self, note_name};
use crate::layout::Layout;
use crate::model::{Outcome, Roll, RollNote};
use crate::svg::{a, num, Writer};

/// The narrowest a note is drawn, px (a zero-length note stays visible).
const MIN_PX: f64 = 1.5;
/// How wide a hit's outline is drawn, px (a drum's or a bar's note: its length means nothing).
const HIT_PX: f64 = 3.0;

/// Draws every note.
pub fn notes(w: &mut Writer, roll: &Roll, l: &Layout) {
    w.open("g", &[a("class", "notes")]);
    for (i, n) in roll.notes.iter().enumerate() {
        note(w, roll, l, i, n);
    }
    w.close("g");
}

fn note(w: &mut Writer, roll: &Roll, l: &Layout, i: usize, n: &RollNote) {
    let late_ms = match n.outcome {
        Outcome::Late => n.strike.map(|s| s.onset_ms),
        _ => None,
    };
    let colour = colour::of(&n.outcome, late_ms);
    let ghost = matches!(n.outcome, Outcome::Dropped(_) | Outcome::Skipped);
    let mut class = format!("note {}", n.outcome.name());
    if ghost {
        class.push_str(" ghost");
    }
    let mut attrs = vec![
        a("class", class),
        a("id", format!("note-{i}")),
        a("data-note", n.note),
        a("data-bar", n.bar),
        a("data-beat", n.beat),
        a("data-channel", n.channel),
        a("data-outcome", n.outcome.name()),
        a("data-t-ms", num(n.t_ms)),
    ];
    if let Some(r) = n.outcome.reason() {
        attrs.push(a("data-reason", r));
    }
    if let Some(s) = n.strike {
        attrs.push(a("data-onset-ms", num(s.onset_ms)));
    }
    if ghost {
        attrs.push(a("opacity", "0.75"));
    }
    w.open("g", &attrs);
    w.text("title", &[], &hover(n, roll.dynamics));
    if let Some(s) = n.strike {
        strike(w, roll, l, n, &colour, &s);
    }
    outline(w, l, n, &colour, ghost);
    mark(w, l, n, &colour);
    w.close("g");
}

/// The hover text: name, bar:beat, outcome, times.
fn hover(n: &RollNote, dynamics: bool) -> String {
    let what = match (&n.outcome, n.strike) {
        (Outcome::OnTime, _) => "on time".to_string(),
        (Outcome::Late, Some(s)) => format!("late by {} ms", num(s.onset_ms)),
        (Outcome::Early, Some(s)) => format!("early by {} ms", num(-s.onset_ms)),
        (Outcome::Unison, _) => "unison: struck with another note on its key".into(),
        (Outcome::Joined, _) => "joined: its key was already down for another note".into(),
        (Outcome::Dropped(r), _) => format!("dropped ({r}): {}", colour::reason(r)),
        (Outcome::Unmatched, _) => "struck, but made no sound".into(),
        (Outcome::Skipped, _) => "skipped: the performance jumped past it".into(),
        (o, None) => o.name().to_string(),
    };
    let mut t = format!(
        "{} ({}), channel {}, bar {}:{}: {what}; score {}–{} ms",
        note_name(n.note),
        n.note,
        n.channel,
        n.bar,
        n.beat,
        num(n.t_ms),
        num(n.end_ms)
    );
    if let Some(s) = n.strike {
        t.push_str(&format!(
            ", sounded {} ms (onset {:+.1} ms), key up {} ms",
            num(s.sounded_ms),
            s.onset_ms,
            num(s.up_ms)
        ));
    }
    if let Some(k) = n.landed.filter(|k| *k != n.note) {
        t.push_str(&format!(", on key {} (folded)", note_name(k)));
    }
    t.push_str(&format!(", velocity {}", n.velocity));
    if let (true, Some(v)) = (dynamics, n.strike.and_then(|s| s.velocity)) {
        t.push_str(&format!(", sounded as {v}"));
    }
    t
}

fn strike(w: &mut Writer, roll: &Roll, l: &Layout, n: &RollNote, colour: &str, s: &crate::Strike) {
    let key = n.landed.unwrap_or(n.note);
    // Loudness as opacity where the robot plays velocity; solid otherwise.
    let opacity = match (roll.dynamics, s.velocity) {
        (true, Some(v)) => 0.2 + 0.8 * f64::from(v.min(127)) / 127.0,
        _ => 0.85,
    };
    for (row, from, to) in l.pieces(s.sounded_ms, s.up_ms.max(s.sounded_ms)) {
        let x = l.x(row, from);
        let width = ((to - from) * l.px_per_ms).max(MIN_PX);
        let (y, h) = l.band(row, n, true);
        w.empty(
            "rect",
            &[
                a("class", "strike"),
                a("x", num(x)),
                a("y", num(y + h * 0.2)),
                a("width", num(width)),
                a("height", num(h * 0.6)),
                a("fill", colour),
                a("fill-opacity", format!("{opacity:.2}")),
            ],
        );
    }
    if key != n.note && n.lane.is_none() {
        // A folded note: a thin line from the written note to its key.
        if let Some((row, from, _)) = l.pieces(n.t_ms, n.t_ms).into_iter().next() {
            let x = l.x(row, from);
            w.empty(
                "line",
                &[
                    a("class", "fold"),
                    a("x1", num(x)),
                    a("y1", num(l.y(row, n.note) + l.semitone / 2.0)),
                    a("x2", num(x)),
                    a("y2", num(l.y(row, key) + l.semitone / 2.0)),
                    a("stroke", colour),
                    a("stroke-width", "0.6"),
                    a("stroke-dasharray", "2 2"),
                ],
            );
        }
    }
}

fn outline(w: &mut Writer, l: &Layout, n: &RollNote, colour: &str, ghost: bool) {
    let dash = match n.outcome {
        Outcome::Dropped(_) => Some("3 2"),
        Outcome::Joined => Some("2 1"),
        Outcome::Skipped => Some("1 2"),
        _ => None,
    };
    // A hit (a drum, a bar) is drawn at its start, whatever its Note-Off says.
    let end_ms = if n.hit { n.t_ms } else { n.end_ms.max(n.t_ms) };
    for (row, from, to) in l.pieces(n.t_ms, end_ms) {
        let (y, h) = l.band(row, n, false);
        let mut attrs = vec![
            a("class", if n.hit { "score hit" } else { "score" }),
            a("x", num(l.x(row, from))),
            a("y", num(y + 0.5)),
            a(
                "width",
                num(((to - from) * l.px_per_ms).max(if n.hit { HIT_PX } else { MIN_PX })),
            ),
            a("height", num(h - 1.0)),
            a("fill", if ghost { colour } else { "none" }),
        ];
        if ghost {
            attrs.push(a("fill-opacity", "0.15"));
        }
        attrs.push(a("stroke", colour));
        attrs.push(a("stroke-width", "1"));
        if let Some(d) = dash {
            attrs.push(a("stroke-dasharray", d));
        }
        w.empty("rect", &attrs);
    }
}

/// A mark at the note's start for what has no strike of its own: a ring for a unison, a
/// wedge for a joined note, a cross for a dropped or silent one.
fn mark(w: &mut Writer, l: &Layout, n: &RollNote, colour: &str) {
    let Some((row, from, _)) = l.pieces(n.t_ms, n.t_ms).into_iter().next() else {
        return;
    };
    let x = l.x(row, from);
    let (y, h) = l.band(row, n, false);
    let ym = y + h / 2.0;
    let r = (l.semitone * 0.6).max(2.5);
    match n.outcome {
        Outcome::Unison => w.empty(
            "circle",
            &[
                a("class", "mark"),
                a("cx", num(x)),
                a("cy", num(ym)),
                a("r", num(r)),
                a("fill", "#ffffff"),
                a("stroke", colour),
                a("stroke-width", "1.2"),
            ],
        ),
        Outcome::Joined => w.empty(
            "path",
            &[
                a("class", "mark"),
                a(
                    "d",
                    format!(
                        "M{} {}l{} {}v{}z",
                        num(x),
                        num(ym),
                        num(-r * 1.4),
                        num(-r),
                        num(2.0 * r)
                    ),
                ),
                a("fill", colour),
            ],
        ),
        Outcome::Dropped(_) | Outcome::Unmatched => w.empty(
            "path",
            &[
                a("class", "mark"),
                a(
                    "d",
                    format!(
                        "M{} {}l{} {}M{} {}l{} {}",
                        num(x - r),
                        num(ym - r),
                        num(2.0 * r),
                        num(2.0 * r),
                        num(x - r),
                        num(ym + r),
                        num(2.0 * r),
                        num(-2.0 * r)
                    ),
                ),
                a(
                    "stroke",
                    if n.outcome == Outcome::Unmatched {
                        colour
                    } else {
                        "#b2182b"
                    },
                ),
                a("stroke-width", "1.3"),
            ],
        ),
        _ => {}
    }
}
