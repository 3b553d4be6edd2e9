//! Configurations that cannot work are refused, and the message names the field and says
//! what to write instead.

use orch_robot::{Robot, RobotError};
use orch_sim::BusClock;

fn refused(text: &str) -> RobotError {
    match Robot::from_toml(text) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e,
    }
}

/// Refused, naming `field`, with every one of `words` in the message.
fn refused_naming(text: &str, field: &str, words: &[&str]) {
    let e = refused(text);
    assert_eq!(e.field_name(), Some(field), "{e}");
    let message = e.to_string();
    assert!(message.starts_with(field), "{message}");
    for w in words {
        assert!(message.contains(w), "{message:?} does not say {w:?}");
    }
}

#[test]
fn a_zero_watchdog_is_refused() {
    refused_naming(
        "[guard]\nwatchdog = \"0s\"\n",
        "guard.watchdog",
        &["\"0s\"", "\"off\""],
    );
    // "off" and any time longer than zero are fine.
    assert!(Robot::from_toml("[guard]\nwatchdog = \"off\"\n").is_ok());
    assert!(Robot::from_toml("[guard]\nwatchdog = \"1ms\"\n").is_ok());
}

#[test]
fn a_zero_max_hold_is_refused_since_no_note_could_sound() {
    refused_naming(
        "[guard]\nmax_hold = \"0ms\"\nmin_press = \"0ms\"\n",
        "guard.max_hold",
        &["\"0ms\"", "no note could sound"],
    );
    assert!(Robot::from_toml("[guard]\nmax_hold = \"off\"\n").is_ok());
}

#[test]
fn min_press_longer_than_max_hold_is_refused() {
    refused_naming(
        "[guard]\nmax_hold = \"10ms\"\nmin_press = \"20ms\"\n",
        "guard.min_press",
        &["\"20ms\"", "guard.max_hold", "\"10ms\""],
    );
    // Equal is fine (the strike is held exactly to the limit), and so is no hold limit.
    assert!(Robot::from_toml("[guard]\nmax_hold = \"20ms\"\nmin_press = \"20ms\"\n").is_ok());
    assert!(Robot::from_toml("[guard]\nmax_hold = \"off\"\nmin_press = \"20min\"\n").is_ok());
}

#[test]
fn a_key_listed_twice_in_mechanics_is_refused() {
    refused_naming(
        "[[mechanics.key]]\nnote = 40\npress_delay = \"10ms\"\n\
         [[mechanics.key]]\nnote = 41\n\
         [[mechanics.key]]\nnote = 40\npress_delay = \"30ms\"\n",
        "mechanics.key[2].note",
        &["40", "mechanics.key[0]"],
    );
}

#[test]
fn a_board_with_no_keys_is_refused() {
    refused_naming(
        "[keys]\nlow = 36\nhigh = 51\n\
         [[boards]]\naddress = 0x20\nkeys = 0\n\
         [[boards]]\naddress = 0x21\nkeys = 16\n",
        "boards[0].keys",
        &["0", "1..=16"],
    );
}

#[test]
fn channels_given_badly_say_what_to_write() {
    for (text, field) in [
        ("channels = \"some\"", "keys.channels"),
        ("channels = 3", "keys.channels"),
        ("channels = []", "keys.channels"),
        ("channels = [1, 0]", "keys.channels[1]"),
        ("channels = [17]", "keys.channels[0]"),
        ("channels = [\"1\"]", "keys.channels[0]"),
    ] {
        let e = refused(&format!("[keys]\n{text}\n"));
        let message = e.to_string();
        assert_eq!(e.field_name(), Some(field), "{message}");
        assert!(!message.contains("untagged"), "{message}");
        assert!(message.contains("\"all\""), "{message}");
        assert!(message.contains("1..=16"), "{message}");
    }
    let r = Robot::from_toml("[keys]\nchannels = [1, 10, 16]\n").unwrap();
    assert_eq!(r.config.channels.0, 1 | 1 << 9 | 1 << 15);
}

#[test]
fn integers_out_of_range_name_the_field_and_the_range() {
    for (text, field, range) in [
        ("[keys]\nlow = 200", "keys.low", "0..=127"),
        ("[keys]\nhigh = -1", "keys.high", "0..=127"),
        (
            "[guard]\nmax_keys_down = 300",
            "guard.max_keys_down",
            "1..=255",
        ),
        (
            "[[boards]]\naddress = 0x21\nkeys = 300",
            "boards[0].keys",
            "1..=16",
        ),
        (
            "[[boards]]\naddress = 0x21\nkeys = 1\nfirst_bit = 256",
            "boards[0].first_bit",
            "0..=15",
        ),
        (
            "[[boards]]\naddress = 4096\nkeys = 1",
            "boards[0].address",
            "0x08..=0x77",
        ),
        (
            "[[mechanics.key]]\nnote = 300",
            "mechanics.key[0].note",
            "36..=96",
        ),
    ] {
        let e = refused(text);
        let message = e.to_string();
        assert_eq!(e.field_name(), Some(field), "{message}");
        assert!(message.contains(range), "{message:?} does not give {range}");
        assert!(!message.contains("expected u8"), "{message}");
    }
}

#[test]
fn bus_clock_is_read_in_hz_khz_and_mhz() {
    let clock = |text: &str| {
        Robot::from_toml(&format!("[bus]\nclock = \"{text}\"\n"))
            .unwrap_or_else(|e| panic!("{text}: {e}"))
            .clock
    };
    assert_eq!(clock("1MHz"), BusClock::from_hz(1_000_000));
    assert_eq!(clock("1MHz"), clock("1000kHz"));
    assert_eq!(clock("1MHz"), clock("1000000Hz"));
    assert_eq!(clock("100000Hz"), clock("100kHz"));
    assert_eq!(clock("0.4MHz"), BusClock::FAST);
    assert_eq!(clock("83.33kHz"), BusClock::THESIS);
    for bad in ["2MHz", "fast", "400", "0.5kHz"] {
        let e = refused(&format!("[bus]\nclock = \"{bad}\"\n"));
        let message = e.to_string();
        assert_eq!(e.field_name(), Some("bus.clock"), "{message}");
        for accepted in ["\"83.33kHz\"", "\"400kHz\"", "\"1MHz\"", "Hz, kHz or MHz"] {
            assert!(message.contains(accepted), "{message:?} lacks {accepted}");
        }
    }
}

/// A drum kit of two outputs on one board, with `extra` added to its first output's table.
fn kit(extra: &str) -> String {
    format!(
        "[keys]\nenabled = false\n[[boards]]\naddress = 0x21\nkeys = 2\n[[strike]]\nchannels = [10]\n\
         [[strike.output]]\nname = \"kick\"\nnotes = [35, 36]\n{extra}\n[[strike.output]]\nname = \"snare\"\nnotes = [38]\n"
    )
}

#[test]
fn strike_groups_that_cannot_play_are_refused_naming_the_field() {
    assert!(Robot::from_toml(&kit("")).is_ok());
    let cases = [
        (
            kit("pulse_loud = \"5ms\""),
            "strike[0].output[0].pulse_loud",
        ),
        (kit("rebound = \"10ms\""), "strike[0].output[0].rebound"),
        (
            kit("pulse_soft = \"2ms\""),
            "strike[0].output[0].pulse_soft",
        ),
        (
            kit("notes = [38]").replace("notes = [35, 36]\n", ""),
            "strike[0].output[1].notes[0]",
        ),
        (
            kit("pulse_loud = \"150ms\"\nrebound = \"200ms\""),
            "strike[0].output[0].pulse_loud",
        ),
        (kit("").replace("keys = 2", "keys = 3"), "boards"),
        (
            kit("").replace("channels = [10]", "channels = [17]"),
            "strike[0].channels[0]",
        ),
        (
            kit("").replace("[[strike]]", "[[strike]]\nlow = 79"),
            "strike[0].low",
        ),
        ("[keys]\nenabled = false\n".to_string(), "keys.enabled"),
        (
            kit("").replace("[keys]", "[guard]\nmax_pulse = \"1s\"\n[keys]"),
            "guard.max_pulse",
        ),
    ];
    for (text, field) in cases {
        let e = Robot::from_toml(&text).expect_err(&text);
        assert_eq!(e.field_name(), Some(field), "{e:#}\n{text}");
    }
}

#[test]
fn a_piano_with_a_drum_kit_on_channel_10_numbers_the_kits_outputs_after_the_keys() {
    let text = "[keys]\nlow = 48\nhigh = 59\n[[boards]]\naddress = 0x21\nkeys = 14\n\
                [[strike]]\nname = \"drums\"\nchannels = [10]\n[[strike.output]]\nname = \"kick\"\nnotes = [36]\n\
                [[strike.output]]\nname = \"snare\"\nnotes = [38]\n";
    let robot = Robot::from_toml(text).unwrap();
    assert_eq!(robot.groups.len(), 2);
    assert_eq!(robot.group_of(12).unwrap().output_name(12), Some("kick"));
    assert_eq!(robot.group_of(3).unwrap().name, "keyboard");
    // The kit's beaters have a drum's mechanics; the keys keep theirs.
    assert_eq!(robot.mechanics.for_key(12).press_delay.as_micros(), 10_000);
    assert_eq!(robot.mechanics.for_key(3).press_delay.as_micros(), 15_000);
}

/// A kit of kick, hi-hat (42, 46) and a third output with `third` as its table, on one board.
fn kit_with(third: &str) -> String {
    format!(
        "[keys]\nenabled = false\n[[boards]]\naddress = 0x21\nkeys = 3\n[[strike]]\nchannels = [10]\n\
         [[strike.output]]\nname = \"kick\"\nnotes = [36]\n\
         [[strike.output]]\nname = \"hi-hat\"\nnotes = [42, 46]\n\
         [[strike.output]]\nname = \"extra\"\n{third}\n"
    )
}

#[test]
fn a_lift_leads_its_notes_and_a_damper_damps_its_drum() {
    let robot = Robot::from_toml(&kit_with("leads = [46]\nlead = \"12ms\"")).unwrap();
    let c = robot.config;
    let ch = orch_core::Channel::new(9).unwrap();
    let lead = c.strikes.lead(ch, orch_core::Note::from_bits(46));
    assert_eq!(lead, Some((2, orch_core::Duration::from_millis(12))));
    assert_eq!(c.strikes.lead(ch, orch_core::Note::from_bits(42)), None);
    // A lift touches no head: nothing to mute.
    assert_eq!(robot.mechanics.for_key(2).mute_after, None);
    let robot = Robot::from_toml(&kit_with("damps = \"hi-hat\"")).unwrap();
    assert_eq!(robot.config.strikes.damper(1), Some(2));
    assert!(robot.interpreter().is_ok());
}

#[test]
fn a_glockenspiel_with_dampers_has_one_after_the_bars_for_each() {
    let text = "[keys]\nenabled = false\n[[boards]]\naddress = 0x21\nkeys = 16\n\
                [[strike]]\nlow = 72\nhigh = 79\ndamper_pulse = \"20ms\"\n";
    let robot = Robot::from_toml(text).unwrap();
    let g = &robot.groups[0];
    assert_eq!(g.outputs.len(), 16);
    assert_eq!(g.outputs[8], "C5 damper");
    assert!(g.notes[8].is_empty());
    for bar in 0..8u8 {
        assert_eq!(robot.config.strikes.damper(bar), Some(8 + bar));
    }
    assert!(robot.interpreter().is_ok());
    // The boards must drive the dampers too.
    let e = Robot::from_toml(&text.replace("keys = 16", "keys = 8")).unwrap_err();
    assert_eq!(e.field_name(), Some("boards"), "{e}");
}

#[test]
fn leads_and_dampers_that_cannot_work_are_refused_naming_the_field() {
    let cases = [
        (kit_with("leads = [46]"), "strike[0].output[2].lead"),
        (kit_with("lead = \"10ms\""), "strike[0].output[2].leads"),
        // As long as the hi-hat's rebound (40 ms): the stick could not wait for it.
        (
            kit_with("leads = [46]\nlead = \"40ms\""),
            "strike[0].output[2].lead",
        ),
        (
            kit_with("leads = [50]\nlead = \"10ms\""),
            "strike[0].output[2].leads[0]",
        ),
        (
            kit_with("notes = [49]\nleads = [46]\nlead = \"10ms\""),
            "strike[0].output[2].notes",
        ),
        (kit_with("damps = \"ride\""), "strike[0].output[2].damps"),
        (kit_with(""), "strike[0].output[2].notes"),
        (
            kit_with("damps = \"kick\"")
                .replace("[[strike]]", "[[strike]]\ndamper_pulse = \"9ms\""),
            "strike[0].damper_pulse",
        ),
    ];
    for (text, field) in cases {
        let e = Robot::from_toml(&text).expect_err(&text);
        assert_eq!(e.field_name(), Some(field), "{e:#}\n{text}");
    }
}
