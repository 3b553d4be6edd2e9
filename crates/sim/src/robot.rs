//! The virtual robot: [`Pca9555`] boards on a [`VirtualBus`], the [`Mechanics`] of the keys,
//! and a [`Recorder`].
//!
//! Drive it through [`orch_core::FingerBoards`] (each [`write_board`](FingerBoards::write_board)
//! is one I2C write `[0x02, lo, hi]` to the board's address, timed on the bus), or through
//! [`embedded_hal::i2c::I2c`] on [`VirtualRobot::bus_mut`], as a board driver would. Either way
//! the robot looks at what the boards actually drive after each transaction (not at what was
//! asked: an unconfigured board drives nothing) and turns each change into pin edges at the
//! transaction's completion time, and those into sounds.
//!
//! Like the real boards, the models power up with every pin an input: nothing plays until the
//! boards are configured, by [`VirtualRobot::init`] or by the driver.

use embedded_hal::i2c::I2c;
use orch_core::{BoardId, BoardKind, BoardSpan, Duty, FingerBoards, Layout};

use crate::bus::{BusClock, BusError, SimTime, VirtualBus};
use crate::mechanics::{Mechanics, MechanicsConfig};
use crate::pca9555::{Pca9555, CONFIGURATION_0, OUTPUT_PORT_0};
use crate::pca9685::{
    Pca9685, AI, ALL_LED_OFF_H, FULL_ON_OFF, LED0_ON_L, MODE1, MODE2, OUTDRV, PRE_SCALE, SLEEP,
};
use crate::recorder::{Performance, PinEdge, Recorder};

/// What the virtual robot is made of.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SimConfig {
    /// The bus clock.
    pub clock: BusClock,
    /// The boards, in key order: address, how many keys, first output bit (as in
    /// [`orch_core::Layout`]).
    pub boards: Vec<BoardSpan>,
    /// The keys' mechanics: a default and per-key overrides.
    pub mechanics: MechanicsConfig,
    /// What to keep: every write, edge and sound ([`Keep::Everything`]), or only the presses
    /// and the figures ([`Keep::Presses`], memory that follows the notes, a fraction of it).
    pub keep: Keep,
    /// What each board is, in the order of `boards`: a PCA9555 ([`BoardKind::OnOff`]) or a
    /// PCA9685 ([`BoardKind::Pwm`]). A board with no entry is on/off.
    pub kinds: Vec<BoardKind>,
    /// The PCA9685 boards' PWM frequency, Hz, for drivers that initialise them.
    pub pwm_hz: u32,
}

/// What a [`VirtualRobot`] keeps of a performance.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Keep {
    /// Every bus write, pin edge and sound, and every press.
    #[default]
    Everything,
    /// Every press (each with its sound) and the figures; no writes, edges or sounds (the
    /// summary's `writes` then counts every transaction, `edges` every edge).
    Presses,
}

impl SimConfig {
    /// The thesis's robot: 4 boards at 0x21..=0x24 with 16/16/16/13 keys, 83.33 kHz, default
    /// mechanics.
    pub fn thesis() -> Self {
        Self {
            clock: BusClock::THESIS,
            boards: Layout::THESIS.boards.to_vec(),
            mechanics: MechanicsConfig::default(),
            keep: Keep::Everything,
            kinds: Vec::new(),
            pwm_hz: Self::PWM_HZ,
        }
    }

    /// The PCA9685's highest PWM frequency, the default: 1526 Hz.
    pub const PWM_HZ: u32 = 1526;

    /// What board `index` is ([`BoardKind::OnOff`] past `kinds`).
    pub fn kind(&self, index: usize) -> BoardKind {
        self.kinds.get(index).copied().unwrap_or_default()
    }

    /// The same boards as `layout`.
    pub fn with_layout<const B: usize>(mut self, layout: &Layout<B>) -> Self {
        self.boards = layout.boards.to_vec();
        self
    }

    /// How many keys the boards drive.
    pub fn keys(&self) -> usize {
        self.boards.iter().map(|b| b.keys as usize).sum()
    }
}

impl Default for SimConfig {
    fn default() -> Self {
        Self::thesis()
    }
}

/// The virtual robot. See the [module notes](self).
#[derive(Clone, Debug)]
pub struct VirtualRobot {
    config: SimConfig,
    bus: VirtualBus,
    /// Per board: the key of each of its 16 bits.
    pins: Vec<[Option<u8>; 16]>,
    mechanics: Mechanics,
    recorder: Recorder,
    /// Writes of the bus log already recorded (with [`Keep::Presses`]: transactions counted).
    log_seen: usize,
    scratch: Vec<crate::bus::PinChange>,
}

impl VirtualRobot {
    /// A robot as `config` says, powered up (nothing configured, nothing driven), at time 0.
    pub fn new(config: SimConfig) -> Self {
        let mut bus = VirtualBus::new(config.clock);
        let mut pins = Vec::with_capacity(config.boards.len());
        let mut first_key = 0usize;
        for (i, span) in config.boards.iter().enumerate() {
            match config.kind(i) {
                BoardKind::OnOff => bus.attach(Pca9555::new(span.address)),
                BoardKind::Pwm => bus.attach(Pca9685::new(span.address)),
            }
            let mut map = [None; 16];
            for i in 0..span.keys as usize {
                let bit = span.first_bit as usize + i;
                if bit < 16 {
                    map[bit] = Some((first_key + i) as u8);
                }
            }
            first_key += span.keys as usize;
            pins.push(map);
        }
        bus.keep_log(config.keep == Keep::Everything);
        let mut mechanics = Mechanics::new(first_key, &config.mechanics);
        mechanics.keep_sounds(config.keep == Keep::Everything);
        Self {
            config,
            bus,
            pins,
            mechanics,
            recorder: Recorder::new(),
            log_seen: 0,
            scratch: Vec::new(),
        }
    }

    /// The thesis's robot ([`SimConfig::thesis`]).
    pub fn thesis() -> Self {
        Self::new(SimConfig::thesis())
    }

    /// What it is made of.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// Sets the present (an [`orch_core::Instant`] or a [`SimTime`]): the next write starts no
    /// earlier. Call it before each flush.
    pub fn set_time(&mut self, t: impl Into<SimTime>) {
        self.sync();
        self.bus.set_time(t);
    }

    /// Configures every board as a driver would: outputs low (`[0x02, 0, 0]`), then every pin
    /// an output (`[0x06, 0, 0]`). Two transactions a board, from the present.
    /// A PCA9685 board is initialised as its driver does: every channel off, asleep, the
    /// prescale for [`SimConfig::pwm_hz`], totem-pole outputs, awake with auto-increment.
    pub fn init(&mut self) -> Result<(), BusError> {
        let boards: Vec<(u8, BoardKind)> = (0..self.config.boards.len())
            .map(|i| (self.config.boards[i].address, self.config.kind(i)))
            .collect();
        let prescale = (25_000_000.0 / (4096.0 * self.config.pwm_hz.max(1) as f64)).round() - 1.0;
        let prescale = prescale.clamp(3.0, 255.0) as u8;
        let result = boards.into_iter().try_for_each(|(a, kind)| match kind {
            BoardKind::OnOff => {
                self.bus.write(a, &[OUTPUT_PORT_0, 0, 0])?;
                self.bus.write(a, &[CONFIGURATION_0, 0, 0])
            }
            BoardKind::Pwm => {
                self.bus.write(a, &[ALL_LED_OFF_H, FULL_ON_OFF])?;
                self.bus.write(a, &[MODE1, SLEEP | AI])?;
                self.bus.write(a, &[PRE_SCALE, prescale])?;
                self.bus.write(a, &[MODE2, OUTDRV])?;
                self.bus.write(a, &[MODE1, AI])
            }
        });
        self.sync();
        result
    }

    /// The bus, to look at.
    pub fn bus(&self) -> &VirtualBus {
        &self.bus
    }

    /// The bus, to drive with [`embedded_hal::i2c::I2c`] (set its time with
    /// [`VirtualBus::set_time`] or [`VirtualRobot::set_time`]). Pin changes made this way reach
    /// the mechanics at the robot's next call that syncs ([`set_time`](Self::set_time),
    /// [`write_board`](FingerBoards::write_board), [`sync`](Self::sync),
    /// [`finish`](Self::finish)), with their own completion times.
    pub fn bus_mut(&mut self) -> &mut VirtualBus {
        &mut self.bus
    }

    /// The model of PWM board `index` (in configuration order), if it is one.
    pub fn pwm_board(&self, index: usize) -> Option<&Pca9685> {
        self.config
            .boards
            .get(index)
            .and_then(|s| self.bus.pca9685(s.address))
    }

    /// The model of board `index` (in configuration order).
    pub fn board(&self, index: usize) -> Option<&Pca9555> {
        self.config
            .boards
            .get(index)
            .and_then(|s| self.bus.device(s.address))
    }

    /// The mechanics (call [`sync`](Self::sync) first to see the latest writes).
    pub fn mechanics(&self) -> &Mechanics {
        &self.mechanics
    }

    /// The recorder (call [`sync`](Self::sync) first to see the latest writes).
    pub fn recorder(&self) -> &Recorder {
        &self.recorder
    }

    /// With [`Keep::Presses`], hands the presses resolved since the last call to `f` and
    /// forgets them (memory then follows the keys, not the notes); with [`Keep::Everything`]
    /// they stay for [`finish`](Self::finish).
    pub fn drain_presses(&mut self, f: impl FnMut(&crate::mechanics::Press)) {
        if self.config.keep == Keep::Presses {
            self.mechanics.drain_presses(f);
        }
    }

    /// Moves what happened on the bus since the last sync into the recorder and the mechanics.
    pub fn sync(&mut self) {
        let keep = self.config.keep == Keep::Everything;
        if keep {
            for w in &self.bus.log()[self.log_seen..] {
                self.recorder.record_write(w.clone());
            }
            self.log_seen = self.bus.log().len();
        } else {
            let tx = self.bus.stats().transactions;
            self.recorder
                .count_writes((tx - self.log_seen as u64) as usize);
            self.log_seen = tx as usize;
        }
        // The PWM boards' duties, in time order with the on/off boards' pins (each change is
        // stamped with its transaction's end, and both lists are in transaction order).
        let mut duty_changes = Vec::new();
        self.bus.drain_duty_changes(|c| duty_changes.push(c));
        for change in duty_changes {
            let board = self
                .config
                .boards
                .iter()
                .position(|s| s.address == change.address);
            for ch in 0..16usize {
                let (before, after) = (change.before[ch], change.after[ch]);
                if before == after {
                    continue;
                }
                let key = board.and_then(|b| self.pins[b][ch]);
                if (before > 0) != (after > 0) {
                    if keep {
                        self.recorder.record_edge(PinEdge {
                            time: change.time,
                            board: board.map_or(u8::MAX, |b| b as u8),
                            address: change.address,
                            bit: ch as u8,
                            key,
                            high: after > 0,
                        });
                    } else {
                        self.recorder.count_edges(1);
                    }
                }
                if let Some(key) = key {
                    self.mechanics.press_duty(change.time, key, after);
                }
            }
        }
        let mut changes = core::mem::take(&mut self.scratch);
        self.bus.drain_pin_changes(|c| changes.push(c));
        for change in changes.drain(..) {
            let board = self
                .config
                .boards
                .iter()
                .position(|s| s.address == change.address);
            let diff = change.before ^ change.after;
            for bit in 0..16u8 {
                if diff & (1 << bit) == 0 {
                    continue;
                }
                let high = change.after & (1 << bit) != 0;
                let key = board.and_then(|b| self.pins[b][bit as usize]);
                if !keep {
                    self.recorder.count_edges(1);
                    if let Some(key) = key {
                        self.mechanics.edge(change.time, key, high);
                    }
                    continue;
                }
                self.recorder.record_edge(PinEdge {
                    time: change.time,
                    board: board.map_or(u8::MAX, |b| b as u8),
                    address: change.address,
                    bit,
                    key,
                    high,
                });
                if let Some(key) = key {
                    self.mechanics.edge(change.time, key, high);
                }
            }
        }
        self.scratch = changes;
    }

    /// Ends the performance at `end` (or when the bus falls idle, if later): pins still high
    /// are taken as released then, every pending key-up is emitted. Returns everything.
    pub fn finish(mut self, end: impl Into<SimTime>) -> Performance {
        self.sync();
        let end = end.into().max(self.bus.free_at());
        let sounds = self.mechanics.finish(end);
        let presses = self.mechanics.take_presses();
        let mut performance = self.recorder.finish(
            end,
            sounds,
            presses,
            self.bus.stats(),
            self.mechanics.stats(),
        );
        performance.onsets = self.mechanics.onsets().to_vec();
        performance
    }
}

impl Default for VirtualRobot {
    fn default() -> Self {
        Self::thesis()
    }
}

/// The robot is also the bus its boards hang on, so a board driver (`orch-boards`) can own it:
/// each transaction goes to [`VirtualRobot::bus_mut`] and the robot syncs its mechanics and
/// recorder after it.
impl embedded_hal::i2c::ErrorType for VirtualRobot {
    type Error = BusError;
}

impl I2c for VirtualRobot {
    fn transaction(
        &mut self,
        address: u8,
        operations: &mut [embedded_hal::i2c::Operation<'_>],
    ) -> Result<(), BusError> {
        let result = self.bus.transaction(address, operations);
        self.sync();
        result
    }
}

impl FingerBoards for VirtualRobot {
    type Error = BusError;

    /// One I2C write `[0x02, lo, hi]` to `board.address`, starting at the present or when the
    /// bus is free (a PWM board: its 16 channels fully on or off, as
    /// [`write_duties`](FingerBoards::write_duties) writes them). An address with no board
    /// fails with [`BusError::AddressNack`].
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), BusError> {
        if self.config.kind(board.index as usize) == BoardKind::Pwm {
            return self.write_duties(board, &orch_core::full_or_off(outputs));
        }
        let [lo, hi] = outputs.to_le_bytes();
        let result = self.bus.write(board.address, &[OUTPUT_PORT_0, lo, hi]);
        self.sync();
        result
    }

    /// A PWM board: one auto-increment write of all 16 channels' registers (LED0_ON_L on; a
    /// driver writes only the channels that changed: drive the robot through `orch-boards`'
    /// `MixedBoardSet` for the real bus time). Each channel goes high at count 0 and low
    /// `duty` counts later; 0 and 4095 are the chip's fully off and fully on. An on/off board:
    /// its outputs with a duty above 0.
    fn write_duties(&mut self, board: BoardId, duties: &[Duty; 16]) -> Result<(), BusError> {
        if self.config.kind(board.index as usize) != BoardKind::Pwm {
            return self.write_board(board, orch_core::on_off(duties));
        }
        let mut frame = [0u8; 65];
        frame[0] = LED0_ON_L;
        for (n, d) in duties.iter().enumerate() {
            let regs = match d.get() {
                0 => [0, 0, 0, FULL_ON_OFF],
                4095.. => [0, FULL_ON_OFF, 0, 0],
                v => {
                    let [lo, hi] = v.to_le_bytes();
                    [0, 0, lo, hi]
                }
            };
            frame[1 + 4 * n..5 + 4 * n].copy_from_slice(&regs);
        }
        let result = self.bus.write(board.address, &frame);
        self.sync();
        result
    }
}
