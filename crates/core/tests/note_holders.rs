//! Guards who holds a key: a key goes up only when every note holding it has been released
//! (the same note on two channels, or two notes folded onto one key); a duplicate Note-Off is
//! harmless; velocity-0 Note-On is a Note-Off; CC 120 and CC 123 release only that channel's
//! keys; System Reset (0xFF) releases everything; the channel mask drops notes.
//! (The original released a key on any Note-Off, even while another note still held it.)
//!
//! Times are 100 ms apart or more so the guard's re-strike gap never interferes. Tests of a
//! second note joining a key that is down use `overlap = hold`; `overlap_settings.rs` has the
//! default, restrike.

mod common;

use common::{cc, ms, note_off, note_on, Rig};
use orch_core::{ChannelMask, Config, Message};

#[test]
fn two_channels_on_one_key_keep_it_down_until_both_let_go() {
    let mut rig = Rig::holding();
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.feed(&[0x91, 60, 100], ms(100));
    assert!(rig.note_down(60));
    rig.feed(&[0x80, 60, 0], ms(200));
    assert!(rig.note_down(60), "channel 2 still holds it");
    rig.feed(&[0x81, 60, 0], ms(300));
    assert!(!rig.note_down(60));
    // It went down once and up once: the second channel did not re-strike it.
    assert_eq!(rig.edges_of(60), vec![(ms(0), true), (ms(300), false)]);
}

#[test]
fn the_order_of_release_does_not_matter() {
    let mut rig = Rig::thesis();
    rig.feed(&[0x90, 60, 100, 0x91, 60, 100], ms(0));
    rig.feed(&[0x81, 60, 0], ms(100));
    assert!(rig.note_down(60));
    rig.feed(&[0x80, 60, 0], ms(200));
    assert!(!rig.note_down(60));
}

#[test]
fn a_note_folded_onto_a_held_key_keeps_it_down_until_both_are_released() {
    // 24 folds up to 36 (key 0), the same key as 36 itself.
    for (first, second) in [(24, 36), (36, 24), (12, 24), (127, 91), (0, 36)] {
        let mut rig = Rig::holding();
        rig.feed(&[0x90, first, 100], ms(0));
        rig.feed(&[0x90, second, 100], ms(100));
        rig.feed(&[0x80, first, 0], ms(200));
        let key = common::fold(first);
        assert!(
            rig.note_down(key),
            "{second} still holds the key of {first}"
        );
        rig.feed(&[0x80, second, 0], ms(300));
        assert!(!rig.note_down(key), "{first} and {second} released");
        assert_eq!(
            rig.edges_of(key),
            vec![(ms(0), true), (ms(300), false)],
            "{first} then {second}"
        );
    }
}

#[test]
fn a_duplicate_note_off_is_harmless() {
    let mut rig = Rig::thesis();
    rig.feed(&[0x90, 60, 100, 0x91, 60, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(100));
    rig.feed(&[0x80, 60, 0], ms(150)); // channel 1 again: already off
    assert!(
        rig.note_down(60),
        "channel 2's note must survive channel 1's second Note-Off"
    );
    rig.feed(&[0x81, 60, 0], ms(200));
    rig.feed(&[0x81, 60, 0, 0x80, 60, 0], ms(300));
    assert!(!rig.note_down(60));
    // A Note-Off for a note never played does nothing either.
    rig.feed(&[0x85, 70, 0], ms(400));
    assert_eq!(rig.edges_of(60), vec![(ms(0), true), (ms(200), false)]);
    assert_eq!(rig.fingers_down(), 0);
}

#[test]
fn velocity_0_note_on_is_a_note_off() {
    let mut rig = Rig::thesis();
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.feed(&[0x90, 60, 0], ms(100));
    assert!(!rig.note_down(60));
    // With running status too, as sequencers send it.
    rig.feed(&[0x90, 62, 100, 64, 100], ms(200));
    rig.feed(&[62, 0, 64, 0], ms(300));
    assert_eq!(rig.fingers_down(), 0);
    // A velocity-0 Note-On for a note that is not on does not strike anything.
    rig.feed(&[0x90, 70, 0], ms(400));
    assert_eq!(rig.fingers_down(), 0);
    assert_eq!(rig.robot.stats().note_ons, 3, "velocity 0 is not a Note-On");
}

#[test]
fn all_notes_off_releases_only_that_channels_keys() {
    for controller in [123u8, 120] {
        let mut rig = Rig::thesis();
        rig.feed(&[0x90, 60, 100, 0x91, 62, 100], ms(0));
        // Key 64 is held by both channels.
        rig.feed(&[0x90, 64, 100, 0x91, 64, 100], ms(0));
        rig.feed(&[0xB0, controller, 0], ms(100));
        assert!(!rig.note_down(60), "CC {controller}: channel 1's own key");
        assert!(rig.note_down(62), "CC {controller}: channel 2's key stays");
        assert!(
            rig.note_down(64),
            "CC {controller}: shared key still held by channel 2"
        );
        // Channel 1's Note-Off afterwards is harmless.
        rig.feed(&[0x80, 64, 0], ms(150));
        assert!(rig.note_down(64));
        rig.feed(&[0xB1, controller, 0], ms(200));
        assert_eq!(rig.fingers_down(), 0, "CC {controller} on channel 2");
    }
}

#[test]
fn all_notes_off_on_another_channel_does_nothing() {
    let mut rig = Rig::thesis();
    rig.feed(&[0x93, 60, 100], ms(0));
    rig.feed(&[0xB0, 123, 0, 0xB1, 120, 0, 0xBF, 123, 0], ms(100));
    assert!(rig.note_down(60));
}

#[test]
fn system_reset_releases_everything() {
    let mut rig = Rig::thesis();
    rig.feed(
        &[0x90, 60, 100, 0x91, 60, 100, 0x9F, 40, 1, 0x95, 24, 100],
        ms(0),
    );
    assert_eq!(rig.fingers_down(), 3);
    rig.feed(&[0xFF], ms(100));
    assert_eq!(rig.fingers_down(), 0);
    assert_eq!(rig.robot.frame().all(), &[0, 0, 0, 0]);
    // The notes are forgotten: their Note-Offs do nothing, and a new note plays.
    rig.feed(&[0x80, 60, 0, 0x81, 60, 0], ms(200));
    rig.feed(&[0x90, 60, 100], ms(300));
    assert!(rig.note_down(60));
    rig.feed(&[0x80, 60, 0], ms(400));
    assert!(
        !rig.note_down(60),
        "channel 2's old note must not hold it after the reset"
    );
}

#[test]
fn system_reset_inside_a_message_releases_first_and_the_message_still_plays() {
    let mut rig = Rig::thesis();
    rig.feed(&[0x90, 64, 100], ms(0));
    rig.feed(&[0x90, 60, 0xFF, 100], ms(100));
    assert!(!rig.note_down(64));
    assert!(rig.note_down(60));
}

#[test]
fn decoded_messages_can_be_handed_in_directly() {
    let mut rig = Rig::holding();
    rig.handle(note_on(0, 60, 100), ms(0));
    rig.handle(note_on(1, 60, 100), ms(100));
    rig.handle(note_off(0, 60, 0), ms(200));
    assert!(rig.note_down(60));
    rig.handle(cc(1, 123, 0), ms(300));
    assert!(!rig.note_down(60));
    rig.handle(note_on(2, 61, 1), ms(400));
    rig.handle(Message::Reset, ms(500));
    assert_eq!(rig.fingers_down(), 0);
}

#[test]
fn the_channel_mask_drops_notes_of_other_channels() {
    let mut rig = Rig::new(Config {
        channels: ChannelMask::NONE.with(common::ch(0)).with(common::ch(9)),
        ..Config::THESIS
    });
    rig.feed(&[0x91, 60, 100, 0x9F, 61, 100], ms(0));
    assert_eq!(rig.writes, 0);
    rig.feed(&[0x90, 62, 100, 0x99, 63, 100], ms(100));
    assert!(rig.note_down(62) && rig.note_down(63));
    // Note-Offs on masked channels do not release the keys of listened channels.
    rig.feed(&[0x81, 62, 0, 0x82, 63, 0], ms(200));
    assert!(rig.note_down(62) && rig.note_down(63));
    let s = rig.robot.stats();
    assert_eq!((s.note_ons, s.dropped_channel, s.played), (4, 2, 2));
}

#[test]
fn the_default_listens_to_all_16_channels() {
    let mut rig = Rig::thesis();
    for c in 0..16u8 {
        rig.feed(&[0x90 | c, 40 + c, 100], ms(0));
    }
    assert_eq!(rig.fingers_down(), 16);
}

/// Regression: a delayed re-strike whose note was already released strikes for `min_press`
/// (20 ms). All Notes Off on another channel cut it short, though no note of that channel held
/// the key.
#[test]
fn all_notes_off_on_another_channel_does_not_cut_a_short_delayed_strike() {
    let mut rig = Rig::patient();
    rig.feed(&[0x90, 60, 100], ms(0));
    rig.feed(&[0x80, 60, 0], ms(10));
    rig.feed(&[0x90, 60, 100], ms(20)); // waits for the gap: strikes at 70 ms
    rig.feed(&[0x80, 60, 0], ms(30)); // over before it struck: held 20 ms once it does
    rig.feed(&[0xB1, 123, 0], ms(75));
    assert!(
        rig.note_down(60),
        "channel 2's All Notes Off is not for this key"
    );
    rig.run_until(ms(500));
    assert_eq!(
        rig.edges_of(60),
        vec![
            (ms(0), true),
            (ms(10), false),
            (ms(70), true),
            (ms(90), false)
        ]
    );
}

/// System Reset cancels running status: `FF 3C 64` after a Note-On plays no note (the old
/// decoder kept the 0x90 status and struck note 60 after the reset).
#[test]
fn system_reset_then_data_bytes_play_no_note() {
    let mut rig = Rig::thesis();
    rig.feed(&[0x90, 64, 100], ms(0));
    assert!(rig.note_down(64));
    rig.feed(&[0xFF, 60, 100], ms(100));
    assert!(!rig.note_down(64), "the reset released the key");
    assert!(!rig.note_down(60), "no running status survives a reset");
    assert!(rig.edges_of(60).is_empty());
}
