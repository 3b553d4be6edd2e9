//! Solenoid and key mechanics: delays, minimum hold, smears, clean re-strikes.

use orch_core::Duration;
use orch_sim::{KeyMechanics, Mechanics, MechanicsConfig, SimTime, SoundEvent, SoundKind};

fn ms(t: u64) -> SimTime {
    SimTime::from_millis(t)
}

fn down(t: u64, key: u8, smeared: bool) -> SoundEvent {
    SoundEvent {
        time: ms(t),
        key,
        kind: SoundKind::Down,
        smeared,
    }
}

fn up(t: u64, key: u8) -> SoundEvent {
    SoundEvent {
        time: ms(t),
        key,
        kind: SoundKind::Up,
        smeared: false,
    }
}

/// One pulse per `(key, high_at, low_at)`, edges fed in time order.
fn play(config: &MechanicsConfig, keys: usize, pulses: &[(u8, u64, u64)]) -> Mechanics {
    let mut edges: Vec<(u64, u8, bool)> = pulses
        .iter()
        .flat_map(|&(k, on, off)| [(on, k, true), (off, k, false)])
        .collect();
    edges.sort_by_key(|e| e.0);
    let mut m = Mechanics::new(keys, config);
    for (t, k, high) in edges {
        m.edge(ms(t), k, high);
    }
    m
}

#[test]
fn default_figures_are_15_ms_press_25_ms_release_8_ms_hold() {
    assert_eq!(KeyMechanics::DEFAULT.press_delay, Duration::from_millis(15));
    assert_eq!(
        KeyMechanics::DEFAULT.release_delay,
        Duration::from_millis(25)
    );
    assert_eq!(KeyMechanics::DEFAULT.min_hold, Duration::from_millis(8));
}

#[test]
fn press_and_release_delays_apply_per_key() {
    let slow = KeyMechanics {
        press_delay: Duration::from_millis(40),
        release_delay: Duration::from_millis(60),
        min_hold: Duration::from_millis(8),
        ..KeyMechanics::DEFAULT
    };
    let config = MechanicsConfig::default().with_key(1, slow);
    let mut m = play(&config, 2, &[(0, 100, 200), (1, 100, 200)]);
    assert_eq!(
        m.finish(ms(1_000)),
        vec![
            down(115, 0, false),
            down(140, 1, false),
            up(225, 0),
            up(260, 1)
        ]
    );
    assert_eq!(m.stats().clean_onsets, 2);
    assert_eq!(m.stats().key_ups, 2);
}

#[test]
fn pulse_shorter_than_min_hold_does_not_sound() {
    let mut m = play(&MechanicsConfig::default(), 1, &[(0, 0, 7)]);
    assert!(m.finish(ms(1_000)).is_empty());
    assert_eq!(m.stats().short_pulses, 1);
    assert_eq!(m.stats().clean_onsets, 0);
}

#[test]
fn pulse_of_exactly_min_hold_sounds() {
    let mut m = play(&MechanicsConfig::default(), 1, &[(0, 0, 8)]);
    assert_eq!(m.finish(ms(1_000)), vec![down(15, 0, false), up(33, 0)]);
}

#[test]
fn repress_before_the_key_returns_is_a_smear() {
    // Released at 100, fully up at 125; pressed again at 110.
    let mut m = play(
        &MechanicsConfig::default(),
        1,
        &[(0, 0, 100), (0, 110, 200)],
    );
    let events = m.finish(ms(1_000));
    assert_eq!(
        events,
        vec![down(15, 0, false), down(125, 0, true), up(225, 0)],
        "no key-up between: the key never came back"
    );
    let s = m.stats();
    assert_eq!(
        (s.clean_onsets, s.smeared_presses, s.smeared_onsets),
        (1, 1, 1)
    );
}

#[test]
fn repress_after_the_key_returns_is_a_clean_onset() {
    // Released at 100, fully up at 125; pressed again at 125.
    let mut m = play(
        &MechanicsConfig::default(),
        1,
        &[(0, 0, 100), (0, 125, 200)],
    );
    assert_eq!(
        m.finish(ms(1_000)),
        vec![
            down(15, 0, false),
            up(125, 0),
            down(140, 0, false),
            up(225, 0)
        ]
    );
    let s = m.stats();
    assert_eq!((s.clean_onsets, s.smeared_presses), (2, 0));
}

#[test]
fn short_repress_during_return_is_a_smear_without_sound_and_delays_the_return() {
    let mut m = play(
        &MechanicsConfig::default(),
        1,
        &[(0, 0, 100), (0, 110, 115)],
    );
    assert_eq!(m.finish(ms(1_000)), vec![down(15, 0, false), up(140, 0)]);
    let s = m.stats();
    assert_eq!(
        (s.smeared_presses, s.smeared_onsets, s.short_pulses),
        (1, 0, 1)
    );
}

#[test]
fn strike_is_committed_once_held_min_hold() {
    // High 10 ms (≥ 8), low before the 15 ms press delay: it still sounds at 15.
    let mut m = play(&MechanicsConfig::default(), 1, &[(0, 0, 10)]);
    assert_eq!(m.finish(ms(1_000)), vec![down(15, 0, false), up(35, 0)]);
}

#[test]
fn finish_closes_a_held_key() {
    let mut m = Mechanics::new(1, &MechanicsConfig::default());
    m.edge(ms(0), 0, true);
    assert!(m.pin_high(0));
    assert_eq!(m.finish(ms(500)), vec![down(15, 0, false), up(525, 0)]);
    assert_eq!(m.stats().stuck_at_end, 1);
    assert!(!m.pin_high(0));
}
