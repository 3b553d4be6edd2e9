//! The virtual robot hears dynamics: orch-core's interpreter plays a PWM robot (strike at the
//! velocity's duty, then hold) through orch-boards' real driver onto PCA9685 models, and each
//! strike sounds at a loudness (on the MIDI velocity scale) and a press delay its duty gives; a
//! strike below the key's softest duty makes no sound.

use embedded_hal_mock::eh1::delay::NoopDelay;
use orch_boards::MixedBoardSet;
use orch_core::{BoardKind, Config, Dynamics, Instant, Interpreter, Layout};
use orch_sim::{Keep, KeyMechanics, MechanicsConfig, SimConfig, SimTime, VirtualRobot};

const ADDRESSES: [u8; 4] = [0x40, 0x41, 0x42, 0x43];

fn layout() -> Layout<4> {
    Layout {
        boards: core::array::from_fn(|i| orch_core::BoardSpan {
            address: ADDRESSES[i],
            ..Layout::THESIS.boards[i]
        }),
    }
}

fn robot(mechanics: MechanicsConfig) -> (Interpreter, MixedBoardSet<VirtualRobot, 4>) {
    let sim = SimConfig {
        mechanics,
        kinds: vec![BoardKind::Pwm; 4],
        keep: Keep::Everything,
        ..SimConfig::thesis().with_layout(&layout())
    };
    let boards: Vec<(u8, BoardKind)> = ADDRESSES.iter().map(|&a| (a, BoardKind::Pwm)).collect();
    let mut set = MixedBoardSet::with_boards(VirtualRobot::new(sim), &boards).unwrap();
    set.init(1526, &mut NoopDelay).unwrap();
    let interp = Interpreter::new(Config {
        layout: layout(),
        dynamics: Dynamics::PWM,
        ..Config::THESIS
    })
    .unwrap();
    (interp, set)
}

/// Plays each `(velocity, note)` as a 300 ms note, one a second, waking at every deadline.
fn play(
    notes: &[(u8, u8)],
    interp: &mut Interpreter,
    set: &mut MixedBoardSet<VirtualRobot, 4>,
) -> Vec<orch_sim::Press> {
    let mut step = |t: Instant, bytes: &[u8], interp: &mut Interpreter| {
        while let Some(due) = interp.next_deadline().filter(|&d| d < t) {
            interp.tick(due);
            set.bus_mut().set_time(due);
            interp.flush_duties(set).unwrap();
        }
        interp.feed_slice(bytes, t);
        set.bus_mut().set_time(t);
        interp.flush_duties(set).unwrap();
    };
    for (i, &(v, note)) in notes.iter().enumerate() {
        let t = 1_000 + i as u64 * 1_000;
        step(Instant::from_millis(t), &[0x90, note, v], interp);
        step(Instant::from_millis(t + 300), &[0x80, note, 0], interp);
    }
    let end = Instant::from_millis(1_000 + notes.len() as u64 * 1_000);
    step(end, &[], interp);
    let mut robot = std::mem::replace(set.bus_mut(), VirtualRobot::thesis());
    robot.sync();
    robot.mechanics().presses().to_vec()
}

#[test]
fn a_velocity_sweep_sounds_in_order_of_loudness_at_the_velocity_asked() {
    let (mut interp, mut set) = robot(MechanicsConfig::default());
    let notes: Vec<(u8, u8)> = (1..=127).step_by(6).map(|v| (v, 60)).collect();
    let presses = play(&notes, &mut interp, &mut set);
    assert_eq!(presses.len(), notes.len());
    let mut last = (0u8, u64::MAX);
    for (p, &(v, _)) in presses.iter().zip(&notes) {
        let sounded = p
            .velocity()
            .expect("every strike at or above the softest sounds");
        // The default curve (45..100 %) matches the default mechanics: the velocity asked,
        // within a step of rounding (4095ths).
        assert!(sounded.abs_diff(v) <= 1, "asked {v}, sounded {sounded}");
        let delay = p.sounded.unwrap().nanos_since(p.pin_high);
        assert!(sounded >= last.0 && delay <= last.1, "velocity {v}");
        last = (sounded, delay);
    }
    // The softest strike sounds 30 ms after its pin, the loudest 15 ms.
    let delay_ms = |p: &orch_sim::Press| p.sounded.unwrap().nanos_since(p.pin_high) as f64 / 1e6;
    assert!((delay_ms(&presses[0]) - 30.0).abs() < 0.01);
    assert!((delay_ms(presses.last().unwrap()) - 15.0).abs() < 0.2);
    // The strike's duty is the chip's: 45 % at velocity 1.
    assert_eq!(presses[0].duty, 1843);
}

#[test]
fn a_strike_below_the_keys_own_softest_makes_no_sound() {
    // This key needs 60 % to sound; the robot's curve starts at 45 %.
    let stiff = KeyMechanics {
        softest: 2457,
        ..KeyMechanics::DEFAULT
    };
    let (mut interp, mut set) = robot(MechanicsConfig::default().with_key(24, stiff));
    let presses = play(
        &[(1, 60), (30, 60), (127, 60), (1, 61)],
        &mut interp,
        &mut set,
    );
    assert!(presses[0].too_soft && presses[0].sounded.is_none());
    assert!(
        presses[1].too_soft,
        "velocity 30 is 45 + 13 % = 58 % < 60 %"
    );
    assert_eq!(presses[2].velocity(), Some(127));
    assert!(!presses[3].too_soft, "the next key sounds at 45 %");
    assert_eq!(presses[3].velocity(), Some(1));
    let t = presses[2].sounded.unwrap();
    assert_eq!(t.nanos_since(presses[2].pin_high), 15_000_000);
    let _ = SimTime::ZERO;
}
