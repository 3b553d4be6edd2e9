//! PCA9685 (PWM) finger boards driven from this host: the I2C output's own path
//! ([`BoardsOut`] on [`ResilientBoards`]) over the virtual robot's bus, its boards PCA9685
//! models. Every strike reaches its channel at its velocity's duty and sounds at that
//! velocity; a board that vanishes and comes back power-cycled (asleep, every channel off) is
//! initialised again and given the duties it should hold; at the end every channel is off.

use std::time::Duration;

use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};
use orch_core::{BoardKind, Config, Dynamics, Instant};
use orch_io::{BoardsOut, TimedBus};
use orch_perform::{thesis_config, Performer, ScoreEvent, Setup};
use orch_seq::WireBytes;
use orch_sim::{BusClock, BusError, Keep, SimConfig, VirtualRobot};

/// The virtual robot's bus, one PWM board of which may vanish for a while.
struct SimBus {
    robot: VirtualRobot,
    now_us: u64,
    vanish: Option<(u8, u64, u64)>,
    came_back: bool,
}

#[derive(Debug)]
enum Fault {
    Bus(BusError),
    Gone,
}

impl embedded_hal::i2c::Error for Fault {
    fn kind(&self) -> ErrorKind {
        match self {
            Fault::Bus(e) => e.kind(),
            Fault::Gone => ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address),
        }
    }
}

impl ErrorType for SimBus {
    type Error = Fault;
}

impl I2c for SimBus {
    fn transaction(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), Fault> {
        if let Some((a, from, to)) = self.vanish {
            if a == address && self.now_us >= from {
                if self.now_us < to {
                    return Err(Fault::Gone);
                }
                if !self.came_back {
                    self.came_back = true;
                    // Back from a power cycle: the chip's reset state.
                    self.robot.bus_mut().pca9685_mut(a).unwrap().reset();
                }
            }
        }
        self.robot.transaction(address, ops).map_err(Fault::Bus)
    }
}

impl TimedBus for SimBus {
    fn set_time(&mut self, t_us: u64) {
        self.now_us = t_us;
        self.robot.set_time(Instant::from_micros(t_us));
    }
    fn pause(&mut self, _d: Duration) {}
}

fn config() -> Config<16> {
    let mut c = Config {
        dynamics: Dynamics::PWM,
        ..thesis_config()
    };
    for (i, b) in c.layout.boards.iter_mut().take(4).enumerate() {
        b.address = 0x40 + i as u8;
    }
    c
}

fn sim(config: &Config<16>, keep: Keep) -> SimConfig {
    let sim = SimConfig {
        clock: BusClock::from_hz(1_000_000),
        kinds: vec![BoardKind::Pwm; 4],
        keep,
        ..SimConfig::thesis().with_layout(&config.layout)
    };
    SimConfig {
        boards: sim.boards[..4].to_vec(),
        ..sim
    }
}

/// Notes one every 250 ms on keys across every board, velocities 1..=127.
fn song() -> (Vec<ScoreEvent>, usize) {
    let mut v = Vec::new();
    let notes: Vec<(u64, u8, u8)> = (0..40u64)
        .map(|i| {
            (
                200 + i * 250,
                36 + (i * 7 % 61) as u8,
                (1 + i * 13 % 127) as u8,
            )
        })
        .collect();
    for &(ms, n, vel) in &notes {
        v.push(ScoreEvent {
            score_us: ms * 1000,
            bytes: WireBytes::new(&[0x90, n, vel]),
        });
        v.push(ScoreEvent {
            score_us: (ms + 150) * 1000,
            bytes: WireBytes::new(&[0x80, n, 0]),
        });
    }
    v.sort_by_key(|e| e.score_us);
    (v, notes.len())
}

fn play(vanish: Option<(u8, u64, u64)>) -> (BoardsOut<SimBus>, orch_perform::Played) {
    let config = config();
    let setup = Setup::new(config, sim(&config, Keep::Presses));
    let bus = SimBus {
        robot: VirtualRobot::new(sim(&config, Keep::Everything)),
        now_us: 0,
        vanish,
        came_back: false,
    };
    let mut out = BoardsOut::with_kinds(config, &[BoardKind::Pwm; 4], 1526, bus).unwrap();
    let (events, notes) = song();
    let played = Performer::new(&setup, events.into_iter(), notes)
        .midi(&mut out)
        .run()
        .expect("plays");
    (out, played)
}

#[test]
fn every_strike_reaches_its_channel_at_its_velocitys_duty_and_every_channel_ends_off() {
    let (out, played) = play(None);
    let robot = &out.boards().set().bus().robot;
    let presses = robot.mechanics().presses();
    assert_eq!(presses.len(), 40);
    let asked: Vec<u8> = played.records.iter().map(|r| r.velocity).collect();
    let mut heard: Vec<(orch_sim::SimTime, u8)> = presses
        .iter()
        .map(|p| (p.pin_high, p.velocity().expect("every strike sounds")))
        .collect();
    heard.sort();
    for (h, a) in heard.iter().zip(&asked) {
        assert!(h.1.abs_diff(*a) <= 1, "asked {a}, heard {}", h.1);
    }
    for i in 0..4 {
        let chip = robot.pwm_board(i).unwrap();
        assert_eq!(chip.duties(), [0; 16], "board {i}");
        assert_eq!(chip.register(0xFE), 3, "1526 Hz");
    }
    assert_eq!(out.boards().stats().lost, 0);
}

#[test]
fn a_pwm_board_that_comes_back_power_cycled_is_initialised_again() {
    // 0x41 (keys 16..=31) is gone from 2 s to 4 s, and comes back asleep, all off.
    let (out, _) = play(Some((0x41, 2_000_000, 4_000_000)));
    let stats = out.boards().stats();
    assert_eq!((stats.lost, stats.reinitialised), (1, 1), "{stats:?}");
    let robot = &out.boards().set().bus().robot;
    let chip = robot.pwm_board(1).unwrap();
    assert!(!chip.sleeping(), "woken by the re-initialisation");
    assert_eq!(chip.register(0xFE), 3);
    // Its keys sound again after it came back.
    let later = robot
        .mechanics()
        .presses()
        .iter()
        .filter(|p| (16..32).contains(&p.key) && p.pin_high.as_micros() > 4_000_000)
        .filter(|p| p.sounded.is_some())
        .count();
    assert!(later > 0);
    for i in 0..4 {
        assert_eq!(robot.pwm_board(i).unwrap().duties(), [0; 16], "board {i}");
    }
}
