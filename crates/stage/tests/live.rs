//! The live interpreter loop's public face: bytes in at wall times, board writes out to the
//! log (a chord on one board is one write), timers at their deadlines, a robot read again
//! swapped in only when every key is up, the input lost or stopped: every key released.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use orch_io::OutSpec;
use orch_robot::{default_toml, BoardKind, Robot};
use orch_stage::{BoardWrite, LiveBoards, LiveRobot, ReloadRefused};

fn live(robot: Robot) -> (LiveRobot, Arc<Mutex<Vec<BoardWrite>>>) {
    let writes = Arc::new(Mutex::new(Vec::new()));
    let log = Arc::clone(&writes);
    let boards = LiveBoards::open(&OutSpec::parse("sim").unwrap(), &robot).unwrap();
    let live = LiveRobot::new(
        robot,
        boards,
        Vec::new(),
        false,
        Some(Box::new(move |w: &BoardWrite| log.lock().unwrap().push(*w))),
    )
    .unwrap();
    (live, writes)
}

#[test]
fn a_chord_is_one_write_and_stop_releases_every_key() {
    let (mut live, writes) = live(Robot::thesis());
    let t0 = Instant::now();
    live.bytes(t0, &[0x90, 60, 100, 64, 100]).unwrap();
    {
        let w = writes.lock().unwrap();
        // Middle C and E on board 0x22: the first note's write, then the chord's.
        assert_eq!(
            w.last().map(|w| (w.address, w.outputs)),
            Some((0x22, (1 << 8) | (1 << 12)))
        );
        assert_eq!(w.last().unwrap().byte, Some(4));
    }
    assert_eq!(live.keys_down().iter().filter(|d| **d).count(), 2);
    live.stop().unwrap();
    assert!(live.outputs().iter().all(|&(_, o)| o == 0));
    assert_eq!(
        writes
            .lock()
            .unwrap()
            .last()
            .map(|w| (w.address, w.outputs, w.byte)),
        Some((0x22, 0, None))
    );
}

#[test]
fn the_input_lost_releases_every_key_and_forgets_the_running_status() {
    let (mut live, _) = live(Robot::thesis());
    let t0 = Instant::now();
    live.bytes(t0, &[0x90, 60, 100, 62]).unwrap();
    live.line_lost().unwrap();
    assert!(live.keys_down().iter().all(|d| !d));
    assert_eq!(live.lost(), (1, 1), "one loss, one message cut off");
    // The new connection's data bytes under no status play nothing.
    live.bytes(t0 + Duration::from_millis(10), &[64, 100])
        .unwrap();
    assert!(live.keys_down().iter().all(|d| !d));
}

#[test]
fn a_robot_read_again_takes_over_only_when_every_key_is_up_and_never_changes_board_kinds() {
    let (mut live, _) = live(Robot::thesis());
    let pwm = Robot::from_toml(&default_toml(BoardKind::Pwm)).unwrap();
    assert_eq!(live.reload(pwm), Err(ReloadRefused::ChangesKinds));
    let t0 = Instant::now();
    live.bytes(t0, &[0x90, 60, 100]).unwrap();
    let narrower = Robot::from_toml("[guard]\nmax_keys_down = 4\n").unwrap();
    live.reload(narrower).unwrap();
    assert!(!live.apply_pending().unwrap(), "a key is down");
    assert!(!live.took_over());
    live.bytes(t0 + Duration::from_millis(1), &[0x80, 60, 0])
        .unwrap();
    // Released 1 ms after the first byte; its rest (60 ms) is over at a tick 80 ms after it.
    std::thread::sleep(Duration::from_millis(80));
    live.tick().unwrap();
    assert!(live.took_over(), "every key up: the new robot is in force");
    assert_eq!(live.robot().config.guard.max_keys_down, 4);
    assert_eq!(
        live.totals().note_ons,
        1,
        "the counts go on across the swap"
    );
}
