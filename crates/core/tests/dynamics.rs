//! Guards dynamics: a press on a PWM key is a strike at the velocity's duty on the key's
//! curve for the strike time, then a hold, then 0; the curve never falls and starts at the
//! softest duty that sounds; the guard counts current (the power budget) and energy (the duty
//! limit) instead of keys; on/off keys play exactly as without dynamics.
//!
//! The duties are re-typed here from the module docs (45 % = 1843, 35 % = 1433 in 4095ths), not
//! read from the crate's constants.
#![cfg(feature = "dynamics")]

mod common;

use common::ms;
use orch_core::{
    Config, ConfigError, Duration, Duty, DutyLimit, Dynamics, DynamicsError, GuardConfig,
    Interpreter, KeyPhase, Recording, Touch,
};

const SOFTEST: u16 = 1843; // 45 %
const HOLD: u16 = 1433; // 35 %
const FULL: u16 = 4095;
const STRIKE_MS: u64 = 40;

/// Middle C: key 24, board 1, output 8.
const C4: u8 = 60;

fn pwm(guard: GuardConfig) -> Config<4> {
    Config {
        guard,
        dynamics: Dynamics::PWM,
        ..Config::THESIS
    }
}

fn duty_of(boards: &Recording<64>, note: u8) -> u16 {
    let key = note - 36;
    boards.duties(key / 16)[key as usize % 16].get()
}

#[test]
fn a_velocity_sweep_gives_strike_duties_that_never_fall_from_the_softest() {
    let mut last = 0;
    for v in 1..=127u8 {
        let mut robot: Interpreter = Interpreter::new(pwm(GuardConfig::DEFAULT)).unwrap();
        let mut boards = Recording::<64>::new();
        robot.feed_slice(&[0x90, C4, v], ms(0));
        robot.flush_duties(&mut boards).unwrap();
        let d = duty_of(&boards, C4);
        if v == 1 {
            assert_eq!(d, SOFTEST, "velocity 1 is the softest duty that sounds");
        }
        assert!(d >= last, "velocity {v}: {d} fell below {last}");
        last = d;
    }
    assert_eq!(last, FULL, "velocity 127 is the loudest");
}

#[test]
fn a_press_strikes_then_holds_at_the_set_times_then_releases_to_zero() {
    let mut robot: Interpreter = Interpreter::new(pwm(GuardConfig::DEFAULT)).unwrap();
    let mut boards = Recording::<64>::new();
    robot.feed_slice(&[0x90, C4, 127], ms(1_000));
    assert_eq!(robot.flush_duties(&mut boards), Ok(1));
    assert_eq!(duty_of(&boards, C4), FULL);
    let write = boards.writes().last().unwrap();
    assert_eq!(write.board.address, 0x22);
    assert_eq!(
        write.duties.unwrap()[8].get(),
        FULL,
        "output 8 of board 0x22"
    );
    // The strike ends at its time: the interpreter asks to be woken then.
    assert_eq!(robot.next_deadline(), Some(ms(1_000 + STRIKE_MS)));
    robot.tick(ms(1_000 + STRIKE_MS - 1));
    assert_eq!(robot.flush_duties(&mut boards), Ok(0), "still striking");
    robot.tick(ms(1_000 + STRIKE_MS));
    assert_eq!(robot.flush_duties(&mut boards), Ok(1));
    assert_eq!(duty_of(&boards, C4), HOLD);
    assert_eq!(robot.flush_duties(&mut boards), Ok(0), "nothing changed");
    robot.feed_slice(&[0x80, C4, 0], ms(3_000));
    assert_eq!(robot.flush_duties(&mut boards), Ok(1));
    assert_eq!(duty_of(&boards, C4), 0);
    assert_eq!(boards.outputs(1), 0);
    // A note released within its strike goes to 0 from the strike duty.
    robot.feed_slice(&[0x90, C4, 64], ms(4_000));
    robot.flush_duties(&mut boards).unwrap();
    let strike = duty_of(&boards, C4);
    assert!(strike > SOFTEST && strike < FULL, "{strike}");
    robot.feed_slice(&[0x80, C4, 0], ms(4_030));
    robot.flush_duties(&mut boards).unwrap();
    assert_eq!(duty_of(&boards, C4), 0);
}

#[test]
fn on_off_keys_ignore_velocity_exactly_as_without_dynamics() {
    let mut a: Interpreter = Interpreter::new(Config::THESIS).unwrap();
    let mut b: Interpreter = Interpreter::new(Config::THESIS).unwrap();
    let (mut bits, mut duties) = (Recording::<64>::new(), Recording::<64>::new());
    let stream = [0x90, 60, 1, 62, 127, 0x80, 60, 0];
    for (i, &byte) in stream.iter().enumerate() {
        let t = ms(i as u64 * 17);
        a.feed(byte, t);
        b.feed(byte, t);
        a.flush(&mut bits).unwrap();
        b.flush_duties(&mut duties).unwrap();
    }
    b.tick(ms(500));
    b.flush_duties(&mut duties).unwrap();
    let on_off: Vec<_> = bits.writes().map(|w| (w.board, w.outputs)).collect();
    let from_duties: Vec<_> = duties.writes().map(|w| (w.board, w.outputs)).collect();
    assert_eq!(on_off, from_duties);
    assert_eq!(duty_of(&duties, 62), FULL, "no hold below full power");
}

#[test]
fn a_key_held_at_its_hold_duty_outlives_the_duty_limit_that_cuts_a_full_power_key() {
    // No hold limit, no watchdog: only the duty limit (30 s in 60 s) acts.
    let guard = GuardConfig {
        max_hold: None,
        watchdog: None,
        duty: Some(DutyLimit::DEFAULT),
        ..GuardConfig::DEFAULT
    };
    let mut on_off: Interpreter = Interpreter::new(Config {
        guard,
        ..Config::THESIS
    })
    .unwrap();
    let mut held: Interpreter = Interpreter::new(pwm(guard)).unwrap();
    for r in [&mut on_off, &mut held] {
        r.feed_slice(&[0x90, C4, 127], ms(0));
    }
    // From cold, a key at full power is cut after max_on / (1 − duty) = 60 s.
    let mut t = 0;
    while t <= 180_000 {
        for r in [&mut on_off, &mut held] {
            r.tick(ms(t));
        }
        t += 500;
        if t == 59_500 {
            assert_eq!(on_off.key_phase(24), KeyPhase::Down, "not yet at 59.5 s");
        }
    }
    assert_eq!(on_off.key_phase(24), KeyPhase::Up);
    assert_eq!(on_off.stats().cut_by_duty_limit, 1);
    // At 35 % a key cools faster than it heats: the duty limit never cuts it.
    assert_eq!(held.key_phase(24), KeyPhase::Down, "held at 35 % for 180 s");
    assert_eq!(held.stats().cut_by_duty_limit, 0);
    assert_eq!(held.key_duty(24).get(), HOLD);

    // A hold above the allowed duty (60 % > 50 %) is still cut, later than at full power:
    // 40 ms at full power, then heating at 0.6 − 0.5 = 0.1: (30 s − 0.02 s) / 0.1 after it.
    let mut hot = pwm(guard);
    for k in hot.dynamics.keys.iter_mut() {
        k.softest = Duty::new(2457).unwrap(); // 60 %
        k.hold = Duty::new(2457).unwrap();
    }
    let mut hot: Interpreter = Interpreter::new(hot).unwrap();
    hot.feed_slice(&[0x90, C4, 127], ms(0));
    hot.tick(ms(40));
    let cut = hot.next_deadline().unwrap().as_micros();
    // 60 % of 4095ths is 2457/4095 = 0.6000: the heat rises at 0.1000. The guard takes the
    // allowed duty in 4095ths rounded down, so its cut is a little early (0.12 % here), never
    // late.
    let exact = 40_000 + ((30_000_000u64 - 20_000) * 4095 * 60).div_ceil(2457 * 60 - 30 * 4095);
    assert!(
        cut <= exact && cut * 1000 >= exact * 998,
        "cut at {cut} µs, exact {exact}"
    );
    hot.tick(ms(cut / 1000 + 1));
    assert!(!hot.is_down(24));
    assert_eq!(hot.stats().cut_by_duty_limit, 1);
}

#[test]
fn a_hot_key_cools_by_its_energy_and_is_cut_sooner_when_struck_again() {
    // The heat a released key keeps is what its energy added, less what the allowed duty
    // drained meanwhile: a full-power key held 20 s and struck again at once is cut after
    // (30 − 10) s / 0.5 = 40 s more; a 35 % key held 20 s has no heat left.
    let guard = GuardConfig {
        max_hold: None,
        watchdog: None,
        restrike_gap: Duration::ZERO,
        ..GuardConfig::DEFAULT
    };
    let mut full: Interpreter = Interpreter::new(Config {
        guard,
        ..Config::THESIS
    })
    .unwrap();
    full.feed_slice(&[0x90, C4, 100], ms(0));
    full.feed_slice(&[0x80, C4, 0, 0x90, C4, 100], ms(20_000));
    // (The re-strike waits out the 1 µs rest every release has.)
    full.tick(ms(20_001));
    assert!(full.is_down(24));
    let cut = full.next_deadline().unwrap().as_micros();
    // (It struck at the tick, 20.001 s, having cooled 0.5 ms meanwhile; heat is kept in ms.)
    assert!(cut.abs_diff(60_003_000) <= 1_000, "{cut}");

    let mut soft: Interpreter = Interpreter::new(pwm(guard)).unwrap();
    soft.feed_slice(&[0x90, C4, 100], ms(0));
    soft.feed_slice(&[0x80, C4, 0, 0x90, C4, 100], ms(20_000));
    soft.tick(ms(20_001));
    assert!(soft.is_down(24));
    // Its only deadline is the new strike's end (from its strike 1 µs after 20 s): no duty
    // cut, then none at all.
    assert_eq!(
        soft.next_deadline().map(|d| d.as_micros()),
        Some(20_001_000 + STRIKE_MS * 1000)
    );
    soft.tick(ms(20_100));
    assert_eq!(soft.next_deadline(), None);

    // Held at 60 % (above the allowed 50 %) for 20 s, a key gained only 0.02 s + 19.96 s ×
    // 0.1 ≈ 2.02 s of heat, not the 10 s a full-power key would: struck again, it is cut
    // (30 − 2.02 − 0.02) s / 0.1 + 40 ms ≈ 279.7 s later (199.8 s had it kept 10 s).
    let mut hot = pwm(guard);
    for k in hot.dynamics.keys.iter_mut() {
        k.softest = Duty::new(2457).unwrap(); // 60 %
        k.hold = Duty::new(2457).unwrap();
    }
    let mut hot: Interpreter = Interpreter::new(hot).unwrap();
    hot.feed_slice(&[0x90, C4, 127], ms(0));
    hot.feed_slice(&[0x80, C4, 0, 0x90, C4, 127], ms(20_000));
    hot.tick(ms(20_001));
    hot.tick(ms(20_001 + STRIKE_MS));
    let cut = hot.next_deadline().unwrap().as_micros() - 20_001_000;
    assert!(
        (279_680_000 / 1000 * 997..=279_700_000).contains(&cut),
        "cut {cut} µs after the re-strike"
    );
}

#[test]
fn the_power_budget_refuses_by_current_not_by_keys() {
    // A budget of two keys at full power.
    let guard = GuardConfig {
        max_keys_down: 2,
        ..GuardConfig::DEFAULT
    };
    // Soft notes at 45 % each: four fit (1.8 keys' current), the fifth (2.25) is refused.
    let mut robot: Interpreter = Interpreter::new(pwm(guard)).unwrap();
    robot.feed_slice(&[0x90, 60, 1, 62, 1, 64, 1, 65, 1, 67, 1], ms(0));
    assert_eq!(robot.keys_down(), 4);
    assert_eq!(robot.stats().dropped_power, 1);
    // Loud notes at 100 %: two fit.
    let mut robot: Interpreter = Interpreter::new(pwm(guard)).unwrap();
    robot.feed_slice(&[0x90, 60, 127, 62, 127, 64, 127], ms(0));
    assert_eq!(robot.keys_down(), 2);
    assert_eq!(robot.stats().dropped_power, 1);
    // Once they hold at 35 % (0.7 in all), a loud strike fits again: 1.7 keys.
    robot.tick(ms(STRIKE_MS));
    robot.feed_slice(&[0x90, 65, 127], ms(STRIKE_MS));
    assert_eq!(robot.keys_down(), 3);
    // And a fourth loud one (2.7) does not, while a soft one (2.15) does not either, but at
    // 25 ms later the third has settled to its hold too: 1.05 + 0.45 fits.
    robot.feed_slice(&[0x90, 67, 127, 69, 1], ms(STRIKE_MS + 1));
    assert_eq!(robot.keys_down(), 3);
    assert_eq!(robot.stats().dropped_power, 3);
    robot.tick(ms(2 * STRIKE_MS));
    robot.feed_slice(&[0x90, 69, 1], ms(2 * STRIKE_MS));
    assert_eq!(robot.keys_down(), 4);

    // On/off keys: exactly keys down, whatever the velocity.
    let mut robot: Interpreter = Interpreter::new(Config {
        guard,
        ..Config::THESIS
    })
    .unwrap();
    robot.feed_slice(&[0x90, 60, 1, 62, 1, 64, 1], ms(0));
    assert_eq!(robot.keys_down(), 2);
}

#[test]
fn the_watchdog_and_all_off_take_every_pwm_channel_to_zero() {
    let mut robot: Interpreter = Interpreter::new(pwm(GuardConfig::DEFAULT)).unwrap();
    let mut boards = Recording::<64>::new();
    robot.feed_slice(&[0x90, 36, 90, 60, 20, 96, 127], ms(0));
    robot.flush_duties(&mut boards).unwrap();
    assert!(duty_of(&boards, 36) > 0 && duty_of(&boards, 60) > 0 && duty_of(&boards, 96) > 0);
    // Input stops: the 4 s watchdog releases every key.
    let mut t = 0;
    while let Some(d) = robot.next_deadline() {
        t = d.as_micros() / 1000;
        robot.tick(d);
        robot.flush_duties(&mut boards).unwrap();
        if robot.keys_down() == 0 {
            break;
        }
    }
    assert_eq!(t, 4_000);
    for b in 0..4 {
        assert!(
            boards.duties(b).iter().all(|d| *d == Duty::OFF),
            "board {b}"
        );
    }
    robot.feed_slice(&[0x90, 50, 90], ms(5_000));
    robot.all_off(ms(5_001));
    robot.flush_duties(&mut boards).unwrap();
    assert!(boards.duties(0).iter().all(|d| *d == Duty::OFF));
}

#[test]
fn a_failed_duty_write_is_written_again_by_the_next_flush() {
    let mut robot: Interpreter = Interpreter::new(pwm(GuardConfig::DEFAULT)).unwrap();
    let mut boards = Recording::<64>::new();
    boards.fail(Some(0x22));
    robot.feed_slice(&[0x90, C4, 127, 36, 127], ms(0));
    assert!(robot.flush_duties(&mut boards).is_err());
    boards.fail(None);
    assert_eq!(robot.flush_duties(&mut boards), Ok(1), "board 0x22 again");
    assert_eq!(duty_of(&boards, C4), FULL);
    // After a bus error the front end invalidates the frame: every board is written again.
    robot.frame_mut().invalidate();
    assert_eq!(robot.flush_duties(&mut boards), Ok(4));
}

#[test]
fn bad_dynamics_are_refused_naming_the_key() {
    let mut c = pwm(GuardConfig::DEFAULT);
    c.dynamics.keys[5] = Touch {
        softest: Duty::new(3000).unwrap(),
        loudest: Duty::new(2000).unwrap(),
        hold: Duty::new(1000).unwrap(),
    };
    assert_eq!(
        Interpreter::<4, 61>::new(c).unwrap_err(),
        ConfigError::Dynamics(DynamicsError::CurveFalls { key: 5 })
    );
    let mut c = pwm(GuardConfig::DEFAULT);
    c.dynamics.keys[7].hold = Duty::new(3000).unwrap();
    assert_eq!(
        Interpreter::<4, 61>::new(c).unwrap_err(),
        ConfigError::Dynamics(DynamicsError::HoldAboveStrike { key: 7 })
    );
    let mut c = pwm(GuardConfig::DEFAULT);
    c.dynamics.strike = Duration::from_secs(11);
    assert_eq!(
        Interpreter::<4, 61>::new(c).unwrap_err(),
        ConfigError::Dynamics(DynamicsError::StrikeLongerThanHold)
    );
    assert!(ConfigError::Dynamics(DynamicsError::CurveFalls { key: 5 })
        .to_string()
        .contains("key 5"));
}
