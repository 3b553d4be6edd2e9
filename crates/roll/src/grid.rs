//! Each row's background: the pitch lanes (black keys striped), the robot's keys shaded, the
//! octave lines, the note names and the bar lines with their numbers.

use crate::colour::{is_black, note_name};
use crate::layout::{Layout, Row};
use crate::model::{BarLine, Roll};
use crate::svg::{a, num, Writer};

/// Draws every row's background and bar lines.
pub fn rows(w: &mut Writer, roll: &Roll, l: &Layout) {
    let step = label_step(&roll.bars, l);
    w.open("g", &[a("class", "rows")]);
    for (i, row) in l.rows.iter().enumerate() {
        w.open(
            "g",
            &[
                a("class", "row"),
                a("data-row", i),
                a("data-from-ms", num(row.from_ms)),
                a("data-to-ms", num(row.to_ms)),
            ],
        );
        lanes(w, roll, l, row);
        // When the row begins, m:ss, in the margin above the note names.
        let s = (row.from_ms / 1000.0).floor().max(0.0) as u64;
        w.text(
            "text",
            &[
                a("class", "time"),
                a("x", num(l.left - 7.0)),
                a("y", num(row.top - 4.0)),
                a("text-anchor", "end"),
                a("font-size", "9"),
                a("fill", "#777777"),
            ],
            &format!("{}:{:02}", s / 60, s % 60),
        );
        bars(w, &roll.bars, l, row, i, step);
        w.close("g");
    }
    w.close("g");
}

fn lanes(w: &mut Writer, roll: &Roll, l: &Layout, row: &Row) {
    let x0 = l.left;
    let width = (row.to_ms - row.from_ms) * l.px_per_ms;
    let h = l.area_height();
    w.empty(
        "rect",
        &[
            a("class", "lanes"),
            a("x", num(x0)),
            a("y", num(row.top)),
            a("width", num(width)),
            a("height", num(h)),
            a("fill", "#ffffff"),
            a("stroke", "#b0b0b0"),
            a("stroke-width", "0.5"),
        ],
    );
    if l.pitched {
        pitch_rows(w, roll, l, row);
    }
    named_lanes(w, roll, l, row);
}

/// The named lanes below the pitch rows (a kit's drums): every other one shaded, each named
/// in the margin.
fn named_lanes(w: &mut Writer, roll: &Roll, l: &Layout, row: &Row) {
    let (x0, width) = (l.left, (row.to_ms - row.from_ms) * l.px_per_ms);
    for (i, name) in roll.lanes.iter().enumerate() {
        let y = l.lane_y(row, i as u16);
        w.empty(
            "rect",
            &[
                a("class", "lane"),
                a("data-lane", name),
                a("x", num(x0)),
                a("y", num(y)),
                a("width", num(width)),
                a("height", num(l.lane_px)),
                a("fill", if i % 2 == 0 { "#eef3e6" } else { "#ffffff" }),
                a("stroke", "#c8c8c8"),
                a("stroke-width", "0.5"),
            ],
        );
        w.text(
            "text",
            &[
                a("class", "lane-name"),
                a("x", num(x0 - 7.0)),
                a("y", num(y + l.lane_px / 2.0 + 3.0)),
                a("text-anchor", "end"),
                a("font-size", "9"),
                a("fill", "#444444"),
            ],
            name,
        );
    }
}

/// The pitch rows: the robot's keys shaded, black keys striped, octaves ruled, C named.
fn pitch_rows(w: &mut Writer, roll: &Roll, l: &Layout, row: &Row) {
    if let Some(keys) = roll.keys {
        keys_shade(w, l, row, keys);
    }
    pitch_lines(w, l, row);
}

/// The robot's keys `klo..=khi` shaded, and their span on the axis.
fn keys_shade(w: &mut Writer, l: &Layout, row: &Row, (klo, khi): (u8, u8)) {
    let (x0, width) = (l.left, (row.to_ms - row.from_ms) * l.px_per_ms);
    let ky = l.y(row, khi);
    let kh = f64::from(khi - klo + 1) * l.semitone;
    w.empty(
        "rect",
        &[
            a("class", "keys"),
            a("data-low", klo),
            a("data-high", khi),
            a("x", num(x0)),
            a("y", num(ky)),
            a("width", num(width)),
            a("height", num(kh)),
            a("fill", "#dbe8f6"),
            a("fill-opacity", "0.6"),
        ],
    );
    // The range on the axis, as a bar beside the names.
    w.empty(
        "rect",
        &[
            a("class", "keys-axis"),
            a("x", num(x0 - 4.0)),
            a("y", num(ky)),
            a("width", "3"),
            a("height", num(kh)),
            a("fill", "#3b7dc4"),
        ],
    );
}

/// Black keys striped, octaves (each B–C boundary) ruled, each C named.
fn pitch_lines(w: &mut Writer, l: &Layout, row: &Row) {
    let (x0, width) = (l.left, (row.to_ms - row.from_ms) * l.px_per_ms);
    // One path each.
    let mut black = String::new();
    let mut octaves = String::new();
    for n in l.lo..=l.hi {
        let y = l.y(row, n);
        if is_black(n) {
            black.push_str(&format!(
                "M{} {}h{}v{}h-{}z",
                num(x0),
                num(y),
                num(width),
                num(l.semitone),
                num(width)
            ));
        }
        if n % 12 == 0 && n > l.lo {
            octaves.push_str(&format!(
                "M{} {}h{}",
                num(x0),
                num(y + l.semitone),
                num(width)
            ));
        }
    }
    if !black.is_empty() {
        w.empty(
            "path",
            &[
                a("class", "black-keys"),
                a("d", black),
                a("fill", "#000000"),
                a("fill-opacity", "0.05"),
            ],
        );
    }
    if !octaves.is_empty() {
        w.empty(
            "path",
            &[
                a("class", "octaves"),
                a("d", octaves),
                a("stroke", "#c8c8c8"),
                a("stroke-width", "0.5"),
            ],
        );
    }
    for n in (l.lo..=l.hi).filter(|n| n % 12 == 0) {
        let y = l.y(row, n) + l.semitone / 2.0 + 3.0;
        w.text(
            "text",
            &[
                a("class", "pitch"),
                a("data-note", n),
                a("x", num(x0 - 7.0)),
                a("y", num(y)),
                a("text-anchor", "end"),
                a("font-size", "9"),
                a("fill", "#444444"),
            ],
            &note_name(n),
        );
    }
}

/// Bar lines in `row`; numbers every `step` bars and at each row's first bar.
fn bars(w: &mut Writer, bars: &[BarLine], l: &Layout, row: &Row, i: usize, step: u32) {
    let last = i + 1 == l.rows.len();
    let mut first = true;
    for b in bars {
        let inside = b.t_ms >= row.from_ms && (b.t_ms < row.to_ms || (last && b.t_ms <= row.to_ms));
        if !inside {
            continue;
        }
        let x = l.x(row, b.t_ms);
        w.open("g", &[a("class", "bar"), a("data-bar", b.bar)]);
        w.empty(
            "line",
            &[
                a("x1", num(x)),
                a("y1", num(row.top - 3.0)),
                a("x2", num(x)),
                a("y2", num(row.top + l.area_height())),
                a("stroke", "#8a8a8a"),
                a("stroke-width", "0.7"),
            ],
        );
        if first || b.bar % step == 0 {
            w.text(
                "text",
                &[
                    a("x", num(x + 2.0)),
                    a("y", num(row.top - 4.0)),
                    a("font-size", "9"),
                    a("fill", "#333333"),
                ],
                &b.bar.to_string(),
            );
        }
        first = false;
        w.close("g");
    }
}

/// Every how many bars a number fits (at least 18 px apart).
fn label_step(bars: &[BarLine], l: &Layout) -> u32 {
    let shortest = bars
        .windows(2)
        .map(|p| (p[1].t_ms - p[0].t_ms) * l.px_per_ms)
        .filter(|w| *w > 0.0)
        .fold(f64::INFINITY, f64::min);
    [1, 2, 4, 5, 10, 20, 50, 100]
        .into_iter()
        .find(|k| shortest * f64::from(*k) >= 18.0)
        .unwrap_or(100)
}
