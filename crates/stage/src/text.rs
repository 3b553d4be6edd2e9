//! The reports as people read them, exactly as `orch play`, `orch conduct` and
//! `orch analyze` print them: a web page shows the same text.

use std::fmt::Write as _;
use std::path::Path;

use crate::analysis::Analysis;
use crate::report::{LinkFigures, Reports};

/// Notes the analysis's text lists (its JSON lists them all).
pub const LISTED: usize = 20;

/// An output's figures in words.
pub fn link(l: &LinkFigures) -> String {
    match l {
        LinkFigures::Port {
            bytes,
            writes,
            lost,
            reconnected,
            dropped_bytes,
        } => format!(
            "{bytes} bytes in {writes} writes; lost {lost} times, back {reconnected} \
             times, {dropped_bytes} bytes not sent"
        ),
        LinkFigures::Boards {
            retries,
            failed_writes,
            boards_lost,
            boards_reinitialised,
        } => format!(
            "{failed_writes} failed writes, {retries} retries; boards lost {boards_lost} \
             times, re-initialised {boards_reinitialised} times"
        ),
    }
}

/// Every robot's report, headed by the file played; each line ends with a newline.
pub fn reports(reports: &Reports, file: &Path) -> String {
    let mut out = format!("{}\n", file.display());
    match reports {
        Reports::One(r) => out.push_str(&r.text()),
        Reports::Robots(robots) => {
            for (i, r) in robots.iter().enumerate() {
                let channels = if r.channels.split(',').count() == 16 {
                    "all"
                } else {
                    &r.channels
                };
                let _ = writeln!(out, "\nrobot {}: {} (channels {channels})", i + 1, r.out);
                if let Some(l) = &r.link {
                    let _ = writeln!(out, "  output: {}", link(l));
                }
                out.push_str(&r.report.text());
            }
        }
    }
    out
}

/// The analysis, headed by the file analysed: the findings, the notes that will go wrong
/// (the first [`LISTED`]), the report; each line ends with a newline.
pub fn analysis(a: &Analysis, file: &Path) -> String {
    let mut out = format!("{}\n", file.display());
    for finding in &a.findings {
        let _ = writeln!(out, "- {finding}");
    }
    if !a.went_wrong.is_empty() {
        out.push_str("\nnotes that will go wrong, the worst first:\n");
        for w in a.went_wrong.iter().take(LISTED) {
            let amount = match (w.ms, w.velocity, w.sounded_velocity) {
                (Some(ms), _, _) => format!(" by {ms:.1} ms"),
                (None, Some(v), Some(heard)) => {
                    format!(" than asked: velocity {v}, sounds as {heard}")
                }
                _ => String::new(),
            };
            let _ = writeln!(
                out,
                "  {:>4}:{:<2} {:<4} ch {:<2} {}{}",
                w.bar, w.beat, w.note, w.channel, w.outcome, amount
            );
        }
        if a.went_wrong.len() > LISTED {
            let _ = writeln!(
                out,
                "  … and {} more (--json lists them all)",
                a.went_wrong.len() - LISTED
            );
        }
    }
    out.push('\n');
    out.push_str(&a.report.text());
    out
}
