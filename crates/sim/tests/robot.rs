//! The virtual robot through `orch_core::FingerBoards` and through `embedded_hal::i2c::I2c`.

use embedded_hal::i2c::{Error as _, ErrorKind, I2c, NoAcknowledgeSource};
use orch_core::{
    BoardId, Config, Duration, FingerBoards, GuardConfig, Instant, Interpreter, Layout,
};
use orch_sim::pca9555::{CONFIGURATION_0, OUTPUT_PORT_0};
use orch_sim::{
    BusClock, KeyMechanics, MechanicsConfig, Performance, SimConfig, SimTime, SoundEvent,
    SoundKind, VirtualRobot,
};

const BOARD_2: BoardId = BoardId {
    index: 1,
    address: 0x22,
};

fn down(t: SimTime, key: u8) -> SoundEvent {
    SoundEvent {
        time: t,
        key,
        kind: SoundKind::Down,
        smeared: false,
    }
}

#[test]
fn thesis_config_is_four_boards_61_keys_at_83_khz() {
    let config = SimConfig::default();
    assert_eq!(config.clock, BusClock::THESIS);
    let addresses: Vec<u8> = config.boards.iter().map(|b| b.address).collect();
    assert_eq!(addresses, [0x21, 0x22, 0x23, 0x24]);
    let keys: Vec<u8> = config.boards.iter().map(|b| b.keys).collect();
    assert_eq!(keys, [16, 16, 16, 13]);
    assert_eq!(config.keys(), 61);
    assert_eq!(config.mechanics.default, KeyMechanics::DEFAULT);
}

#[test]
fn power_up_boards_drive_nothing_although_outputs_are_high() {
    let mut robot = VirtualRobot::thesis();
    for i in 0..4 {
        let board = robot.board(i).unwrap();
        assert_eq!(board.output(), 0xFFFF);
        assert_eq!(board.configuration(), 0xFFFF);
        assert_eq!(board.driven(), 0);
    }
    // Writing outputs without configuring: the register changes, no pin moves.
    robot.write_board(BOARD_2, 0x0100).unwrap();
    assert_eq!(robot.board(1).unwrap().output(), 0x0100);
    let p = robot.finish(Instant::from_millis(100));
    assert_eq!(p.writes.len(), 1);
    assert!(p.edges.is_empty());
    assert!(p.sounds.is_empty());
}

#[test]
fn key_down_sounds_at_write_completion_plus_press_delay() {
    let mut robot = VirtualRobot::thesis();
    robot.init().unwrap();
    let t = Instant::from_millis(10);
    robot.set_time(t);
    robot.write_board(BOARD_2, 1 << 8).unwrap(); // key 24, middle C
    let completion = SimTime::from(t).plus_nanos(456_000);
    assert_eq!(robot.bus().free_at(), completion);
    robot.set_time(Instant::from_millis(100));
    robot.write_board(BOARD_2, 0).unwrap();
    let p = robot.finish(Instant::from_millis(200));
    assert_eq!(
        p.sounds[0],
        down(completion + Duration::from_millis(15), 24)
    );
    let release_done = SimTime::from_micros(100_456) + Duration::from_millis(25);
    assert_eq!(p.sounds[1].time, release_done);
    assert_eq!(p.sounds[1].kind, SoundKind::Up);
    assert_eq!(p.edges.len(), 2);
    assert_eq!((p.edges[0].time, p.edges[0].key), (completion, Some(24)));
}

#[test]
fn per_key_press_delay_from_config() {
    let slow = KeyMechanics {
        press_delay: Duration::from_millis(40),
        ..KeyMechanics::DEFAULT
    };
    let mut robot = VirtualRobot::new(SimConfig {
        mechanics: MechanicsConfig::default().with_key(24, slow),
        ..SimConfig::thesis()
    });
    robot.init().unwrap();
    robot.set_time(Instant::from_millis(10));
    robot.write_board(BOARD_2, (1 << 8) | (1 << 9)).unwrap();
    let p = robot.finish(Instant::from_millis(200));
    let end = SimTime::from_micros(10_456);
    let downs: Vec<_> = p.clean_onsets().map(|e| (e.key, e.time)).collect();
    assert_eq!(
        downs,
        [
            (25, end + Duration::from_millis(15)),
            (24, end + Duration::from_millis(40))
        ]
    );
}

#[test]
fn writes_flushed_together_serialize_on_the_bus() {
    let mut robot = VirtualRobot::thesis();
    robot.init().unwrap(); // 8 writes: free at 8 × 456 µs
    robot.set_time(Instant::from_millis(10));
    robot
        .write_board(
            BoardId {
                index: 0,
                address: 0x21,
            },
            1,
        )
        .unwrap();
    robot.write_board(BOARD_2, 1).unwrap();
    let p = robot.finish(Instant::from_millis(100));
    let starts: Vec<_> = p.writes[8..].iter().map(|w| w.start.as_micros()).collect();
    assert_eq!(starts, [10_000, 10_456]);
    let onsets: Vec<_> = p
        .clean_onsets()
        .map(|e| (e.key, e.time.as_micros()))
        .collect();
    assert_eq!(onsets, [(0, 10_456 + 15_000), (16, 10_912 + 15_000)]);
}

#[test]
fn absent_board_nacks_through_finger_boards() {
    let mut robot = VirtualRobot::thesis();
    let err = robot
        .write_board(
            BoardId {
                index: 4,
                address: 0x25,
            },
            1,
        )
        .unwrap_err();
    assert_eq!(
        err.kind(),
        ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address)
    );
    assert_eq!(robot.bus().stats().nacks, 1);
}

/// What an embedded-hal board driver would do: knows nothing of the simulator.
fn drive_by_hand<I: I2c>(i2c: &mut I, address: u8, outputs: u16) -> Result<(), I::Error> {
    i2c.write(address, &[OUTPUT_PORT_0, 0, 0])?;
    i2c.write(address, &[CONFIGURATION_0, 0, 0])?;
    let [lo, hi] = outputs.to_le_bytes();
    i2c.write(address, &[OUTPUT_PORT_0, lo, hi])
}

#[test]
fn embedded_hal_transactions_drive_the_robot() {
    let mut robot = VirtualRobot::thesis();
    robot.set_time(Instant::from_millis(1));
    drive_by_hand(robot.bus_mut(), 0x24, 1 << 12).unwrap(); // key 60, the top C
    let mut levels = [0; 2];
    robot
        .bus_mut()
        .write_read(0x24, &[0x00], &mut levels)
        .unwrap();
    assert_eq!(levels, [0x00, 0x10]);
    let p = robot.finish(Instant::from_millis(100));
    // Third write completes at 1 ms + 3 × 456 µs.
    let completion = SimTime::from_micros(1_000 + 3 * 456);
    assert_eq!(
        p.sounds[0],
        down(completion + Duration::from_millis(15), 60)
    );
    assert_eq!(p.summary.mechanics.stuck_at_end, 1);
    assert_eq!(p.summary.bus.transactions, 4);
}

#[test]
fn finger_boards_and_embedded_hal_paths_agree() {
    let mut a = VirtualRobot::thesis();
    a.init().unwrap();
    a.set_time(Instant::from_millis(10));
    a.write_board(BOARD_2, 0x00F0).unwrap();

    let mut b = VirtualRobot::thesis();
    for addr in [0x21, 0x22, 0x23, 0x24] {
        b.bus_mut().write(addr, &[OUTPUT_PORT_0, 0, 0]).unwrap();
        b.bus_mut().write(addr, &[CONFIGURATION_0, 0, 0]).unwrap();
    }
    b.set_time(Instant::from_millis(10));
    b.bus_mut()
        .write(0x22, &[OUTPUT_PORT_0, 0xF0, 0x00])
        .unwrap();

    let end = Instant::from_millis(300);
    assert_eq!(a.finish(end), b.finish(end));
}

/// Plays a MIDI byte stream, `(time in ms, bytes)`, through the interpreter into a robot,
/// meeting every guard deadline on time.
fn perform(guard: GuardConfig, script: &[(u64, &[u8])], end_ms: u64) -> Performance {
    let config = Config {
        guard,
        ..Config::THESIS
    };
    let mut brain = Interpreter::<4, 61>::new(config).unwrap();
    let mut robot = VirtualRobot::new(SimConfig::thesis().with_layout(&Layout::THESIS));
    robot.init().unwrap();
    let end = Instant::from_millis(end_ms);
    let mut script = script.iter().peekable();
    loop {
        let next_input = script.peek().map(|(t, _)| Instant::from_millis(*t));
        let next = match (next_input, brain.next_deadline()) {
            (Some(a), Some(b)) => a.min(b),
            (Some(a), None) => a,
            (None, Some(b)) if b <= end => b,
            _ => break,
        };
        brain.tick(next);
        if next_input == Some(next) {
            let (_, bytes) = script.next().unwrap();
            brain.feed_slice(bytes, next);
        }
        robot.set_time(next);
        brain.flush(&mut robot).unwrap();
    }
    robot.finish(end)
}

const REPEATED_C: &[(u64, &[u8])] = &[
    (0, &[0x90, 60, 100]),
    (30, &[0x80, 60, 0]),
    (40, &[0x90, 60, 100]),
    (100, &[0x80, 60, 0]),
];

#[test]
fn fast_repeated_note_smears_without_the_guard() {
    let p = perform(GuardConfig::OFF, REPEATED_C, 500);
    assert_eq!(p.clean_onsets().count(), 1);
    assert_eq!(p.summary.mechanics.smeared_presses, 1);
    assert_eq!(p.summary.mechanics.smeared_onsets, 1);
}

#[test]
fn fast_repeated_note_strikes_cleanly_twice_with_the_guard() {
    // No late limit: the re-strike waits for its rest however long (with the default 30 ms
    // limit it would be dropped as too fast).
    let patient = GuardConfig {
        late_limit: None,
        ..GuardConfig::DEFAULT
    };
    let p = perform(patient, REPEATED_C, 500);
    assert_eq!(p.clean_onsets().count(), 2);
    assert_eq!(p.summary.mechanics.smeared_presses, 0);
}

#[test]
fn identical_inputs_give_identical_performances() {
    let a = perform(GuardConfig::DEFAULT, REPEATED_C, 500);
    let b = perform(GuardConfig::DEFAULT, REPEATED_C, 500);
    assert_eq!(a, b);
    assert_eq!(a.to_text(), b.to_text());
    let c = perform(GuardConfig::OFF, REPEATED_C, 500);
    assert_ne!(a, c);
}

#[test]
fn performance_serializes_to_json_and_stable_text() {
    let mut robot = VirtualRobot::thesis();
    robot.init().unwrap();
    robot.set_time(Instant::from_millis(10));
    robot.write_board(BOARD_2, 1 << 8).unwrap();
    let p = robot.finish(Instant::from_millis(20));
    let json = serde_json::to_value(&p).unwrap();
    assert_eq!(json["sounds"][0]["time"], 25_456_000u64);
    assert_eq!(json["sounds"][0]["kind"], "down");
    assert_eq!(json["writes"][8]["bytes"], serde_json::json!([2, 0, 1]));
    let text = p.to_text();
    assert!(text.contains("write 10000.000us..10456.000us @0x22 [02 00 01] driven=0x0100\n"));
    assert!(text.contains("edge 10456.000us board 1 @0x22 bit 8 key 24 high\n"));
    assert!(text.contains("sound 25456.000us key 24 down\n"));
}
