'use strict';
// The status LED (GP25): off when all is well and quiet, a 20 ms flash for MIDI coming in (DIN
// or USB), blinking about 4 times a second (131 ms on, 131 ms off) while a board does not
// answer and for 2 s after a watchdog reset.
const test = require('node:test');
const assert = require('node:assert/strict');
const { Pico } = require('../lib/pico.js');
const { booted, midiEvent, fmt } = require('./common.js');

const BLINK_HALF_NS = 131_072e3;

/** The LED's changes from `fromNs` on. */
function changes(p, fromNs) {
  return p.led.filter((c) => c.ns >= fromNs);
}

/** Whether the LED is on at `ns`. */
function onAt(p, ns) {
  let on = false;
  for (const c of p.led) {
    if (c.ns > ns) break;
    on = c.on;
  }
  return on;
}

test('the LED stays off at power-up and while nothing comes in', () => {
  const p = new Pico();
  p.bootUp();
  p.runUs(300_000);
  assert.deepEqual(p.led.filter((c) => c.on), [], 'never on');
});

test('the LED flashes 20 ms for a DIN message and for a USB packet', () => {
  const { p } = booted();
  const t0 = p.nowNs;
  p.sendDin([0x90, 60, 100]);
  const last = p.dinIn[p.dinIn.length - 1].ns;
  p.runUs(50_000);
  const din = changes(p, t0);
  assert.equal(din.length, 2, `one flash: ${JSON.stringify(din)}`);
  assert.ok(din[0].on && din[0].ns - p.dinIn[0].ns < 1e6, 'on within 1 ms of the first byte');
  const offAfter = (din[1].ns - last) / 1e6;
  assert.ok(offAfter >= 19.9 && offAfter < 22, `off ${fmt(offAfter)} ms after the last byte`);

  const t1 = p.nowNs;
  p.sendUsb(midiEvent([0x80, 60, 0]));
  p.runUs(50_000);
  const usb = changes(p, t1);
  assert.equal(usb.length, 2, `one flash: ${JSON.stringify(usb)}`);
  const length = (usb[1].ns - usb[0].ns) / 1e6;
  assert.ok(usb[0].on && length >= 19 && length < 22, `a ${fmt(length)} ms flash`);
});

test('the LED blinks while a board does not answer, and stops once it does', () => {
  const { p } = booted();
  p.bus.boards[1].nack = true;
  const t0 = p.nowNs;
  p.sendDin([0x90, 60, 100]); // board 1: set aside after 3 attempts
  p.runUs(1_000_000);
  const blinks = changes(p, t0 + 30e6);
  assert.ok(blinks.length >= 6, `blinking: ${blinks.length} changes in 1 s`);
  for (let i = 1; i < blinks.length; i++) {
    assert.notEqual(blinks[i].on, blinks[i - 1].on);
    const half = blinks[i].ns - blinks[i - 1].ns;
    assert.ok(Math.abs(half - BLINK_HALF_NS) < 2e6, `a half blink of ${fmt(half / 1e6)} ms`);
  }
  // Incoming MIDI does not interrupt the fault blinking.
  const at = p.nowNs;
  p.sendDin([0x80, 60, 0]);
  p.runUs(300_000);
  assert.ok(changes(p, at).length >= 2, 'still blinking');

  p.bus.boards[1].nack = false;
  p.runUs(300_000); // initialised again within the 10 ms retry round
  const settled = p.nowNs;
  p.runUs(500_000);
  assert.deepEqual(changes(p, settled), [], 'no more changes');
  assert.equal(onAt(p, p.nowNs), false, 'and off');
});

test('the LED shows a watchdog reset for 2 s', () => {
  const { p } = booted();
  p.hangUs(700_000); // the firmware hangs: the watchdog resets the Pico
  p.runUs(100_000);
  assert.equal(p.resets.length, 1, 'one watchdog reset');
  const reset = p.resets[0];
  p.runUs(2_500_000);
  const after = changes(p, reset);
  assert.ok(after.length >= 13, `blinking after the reset: ${after.length} changes`);
  const lastOn = after.filter((c) => c.on).pop();
  const blinkingFor = (after[after.length - 1].ns - reset) / 1e6;
  assert.ok(blinkingFor > 1_900 && blinkingFor < 2_200, `for ${fmt(blinkingFor)} ms`);
  assert.ok(lastOn.ns - reset < 2_000e6, 'not on past 2 s');
  assert.equal(onAt(p, p.nowNs), false, 'off after');
});
