//! A drum kit's strikes through the PCA9555 driver on a mock bus: every pulse is one write on
//! and one write off at its time, an open hi-hat's lift goes on before its stick, a crash's
//! damper after the crash's pulse, and all-off writes every output off.

use embedded_hal_mock::eh1::i2c::{Mock, Transaction};
use orch_boards::FingerBoardSet;
use orch_core::{
    ChannelMask, Config, Duration, Instant, Interpreter, Layout, Note, Pulse, Strikes,
};

// Data sheet values, typed again here on purpose.
const OUTPUT_PORT_0: u8 = 0x02;
const CONFIGURATION_0: u8 = 0x06;
const ADDRESSES: [u8; 4] = [0x21, 0x22, 0x23, 0x24];

const STICK: u16 = 1 << 1;
const LIFT: u16 = 1 << 2;
const CRASH: u16 = 1 << 3;
const DAMPER: u16 = 1 << 4;

fn outputs(bits: u16) -> Transaction {
    Transaction::write(0x21, vec![OUTPUT_PORT_0, bits as u8, (bits >> 8) as u8])
}

fn init() -> Vec<Transaction> {
    ADDRESSES
        .iter()
        .flat_map(|&a| {
            [
                Transaction::write(a, vec![OUTPUT_PORT_0, 0, 0]),
                Transaction::write(a, vec![CONFIGURATION_0, 0, 0]),
            ]
        })
        .collect()
}

fn ms(t: u64) -> Instant {
    Instant::from_micros(t * 1000)
}

/// Kick (36), hi-hat stick (42, 46), its lift (46's lead, 15 ms), crash (49) and its damper,
/// on board 0x21 bits 0..=4. Every pulse 20 ms, the lift's 60, the damper's 30.
fn kit() -> Config<4> {
    let pulse = |ms_: u32, rebound: u32| Pulse {
        soft: Duration::from_millis(ms_),
        loud: Duration::from_millis(ms_),
        rebound: Duration::from_millis(rebound),
    };
    let mut s = Strikes {
        keyboard: false,
        ..Strikes::NONE
    };
    let drum = pulse(20, 40);
    s.push_kit(
        ChannelMask(1 << 9),
        0,
        &[
            (&[36], drum),
            (&[42, 46], drum),
            (&[], pulse(60, 80)),
            (&[49], drum),
            (&[], pulse(30, 60)),
        ],
    )
    .unwrap();
    s.set_lead(0, Note::from_bits(46), 2, Duration::from_millis(15));
    s.set_damper(3, 4);
    Config {
        layout: Layout::sequential(ADDRESSES, 5),
        strikes: s,
        ..Config::THESIS
    }
}

/// Runs `input` (bytes at ms) on the kit through the driver, ticking at every deadline, and
/// checks the mock saw exactly `writes` after init.
fn run(input: &[(u64, &[u8])], end: u64, writes: &[Transaction]) {
    let mut expected = init();
    expected.extend_from_slice(writes);
    let mut set = FingerBoardSet::new(Mock::new(&expected), ADDRESSES);
    set.init().unwrap();
    let mut robot = Interpreter::<4, 16>::new(kit()).unwrap();
    let mut input = input.iter().peekable();
    loop {
        let deadline = robot.next_deadline().map(|d| d.as_micros());
        let next_in = input.peek().map(|(t, _)| t * 1000);
        let Some(now) = [deadline, next_in].into_iter().flatten().min() else {
            break;
        };
        if now > end * 1000 {
            break;
        }
        let now = Instant::from_micros(now);
        robot.tick(now);
        if next_in == Some(now.as_micros()) {
            let (_, bytes) = input.next().unwrap();
            robot.feed_slice(bytes, now);
        }
        robot.flush(&mut set).unwrap();
    }
    robot.all_off(ms(end));
    robot.flush(&mut set).unwrap();
    set.destroy().done();
}

#[test]
fn an_open_hi_hat_writes_its_lift_then_its_stick_and_each_goes_off_by_itself() {
    run(
        &[(0, &[0x99, 46, 127])],
        1_000,
        &[
            outputs(LIFT),         // 0 ms
            outputs(LIFT | STICK), // 15 ms
            outputs(LIFT),         // 35 ms
            outputs(0),            // 60 ms
        ],
    );
}

#[test]
fn a_crash_writes_its_damper_at_its_note_off_and_all_off_ends_a_pulse() {
    run(
        &[
            (0, &[0x99, 49, 127]),
            (200, &[0x89, 49, 0]),
            (500, &[0x99, 36, 127]),
        ],
        505,
        &[
            outputs(CRASH),  // 0 ms
            outputs(0),      // 20 ms
            outputs(DAMPER), // 200 ms: the Note-Off
            outputs(0),      // 230 ms
            outputs(1),      // 500 ms: the kick
            outputs(0),      // 505 ms: all off, mid-pulse
        ],
    );
}
