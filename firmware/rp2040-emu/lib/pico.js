'use strict';
// A Raspberry Pi Pico in rp2040js running firmware/rp2040's ELF: the project's stand-in boot
// ROM, four PCA9555 boards on I2C0 (or, for the `pca9685` build, five PCA9685 with their OE
// pin on GP6: the piano's four and the drum kit's), a DIN MIDI line into UART0 at wire pacing
// (thru out of its TX collected), a USB host on the USB controller, and the watchdog's reset.
//
// The emulated clock runs in ns; the core's cycles advance it at clk_sys. When the core
// sleeps (WFI/WFE) the clock jumps to the next event. A watchdog reset builds the chip anew
// (every peripheral at its reset state, SRAM lost) at the same moment, with the same boards
// and the same USB host: a Pico's reset does not reset the boards.
const path = require('node:path');
const { RP2040 } = require('rp2040js');
const { readElf } = require('./elf.js');
const { readUf2 } = require('./uf2.js');
const { standInRom, RomCallError, TRAP } = require('./rom.js');
const { Pca9555Bus } = require('./pca9555.js');
const { Pca9685Bus } = require('./pca9685.js');
const { UsbMidiHost } = require('./usb-midi-host.js');
const { pl011 } = require('./pl011.js');
const { usbOutBuffers } = require('./usb-out.js');
const { dwI2c } = require('./dw-i2c.js');

const ADDRESSES = [0x21, 0x22, 0x23, 0x24];
/**
 * The `pca9685` build's boards (the keyboard on 0x40..=0x43, the drum kit on 0x44), and the
 * GPIO wired to their OE pins (active low).
 */
const PCA9685_ADDRESSES = [0x40, 0x41, 0x42, 0x43, 0x44];
const OE_PIN = 6;
/** One MIDI byte on the wire: 10 bits at 31250 baud. */
const BYTE_US = 320;
/** The stack is painted with this byte; what is no longer it was used. */
const PAINT = 0xa5;

/**
 * The UF2 file to flash instead of the ELF's segments (`ORCH_RP2040_UF2`, as
 * `firmware/test.sh` sets it: the file the README has a builder copy onto the Pico), or null.
 * The ELF still names the symbols the harness reads.
 */
function uf2Path() {
  return process.env.ORCH_RP2040_UF2 || null;
}

function elfPath() {
  return (
    process.env.ORCH_RP2040_ELF ||
    path.join(__dirname, '../../rp2040/target/thumbv6m-none-eabi/release/orch-rp2040')
  );
}

/**
 * The `pca9685` build (`ORCH_RP2040_PCA9685_ELF`; firmware/test.sh copies it beside the
 * default build's ELF) and its UF2 (`ORCH_RP2040_PCA9685_UF2`, or null: the ELF's segments).
 */
function pca9685Paths() {
  return {
    elf:
      process.env.ORCH_RP2040_PCA9685_ELF ||
      path.join(__dirname, '../../rp2040/target/thumbv6m-none-eabi/release/orch-rp2040-pca9685'),
    uf2: process.env.ORCH_RP2040_PCA9685_UF2 || null,
  };
}

const quiet = {
  debug() {},
  info() {},
  warn() {},
  error(component, message) {
    throw new Error(`rp2040js ${component}: ${message}`);
  },
};

class Pico {
  /** `boards`: 'pca9555' (the default build) or 'pca9685' (its ELF and UF2 by default). */
  constructor({ boards = 'pca9555', elf, uf2 } = {}) {
    this.kind = boards;
    if (boards === 'pca9685') {
      const d = pca9685Paths();
      elf ??= d.elf;
      uf2 ??= d.uf2;
    } else {
      elf ??= elfPath();
      uf2 ??= uf2Path();
    }
    this.elf = readElf(elf);
    this.uf2 = uf2 ? readUf2(uf2) : null;
    this.bus = boards === 'pca9685' ? new Pca9685Bus(PCA9685_ADDRESSES) : new Pca9555Bus(ADDRESSES);
    this.usbHost = new UsbMidiHost();
    /** Bytes the firmware sent on UART0 TX (MIDI thru). */
    this.thru = [];
    /** DIN bytes fed: { byte, ns } with ns the end of its stop bit. */
    this.dinIn = [];
    /** USB packets landed in the device's buffer: { bytes, ns }. */
    this.usbIn = [];
    this.usbHost.onPacketIn = (bytes, ns) => this.usbIn.push({ bytes: Array.from(bytes), ns });
    /** Watchdog resets, with their times (ns). */
    this.resets = [];
    /** The status LED (GP25) driven high or low: { on, ns }, in order (power-up is off). */
    this.led = [];
    /** Instructions and cycles executed (all chips), and the cycles spent asleep. */
    this.cycles = 0;
    this.lineFreeNs = 0;
    this.boot(0);
  }

  /** Powers the chip up (or resets it) at `ns`. */
  boot(ns) {
    // A reset lets go of the LED's pin.
    if (this.led.length && this.led[this.led.length - 1].on) this.led.push({ on: false, ns });
    const chip = new RP2040(); // with a SimulationClock of its own, set to `ns`
    const clock = chip.clock;
    clock.nanosCounter = ns;
    // rp2040js executes SEV as a no-op that it logs: make it set the event register, as the
    // core does (embassy's executor sends one when a task wakes another, so that its WFE
    // returns; without it the woken task waited for the next interrupt).
    chip.logger = {
      ...quiet,
      info(component, message) {
        if (message === 'SEV') chip.core.eventRegistered = true;
      },
    };
    chip.loadBootrom(standInRom()); // (also erases the flash)
    if (this.uf2) {
      chip.flash.set(this.uf2.data, this.uf2.base - 0x10000000);
    } else {
      for (const s of this.elf.segments) {
        if (s.paddr >= 0x10000000 && s.paddr < 0x11000000) chip.flash.set(s.data, s.paddr - 0x10000000);
      }
    }
    chip.core.reset();
    // Paint the stack: from the end of the static data to the top of the RAM.
    const lo = this.elf.symbols.__euninit.value - 0x20000000;
    const hi = this.elf.symbols._stack_start.value - 0x20000000;
    chip.sram.fill(PAINT, lo, hi);
    chip.onBreak = (code) => {
      const pc = chip.core.PC;
      if (code === TRAP && pc < 0x4000) throw new RomCallError(`the firmware called the boot ROM (PC 0x${pc.toString(16)})`);
      throw new Error(`UDF/BKPT #${code} at PC 0x${pc.toString(16)}`);
    };
    const watchdog = chip.peripherals[0x40058];
    // After a watchdog reset the new chip's REASON register says so (the datasheet: TIMER,
    // bit 0; the watchdog block keeps it across the reset it made).
    if (this.resetDue) watchdog.reason = 1;
    watchdog.onWatchdogTrigger = () => {
      // The chip resets: stop its watchdog (rp2040js's periodic alarm would fire again at
      // once, forever), and build the chip anew before the next instruction.
      watchdog.timer.enable = false;
      watchdog.alarm.enable = false;
      this.resetDue = true;
    };
    // The status LED: only its driven levels (an input pin is off).
    chip.gpio[25].addListener((state) => {
      const on = state === 1; // GPIOPinState.High
      const last = this.led.length ? this.led[this.led.length - 1].on : false;
      if (on !== last) this.led.push({ on, ns: clock.nanos });
    });
    if (this.kind === 'pca9685') {
      // OE: the boards' pull-up holds it high (every output off) while GP6 is not driven, as
      // after a reset; driven low, the outputs are enabled.
      this.bus.setOutputEnable(false, clock.nanos);
      chip.gpio[OE_PIN].addListener((state) => this.bus.setOutputEnable(state === 0, clock.nanos)); // GPIOPinState.Low
    }
    pl011(chip.uart[0]);
    chip.uart[0].onByte = (b) => this.thru.push(b);
    dwI2c(chip.i2c[0]);
    this.bus.attach(chip, chip.i2c[0]);
    usbOutBuffers(chip.usbCtrl);
    this.usbHost.attach(chip);
    this.chip = chip;
    this.clock = clock;
    this.resetDue = false;
    this.nsPerCycle = 1e9 / chip.clkSys;
  }

  get nowNs() {
    return this.clock.nanos;
  }

  get nowUs() {
    return this.clock.nanos / 1000;
  }

  /** Runs the chip until `ns`. */
  runUntilNs(ns) {
    while (this.clock.nanos < ns) {
      if (this.resetDue) {
        this.resets.push(this.clock.nanos);
        this.boot(this.clock.nanos);
        continue;
      }
      const { core } = this.chip;
      const clock = this.clock;
      if (core.waiting) {
        const next = clock.nextAlarm ? Math.min(clock.nextAlarm.nanos, ns) : ns;
        clock.tick(Math.max(next - clock.nanos, 0));
        if (!clock.nextAlarm && next === ns) break;
      } else {
        const c = core.executeInstruction();
        this.cycles += c;
        clock.tick(c * this.nsPerCycle);
        if (this.chip.clkSys !== 1e9 / this.nsPerCycle) this.nsPerCycle = 1e9 / this.chip.clkSys;
      }
    }
  }

  runUs(us) {
    this.runUntilNs(this.clock.nanos + us * 1000);
  }

  /**
   * The firmware panics now, as a failed check would: the core goes on at `core::panicking::
   * panic_fmt` (with no message: the firmware's handler reads none), in thread mode.
   */
  panicNow() {
    const name = Object.keys(this.elf.symbols).find((n) => n.includes('9panicking9panic_fmt'));
    if (!name) throw new Error('the ELF has no core::panicking::panic_fmt');
    const core = this.chip.core;
    core.PC = this.elf.symbols[name].value & ~1;
    core.waiting = false;
  }

  /**
   * The firmware hangs for `us` (a loop with interrupts off, a lock-up): the core runs no
   * instruction while time and the peripherals go on. Ends early if the watchdog resets the
   * chip meanwhile (the reset itself happens at the next run).
   */
  hangUs(us) {
    const end = this.clock.nanos + us * 1000;
    while (this.clock.nanos < end && !this.resetDue) {
      const next = this.clock.nextAlarm ? Math.min(this.clock.nextAlarm.nanos, end) : end;
      this.clock.tick(Math.max(next - this.clock.nanos, 0));
    }
  }

  /**
   * Puts DIN bytes on the wire back to back from now (or after the bytes still on it), one
   * every `paceUs` (320 µs: 31250 baud, 10 bits); each reaches UART0's receiver at the end
   * of its stop bit. Returns when the last is in the FIFO.
   */
  sendDin(bytes, paceUs = BYTE_US) {
    let t = Math.max(this.clock.nanos, this.lineFreeNs);
    for (const b of bytes) {
      t += paceUs * 1000;
      this.runUntilNs(t);
      this.chip.uart[0].feedByte(b);
      this.dinIn.push({ byte: b, ns: t });
    }
    this.lineFreeNs = t;
  }

  /** One DIN byte whose stop bit ends at `ns` (not before the line is free). */
  putDinAt(byte, ns) {
    const t = Math.max(ns, this.lineFreeNs + BYTE_US * 1000);
    this.runUntilNs(t);
    this.chip.uart[0].feedByte(byte);
    this.dinIn.push({ byte, ns: t });
    this.lineFreeNs = t;
  }

  /** Sends one USB packet of MIDI events now (the host queues it until the device reads). */
  sendUsb(packet) {
    this.usbHost.send(packet);
  }

  /** Boots until the firmware has initialised every board and the host configured USB. */
  bootUp(maxUs = 200_000) {
    const end = this.clock.nanos + maxUs * 1000;
    while (this.clock.nanos < end) {
      this.runUs(1000);
      const up =
        this.kind === 'pca9685'
          ? this.bus.initialised() && this.bus.oe[this.bus.oe.length - 1].enabled
          : this.bus.log.filter((t) => t.bytes[0] === 6).length >= 4;
      if (up && this.usbHost.configured) return;
    }
    throw new Error(
      `not up after ${maxUs} µs: ${this.bus.log.length} bus transactions, USB configured: ${this.usbHost.configured}`,
    );
  }

  outputs() {
    return this.bus.outputs();
  }

  /** The deepest the stack has been, in bytes (the painted RAM no longer painted). */
  stackHighWater() {
    const lo = this.elf.symbols.__euninit.value - 0x20000000;
    const hi = this.elf.symbols._stack_start.value - 0x20000000;
    let i = lo;
    while (i < hi && this.chip.sram[i] === PAINT) i++;
    return hi - i;
  }
}

module.exports = { Pico, elfPath, uf2Path, pca9685Paths, ADDRESSES, PCA9685_ADDRESSES, OE_PIN, BYTE_US };
