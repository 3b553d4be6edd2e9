//! The roll of two small hand-made songs: golden files, well-formed XML, one note element for
//! every line of the account with its outcome, ghosts for dropped notes with their reason,
//! loudness where the robot plays velocity.
//!
//! The golden files (`tests/golden/*.svg`) are rewritten by `UPDATE_GOLDEN=1 cargo test -p
//! orch-roll --test roll`; look at the difference (and the picture) before committing them.

use std::collections::BTreeMap;
use std::path::PathBuf;

use orch_roll::{render, Options};

mod common;

fn golden(name: &str, svg: &str) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(name);
    if std::env::var_os("UPDATE_GOLDEN").is_some_and(|v| v == "1") {
        std::fs::write(&path, svg).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (UPDATE_GOLDEN=1 cargo test -p orch-roll writes it)",
            path.display()
        )
    });
    assert!(
        svg == want,
        "{name} differs from its golden file (UPDATE_GOLDEN=1 rewrites it after a change made on purpose)"
    );
}

fn outcomes_svg() -> (String, orch_perform::Played) {
    let (song, robot) = common::outcomes_song();
    let (roll, played) = common::roll(&song, &robot, "outcomes <&> song");
    (render(&roll, &Options::default()), played)
}

fn dynamics_svg() -> String {
    let (song, robot) = common::dynamics_song();
    let (roll, _) = common::roll(&song, &robot, "dynamics");
    render(&roll, &Options::default())
}

#[test]
fn golden_outcomes_song() {
    golden("outcomes.svg", &outcomes_svg().0);
}

#[test]
fn golden_dynamics_song() {
    golden("dynamics.svg", &dynamics_svg());
}

#[test]
fn the_svg_parses_as_xml() {
    for svg in [outcomes_svg().0, dynamics_svg()] {
        let doc = roxmltree::Document::parse(&svg).expect("well-formed XML");
        let root = doc.root_element();
        assert_eq!(root.tag_name().name(), "svg");
        assert_eq!(
            root.tag_name().namespace(),
            Some("http://www.w3.org/2000/svg")
        );
    }
}

fn has_class(n: &roxmltree::Node, class: &str) -> bool {
    n.attribute("class")
        .is_some_and(|c| c.split(' ').any(|w| w == class))
}

fn notes<'a>(doc: &'a roxmltree::Document) -> Vec<roxmltree::Node<'a, 'a>> {
    doc.descendants()
        .filter(|n| n.has_tag_name("g") && has_class(n, "note"))
        .collect()
}

fn title(n: &roxmltree::Node) -> String {
    n.children()
        .find(|c| c.has_tag_name("title"))
        .and_then(|t| t.text())
        .unwrap_or_default()
        .to_string()
}

#[test]
fn note_elements_by_outcome_equal_the_accounts_counts() {
    let (svg, played) = outcomes_svg();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    let mut drawn: BTreeMap<String, usize> = BTreeMap::new();
    for n in notes(&doc) {
        let outcome = n.attribute("data-outcome").unwrap().to_string();
        assert!(has_class(&n, &outcome), "class names the outcome");
        *drawn.entry(outcome).or_default() += 1;
    }
    let mut account: BTreeMap<String, usize> = BTreeMap::new();
    for line in played.account(|_, _| (1, 1)) {
        *account.entry(line.outcome.to_string()).or_default() += 1;
    }
    assert_eq!(drawn, account);
    // Every outcome a straight performance can give is in this song.
    let r = played.report(None);
    assert_eq!(
        drawn.get("on_time").copied(),
        Some(r.outcomes.on_time as usize)
    );
    assert_eq!(drawn.get("late").copied(), Some(r.outcomes.late as usize));
    assert_eq!(
        drawn.get("unison").copied(),
        Some(r.outcomes.unison as usize)
    );
    assert_eq!(
        drawn.get("joined").copied(),
        Some(r.outcomes.joined as usize)
    );
    assert_eq!(drawn.get("dropped").copied(), Some(2));
    // The legend says the same counts.
    for item in doc.descendants().filter(|n| has_class(n, "legend-item")) {
        let o = item.attribute("data-outcome").unwrap();
        let count: usize = item.attribute("data-count").unwrap().parse().unwrap();
        assert_eq!(count, drawn.get(o).copied().unwrap_or(0), "legend {o}");
    }
}

#[test]
fn a_dropped_note_is_a_ghost_with_its_reason_in_its_title() {
    let (svg, _) = outcomes_svg();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    let dropped: Vec<_> = notes(&doc)
        .into_iter()
        .filter(|n| n.attribute("data-outcome") == Some("dropped"))
        .collect();
    let reasons: Vec<_> = dropped
        .iter()
        .map(|n| n.attribute("data-reason").unwrap())
        .collect();
    assert_eq!(reasons, ["channel", "too_fast"]);
    for n in &dropped {
        assert!(has_class(n, "ghost"));
        let reason = n.attribute("data-reason").unwrap();
        assert!(
            title(n).contains(&format!("dropped ({reason})")),
            "{}",
            title(n)
        );
        // Its outline is dashed and faint, and it has no strike.
        let outline = n.children().find(|c| has_class(c, "score")).unwrap();
        assert!(outline.attribute("stroke-dasharray").is_some());
        assert!(!n.children().any(|c| has_class(&c, "strike")));
    }
    // No other note is a ghost.
    assert_eq!(
        notes(&doc).iter().filter(|n| has_class(n, "ghost")).count(),
        dropped.len()
    );
}

#[test]
fn every_note_has_a_title_with_name_bar_beat_and_outcome() {
    let (svg, played) = outcomes_svg();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    let notes = notes(&doc);
    assert_eq!(notes.len(), played.records.len());
    for n in notes {
        let t = title(&n);
        let name = orch_roll::note_name(n.attribute("data-note").unwrap().parse().unwrap());
        let bar_beat = format!(
            "bar {}:{}",
            n.attribute("data-bar").unwrap(),
            n.attribute("data-beat").unwrap()
        );
        assert!(t.starts_with(&format!("{name} (")), "{t}");
        assert!(t.contains(&bar_beat), "{t}");
        assert!(t.contains(" ms"), "{t}");
    }
}

#[test]
fn late_notes_are_shaded_by_how_late_and_struck_notes_have_fills() {
    let (svg, _) = outcomes_svg();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    for n in notes(&doc) {
        let strike = n.children().find(|c| has_class(c, "strike"));
        match n.attribute("data-outcome").unwrap() {
            "on_time" | "late" => {
                let s = strike.expect("a struck note has a fill");
                if n.attribute("data-outcome") == Some("late") {
                    let ms: f64 = n.attribute("data-onset-ms").unwrap().parse().unwrap();
                    assert!(ms > 1.0);
                    assert!(title(&n).contains("late by"));
                    let want = orch_roll::late_colour(ms);
                    assert_eq!(s.attribute("fill"), Some(want.as_str()));
                }
            }
            _ => assert!(strike.is_none(), "no strike of its own"),
        }
    }
}

#[test]
fn unison_and_joined_notes_are_marked() {
    let (svg, _) = outcomes_svg();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    for outcome in ["unison", "joined"] {
        let marked: Vec<_> = notes(&doc)
            .into_iter()
            .filter(|n| n.attribute("data-outcome") == Some(outcome))
            .collect();
        assert!(!marked.is_empty(), "{outcome}");
        for n in marked {
            assert!(n.children().any(|c| has_class(&c, "mark")), "{outcome}");
        }
    }
}

#[test]
fn a_folded_note_strikes_on_its_key_with_a_line_from_the_note_written() {
    let (svg, _) = outcomes_svg();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    let c1 = notes(&doc)
        .into_iter()
        .find(|n| n.attribute("data-note") == Some("24"))
        .expect("the C1");
    let y = |class: &str| -> f64 {
        c1.children()
            .find(|c| has_class(c, class))
            .and_then(|c| c.attribute("y"))
            .unwrap()
            .parse()
            .unwrap()
    };
    // Twelve semitones higher, 6 px each (the fill sits 0.2 of a lane lower in its lane).
    let (outline, strike) = (y("score") - 0.5, y("strike") - 1.2);
    assert!((outline - strike - 72.0).abs() < 0.2, "{outline} {strike}");
    assert!(c1.children().any(|c| has_class(&c, "fold")));
    assert!(title(&c1).contains("on key C2 (folded)"));
}

#[test]
fn velocity_is_drawn_only_where_the_robot_plays_it() {
    let opacities = |svg: &str| -> Vec<f64> {
        let doc = roxmltree::Document::parse(svg).unwrap();
        doc.descendants()
            .filter(|n| has_class(n, "strike"))
            .map(|n| n.attribute("fill-opacity").unwrap().parse().unwrap())
            .collect()
    };
    // PWM boards: the phrase's seven notes get louder, and so do their fills.
    let d = opacities(&dynamics_svg());
    assert_eq!(d.len(), 10);
    assert!(d[..7].windows(2).all(|w| w[0] < w[1]), "{d:?}");
    assert!(dynamics_svg().contains("fill opacity: loudness"));
    // On/off keys: every strike alike.
    let o = opacities(&outcomes_svg().0);
    assert!(o.iter().all(|x| *x == o[0]), "{o:?}");
    assert!(!outcomes_svg().0.contains("fill opacity: loudness"));
}

#[test]
fn bar_lines_keys_and_pitch_names_are_drawn() {
    let (svg, _) = outcomes_svg();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    // 3/4 at 120 bpm: bars 1.5 s long; the song lasts 4.5 s (bars 1–3, and the line that
    // closes bar 3).
    let bars: Vec<u32> = doc
        .descendants()
        .filter(|n| has_class(n, "bar"))
        .map(|n| n.attribute("data-bar").unwrap().parse().unwrap())
        .collect();
    assert_eq!(bars, [1, 2, 3, 4]);
    let keys = doc
        .descendants()
        .find(|n| has_class(n, "keys"))
        .expect("the key range");
    assert_eq!(keys.attribute("data-low"), Some("36"));
    assert_eq!(keys.attribute("data-high"), Some("96"));
    let names: Vec<&str> = doc
        .descendants()
        .filter(|n| has_class(n, "pitch"))
        .filter_map(|n| n.text())
        .collect();
    assert!(names.contains(&"C4"), "{names:?}");
    assert!(names.contains(&"C1"), "{names:?}");
}

#[test]
fn a_performance_that_kept_no_sounds_is_refused() {
    let (song, robot) = common::outcomes_song();
    let setup = orch_perform::Setup::for_robot(&robot);
    let played =
        orch_perform::Performer::new(&setup, orch_perform::song_events(&song), song.notes())
            .run()
            .unwrap();
    assert_eq!(
        orch_roll::build::roll(&song, &played, (36, 96), 1.0, "x"),
        Err(orch_roll::build::BuildError::NoSounds)
    );
}

#[test]
fn at_twice_the_tempo_notes_and_bar_lines_come_twice_as_soon() {
    let (song, robot) = common::dynamics_song();
    let keys = (36, 96);
    let normal = common::play(&song, &robot);
    let fast = common::play_at(&song, &robot, orch_perform::Tempo::new(2.0).unwrap());
    let a = orch_roll::build::roll(&song, &normal, keys, 1.0, "x").unwrap();
    let b = orch_roll::build::roll(&song, &fast, keys, 2.0, "x").unwrap();
    assert_eq!(a.notes.len(), b.notes.len());
    for (x, y) in a.notes.iter().zip(&b.notes) {
        assert!((x.t_ms / 2.0 - y.t_ms).abs() < 0.01, "{x:?} {y:?}");
        assert!((x.end_ms / 2.0 - y.end_ms).abs() < 0.01, "{x:?} {y:?}");
        // Bars and beats are the song's own.
        assert_eq!((x.bar, x.beat), (y.bar, y.beat));
    }
    let bars = |r: &orch_roll::Roll| r.bars.iter().map(|b| (b.bar, b.t_ms)).collect::<Vec<_>>();
    assert_eq!(bars(&a), [(1, 0.0), (2, 1500.0), (3, 3000.0)]);
    assert_eq!(bars(&b), [(1, 0.0), (2, 750.0), (3, 1500.0)]);
}

#[test]
fn a_performance_of_only_some_of_the_songs_notes_is_refused() {
    // Channel 1's notes only, as a robot given `ch=1` plays them: the records are not the
    // song's Note-Ons one for one, so their Note-Offs cannot be found by place.
    let (song, robot) = common::outcomes_song();
    let events: Vec<_> = orch_perform::song_events(&song)
        .filter(|e| e.bytes.channel() == Some(0))
        .collect();
    let notes = events
        .iter()
        .filter(|e| e.bytes.note_on().is_some())
        .count();
    let setup = orch_perform::Setup::for_robot(&robot).with_keep(orch_sim::Keep::Everything);
    let played = orch_perform::Performer::new(&setup, events.into_iter(), notes)
        .run()
        .unwrap();
    assert_eq!(
        orch_roll::build::roll(&song, &played, (36, 96), 1.0, "x"),
        Err(orch_roll::build::BuildError::NotTheSong)
    );
}

#[test]
fn a_performance_that_jumped_is_refused() {
    // From bar 2, as `orch play --from 2` plays: performance time no longer follows the bars.
    let (song, robot) = common::outcomes_song();
    let control = orch_perform::Control::new();
    control.jump_to(song.bar_start_us(2).unwrap());
    let setup = orch_perform::Setup::for_robot(&robot).with_keep(orch_sim::Keep::Everything);
    let played =
        orch_perform::Performer::new(&setup, orch_perform::song_events(&song), song.notes())
            .control(&control)
            .run()
            .unwrap();
    assert!(played.jumps > 0);
    assert_eq!(
        orch_roll::build::roll(&song, &played, (36, 96), 1.0, "x"),
        Err(orch_roll::build::BuildError::Jumped)
    );
}
