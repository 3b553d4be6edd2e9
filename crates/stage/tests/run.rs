//! The live interpreter's loop: the input's bytes played, a front end's requests taken (the
//! counters, a robot file read again, stop), what happened said, the front end's hook after
//! each step, and the watchdog's deadline kept while the input is silent.

use std::path::PathBuf;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use orch_io::{InEvent, OutSpec};
use orch_robot::{default_toml, BoardKind, Robot};
use orch_stage::run::{counters, end_state, End, Event, Loop, Said};
use orch_stage::{LiveBoards, LiveRobot};

fn live(robot: Robot) -> LiveRobot {
    let boards = LiveBoards::open(&OutSpec::parse("sim").unwrap(), &robot).unwrap();
    LiveRobot::new(robot, boards, Vec::new(), false, None).unwrap()
}

/// Runs the loop on `events` (then the input's end), with the robot file `robot_path`;
/// what it said (in words) and how it ended, and the hook's count of steps.
fn run(
    live: &mut LiveRobot,
    robot_path: Option<PathBuf>,
    events: Vec<Event>,
    after: &mut dyn FnMut(&LiveRobot) -> Option<End>,
) -> (Vec<String>, End) {
    let (tx, rx) = mpsc::channel();
    for e in events {
        tx.send(e).unwrap();
    }
    tx.send(Event::In(InEvent::End)).unwrap();
    let mut said = Vec::new();
    let end = Loop {
        robot_path,
        every: Duration::from_millis(5),
        verbose: false,
        say: &mut |s: Said| said.push(s.to_string()),
        after,
    }
    .run(live, &rx);
    (said, end)
}

fn bytes(b: &[u8]) -> Event {
    Event::In(InEvent::Bytes {
        at: Instant::now(),
        bytes: b.to_vec(),
    })
}

#[test]
fn bytes_play_the_counters_are_said_and_the_input_s_end_ends_it() {
    let mut live = live(Robot::thesis());
    let mut steps = 0;
    let (said, end) = run(
        &mut live,
        None,
        vec![bytes(&[0x90, 60, 100]), Event::Counters, Event::Reload],
        &mut |_| {
            steps += 1;
            None
        },
    );
    assert!(matches!(end, End::Input), "{end:?}");
    assert_eq!(steps, 3, "the hook after each step");
    assert_eq!(said.len(), 2, "{said:?}");
    assert!(
        said[0].starts_with("3 bytes in 1 reads; 1 messages;"),
        "{}",
        said[0]
    );
    assert!(said[0].contains("1 notes: 1 sounded"), "{}", said[0]);
    assert!(said[0].contains("1 keys down"), "{}", said[0]);
    assert_eq!(said[0], counters(&live));
    assert_eq!(
        said[1],
        "no --robot file to read again; the thesis's robot stays"
    );
    // Middle C is down on board 0x22 until the robot is stopped.
    assert!(end_state(&live)
        .iter()
        .any(|b| b.address == 0x22 && b.outputs == 1 << 8));
    live.stop().unwrap();
    assert!(end_state(&live).iter().all(|b| b.outputs == 0));
}

#[test]
fn stop_and_the_front_end_end_it_and_a_robot_file_read_again_takes_over() {
    let mut live = live(Robot::thesis());
    let (_, end) = run(
        &mut live,
        None,
        vec![Event::Stop, bytes(&[0x90])],
        &mut |_| None,
    );
    assert!(matches!(end, End::Stopped), "{end:?}");
    let (_, end) = run(&mut live, None, vec![bytes(&[0xF8])], &mut |_| {
        Some(End::Quit)
    });
    assert!(matches!(end, End::Quit), "{end:?}");

    let path = testkit::in_test("robot.toml");
    std::fs::write(&path, "not = [a robot").unwrap();
    let (said, _) = run(
        &mut live,
        Some(path.clone()),
        vec![Event::Reload],
        &mut |_| None,
    );
    assert!(
        said[0].contains("robot.toml refused, the robot stays as it was"),
        "{said:?}"
    );
    std::fs::write(&path, default_toml(BoardKind::OnOff)).unwrap();
    let (said, _) = run(&mut live, Some(path), vec![Event::Reload], &mut |_| None);
    assert!(said[0].ends_with("robot.toml read; it takes over when no key is down"));
    assert_eq!(
        said[1], "the new robot configuration is in force",
        "{said:?}"
    );
}

#[test]
fn a_silent_input_lets_the_watchdog_release_the_keys_at_its_deadline() {
    let mut live = live(Robot::thesis());
    // Active Sensing seen: the watchdog lets go 300 ms after the last byte.
    let (tx, rx) = mpsc::channel::<Event>();
    let t0 = Instant::now();
    tx.send(bytes(&[0xFE, 0x90, 60, 100])).unwrap();
    let mut released = None;
    let end = Loop {
        robot_path: None,
        // Longer than the deadline: the loop wakes for the deadline itself.
        every: Duration::from_secs(5),
        verbose: false,
        say: &mut |_| {},
        after: &mut |live: &LiveRobot| {
            (!live.keys_down().iter().any(|d| *d)).then(|| {
                released = Some(t0.elapsed());
                End::Quit
            })
        },
    }
    .run(&mut live, &rx);
    assert!(matches!(end, End::Quit), "{end:?}");
    let at = released.expect("released");
    assert!(
        at >= Duration::from_millis(300),
        "not before the watchdog: {at:?}"
    );
    assert!(
        at < Duration::from_secs(3),
        "at its deadline, not the loop's wait: {at:?}"
    );
    drop(tx);
}
