//! One PCA9555 on a mock bus: the exact bytes of the public API.

use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::i2c::{Mock, Transaction};
use orch_boards::{Error, Pca9555, Tca9555};

// Datasheet values, typed again here on purpose: a wrong constant in the crate must fail.
const INPUT_PORT_0: u8 = 0x00;
const OUTPUT_PORT_0: u8 = 0x02;
const CONFIGURATION_0: u8 = 0x06;
const ALL_OUTPUTS: u8 = 0x00;
const ADDR: u8 = 0x21;

const NACK: ErrorKind = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address);

fn zero_outputs(addr: u8) -> Transaction {
    Transaction::write(addr, vec![OUTPUT_PORT_0, 0x00, 0x00])
}

fn all_pins_outputs(addr: u8) -> Transaction {
    Transaction::write(addr, vec![CONFIGURATION_0, ALL_OUTPUTS, ALL_OUTPUTS])
}

#[test]
fn init_zeroes_outputs_before_making_pins_outputs() {
    // The mock checks order: the configuration write must come strictly after the zeroing.
    let mut dev = Pca9555::new(
        Mock::new(&[zero_outputs(ADDR), all_pins_outputs(ADDR)]),
        ADDR,
    );
    dev.init().unwrap();
    assert_eq!(dev.last_written(), Some(0));
    dev.destroy().done();
}

#[test]
fn init_that_cannot_zero_outputs_never_makes_pins_outputs() {
    // After a NACK on the zeroing write no configuration write may follow: with outputs still
    // at their power-up 1s, it would energise every solenoid.
    let mut dev = Pca9555::new(Mock::new(&[zero_outputs(ADDR).with_error(NACK)]), ADDR);
    let err = dev.init().unwrap_err();
    assert_eq!(err, Error::I2c(NACK));
    assert_eq!(dev.last_written(), None);
    dev.destroy().done();
}

#[test]
fn single_key_change_is_one_write_of_both_ports() {
    // Output 9 is port 1 bit 1: [0x02, lo=0x00, hi=0x02], one transaction.
    let mut dev = Pca9555::new(
        Mock::new(&[
            Transaction::write(ADDR, vec![OUTPUT_PORT_0, 0x00, 0x02]),
            Transaction::write(ADDR, vec![OUTPUT_PORT_0, 0x01, 0x02]),
        ]),
        ADDR,
    );
    dev.set_outputs(1 << 9).unwrap();
    dev.set_outputs((1 << 9) | 1).unwrap();
    dev.destroy().done();
}

#[test]
fn set_outputs_always_writes_update_outputs_skips_unchanged() {
    let mut dev = Pca9555::new(
        Mock::new(&[
            zero_outputs(ADDR),
            all_pins_outputs(ADDR),
            Transaction::write(ADDR, vec![OUTPUT_PORT_0, 0x10, 0x00]),
            Transaction::write(ADDR, vec![OUTPUT_PORT_0, 0x10, 0x00]),
        ]),
        ADDR,
    );
    dev.init().unwrap();
    assert!(!dev.update_outputs(0).unwrap(), "init already wrote 0");
    assert!(dev.update_outputs(0x0010).unwrap());
    assert!(!dev.update_outputs(0x0010).unwrap());
    dev.set_outputs(0x0010).unwrap();
    dev.destroy().done();
}

#[test]
fn nack_is_a_typed_error_and_the_next_update_retries() {
    let mut dev = Pca9555::new(
        Mock::new(&[
            Transaction::write(ADDR, vec![OUTPUT_PORT_0, 0x80, 0x00]),
            Transaction::write(ADDR, vec![OUTPUT_PORT_0, 0x80, 0x00]).with_error(NACK),
            Transaction::write(ADDR, vec![OUTPUT_PORT_0, 0x80, 0x00]),
        ]),
        ADDR,
    );
    dev.set_outputs(0x0080).unwrap();
    // Board reset behind our back: the caller forgets, rewrites, and the bus NACKs.
    dev.invalidate();
    let err = dev.update_outputs(0x0080).unwrap_err();
    assert!(err.is_nack());
    assert_eq!(err.i2c_kind(), Some(NACK));
    assert_eq!(
        dev.last_written(),
        None,
        "a failed write leaves the value unknown"
    );
    assert!(
        dev.update_outputs(0x0080).unwrap(),
        "same value, but it must go out again"
    );
    dev.destroy().done();
}

#[test]
fn reads_take_port_0_as_the_low_byte() {
    let mut dev = Pca9555::new(
        Mock::new(&[
            Transaction::write_read(ADDR, vec![OUTPUT_PORT_0], vec![0x34, 0x12]),
            Transaction::write_read(ADDR, vec![INPUT_PORT_0], vec![0xCD, 0xAB]),
        ]),
        ADDR,
    );
    assert_eq!(dev.read_outputs().unwrap(), 0x1234);
    assert_eq!(dev.read_inputs().unwrap(), 0xABCD);
    dev.destroy().done();
}

#[test]
fn destroy_hands_back_the_bus_without_traffic() {
    let dev: Tca9555<Mock> = Tca9555::new(Mock::new(&[]), 0x27);
    assert_eq!(dev.address(), 0x27);
    let mut bus = dev.destroy();
    bus.done();
}
