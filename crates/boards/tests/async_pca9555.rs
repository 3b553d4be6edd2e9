//! The async driver (feature `async`) on the mock's embedded-hal-async bus.
#![cfg(feature = "async")]

use core::future::Future;
use core::pin::pin;
use core::task::{Context, Poll, Waker};

use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::i2c::{Mock, Transaction};
use orch_boards::asynch::Pca9555Async;

// Datasheet values, typed again here on purpose.
const INPUT_PORT_0: u8 = 0x00;
const OUTPUT_PORT_0: u8 = 0x02;
const CONFIGURATION_0: u8 = 0x06;
const ADDR: u8 = 0x24;

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

#[test]
fn async_init_zeroes_outputs_before_making_pins_outputs() {
    let mut dev = Pca9555Async::new(
        Mock::new(&[
            Transaction::write(ADDR, vec![OUTPUT_PORT_0, 0x00, 0x00]),
            Transaction::write(ADDR, vec![CONFIGURATION_0, 0x00, 0x00]),
        ]),
        ADDR,
    );
    block_on(dev.init()).unwrap();
    assert_eq!(dev.last_written(), Some(0));
    dev.destroy().done();
}

#[test]
fn async_key_change_is_one_write_and_unchanged_is_skipped() {
    let mut dev = Pca9555Async::new(
        Mock::new(&[Transaction::write(ADDR, vec![OUTPUT_PORT_0, 0x00, 0x10])]),
        ADDR,
    );
    assert!(block_on(dev.update_outputs(1 << 12)).unwrap());
    assert!(!block_on(dev.update_outputs(1 << 12)).unwrap());
    dev.destroy().done();
}

#[test]
fn async_nack_is_typed_and_next_update_retries() {
    let mut dev = Pca9555Async::new(
        Mock::new(&[
            Transaction::write(ADDR, vec![OUTPUT_PORT_0, 0x01, 0x00]).with_error(NACK),
            Transaction::write(ADDR, vec![OUTPUT_PORT_0, 0x01, 0x00]),
            Transaction::write_read(ADDR, vec![INPUT_PORT_0], vec![0x01, 0x00]),
        ]),
        ADDR,
    );
    assert!(block_on(dev.update_outputs(1)).unwrap_err().is_nack());
    assert!(block_on(dev.update_outputs(1)).unwrap());
    assert_eq!(block_on(dev.read_inputs()).unwrap(), 1);
    dev.destroy().done();
}
