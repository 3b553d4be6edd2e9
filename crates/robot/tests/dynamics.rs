//! robot.toml's PWM boards and dynamics: `kind = "pca9685"` boards get velocity curves from
//! `[dynamics]` (per key where keys differ), on/off boards play at full power, the PWM
//! frequency must be one the chip makes, and a bad setting is refused naming its field.
//! Duties are re-typed in 4095ths (45 % = 1843, 35 % = 1433).

use orch_core::{Duration, Duty, Touch};
use orch_robot::{default_toml, BoardKind, Robot, RobotError};

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
    for w in words {
        assert!(message.contains(w), "{message:?} does not say {w:?}");
    }
}

const PWM: &str =
    "[keys]\nlow = 60\nhigh = 75\n[[boards]]\nkind = \"pca9685\"\naddress = 0x40\nkeys = 16\n";

fn d(value: u16) -> Duty {
    Duty::new(value).unwrap()
}

#[test]
fn the_pca9685_default_is_four_pwm_boards_with_the_peers_curve() {
    let r = Robot::from_toml(&default_toml(BoardKind::Pwm)).unwrap();
    assert_eq!(r.boards, 4);
    assert_eq!(r.kinds, vec![BoardKind::Pwm; 4]);
    let addresses: Vec<u8> = r.config.layout.boards[..4]
        .iter()
        .map(|b| b.address)
        .collect();
    assert_eq!(addresses, vec![0x40, 0x41, 0x42, 0x43]);
    assert_eq!(r.config.range.keys(), 61);
    assert!(r.has_dynamics());
    assert_eq!(r.pwm_hz, 1_526);
    assert_eq!(r.clock, orch_sim::BusClock::from_hz(1_000_000));
    assert_eq!(r.config.dynamics.strike, Duration::from_millis(40));
    for key in 0..61 {
        assert_eq!(
            r.config.dynamics.keys[key],
            Touch {
                softest: d(1843),
                loudest: d(4095),
                hold: d(1433)
            },
            "key {key}"
        );
    }
    r.interpreter().unwrap();
    // The on/off default is the thesis's robot, velocity ignored.
    let r = Robot::from_toml(&default_toml(BoardKind::OnOff)).unwrap();
    assert_eq!(r.kinds, vec![BoardKind::OnOff; 4]);
    assert!(!r.has_dynamics());
    assert!(r.config.dynamics.is_on_off());
}

#[test]
fn per_key_curves_apply_to_their_keys_and_on_off_boards_play_at_full_power() {
    let r = Robot::from_toml(
        "[keys]\nlow = 60\nhigh = 91\n\
         [[boards]]\nkind = \"pca9685\"\naddress = 0x40\nkeys = 16\n\
         [[boards]]\nkind = \"pca9555\"\naddress = 0x21\nkeys = 16\n\
         [dynamics]\nstrike = \"25ms\"\nsoftest = \"50%\"\n\
         [[dynamics.key]]\nnote = 62\nsoftest = \"60%\"\nloudest = \"90%\"\nhold = \"20%\"\n",
    )
    .unwrap();
    let dy = &r.config.dynamics;
    assert_eq!(dy.strike, Duration::from_millis(25));
    assert_eq!(dy.keys[0].softest, d(2048), "50 %");
    assert_eq!(dy.keys[0].hold, d(1433));
    assert_eq!(
        dy.keys[2],
        Touch {
            softest: d(2457),
            loudest: d(3686),
            hold: d(819)
        }
    );
    for key in 16..32 {
        assert_eq!(dy.keys[key], Touch::FULL, "key {key} is on the PCA9555");
    }
    assert_eq!(r.kinds, vec![BoardKind::Pwm, BoardKind::OnOff]);
}

#[test]
fn a_curve_that_falls_is_refused_naming_the_field() {
    refused_naming(
        &format!("{PWM}[dynamics]\nsoftest = \"70%\"\nloudest = \"60%\"\n"),
        "dynamics.loudest",
        &["fall", "60.0%", "70.0%"],
    );
    refused_naming(
        &format!("{PWM}[[dynamics.key]]\nnote = 64\nloudest = \"40%\"\n"),
        "dynamics.key[0].loudest",
        &["fall"],
    );
}

#[test]
fn a_hold_above_the_strike_is_refused() {
    refused_naming(
        &format!("{PWM}[dynamics]\nhold = \"50%\"\n"),
        "dynamics.hold",
        &["above softest"],
    );
    refused_naming(
        &format!("{PWM}[[dynamics.key]]\nnote = 61\nsoftest = \"30%\"\n"),
        "dynamics.key[0].hold",
        &["above softest"],
    );
}

#[test]
fn a_duty_over_100_percent_or_not_in_per_cent_is_refused() {
    refused_naming(
        &format!("{PWM}[dynamics]\nloudest = \"101%\"\n"),
        "dynamics.loudest",
        &["0% to 100%"],
    );
    refused_naming(
        &format!("{PWM}[dynamics]\nsoftest = \"0.5\"\n"),
        "dynamics.softest",
        &["per cent"],
    );
    refused_naming(
        &format!("{PWM}[dynamics]\nsoftest = \"0%\"\nhold = \"0%\"\n"),
        "dynamics.softest",
        &["no sound"],
    );
}

#[test]
fn a_strike_longer_than_the_hold_limit_is_refused() {
    refused_naming(
        &format!(
            "{PWM}[dynamics]\nstrike = \"2s\"\n[guard]\nmax_hold = \"1s\"\nmin_press = \"20ms\"\n"
        ),
        "dynamics.strike",
        &["max_hold"],
    );
    refused_naming(
        &format!("{PWM}[dynamics]\nstrike = \"0ms\"\n"),
        "dynamics.strike",
        &["40ms"],
    );
}

#[test]
fn a_pwm_frequency_the_chip_cannot_make_is_refused() {
    for bad in ["20Hz", "2kHz", "fast", "0Hz"] {
        refused_naming(
            &format!("{PWM}[pwm]\nfrequency = \"{bad}\"\n"),
            "pwm.frequency",
            &["24..=1526 Hz"],
        );
    }
    for (good, hz) in [
        ("24Hz", 24),
        ("1.5kHz", 1_500),
        ("1526Hz", 1_526),
        ("200 Hz", 200),
    ] {
        let r = Robot::from_toml(&format!("{PWM}[pwm]\nfrequency = \"{good}\"\n")).unwrap();
        assert_eq!(r.pwm_hz, hz, "{good}");
    }
}

#[test]
fn dynamics_entries_name_keys_the_robot_has_once_each() {
    refused_naming(
        &format!("{PWM}[[dynamics.key]]\nnote = 40\nsoftest = \"50%\"\n"),
        "dynamics.key[0].note",
        &["60..=75"],
    );
    refused_naming(
        &format!("{PWM}[[dynamics.key]]\nnote = 61\n[[dynamics.key]]\nnote = 61\n"),
        "dynamics.key[1].note",
        &["dynamics.key[0]"],
    );
    let e = refused("[[boards]]\nkind = \"pca9999\"\naddress = 0x40\nkeys = 16\n").to_string();
    assert!(e.contains("pca9555") && e.contains("pca9685"), "{e}");
}
