//! The follower's figures on the virtual clock (deterministic): how many beats a performance
//! takes to settle within 25 ms of the conductor after an abrupt change of 30 %, and the
//! phase error during an accelerando, for each follow mode. The beats go through the OSC
//! decoder (`/orch/beat` without a tempo) and the follower to a performance of the virtual
//! robot, as in `tests/conduct.rs`; each note's sound is measured against its beat.
//!
//! ```sh
//! cargo bench -p orch-perform --bench follow_figures
//! ```

use orch_perform::Follow;
use orch_seq::Song;
use testkit::conducted::{self, conduct, input, Via};
use testkit::smf;

/// From which beat after the change's last old beat (the first at the new tempo is 1) every
/// later note is within 25 ms of its beat; `None` if the last is not.
fn settles(errors: &[f64], change: usize) -> Option<usize> {
    let last_bad = errors.iter().rposition(|e| e.abs() > 25.0);
    match last_bad {
        None => Some(1),
        Some(i) if i + 1 < errors.len() => Some((i + 1).saturating_sub(change).max(1)),
        Some(_) => None,
    }
}

/// 1st, 2nd, 3rd, 4th…
fn ordinal(n: usize) -> String {
    let suffix = match (n % 10, n % 100) {
        (_, 11..=13) => "th",
        (1, _) => "st",
        (2, _) => "nd",
        (3, _) => "rd",
        _ => "th",
    };
    format!("{n}{suffix}")
}

fn quantile(v: &[f64], q: f64) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

fn main() {
    let modes = [("immediate", Follow::Immediate), ("phase", Follow::PHASE)];
    println!(
        "abrupt change of tempo after 16 beats, 16 beats after it (score at the first tempo):"
    );
    for (from, to) in [(100.0, 130.0), (130.0, 90.0), (130.0, 91.0)] {
        let beats = conducted::abrupt(from, 16, to, 16);
        let song = Song::parse(&smf::quarters_smf(34, from)).unwrap();
        for (name, follow) in modes {
            let run = conduct(&song, &input(&beats, Via::Osc), Via::Osc, follow);
            let e = run.errors_ms(&beats);
            let worst = e[17..].iter().fold(0f64, |a, x| a.max(x.abs()));
            match settles(&e, 16) {
                Some(n) => println!(
                    "  {from} -> {to} BPM, {name}: every note within 25 ms from the {} beat \
                     at the new tempo on (the change recognised at the 2nd); worst {worst:.0} ms; \
                     the 1st to 5th: {:.0?} ms",
                    ordinal(n),
                    &e[17..22]
                ),
                None => println!(
                    "  {from} -> {to} BPM, {name}: never within 25 ms (the last note {:.0} ms \
                     off its beat); worst {worst:.0} ms",
                    e[e.len() - 1]
                ),
            }
        }
    }
    println!(
        "accelerando 80 -> 140 BPM over 16 beats (8 at 80 before, 8 at 140 after; score at 80):"
    );
    let beats = conducted::ramp(80.0, 140.0, 8, 16, 8);
    let song = Song::parse(&smf::quarters_smf(34, 80.0)).unwrap();
    for (name, follow) in modes {
        let run = conduct(&song, &input(&beats, Via::Osc), Via::Osc, follow);
        let e: Vec<f64> = run.errors_ms(&beats)[9..25]
            .iter()
            .map(|x| x.abs())
            .collect();
        let from3: Vec<f64> = e[2..].to_vec();
        println!(
            "  {name}: |note - beat| over the 16 beats of the ramp: median {:.1} ms, max {:.1} ms; \
             from its 3rd beat: median {:.1} ms, max {:.1} ms",
            quantile(&e, 0.5),
            quantile(&e, 1.0),
            quantile(&from3, 0.5),
            quantile(&from3, 1.0),
        );
    }
}
