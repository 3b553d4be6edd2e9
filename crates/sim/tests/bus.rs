//! The virtual I2C bus through its public face: embedded-hal 1.0 `I2c`, timing and errors.

use embedded_hal::i2c::{Error as _, ErrorKind, I2c, NoAcknowledgeSource, Operation};
use orch_core::Instant;
use orch_sim::pca9555::{CONFIGURATION_0, INPUT_PORT_0, OUTPUT_PORT_0, POLARITY_INVERSION_0};
use orch_sim::{BusClock, BusError, Pca9555, SimTime, VirtualBus};
use proptest::prelude::*;

fn bus_with_board(clock: BusClock) -> VirtualBus {
    let mut bus = VirtualBus::new(clock);
    bus.attach(Pca9555::new(0x21));
    bus
}

#[test]
fn absent_address_nacks_with_no_acknowledge_address() {
    let mut bus = bus_with_board(BusClock::THESIS);
    let err = bus.write(0x25, &[OUTPUT_PORT_0, 1, 0]).unwrap_err();
    assert_eq!(err, BusError::AddressNack { address: 0x25 });
    assert_eq!(
        err.kind(),
        ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address)
    );
    let stats = bus.stats();
    // START + the NACKed address byte + STOP.
    assert_eq!(
        (stats.transactions, stats.nacks, stats.bit_times),
        (1, 1, 11)
    );
    assert_eq!(stats.busy_nanos, 11 * 12_000);
    assert!(
        bus.log().is_empty(),
        "a NACKed write is not a completed write"
    );
}

#[test]
fn non_seven_bit_address_is_an_error_and_sends_nothing() {
    let mut bus = bus_with_board(BusClock::THESIS);
    let err = bus.write(0x80, &[0]).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Other);
    assert_eq!(bus.stats().transactions, 0);
}

fn four_byte_write_duration(clock: BusClock) -> (u64, SimTime) {
    let mut bus = bus_with_board(clock);
    bus.write(0x21, &[OUTPUT_PORT_0, 0x34, 0x12]).unwrap();
    let (start, end) = bus.last_transaction().unwrap();
    assert_eq!(start, SimTime::ZERO);
    (bus.stats().bit_times, end)
}

#[test]
fn four_byte_write_is_38_bit_times_456_us_at_83_khz() {
    assert_eq!(
        four_byte_write_duration(BusClock::THESIS),
        (38, SimTime::from_micros(456))
    );
}

#[test]
fn four_byte_write_is_95_us_at_400_khz() {
    assert_eq!(
        four_byte_write_duration(BusClock::FAST),
        (38, SimTime::from_micros(95))
    );
}

#[test]
fn four_byte_write_is_380_us_at_100_khz() {
    assert_eq!(
        four_byte_write_duration(BusClock::STANDARD),
        (38, SimTime::from_micros(380))
    );
}

#[test]
fn byte_and_busy_counters_add_up() {
    let mut bus = bus_with_board(BusClock::THESIS);
    bus.write(0x21, &[OUTPUT_PORT_0, 0, 0]).unwrap();
    let mut buf = [0; 2];
    // write_read: START, addr, cmd, Sr, addr, 2 data, STOP = 1 + 18 + 1 + 27 + 1 = 48.
    bus.write_read(0x21, &[OUTPUT_PORT_0], &mut buf).unwrap();
    let s = bus.stats();
    assert_eq!(s.transactions, 2);
    assert_eq!(s.bytes, 4 + 5);
    assert_eq!(s.bit_times, 38 + 48);
    assert_eq!(s.busy_nanos, (38 + 48) * 12_000);
}

#[test]
fn write_issued_while_busy_starts_when_the_bus_is_free() {
    let mut bus = VirtualBus::new(BusClock::THESIS);
    bus.attach(Pca9555::new(0x21));
    bus.attach(Pca9555::new(0x22));
    bus.set_time(Instant::from_micros(1_000));
    bus.write(0x21, &[OUTPUT_PORT_0, 1, 0]).unwrap();
    bus.set_time(Instant::from_micros(1_100)); // the first write is still on the wire
    bus.write(0x22, &[OUTPUT_PORT_0, 2, 0]).unwrap();
    let log = bus.log();
    assert_eq!(
        (log[0].start, log[0].end),
        (SimTime::from_micros(1_000), SimTime::from_micros(1_456))
    );
    assert_eq!(
        (log[1].start, log[1].end),
        (SimTime::from_micros(1_456), SimTime::from_micros(1_912))
    );
    // An idle bus starts at the present.
    bus.set_time(Instant::from_micros(5_000));
    bus.write(0x21, &[OUTPUT_PORT_0, 0, 0]).unwrap();
    assert_eq!(bus.log()[2].start, SimTime::from_micros(5_000));
    assert_eq!(bus.free_at(), SimTime::from_micros(5_456));
}

#[test]
fn write_log_keeps_address_bytes_and_driven_pins() {
    let mut bus = bus_with_board(BusClock::THESIS);
    bus.write(0x21, &[CONFIGURATION_0, 0, 0]).unwrap();
    bus.write(0x21, &[OUTPUT_PORT_0, 0x01, 0x80]).unwrap();
    let w = &bus.log()[1];
    assert_eq!(w.address, 0x21);
    assert_eq!(w.bytes, vec![OUTPUT_PORT_0, 0x01, 0x80]);
    assert_eq!(w.driven, 0x8001);
}

#[test]
fn pin_changes_are_stamped_at_completion() {
    let mut bus = bus_with_board(BusClock::THESIS);
    bus.write(0x21, &[OUTPUT_PORT_0, 0, 0]).unwrap();
    bus.write(0x21, &[CONFIGURATION_0, 0, 0]).unwrap();
    assert!(bus.take_pin_changes().is_empty(), "outputs were low");
    bus.write(0x21, &[OUTPUT_PORT_0, 0x04, 0]).unwrap();
    let changes = bus.take_pin_changes();
    assert_eq!(changes.len(), 1);
    assert_eq!(changes[0].time, SimTime::from_micros(3 * 456));
    assert_eq!((changes[0].before, changes[0].after), (0, 0x0004));
}

#[test]
fn register_pair_toggles_through_i2c_reads_and_writes() {
    let mut bus = bus_with_board(BusClock::THESIS);
    bus.write(0x21, &[POLARITY_INVERSION_0, 0x12, 0x34, 0x56])
        .unwrap();
    let mut buf = [0; 4];
    bus.write_read(0x21, &[POLARITY_INVERSION_0], &mut buf)
        .unwrap();
    assert_eq!(buf, [0x56, 0x34, 0x56, 0x34]);
    // Adjacent reads are one frame: the pair keeps toggling across buffers.
    let (mut a, mut b) = ([0; 1], [0; 2]);
    bus.transaction(
        0x21,
        &mut [Operation::Read(&mut a), Operation::Read(&mut b)],
    )
    .unwrap();
    assert_eq!((a, b), ([0x56], [0x34, 0x56]));
}

#[test]
fn power_up_registers_read_over_i2c() {
    let mut bus = bus_with_board(BusClock::THESIS);
    let mut regs = [0; 2];
    for (command, expected) in [
        (INPUT_PORT_0, [0x00, 0x00]),
        (OUTPUT_PORT_0, [0xFF, 0xFF]),
        (POLARITY_INVERSION_0, [0x00, 0x00]),
        (CONFIGURATION_0, [0xFF, 0xFF]),
    ] {
        bus.write_read(0x21, &[command], &mut regs).unwrap();
        assert_eq!(regs, expected, "command {command:#04x}");
    }
}

#[test]
fn input_port_reads_the_driven_pins() {
    let mut bus = bus_with_board(BusClock::THESIS);
    bus.write(0x21, &[OUTPUT_PORT_0, 0xA5, 0x0F]).unwrap();
    bus.write(0x21, &[CONFIGURATION_0, 0x0F, 0x00]).unwrap(); // pins 0..=3 inputs
    let mut levels = [0; 2];
    bus.write_read(0x21, &[INPUT_PORT_0], &mut levels).unwrap();
    assert_eq!(levels, [0xA0, 0x0F]);
}

proptest! {
    #[test]
    fn any_write_costs_start_9_bits_a_byte_and_stop(data in proptest::collection::vec(any::<u8>(), 0..40)) {
        let mut bus = bus_with_board(BusClock::FAST);
        bus.write(0x21, &data).unwrap();
        let bits = 1 + 9 * (1 + data.len() as u64) + 1;
        prop_assert_eq!(bus.stats().bit_times, bits);
        // 2.5 µs a bit, rounded up to the nanosecond (exact here).
        prop_assert_eq!(bus.free_at().as_nanos(), bits * 2_500);
    }
}
