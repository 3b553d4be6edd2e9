'use strict';
// The `pca9685` build's keys: five PCA9685 PWM boards at 0x40..=0x44 (the keyboard on the
// first four, the drum kit on the fifth: drums.test.js) and their OE pin on GP6.
// Power-up all off with OE high until then, strike then hold then release on one key, whole
// corpus files where every duty write equals orch-core's flush_duties on the host, a hung
// firmware and the watchdog, a panic, and a hung bus.
const test = require('node:test');
const assert = require('node:assert/strict');
const fs = require('node:fs');
const path = require('node:path');
const { Pico } = require('../lib/pico.js');
const { midiEvent, fmt, assertPwmSameAsHost } = require('./common.js');
const host = require('../lib/host.js');

/** The data sheet's init, as orch-boards writes it: all off, sleep, prescale, MODE2, wake. */
const INIT = [
  [0xfd, 0x10], // ALL_LED_OFF_H: every channel full OFF
  [0x00, 0x30], // MODE1: SLEEP | AI
  [0xfe, 0x03], // PRE_SCALE 3: 1526 Hz
  [0x01, 0x04], // MODE2: OUTDRV (totem pole), outputs 0 while OE is high
  [0x00, 0x20], // MODE1: awake, AI
];
const OFF = new Array(16).fill(0);
/** The boards: the keyboard's four, the kit's. */
const BOARDS = [0, 1, 2, 3, 4];
const ALL_OFF = BOARDS.map(() => OFF);
/** The defaults (orch-core's Touch::PWM): 45 % at velocity 1, 100 % at 127, hold 35 %. */
const SOFTEST = 1843;
const HOLD = 1433;
const STRIKE_US = 40_000;

function strikeDuty(velocity) {
  return SOFTEST + Math.floor(((4095 - SOFTEST) * (velocity - 1) + 63) / 126);
}

function booted() {
  const p = new Pico({ boards: 'pca9685' });
  p.bootUp();
  return { p, from: p.bus.log.length };
}

function lastOe(p) {
  return p.bus.oe[p.bus.oe.length - 1];
}

/** Every duty write as the host's flush_duties, in time; see common.js. */
function assertSameAsHost(p, from, din = []) {
  return assertPwmSameAsHost(p, from, din);
}

test('PCA9685 power-up: OE high from reset until every board is initialised all off, then low', () => {
  const p = new Pico({ boards: 'pca9685' });
  p.runUs(100_000);
  p.bus.boards.forEach((b, i) => {
    const seq = p.bus.log.filter((t) => t.board === i).map((t) => t.bytes);
    assert.deepEqual(seq, INIT, `board ${i}: the data sheet's init, every channel off first`);
    assert.deepEqual(b.programmed(), OFF, `board ${i}: every channel full OFF`);
    assert.ok(!b.sleeping, `board ${i} awake`);
    assert.equal(b.preScale, 3);
  });
  // OE: high (not driven, the boards' pull-up) from reset, driven high by the firmware, low
  // only once the last board's oscillator has had its 500 µs.
  assert.equal(p.bus.oe.length, 2, `OE changed once: ${JSON.stringify(p.bus.oe)}`);
  assert.deepEqual(p.bus.oe[0], { enabled: false, ns: 0 });
  const lastInit = Math.max(...p.bus.log.map((t) => t.stopNs));
  const lowAt = p.bus.oe[1].ns;
  assert.ok(p.bus.oe[1].enabled && lowAt >= lastInit + 500e3, `OE low ${fmt((lowAt - lastInit) / 1000)} µs after the last init write`);
  assert.equal(p.bus.firstDrivenHighNs, null, 'no output driven at power-up');
  const before = p.nowNs;
  p.sendDin([0x90, 60, 100]);
  p.runUs(5_000);
  assert.ok(p.bus.firstDrivenHighNs > before, 'the note drives its channel');
  console.log(`  OE low ${fmt(lowAt / 1e3)} µs after reset, ${fmt((lowAt - lastInit) / 1000)} µs after the last board's init`);
});

test('strike, then hold at strike + 40 ms, then release: one 5-byte write each, the default curve', () => {
  const { p, from } = booted();
  p.sendDin([0x90, 60, 100]); // key 24: board 1 (0x41), channel 8
  const on = p.dinIn[p.dinIn.length - 1].ns;
  p.runUs(20_000);
  assert.equal(p.bus.outputs()[1][8], strikeDuty(100), 'the strike duty on the output');
  assert.equal(strikeDuty(100), 3612);
  p.runUs(80_000);
  assert.equal(p.bus.outputs()[1][8], HOLD, 'then the hold duty');
  p.sendDin([0x80, 60, 0]);
  const off = p.dinIn[p.dinIn.length - 1].ns;
  p.runUs(10_000);
  const w = p.bus.log.slice(from).filter((t) => !t.read);
  // Channel 8 goes high at its phase, 8 × 256 = 2048 (0x800), and low `duty` counts later.
  assert.deepEqual(
    w.map((t) => [t.board, t.bytes]),
    [
      [1, [0x26, 0x00, 0x08, 0x1c, 0x06]], // strike: OFF 2048 + 3612 - 4096 = 1564 (0x61C)
      [1, [0x26, 0x00, 0x08, 0x99, 0x0d]], // hold: OFF 2048 + 1433 = 3481 (0xD99)
      [1, [0x26, 0x00, 0x00, 0x00, 0x10]], // release: full OFF
    ],
  );
  const strikeUs = (w[0].stopNs - on) / 1000;
  const holdUs = (w[1].stopNs - on) / 1000;
  const releaseUs = (w[2].stopNs - off) / 1000;
  assert.ok(strikeUs > 0 && strikeUs < 400, `strike written ${strikeUs} µs after the last stop bit`);
  assert.ok(holdUs >= STRIKE_US && holdUs < STRIKE_US + 400, `hold written ${holdUs} µs after the Note-On`);
  assert.ok(releaseUs > 0 && releaseUs < 400, `release written ${releaseUs} µs after the Note-Off`);
  assert.deepEqual(p.bus.outputs(), ALL_OFF);
  assertSameAsHost(p, from, [0x90, 60, 100, 0x80, 60, 0]);
  console.log(`  strike on the board ${fmt(strikeUs)} µs after the Note-On's last stop bit, hold ${fmt(holdUs)} µs after it, release ${fmt(releaseUs)} µs after the Note-Off's`);
});

test('velocity 1 strikes at the softest duty, 127 fully on (the full-ON bit), both held at 35 %', () => {
  const { p, from } = booted();
  p.sendDin([0x90, 36, 1, 0x90, 37, 127]); // board 0, channels 0 and 1
  p.runUs(10_000);
  assert.deepEqual(p.bus.outputs()[0].slice(0, 2), [SOFTEST, 4095]);
  const w = p.bus.log.slice(from).filter((t) => !t.read).map((t) => t.bytes);
  assert.deepEqual(w, [
    [0x06, 0x00, 0x00, 0x33, 0x07], // channel 0: ON 0, OFF 1843 (0x733)
    [0x0a, 0x00, 0x10, 0x00, 0x00], // channel 1: full ON
  ]);
  p.runUs(50_000);
  assert.deepEqual(p.bus.outputs()[0].slice(0, 2), [HOLD, HOLD]);
  assertSameAsHost(p, from, [0x90, 36, 1, 0x90, 37, 127]);
});

function corpusFile(name) {
  const beside = path.join(__dirname, '../../../../shared/midi', name);
  return fs.existsSync(beside) ? beside : path.join('/work/shared/midi', name);
}

function finish(p, from, din, how, t0, file) {
  p.runUs(5_000_000); // past the guard's 4 s watchdog
  assert.deepEqual(p.bus.outputs(), ALL_OFF, 'boards end all off');
  assert.ok(lastOe(p).enabled && p.bus.oe.length === 2, 'OE stayed low');
  const m = assertSameAsHost(p, from, din);
  assert.ok(m.changes > 100, `${m.changes} strikes and holds`);
  console.log(`  ${file} by ${how} on PCA9685 boards: ${fmt(p.nowUs / 1000)} ms emulated in ${Date.now() - t0} ms`);
}

for (const FILE of ['m21-test06.mid', 'bach-bwv66-6-chorale.mid']) {
  test(`${FILE} by DIN on PCA9685 boards: every duty write as orch-core's flush_duties`, () => {
    const t0 = Date.now();
    const timed = host.smfToWire(corpusFile(FILE));
    const { p, from } = booted();
    const start = p.nowNs;
    for (const { us, byte } of timed) p.putDinAt(byte, start + us * 1000);
    finish(p, from, timed.map((t) => t.byte), 'DIN', t0, FILE);
  });
}

test('bach-bwv66-6-chorale.mid by USB on PCA9685 boards: every duty write as orch-core\'s', () => {
  const t0 = Date.now();
  const timed = host.smfToWire(corpusFile('bach-bwv66-6-chorale.mid'));
  const messages = [];
  for (const t of timed) {
    if (t.byte & 0x80) messages.push({ us: t.us, bytes: [t.byte] });
    else messages[messages.length - 1].bytes.push(t.byte);
  }
  const { p, from } = booted();
  const start = p.nowNs;
  for (const m of messages) {
    p.runUntilNs(start + m.us * 1000);
    p.sendUsb(midiEvent(m.bytes));
  }
  finish(p, from, [], 'USB', t0, 'bach-bwv66-6-chorale.mid');
  assert.equal(p.usbIn.length, messages.length, 'every packet reached the device');
});

test('a hung firmware: the watchdog\'s reset lets go of OE (every channel off at once), then every board is initialised all off', () => {
  const { p } = booted();
  p.sendDin([0x90, 36, 100, 0x90, 60, 100]); // board 0 channel 0, board 1 channel 8
  p.runUs(5_000);
  const struck = strikeDuty(100);
  assert.equal(p.bus.outputs()[0][0], struck);
  assert.equal(p.bus.outputs()[1][8], struck);
  const hungAt = p.nowNs;
  const fromLog = p.bus.log.length;
  p.hangUs(700_000);
  p.runUs(1); // the reset happens
  assert.equal(p.resets.length, 1, 'one watchdog reset');
  const reset = p.resets[0];
  const resetMs = (reset - hungAt) / 1e6;
  assert.ok(resetMs > 400 && resetMs < 600, `the reset came ${resetMs} ms after the hang`);
  // The boards still hold the strike in their registers: OE, let go by the reset, holds
  // every output off.
  assert.deepEqual(lastOe(p), { enabled: false, ns: reset }, 'OE high at the reset');
  assert.equal(p.bus.programmed()[0][0], struck, 'the registers still hold the strike');
  assert.deepEqual(p.bus.outputs(), ALL_OFF, 'every output off at the reset');
  p.runUs(20_000);
  for (const b of BOARDS) {
    const first = p.bus.log.slice(fromLog).find((t) => t.board === b);
    assert.deepEqual(first.bytes, INIT[0], `board ${b}: every channel off first after the reset`);
    assert.ok(first.stopNs - reset < 20e6, 'within 20 ms of the reset');
  }
  assert.deepEqual(p.bus.programmed(), ALL_OFF, 'every channel full OFF');
  const low = lastOe(p);
  assert.ok(low.enabled, 'OE low again once the boards are initialised');
  const lastInit = Math.max(...p.bus.log.slice(fromLog).filter((t) => t.bytes[0] === 0x00 && t.bytes[1] === 0x20).map((t) => t.stopNs));
  assert.equal(p.bus.oe.filter((e) => e.ns >= reset).length, 2, 'OE high from the reset, then low once');
  assert.ok(low.ns >= lastInit + 500e3, 'not before every board is initialised');
  p.thru.length = 0;
  p.sendDin([0x90, 84, 1]);
  p.runUs(5_000);
  assert.deepEqual(p.thru, [0x90, 84, 1]);
  assert.equal(p.bus.outputs()[3][0], SOFTEST, 'it plays again');
  p.runUs(1_000_000);
  assert.equal(p.resets.length, 1, 'no reset loop');
  console.log(`  watchdog reset ${fmt(resetMs)} ms after the firmware hung: every output off at the reset (OE), every board all off and OE low ${fmt((low.ns - reset) / 1000)} µs after it`);
});

test('a panic drives OE high at once and turns every channel off, then the watchdog resets the Pico', () => {
  const { p } = booted();
  // One key a board, and a loud kick on the kit's board (20 ms pulse): the panic comes in it.
  p.sendDin([0x90, 36, 100, 0x90, 60, 100, 0x90, 76, 100, 0x90, 96, 100, 0x99, 36, 127]);
  p.runUs(2_000);
  assert.ok(p.bus.outputs().every((b) => b.some((d) => d > 0)));
  const at = p.nowNs;
  const fromLog = p.bus.log.length;
  p.panicNow();
  p.runUs(2_000);
  const oe = lastOe(p);
  assert.ok(!oe.enabled && oe.ns - at < 50e3, `OE high ${fmt((oe.ns - at) / 1000)} µs after the panic`);
  assert.deepEqual(p.bus.outputs(), ALL_OFF, 'every output off');
  const writes = p.bus.log.slice(fromLog);
  assert.deepEqual(writes.map((t) => [t.board, t.bytes]), BOARDS.map((b) => [b, INIT[0]]), 'then every board all off');
  assert.deepEqual(p.bus.programmed(), ALL_OFF);
  const ms = (writes.at(-1).stopNs - at) / 1e6;
  p.runUs(700_000);
  assert.equal(p.resets.length, 1, 'then the watchdog resets it');
  p.sendDin([0x90, 60, 100]);
  p.runUs(5_000);
  assert.equal(p.bus.outputs()[1][8], strikeDuty(100), 'and it plays again');
  console.log(`  a panic: OE high ${fmt((oe.ns - at) / 1000)} µs after it, every board all off ${fmt(ms * 1000)} µs after it`);
});

test('a NACKing board is set aside while the others play (OE stays low), and initialised again with its duties when it answers', () => {
  const { p } = booted();
  p.sendDin([0x90, 60, 100, 0x90, 61, 100]); // board 1, channels 8 and 9
  p.runUs(60_000);
  assert.deepEqual(p.bus.outputs()[1].slice(8, 10), [HOLD, HOLD]);
  p.bus.boards[1].nack = true;
  p.sendDin([0x80, 61, 0]); // board 1's write fails
  p.runUs(5_000);
  const nacked = p.bus.nacked;
  assert.ok(nacked >= 3, `the firmware retried (${nacked} NACKed address phases)`);
  p.sendDin([0x90, 36, 100]); // board 0 still plays
  p.runUs(5_000);
  assert.equal(p.bus.outputs()[0][0], strikeDuty(100));
  assert.ok(lastOe(p).enabled, 'OE low: the other boards are in service');
  assert.ok(p.bus.nacked > nacked, 'it keeps trying board 1');
  // Board 1 comes back after losing power: asleep, every channel off.
  const fromLog = p.bus.log.length;
  p.bus.boards[1].powerCycle();
  p.bus.boards[1].nack = false;
  p.runUs(30_000);
  const seq = p.bus.log.slice(fromLog).filter((t) => t.board === 1).map((t) => t.bytes);
  assert.deepEqual(seq.slice(0, 5), INIT, 'initialised again, every channel off first');
  assert.deepEqual(seq.slice(5), [[0x26, 0x00, 0x08, 0x99, 0x0d]], 'then its duties: key 60 still holding');
  assert.deepEqual(p.bus.outputs()[1].slice(8, 10), [HOLD, 0]);
  assert.equal(p.resets.length, 0);
});

test('a board holding SCL low: OE goes high while every board is set aside, low again once they are initialised', () => {
  const { p } = booted();
  p.sendDin([0x90, 36, 100]); // board 0 channel 0
  p.runUs(60_000); // held
  assert.equal(p.bus.outputs()[0][0], HOLD);
  const hungAt = p.nowNs;
  p.bus.boards[2].stretchUntilNs = hungAt + 700e6;
  p.sendDin([0x90, 76, 100]); // board 2: its write hangs the bus
  const sent = p.nowNs;
  p.runUs(10_000);
  const high = lastOe(p);
  assert.ok(!high.enabled && high.ns > sent && high.ns - sent < 5e6, `OE high ${fmt((high.ns - sent) / 1000)} µs after the note whose write hung`);
  assert.deepEqual(p.bus.outputs(), ALL_OFF, 'the key that was held is released by OE');
  p.runUs(600_000);
  assert.equal(p.resets.length, 0, 'no watchdog reset: the loop went on');
  assert.ok(!lastOe(p).enabled, 'OE high while the bus is held');
  p.runUs(200_000); // it lets go at 0.7 s
  const low = lastOe(p);
  assert.ok(low.enabled, 'OE low again');
  const backMs = (low.ns - (hungAt + 700e6)) / 1e6;
  assert.ok(backMs > 0 && backMs < 15, `OE low ${backMs} ms after the bus was free`);
  // The boards show the interpreter's duties again: board 0's key cut by nothing (it holds),
  // board 2's key struck long ago and holding.
  assert.equal(p.bus.outputs()[0][0], HOLD);
  assert.equal(p.bus.outputs()[2][8], HOLD);
  assert.equal(p.resets.length, 0);
  console.log(`  a board held SCL low 700 ms: OE high ${fmt((high.ns - sent) / 1000)} µs after the Note-On whose write hung, low ${fmt(backMs)} ms after it let go`);
});

test('figures of the pca9685 build', () => {
  const { p } = booted();
  const sec = (n) => (p.elf.sections[n] ? p.elf.sections[n].size : 0);
  const flash = sec('.boot2') + sec('.vector_table') + sec('.text') + sec('.rodata') + sec('.data');
  const ram = sec('.data') + sec('.bss') + sec('.uninit');
  // A Note-On by DIN and by USB: arrival to the STOP of its strike write, and CPU cycles.
  const measure = (send, arrival) => {
    const from = p.bus.log.length;
    const c0 = p.cycles;
    send();
    const at = arrival();
    p.runUntilNs(at + 3e6);
    const cycles = p.cycles - c0;
    const w = host.firmwareDutyWrites(p, from)[0];
    assert.ok(w, 'a strike write');
    p.runUs(200_000); // past the hold
    return { us: w.tUs - at / 1000, cycles };
  };
  const din = [60, 64, 67].map((k) => measure(() => p.sendDin([0x90, k, 100]), () => p.dinIn.at(-1).ns));
  const usb = [62, 65, 69].map((k) =>
    measure(
      () => p.sendUsb(midiEvent([0x90, k, 100])),
      () => {
        const n = p.usbIn.length;
        while (p.usbIn.length === n) p.runUs(1);
        return p.usbIn.at(-1).ns;
      },
    ),
  );
  p.sendDin([0x80, 60, 0, 64, 0, 67, 0, 62, 0, 65, 0, 69, 0]);
  p.runUs(100_000);
  // The deepest stack after a busy stretch, as the default build's figure.
  const { floodStream } = require('./common.js');
  const stream = floodStream(1);
  for (let i = 0; i < stream.length; i += 50) {
    p.sendDin(stream.slice(i, i + 50));
    p.sendUsb([...midiEvent([0x91, 40 + (i % 40), 90]), ...midiEvent([0x81, 40 + (i % 40), 0])]);
  }
  p.runUs(200_000);
  const stack = p.stackHighWater();
  assert.equal(p.resets.length, 0);
  const r = (v) => v.map((m) => fmt(m.us)).join(', ');
  const c = (v) => v.map((m) => m.cycles).join(', ');
  console.log('\n== Raspberry Pi Pico firmware figures, pca9685 build ==');
  console.log(`ELF: ${require('../lib/pico.js').pca9685Paths().elf}`);
  console.log(`flash: ${flash} bytes (.boot2 ${sec('.boot2')} + .vector_table ${sec('.vector_table')} + .text ${sec('.text')} + .rodata ${sec('.rodata')} + .data ${sec('.data')}) of 2 MiB`);
  console.log(`RAM: ${ram} bytes static (.data ${sec('.data')} + .bss ${sec('.bss')} + .uninit ${sec('.uninit')}) + ${stack} bytes deepest stack seen = ${ram + stack} of 264 KiB`);
  console.log(`DIN last stop bit -> strike write done: ${r(din)} µs (cycles per message ${c(din)}); USB packet in -> strike write done: ${r(usb)} µs (cycles ${c(usb)}); the write itself 56 SCL periods, 140 µs at 400 kHz`);
});
