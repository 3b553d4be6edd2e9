'use strict';
// PCA9685 16-channel 12-bit PWM controllers on the emulated RP2040's I2C0 (the `pca9685`
// build's five boards at 0x40..=0x44: the keyboard's four and the drum kit's), on the PCA9555
// bus's machinery (bus time from the programmed SCL period, a board that NACKs or holds SCL
// low, SDA held low), and their active-low OE pin wired to the Pico's GP6.
//
// Registers as the data sheet (NXP PCA9685 Rev. 4; orch-sim's `pca9685.rs` models the same):
// MODE1 (0x00: RESTART, EXTCLK, AI, SLEEP, SUB1..3, ALLCALL; power-up 0x11, asleep), MODE2
// (0x01: INVRT, OCH, OUTDRV, OUTNE; power-up 0x04), channel n's ON_L/ON_H/OFF_L/OFF_H at
// 0x06 + 4n (power-up full OFF: OFF_H = 0x10), ALL_LED_ON_L..ALL_LED_OFF_H (0xFA..0xFD: the byte
// into that register of every channel; read 0), PRE_SCALE (0xFE: writable only asleep, at
// least 3). A write frame is [register, data...]; with AI the pointer moves on after each byte
// (from 0x45 and from 0xFE back to MODE1), without it every byte goes to the one register.
// Bits 7:5 of the _H registers read 0. The frame takes effect at its STOP (MODE2's OCH = 0: the
// outputs change at the STOP).
//
// A channel's output (`output(c)`, on the driver's 0..=4095 scale where 4095 is 100 %):
// 0 asleep, 0 while channels are held after a wake with RESTART pending, 0 while OE is high
// (OUTNE = 00; 4095 with OUTNE = 01 and totem-pole outputs), else full OFF 0 (it wins), full ON
// 4095, or (OFF - ON) mod 4096 counts; INVRT inverts it (OE low only).
const { Pca9555Bus } = require('./pca9555.js');

const MODE1 = 0x00;
const MODE2 = 0x01;
const LED0_ON_L = 0x06;
const LED15_OFF_H = 0x45;
const ALL_LED_ON_L = 0xfa;
const ALL_LED_OFF_H = 0xfd;
const PRE_SCALE = 0xfe;
const RESTART = 0x80;
const EXTCLK = 0x40;
const AI = 0x20;
const SLEEP = 0x10;
const INVRT = 0x10;
const OUTDRV = 0x04;
const FULL = 0x10; // bit 4 of ON_H (full ON) and OFF_H (full OFF)
const COUNTS = 4096;

class Pca9685 {
  constructor(address) {
    this.address = address;
    /** The board acknowledges nothing when set. */
    this.nack = false;
    /** While set, the board holds SCL low after its address (a hung board): ns or Infinity. */
    this.stretchUntilNs = 0;
    /** The OE pin is low (outputs enabled). Wired outside the chip: a power cycle keeps it. */
    this.outputEnable = true;
    this.powerCycle();
  }

  /** Power-on reset: asleep, every channel full OFF, PRE_SCALE 30 (200 Hz). */
  powerCycle() {
    this.mode1 = SLEEP | 0x01;
    this.mode2 = OUTDRV;
    this.subaddresses = [0xe2, 0xe4, 0xe8, 0xe0];
    this.led = new Array(64).fill(0);
    for (let i = 3; i < 64; i += 4) this.led[i] = FULL;
    this.preScale = 30;
    this.restart = false;
    this.held = false;
    this.pointer = MODE1;
    this.frame = [];
  }

  get sleeping() {
    return (this.mode1 & SLEEP) !== 0;
  }

  // --- the bus's side: bytes as they are acknowledged, applied at the STOP

  write(byte, first) {
    if (first) this.frame = [];
    this.frame.push(byte);
  }

  /** The write's STOP: its frame takes effect. A write to channel registers logs their duties. */
  stop() {
    const f = this.frame;
    this.frame = [];
    if (f.length === 0) return null;
    this.pointer = f[0];
    let r = f[0];
    for (const byte of f.slice(1)) {
      this.setRegister(r, byte);
      r = this.next(r);
    }
    const channels = (f[0] >= LED0_ON_L && f[0] <= LED15_OFF_H) || (f[0] >= ALL_LED_ON_L && f[0] <= ALL_LED_OFF_H);
    return channels && f.length > 1 ? { duties: this.programmed() } : null;
  }

  read() {
    const v = this.register(this.pointer);
    this.pointer = this.next(this.pointer);
    return v;
  }

  next(r) {
    if ((this.mode1 & AI) === 0) return r;
    if (r === LED15_OFF_H || r === PRE_SCALE) return MODE1;
    return (r + 1) & 0xff;
  }

  register(r) {
    if (r === MODE1) return this.mode1 | (this.restart ? RESTART : 0);
    if (r === MODE2) return this.mode2;
    if (r >= 0x02 && r <= 0x05) return this.subaddresses[r - 2];
    if (r >= LED0_ON_L && r <= LED15_OFF_H) return this.led[r - LED0_ON_L];
    if (r === PRE_SCALE) return this.preScale;
    return 0;
  }

  setRegister(r, v) {
    if (r === MODE1) this.setMode1(v);
    else if (r === MODE2) this.mode2 = v & 0x1f;
    else if (r >= 0x02 && r <= 0x05) this.subaddresses[r - 2] = v;
    else if (r >= LED0_ON_L && r <= LED15_OFF_H) {
      const i = r - LED0_ON_L;
      this.led[i] = i % 2 === 1 ? v & 0x1f : v;
      this.channelWritten();
    } else if (r >= ALL_LED_ON_L && r <= ALL_LED_OFF_H) {
      const k = r - ALL_LED_ON_L;
      for (let c = 0; c < 16; c++) this.led[4 * c + k] = k % 2 === 1 ? v & 0x1f : v;
      this.channelWritten();
    } else if (r === PRE_SCALE && this.sleeping) this.preScale = Math.max(v, 3);
    // PRE_SCALE while awake is blocked; reserved registers and TEST_MODE are ignored.
  }

  /** A channel register written: RESTART clears and nothing is held any more (OCH = 0). */
  channelWritten() {
    if (!this.sleeping) {
      this.restart = false;
      this.held = false;
    }
  }

  setMode1(v) {
    const wasSleeping = this.sleeping;
    const extclk = (this.mode1 | v) & EXTCLK; // sticky
    this.mode1 = (v & ~(RESTART | EXTCLK)) | extclk;
    if (this.sleeping && !wasSleeping) {
      // Asleep with channels running: they can be restarted; every channel off first clears it.
      this.restart = this.programmed().some((d) => d > 0);
    } else if (!this.sleeping && wasSleeping) {
      this.held = this.restart;
    }
    if (v & RESTART && !this.sleeping && this.restart) {
      this.restart = false;
      this.held = false;
    }
  }

  // --- what the chip does

  /** Channel c's ON/OFF registers as counts of the period (0..=4096), before sleep, OE, INVRT. */
  programmedCounts(c) {
    const [onL, onH, offL, offH] = this.led.slice(4 * c, 4 * c + 4);
    if (offH & FULL) return 0;
    if (onH & FULL) return COUNTS;
    const on = onL | ((onH & 0x0f) << 8);
    const off = offL | ((offH & 0x0f) << 8);
    return (off + COUNTS - on) % COUNTS;
  }

  /** Every channel's duty as its registers program it, on the 0..=4095 scale. */
  programmed() {
    return Array.from({ length: 16 }, (_, c) => Math.min(this.programmedCounts(c), COUNTS - 1));
  }

  /** Channel c's output, on the 0..=4095 scale (4095: always on). */
  output(c) {
    if (this.sleeping || this.held) return 0;
    if (!this.outputEnable) {
      return (this.mode2 & 0x03) === 0x01 && this.mode2 & OUTDRV ? COUNTS - 1 : 0;
    }
    const counts = this.programmedCounts(c);
    return Math.min(this.mode2 & INVRT ? COUNTS - counts : counts, COUNTS - 1);
  }

  outputs() {
    return Array.from({ length: 16 }, (_, c) => this.output(c));
  }

  /** Outputs driven some of the time, as bits. */
  drivenHigh() {
    return this.outputs().reduce((m, d, c) => (d > 0 ? m | (1 << c) : m), 0);
  }
}

/** The PCA9685s on the bus (as many as addresses), and the OE pin they share. */
class Pca9685Bus extends Pca9555Bus {
  constructor(addresses) {
    super(addresses, Pca9685);
    /** OE's level changes: { enabled (OE low), ns }, in order. */
    this.oe = [];
  }

  /** The OE pin: `enabled` (low) or not (high: every output off), from `ns` on. */
  setOutputEnable(enabled, ns) {
    const last = this.oe.length ? this.oe[this.oe.length - 1].enabled : null;
    if (last !== enabled) this.oe.push({ enabled, ns });
    for (const b of this.boards) b.outputEnable = enabled;
    if (enabled && this.firstDrivenHighNs === null && this.boards.some((b) => b.drivenHigh())) {
      this.firstDrivenHighNs = ns;
    }
  }

  /** What every board outputs now: a board's 16 duties each. */
  outputs() {
    return this.boards.map((b) => b.outputs());
  }

  /** What every board's registers program: a board's 16 duties each. */
  programmed() {
    return this.boards.map((b) => b.programmed());
  }

  /** Whether the firmware has initialised every board: the last write to each wakes it. */
  initialised() {
    return this.boards.every((b, i) => {
      const mine = this.log.filter((t) => t.board === i && !t.read);
      return mine.length > 0 && mine[mine.length - 1].bytes[0] === MODE1 && !b.sleeping;
    });
  }

  /**
   * Every write to channel registers (LEDn_*, not ALL_LED_*) from log entry `from` on, with each board's programmed
   * duties after it: { tNs (its STOP), board, duties[16] }.
   */
  dutyWrites(from = 0) {
    return this.log
      .slice(from)
      .filter((t) => !t.read && t.duties && t.bytes[0] >= LED0_ON_L && t.bytes[0] <= LED15_OFF_H)
      .map((t) => ({ tNs: t.stopNs, board: t.board, duties: t.duties }));
  }
}

module.exports = { Pca9685, Pca9685Bus, MODE1, MODE2, LED0_ON_L, ALL_LED_OFF_H, PRE_SCALE, AI, SLEEP, OUTDRV, FULL };
