//! Finger boards on a bad bus: the I2C output's own driver path ([`BoardsOut`] on
//! [`ResilientBoards`]) over the virtual robot's bus, with faults injected between them:
//! NACKs, timeouts, and a board that vanishes mid-piece and comes back power-cycled.
//! Nothing panics, no key stays down, the other boards play every write they play on a good
//! bus, and the board that came back is re-initialised.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};
use orch_core::Instant;
use orch_io::{BoardStats, BoardsOut, TimedBus};
use orch_perform::{song_events, thesis_config, Performer, Setup};
use orch_seq::Song;
use orch_sim::{BusError, Keep, SimConfig, VirtualRobot};

/// A fault the bus injects.
#[derive(Clone, Copy, Debug)]
enum Fault {
    /// Every `n`th transaction to `address` fails once with a NACK.
    Nack { address: u8, every: u32 },
    /// Every `n`th transaction to `address` fails once with a timeout.
    Timeout { address: u8, every: u32 },
    /// `address` answers nothing from `from_us` to `to_us`, and comes back in its power-up
    /// state (every pin an input, the outputs all 1s).
    Vanish {
        address: u8,
        from_us: u64,
        to_us: u64,
    },
}

#[derive(Debug)]
enum FaultError {
    Bus(BusError),
    Injected(ErrorKind),
}

impl embedded_hal::i2c::Error for FaultError {
    fn kind(&self) -> ErrorKind {
        match self {
            FaultError::Bus(e) => e.kind(),
            FaultError::Injected(k) => *k,
        }
    }
}

/// The virtual robot's bus with faults between it and the driver.
struct FaultyBus {
    robot: VirtualRobot,
    faults: Vec<Fault>,
    now_us: u64,
    count: u32,
    returned: bool,
    pauses: u32,
    /// Every board's (address, outputs, configuration) when the bus is dropped.
    at_drop: Arc<Mutex<Vec<(u8, u16, u16)>>>,
}

impl Drop for FaultyBus {
    fn drop(&mut self) {
        *self.at_drop.lock().unwrap() = self
            .robot
            .bus()
            .devices()
            .iter()
            .map(|d| (d.address(), d.output(), d.configuration()))
            .collect();
    }
}

impl FaultyBus {
    fn new(faults: Vec<Fault>) -> Self {
        Self {
            robot: VirtualRobot::new(sim()),
            faults,
            now_us: 0,
            count: 0,
            returned: false,
            pauses: 0,
            at_drop: Arc::default(),
        }
    }
}

impl ErrorType for FaultyBus {
    type Error = FaultError;
}

impl I2c for FaultyBus {
    fn transaction(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), FaultError> {
        self.count += 1;
        for f in self.faults.clone() {
            match f {
                Fault::Nack { address: a, every } if a == address && self.count % every == 0 => {
                    return Err(FaultError::Injected(ErrorKind::NoAcknowledge(
                        NoAcknowledgeSource::Data,
                    )));
                }
                Fault::Timeout { address: a, every } if a == address && self.count % every == 0 => {
                    return Err(FaultError::Injected(ErrorKind::Other));
                }
                Fault::Vanish {
                    address: a,
                    from_us,
                    to_us,
                } if a == address && self.now_us >= from_us => {
                    if self.now_us < to_us {
                        return Err(FaultError::Injected(ErrorKind::NoAcknowledge(
                            NoAcknowledgeSource::Address,
                        )));
                    }
                    if !self.returned {
                        self.returned = true;
                        self.robot
                            .bus_mut()
                            .device_mut(address)
                            .expect("the board is on the bus")
                            .reset();
                    }
                }
                _ => {}
            }
        }
        self.robot
            .transaction(address, ops)
            .map_err(FaultError::Bus)
    }
}

impl TimedBus for FaultyBus {
    fn set_time(&mut self, t_us: u64) {
        self.now_us = t_us;
        self.robot.set_time(Instant::from_micros(t_us));
    }
    fn pause(&mut self, _d: Duration) {
        self.pauses += 1;
    }
}

fn sim() -> SimConfig {
    SimConfig {
        keep: Keep::Everything,
        ..SimConfig::thesis()
    }
}

fn song() -> Song {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/midi");
    Song::parse(&std::fs::read(dir.join("bach-invention-01.mid")).unwrap()).unwrap()
}

/// Plays the piece on boards behind `faults`; returns every acknowledged write as
/// (address, bytes), the boards' figures, the final state of every board and the time of
/// the first write after `t_us` to each address.
struct Run {
    writes: Vec<(u64, u8, Vec<u8>)>,
    stats: BoardStats,
    boards: Vec<(u8, u16, u16)>,
    pauses: u32,
    report_adds_up: bool,
}

fn run(faults: Vec<Fault>) -> Run {
    let song = song();
    let setup = Setup::thesis().with_keep(Keep::Presses);
    let mut out = BoardsOut::new(setup.config, FaultyBus::new(faults)).unwrap();
    let played = Performer::new(&setup, song_events(&song), song.notes())
        .midi(&mut out)
        .run()
        .expect("a bad bus never stops the performance");
    let stats = out.boards().stats();
    let bus = out.boards().set().bus();
    let writes = bus
        .robot
        .bus()
        .log()
        .iter()
        .map(|w| (w.end.as_micros(), w.address, w.bytes.clone()))
        .collect();
    let boards = bus
        .robot
        .bus()
        .devices()
        .iter()
        .map(|d| (d.address(), d.output(), d.configuration()))
        .collect();
    Run {
        writes,
        stats,
        boards,
        pauses: bus.pauses,
        report_adds_up: played.report(None).adds_up(),
    }
}

fn to(writes: &[(u64, u8, Vec<u8>)], address: u8) -> Vec<Vec<u8>> {
    writes
        .iter()
        .filter(|w| w.1 == address)
        .map(|w| w.2.clone())
        .collect()
}

/// Every board ends with all 16 pins outputs, driven low: no key down, none floating.
fn all_keys_up(r: &Run) {
    for &(address, output, configuration) in &r.boards {
        assert_eq!(
            (output, configuration),
            (0, 0),
            "board {address:#04x}: outputs {output:#06x}, configuration {configuration:#06x}"
        );
    }
}

#[test]
fn transient_nacks_and_timeouts_are_retried_and_change_nothing() {
    let clean = run(vec![]);
    assert!(clean.writes.len() > 800, "{}", clean.writes.len());
    assert_eq!(clean.stats, BoardStats::default());
    all_keys_up(&clean);
    let faulty = run(vec![
        Fault::Nack {
            address: 0x22,
            every: 7,
        },
        Fault::Timeout {
            address: 0x23,
            every: 11,
        },
    ]);
    assert!(faulty.report_adds_up);
    assert!(faulty.stats.retries > 20, "{:?}", faulty.stats);
    assert_eq!(faulty.stats.retries, faulty.stats.failed_writes);
    assert_eq!(faulty.pauses as u64, faulty.stats.retries);
    assert_eq!(faulty.stats.lost, 0, "a single failure never loses a board");
    for a in 0x21..=0x24 {
        assert_eq!(
            to(&faulty.writes, a),
            to(&clean.writes, a),
            "board {a:#04x}"
        );
    }
    all_keys_up(&faulty);
}

#[test]
fn a_board_that_vanishes_mid_piece_is_reported_once_played_around_and_reinitialised() {
    let clean = run(vec![]);
    let (from_us, to_us) = (10_000_000, 20_000_000);
    let r = run(vec![Fault::Vanish {
        address: 0x22,
        from_us,
        to_us,
    }]);
    assert!(r.report_adds_up);
    assert_eq!(r.stats.lost, 1, "lost once, said once: {:?}", r.stats);
    assert_eq!(r.stats.reinitialised, 1, "{:?}", r.stats);
    // The other boards played on: every write they get on a good bus, in order.
    for a in [0x21, 0x23, 0x24] {
        assert_eq!(to(&r.writes, a), to(&clean.writes, a), "board {a:#04x}");
    }
    // The lost board: nothing while it was away, then initialised as at power-up (outputs to
    // 0 first, then pins outputs) before anything else.
    let lost: Vec<&(u64, u8, Vec<u8>)> = r.writes.iter().filter(|w| w.1 == 0x22).collect();
    assert!(lost.iter().all(|w| w.0 < from_us + 1_000 || w.0 >= to_us));
    let back = lost
        .iter()
        .position(|w| w.0 >= to_us)
        .expect("written after its return");
    assert_eq!(lost[back].2, vec![0x02, 0, 0]);
    assert_eq!(lost[back + 1].2, vec![0x06, 0, 0]);
    assert!(
        lost.len() > back + 10,
        "it plays again after its return: {} writes",
        lost.len() - back
    );
    // It played before it vanished.
    assert!(back > 10);
    all_keys_up(&r);
}

#[test]
fn a_board_that_never_answers_is_played_around_and_none_that_answers_is_an_error() {
    let r = run(vec![Fault::Vanish {
        address: 0x21,
        from_us: 0,
        to_us: u64::MAX,
    }]);
    assert_eq!(r.stats.lost, 1);
    assert_eq!(r.stats.reinitialised, 0);
    assert!(to(&r.writes, 0x21).is_empty());
    assert!(to(&r.writes, 0x22).len() > 100);
    // Never configured, so never driving: its pins stay inputs.
    let b = r.boards.iter().find(|b| b.0 == 0x21).unwrap();
    assert_eq!(b.2, 0xFFFF);
    let none: Vec<Fault> = (0x21..=0x24)
        .map(|address| Fault::Vanish {
            address,
            from_us: 0,
            to_us: u64::MAX,
        })
        .collect();
    let Err(e) = BoardsOut::new(thesis_config(), FaultyBus::new(none)) else {
        panic!("no board answers: an error");
    };
    assert!(e.to_string().contains("no finger board answered"), "{e}");
}

/// An output that panics at its `n`th send: a bug on the sender's thread.
struct PanicAt<M> {
    inner: M,
    n: usize,
}

impl<M: orch_perform::MidiOut> orch_perform::MidiOut for PanicAt<M> {
    type Error = M::Error;
    fn send(&mut self, t_us: u64, bytes: &[u8]) -> Result<(), M::Error> {
        self.n -= 1;
        assert!(self.n > 0, "a bug in the middle of the piece");
        self.inner.send(t_us, bytes)
    }
    fn next_deadline(&self) -> Option<u64> {
        self.inner.next_deadline()
    }
    fn poll(&mut self, t_us: u64) -> Result<(), M::Error> {
        self.inner.poll(t_us)
    }
}

#[test]
fn a_panic_in_the_middle_of_a_piece_lets_go_of_every_finger_as_it_unwinds() {
    let song = song();
    let setup = Setup::thesis();
    let bus = FaultyBus::new(vec![]);
    let at_drop = Arc::clone(&bus.at_drop);
    let out = BoardsOut::new(setup.config, bus).unwrap();
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let mut out = PanicAt { inner: out, n: 301 };
        let _ = Performer::new(&setup, song_events(&song), song.notes())
            .midi(&mut out)
            .run();
    }));
    assert!(result.is_err());
    // (Without the release on drop, keys are down here: the test fails.)
    let boards = at_drop.lock().unwrap().clone();
    assert_eq!(boards.len(), 4);
    for (address, output, configuration) in boards {
        assert_eq!((address, output, configuration), (address, 0, 0));
    }
}

#[test]
fn stopping_during_a_chord_lets_every_finger_up_before_the_performance_returns() {
    use orch_perform::{Control, ScoreEvent};
    use orch_seq::WireBytes;
    // C3 E3 G3 C4 on boards 0x21 and 0x22 from 0.25 s, held 20 s; stopped at 2 s (as `q`,
    // SIGINT or SIGTERM stop `orch play`).
    let mut ev = Vec::new();
    for (at, status, vel) in [(250_000, 0x90, 100), (20_250_000, 0x80, 0)] {
        for n in [48u8, 52, 55, 60] {
            ev.push(ScoreEvent {
                score_us: at,
                bytes: WireBytes::new(&[status, n, vel]),
            });
        }
    }
    let setup = Setup::thesis();
    let mut out = BoardsOut::new(setup.config, FaultyBus::new(vec![])).unwrap();
    let control = Control::new();
    let stopper = std::sync::Arc::clone(&control);
    let mut down_before_stop = 0;
    let mut on_live = |l: &orch_perform::Live| {
        if l.song_us >= 2_000_000 {
            down_before_stop = down_before_stop.max(l.keys_down.iter().filter(|d| **d).count());
            stopper.stop();
        }
    };
    let played = Performer::new(&setup, ev.into_iter(), 4)
        .control(&control)
        .midi(&mut out)
        .live(&mut on_live)
        .run()
        .unwrap();
    assert!(played.stopped);
    assert_eq!(
        down_before_stop, 4,
        "the chord was down when it was stopped"
    );
    let bus = out.boards().set().bus();
    let log = bus.robot.bus().log();
    // The chord went out (two boards), and the last write to each board let every finger up,
    // before the 20 s the chord was written for.
    for a in [0x21u8, 0x22] {
        let writes: Vec<_> = log.iter().filter(|w| w.address == a).collect();
        assert!(writes.iter().any(|w| w.bytes[0] == 0x02 && w.driven != 0));
        let last = writes.last().unwrap();
        assert_eq!(last.bytes, vec![0x02, 0, 0], "board {a:#04x}");
        assert!(last.end.as_micros() < 3_000_000, "{:?}", last.end);
    }
    for d in bus.robot.bus().devices() {
        assert_eq!(d.driven(), 0, "board {:#04x}", d.address());
    }
}
