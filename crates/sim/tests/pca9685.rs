//! The PCA9685 model driven through `orch-boards`' real driver over the timed bus, beside a
//! PCA9555 on the same bus.

use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::I2c;
use orch_boards::Pca9685 as Driver;
use orch_sim::{BusClock, DutyChange, Pca9555, Pca9685, SimTime, VirtualBus};

const PWM: u8 = 0x40;

/// The driver's waits, counted; the bus's time is set by the test.
#[derive(Default)]
struct Waits(u64);

impl DelayNs for Waits {
    fn delay_ns(&mut self, ns: u32) {
        self.0 += u64::from(ns);
    }
}

fn bus(clock: BusClock) -> VirtualBus {
    let mut bus = VirtualBus::new(clock);
    bus.attach(Pca9685::new(PWM));
    bus
}

fn ready(bus: &mut VirtualBus) -> Driver<&mut VirtualBus> {
    let mut waits = Waits::default();
    let mut dev = Driver::new(bus, PWM);
    dev.init(1526, &mut waits).unwrap();
    assert_eq!(waits.0, 500_000);
    dev
}

fn only(changes: Vec<DutyChange>) -> DutyChange {
    assert_eq!(changes.len(), 1, "{changes:?}");
    changes[0]
}

#[test]
fn init_from_power_up_energises_nothing_and_leaves_the_chip_awake_at_1526_hz() {
    let mut bus = bus(BusClock::FAST);
    assert!(bus.pca9685(PWM).unwrap().sleeping(), "power-up: asleep");
    ready(&mut bus);
    let chip = bus.pca9685(PWM).unwrap();
    assert!(!chip.sleeping());
    assert_eq!(chip.pre_scale(), 3);
    assert_eq!(chip.period_nanos(), 655_360);
    assert_eq!(chip.duties(), [0; 16]);
    assert!(
        bus.take_duty_changes().is_empty(),
        "no write of init changed an output"
    );
    assert!(bus.log().iter().all(|w| w.duty == Some([0; 16])));
    assert_eq!(bus.log().len(), 5);
}

#[test]
fn one_key_change_is_one_write_of_56_bit_times_and_its_duty_changes_at_the_stop() {
    for (clock, micros) in [(BusClock::FAST, 140), (BusClock::from_hz(1_000_000), 56)] {
        let mut bus = bus(clock);
        let mut dev = ready(&mut bus);
        dev.bus_mut().set_time(SimTime::from_millis(10));
        assert!(dev.set_duty(5, 2048).unwrap());
        assert!(dev.set_duty(14, 1000).unwrap()); // ON 3584, OFF wraps to 488
        let writes = &bus.log()[5..];
        assert_eq!(writes.len(), 2);
        assert_eq!(writes[0].bytes.len(), 5);
        let change = bus.take_duty_changes()[0];
        assert_eq!(change.time, SimTime::from_micros(10_000 + micros));
        assert_eq!((change.before[5], change.after[5]), (0, 2048));
        let chip = bus.pca9685(PWM).unwrap();
        assert_eq!((chip.duty(5), chip.duty(14)), (2048, 1000));
        assert_eq!(chip.driven(), (1 << 5) | (1 << 14));
    }
}

#[test]
fn full_on_and_full_off_reach_the_pins() {
    let mut bus = bus(BusClock::FAST);
    let mut dev = ready(&mut bus);
    dev.set_duty(0, 4095).unwrap();
    dev.set_duty(1, 1).unwrap();
    let chip = bus.pca9685(PWM).unwrap();
    assert_eq!((chip.high_counts(0), chip.high_counts(1)), (4096, 1));
    let mut dev = Driver::new(&mut bus, PWM);
    dev.invalidate();
    dev.set_duty(0, 0).unwrap();
    assert_eq!(bus.pca9685(PWM).unwrap().high_counts(0), 0);
}

#[test]
fn a_chord_changes_together_in_one_transaction() {
    let mut bus = bus(BusClock::FAST);
    let mut dev = ready(&mut bus);
    let mut duties = [0; 16];
    duties[3] = 4095;
    duties[7] = 3000;
    duties[11] = 1500;
    dev.set_duties(&duties).unwrap();
    let change = only(bus.take_duty_changes());
    assert_eq!(change.after, duties);
    let last = bus.log().last().unwrap();
    assert_eq!(last.bytes.len(), 1 + 4 * 9, "channels 3..=11");
    assert_eq!(last.duty, Some(duties));
}

#[test]
fn all_off_sleep_and_restart() {
    let mut bus = bus(BusClock::FAST);
    let mut dev = ready(&mut bus);
    let mut waits = Waits::default();
    dev.set_duty(2, 1200).unwrap();
    dev.sleep().unwrap();
    assert!(dev.restart(&mut waits).unwrap(), "a channel was running");
    dev.all_off().unwrap();
    dev.sleep().unwrap();
    assert!(!dev.restart(&mut waits).unwrap(), "nothing was running");
    let changes = bus.take_duty_changes();
    let at_2: Vec<u16> = changes.iter().map(|c| c.after[2]).collect();
    // on, asleep (off), restarted (on), all off; the second sleep changes nothing.
    assert_eq!(at_2, [1200, 0, 1200, 0]);
    assert!(changes.windows(2).all(|w| w[0].time <= w[1].time));
    assert_eq!(bus.log().last().unwrap().bytes, vec![0x00, 0x20]);
}

#[test]
fn a_board_reset_behind_the_drivers_back_is_turned_off_and_rewritten_by_init() {
    let mut bus = bus(BusClock::FAST);
    let mut dev = ready(&mut bus);
    dev.set_duty(9, 700).unwrap();
    dev.bus_mut().pca9685_mut(PWM).unwrap().reset(); // a brown-out: asleep, all off
    dev.init(1526, &mut Waits::default()).unwrap();
    assert!(dev.set_duty(9, 700).unwrap());
    assert_eq!(bus.pca9685(PWM).unwrap().duty(9), 700);
}

#[test]
fn oe_high_stops_every_output_and_the_registers_stay() {
    let mut bus = bus(BusClock::FAST);
    let mut dev = ready(&mut bus);
    dev.set_duties(&[2000; 16]).unwrap();
    let chip = bus.pca9685_mut(PWM).unwrap();
    chip.set_output_enable(false);
    assert_eq!(chip.duties(), [0; 16]);
    chip.set_output_enable(true);
    assert_eq!(chip.duties(), [2000; 16]);
}

#[test]
fn mixed_boards_on_one_bus_each_report_their_own_changes() {
    let mut bus = bus(BusClock::FAST);
    bus.attach(Pca9555::new(0x21));
    let mut io = orch_boards::Pca9555::new(&mut bus, 0x21);
    io.init().unwrap();
    io.set_outputs(0x0101).unwrap();
    let mut pwm = ready(&mut bus);
    pwm.set_duty(0, 100).unwrap();
    let pins = bus.take_pin_changes();
    assert_eq!(pins.len(), 1);
    assert_eq!((pins[0].address, pins[0].after), (0x21, 0x0101));
    let duties = only(bus.take_duty_changes());
    assert_eq!((duties.address, duties.after[0]), (PWM, 100));
    assert!(bus.device(PWM).is_none() && bus.pca9685(0x21).is_none());
    assert_eq!(bus.devices().len(), 1);
    assert_eq!(bus.pca9685s().len(), 1);
    // The PCA9555 log line has no duty; the PCA9685's does.
    assert!(bus
        .log()
        .iter()
        .filter(|w| w.address == 0x21)
        .all(|w| w.duty.is_none()));
    assert!(bus.write(0x41, &[0x00, 0x20]).is_err(), "no device at 0x41");
}

#[test]
fn reads_go_through_the_bus() {
    let mut bus = bus(BusClock::FAST);
    ready(&mut bus);
    let mut mode = [0; 2];
    bus.write_read(PWM, &[0x00], &mut mode).unwrap();
    assert_eq!(
        mode,
        [0x20, 0x04],
        "MODE1 awake with AI, then MODE2 totem pole"
    );
}

#[test]
fn four_pwm_boards_at_0x40_to_0x43_through_the_set() {
    let mut bus = VirtualBus::new(BusClock::FAST);
    for a in 0x40..=0x43 {
        bus.attach(Pca9685::new(a));
    }
    let mut set = orch_boards::Pca9685Set::new(bus, [0x40, 0x41, 0x42, 0x43]);
    set.init(1526, &mut Waits::default()).unwrap();
    set.bus_mut().set_time(SimTime::from_millis(5));
    set.set_duty(3, 12, 4095).unwrap();
    set.set_duty(3, 12, 1434).unwrap(); // strike, then hold at 35 %
    let mut bus = set.destroy();
    let changes = bus.take_duty_changes();
    assert_eq!(changes.len(), 2);
    assert!(changes.iter().all(|c| c.address == 0x43));
    assert_eq!(changes[0].time, SimTime::from_micros(5_140));
    assert_eq!(changes[1].time, SimTime::from_micros(5_280));
    assert_eq!(bus.pca9685(0x43).unwrap().duty(12), 1434);
    assert!(bus.pca9685s().iter().take(3).all(|c| c.duties() == [0; 16]));
}

#[test]
fn a_pwm_write_logs_its_duties_and_a_pca9555_write_stays_as_it_was() {
    let mut bus = bus(BusClock::FAST);
    bus.attach(Pca9555::new(0x21));
    bus.write(0x21, &[0x02, 0x01, 0x00]).unwrap();
    let mut dev = ready(&mut bus);
    dev.set_duty(1, 300).unwrap();
    let io = serde_json::to_value(&bus.log()[0]).unwrap();
    assert!(io.get("duty").is_none(), "{io}");
    let pwm = serde_json::to_value(bus.log().last().unwrap()).unwrap();
    let mut duty = [0u16; 16];
    duty[1] = 300;
    assert_eq!(pwm["duty"], serde_json::json!(duty));
    assert_eq!(pwm["driven"], 2);
}
