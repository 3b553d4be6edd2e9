'use strict';
// The emulator's PCA9685 model (lib/pca9685.js) against the data sheet, case by case as
// orch-sim's register model (crates/sim/src/pca9685.rs) is tested: a model that decodes a
// write wrongly would let the firmware's tests pass on a wrong write.
const test = require('node:test');
const assert = require('node:assert/strict');
const { Pca9685, MODE1, PRE_SCALE, ALL_LED_OFF_H, AI, SLEEP } = require('../lib/pca9685.js');

/** One write frame, as the bus delivers it: bytes as acknowledged, then the STOP. */
function write(chip, bytes) {
  bytes.forEach((b, i) => chip.write(b, i === 0));
  return chip.stop();
}

function awake() {
  const chip = new Pca9685(0x40);
  write(chip, [MODE1, AI]);
  return chip;
}

test('power-up: asleep, every channel full OFF, 200 Hz; awake, still nothing driven', () => {
  const chip = new Pca9685(0x40);
  assert.equal(chip.register(MODE1), 0x11);
  assert.equal(chip.register(0x01), 0x04);
  assert.equal(chip.preScale, 30);
  for (let c = 0; c < 16; c++) assert.deepEqual(chip.led.slice(4 * c, 4 * c + 4), [0, 0, 0, 0x10]);
  write(chip, [MODE1, 0]);
  assert.deepEqual(chip.outputs(), new Array(16).fill(0));
});

test('a frame takes effect at its STOP; without AI every byte goes to one register', () => {
  const chip = new Pca9685(0x40);
  chip.write(0x06, true);
  chip.write(1, false);
  assert.equal(chip.register(0x06), 0, 'not before the STOP');
  chip.write(2, false);
  chip.write(3, false);
  chip.stop();
  assert.deepEqual(chip.led.slice(0, 4), [3, 0, 0, 0x10]);
});

test('counts, full ON, full OFF winning, wrap past the period, ON = OFF, reserved bits', () => {
  const chip = awake();
  write(chip, [0x06, 0, 0, 0xe8, 0x03]); // ON 0, OFF 1000
  assert.equal(chip.output(0), 1000);
  write(chip, [0x0a, 0x00, 0x0f, 0xe8, 0x02]); // ON 3840, OFF 744: wraps
  assert.equal(chip.output(1), 1000);
  write(chip, [0x0e, 0, 0x10, 0, 0]); // full ON
  assert.equal(chip.output(2), 4095);
  write(chip, [0x0e, 0, 0x10, 0, 0x10]); // full OFF wins
  assert.equal(chip.output(2), 0);
  write(chip, [0x16, 0x34, 0x01, 0x34, 0x01]); // ON = OFF: nothing
  assert.equal(chip.output(4), 0);
  write(chip, [0x1a, 0, 0xe0, 0, 0xe0]); // bits 7:5 of _H read 0
  assert.deepEqual(chip.led.slice(20, 24), [0, 0, 0, 0]);
});

test('auto-increment wraps from 0x45 and from PRE_SCALE to MODE1', () => {
  let chip = awake();
  write(chip, [0x42, 0, 0, 0x00, 0x08, AI | 0x01]);
  assert.equal(chip.output(15), 2048);
  assert.equal(chip.register(MODE1), AI | 0x01);
  chip = awake();
  write(chip, [MODE1, SLEEP | AI]);
  write(chip, [PRE_SCALE, 5, AI]); // PRE_SCALE, then MODE1: wakes
  assert.equal(chip.preScale, 5);
  assert.ok(!chip.sleeping);
  assert.deepEqual([chip.read(), chip.read(), chip.read()], [5, AI, 0x04], 'reads from the pointer on');
});

test('ALL_LED registers load every channel', () => {
  const chip = awake();
  write(chip, [0xfa, 0, 0, 0x00, 0x04]); // every channel 1024
  assert.deepEqual(chip.outputs(), new Array(16).fill(1024));
  assert.equal(chip.register(ALL_LED_OFF_H), 0, 'reads 0');
  write(chip, [ALL_LED_OFF_H, 0x10]);
  assert.deepEqual(chip.outputs(), new Array(16).fill(0));
  assert.deepEqual(chip.led.slice(28, 32), [0, 0, 0, 0x10]);
});

test('PRE_SCALE is writable only asleep, at least 3', () => {
  const chip = awake();
  write(chip, [PRE_SCALE, 100]);
  assert.equal(chip.preScale, 30, 'blocked while awake');
  write(chip, [MODE1, SLEEP]);
  write(chip, [PRE_SCALE, 1]);
  assert.equal(chip.preScale, 3);
});

test('sleep with channels running sets RESTART and holds them until a restart; all off first clears it', () => {
  let chip = awake();
  write(chip, [0x06, 0, 0, 0x00, 0x08]); // channel 0 at half
  write(chip, [MODE1, SLEEP | AI]);
  assert.equal(chip.output(0), 0, 'nothing asleep');
  assert.equal(chip.register(MODE1) & 0x80, 0x80);
  write(chip, [MODE1, AI]); // awake, but held
  assert.equal(chip.output(0), 0);
  write(chip, [MODE1, 0x80 | AI]);
  assert.equal(chip.output(0), 2048);
  assert.equal(chip.register(MODE1), AI, 'RESTART cleared');
  chip = awake();
  write(chip, [0x06, 0, 0, 0x00, 0x08]);
  write(chip, [ALL_LED_OFF_H, 0x10]);
  write(chip, [MODE1, SLEEP | AI]);
  assert.equal(chip.register(MODE1) & 0x80, 0, 'an orderly shutdown leaves no RESTART');
});

test('OE high: every output 0 (OUTNE = 00), the registers kept; INVRT only while OE is low', () => {
  const chip = awake();
  write(chip, [0x06, 0, 0, 0x00, 0x04]); // 1024
  chip.outputEnable = false;
  assert.equal(chip.output(0), 0);
  assert.equal(chip.programmed()[0], 1024);
  write(chip, [0x01, 0x04 | 0x01]); // OUTNE = 01, totem pole: outputs 1 while OE is high
  assert.equal(chip.output(0), 4095);
  write(chip, [0x01, 0x04 | 0x10]); // INVRT, OUTNE = 00
  assert.equal(chip.output(0), 0);
  chip.outputEnable = true;
  assert.equal(chip.output(0), 4096 - 1024);
});
