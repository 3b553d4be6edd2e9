'use strict';
// The `pca9685` build's drum kit: General MIDI notes on channel 10 fire the nine beaters on the
// fifth PCA9685 (0x44, channels 0..=8; firmware/rp2040-robot/src/lib.rs). A drum pattern with the
// piano playing beside it, where every duty write equals orch-core's flush_duties on the host
// (as the keys are proven in pca9685.test.js); every strike's channel goes off by itself at
// its pulse's end (8 ms at velocity 1 to 20 ms at 127), whatever the Note-Off does and with
// none at all; a roll faster than the rebound; nothing left on after the watchdog's reset or a
// panic in the middle of a pulse; and the kit's board not answering while the piano plays on.
const test = require('node:test');
const assert = require('node:assert/strict');
const { Pico } = require('../lib/pico.js');
const { fmt, assertPwmSameAsHost } = require('./common.js');

/** The kit's board and channel 10's status bytes. */
const KIT = 4;
const HIT = 0x99;
const DAMP = 0x89;
/** The kit's beaters (orch-rp2040-robot's KIT): channel on the fifth board by GM note. */
const BEATER = { 35: 0, 36: 0, 38: 1, 40: 1, 42: 2, 46: 2, 44: 3, 41: 4, 43: 4, 45: 5, 47: 5, 48: 6, 50: 6, 49: 7, 57: 7, 51: 8, 59: 8 };
/** orch-core's Touch::PWM: 45 % at velocity 1 to 100 % at 127. */
const SOFTEST = 1843;
/** Pulse::DRUM: 8 ms soft, 20 ms loud, 40 ms rebound (µs). */
const SOFT_US = 8_000;
const LOUD_US = 20_000;
const REBOUND_US = 40_000;

function strikeDuty(velocity) {
  return SOFTEST + Math.floor(((4095 - SOFTEST) * (velocity - 1) + 63) / 126);
}

/** orch-core's Pulse::length: soft at 1, loud at 127, linear, rounded to the nearest µs. */
function pulseUs(velocity) {
  return SOFT_US + Math.floor(((LOUD_US - SOFT_US) * (velocity - 1) + 63) / 126);
}

/** The velocity whose strike duty is `duty` (one duty a velocity: 17 or 18 steps apart). */
function velocityOf(duty) {
  for (let v = 1; v <= 127; v++) if (strikeDuty(v) === duty) return v;
  throw new Error(`no velocity strikes at duty ${duty}`);
}

function booted() {
  const p = new Pico({ boards: 'pca9685' });
  p.bootUp();
  return { p, from: p.bus.log.length };
}

/** Messages [{ ms, bytes }] put on the DIN line at their times (after the line is free). */
function play(p, messages) {
  const start = p.nowNs;
  const din = [];
  for (const m of [...messages].sort((a, b) => a.ms - b.ms)) {
    for (const b of m.bytes) {
      p.putDinAt(b, start + m.ms * 1e6);
      din.push(b);
    }
  }
  return din;
}

/**
 * The strikes on the kit's board in a series of duty writes: each channel's change above 0
 * and the change to 0 after it: [{ channel, onUs, offUs, duty }].
 */
function strikes(writes) {
  const last = new Array(16).fill(0);
  const on = [];
  const out = [];
  for (const w of writes.filter((x) => x.board === KIT)) {
    w.duties.forEach((d, c) => {
      if (d === last[c]) return;
      if (last[c] === 0) on[c] = { channel: c, onUs: w.tUs, duty: d };
      else {
        assert.equal(d, 0, `kit channel ${c}: a strike's duty changed to ${d} without ending (no hold on a drum)`);
        out.push({ ...on[c], offUs: w.tUs });
      }
      last[c] = d;
    });
  }
  assert.ok(last.every((d) => d === 0), 'every pulse ended');
  return out;
}

/**
 * Every strike lasts its velocity's pulse: exactly on the host (orch-core's deadlines), and on
 * the board within `slackUs` (the strike's write and the end's come out of different paths of
 * the loop: ≈ 300 µs after a byte, ≈ 150 µs after a deadline). Returns the strikes.
 */
function assertPulses(m, slackUs = 600) {
  const onHost = strikes(m.host);
  const onBoard = strikes(m.fw);
  assert.equal(onBoard.length, onHost.length, 'as many strikes on the board as on the host');
  for (const s of onHost) assert.equal(s.offUs - s.onUs, pulseUs(velocityOf(s.duty)), `host: channel ${s.channel} at ${s.onUs} µs`);
  const err = onBoard.map((s) => s.offUs - s.onUs - pulseUs(velocityOf(s.duty)));
  err.forEach((e, i) => assert.ok(Math.abs(e) <= slackUs, `the board's strike #${i} (channel ${onBoard[i].channel}) lasted ${e} µs off its pulse`));
  return { onBoard, err };
}

/** A one-bar groove with the piano beside it, soft and loud hits, and every kind of Note-Off. */
function pattern() {
  const m = [];
  const hit = (ms, note, v) => m.push({ ms, bytes: [HIT, note, v] });
  const damp = (ms, note) => m.push({ ms, bytes: [DAMP, note, 64] });
  for (let i = 0; i < 8; i++) {
    const t = i * 125; // eighths at 240 bpm
    hit(t, i === 7 ? 46 : 42, i % 2 ? 40 : 100); // hi-hat, accents on the beat
    damp(t + 3, i === 7 ? 46 : 42); // its Note-Off 3 ms in: inside the pulse
    if (i % 4 === 0) hit(t + 1, 36, 127); // kick, loud, no Note-Off at all
    if (i % 4 === 2) {
      hit(t + 1, 38, 110); // snare, its Note-Off long after
      damp(t + 90, 38);
    }
  }
  // Both kick notes at once: one beater, one strike (the second joins it).
  m.push({ ms: 1000, bytes: [HIT, 35, 90, 36, 90] });
  // Toms soft to loud, Note-Offs as velocity-0 Note-Ons (running status).
  m.push({ ms: 1100, bytes: [HIT, 41, 1, 43, 0] });
  m.push({ ms: 1150, bytes: [HIT, 45, 64, 47, 0] });
  m.push({ ms: 1200, bytes: [HIT, 48, 127, 50, 0] });
  // Cymbals and the pedal, and notes the kit lacks (hand clap 39, note 60): dropped.
  hit(1300, 49, 127);
  hit(1301, 51, 50);
  hit(1302, 44, 70);
  hit(1303, 39, 100);
  hit(1304, 60, 100);
  hit(1350, 57, 20);
  hit(1351, 59, 126);
  // The piano on channel 1 meanwhile: a held note and a chord, struck then held.
  m.push({ ms: 0, bytes: [0x90, 60, 90] });
  m.push({ ms: 600, bytes: [0x80, 60, 0] });
  m.push({ ms: 700, bytes: [0x90, 48, 100, 52, 100, 55, 100] });
  m.push({ ms: 1500, bytes: [0x80, 48, 0, 52, 0, 55, 0] });
  return m;
}

test('a drum pattern beside the piano: every duty write as orch-core\'s flush_duties, every strike its velocity\'s pulse', () => {
  const t0 = Date.now();
  const { p, from } = booted();
  const din = play(p, pattern());
  p.runUs(2_000_000);
  const m = assertPwmSameAsHost(p, from, din);
  const { onBoard, err } = assertPulses(m);
  // 8 hi-hats, 2 kicks, 2 snares, the double kick once, 3 toms, 2 crashes, 2 rides, the pedal.
  assert.equal(onBoard.length, 21, 'every hit struck once, the kit\'s missing notes none');
  const channels = new Set(onBoard.map((s) => s.channel));
  assert.deepEqual([...channels].sort(), [0, 1, 2, 3, 4, 5, 6, 7, 8], 'every beater struck');
  const duties = onBoard.map((s) => s.duty);
  assert.ok(duties.includes(SOFTEST) && duties.includes(4095), 'velocity 1 at the softest duty, 127 fully on');
  // The piano's keys: struck, held, released on boards 0..3 as the host's (checked above).
  assert.ok(m.fw.some((w) => w.board === 1 && w.duties[8] > 0), 'the piano played beside the kit');
  assert.ok(p.bus.outputs().every((b) => b.every((d) => d === 0)), 'all off at the end');
  console.log(`  ${onBoard.length} strikes, each its velocity's pulse on the board within ${fmt(Math.max(...err.map(Math.abs)))} µs (${fmt(Date.now() - t0)} ms)`);
});

test('a strike ends by itself at its pulse\'s end: no Note-Off, an early one, a late one', () => {
  const { p, from } = booted();
  const cases = [
    { note: 36, v: 127, off: null }, // kick, loud, no Note-Off at all
    { note: 38, v: 1, off: 3 }, // snare, soft, its Note-Off ≈ 3 ms in (before its 8 ms end)
    { note: 42, v: 64, off: 500 }, // hi-hat, its Note-Off long after
  ];
  for (const c of cases) {
    const din = [HIT, c.note, c.v];
    p.sendDin(din);
    const at = p.dinIn.at(-1).ns;
    const ch = BEATER[c.note];
    p.runUntilNs(at + 2e6);
    assert.equal(p.bus.outputs()[KIT][ch], strikeDuty(c.v), `note ${c.note}: struck at its velocity's duty`);
    if (c.off !== null && c.off < 5) {
      p.sendDin([DAMP, c.note, 0]);
    }
    // Still on just before its end, off just after it.
    const end = at + pulseUs(c.v) * 1000;
    p.runUntilNs(end - 500e3);
    assert.equal(p.bus.outputs()[KIT][ch], strikeDuty(c.v), `note ${c.note}: on until its pulse's end`);
    p.runUntilNs(end + 800e3);
    assert.equal(p.bus.outputs()[KIT][ch], 0, `note ${c.note}: off by itself at ${pulseUs(c.v)} µs`);
    if (c.off !== null && c.off >= 5) {
      p.runUntilNs(at + c.off * 1e6);
      p.sendDin([DAMP, c.note, 0]);
    }
    p.runUs(100_000);
  }
  // Nothing more after: no write when the late Note-Off came, nothing at the guard's 4 s watchdog.
  p.runUs(5_000_000);
  const m = assertPwmSameAsHost(p, from, p.dinIn.map((d) => d.byte));
  const { onBoard } = assertPulses(m);
  assert.equal(onBoard.length, 3);
  assert.equal(m.fw.length, 6, 'one write to strike and one to end each, none for a Note-Off');
});

test('a roll faster than the rebound: strikes never closer than 40 ms, as the host plays it', () => {
  const { p, from } = booted();
  const m = [];
  for (let i = 0; i < 24; i++) m.push({ ms: i * 15, bytes: [HIT, 38, 1 + ((i * 37) % 127)] }); // every 15 ms
  const din = play(p, m);
  p.runUs(500_000);
  const r = assertPwmSameAsHost(p, from, din);
  const { onBoard } = assertPulses(r);
  const starts = onBoard.map((s) => s.onUs);
  for (let i = 1; i < starts.length; i++) {
    assert.ok(starts[i] - starts[i - 1] >= REBOUND_US - 600, `strikes ${fmt(starts[i] - starts[i - 1])} µs apart`);
  }
  assert.ok(starts.length >= 6 && starts.length < 24, `${starts.length} strikes of 24 hits: the rebound kept, the hits it could not take dropped or joined`);
  console.log(`  24 hits every 15 ms: ${starts.length} strikes, ${fmt(Math.min(...starts.slice(1).map((s, i) => s - starts[i])))} µs apart at the closest`);
});

test('a hung firmware in the middle of a pulse: every output off at the watchdog\'s reset, nothing struck again after it', () => {
  const { p } = booted();
  p.sendDin([HIT, 36, 127, HIT, 49, 127]); // kick, crash: 20 ms pulses
  p.runUs(1_000);
  assert.deepEqual(p.bus.outputs()[KIT].slice(0, 8), [4095, 0, 0, 0, 0, 0, 0, 4095]);
  const hungAt = p.nowNs;
  const fromLog = p.bus.log.length;
  p.hangUs(700_000);
  p.runUs(1);
  assert.equal(p.resets.length, 1, 'one watchdog reset');
  const reset = p.resets[0];
  // A hung loop ends no pulse: the coils stay on until the reset (the watchdog's 0.5 s).
  assert.ok(reset - hungAt < 600e6, `reset ${fmt((reset - hungAt) / 1e6)} ms after the hang`);
  assert.ok(p.bus.outputs().every((b) => b.every((d) => d === 0)), 'every output off at the reset (OE)');
  p.runUs(1_000_000);
  const after = p.bus.log.slice(fromLog).filter((t) => t.board === KIT && !t.read).map((t) => t.bytes);
  assert.deepEqual(after[0], [0xfd, 0x10], 'the kit\'s board: every channel off first after the reset');
  assert.ok(p.bus.programmed()[KIT].every((d) => d === 0), 'nothing struck again');
  assert.ok(p.bus.outputs().every((b) => b.every((d) => d === 0)));
  p.sendDin([HIT, 38, 100]);
  p.runUs(2_000);
  assert.equal(p.bus.outputs()[KIT][1], strikeDuty(100), 'it plays again');
  p.runUs(30_000);
  assert.equal(p.bus.outputs()[KIT][1], 0);
  console.log(`  the kick and the crash on at the hang, every output off at the reset ${fmt((reset - hungAt) / 1e6)} ms later`);
});

test('a panic in the middle of a pulse: OE high at once, every channel of the five boards off', () => {
  const { p } = booted();
  p.sendDin([HIT, 36, 127, 0x90, 60, 100]);
  p.runUs(1_000);
  assert.equal(p.bus.outputs()[KIT][0], 4095);
  const at = p.nowNs;
  const fromLog = p.bus.log.length;
  p.panicNow();
  p.runUs(2_000);
  assert.ok(p.bus.outputs().every((b) => b.every((d) => d === 0)), 'every output off');
  const writes = p.bus.log.slice(fromLog).map((t) => [t.board, t.bytes]);
  assert.deepEqual(writes, [0, 1, 2, 3, 4].map((b) => [b, [0xfd, 0x10]]), 'every board all off, the kit\'s too');
  assert.ok(p.bus.programmed().every((b) => b.every((d) => d === 0)));
  const oe = p.bus.oe.at(-1);
  assert.ok(!oe.enabled && oe.ns - at < 50e3);
  p.runUs(700_000);
  assert.equal(p.resets.length, 1);
  assert.ok(p.bus.programmed().every((b) => b.every((d) => d === 0)), 'nothing struck again after the reset');
});

test('the kit\'s board not answering: the piano plays on (OE low), and the board comes back all off, no stale strike', () => {
  const { p } = booted();
  p.bus.boards[KIT].nack = true;
  p.sendDin([HIT, 36, 127]); // its write fails: retried, then the board is set aside
  p.runUs(5_000);
  const nacked = p.bus.nacked;
  assert.ok(nacked >= 3, `the firmware retried (${nacked} NACKed address phases)`);
  p.sendDin([0x90, 60, 100]); // the piano still plays
  p.runUs(5_000);
  assert.equal(p.bus.outputs()[1][8], strikeDuty(100));
  assert.ok(p.bus.oe.at(-1).enabled, 'OE low: the keyboard\'s boards are in service');
  // The kit's board comes back from a power cycle after the kick's 20 ms pulse has ended (the
  // retry rounds, every 10 ms, still failing meanwhile).
  p.runUs(50_000);
  const fromLog = p.bus.log.length;
  p.bus.boards[KIT].powerCycle();
  p.bus.boards[KIT].nack = false;
  p.runUs(30_000);
  const seq = p.bus.log.slice(fromLog).filter((t) => t.board === KIT && !t.read).map((t) => t.bytes);
  assert.deepEqual(seq[0], [0xfd, 0x10], 'initialised again, every channel off first');
  assert.equal(seq.length, 5, 'the init alone: the kick\'s pulse is over, nothing to strike');
  assert.ok(p.bus.outputs()[KIT].every((d) => d === 0));
  p.sendDin([HIT, 38, 127]);
  p.runUs(2_000);
  assert.equal(p.bus.outputs()[KIT][1], 4095, 'and it plays again');
  assert.equal(p.resets.length, 0);
});
