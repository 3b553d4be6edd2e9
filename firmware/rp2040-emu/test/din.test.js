'use strict';
// DIN MIDI into UART0 at wire speed (a byte every 320 µs), compared with orch-core on the host.
const test = require('node:test');
const assert = require('node:assert/strict');
const { checkDin } = require('./common.js');

test('thesis Table 3: three Note-Ons by DIN', () => {
  const p = checkDin([0x90, 0x3c, 0x7f, 0x90, 0x40, 0x7f, 0x90, 0x43, 0x7f]);
  // C, E, G: keys 24, 28, 31, on board 1.
  assert.deepEqual(p.outputs(), [0, (1 << 8) | (1 << 12) | (1 << 15), 0, 0]);
});

test('thesis Table 4: running status and a Note-Off by DIN', () => {
  const p = checkDin([0x90, 0x3c, 0x7f, 0x40, 0x7f, 0x43, 0x7f, 0x80, 0x40, 0x00]);
  assert.deepEqual(p.outputs(), [0, (1 << 8) | (1 << 15), 0, 0]);
});

test('running status with velocity-0 Note-Offs by DIN', () => {
  const s = [0x90];
  for (const n of [48, 52, 55, 60, 64, 67]) s.push(n, 90);
  for (const n of [48, 55, 64]) s.push(n, 0);
  const p = checkDin(s);
  assert.notDeepEqual(p.outputs(), [0, 0, 0, 0]);
});

test('real-time bytes inside messages by DIN', () => {
  const p = checkDin([
    0x90, 0xf8, 0x3c, 0xfe, 0x7f, // clock and active sensing inside a Note-On
    0xf8, 0x40, 0xfa, 0x7f, // running status with Start inside
    0x80, 0x3c, 0xf8, 0x00,
  ]);
  assert.deepEqual(p.outputs(), [0, 1 << 12, 0, 0]);
});

test('all 16 channels by DIN', () => {
  const s = [];
  for (let ch = 0; ch < 16; ch++) s.push(0x90 | ch, 40 + ch * 3, 100);
  for (let ch = 0; ch < 16; ch += 2) s.push(0x80 | ch, 40 + ch * 3, 0);
  const p = checkDin(s);
  assert.notDeepEqual(p.outputs(), [0, 0, 0, 0]);
});

test('notes 0 to 127 fold into the keyboard by DIN', () => {
  const s = [];
  for (let n = 0; n <= 127; n++) s.push(0x90, n, 64);
  for (let n = 0; n <= 127; n++) s.push(0x80, n, 0);
  const p = checkDin(s);
  assert.deepEqual(p.outputs(), [0, 0, 0, 0]);
});

test('a lone DIN message reaches its board within 400 µs of its last stop bit', () => {
  // The UART interrupts for every byte (its FIFO off). With the FIFO on at embassy-rp's
  // trigger level (28 of 32 bytes) a lone message waited for the receive timeout, 32 bit
  // times (1024 µs) after its last stop bit.
  const { booted } = require('./common.js');
  const { p, from } = booted();
  p.sendDin([0x90, 60, 100]);
  const stop = p.dinIn.at(-1).ns;
  p.runUs(5_000);
  const write = p.bus.outputWrites(from)[0];
  assert.ok(write, 'the note made a board write');
  const us = (write.tNs - stop) / 1000;
  assert.ok(us < 400, `last stop bit -> write done: ${us} µs`);
});
