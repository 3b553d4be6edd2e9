'use strict';
// USB-MIDI event packets through the emulated USB controller (the harness's host enumerated
// the device first), compared with orch-core on the host.
const test = require('node:test');
const assert = require('node:assert/strict');
const { booted, assertSameAsHost, checkUsb, midiEvent } = require('./common.js');

test('the host enumerates a USB-MIDI device', () => {
  const { p } = booted();
  const d = p.usbHost.device;
  assert.equal(d[0], 18, 'a device descriptor');
  assert.equal(d[8] | (d[9] << 8), 0x1209, 'the firmware vendor id');
  assert.ok(p.usbHost.outEndpoint > 0, 'a bulk OUT endpoint on the MIDI streaming interface');
});

test('thesis Table 3: three Note-Ons by USB', () => {
  const p = checkUsb([
    [0x90, 0x3c, 0x7f],
    [0x90, 0x40, 0x7f],
    [0x90, 0x43, 0x7f],
  ]);
  assert.deepEqual(p.outputs(), [0, (1 << 8) | (1 << 12) | (1 << 15), 0, 0]);
});

test('thesis Table 4 as one USB packet of four events', () => {
  const { p, from } = booted();
  p.sendUsb([
    ...midiEvent([0x90, 0x3c, 0x7f]),
    ...midiEvent([0x90, 0x40, 0x7f]),
    ...midiEvent([0x90, 0x43, 0x7f]),
    ...midiEvent([0x80, 0x40, 0x00]),
  ]);
  p.runUs(100_000);
  assert.equal(p.usbIn.length, 1);
  assertSameAsHost(p, from);
  assert.deepEqual(p.outputs(), [0, (1 << 8) | (1 << 15), 0, 0]);
});

test('real-time events between USB messages', () => {
  const p = checkUsb([[0xf8], [0x90, 0x3c, 0x7f], [0xfe], [0x90, 0x40, 0x7f], [0xfa], [0x80, 0x3c, 0x00], [0xf8]]);
  assert.deepEqual(p.outputs(), [0, 1 << 12, 0, 0]);
});

test('all 16 channels by USB', () => {
  const m = [];
  for (let ch = 0; ch < 16; ch++) m.push([0x90 | ch, 40 + ch * 3, 100]);
  for (let ch = 0; ch < 16; ch += 2) m.push([0x80 | ch, 40 + ch * 3, 0]);
  const p = checkUsb(m);
  assert.notDeepEqual(p.outputs(), [0, 0, 0, 0]);
});

test('notes 0 to 127 fold into the keyboard by USB', () => {
  const m = [];
  for (let n = 0; n <= 127; n++) m.push([0x90, n, 64]);
  for (let n = 0; n <= 127; n++) m.push([0x80, n, 0]);
  const p = checkUsb(m, 400);
  assert.deepEqual(p.outputs(), [0, 0, 0, 0]);
});

test('a USB message inside a DIN message does not split its running status', () => {
  const { p, from } = booted();
  const din = [0x90, 0x3c];
  p.sendDin(din); // a Note-On by DIN, its velocity still to come
  p.sendUsb(midiEvent([0x80, 0x30, 0x00])); // a Note-Off by USB in between
  p.runUs(100);
  const rest = [0x7f, 0x43, 0x7f]; // the velocity, then running status
  p.sendDin(rest);
  p.runUs(100_000);
  assertSameAsHost(p, from, [...din, ...rest]);
  assert.deepEqual(p.outputs(), [0, (1 << 8) | (1 << 15), 0, 0]);
});
