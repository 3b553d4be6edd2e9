//! A panic in the firmware lets every key go at once, wherever it strikes: the HIL harness
//! sends the CPU into `abort` (where `-Cpanic=immediate-abort` sends every panic) at chosen
//! moments of a note's write, with keys held on all four boards.

use orch_atmega16_hil::{Bus, Cpu};

/// Configuration writes `[0x06, 0, 0]` (all pins outputs): four at each power-up.
fn configurations(bus: &Bus) -> usize {
    bus.log.iter().filter(|t| t.bytes == [0x06, 0, 0]).count()
}

/// Boots, holds a key on every board, then sends `lead` and runs until `moment` before the
/// panic. Returns the simulator and how long after the panic every output was 0 (µs).
fn panic_when(lead: &[u8], moment: impl FnMut(&Bus) -> bool) -> (Cpu, u64) {
    let mut cpu = Cpu::new();
    cpu.run_us(20_000);
    assert_eq!(configurations(&cpu.bus.borrow()), 4, "power-up");
    // Notes 36, 52, 68 and 84: keys 0, 16, 32 and 48, one on each board.
    cpu.send(&[0x90, 36, 100, 52, 100, 68, 100, 84, 100]);
    cpu.run_us(3_000);
    assert!(
        cpu.outputs().iter().all(|&o| o != 0),
        "{:x?}",
        cpu.outputs()
    );
    for &b in lead {
        cpu.sim.write_uart('0', b);
    }
    assert!(cpu.run_us_until(5_000, moment), "the moment never came");
    cpu.jump_to("abort");
    let at = cpu.now_us();
    assert!(
        cpu.run_us_until(10_000, |bus| bus.outputs() == [0; 4]),
        "keys still held 10 ms after the panic: {:x?}",
        cpu.outputs()
    );
    let up = cpu.now_us() - at;
    (cpu, up)
}

/// WDTCR (I/O 0x21, data space 0x41): WDE (bit 3) and the prescaler (bits 2..0).
const WDTCR: u16 = 0x41;
const WDE: u8 = 1 << 3;
/// WDP2 | WDP0: 512 K cycles of the watchdog's 1 MHz oscillator, about 0.5 s.
const WDP_HALF_SECOND: u8 = 0b101;

/// After the keys are up, the firmware waits for the watchdog: interrupts off (so no write
/// follows), the watchdog on at about 0.5 s and never reset again, the CPU in `abort`'s final
/// loop. (simavr itself crashes in its watchdog reset, in `avr_irq_register_notify` as it
/// resets the UART, so the reset is not run here: power-up's release is tested on its own.)
fn waits_for_the_watchdog(cpu: Cpu) {
    waits_for_the_watchdog_with(cpu, [0; 4]);
}

/// [`waits_for_the_watchdog`], the boards holding `outputs`.
fn waits_for_the_watchdog_with(mut cpu: Cpu, outputs: [u16; 4]) {
    // The last write's STOP.
    cpu.run_us(1_000);
    let writes = cpu.bus.borrow().log.len();
    cpu.run_us(400_000);
    assert_eq!(cpu.outputs(), outputs);
    assert_eq!(
        cpu.bus.borrow().log.len(),
        writes,
        "nothing written after the release"
    );
    assert!(!cpu.interrupts_on());
    assert_eq!(cpu.data(WDTCR) & (WDE | 0b111), WDE | WDP_HALF_SECOND);
    let abort =
        orch_atmega16_hil::symbol_address(&orch_atmega16_hil::elf_path(), "abort").expect("abort");
    let pc = cpu.pc();
    assert!(
        (abort..abort + 0x100).contains(&pc),
        "pc {pc:#x}, abort at {abort:#x}"
    );
}

#[test]
fn a_panic_with_the_bus_idle_lets_every_key_go_at_once() {
    let (cpu, up) = panic_when(&[], |_| true);
    println!("bus idle: every key up {up} µs after the panic");
    // Four polled writes of 38 bit times at 83.33 kHz (456 µs each) and the bus freed first.
    assert!(up < 2_500, "{up} µs");
    waits_for_the_watchdog(cpu);
}

#[test]
fn a_panic_inside_a_write_lets_every_key_go_at_once() {
    // A Note-On for key 1 (board 0): the panic when its write has the register byte and the
    // low output byte on the bus, the high one still to come.
    let (cpu, up) = panic_when(&[0x90, 37, 100], |bus| bus.boards[0].in_write() == Some(2));
    println!("inside a write: every key up {up} µs after the panic");
    assert!(up < 2_500, "{up} µs");
    waits_for_the_watchdog(cpu);
}

#[test]
fn a_panic_with_the_bus_held_for_a_velocity_lets_every_key_go_at_once() {
    // A Note-On's status and note byte only: its board addressed ahead, the bus held (SCL
    // low) for the velocity that never comes.
    let (cpu, up) = panic_when(&[0x90, 53], |bus| bus.boards[1].in_write() == Some(1));
    println!("bus held ahead: every key up {up} µs after the panic");
    assert!(up < 2_500, "{up} µs");
    waits_for_the_watchdog(cpu);
}

#[test]
fn a_panic_with_a_board_not_answering_still_lets_the_others_go() {
    let mut cpu = Cpu::new();
    cpu.run_us(20_000);
    cpu.send(&[0x90, 36, 100, 52, 100, 68, 100, 84, 100]);
    cpu.run_us(3_000);
    let held = cpu.outputs();
    assert!(held.iter().all(|&o| o != 0), "{held:x?}");
    // Board 2 stops answering (its keys are out of reach), then the panic.
    cpu.bus.borrow_mut().boards[2].nack = true;
    cpu.jump_to("abort");
    let at = cpu.now_us();
    let released = |bus: &Bus| {
        let o = bus.outputs();
        o[0] == 0 && o[1] == 0 && o[3] == 0
    };
    assert!(cpu.run_us_until(10_000, released), "{:x?}", cpu.outputs());
    let up = cpu.now_us() - at;
    println!("board 2 not answering: the other keys up {up} µs after the panic");
    assert!(up < 2_500, "{up} µs");
    assert_eq!(cpu.outputs()[2], held[2]);
    waits_for_the_watchdog_with(cpu, [0, 0, held[2], 0]);
}
