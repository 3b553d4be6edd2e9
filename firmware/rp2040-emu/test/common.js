'use strict';
// What the tests share: a booted Pico, streams played into it by DIN or USB, and the check
// that the boards saw what orch-core on the host made of the same input at the same times.
const assert = require('node:assert/strict');
const { Pico, BYTE_US } = require('../lib/pico.js');
const { midiEvent } = require('../lib/usb-midi-host.js');
const host = require('../lib/host.js');

/**
 * The latest a press or release may reach its board after the host made it: a write takes
 * 38 SCL periods (95 µs at 400 kHz); under a full-rate flood bytes, the guard's timers and the
 * writes of up to four boards queue behind each other.
 */
const MAX_LATE_US = 3_000;

function booted() {
  const p = new Pico();
  p.bootUp();
  return { p, from: p.bus.log.length };
}

/**
 * The firmware made exactly the host's board writes, board by board in order, every press
 * and release reached its board in time, and the boards end as the host's frame; DIN thru
 * equals what came in. Returns the match.
 */
function assertSameAsHost(p, from, din = []) {
  assert.deepEqual(p.thru, din, 'MIDI thru must equal the DIN input');
  const fw = host.firmwareWrites(p, from);
  const h = host.hostRun(p);
  const m = host.sameKeyEvents(fw, h.writes, MAX_LATE_US);
  assert.deepEqual(host.perBoard(fw), host.perBoard(h.writes), 'the same board writes as the host');
  assert.deepEqual(p.outputs(), h.outputs, 'final board outputs');
  assert.equal(p.resets.length, 0, 'no watchdog reset');
  console.log(
    `  ${h.writes.length} host writes; ${m.presses} presses and ${m.releases} releases on the boards after the host's by: median ${fmt(host.percentile(m.late, 50))} µs, 99 % ${fmt(host.percentile(m.late, 99))} µs, at most ${fmt(host.percentile(m.late, 100))} µs`,
  );
  return m;
}

/**
 * The `pca9685` build: every duty write the firmware made equals the host's flush_duties
 * (those that change a board: the driver writes nothing for the others), board by board in
 * order; every strike, hold and release (and every drum pulse's start and end) reached its
 * channel no earlier than the host's and at most MAX_LATE_US later; the boards end as the
 * host's duties; DIN thru equals the input. Returns the match and the host's writes.
 */
function assertPwmSameAsHost(p, from, din = []) {
  assert.deepEqual(p.thru, din, 'MIDI thru must equal the DIN input');
  const fw = host.firmwareDutyWrites(p, from);
  const h = host.hostRunPwm(p);
  const { writes, dropped } = host.changingDutyWrites(h.writes);
  const boards = p.bus.boards.map((_, i) => i);
  const perBoard = (ws) => boards.map((b) => ws.filter((w) => w.board === b).map((w) => w.duties));
  assert.deepEqual(perBoard(fw), perBoard(writes), 'the same duty writes as the host, board by board');
  const m = host.sameDutyEvents(fw, writes, MAX_LATE_US);
  assert.deepEqual(p.bus.programmed(), h.duties, 'final duties');
  assert.equal(p.resets.length, 0, 'no watchdog reset');
  console.log(
    `  ${writes.length} host duty writes (${dropped} that changed nothing left out); ${m.changes} strikes and holds and ${m.releases} releases on the boards after the host's by: median ${fmt(host.percentile(m.late, 50))} µs, 99 % ${fmt(host.percentile(m.late, 99))} µs, at most ${fmt(host.percentile(m.late, 100))} µs`,
  );
  return { ...m, fw, host: writes };
}

/** DIN bytes back to back at wire speed, then `tailUs` (past the guard's strike and rest). */
function checkDin(stream, tailUs = 100_000) {
  const { p, from } = booted();
  p.sendDin(stream);
  p.runUs(tailUs);
  assertSameAsHost(p, from, stream);
  return p;
}

/** MIDI messages by USB, one event packet each, `paceUs` apart. */
function checkUsb(messages, paceUs = 1_000, tailUs = 100_000) {
  const { p, from } = booted();
  for (const m of messages) {
    p.sendUsb(midiEvent(m));
    p.runUs(paceUs);
  }
  p.runUs(tailUs);
  assert.equal(p.usbIn.length, messages.length, 'every packet reached the device');
  assertSameAsHost(p, from);
  return p;
}

function fmt(x) {
  return Math.round(x);
}

/**
 * A DIN line at full rate for `seconds` (the ATmega16 tests' flood): running status
 * throughout; sweeps of Note-On/Note-Off pairs over all 61 keys, then notes on random keys,
 * half of them Note-Offs (velocity 0), one message in 16 with a clock byte (0xF8) inside.
 */
function floodStream(seconds) {
  const n = Math.floor((seconds * 1e6) / BYTE_US);
  const s = [0x90];
  while (s.length < n / 3) for (let k = 36; k <= 96; k++) s.push(k, 100, k, 0);
  let x = 0x2545f491;
  const next = () => {
    x ^= x << 13;
    x >>>= 0;
    x ^= x >>> 17;
    x ^= x << 5;
    x >>>= 0;
    return x;
  };
  while (s.length + 1 < n) {
    const r = next();
    const key = 36 + (r % 61);
    const velocity = ((r >>> 16) & 1) === 0 ? 0 : 1 + (((r >>> 8) & 0xff) % 127);
    if (r >>> 24 < 16) s.push(key, 0xf8, velocity);
    else s.push(key, velocity);
  }
  return s;
}

module.exports = { booted, assertSameAsHost, assertPwmSameAsHost, checkDin, checkUsb, floodStream, MAX_LATE_US, fmt, midiEvent, BYTE_US };
