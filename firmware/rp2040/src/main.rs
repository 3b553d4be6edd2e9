//! orch on a Raspberry Pi Pico (RP2040, embassy).
//!
//! - MIDI in from USB (a USB-MIDI device, one cable) and from a DIN socket on UART0 RX
//!   (GP1, 31250 baud 8N1); every DIN byte goes out again at once on UART0 TX (GP0): MIDI
//!   thru, as the thesis's board passed its stream on to the flute robot.
//! - orch-core's interpreter and safety guard with the thesis's keyboard and boards
//!   (`Interpreter::thesis`, in a static built at compile time; the `pca9685` build's piano
//!   and drum kit, `orch-rp2040-robot`, in a static built at start-up), time from embassy-time (µs). DIN bytes go through its decoder; a USB-MIDI event carries a whole message, decoded
//!   apart so that it never splits a DIN message's running status.
//! - The four PCA9555 finger boards at 0x21..=0x24 on I2C0 (GP4 SDA, GP5 SCL) at 400 kHz,
//!   with orch-boards' async driver: each board initialised outputs-0 FIRST, THEN outputs;
//!   one write per changed board; 3 attempts, then the board is set aside and initialised
//!   again every 10 ms with its frame. Every bus operation has a time limit and a hung bus is
//!   recovered ([`bus`]): a hung board no longer hangs the loop. With the `pca9685` feature,
//!   five PCA9685 PWM boards at 0x40..=0x44 instead, a piano and a drum kit on channel 10
//!   (`orch-rp2040-robot`), keys played with strike and hold, drums with pulses that end by
//!   themselves, and the boards' output-enable pin on GP6 as the hardware stop
//!   (`pca9685.rs`); the loop is the same.
//! - The watchdog (0.5 s), fed by the interpreter loop: a hung loop resets the Pico, and
//!   power-up releases every key. A panic releases them at once, then waits for the reset.
//! - The status LED (GP25): a flash for MIDI coming in, blinking for a fault ([`led`]).
//! - The pin-out in one place: [`Pins`].
#![no_std]
#![no_main]

mod bus;
mod led;
#[cfg(feature = "pca9685")]
use orch_rp2040_robot as robot;

// The finger boards: the same interface from either file (`Boards`, `robot`, `changed`,
// `frame`, `is_off`, `release_all_now`, `ADDRESSES`).
#[cfg(not(feature = "pca9685"))]
#[path = "pca9555.rs"]
mod boards;
#[cfg(feature = "pca9685")]
#[path = "pca9685.rs"]
mod boards;

use embassy_embedded_hal::shared_bus::asynch::i2c::I2cDevice;
use embassy_executor::Spawner;
use embassy_futures::select::{select, Either};
use embassy_rp::bind_interrupts;
use embassy_rp::gpio::{Level, Output};
use embassy_rp::i2c::{self, I2c};
#[cfg(feature = "pca9685")]
use embassy_rp::peripherals::PIN_6;
use embassy_rp::peripherals::{I2C0, PIN_0, PIN_1, PIN_25, PIN_4, PIN_5, UART0, USB};
use embassy_rp::uart::{
    self, BufferedInterruptHandler, BufferedUart, BufferedUartRx, BufferedUartTx,
};
use embassy_rp::usb::{self, Driver};
use embassy_rp::watchdog::{ResetReason, Watchdog};
use embassy_rp::Peri;
use embassy_sync::blocking_mutex::raw::{CriticalSectionRawMutex, NoopRawMutex};
use embassy_sync::channel::Channel;
use embassy_sync::mutex::Mutex;
use embassy_time::{Duration, Instant as Clock, Timer};
use embassy_usb::class::midi::MidiClass;
use embassy_usb::UsbDevice;
use embedded_io_async::{Read, Write};
use orch_core::{Decoder, Instant};
use static_cell::StaticCell;

use crate::boards::{Boards, Robot};
use crate::bus::Fault;
use crate::led::Led;

bind_interrupts!(struct Irqs {
    UART0_IRQ => BufferedInterruptHandler<UART0>;
    I2C0_IRQ => i2c::InterruptHandler<I2C0>;
    USBCTRL_IRQ => usb::InterruptHandler<USB>;
});

/// The I2C clock: the PCA9555's fastest (the PCA9685 boards run at it too).
const I2C_HZ: u32 = 400_000;
/// Attempts per board write before the board is set aside.
const ATTEMPTS: u8 = 3;
/// How often boards set aside are initialised again.
const RETRY: Duration = Duration::from_millis(10);
/// The watchdog's timeout.
const WATCHDOG: Duration = Duration::from_millis(500);
/// Every board: bit `i` for board `i`.
pub(crate) const ALL: u8 = ((1u16 << boards::BOARDS) - 1) as u8;

/// The pin-out, in one place (the README's table): every GPIO the firmware uses.
struct Pins {
    /// GP0, UART0 TX: MIDI thru out.
    din_thru: Peri<'static, PIN_0>,
    /// GP1, UART0 RX: DIN MIDI in (through the opto-isolator).
    din_in: Peri<'static, PIN_1>,
    /// GP4, I2C0 SDA: the finger boards.
    sda: Peri<'static, PIN_4>,
    /// GP5, I2C0 SCL.
    scl: Peri<'static, PIN_5>,
    /// GP25: the Pico's own LED, the status LED.
    led: Peri<'static, PIN_25>,
    /// GP6: the PCA9685 boards' OE, active low (`pca9685` builds only).
    #[cfg(feature = "pca9685")]
    oe: Peri<'static, PIN_6>,
}

/// MIDI in, in arrival order, with the µs clock at arrival.
enum Input {
    /// One byte from the DIN socket.
    Din(u8, u64),
    /// The MIDI bytes of one USB-MIDI event packet (1 to 3).
    Usb([u8; 3], u8, u64),
}

static INPUT: Channel<CriticalSectionRawMutex, Input, 64> = Channel::new();

type Bus = Mutex<NoopRawMutex, I2c<'static, I2C0, i2c::Async>>;
/// One board's handle on the shared bus.
pub(crate) type BusDevice = I2cDevice<'static, NoopRawMutex, I2c<'static, I2C0, i2c::Async>>;

fn now_us() -> u64 {
    Clock::now().as_micros()
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let p = embassy_rp::init(Default::default());
    let pins = Pins {
        din_thru: p.PIN_0,
        din_in: p.PIN_1,
        sda: p.PIN_4,
        scl: p.PIN_5,
        led: p.PIN_25,
        #[cfg(feature = "pca9685")]
        oe: p.PIN_6,
    };
    // The PCA9685 boards' outputs off (OE high) first of all, until they are initialised.
    #[cfg(feature = "pca9685")]
    let oe = Output::new(pins.oe, Level::High);
    let mut watchdog = Watchdog::new(p.WATCHDOG);
    let after_reset = watchdog.reset_reason() == Some(ResetReason::TimedOut);
    watchdog.start(WATCHDOG);
    let led = Led::new(Output::new(pins.led, Level::Low), now_us(), after_reset);

    // DIN MIDI in and thru on UART0.
    static TX_BUF: StaticCell<[u8; 64]> = StaticCell::new();
    static RX_BUF: StaticCell<[u8; 64]> = StaticCell::new();
    let mut config = uart::Config::default();
    config.baudrate = 31_250;
    let din = BufferedUart::new(
        p.UART0,
        pins.din_thru,
        pins.din_in,
        Irqs,
        TX_BUF.init([0; 64]),
        RX_BUF.init([0; 64]),
        config,
    );
    // Each byte as it comes: without its FIFO the UART interrupts for every byte. With it
    // (embassy-rp's setting: interrupt at 28 of 32 bytes, or 32 bit times after the last
    // byte) a DIN message waited 1 ms after its last stop bit, and a full-rate stream came in
    // batches of 28 bytes (9 ms) stamped with one time. 31250 baud leaves the interrupt
    // 320 µs a byte. The line control register changes only with the UART off.
    let uart0 = embassy_rp::pac::UART0;
    uart0.uartcr().modify(|w| w.set_uarten(false));
    uart0.uartlcr_h().modify(|w| w.set_fen(false));
    uart0.uartcr().modify(|w| w.set_uarten(true));
    let (thru, din_rx) = din.split();
    spawner.spawn(din_task(din_rx, thru).expect("one DIN task"));

    // USB-MIDI device.
    let driver = Driver::new(p.USB, Irqs);
    let mut usb_config = embassy_usb::Config::new(0x1209, 0x0001);
    usb_config.manufacturer = Some("orch");
    usb_config.product = Some("orch piano robot");
    usb_config.max_power = 100;
    static CONFIG_DESC: StaticCell<[u8; 256]> = StaticCell::new();
    static BOS_DESC: StaticCell<[u8; 64]> = StaticCell::new();
    static CONTROL_BUF: StaticCell<[u8; 64]> = StaticCell::new();
    let mut builder = embassy_usb::Builder::new(
        driver,
        usb_config,
        CONFIG_DESC.init([0; 256]),
        BOS_DESC.init([0; 64]),
        &mut [],
        CONTROL_BUF.init([0; 64]),
    );
    let midi = MidiClass::new(&mut builder, 1, 1, 64);
    let usb = builder.build();
    spawner.spawn(usb_task(usb).expect("one USB task"));
    spawner.spawn(usb_midi_task(midi).expect("one USB-MIDI task"));

    // The finger boards.
    let mut i2c_config = i2c::Config::default();
    i2c_config.frequency = I2C_HZ;
    static BUS: StaticCell<Bus> = StaticCell::new();
    let bus = BUS.init(Mutex::new(I2c::new_async(
        p.I2C0, pins.scl, pins.sda, Irqs, i2c_config,
    )));
    let device = || I2cDevice::new(bus);
    #[cfg(not(feature = "pca9685"))]
    let mut boards = Boards::new(device);
    #[cfg(feature = "pca9685")]
    let mut boards = Boards::new(device, oe);

    interpret(&mut boards, &mut watchdog, led).await
}

/// The interpreter loop: MIDI in, the guard's timers, the boards, the watchdog, the LED.
async fn interpret(boards: &mut Boards, watchdog: &mut Watchdog, mut led: Led<'_>) -> ! {
    let robot = boards::robot();
    let mut usb_decoder: Decoder = Decoder::new();
    let mut failed: u8 = 0;
    for i in 0..boards::BOARDS {
        match boards.init(i).await {
            Ok(()) => {}
            Err(Fault::Failed) => failed |= 1 << i,
            Err(Fault::TimedOut) => {
                failed = ALL;
                break;
            }
        }
    }
    boards.in_service(failed);
    let mut retry_at = Clock::now() + RETRY;
    loop {
        watchdog.feed(WATCHDOG);
        let led_changes = led.show(now_us(), failed != 0);
        // Wake for input, the guard's next deadline, a retry round, the LED, or the watchdog.
        let mut wake = Clock::now() + WATCHDOG / 4;
        if let Some(t) = led_changes {
            wake = wake.min(Clock::from_micros(t));
        }
        if let Some(d) = robot.next_deadline() {
            wake = wake.min(Clock::from_micros(d.as_micros()));
        }
        if failed != 0 {
            wake = wake.min(retry_at);
        }
        // Whether the boards may have changed: not for a byte that only began a message or
        // continued one (orch-core's `feed` says so), so the loop does not look for changes
        // after every byte (a PWM robot's `flush_duties` computes every key's duty).
        let mut changed = true;
        match select(INPUT.receive(), Timer::at(wake)).await {
            Either::First(Input::Din(byte, at)) => {
                advance(robot, boards, &mut failed, at).await;
                changed = robot.feed(byte, Instant::from_micros(at));
                led.activity(at);
            }
            Either::First(Input::Usb(bytes, len, at)) => {
                advance(robot, boards, &mut failed, at).await;
                led.activity(at);
                for &b in &bytes[..len as usize] {
                    for message in usb_decoder.push(b) {
                        robot.handle(message, Instant::from_micros(at));
                    }
                }
            }
            Either::Second(()) => advance(robot, boards, &mut failed, now_us()).await,
        }
        if changed {
            write(robot, boards, &mut failed).await;
        }
        if failed != 0 && Clock::now() >= retry_at {
            // Boards set aside are initialised again, and sent their frame, once the bus is
            // usable (a hung transfer ended, SDA cleared).
            if bus::recover().await {
                retry(robot, boards, &mut failed).await;
            }
            retry_at = Clock::now() + RETRY;
        }
        boards.in_service(failed);
    }
}

/// Runs the guard's timers due by `at`, each at its own deadline (a strike's end among them),
/// and writes what each changed, as orch-core on the host flushes after each.
async fn advance(robot: &mut Robot, boards: &mut Boards, failed: &mut u8, at: u64) {
    while let Some(d) = robot.next_deadline().filter(|d| d.as_micros() <= at) {
        robot.tick(d);
        write(robot, boards, failed).await;
    }
}

/// Writes every changed board, [`ATTEMPTS`] times at most; a board that fails is set aside
/// in `failed` (the retry round initialises it again and sends its frame). A write that runs
/// out of time has hung the bus: every board is set aside until the bus is recovered.
async fn write(robot: &mut Robot, boards: &mut Boards, failed: &mut u8) {
    for (i, frame) in boards::changed(robot).into_iter().enumerate() {
        let Some(frame) = frame else { continue };
        if *failed & (1 << i) != 0 {
            continue;
        }
        let mut result = Err(Fault::Failed);
        for _ in 0..ATTEMPTS {
            result = boards.set(i, &frame).await;
            if result != Err(Fault::Failed) {
                break;
            }
        }
        match result {
            Ok(()) => {}
            Err(Fault::Failed) => *failed |= 1 << i,
            Err(Fault::TimedOut) => {
                *failed = ALL;
                return;
            }
        }
    }
}

/// The retry round: every board set aside is initialised again (every output off first) and
/// sent its frame; one that still fails stays aside, and a timeout sets them all aside again.
async fn retry(robot: &Robot, boards: &mut Boards, failed: &mut u8) {
    for i in 0..boards::BOARDS {
        if *failed & (1 << i) == 0 {
            continue;
        }
        let frame = boards::frame(robot, i);
        let result = match boards.init(i).await {
            Ok(()) if !boards::is_off(&frame) => boards.set(i, &frame).await,
            other => other,
        };
        match result {
            Ok(()) => *failed &= !(1 << i),
            Err(Fault::Failed) => {}
            Err(Fault::TimedOut) => {
                *failed = ALL;
                return;
            }
        }
    }
}

#[embassy_executor::task]
async fn usb_task(mut usb: UsbDevice<'static, Driver<'static, USB>>) -> ! {
    usb.run().await
}

/// USB-MIDI event packets: 4 bytes each, the code index number in the low nibble of the
/// first says how many MIDI bytes follow.
#[embassy_executor::task]
async fn usb_midi_task(mut midi: MidiClass<'static, Driver<'static, USB>>) -> ! {
    let mut buf = [0u8; 64];
    loop {
        midi.wait_connection().await;
        while let Ok(n) = midi.read_packet(&mut buf).await {
            let at = now_us();
            for event in buf[..n].chunks_exact(4) {
                let len = match event[0] & 0x0F {
                    0x5 | 0xF => 1,
                    0x2 | 0x6 | 0xC | 0xD => 2,
                    0x3 | 0x4 | 0x7 | 0x8 | 0x9 | 0xA | 0xB | 0xE => 3,
                    _ => 0, // reserved codes carry nothing
                };
                if len > 0 {
                    INPUT
                        .send(Input::Usb([event[1], event[2], event[3]], len, at))
                        .await;
                }
            }
        }
    }
}

/// DIN MIDI in: every byte thru at once, then to the interpreter.
#[embassy_executor::task]
async fn din_task(mut rx: BufferedUartRx, mut thru: BufferedUartTx) -> ! {
    let mut buf = [0u8; 16];
    loop {
        let Ok(n) = rx.read(&mut buf).await else {
            continue; // a framing or overrun error: the decoder resynchronises
        };
        let at = now_us();
        let _ = thru.write_all(&buf[..n]).await;
        for &b in &buf[..n] {
            INPUT.send(Input::Din(b, at)).await;
        }
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    // Every key up at once, then the watchdog resets the Pico (and power-up releases every
    // key again, should the bus have been hung now).
    cortex_m::interrupt::disable();
    boards::release_all_now();
    loop {}
}
