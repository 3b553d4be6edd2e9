'use strict';
// Four PCA9555 16-bit I/O expanders on the emulated RP2040's I2C0, with bus timing.
//
// Registers as the datasheet: 0/1 input port, 2/3 output port, 4/5 polarity inversion,
// 6/7 configuration (1 = input). After the address the first byte is the command (the
// register pointer); each data byte after it goes to the pointer, which then moves to the
// other register of its pair (2 -> 3 -> 2 ...); a read reads the same way. Power-up: outputs
// 1, every pin an input. A pin is driven high when it is an output (configuration 0) and its
// output bit is 1.
//
// Bus time, from the SCL period the firmware programmed (IC_FS_SCL_HCNT + LCNT of clk_sys):
// START one bit, each byte (address or data) nine bits with its acknowledge, STOP one bit.

const INPUT0 = 0;
const OUTPUT0 = 2;
const CONFIG0 = 6;

class Pca9555 {
  constructor(address) {
    this.address = address;
    /** The board acknowledges nothing when set (unpowered, missing). */
    this.nack = false;
    /** While set, the board holds SCL low after its address (a hung board): ns or Infinity. */
    this.stretchUntilNs = 0;
    this.powerCycle();
  }

  /** Power-up state: outputs 1, every pin an input. */
  powerCycle() {
    this.regs = [0xff, 0xff, 0xff, 0xff, 0, 0, 0xff, 0xff];
    this.pointer = 0;
  }

  outputs() {
    return this.regs[OUTPUT0] | (this.regs[OUTPUT0 + 1] << 8);
  }

  config() {
    return this.regs[CONFIG0] | (this.regs[CONFIG0 + 1] << 8);
  }

  drivenHigh() {
    return this.outputs() & ~this.config() & 0xffff;
  }

  write(byte, first) {
    if (first) {
      this.pointer = byte & 7;
      return;
    }
    if (this.pointer >= 2) this.regs[this.pointer] = byte; // input ports are read-only
    this.pointer ^= 1;
  }

  read() {
    const value = this.pointer < 2 ? this.inputPort(this.pointer) : this.regs[this.pointer];
    this.pointer ^= 1;
    return value;
  }

  /** An input port reads its pins: driven ones as driven, the rest pulled high. */
  inputPort(i) {
    const out = this.regs[OUTPUT0 + i];
    const cfg = this.regs[CONFIG0 + i];
    return ((out & ~cfg) | cfg) & 0xff;
  }
}

/**
 * The boards on one I2C controller of the emulated chip, and a log of every transaction.
 * `Device` is the boards' model (`Pca9685Bus` in `pca9685.js` uses this bus with PCA9685s):
 * `write(byte, first)` for each data byte acknowledged (`first`: the byte after the address),
 * `read()`, and `stop()` (if it has one) at the STOP of a write addressed to it, which may
 * return fields for the write's log entry.
 */
class Pca9555Bus {
  constructor(addresses, Device = Pca9555) {
    this.boards = addresses.map((a) => new Device(a));
    /** Finished transactions: { board, bytes (after the address), startNs, stopNs, read }. */
    this.log = [];
    /** Address phases NACKed. */
    this.nacked = 0;
    /** When a pin was first driven high (ns), or null. */
    this.firstDrivenHighNs = null;
    /** Called with each finished write transaction. */
    this.onWrite = null;
    /**
     * Clock pulses a board holding SDA low (it lost its place in a byte) still needs before it
     * lets go: 0 when SDA is free. See `holdSda`.
     */
    this.sdaHeldFor = 0;
    /** Clock pulses made by hand on SCL (GP5 driven low by the firmware as a GPIO). */
    this.handPulses = 0;
    /** The pads of the chip attached last: { sda, scl }. */
    this.pads = null;
  }

  /**
   * A board holds SDA low, as one does that lost its place in a byte (the master reset in the
   * middle of a read or a write): it lets go after `pulses` clock pulses. Meanwhile no START
   * can be made (the controller loses arbitration).
   */
  holdSda(pulses) {
    this.sdaHeldFor = pulses;
    this.pads?.sda.setInputValue(pulses === 0);
  }

  outputs() {
    return this.boards.map((b) => b.outputs());
  }

  /** Connects the bus to `i2c` (an RPI2C) of a chip running on `clock`. */
  attach(chip, i2c) {
    const clock = chip.clock;
    // The bus lines as the pads read them (GP4 SDA, GP5 SCL): pulled up, SCL low while a
    // board stretches the clock, SDA low while a board holds it. A pulse made by hand on SCL
    // (the pin a GPIO output driven low, then let go) counts for a board holding SDA.
    const pads = { sda: chip.gpio[4], scl: chip.gpio[5] };
    this.pads = pads;
    pads.sda.setInputValue(this.sdaHeldFor === 0);
    pads.scl.setInputValue(true);
    pads.scl.addListener((state) => {
      if (state !== 0) return; // GPIOPinState.Low: driven low
      this.handPulses++;
      if (this.sdaHeldFor > 0 && --this.sdaHeldFor === 0) pads.sda.setInputValue(true);
    });
    let current = null; // { board, bytes, startNs, first, read }
    let pending = null;
    const later = (bits, fn) => {
      pending = fn;
      alarm.schedule(bits * this.bitNs(chip, i2c));
    };
    const alarm = clock.createAlarm(() => {
      const fn = pending;
      pending = null;
      fn();
    });
    i2c.onStart = () => {
      if (this.sdaHeldFor > 0) {
        // SDA is low: the controller cannot make its START.
        later(1, () => i2c.arbitrationLost());
        return;
      }
      current = { board: null, bytes: [], startNs: clock.nanos, first: true, read: false };
      later(1, () => i2c.completeStart());
    };
    i2c.onConnect = (address, mode) => {
      const board = this.boards.find((b) => b.address === address && !b.nack);
      const ack = () => {
        if (!board) this.nacked++;
        current.board = board ? this.boards.indexOf(board) : null;
        current.read = mode === 1;
        i2c.completeConnect(!!board);
      };
      later(9, () => {
        if (board && board.stretchUntilNs > clock.nanos) {
          // SCL held low: the controller waits (it has no timeout of its own).
          pads.scl.setInputValue(false);
          if (board.stretchUntilNs !== Infinity) {
            later((board.stretchUntilNs - clock.nanos) / this.bitNs(chip, i2c), () => {
              pads.scl.setInputValue(true);
              ack();
            });
          }
          return;
        }
        ack();
      });
    };
    i2c.onWriteByte = (value) => {
      later(9, () => {
        const board = this.boards[current.board];
        if (board.nack) {
          i2c.completeWrite(false);
          return;
        }
        board.write(value, current.first);
        current.first = false;
        current.bytes.push(value);
        i2c.completeWrite(true);
      });
    };
    i2c.onReadByte = () => {
      later(9, () => i2c.completeRead(this.boards[current.board].read()));
    };
    i2c.onStop = () => {
      later(1, () => {
        const t = current;
        current = null;
        if (t && t.board !== null) {
          const more = t.read ? null : this.boards[t.board].stop?.();
          const entry = { board: t.board, bytes: t.bytes, startNs: t.startNs, stopNs: clock.nanos, read: t.read, ...more };
          this.log.push(entry);
          if (this.firstDrivenHighNs === null && this.boards.some((b) => b.drivenHigh())) {
            this.firstDrivenHighNs = clock.nanos;
          }
          if (!t.read && this.onWrite) this.onWrite(entry);
        }
        i2c.completeStop();
      });
    };
  }

  /** One SCL period as the firmware programmed it (IC_FS_SCL_HCNT + LCNT clk_sys cycles). */
  bitNs(chip, i2c) {
    return ((i2c.fsClockHighPeriod + i2c.fsClockLowPeriod) * 1e9) / chip.clkSys;
  }

  /** Every output-port write from log entry `from` on: { tNs, board, outputs }. */
  outputWrites(from = 0) {
    return this.log
      .slice(from)
      .filter((t) => !t.read && t.bytes.length === 3 && t.bytes[0] === OUTPUT0)
      .map((t) => ({ tNs: t.stopNs, board: t.board, outputs: t.bytes[1] | (t.bytes[2] << 8) }));
  }
}

module.exports = { Pca9555, Pca9555Bus, INPUT0, OUTPUT0, CONFIG0 };
