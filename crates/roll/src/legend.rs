//! The legend above the rows: each outcome's colour and count, the late shading, the robot's
//! keys, and what outline and fill mean.

use crate::colour::{self, note_name, LATE_FULL_MS};
use crate::model::{Outcome, Roll};
use crate::svg::{a, num, Writer};

/// Height of the title and legend, px.
pub const HEIGHT: f64 = 78.0;
/// The narrowest drawing that holds the legend, px.
pub const MIN_WIDTH: f64 = 900.0;

/// A rough width of `text` at 10 px sans-serif.
fn text_px(text: &str) -> f64 {
    text.chars().count() as f64 * 5.6
}

fn swatch(w: &mut Writer, x: f64, y: f64, fill: &str, stroke: &str, dash: Option<&str>) {
    let mut attrs = vec![
        a("x", num(x)),
        a("y", num(y - 8.0)),
        a("width", "16"),
        a("height", "8"),
        a("fill", fill),
        a("stroke", stroke),
        a("stroke-width", "1"),
    ];
    if let Some(d) = dash {
        attrs.push(a("stroke-dasharray", d));
    }
    w.empty("rect", &attrs);
}

fn label(w: &mut Writer, x: f64, y: f64, text: &str) -> f64 {
    w.text(
        "text",
        &[a("x", num(x)), a("y", num(y)), a("fill", "#222222")],
        text,
    );
    x + text_px(text)
}

/// Draws the title and legend.
pub fn legend(w: &mut Writer, roll: &Roll) {
    w.text(
        "text",
        &[
            a("class", "title"),
            a("x", "8"),
            a("y", "16"),
            a("font-size", "13"),
            a("font-weight", "bold"),
            a("fill", "#111111"),
        ],
        &roll.title,
    );
    w.open("g", &[a("class", "legend")]);
    let y = 36.0;
    let mut x = 8.0;
    for name in Outcome::NAMES {
        let count = roll
            .notes
            .iter()
            .filter(|n| n.outcome.name() == name)
            .count();
        w.open(
            "g",
            &[
                a("class", "legend-item"),
                a("data-outcome", name),
                a("data-count", count),
            ],
        );
        let o = Outcome::from_account(name, Some("")).expect("a known outcome");
        let c = colour::of(&o, Some(LATE_FULL_MS / 2.0));
        match name {
            "dropped" => swatch(w, x, y, &c, &c, Some("3 2")),
            "skipped" => swatch(w, x, y, "none", &c, Some("1 2")),
            "joined" => swatch(w, x, y, "none", &c, Some("2 1")),
            "unison" => swatch(w, x, y, "none", &c, None),
            _ => swatch(w, x, y, &c, &c, None),
        }
        x = label(w, x + 20.0, y, &format!("{} {count}", colour::label(name))) + 12.0;
        w.close("g");
    }
    w.close("g");

    // Second line: late shading, keys, outline and fill, loudness.
    let y = 54.0;
    let mut x = 8.0;
    w.open("g", &[a("class", "legend-key")]);
    for i in 0..6 {
        let ms = 1.0 + (LATE_FULL_MS - 1.0) * f64::from(i) / 5.0;
        let c = colour::late(ms);
        w.empty(
            "rect",
            &[
                a("x", num(x + f64::from(i) * 6.0)),
                a("y", num(y - 8.0)),
                a("width", "6"),
                a("height", "8"),
                a("fill", c),
            ],
        );
    }
    x = label(w, x + 40.0, y, &format!("late 1 → {LATE_FULL_MS:.0}+ ms")) + 14.0;
    if let Some((lo, hi)) = roll.keys {
        swatch(w, x, y, "#dbe8f6", "#3b7dc4", None);
        x = label(
            w,
            x + 20.0,
            y,
            &format!("the robot's keys {}–{}", note_name(lo), note_name(hi)),
        ) + 14.0;
    }
    if roll.dynamics {
        for (i, v) in [1u8, 64, 127].into_iter().enumerate() {
            let op = 0.2 + 0.8 * f64::from(v) / 127.0;
            w.empty(
                "rect",
                &[
                    a("x", num(x + i as f64 * 10.0)),
                    a("y", num(y - 8.0)),
                    a("width", "9"),
                    a("height", "8"),
                    a("fill", "#2a9d55"),
                    a("fill-opacity", format!("{op:.2}")),
                ],
            );
        }
        label(w, x + 34.0, y, "fill opacity: loudness, velocity 1 → 127");
    }
    let hits = if roll.notes.iter().any(|n| n.hit) {
        " (a struck drum or bar: a short outline at its start)"
    } else {
        ""
    };
    label(
        w,
        8.0,
        y + 17.0,
        &format!("outline: the score's note, Note-On to Note-Off{hits} · fill: the robot's strike, sounded to key up · hover a note for its account"),
    );
    w.close("g");
}
