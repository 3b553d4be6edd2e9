'use strict';
// Power-up, a board that stops answering, a board holding SCL or SDA low, a hung firmware and the
// watchdog, a full-rate DIN line.
const test = require('node:test');
const assert = require('node:assert/strict');
const { Pico } = require('../lib/pico.js');
const { booted, assertSameAsHost, floodStream, fmt, midiEvent, BYTE_US } = require('./common.js');
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

test('a hung firmware trips the watchdog, and the keys come up released', () => {
  const { p } = booted();
  p.sendDin([0x90, 36, 100, 0x90, 60, 100]); // board 0 bit 0, board 1 bit 8
  p.runUs(5_000);
  assert.deepEqual(p.outputs(), [1, 1 << 8, 0, 0]);
  const hungAt = p.nowNs;
  const fromLog = p.bus.log.length;
  p.hangUs(700_000);
  p.runUs(20_000);
  assert.equal(p.resets.length, 1, 'one watchdog reset');
  const resetMs = (p.resets[0] - hungAt) / 1e6;
  assert.ok(resetMs > 400 && resetMs < 600, `the reset came ${resetMs} ms after the hang (watchdog 0.5 s)`);
  // After the reset the firmware initialised every board: outputs 0 first.
  const after = p.bus.log.slice(fromLog).filter((t) => t.stopNs > p.resets[0]);
  for (const b of [0, 1, 2, 3]) {
    const first = after.find((t) => t.board === b);
    assert.deepEqual(first.bytes, [2, 0, 0], `board ${b}: outputs 0 first after the reset`);
    assert.ok(first.stopNs - p.resets[0] < 20e6, 'within 20 ms of the reset');
  }
  assert.deepEqual(p.outputs(), [0, 0, 0, 0], 'the keys that were down came up released');
  p.thru.length = 0;
  p.sendDin([0x90, 84, 1]);
  p.runUs(5_000);
  assert.deepEqual(p.thru, [0x90, 84, 1]);
  assert.equal(p.outputs()[3], 1, 'it plays again');
  p.runUs(1_000_000);
  assert.equal(p.resets.length, 1, 'no reset loop');
  console.log(`  watchdog reset ${fmt(resetMs)} ms after the firmware hung; boards 0 and 1 released ${fmt((after.find((t) => t.board === 1).stopNs - p.resets[0]) / 1000)} µs after it`);
});

test('a panic releases every key at once, then the watchdog resets the Pico', () => {
  const { p } = booted();
  p.sendDin([0x90, 36, 100, 0x90, 60, 100, 0x90, 76, 100, 0x90, 96, 100]); // one key a board
  p.runUs(5_000);
  assert.deepEqual(p.outputs(), [1, 1 << 8, 1 << 8, 1 << 12]);
  const at = p.nowNs;
  const fromLog = p.bus.log.length;
  p.panicNow();
  p.runUs(2_000);
  assert.deepEqual(p.outputs(), [0, 0, 0, 0], 'every key up within 2 ms of the panic');
  const writes = p.bus.log.slice(fromLog);
  assert.deepEqual(writes.map((t) => [t.board, t.bytes]), [0, 1, 2, 3].map((b) => [b, [2, 0, 0]]));
  const ms = (writes[3].stopNs - at) / 1e6;
  assert.equal(p.resets.length, 0, 'not by a reset');
  p.runUs(700_000);
  assert.equal(p.resets.length, 1, 'then the watchdog resets it');
  assert.ok((p.resets[0] - at) / 1e6 > 400, 'after its 0.5 s');
  p.sendDin([0x90, 60, 100]);
  p.runUs(5_000);
  assert.equal(p.outputs()[1], 1 << 8, 'and it plays again');
  console.log(`  a panic: every key up ${fmt(ms * 1000)} µs after it (four writes), the watchdog's reset ${fmt((p.resets[0] - at) / 1e6)} ms after it`);
});

test('a board holding SCL low is timed out: the loop goes on, and every board is initialised again once it lets go', () => {
  const { p } = booted();
  p.sendDin([0x90, 36, 100, 0x90, 60, 100]); // board 0 bit 0, board 1 bit 8
  p.runUs(5_000);
  assert.deepEqual(p.outputs(), [1, 1 << 8, 0, 0]);
  // Board 2 holds SCL low for 0.7 s after its address: longer than the watchdog.
  const hungAt = p.nowNs;
  p.bus.boards[2].stretchUntilNs = hungAt + 700e6;
  const fromLog = p.bus.log.length;
  const ledFrom = p.led.length;
  p.sendDin([0x90, 76, 100]); // board 2 bit 8: its write hangs the bus
  p.runUs(100_000);
  // Meanwhile: MIDI in by DIN and USB, interpreted (the boards cannot be written yet).
  p.thru.length = 0;
  p.sendDin([0x80, 36, 0]); // board 0 released
  p.sendUsb(midiEvent([0x90, 48, 100])); // board 0 bit 12
  p.runUs(500_000);
  assert.deepEqual(p.thru, [0x80, 36, 0], 'thru goes on');
  assert.equal(p.resets.length, 0, 'no watchdog reset: the loop went on');
  assert.ok(p.led.length - ledFrom >= 4, 'the LED blinks: the boards are set aside');
  assert.deepEqual(p.bus.log.slice(fromLog), [], 'nothing on the bus while it is held');
  // Board 2 lets go at 0.7 s: the aborted write ends, every board is initialised again (outputs
  // 0 first) and shows the interpreter's frame, the notes of the hang included.
  p.runUs(200_000);
  const after = p.bus.log.slice(fromLog);
  for (const b of [0, 1, 2, 3]) {
    const first = after.find((t) => t.board === b && t.bytes.length === 3);
    assert.deepEqual(first.bytes, [2, 0, 0], `board ${b}: outputs 0 first`);
    const backMs = (first.stopNs - (hungAt + 700e6)) / 1e6;
    assert.ok(backMs > 0 && backMs < 15, `board ${b} initialised ${fmt(backMs)} ms after the bus was free`);
  }
  assert.deepEqual(p.outputs(), [1 << 12, 1 << 8, 1 << 8, 0]);
  assert.equal(p.resets.length, 0);
  console.log(`  a board held SCL low 700 ms: no reset, thru and the interpreter went on, every board back ${fmt((after[after.length - 1].stopNs - (hungAt + 700e6)) / 1e6)} ms after it let go`);
});

test('a board holding SDA low is cleared by clock pulses made by hand (bus clear)', () => {
  const { p } = booted();
  // A board lost its place in a byte and holds SDA until it has seen 3 more clock pulses.
  p.bus.holdSda(3);
  const t0 = p.nowNs;
  p.sendDin([0x90, 60, 100]); // board 1 bit 8: no START can be made
  p.runUs(50_000);
  assert.equal(p.bus.sdaHeldFor, 0, 'SDA let go');
  assert.equal(p.bus.handPulses, 3, 'three pulses by hand, no more than it took');
  assert.deepEqual(p.outputs(), [0, 1 << 8, 0, 0], 'the note reached its board');
  const written = p.bus.outputWrites().filter((w) => w.board === 1 && w.outputs === 1 << 8);
  const ms = (written[0].tNs - t0) / 1e6;
  assert.ok(ms < 30, `written ${fmt(ms)} ms after the note (a 10 ms retry round)`);
  p.sendDin([0x80, 60, 0]);
  p.runUs(5_000);
  assert.deepEqual(p.outputs(), [0, 0, 0, 0], 'the bus works');
  assert.equal(p.resets.length, 0);
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
