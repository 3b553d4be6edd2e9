//! Guards that the `Stats` docs say what the interpreter does, claim by claim: when a note is
//! counted, what `folded_octaves`, `dropped_power`, `dropped_cancelled`, the `cut_by_*`
//! counts and `peak_keys_down` count, and what they leave out.
//!
//! The default guard (60 ms re-strike gap, 20 ms `min_press`, 10 s hold limit, 4 s
//! watchdog) with no late limit, so that every re-strike waits for its gap however long.

mod common;

use common::{ms, Rig};
use orch_core::{Config, GuardConfig, Stats};

fn budget(max_keys_down: u8) -> Rig {
    Rig::with_guard(GuardConfig {
        max_keys_down,
        late_limit: None,
        ..GuardConfig::DEFAULT
    })
}

/// Notes counted in `note_ons` but not yet in `played + folded + dropped()`.
fn waiting(s: &Stats) -> u32 {
    s.note_ons - (s.played + s.folded + s.dropped())
}

#[test]
fn a_strike_waiting_for_its_gap_is_in_no_count_until_it_strikes() {
    let mut rig = Rig::patient();
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(100));
    rig.feed(&[0x90, 60, 100], ms(110)); // 10 ms after its release: waits until 160 ms
    let s = *rig.robot.stats();
    assert_eq!((s.note_ons, s.played, s.restrikes_delayed), (2, 1, 1));
    assert_eq!(waiting(&s), 1);
    rig.tick(ms(160));
    assert!(rig.note_down(60));
    let s = *rig.robot.stats();
    assert_eq!((s.played, waiting(&s)), (2, 0));
}

#[test]
fn a_waiting_strike_whose_note_ends_still_sounds_and_is_not_cancelled() {
    let mut rig = Rig::patient();
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(100));
    rig.feed(&[0x90, 60, 100], ms(110));
    rig.feed(&[0x80, 60, 0], ms(120)); // over before it could strike
    rig.feed(&[0xB0, 123, 0], ms(130)); // All Notes Off does not cancel it either
    rig.run_until(ms(1000));
    let s = *rig.robot.stats();
    assert_eq!((s.played, s.dropped_cancelled), (2, 0));
    // It struck at 160 ms and was held for min_press (20 ms).
    assert_eq!(
        rig.edges_of(60),
        vec![
            (ms(0), true),
            (ms(100), false),
            (ms(160), true),
            (ms(180), false)
        ]
    );
}

#[test]
fn dropped_cancelled_counts_waiting_strikes_when_everything_is_released() {
    // System Reset and the watchdog each cancel a waiting strike; all_off stops it.
    for how in ["reset", "all_off", "watchdog"] {
        let mut rig = Rig::patient();
        rig.feed(&[0x90, 60, 100, 0x90, 64, 100], ms(0));
        rig.feed(&[0x80, 60, 0], ms(100));
        rig.feed(&[0x90, 60, 100], ms(110)); // 60 waits until 160 ms; 64 stays down
        match how {
            "reset" => rig.feed(&[0xFF], ms(120)),
            "all_off" => rig.all_off(ms(120)),
            _ => {
                // The watchdog needs a strike still waiting when it fires: a long gap.
                let mut rig2 = Rig::with_guard(GuardConfig {
                    restrike_gap: orch_core::Duration::from_secs(10),
                    late_limit: None,
                    ..GuardConfig::DEFAULT
                });
                rig2.feed(&[0x90, 60, 100, 0x90, 64, 100], ms(0));
                rig2.feed(&[0x80, 60, 0], ms(100));
                rig2.feed(&[0x90, 60, 100], ms(110));
                rig2.run_until(ms(5000)); // 4 s without a byte
                rig = rig2;
            }
        }
        let s = *rig.robot.stats();
        // all_off stops the performance: its waiting strikes are stopped, not cancelled.
        let stopped = u32::from(how == "all_off");
        assert_eq!(s.dropped_cancelled, 1 - stopped, "{how}: {s:?}");
        assert_eq!(s.dropped_stopped, stopped, "{how}: {s:?}");
        assert_eq!(s.restrikes_delayed, 1, "{how}: still counted as delayed");
        assert_eq!(waiting(&s), 0, "{how}");
        let watchdog = u32::from(how == "watchdog");
        assert_eq!(
            s.cut_by_watchdog, watchdog,
            "{how}: the watchdog counts the key down (64), not the waiting strike"
        );
    }
}

#[test]
fn folded_octaves_count_a_folded_note_even_when_it_is_dropped() {
    let mut rig = budget(1);
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.feed(&[0x90, 12, 100], ms(100)); // folds up 2 octaves to 36; the budget refuses it
    let s = *rig.robot.stats();
    assert_eq!((s.folded, s.dropped_power, s.folded_octaves), (0, 1, 2));
    rig.feed(&[0x90, 108, 100], ms(200)); // folds down 1 octave to 96; refused too
    assert_eq!(rig.robot.stats().folded_octaves, 3);
}

#[test]
fn dropped_power_counts_strikes_waiting_as_keys_down() {
    let mut rig = budget(1);
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(100));
    rig.feed(&[0x90, 60, 100], ms(110)); // waiting, not down
    rig.feed(&[0x90, 62, 100], ms(120)); // refused: the waiting strike takes the budget
    let s = *rig.robot.stats();
    assert_eq!(s.dropped_power, 1);
    assert!(!rig.note_down(62));
}

#[test]
fn dropped_power_is_not_counted_with_the_guard_off() {
    let mut rig = Rig::with_guard(GuardConfig {
        max_keys_down: 1,
        ..GuardConfig::OFF
    });
    rig.feed(&[0x90, 60, 100, 0x90, 62, 100], ms(0));
    assert_eq!(rig.robot.stats().dropped_power, 0);
    assert!(rig.note_down(60) && rig.note_down(62));
}

#[test]
fn dropped_range_counts_notes_with_no_key_under_either_policy() {
    use orch_core::{KeyRange, Layout, Note, OutOfRange};
    // Drop: outside the range.
    let mut rig = Rig::new(Config {
        out_of_range: OutOfRange::Drop,
        ..Config::THESIS
    });
    rig.feed(&[0x90, 20, 100, 0x90, 100, 100], ms(0));
    assert_eq!(rig.robot.stats().dropped_range, 2);
    // Fold on a range narrower than an octave: 36..=40 has no key for a G.
    let narrow = Config {
        range: KeyRange::new(Note::new(36).unwrap(), Note::new(40).unwrap()).unwrap(),
        layout: Layout {
            boards: [
                orch_core::BoardSpan {
                    address: 0x21,
                    keys: 5,
                    first_bit: 0,
                },
                orch_core::BoardSpan {
                    address: 0x22,
                    keys: 0,
                    first_bit: 0,
                },
                orch_core::BoardSpan {
                    address: 0x23,
                    keys: 0,
                    first_bit: 0,
                },
                orch_core::BoardSpan {
                    address: 0x24,
                    keys: 0,
                    first_bit: 0,
                },
            ],
        },
        ..Config::THESIS
    };
    let mut rig = Rig::new(narrow);
    rig.feed(&[0x90, 55, 100, 0x90, 52, 100], ms(0)); // G3: no key; E3 folds to 40
    let s = *rig.robot.stats();
    assert_eq!((s.dropped_range, s.folded), (1, 1));
}

#[test]
fn cut_by_hold_limit_counts_each_key_and_forgets_its_notes() {
    let mut rig = Rig::patient();
    rig.feed(&[0x90, 60, 100, 0x91, 60, 100, 0x90, 64, 100], ms(0));
    // Bytes keep coming so the watchdog stays quiet; the 10 s limit cuts both keys.
    for t in (1000..=11_000).step_by(1000) {
        rig.feed(&[0xF8], ms(t));
    }
    assert_eq!(rig.robot.stats().cut_by_hold_limit, 2);
    // Its notes are forgotten: a new Note-On strikes afresh.
    rig.feed(&[0x90, 60, 100], ms(11_100));
    assert!(rig.note_down(60));
}

#[test]
fn peak_keys_down_counts_keys_down_not_strikes_waiting() {
    let mut rig = Rig::patient();
    rig.feed(&[0x90, 60, 100, 0x90, 62, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(100));
    rig.feed(&[0x90, 60, 100], ms(110)); // one down, one waiting
    assert_eq!(rig.robot.stats().peak_keys_down, 2, "from 0 ms");
    rig.feed(&[0x90, 64, 100], ms(120));
    assert_eq!(
        rig.robot.stats().peak_keys_down,
        2,
        "62, 64 down; 60 waiting"
    );
    rig.tick(ms(160));
    assert_eq!(rig.robot.stats().peak_keys_down, 3);
}
