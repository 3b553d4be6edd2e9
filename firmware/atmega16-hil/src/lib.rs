//! Hardware in the loop for the ATmega16 firmware: the ELF on a simulated ATmega16 at 8 MHz
//! (simavr through avr-tester), four simulated PCA9555 boards on its TWI, MIDI bytes fed at
//! wire pacing, and orch-core run on the host for the expected board outputs.

use std::cell::{Cell, RefCell};
use std::path::PathBuf;
use std::rc::Rc;

use avr_simulator::AvrSimulator;
use avr_tester::{AvrTester, Reader, TwiPacket, TwiSlave};
use orch_core::{BoardId, Config, FingerBoards, Instant, Interpreter, NotePool};

/// The clock of the simulated ATmega16.
pub const F_CPU: u64 = 8_000_000;
/// The boards' 7-bit addresses.
pub const ADDRESSES: [u8; 4] = [0x21, 0x22, 0x23, 0x24];
/// One MIDI byte on the wire: 10 bits at 31250 baud.
pub const BYTE_US: u64 = 320;
/// One byte as simavr's UART paces it: 11 bit times (start, 8 data, a parity bit it always
/// counts, stop) at UBRR 15: 2816 cycles.
pub const SIM_BYTE_US: u64 = 352;

/// The firmware's ELF: `$ORCH_ATMEGA16_ELF`, or where `cargo build --release` in
/// `firmware/atmega16` puts it.
pub fn elf_path() -> PathBuf {
    if let Ok(p) = std::env::var("ORCH_ATMEGA16_ELF") {
        return PathBuf::from(p);
    }
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../atmega16/target/avr-none/release/orch-atmega16.elf")
}

/// The bus clock the firmware was built with: `ORCH_TWI_HZ` if set (as when it was built), or
/// the default in `firmware/atmega16/.cargo/config.toml`'s `[env]`, the one place it is kept.
pub fn twi_hz() -> u64 {
    if let Ok(v) = std::env::var("ORCH_TWI_HZ") {
        return v
            .replace('_', "")
            .parse()
            .expect("ORCH_TWI_HZ: a number of Hz");
    }
    let config = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../atmega16/.cargo/config.toml"
    ))
    .expect("firmware/atmega16/.cargo/config.toml");
    config
        .lines()
        .find_map(|l| l.trim().strip_prefix("ORCH_TWI_HZ = "))
        .and_then(|v| v.trim_matches('"').replace('_', "").parse().ok())
        .expect("ORCH_TWI_HZ = \"…\" in firmware/atmega16/.cargo/config.toml")
}

/// One finished write transaction seen by a board.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Transaction {
    /// Board index (0..4).
    pub board: usize,
    /// The bytes after the address byte.
    pub bytes: Vec<u8>,
    /// CPU cycle of the START (simavr sends it with the address byte, taking no bus time
    /// for either).
    pub start_cycle: u64,
    /// CPU cycle of the STOP condition.
    pub stop_cycle: u64,
}

/// A PCA9555 register model: input 0/1, output 0/1, polarity 0/1, configuration 0/1.
#[derive(Clone, Debug)]
pub struct Pca9555 {
    /// Registers 0..=7.
    pub regs: [u8; 8],
    pointer: u8,
    /// In a transaction addressed to this board, and whether the command byte came.
    active: bool,
    command_seen: bool,
    reading: bool,
    bytes: Vec<u8>,
    started: u64,
    /// When set, the board acknowledges nothing (unpowered, missing, or a dead bus).
    pub nack: bool,
}

impl Default for Pca9555 {
    fn default() -> Self {
        // Power-up: outputs 1, every pin an input (configuration 1).
        Self {
            regs: [0, 0, 0xFF, 0xFF, 0, 0, 0xFF, 0xFF],
            pointer: 0,
            active: false,
            command_seen: false,
            reading: false,
            bytes: Vec::new(),
            started: 0,
            nack: false,
        }
    }
}

impl Pca9555 {
    /// The 16 output register bits (bit n = output n).
    pub fn outputs(&self) -> u16 {
        u16::from_le_bytes([self.regs[2], self.regs[3]])
    }

    /// The 16 configuration bits (1 = input).
    pub fn config(&self) -> u16 {
        u16::from_le_bytes([self.regs[6], self.regs[7]])
    }

    /// Pins driven high: outputs (configuration 0) whose output bit is 1.
    pub fn driven_high(&self) -> u16 {
        self.outputs() & !self.config()
    }

    /// Whether a write addressed to this board has begun and not ended, and how many bytes
    /// of it (the register byte first) have come.
    pub fn in_write(&self) -> Option<usize> {
        (self.active && !self.reading).then_some(self.bytes.len())
    }

    /// Power-cycles the board.
    pub fn power_cycle(&mut self) {
        let nack = self.nack;
        *self = Self::default();
        self.nack = nack;
    }

    fn advance(&mut self) {
        // The pointer toggles within its register pair.
        self.pointer ^= 1;
    }
}

/// Everything on the simulated bus.
#[derive(Debug, Default)]
pub struct Bus {
    /// The four boards at 0x21..=0x24.
    pub boards: [Pca9555; 4],
    /// Finished write transactions, in order.
    pub log: Vec<Transaction>,
    /// Address phases not acknowledged (a board with `nack`).
    pub nacked: u32,
    /// A pin was driven high at some point (any board), with the cycle it first happened.
    pub first_driven_high: Option<u64>,
}

impl Bus {
    /// Every board's outputs.
    pub fn outputs(&self) -> [u16; 4] {
        std::array::from_fn(|i| self.boards[i].outputs())
    }

    /// The output-register writes (`[0x02, lo, hi]`) to each board, in order, from log entry
    /// `from` on.
    pub fn output_writes(&self, from: usize) -> [Vec<u16>; 4] {
        per_board(&self.timed_output_writes(from))
    }

    /// The output-register writes from log entry `from` on, in bus order, each with the time
    /// of its STOP in µs.
    pub fn timed_output_writes(&self, from: usize) -> Vec<TimedWrite> {
        self.log[from..]
            .iter()
            .filter(|t| t.bytes.len() == 3 && t.bytes[0] == 0x02)
            .map(|t| TimedWrite {
                t_us: t.stop_cycle / (F_CPU / 1_000_000),
                board: t.board,
                outputs: u16::from_le_bytes([t.bytes[1], t.bytes[2]]),
            })
            .collect()
    }
}

struct Slave {
    bus: Rc<RefCell<Bus>>,
    cycles: Rc<Cell<u64>>,
}

impl TwiSlave for Slave {
    fn recv(&mut self, p: TwiPacket) -> Option<TwiPacket> {
        let mut bus = self.bus.borrow_mut();
        let seven = p.addr >> 1;
        let i = ADDRESSES.iter().position(|&a| a == seven)?;
        let now = self.cycles.get();
        if p.is_stop() {
            let b = &mut bus.boards[i];
            let was = b.active;
            b.active = false;
            if was && !b.reading {
                let bytes = std::mem::take(&mut b.bytes);
                let start_cycle = bus.boards[i].started;
                bus.log.push(Transaction {
                    board: i,
                    bytes,
                    start_cycle,
                    stop_cycle: now,
                });
            }
            return Some(p.respond_ack());
        }
        if bus.boards[i].nack {
            if p.is_start() {
                bus.nacked += 1;
            }
            return None;
        }
        if p.is_start() {
            // The address phase (simavr reports it as START with the address).
            let b = &mut bus.boards[i];
            if b.active && !b.reading && !b.bytes.is_empty() {
                // A repeated START ends a write part.
                let bytes = std::mem::take(&mut b.bytes);
                let start_cycle = b.started;
                bus.log.push(Transaction {
                    board: i,
                    bytes,
                    start_cycle,
                    stop_cycle: now,
                });
            }
            let b = &mut bus.boards[i];
            b.started = now;
            b.active = true;
            b.reading = p.addr & 1 == 1;
            if !b.reading {
                b.command_seen = false;
            }
            return Some(p.respond_ack());
        }
        if p.is_write() {
            let b = &mut bus.boards[i];
            b.bytes.push(p.data);
            if !b.command_seen {
                b.command_seen = true;
                b.pointer = p.data & 7;
            } else {
                let r = b.pointer as usize;
                if r >= 2 {
                    b.regs[r] = p.data;
                }
                b.advance();
            }
            if bus.first_driven_high.is_none() && bus.boards.iter().any(|b| b.driven_high() != 0) {
                bus.first_driven_high = Some(now);
            }
            return Some(p.respond_ack());
        }
        if p.is_read() {
            let b = &mut bus.boards[i];
            let v = b.regs[b.pointer as usize];
            b.advance();
            return Some(p.respond_data(v));
        }
        None
    }
}

/// The simulated robot: the firmware, its four boards and its MIDI ports.
pub struct Hil {
    /// The simulator.
    pub avr: AvrTester,
    /// CPU cycles run so far.
    pub cycles: Rc<Cell<u64>>,
    /// The boards.
    pub bus: Rc<RefCell<Bus>>,
    /// Bytes sent to the MIDI in, with the cycle each was handed to the UART.
    pub sent: Vec<(u64, u8)>,
    /// Bytes that came out of MIDI thru.
    pub thru: Vec<u8>,
}

impl Default for Hil {
    fn default() -> Self {
        Self::new()
    }
}

impl Hil {
    /// Loads the firmware and attaches the boards. Does not run anything yet.
    pub fn new() -> Self {
        let elf = elf_path();
        assert!(
            elf.exists(),
            "no firmware at {} (build it: cd firmware/atmega16 && cargo build --release)",
            elf.display()
        );
        let mut avr = AvrTester::atmega16().with_clock(F_CPU as u32).load(&elf);
        let cycles = Rc::new(Cell::new(0));
        let bus = Rc::new(RefCell::new(Bus::default()));
        avr.twi0().attach_slave(Slave {
            bus: bus.clone(),
            cycles: cycles.clone(),
        });
        Self {
            avr,
            cycles,
            bus,
            sent: Vec::new(),
            thru: Vec::new(),
        }
    }

    /// Runs one instruction; returns its cycles.
    pub fn step(&mut self) -> u64 {
        let n = self.avr.run().as_cycles();
        self.cycles.set(self.cycles.get() + n);
        n
    }

    /// The simulated time in µs.
    pub fn now_us(&self) -> u64 {
        self.cycles.get() / (F_CPU / 1_000_000)
    }

    /// Runs until the simulated clock reaches `cycle`.
    pub fn run_until(&mut self, cycle: u64) {
        while self.cycles.get() < cycle {
            self.step();
        }
        self.drain_thru();
    }

    /// Runs for `us` microseconds.
    pub fn run_us(&mut self, us: u64) {
        let end = self.cycles.get() + us * (F_CPU / 1_000_000);
        self.run_until(end);
    }

    /// Collects what came out of MIDI thru.
    pub fn drain_thru(&mut self) {
        while let Some(b) = self.avr.uart0().try_read_byte() {
            self.thru.push(b);
        }
    }

    /// Hands one byte to MIDI in.
    pub fn put(&mut self, byte: u8) {
        self.avr.uart0().write(byte);
        self.sent.push((self.cycles.get(), byte));
    }

    /// Sends bytes back to back at wire pacing (one every 320 µs).
    pub fn send(&mut self, bytes: &[u8]) {
        self.send_paced(bytes, BYTE_US);
    }

    /// Sends bytes one every `pace_us`.
    pub fn send_paced(&mut self, bytes: &[u8], pace_us: u64) {
        for &b in bytes {
            self.put(b);
            self.run_us(pace_us);
        }
    }

    /// When simavr's UART hands each byte sent so far to the firmware (its receive-complete
    /// flag, the end of the stop bit), in µs: simavr paces received bytes at
    /// [`SIM_BYTE_US`] (it counts a parity bit that 8N1 does not have).
    pub fn arrivals_us(&self) -> Vec<u64> {
        let mut out = Vec::with_capacity(self.sent.len());
        let mut last = 0u64;
        for &(cycle, _) in &self.sent {
            let put = cycle / (F_CPU / 1_000_000);
            let t = put.max(last) + SIM_BYTE_US;
            out.push(t);
            last = t;
        }
        out
    }

    /// The bytes sent so far.
    pub fn sent_bytes(&self) -> Vec<u8> {
        self.sent.iter().map(|&(_, b)| b).collect()
    }

    /// Boots the firmware: runs `us` microseconds with no input.
    pub fn boot(&mut self) {
        self.run_us(20_000);
    }

    /// Every board's outputs.
    pub fn outputs(&self) -> [u16; 4] {
        self.bus.borrow().outputs()
    }

    /// Digital pin level.
    pub fn pin(&mut self, port: char, pin: u8) -> bool {
        let mut pins = self.avr.pins();
        let mut p = match (port, pin) {
            ('A', 0) => pins.pa0(),
            ('A', 1) => pins.pa1(),
            ('A', 2) => pins.pa2(),
            ('A', 3) => pins.pa3(),
            ('A', 4) => pins.pa4(),
            ('A', 5) => pins.pa5(),
            ('A', 6) => pins.pa6(),
            ('A', 7) => pins.pa7(),
            ('D', 2) => pins.pd2(),
            ('D', 4) => pins.pd4(),
            ('D', 5) => pins.pd5(),
            ('B', n) => match n {
                0 => pins.pb0(),
                1 => pins.pb1(),
                2 => pins.pb2(),
                3 => pins.pb3(),
                4 => pins.pb4(),
                5 => pins.pb5(),
                6 => pins.pb6(),
                _ => pins.pb7(),
            },
            _ => panic!("no probe pin P{port}{pin}"),
        };
        p.is_high()
    }

    /// The deepest stack the firmware has seen, in bytes (2-byte resolution), from its
    /// diagnostic port (PORTA).
    pub fn stack_high_water(&mut self) -> u16 {
        let mut v = 0u16;
        for bit in 0..8 {
            if self.pin('A', bit) {
                v |= 1 << bit;
            }
        }
        v * 2
    }
}

/// The firmware on simavr directly, not through avr-tester, for the tests that need the CPU
/// itself: its program counter, to send the firmware into its panic path at a chosen moment.
/// The same four boards; MIDI in on the UART, thru read and dropped.
pub struct Cpu {
    /// The simulator.
    pub sim: AvrSimulator,
    /// simavr's CPU state (`AvrSimulator` keeps it to itself: see [`avr_pointer`]).
    avr: *mut avr_simulator::ffi::avr_t,
    /// CPU cycles run so far.
    pub cycles: Rc<Cell<u64>>,
    /// The boards.
    pub bus: Rc<RefCell<Bus>>,
}

impl Default for Cpu {
    fn default() -> Self {
        Self::new()
    }
}

impl Cpu {
    /// Loads the firmware and attaches the boards. Does not run anything yet.
    pub fn new() -> Self {
        let elf = elf_path();
        assert!(elf.exists(), "no firmware at {}", elf.display());
        let mut sim = AvrSimulator::new("atmega16", F_CPU as u32, &elf);
        let cycles = Rc::new(Cell::new(0));
        let bus = Rc::new(RefCell::new(Bus::default()));
        sim.set_twi_slave(
            0,
            Slave {
                bus: bus.clone(),
                cycles: cycles.clone(),
            },
        );
        let avr = avr_pointer(&format!("{sim:?}"));
        Self {
            sim,
            avr,
            cycles,
            bus,
        }
    }

    /// The simulated time in µs.
    pub fn now_us(&self) -> u64 {
        self.cycles.get() / (F_CPU / 1_000_000)
    }

    /// Runs for `us` microseconds, or until `stop` says so after an instruction; returns
    /// whether it stopped.
    pub fn run_us_until(&mut self, us: u64, mut stop: impl FnMut(&Bus) -> bool) -> bool {
        let end = self.cycles.get() + us * (F_CPU / 1_000_000);
        while self.cycles.get() < end {
            let n = self.sim.step().tt.as_cycles();
            self.cycles.set(self.cycles.get() + n);
            while self.sim.read_uart('0').is_some() {}
            if stop(&self.bus.borrow()) {
                return true;
            }
        }
        false
    }

    /// Runs for `us` microseconds.
    pub fn run_us(&mut self, us: u64) {
        self.run_us_until(us, |_| false);
    }

    /// Sends bytes back to back at wire pacing (one every 320 µs).
    pub fn send(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.sim.write_uart('0', b);
            self.run_us(BYTE_US);
        }
    }

    /// Every board's outputs.
    pub fn outputs(&self) -> [u16; 4] {
        self.bus.borrow().outputs()
    }

    /// The program counter (a byte address).
    pub fn pc(&self) -> u32 {
        // SAFETY: the simulator is alive and not running.
        unsafe { (*self.avr).pc }
    }

    /// Whether interrupts are on (SREG's I bit).
    pub fn interrupts_on(&self) -> bool {
        // SAFETY: as above.
        unsafe { (*self.avr).sreg[7] != 0 }
    }

    /// A byte of the data space (registers, I/O at 0x20.., SRAM at 0x60..).
    pub fn data(&self, address: u16) -> u8 {
        // SAFETY: as above; the data space is larger than any address the tests read.
        unsafe { *(*self.avr).data.add(address as usize) }
    }

    /// Sends the CPU to the firmware's function `symbol` (its unmangled name, as `avr-nm`
    /// lists it) before its next instruction, as a call from anywhere would, with whatever
    /// the interrupts and peripherals were doing left as it was.
    pub fn jump_to(&mut self, symbol: &str) {
        let at = symbol_address(&elf_path(), symbol)
            .unwrap_or_else(|| panic!("no symbol {symbol} in the firmware"));
        // SAFETY: the simulator is alive and not running; `pc` is a byte address.
        unsafe { (*self.avr).pc = at };
    }
}

/// The address of `symbol` (an unmangled name) in `elf`, by `avr-nm`.
pub fn symbol_address(elf: &std::path::Path, symbol: &str) -> Option<u32> {
    let out = std::process::Command::new("avr-nm")
        .args(["--defined-only"])
        .arg(elf)
        .output()
        .expect("avr-nm (Debian's binutils-avr)");
    String::from_utf8_lossy(&out.stdout).lines().find_map(|l| {
        let mut p = l.split(' ');
        let addr = u32::from_str_radix(p.next()?, 16).ok()?;
        let _kind = p.next()?;
        (p.next()? == symbol).then_some(addr)
    })
}

/// simavr's `avr_t` inside an [`AvrSimulator`]: it keeps the pointer private, but its Debug
/// output names it (`Avr { inner: 0x… }`).
pub fn avr_pointer(debug: &str) -> *mut avr_simulator::ffi::avr_t {
    let at = debug
        .find("inner: 0x")
        .expect("Avr { inner: 0x… } in the Debug output")
        + 9;
    let hex: String = debug[at..]
        .chars()
        .take_while(|c| c.is_ascii_hexdigit())
        .collect();
    usize::from_str_radix(&hex, 16).unwrap() as *mut avr_simulator::ffi::avr_t
}

/// One board write with its time: on the host, when the interpreter made it; from the
/// simulated bus, the STOP of the transaction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TimedWrite {
    /// µs since the simulation started.
    pub t_us: u64,
    /// Board index (0..4).
    pub board: usize,
    /// The 16 outputs written.
    pub outputs: u16,
}

/// Each board's values, in order.
pub fn per_board(writes: &[TimedWrite]) -> [Vec<u16>; 4] {
    let mut out: [Vec<u16>; 4] = Default::default();
    for w in writes {
        out[w.board].push(w.outputs);
    }
    out
}

/// The host's boards: every write, with the time it was made.
#[derive(Debug, Default)]
pub struct TimedRecorder {
    /// The time of the writes being made now.
    pub now_us: u64,
    /// Every write, in order.
    pub writes: Vec<TimedWrite>,
}

impl FingerBoards for TimedRecorder {
    type Error = std::convert::Infallible;
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Self::Error> {
        self.writes.push(TimedWrite {
            t_us: self.now_us,
            board: board.index as usize,
            outputs,
        });
        Ok(())
    }
}

/// orch-core on the host, with the firmware's configuration, fed the same bytes at the same
/// times: the board writes it makes, in order and with their times, and its final outputs.
pub struct HostRobot {
    /// The interpreter, as built into the firmware.
    pub robot: Interpreter<4, 61, NotePool<32>>,
    /// What it wrote, and when.
    pub boards: TimedRecorder,
}

impl Default for HostRobot {
    fn default() -> Self {
        Self::new()
    }
}

impl HostRobot {
    /// The firmware's configuration (`Config::THESIS`, `NotePool<32>`).
    pub fn new() -> Self {
        Self {
            robot: Interpreter::new(Config::THESIS).unwrap(),
            boards: TimedRecorder::default(),
        }
    }

    /// Feeds one byte at `us` and flushes, as the firmware does for each byte it takes (after
    /// the guard's timers due by then, each at its own time).
    pub fn feed(&mut self, byte: u8, us: u64) {
        self.advance_to(us);
        self.robot.feed(byte, Instant::from_micros(us));
        self.boards.now_us = us;
        self.robot.flush(&mut self.boards).unwrap();
    }

    /// Runs the guard's timers at every deadline up to `us`, each at its own time, as the
    /// firmware's loop does.
    pub fn advance_to(&mut self, us: u64) {
        while let Some(d) = self.robot.next_deadline() {
            if d.as_micros() > us {
                break;
            }
            self.tick(d.as_micros());
        }
    }

    /// Runs the guard's timers at `us`.
    pub fn tick(&mut self, us: u64) {
        self.robot.tick(Instant::from_micros(us));
        self.boards.now_us = us;
        self.robot.flush(&mut self.boards).unwrap();
    }

    /// The final outputs.
    pub fn outputs(&self) -> [u16; 4] {
        std::array::from_fn(|i| self.robot.frame().outputs(i))
    }

    /// The writes to each board, in order.
    pub fn writes(&self) -> [Vec<u16>; 4] {
        per_board(&self.boards.writes)
    }
}

/// A key going down or up, as a board write shows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KeyEvent {
    /// µs since the simulation started.
    pub t_us: u64,
    /// Board × 16 + output bit.
    pub key: usize,
    /// Down (pressed) or up (released).
    pub down: bool,
}

/// Every press and release in a series of board writes (every board starts at 0).
pub fn key_events(writes: &[TimedWrite]) -> Vec<KeyEvent> {
    let mut last = [0u16; 4];
    let mut out = Vec::new();
    for w in writes {
        let changed = last[w.board] ^ w.outputs;
        for bit in 0..16 {
            if changed & (1 << bit) != 0 {
                out.push(KeyEvent {
                    t_us: w.t_us,
                    key: w.board * 16 + bit,
                    down: w.outputs & (1 << bit) != 0,
                });
            }
        }
        last[w.board] = w.outputs;
    }
    out
}

/// How the firmware's presses and releases compare with the host's.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct EventMatch {
    /// Presses matched.
    pub presses: usize,
    /// Releases matched.
    pub releases: usize,
    /// The latest a firmware event came after the host's, in µs.
    pub max_late_us: u64,
    /// How late each firmware event came, in µs, sorted.
    pub late_us: Vec<u64>,
}

impl EventMatch {
    /// The lateness below which `percent` % of the events came.
    pub fn percentile(&self, percent: usize) -> u64 {
        if self.late_us.is_empty() {
            return 0;
        }
        self.late_us[(self.late_us.len() - 1) * percent / 100]
    }
}

/// Whether every press and release the host made appears on the firmware's bus, key by key
/// in the same order, none missing and none extra, each no earlier than the host made it and
/// at most `max_late_us` after.
pub fn same_key_events(
    firmware: &[TimedWrite],
    host: &[TimedWrite],
    max_late_us: u64,
) -> Result<EventMatch, String> {
    let (f, h) = (key_events(firmware), key_events(host));
    let mut m = EventMatch::default();
    for key in 0..64 {
        let fk: Vec<&KeyEvent> = f.iter().filter(|e| e.key == key).collect();
        let hk: Vec<&KeyEvent> = h.iter().filter(|e| e.key == key).collect();
        for (i, he) in hk.iter().enumerate() {
            let what = if he.down { "press" } else { "release" };
            let Some(fe) = fk.get(i) else {
                return Err(format!(
                    "key {key} (board {}, bit {}): the host's {what} #{i} at {} µs never reached the boards ({} events on the bus, {} on the host)",
                    key / 16, key % 16, he.t_us, fk.len(), hk.len()
                ));
            };
            if fe.down != he.down {
                return Err(format!(
                    "key {key}: event #{i} is a {} on the bus at {} µs, the host's is a {what} at {} µs",
                    if fe.down { "press" } else { "release" },
                    fe.t_us,
                    he.t_us
                ));
            }
            if fe.t_us < he.t_us || fe.t_us - he.t_us > max_late_us {
                return Err(format!(
                    "key {key}: {what} #{i} on the bus at {} µs, the host made it at {} µs (allowed: 0..={max_late_us} µs later)",
                    fe.t_us, he.t_us
                ));
            }
            m.max_late_us = m.max_late_us.max(fe.t_us - he.t_us);
            m.late_us.push(fe.t_us - he.t_us);
            if he.down {
                m.presses += 1;
            } else {
                m.releases += 1;
            }
        }
        if fk.len() > hk.len() {
            let e = fk[hk.len()];
            return Err(format!(
                "key {key}: the bus has a {} at {} µs that the host never made",
                if e.down { "press" } else { "release" },
                e.t_us
            ));
        }
    }
    m.late_us.sort_unstable();
    Ok(m)
}

/// A Standard MIDI File as timed wire bytes: (µs from the start, byte), channel messages
/// only (with their status byte each), in time order, respecting the tempo map.
pub fn smf_to_wire(data: &[u8]) -> Vec<(u64, u8)> {
    use midly::{live::LiveEvent, MetaMessage, Smf, Timing, TrackEventKind};
    let smf = Smf::parse(data).expect("a valid MIDI file");
    let ppq = match smf.header.timing {
        Timing::Metrical(t) => t.as_int() as u64,
        Timing::Timecode(..) => panic!("timecode files are not used here"),
    };
    // (tick, track, index, event)
    let mut events = Vec::new();
    for (ti, track) in smf.tracks.iter().enumerate() {
        let mut tick = 0u64;
        for (ei, ev) in track.iter().enumerate() {
            tick += ev.delta.as_int() as u64;
            events.push((tick, ti, ei, ev.kind));
        }
    }
    events.sort_by_key(|e| (e.0, e.1, e.2));
    let mut tempo = 500_000u64; // µs per quarter
    let mut last_tick = 0u64;
    let mut us = 0u64;
    let mut out = Vec::new();
    for (tick, _, _, kind) in events {
        us += (tick - last_tick) * tempo / ppq;
        last_tick = tick;
        match kind {
            TrackEventKind::Meta(MetaMessage::Tempo(t)) => tempo = t.as_int() as u64,
            TrackEventKind::Midi { channel, message } => {
                let mut buf = Vec::new();
                LiveEvent::Midi { channel, message }
                    .write_std(&mut buf)
                    .unwrap();
                out.extend(buf.into_iter().map(|b| (us, b)));
            }
            _ => {}
        }
    }
    out
}

/// A DIN line at full rate for `seconds`: running status throughout; first sweeps of
/// Note-On/Note-Off pairs over all 61 keys (what once made the firmware reset after 125 ms),
/// then notes on random keys, half of them Note-Offs (velocity 0): re-strikes inside the
/// guard's rest, presses shorter than its shortest strike, chords past its power budget;
/// there a MIDI clock byte (0xF8, real time) now and then falls inside a message, as a
/// sequencer's clock does.
pub fn flood_stream(seconds: u64) -> Vec<u8> {
    let n = (seconds * 1_000_000 / SIM_BYTE_US) as usize;
    let mut s = vec![0x90];
    while s.len() < n / 3 {
        for k in 36..=96u8 {
            s.extend([k, 100, k, 0]);
        }
    }
    let mut x = 0x2545_f491_u32;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        x
    };
    while s.len() + 1 < n {
        let r = next();
        let key = 36 + (r % 61) as u8;
        let velocity = if r >> 16 & 1 == 0 {
            0
        } else {
            1 + (r >> 8) as u8 % 127
        };
        if r >> 24 < 16 {
            // One message in 16: the clock byte between the key and the velocity.
            s.extend([key, 0xF8, velocity]);
        } else {
            s.extend([key, velocity]);
        }
    }
    s
}
