//! One PCA9685 on a mock bus: the exact bytes of the public API, against the data sheet.

use std::cell::RefCell;
use std::rc::Rc;

use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};
use embedded_hal_mock::eh1::i2c::{Mock, Transaction};
use orch_boards::{Error, Pca9685};

// Data sheet values (NXP PCA9685 Rev. 4, table 4 and sections 7.3.1–7.3.3), typed again here
// on purpose: a wrong constant in the crate must fail.
const MODE1: u8 = 0x00;
const MODE2: u8 = 0x01;
const LED0_ON_L: u8 = 0x06;
const ALL_LED_OFF_H: u8 = 0xFD;
const PRE_SCALE: u8 = 0xFE;
const RESTART: u8 = 0x80;
const AI: u8 = 0x20;
const SLEEP: u8 = 0x10;
const OUTDRV: u8 = 0x04;
const FULL: u8 = 0x10; // bit 4 of LEDn_ON_H (full ON) and LEDn_OFF_H (full OFF)
const ADDR: u8 = 0x40;

const NACK: ErrorKind = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data);

fn w(bytes: &[u8]) -> Transaction {
    Transaction::write(ADDR, bytes.to_vec())
}

/// What happened, in order: bus transactions and delays.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Event {
    Bus,
    Delay(u64),
}

/// The mock bus, logging each transaction into a log shared with [`Delay`], so that a test
/// sees where the waits fall between the writes.
struct Logged {
    mock: Mock,
    log: Rc<RefCell<Vec<Event>>>,
}

impl ErrorType for Logged {
    type Error = ErrorKind;
}

impl I2c for Logged {
    // The driver makes only writes and write_reads; the mock checks each of them.
    fn write(&mut self, a: u8, bytes: &[u8]) -> Result<(), ErrorKind> {
        self.log.borrow_mut().push(Event::Bus);
        self.mock.write(a, bytes)
    }
    fn write_read(&mut self, a: u8, bytes: &[u8], buf: &mut [u8]) -> Result<(), ErrorKind> {
        self.log.borrow_mut().push(Event::Bus);
        self.mock.write_read(a, bytes, buf)
    }
    fn transaction(&mut self, a: u8, ops: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
        self.log.borrow_mut().push(Event::Bus);
        self.mock.transaction(a, ops)
    }
}

struct Delay(Rc<RefCell<Vec<Event>>>);

impl DelayNs for Delay {
    fn delay_ns(&mut self, ns: u32) {
        self.0.borrow_mut().push(Event::Delay(u64::from(ns)));
    }
    fn delay_us(&mut self, us: u32) {
        self.0
            .borrow_mut()
            .push(Event::Delay(u64::from(us) * 1_000));
    }
    fn delay_ms(&mut self, ms: u32) {
        self.0
            .borrow_mut()
            .push(Event::Delay(u64::from(ms) * 1_000_000));
    }
}

fn logged(expect: &[Transaction]) -> (Pca9685<Logged>, Delay, Rc<RefCell<Vec<Event>>>) {
    let log = Rc::new(RefCell::new(Vec::new()));
    let bus = Logged {
        mock: Mock::new(expect),
        log: log.clone(),
    };
    (Pca9685::new(bus, ADDR), Delay(log.clone()), log)
}

fn init_sequence(prescale: u8) -> Vec<Transaction> {
    vec![
        w(&[ALL_LED_OFF_H, FULL]), // every channel fully off, before anything else
        w(&[MODE1, SLEEP | AI]),   // asleep: PRE_SCALE is writable only now
        w(&[PRE_SCALE, prescale]),
        w(&[MODE2, OUTDRV]), // totem pole, not inverted, change on STOP, OE high -> 0
        w(&[MODE1, AI]),     // awake, auto-increment
    ]
}

#[test]
fn init_turns_everything_off_sets_prescale_asleep_then_wakes_and_waits_500_us() {
    let (mut dev, mut delay, log) = logged(&init_sequence(3));
    dev.init(1526, &mut delay).unwrap();
    // Five writes, THEN the oscillator's 500 µs, before anything else may be written.
    let mut expected = vec![Event::Bus; 5];
    expected.push(Event::Delay(500_000));
    assert_eq!(*log.borrow(), expected);
    assert_eq!(dev.duties(), [Some(0); 16], "every channel known to be off");
    assert_eq!(dev.prescale().map(|p| p.value()), Some(3));
    dev.destroy().mock.done();
}

#[test]
fn init_prescale_is_round_25_mhz_over_4096_f_minus_1() {
    // 200 Hz: round(25e6 / 819200) - 1 = 30 (0x1E, the power-up value).
    let (mut dev, mut delay, _) = logged(&init_sequence(0x1E));
    dev.init(200, &mut delay).unwrap();
    dev.destroy().mock.done();
    // 1000 Hz: round(6.10) - 1 = 5.
    let (mut dev, mut delay, _) = logged(&init_sequence(5));
    dev.init(1000, &mut delay).unwrap();
    dev.destroy().mock.done();
}

#[test]
fn a_frequency_the_chip_cannot_make_is_refused_before_any_write() {
    for hz in [0, 23, 1527, 20_000] {
        let (mut dev, mut delay, log) = logged(&[]);
        assert_eq!(dev.init(hz, &mut delay), Err(Error::Frequency { hz }));
        assert!(log.borrow().is_empty());
        assert_eq!(dev.duty(0), None);
        dev.destroy().mock.done();
    }
}

#[test]
fn init_that_cannot_turn_channels_off_goes_no_further() {
    let (mut dev, mut delay, log) = logged(&[w(&[ALL_LED_OFF_H, FULL]).with_error(NACK)]);
    assert_eq!(dev.init(1526, &mut delay), Err(Error::I2c(NACK)));
    assert_eq!(*log.borrow(), vec![Event::Bus], "no wake, no wait");
    assert_eq!(dev.duties(), [None; 16]);
    dev.destroy().mock.done();
}

#[test]
fn one_channels_duty_is_one_5_byte_write() {
    let mut expect = init_sequence(3);
    expect.extend([
        // Channel 0, duty 1000: ON at its phase 0, OFF at 1000 (0x3E8).
        w(&[LED0_ON_L, 0x00, 0x00, 0xE8, 0x03]),
        // Channel 5 (registers at 0x06 + 4 * 5 = 0x1A), duty 2048: ON at its phase
        // 5 * 256 = 1280 (0x500), OFF at 3328 (0xD00).
        w(&[0x1A, 0x00, 0x05, 0x00, 0x0D]),
        // Channel 15 (0x42), duty 4095: full ON.
        w(&[0x42, 0x00, FULL, 0x00, 0x00]),
        // Channel 15 back to 0: full OFF.
        w(&[0x42, 0x00, 0x00, 0x00, FULL]),
        // Channel 14 (0x3E), duty 1000: ON at 3584 (0xE00), OFF wraps to 488 (0x1E8).
        w(&[0x3E, 0x00, 0x0E, 0xE8, 0x01]),
    ]);
    let (mut dev, mut delay, _) = logged(&expect);
    dev.init(1526, &mut delay).unwrap();
    assert!(dev.set_duty(0, 1000).unwrap());
    assert!(dev.set_duty(5, 2048).unwrap());
    assert!(dev.set_duty(15, 4095).unwrap());
    assert!(dev.set_duty(15, 0).unwrap());
    assert!(dev.set_duty(14, 1000).unwrap());
    dev.destroy().mock.done();
}

#[test]
fn unchanged_duties_are_not_written() {
    let mut expect = init_sequence(3);
    expect.push(w(&[LED0_ON_L, 0x00, 0x00, 0x10, 0x00]));
    let (mut dev, mut delay, _) = logged(&expect);
    dev.init(1526, &mut delay).unwrap();
    assert!(!dev.set_duty(3, 0).unwrap(), "init left every channel off");
    assert!(dev.set_duty(0, 16).unwrap());
    assert!(!dev.set_duty(0, 16).unwrap());
    assert!(!dev
        .set_duties(&[16, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0])
        .unwrap());
    dev.destroy().mock.done();
}

#[test]
fn bad_channel_or_duty_is_refused_and_nothing_written() {
    let (mut dev, mut delay, _) = logged(&init_sequence(3));
    dev.init(1526, &mut delay).unwrap();
    assert_eq!(dev.set_duty(16, 1), Err(Error::UnknownChannel(16)));
    assert_eq!(
        dev.set_duty(2, 4096),
        Err(Error::DutyOutOfRange {
            channel: 2,
            duty: 4096
        })
    );
    let mut duties = [0; 16];
    duties[0] = 100;
    duties[9] = 5000;
    assert_eq!(
        dev.set_duties(&duties),
        Err(Error::DutyOutOfRange {
            channel: 9,
            duty: 5000
        })
    );
    assert_eq!(dev.duties(), [Some(0); 16]);
    dev.destroy().mock.done();
}

#[test]
fn set_duties_writes_the_changed_run_in_one_transaction() {
    let mut expect = init_sequence(3);
    // Channels 2 and 4 change: one write from channel 2's registers (0x0E) to channel 4's,
    // channel 3 (unchanged, off) rewritten between them.
    expect.push(w(&[
        0x0E, 0x00, 0x02, 0x64, 0x02, // ch 2: ON 512 (0x200), OFF 612 (0x264)
        0x00, 0x00, 0x00, FULL, //       ch 3: full OFF
        0x00, 0x10, 0x00, 0x00, //       ch 4: full ON
    ]));
    // All 16 change: 65 bytes from LED0_ON_L.
    let mut all = vec![LED0_ON_L];
    for ch in 0u16..16 {
        let on = ch * 256;
        let off = (on + 1) % 4096;
        all.extend([on as u8, (on >> 8) as u8, off as u8, (off >> 8) as u8]);
    }
    assert_eq!(all.len(), 65);
    expect.push(Transaction::write(ADDR, all));
    let (mut dev, mut delay, _) = logged(&expect);
    dev.init(1526, &mut delay).unwrap();
    let mut duties = [0; 16];
    duties[2] = 100;
    duties[4] = 4095;
    assert!(dev.set_duties(&duties).unwrap());
    assert_eq!(dev.duty(4), Some(4095));
    assert!(dev.set_duties(&[1; 16]).unwrap());
    assert!(!dev.set_duties(&[1; 16]).unwrap());
    dev.destroy().mock.done();
}

#[test]
fn all_off_is_one_write_to_all_led_off_h_whatever_the_cache() {
    let mut expect = init_sequence(3);
    expect.extend([
        w(&[ALL_LED_OFF_H, FULL]),
        w(&[0x0A, 0x00, 0x01, 0x00, 0x02]), // ch 1, duty 256
        w(&[ALL_LED_OFF_H, FULL]),
        w(&[0x0A, 0x00, 0x01, 0x00, 0x02]), // after all_off the same duty goes out again
    ]);
    let (mut dev, mut delay, _) = logged(&expect);
    dev.init(1526, &mut delay).unwrap();
    dev.all_off().unwrap();
    assert!(dev.set_duty(1, 256).unwrap());
    dev.all_off().unwrap();
    assert_eq!(dev.duty(1), Some(0));
    assert!(dev.set_duty(1, 256).unwrap());
    dev.destroy().mock.done();
}

#[test]
fn sleep_then_restart_follows_datasheet_7_3_1_1() {
    let mut expect = init_sequence(3);
    expect.extend([
        w(&[MODE1, SLEEP | AI]),
        // 1. read MODE1; 2. RESTART is 1: clear SLEEP, wait 500 µs; 3. write 1 to RESTART.
        Transaction::write_read(ADDR, vec![MODE1], vec![RESTART | SLEEP | AI]),
        w(&[MODE1, AI]),
        w(&[MODE1, RESTART | AI]),
        // A sleep with nothing running: RESTART reads 0, only the wake and the wait.
        w(&[MODE1, SLEEP | AI]),
        Transaction::write_read(ADDR, vec![MODE1], vec![SLEEP | AI]),
        w(&[MODE1, AI]),
    ]);
    let (mut dev, mut delay, log) = logged(&expect);
    dev.init(1526, &mut delay).unwrap();
    log.borrow_mut().clear();
    dev.sleep().unwrap();
    assert!(dev.restart(&mut delay).unwrap());
    assert_eq!(
        *log.borrow(),
        [
            Event::Bus,
            Event::Bus,
            Event::Bus,
            Event::Delay(500_000), // SLEEP 0 for 500 µs before RESTART is written
            Event::Bus
        ]
    );
    dev.sleep().unwrap();
    assert!(!dev.restart(&mut delay).unwrap());
    dev.destroy().mock.done();
}

#[test]
fn a_failed_write_forgets_what_it_was_writing_and_the_next_one_goes_out() {
    let mut expect = init_sequence(3);
    expect.extend([
        w(&[0x12, 0x00, 0x03, 0x00, 0x04]), // ch 3, duty 256: written
        w(&[0x12, 0x00, 0x03, 0x00, 0x05]).with_error(NACK), // ch 3, duty 512: NACKed
        w(&[0x12, 0x00, 0x03, 0x00, 0x04]), // back to 256: must go out again
        w(&[0x12, 0x00, 0x00, 0x00, FULL]).with_error(NACK), // in a run: ch 3 off, NACKed
        w(&[0x12, 0x00, 0x00, 0x00, FULL]),
        w(&[ALL_LED_OFF_H, FULL]).with_error(NACK),
    ]);
    let (mut dev, mut delay, _) = logged(&expect);
    dev.init(1526, &mut delay).unwrap();
    assert!(dev.set_duty(3, 256).unwrap());
    let err = dev.set_duty(3, 512).unwrap_err();
    assert!(err.is_nack());
    assert_eq!(
        dev.duty(3),
        None,
        "a failed write leaves the channel unknown"
    );
    assert_eq!(dev.duty(2), Some(0), "and only that channel");
    assert!(
        dev.set_duty(3, 256).unwrap(),
        "same duty as before, but it must go out"
    );
    assert!(dev.set_duties(&[0; 16]).is_err());
    assert_eq!(dev.duty(3), None);
    assert!(dev.set_duties(&[0; 16]).unwrap());
    assert!(dev.all_off().is_err());
    assert_eq!(
        dev.duties(),
        [None; 16],
        "a failed all_off leaves every channel unknown"
    );
    dev.destroy().mock.done();
}

#[test]
fn invalidate_makes_the_next_write_go_out() {
    let mut expect = init_sequence(3);
    expect.push(w(&[LED0_ON_L, 0x00, 0x00, 0x00, FULL]));
    let (mut dev, mut delay, _) = logged(&expect);
    dev.init(1526, &mut delay).unwrap();
    dev.invalidate();
    assert!(dev.set_duty(0, 0).unwrap());
    dev.destroy().mock.done();
}
