//! I2C bus cost and latency of a key change: orch's event-driven writes against the thesis's
//! busy loop, at the thesis's 83.33 kHz and at 400 kHz, measured in bus bit-times, µs and DIN
//! byte times (320 µs), the wire's own unit.
//!
//! - orch: `Interpreter::thesis()` is driven with real bytes and flushed into a `FingerBoards`
//!   that puts each write on a modelled wire as the PCA9555 driver does: START, address+W,
//!   register 0x02, port 0, port 1 (auto-increment), STOP. Its figures come from counting what
//!   the interpreter actually wrote.
//! - thesis (Appendix C, `main` and `I2C_Send`): `while (1)` calls `I2C_Send` for the four
//!   boards, and each call is two transactions: START, address (0x42/0x44/0x46/0x48),
//!   register 0x02, port 0 byte, repeated START, address, register 0x03, port 1 byte, STOP.
//!   `I2C_Send` takes the board's 16-bit state as its argument, so a change made by the UART
//!   interrupt waits until the loop next reaches that board (up to one whole loop), and then
//!   for that board's send.
//!
//! A byte is 9 bit-times (8 + ACK); START, repeated START and STOP are counted as one bit-time
//! each. Bus time only: the ATmega16's CPU cycles between TWI steps and the bus-free time
//! between transactions are left out, so the thesis's figures are lower bounds.
//!
//! Then the same comparison over a whole real piece (see `common/mod.rs`), with orch's writes
//! queued on the bus when they come faster than it can carry them.
//! Run: `cargo bench -p orch-core --bench bus`.

mod common;

use common::DIN_BYTE_US;
use orch_core::{BoardId, FingerBoards, Instant, Interpreter};

/// One thing on the I2C wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Sym {
    Start,
    RepeatedStart,
    Stop,
    Byte(u8),
}

impl Sym {
    fn bit_times(self) -> u32 {
        match self {
            Sym::Start | Sym::RepeatedStart | Sym::Stop => 1,
            Sym::Byte(_) => 9,
        }
    }
}

fn bit_times(frame: &[Sym]) -> u32 {
    frame.iter().map(|s| s.bit_times()).sum()
}

fn bytes(frame: &[Sym]) -> usize {
    frame.iter().filter(|s| matches!(s, Sym::Byte(_))).count()
}

fn transactions(frame: &[Sym]) -> usize {
    frame
        .iter()
        .filter(|s| matches!(s, Sym::Start | Sym::RepeatedStart))
        .count()
}

/// A board write as orch's PCA9555 driver puts it on the wire.
fn orch_frame(address: u8, outputs: u16) -> Vec<Sym> {
    let [port0, port1] = outputs.to_le_bytes();
    vec![
        Sym::Start,
        Sym::Byte(address << 1),
        Sym::Byte(0x02),
        Sym::Byte(port0),
        Sym::Byte(port1),
        Sym::Stop,
    ]
}

/// The thesis's `I2C_Send(card, data)`, symbol for symbol.
fn thesis_send(card: u8, data: u16) -> Vec<Sym> {
    vec![
        Sym::Start,
        Sym::Byte(card),
        Sym::Byte(0x02),
        Sym::Byte((data & 0x00FF) as u8),
        Sym::RepeatedStart,
        Sym::Byte(card),
        Sym::Byte(0x03),
        Sym::Byte((data >> 8) as u8),
        Sym::Stop,
    ]
}

/// The thesis's `CARD1..CARD4`: 7-bit addresses 0x21..=0x24 with the write bit.
const CARDS: [u8; 4] = [0x42, 0x44, 0x46, 0x48];

/// One pass of the thesis's `while (1)`.
fn thesis_loop(states: [u16; 4]) -> Vec<Sym> {
    CARDS
        .iter()
        .zip(states)
        .flat_map(|(&card, data)| thesis_send(card, data))
        .collect()
}

/// A write the interpreter made: which board, what it wrote, and what caused it when.
struct Written {
    board: u8,
    outputs: u16,
    frame: Vec<Sym>,
    /// The time of the byte (or timer) after which it was flushed, in µs.
    trigger_us: u64,
    /// Index of that byte in the input, or `None` for a timer.
    byte: Option<usize>,
}

/// Finger boards on a modelled wire: records every write as its I2C frame.
struct WireBoards {
    writes: Vec<Written>,
    trigger_us: u64,
    byte: Option<usize>,
}

impl FingerBoards for WireBoards {
    type Error = core::convert::Infallible;
    fn write_board(&mut self, board: BoardId, outputs: u16) -> Result<(), Self::Error> {
        self.writes.push(Written {
            board: board.index,
            outputs,
            frame: orch_frame(board.address, outputs),
            trigger_us: self.trigger_us,
            byte: self.byte,
        });
        Ok(())
    }
}

/// Feeds timed bytes, serving guard deadlines in between, flushing after each step.
fn drive(bytes: &[u8], arrival_us: &[u64], end_us: u64) -> WireBoards {
    let mut robot = Interpreter::thesis();
    let mut boards = WireBoards {
        writes: Vec::new(),
        trigger_us: 0,
        byte: None,
    };
    let timers = |robot: &mut Interpreter, boards: &mut WireBoards, before: Instant| {
        while let Some(deadline) = robot.next_deadline().filter(|&d| d < before) {
            robot.tick(deadline);
            boards.trigger_us = deadline.as_micros();
            boards.byte = None;
            robot.flush(&mut *boards).unwrap();
        }
    };
    for (i, (&byte, &at)) in bytes.iter().zip(arrival_us).enumerate() {
        let now = Instant::from_micros(at);
        timers(&mut robot, &mut boards, now);
        robot.feed(byte, now);
        boards.trigger_us = at;
        boards.byte = Some(i);
        robot.flush(&mut boards).unwrap();
    }
    timers(&mut robot, &mut boards, Instant::from_micros(end_us));
    boards
}

struct Clock {
    name: &'static str,
    hz: f64,
}

impl Clock {
    fn us(&self, bit_times: f64) -> f64 {
        bit_times * 1e6 / self.hz
    }
}

const CLOCKS: [Clock; 2] = [
    Clock {
        name: "83.33 kHz (thesis: TWBR 10, prescaler 4, 8 MHz)",
        hz: 8e6 / (16.0 + 2.0 * 10.0 * 4.0),
    },
    Clock {
        name: "400 kHz (fast mode)",
        hz: 400e3,
    },
];

fn din(us: f64) -> f64 {
    us / DIN_BYTE_US as f64
}

fn main() {
    println!("orch-core bus cost: one key change on the I2C bus, orch vs the thesis's busy loop");
    println!();

    // --- orch, measured: one Note-On then one Note-Off for middle C, byte by byte. ---
    let note_on = [0x90, 60, 100];
    let note_off = [0x80, 60, 64];
    let mut input = Vec::new();
    let mut arrival = Vec::new();
    for (i, &b) in note_on.iter().enumerate() {
        input.push(b);
        arrival.push((i as u64 + 1) * DIN_BYTE_US);
    }
    for (i, &b) in note_off.iter().enumerate() {
        input.push(b);
        arrival.push(500_000 + (i as u64 + 1) * DIN_BYTE_US);
    }
    let run = drive(&input, &arrival, 1_000_000);
    let on_writes: Vec<&Written> = run.writes.iter().filter(|w| w.byte == Some(2)).collect();
    let off_writes: Vec<&Written> = run.writes.iter().filter(|w| w.byte == Some(5)).collect();
    // Correctness, not speed: the whole point of the comparison is one write per change.
    assert_eq!(
        run.writes.len(),
        2,
        "expected exactly one write per message"
    );
    assert_eq!((on_writes.len(), off_writes.len()), (1, 1));
    let on = on_writes[0];
    println!("orch, measured by driving Interpreter::thesis():");
    for (what, w) in [
        ("Note-On  90 3C 64", on),
        ("Note-Off 80 3C 40", off_writes[0]),
    ] {
        let shown: Vec<String> = w
            .frame
            .iter()
            .map(|s| match s {
                Sym::Start => "S".into(),
                Sym::RepeatedStart => "Sr".into(),
                Sym::Stop => "P".into(),
                Sym::Byte(b) => format!("{b:02X}"),
            })
            .collect();
        println!(
            "  {what} -> {} write, on the wire: {}  ({} bytes, {} bit-times)",
            run.writes.iter().filter(|x| x.byte == w.byte).count(),
            shown.join(" "),
            bytes(&w.frame),
            bit_times(&w.frame),
        );
    }
    let orch_bytes = bytes(&on.frame);
    let orch_bits = bit_times(&on.frame) as f64;

    // --- thesis, from its code: the loop and the one send that carries the change. ---
    let mut states = [0u16; 4];
    states[on.board as usize] = on.outputs;
    let lp = thesis_loop(states);
    let send = thesis_send(CARDS[on.board as usize], on.outputs);
    let loop_bits = bit_times(&lp) as f64;
    let send_bits = bit_times(&send) as f64;
    println!("thesis, from Appendix C (I2C_Send x 4 boards, forever):");
    println!(
        "  one board's send: {} transactions, {} bytes, {} bit-times; one loop: {} transactions, \
         {} bytes, {} bit-times, repeated whether anything changed or not",
        transactions(&send),
        bytes(&send),
        send_bits,
        transactions(&lp),
        bytes(&lp),
        loop_bits,
    );
    println!(
        "  a change waits for the loop to reach its board (0 to 1 loop), then that board's send: \
         latency = send + U(0, loop)"
    );
    println!();

    for clock in &CLOCKS {
        let write = clock.us(orch_bits);
        let lp_us = clock.us(loop_bits);
        let send_us = clock.us(send_bits);
        let worst = lp_us + send_us;
        let mean = lp_us / 2.0 + send_us;
        println!("at {}: one bit-time = {:.2} us", clock.name, clock.us(1.0));
        println!(
            "  {:<44} {:>24} {:>34}",
            "", "orch (one write)", "thesis (busy loop)"
        );
        println!(
            "  {:<44} {:>24} {:>34}",
            "I2C bytes per note-on",
            orch_bytes,
            format!("{} carry it ({} a loop, always)", bytes(&send), bytes(&lp)),
        );
        println!(
            "  {:<44} {:>24} {:>34}",
            "bit-times",
            orch_bits,
            format!("{send_bits} ({loop_bits} a loop)"),
        );
        println!(
            "  {:<44} {:>24} {:>34}",
            "wire time of the write",
            format!("{write:.0} us = {:.2} DIN bytes", din(write)),
            format!("{send_us:.0} us = {:.2} DIN bytes", din(send_us)),
        );
        println!(
            "  {:<44} {:>24} {:>34}",
            "loop time",
            "-",
            format!("{lp_us:.0} us = {:.2} DIN bytes", din(lp_us)),
        );
        println!(
            "  {:<44} {:>24} {:>34}",
            "latency, message complete -> write done: worst",
            format!("{write:.0} us = {:.2} DIN", din(write)),
            format!(
                "{worst:.0} us = {:.2} DIN ({:.1}x)",
                din(worst),
                worst / write
            ),
        );
        println!(
            "  {:<44} {:>24} {:>34}",
            "                                          mean",
            format!("{write:.0} us = {:.2} DIN", din(write)),
            format!("{mean:.0} us = {:.2} DIN ({:.1}x)", din(mean), mean / write),
        );
        println!(
            "  {:<44} {:>24} {:>34}",
            "bus busy", "only for writes", "100%, always"
        );
        println!(
            "  the Note-On itself takes 960 us on DIN (640 with running status); orch adds {:.0}% \
             of that, the thesis up to {:.0}%",
            write / 960.0 * 100.0,
            worst / 960.0 * 100.0
        );
        println!();
    }

    // --- a whole piece: the same key changes, on both buses. ---
    let stream = common::realistic_stream();
    let end = stream.duration_us() + 1_000_000;
    let run = drive(&stream.bytes, &stream.arrival_us, end);
    let secs = stream.duration_us() as f64 / 1e6;
    let timer_writes = run.writes.iter().filter(|w| w.byte.is_none()).count();
    println!("a whole piece: {}", stream.source);
    println!("  {}", stream.describe());
    if stream.synthetic {
        println!("  NOTE: synthetic input; the real-file figures need ../shared/midi");
    }
    println!(
        "  orch made {} board writes ({} by the guard's timers), {} I2C bytes in all",
        run.writes.len(),
        timer_writes,
        run.writes.iter().map(|w| bytes(&w.frame)).sum::<usize>(),
    );
    for clock in &CLOCKS {
        // orch: writes queue on the bus in order; latency = from the trigger to the write's end.
        let mut free = 0.0f64;
        let mut busy = 0.0f64;
        let mut orch_lat = Vec::with_capacity(run.writes.len());
        // thesis: the loop runs from time 0; board b's state is read at k·loop + b·send.
        let lp = clock.us(loop_bits);
        let send = clock.us(send_bits);
        let mut thesis_lat = Vec::with_capacity(run.writes.len());
        for w in &run.writes {
            let t = w.trigger_us as f64;
            let len = clock.us(bit_times(&w.frame) as f64);
            let start = free.max(t);
            free = start + len;
            busy += len;
            orch_lat.push(free - t);
            let offset = w.board as f64 * send;
            let k = ((t - offset) / lp).ceil().max(0.0);
            let sampled = k * lp + offset;
            thesis_lat.push(sampled - t + send);
        }
        let stats = |v: &[f64]| {
            let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
            let worst = v.iter().copied().fold(0.0, f64::max);
            (mean, worst)
        };
        let (om, ow) = stats(&orch_lat);
        let (tm, tw) = stats(&thesis_lat);
        let loops = stream.duration_us() as f64 / lp;
        println!(
            "  at {}: orch bus busy {:.3}% of the piece, latency mean {:.0} us, worst {:.0} us \
             ({:.2} DIN bytes); thesis bus busy 100% ({:.0} bytes over {:.0} s), latency mean \
             {:.0} us, worst {:.0} us ({:.2} DIN bytes): {:.1}x / {:.1}x orch's",
            clock.name.split(" (").next().unwrap_or(""),
            busy / stream.duration_us() as f64 * 100.0,
            om,
            ow,
            din(ow),
            loops * bytes(&thesis_loop([0; 4])) as f64,
            secs,
            tm,
            tw,
            din(tw),
            tm / om,
            tw / ow,
        );
    }
}
