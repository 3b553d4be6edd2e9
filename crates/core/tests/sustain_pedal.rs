//! Guards the sustain pedal (CC 64): off by default, so the pedal is ignored (a held solenoid
//! heats up); when switched on, released keys stay down until the pedal goes up.

mod common;

use common::{ms, Rig};
use orch_core::Config;

fn with_sustain() -> Rig {
    Rig::new(Config {
        sustain: true,
        ..Config::THESIS
    })
}

#[test]
fn sustain_is_off_by_default_and_the_pedal_is_ignored() {
    assert_eq!(Config::default(), Config::THESIS);
    assert!(!Config::default().sustain);
    let mut rig = Rig::thesis();
    rig.feed(&[0xB0, 64, 127], ms(0));
    rig.feed(&[0x90, 60, 100], ms(100));
    rig.feed(&[0x80, 60, 0], ms(200));
    assert!(
        !rig.note_down(60),
        "the pedal must not hold keys by default"
    );
    rig.feed(&[0xB0, 64, 0], ms(300));
    assert_eq!(rig.edges_of(60), vec![(ms(100), true), (ms(200), false)]);
}

#[test]
fn with_sustain_on_released_keys_stay_down_until_the_pedal_goes_up() {
    let mut rig = with_sustain();
    rig.feed(&[0xB0, 64, 127], ms(0));
    rig.feed(&[0x90, 60, 100, 64, 100], ms(100));
    rig.feed(&[0x80, 60, 0, 64, 0], ms(200));
    assert!(rig.note_down(60) && rig.note_down(64), "held by the pedal");
    rig.feed(&[0xB0, 64, 0], ms(300));
    assert!(!rig.note_down(60) && !rig.note_down(64), "pedal up");
    assert_eq!(rig.edges_of(60), vec![(ms(100), true), (ms(300), false)]);
}

#[test]
fn pedal_down_after_the_note_holds_it_too() {
    let mut rig = with_sustain();
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.feed(&[0xB0, 64, 100], ms(100));
    rig.feed(&[0x80, 60, 0], ms(200));
    assert!(rig.note_down(60));
    rig.feed(&[0xB0, 64, 63], ms(300)); // below 64 is up
    assert!(!rig.note_down(60));
}

#[test]
fn keys_still_held_by_a_note_stay_down_when_the_pedal_goes_up() {
    let mut rig = with_sustain();
    rig.feed(&[0xB0, 64, 127, 0x90, 60, 100, 62, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(100));
    rig.feed(&[0xB0, 64, 0], ms(200));
    assert!(!rig.note_down(60));
    assert!(rig.note_down(62), "its note is still on");
    rig.feed(&[0x80, 62, 0], ms(300));
    assert!(!rig.note_down(62));
}

#[test]
fn notes_released_before_the_pedal_went_down_are_not_held() {
    let mut rig = with_sustain();
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(100));
    rig.feed(&[0xB0, 64, 127], ms(200));
    assert!(!rig.note_down(60));
}

#[test]
fn all_sound_off_and_reset_release_sustained_keys() {
    let mut rig = with_sustain();
    rig.feed(&[0xB0, 64, 127, 0x90, 60, 100, 62, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(100));
    rig.feed(&[0xB0, 120, 0], ms(200));
    assert!(
        !rig.note_down(60) && !rig.note_down(62),
        "All Sound Off lets go of the pedal's keys and the played ones"
    );
    // All Sound Off lets the pedal go too: a new note is released by its Note-Off.
    rig.feed(&[0x90, 64, 100], ms(300));
    rig.feed(&[0x80, 64, 0], ms(400));
    assert!(!rig.note_down(64));

    let mut rig = with_sustain();
    rig.feed(&[0xB0, 64, 127, 0x90, 60, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(100));
    rig.feed(&[0xFF], ms(200));
    assert!(!rig.note_down(60), "System Reset lets go of everything");
    // And the pedal is up afterwards: a new note is released by its Note-Off.
    rig.feed(&[0x90, 62, 100], ms(300));
    rig.feed(&[0x80, 62, 0], ms(400));
    assert!(!rig.note_down(62));
}

#[test]
fn the_hold_limit_still_applies_to_keys_held_by_the_pedal() {
    let mut rig = with_sustain();
    rig.feed(&[0xB0, 64, 127, 0x90, 60, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(100));
    // Keep bytes coming so the watchdog stays quiet.
    for t in (500..=12_000).step_by(500) {
        rig.feed(&[0xF8], ms(t));
    }
    assert_eq!(rig.edges_of(60), vec![(ms(0), true), (ms(10_000), false)]);
}

/// The sustain pedal is per channel in MIDI: channel 2's pedal must not hold channel 1's key.
#[test]
fn a_pedal_holds_only_its_own_channels_keys() {
    let mut rig = with_sustain();
    rig.feed(&[0xB0, 64, 127, 0xB1, 64, 127, 0x90, 60, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(100));
    rig.feed(&[0xB0, 64, 0], ms(200));
    assert!(
        !rig.note_down(60),
        "channel 1's pedal is up; channel 2's pedal must not hold channel 1's key"
    );
}

/// The same key held by two channels' pedals goes up only when both pedals are up.
#[test]
fn a_key_sustained_by_two_channels_waits_for_both_pedals() {
    let mut rig = with_sustain();
    rig.feed(
        &[0xB0, 64, 127, 0xB1, 64, 127, 0x90, 60, 100, 0x91, 60, 100],
        ms(0),
    );
    rig.feed(&[0x80, 60, 0, 0x81, 60, 0], ms(100));
    rig.feed(&[0xB0, 64, 0], ms(200));
    assert!(rig.note_down(60), "channel 2's pedal still holds it");
    rig.feed(&[0xB1, 64, 0], ms(300));
    assert!(!rig.note_down(60));
}

/// MIDI 1.0: All Notes Off switches notes off as their Note-Offs would, so with the pedal down
/// they stay sustained until it goes up; and the pedal is not forgotten, so a note played
/// after it is sustained as well.
#[test]
fn all_notes_off_keeps_the_pedal_down_and_its_keys_sustained() {
    let mut rig = with_sustain();
    rig.feed(&[0xB0, 64, 127, 0x90, 60, 100, 62, 100], ms(0));
    rig.feed(&[0x80, 62, 0], ms(100)); // 62 sustained, 60 still played
    rig.feed(&[0xB0, 123, 0], ms(200));
    assert!(
        rig.note_down(60) && rig.note_down(62),
        "the pedal is down: All Notes Off leaves both keys sustained"
    );
    rig.feed(&[0x90, 64, 100], ms(300));
    rig.feed(&[0x80, 64, 0], ms(400));
    assert!(
        rig.note_down(64),
        "the pedal is still down after All Notes Off"
    );
    rig.feed(&[0xB0, 64, 0], ms(500));
    assert!(!rig.note_down(60) && !rig.note_down(62) && !rig.note_down(64));
    assert_eq!(rig.edges_of(60), vec![(ms(0), true), (ms(500), false)]);
}

/// The mode messages (Omni Off/On, Mono, Poly: CC 124..=127) imply All Notes Off and keep the
/// pedal's keys the same way.
#[test]
fn mode_messages_keep_the_pedal_down_and_its_keys_sustained() {
    for controller in 124u8..=127 {
        let mut rig = with_sustain();
        rig.feed(&[0xB0, 64, 127, 0x90, 60, 100], ms(0));
        rig.feed(&[0xB0, controller, 0], ms(100));
        assert!(
            rig.note_down(60),
            "CC {controller}: the pedal holds the key"
        );
        rig.feed(&[0xB0, 64, 0], ms(200));
        assert!(!rig.note_down(60), "CC {controller}: the pedal went up");
    }
}

/// Without the pedal down, All Notes Off releases the channel's keys at once, and only that
/// channel's pedal counts.
#[test]
fn all_notes_off_with_the_pedal_up_releases_at_once() {
    let mut rig = with_sustain();
    rig.feed(&[0xB1, 64, 127, 0x90, 60, 100], ms(0));
    rig.feed(&[0xB0, 123, 0], ms(100));
    assert!(!rig.note_down(60), "channel 1's pedal is up");
}

/// Reset All Controllers (CC 121) lets the pedal up: the keys it held go up.
#[test]
fn reset_all_controllers_lets_the_pedal_up() {
    let mut rig = with_sustain();
    rig.feed(&[0xB0, 64, 127, 0x90, 60, 100, 62, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(100));
    rig.feed(&[0xB0, 121, 0], ms(200));
    assert!(!rig.note_down(60), "only the pedal held it");
    assert!(rig.note_down(62), "its note is still on");
}
