'use strict';
// Power-up, a board that stops answering, a hung bus and the watchdog, a full-rate DIN line.
const test = require('node:test');
const assert = require('node:assert/strict');
const { Pico } = require('../lib/pico.js');
const { booted, assertSameAsHost, floodStream, fmt, BYTE_US } = require('./common.js');
const host = require('../lib/host.js');

test('power-up drives no pin before the first note', () => {
  const p = new Pico();
  p.runUs(100_000);
  assert.equal(p.bus.firstDrivenHighNs, null, 'a pin was driven high at power-up');
  p.bus.boards.forEach((b, i) => {
    assert.equal(b.outputs(), 0, `board ${i} outputs`);
    assert.equal(b.config(), 0, `board ${i} pins are outputs (driven low)`);
    // Outputs to 0 FIRST, THEN the configuration.
    const seq = p.bus.log.filter((t) => t.board === i).map((t) => t.bytes);
    assert.deepEqual(seq, [[2, 0, 0], [6, 0, 0]], `board ${i} init order`);
  });
  const before = p.nowNs;
  p.sendDin([0x90, 60, 100]);
  p.runUs(5_000);
  assert.ok(p.bus.firstDrivenHighNs > before, 'the note drives a pin');
});

test('a NACKing board is retried and released when it answers again', () => {
  const { p } = booted();
  p.sendDin([0x90, 60, 100, 0x90, 36, 100]); // board 1 bit 8, board 0 bit 0
  p.runUs(5_000);
  assert.deepEqual(p.outputs(), [1, 1 << 8, 0, 0]);

  p.bus.boards[1].nack = true;
  p.sendDin([0x80, 60, 0, 0x80, 36, 0]);
  p.runUs(100_000);
  // Board 0 was written despite board 1; board 1 keeps its stale value for now.
  assert.deepEqual(p.outputs(), [0, 1 << 8, 0, 0]);
  const nacked = p.bus.nacked;
  assert.ok(nacked >= 3, `the firmware retried (${nacked} NACKed address phases)`);
  // Still alive: thru works and the other boards play.
  p.thru.length = 0;
  p.sendDin([0x90, 84, 1]);
  p.runUs(15_000); // longer than the retry period (10 ms)
  assert.deepEqual(p.thru, [0x90, 84, 1]);
  assert.equal(p.outputs()[3], 1);
  assert.ok(p.bus.nacked > nacked, 'it keeps retrying');

  // The board comes back (after losing power: pins are inputs again, outputs 1).
  p.bus.boards[1].powerCycle();
  p.bus.boards[1].nack = false;
  p.runUs(30_000);
  assert.equal(p.bus.boards[1].outputs(), 0, 'key released once the board answers');
  assert.equal(p.bus.boards[1].config(), 0, 'board re-initialised');
  assert.deepEqual(p.outputs(), [0, 0, 0, 1]);
  assert.equal(p.resets.length, 0, 'no watchdog reset');
});

test('a hung bus trips the watchdog, and the keys come up released', () => {
  const { p } = booted();
  p.sendDin([0x90, 36, 100, 0x90, 60, 100]); // board 0 bit 0, board 1 bit 8
  p.runUs(5_000);
  assert.deepEqual(p.outputs(), [1, 1 << 8, 0, 0]);
  // Board 2 holds SCL low for 0.7 s after its address: the firmware's write to it (the
  // RP2040's I2C has no timeout) and with it the interpreter loop hang.
  const hungAt = p.nowNs;
  p.bus.boards[2].stretchUntilNs = hungAt + 700e6;
  p.sendDin([0x90, 76, 100]); // board 2 bit 8
  const fromLog = p.bus.log.length;
  p.runUs(690_000);
  assert.equal(p.resets.length, 1, 'one watchdog reset');
  const resetMs = (p.resets[0] - hungAt) / 1e6;
  assert.ok(resetMs > 400 && resetMs < 600, `the reset came ${resetMs} ms after the hang (watchdog 0.5 s)`);
  // After the reset the firmware initialised boards 0 and 1: outputs 0 first.
  const after = p.bus.log.slice(fromLog).filter((t) => t.stopNs > p.resets[0]);
  for (const b of [0, 1]) {
    const first = after.find((t) => t.board === b);
    assert.deepEqual(first.bytes, [2, 0, 0], `board ${b}: outputs 0 first after the reset`);
    assert.ok(first.stopNs - p.resets[0] < 20e6, 'within 20 ms of the reset');
  }
  assert.deepEqual(p.outputs().slice(0, 2), [0, 0], 'the keys that were down came up released');
  // Board 2 lets go at 0.7 s: initialised too, and the firmware plays again.
  p.runUs(100_000);
  assert.deepEqual(p.outputs(), [0, 0, 0, 0]);
  assert.equal(p.bus.boards[2].config(), 0);
  p.thru.length = 0;
  p.sendDin([0x90, 84, 1]);
  p.runUs(5_000);
  assert.deepEqual(p.thru, [0x90, 84, 1]);
  assert.equal(p.outputs()[3], 1);
  assert.equal(p.resets.length, 1, 'no reset loop');
  console.log(`  watchdog reset ${fmt(resetMs)} ms after the bus hung; boards 0 and 1 released ${fmt((after.find((t) => t.board === 1).stopNs - p.resets[0]) / 1000)} µs after it`);
});

test('a full-rate DIN line loses no press or release', () => {
  const stream = floodStream(4);
  const t0 = Date.now();
  const { p, from } = booted();
  p.sendDin(stream);
  p.runUs(4_500_000); // the guard's watchdog (4 s) lets every key go, on both
  const m = assertSameAsHost(p, from, stream);
  assert.ok(m.presses > 1000 && m.releases > 1000, `a flood that presses keys (${m.presses}, ${m.releases})`);
  assert.equal(p.chip.uart[0].overruns, 0, 'no DIN byte lost in the UART');
  const inits = p.bus.log.filter((t) => t.bytes[0] === 6).length;
  assert.equal(inits, 4, 'the boards were initialised again: the firmware reset');
  console.log(
    `  flood: ${stream.length} bytes in ${((stream.length * BYTE_US) / 1e6).toFixed(1)} s emulated, ${m.presses} presses and ${m.releases} releases, after the host's by median ${fmt(host.percentile(m.late, 50))} µs, 99 % ${fmt(host.percentile(m.late, 99))} µs, at most ${fmt(host.percentile(m.late, 100))} µs; ${Date.now() - t0} ms`,
  );
});
