//! How a performance is set up: the robot, its virtual copy, compensation, tempo and link;
//! and the planner's rules that follow from them.

use orch_core::{BoardKind, Config, Velocity};
use orch_sim::{Keep, SimConfig};

use crate::link::Link;
use crate::plan::{KeyMap, PlanRules};
use crate::robot::MAX_BOARDS;
use crate::tempo::Tempo;

/// The longest burst the performer plans for on a DIN line: a chord of 16 notes, every
/// message with its status byte (15.4 ms).
const DIN_BURST_US: u64 = 16 * 3 * Link::DIN_BYTE_US;

/// How a performance is set up. Made in one call ([`Setup::for_robot`], [`Setup::new`],
/// [`Setup::thesis`]: compensation on, the tempo as written, a direct link), changed with
/// the `with_*` methods.
#[derive(Clone, Debug)]
pub struct Setup {
    /// The interpreter's configuration (the robot's keys, boards and guard).
    pub config: Config<MAX_BOARDS>,
    /// The virtual robot: boards, bus clock, mechanics.
    pub sim: SimConfig,
    /// Send each key early by its delays.
    pub compensation: bool,
    /// The tempo to start at.
    pub tempo: Tempo,
    /// How the bytes reach the robot.
    pub link: Link,
    /// The robot's groups (a keyboard, a kit, a recorder: robot.toml's), each its name and
    /// its outputs, when it has more than one: the report then says how each fared.
    pub groups: Vec<(String, std::ops::Range<u8>)>,
}

impl Setup {
    /// `config` played on the virtual robot `sim`, compensated, at the written tempo, on a
    /// direct link.
    pub fn new(config: Config<MAX_BOARDS>, sim: SimConfig) -> Self {
        Self {
            config,
            sim,
            compensation: true,
            tempo: Tempo::NORMAL,
            link: Link::Direct,
            groups: Vec::new(),
        }
    }

    /// The thesis's robot ([`thesis_config`](crate::thesis_config), `SimConfig::thesis`),
    /// keeping everything the virtual robot does.
    pub fn thesis() -> Self {
        Self::new(crate::thesis_config(), SimConfig::thesis())
    }

    /// How `robot` (a robot.toml) plays on this host: its keys and its virtual copy, keeping
    /// the presses and the figures (what the report needs), not every write and edge.
    pub fn for_robot(robot: &orch_robot::Robot) -> Self {
        let mut setup = Self::new(robot.config, robot.sim_config()).with_keep(Keep::Presses);
        if robot.groups.len() > 1 {
            let groups = robot.groups.iter();
            setup.groups = groups.map(|g| (g.name.clone(), g.keys())).collect();
        }
        setup
    }

    /// With or without compensation.
    pub fn with_compensation(self, compensation: bool) -> Self {
        Self {
            compensation,
            ..self
        }
    }

    /// Starting at `tempo`.
    pub fn with_tempo(self, tempo: Tempo) -> Self {
        Self { tempo, ..self }
    }

    /// The bytes reach the robot over `link`.
    pub fn with_link(self, link: Link) -> Self {
        Self { link, ..self }
    }

    /// The virtual robot keeps `keep` of the performance.
    pub fn with_keep(mut self, keep: Keep) -> Self {
        self.sim.keep = keep;
        self
    }

    /// One board write on the bus, µs (START, 4 bytes of 9 bits, STOP), rounded up.
    pub fn write_us(&self) -> u64 {
        self.sim.clock.nanos_for_bits(38).div_ceil(1000)
    }

    /// The longest the bus can be busy with one write to every board, µs: a PCA9555's is 38
    /// bit-times, a PCA9685's at most 596 (all 16 channels in one write). A write waits at
    /// most that long behind the others.
    pub fn bus_queue_us(&self) -> u64 {
        let bits: u64 = (0..self.sim.boards.len())
            .map(|i| match self.sim.kind(i) {
                BoardKind::OnOff => 38,
                BoardKind::Pwm => 596,
            })
            .sum();
        self.sim.clock.nanos_for_bits(bits).div_ceil(1000)
    }

    /// The robot's keys, by number.
    fn keys(&self) -> impl Iterator<Item = u8> {
        (0..self.config.keys()).map_while(|k| u8::try_from(k).ok())
    }

    /// The planner's rules for this robot: each key's press lead is its press delay, one
    /// board write and the link's time; its release lead, its release delay and one write.
    pub fn rules(&self) -> PlanRules {
        let c = &self.config;
        let write = self.write_us() + self.link.note_lead_us();
        let m = &self.sim.mechanics;
        let guard = |d: orch_core::Duration| {
            if c.guard.enabled {
                u64::from(d.as_micros())
            } else {
                0
            }
        };
        PlanRules {
            keys: KeyMap::new(*c),
            press_lead_us: self
                .keys()
                .map(|k| u64::from(m.for_key(k).press_delay.as_micros()) + write)
                .collect(),
            press_lead_by_velocity_us: self.press_leads_by_velocity(),
            release_lead_us: self
                .keys()
                .map(|k| u64::from(m.for_key(k).release_delay.as_micros()) + write)
                .collect(),
            // The shortest press that sounds, plus the longest a write can queue on the bus
            // behind the other boards' (the press may reach its pin later than the release),
            // plus, on a DIN line, the longest burst a chord makes (a burst is centred on its
            // time, so a press can arrive half a burst later and its release half a burst
            // earlier than planned).
            min_hold_us: self
                .keys()
                .map(|k| {
                    u64::from(m.for_key(k).min_hold.as_micros())
                        + self.bus_queue_us()
                        + self.din_burst_us()
                })
                .collect(),
            restrike_gap_us: guard(c.guard.restrike_gap),
            min_press_us: guard(c.guard.min_press),
            late_limit_us: c
                .guard
                .late_limit
                .filter(|_| c.guard.enabled)
                .map(|d| u64::from(d.as_micros())),
            overlap: c.overlap,
            compensation: self.compensation,
            // The bus's queue; on a DIN line also half a burst, since a press can arrive that
            // much earlier than planned and find its key resting longer.
            bus_margin_us: self.bus_queue_us() + self.din_burst_us() / 2,
            extra_lookahead_us: self.din_burst_us(),
        }
    }

    /// The longest burst a chord makes on the link: none on a direct one.
    fn din_burst_us(&self) -> u64 {
        match self.link {
            Link::Direct => 0,
            Link::Din => DIN_BURST_US,
        }
    }

    /// Per PWM key, its press lead at each velocity: its strike's duty (from the velocity)
    /// sets its press delay, and its write is one channel's five bytes (56 bit-times). Empty
    /// for a robot with no PWM key, and for a key struck at full power.
    fn press_leads_by_velocity(&self) -> Vec<Vec<u64>> {
        let c = &self.config;
        if c.dynamics.is_on_off() {
            return Vec::new();
        }
        let pwm_write = self.sim.clock.nanos_for_bits(56).div_ceil(1000) + self.link.note_lead_us();
        self.keys()
            .map(|k| {
                let touch = c.dynamics.touch(k);
                if touch.is_full() {
                    return Vec::new();
                }
                let figures = self.sim.mechanics.for_key(k);
                (0..=127u8)
                    .map(|v| {
                        let duty = touch.strike_duty(Velocity::from_bits(v));
                        u64::from(figures.press_delay_at(duty.get()).as_micros()) + pwm_write
                    })
                    .collect()
            })
            .collect()
    }

    /// The longest shortest-sounding press of any key, with the bus's margin: how long the
    /// end of a song waits so that a key struck last still sounds.
    pub(crate) fn settle_us(&self) -> u64 {
        self.rules().min_hold_us.into_iter().max().unwrap_or(0)
    }

    /// The longest release delay of any key, µs.
    pub(crate) fn longest_release_us(&self) -> u64 {
        self.keys()
            .map(|k| u64::from(self.sim.mechanics.for_key(k).release_delay.as_micros()))
            .max()
            .unwrap_or(0)
    }

    /// Per key: whether it plays velocity (a PWM key).
    pub(crate) fn dynamic_keys(&self) -> Vec<bool> {
        self.keys()
            .map(|k| !self.config.dynamics.touch(k).is_full())
            .collect()
    }

    /// Per key: whether it is a lift or a damper, not a note's strike.
    pub(crate) fn extra_keys(&self) -> Vec<bool> {
        self.keys()
            .map(|k| self.config.strikes.is_extra(k))
            .collect()
    }

    /// Per key: whether it is a wind robot's finger, not a note's strike (the notes sound on
    /// its valve).
    pub(crate) fn finger_keys(&self) -> Vec<bool> {
        let wind = &self.config.wind;
        self.keys()
            .map(|k| wind.owns(k) && k != wind.valve())
            .collect()
    }
}
