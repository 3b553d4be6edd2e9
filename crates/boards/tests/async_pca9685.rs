//! The async PCA9685 driver (feature `async`) on the mock's embedded-hal-async bus and delay:
//! the same bytes as the blocking driver.
#![cfg(feature = "async")]

use core::future::Future;
use core::pin::pin;
use core::task::{Context, Poll, Waker};

use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::delay::{CheckedDelay, Transaction as Wait};
use embedded_hal_mock::eh1::i2c::{Mock, Transaction};
use orch_boards::asynch::Pca9685Async;
use orch_boards::Error;

// Data sheet values, typed again here on purpose.
const MODE1: u8 = 0x00;
const MODE2: u8 = 0x01;
const ALL_LED_OFF_H: u8 = 0xFD;
const PRE_SCALE: u8 = 0xFE;
const RESTART: u8 = 0x80;
const AI: u8 = 0x20;
const SLEEP: u8 = 0x10;
const OUTDRV: u8 = 0x04;
const FULL: u8 = 0x10;
const ADDR: u8 = 0x43;

const NACK: ErrorKind = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address);

/// Polls a future to completion; the mock's futures are ready at once.
fn block_on<F: Future>(f: F) -> F::Output {
    let mut f = pin!(f);
    let mut cx = Context::from_waker(Waker::noop());
    loop {
        if let Poll::Ready(v) = f.as_mut().poll(&mut cx) {
            return v;
        }
    }
}

fn w(bytes: &[u8]) -> Transaction {
    Transaction::write(ADDR, bytes.to_vec())
}

fn init_sequence() -> Vec<Transaction> {
    vec![
        w(&[ALL_LED_OFF_H, FULL]),
        w(&[MODE1, SLEEP | AI]),
        w(&[PRE_SCALE, 3]),
        w(&[MODE2, OUTDRV]),
        w(&[MODE1, AI]),
    ]
}

#[test]
fn async_init_duty_all_off_sleep_restart() {
    let mut expect = init_sequence();
    expect.extend([
        w(&[0x0A, 0x00, 0x01, 0x00, 0x02]), // channel 1, duty 256
        w(&[ALL_LED_OFF_H, FULL]),
        w(&[MODE1, SLEEP | AI]),
        Transaction::write_read(ADDR, vec![MODE1], vec![RESTART | SLEEP | AI]),
        w(&[MODE1, AI]),
        w(&[MODE1, RESTART | AI]),
    ]);
    let mut dev = Pca9685Async::new(Mock::new(&expect), ADDR);
    let mut delay = CheckedDelay::new(&[Wait::async_delay_us(500), Wait::async_delay_us(500)]);
    block_on(dev.init(1526, &mut delay)).unwrap();
    assert!(block_on(dev.set_duty(1, 256)).unwrap());
    assert!(!block_on(dev.set_duty(1, 256)).unwrap());
    block_on(dev.all_off()).unwrap();
    block_on(dev.sleep()).unwrap();
    assert!(block_on(dev.restart(&mut delay)).unwrap());
    dev.destroy().done();
    delay.done();
}

#[test]
fn async_set_duties_is_one_write_of_the_changed_run() {
    let mut expect = init_sequence();
    expect.push(w(&[
        0x3E, 0x00, 0x0E, 0xE8, 0x01, // ch 14, duty 1000: ON 3584, OFF wraps to 488
        0x00, 0x10, 0x00, 0x00, //       ch 15, full ON
    ]));
    let mut dev = Pca9685Async::new(Mock::new(&expect), ADDR);
    let mut delay = CheckedDelay::new(&[Wait::async_delay_us(500)]);
    block_on(dev.init(1526, &mut delay)).unwrap();
    let mut duties = [0; 16];
    duties[14] = 1000;
    duties[15] = 4095;
    assert!(block_on(dev.set_duties(&duties)).unwrap());
    assert!(!block_on(dev.set_duties(&duties)).unwrap());
    dev.destroy().done();
    delay.done();
}

#[test]
fn async_failed_write_forgets_and_bad_frequency_is_refused() {
    let mut expect = init_sequence();
    expect.extend([
        w(&[0x06, 0x00, 0x00, 0x01, 0x00]).with_error(NACK),
        w(&[0x06, 0x00, 0x00, 0x01, 0x00]),
    ]);
    let mut dev = Pca9685Async::new(Mock::new(&expect), ADDR);
    let mut delay = CheckedDelay::new(&[Wait::async_delay_us(500)]);
    assert_eq!(
        block_on(dev.init(2000, &mut delay)),
        Err(Error::Frequency { hz: 2000 })
    );
    block_on(dev.init(1526, &mut delay)).unwrap();
    assert!(block_on(dev.set_duty(0, 1)).unwrap_err().is_nack());
    assert_eq!(dev.duty(0), None);
    assert!(block_on(dev.set_duty(0, 1)).unwrap());
    dev.destroy().done();
    delay.done();
}
