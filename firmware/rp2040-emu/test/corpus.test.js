'use strict';
// A whole MIDI file from the corpus, by DIN at wire speed and by USB, every press and release
// equal to orch-core's on the host.
const test = require('node:test');
const assert = require('node:assert/strict');
const fs = require('node:fs');
const path = require('node:path');
const { booted, assertSameAsHost, midiEvent, fmt } = require('./common.js');
const host = require('../lib/host.js');

// A short piece on one channel, and a four-part chorale (notes below the keyboard fold).
const FILES = ['m21-test06.mid', 'bach-bwv66-6-chorale.mid'];

function corpusFile(name) {
  const beside = path.join(__dirname, '../../../../shared/midi', name);
  return fs.existsSync(beside) ? beside : path.join('/work/shared/midi', name);
}

/** The longest any key stayed down on the boards, in ms. */
function longestKeyMs(p, from) {
  const down = new Map();
  let longest = 0;
  for (const e of host.keyEvents(host.firmwareWrites(p, from))) {
    if (e.down) down.set(e.key, e.tUs);
    else {
      longest = Math.max(longest, e.tUs - down.get(e.key));
      down.delete(e.key);
    }
  }
  return longest / 1000;
}

function finish(p, from, din, how, t0, FILE) {
  p.runUs(5_000_000); // past the guard's 4 s watchdog
  assert.deepEqual(p.outputs(), [0, 0, 0, 0], 'boards end all-off');
  const longest = longestKeyMs(p, from);
  assert.ok(longest <= 10_010, `a key was held ${longest} ms`);
  const m = assertSameAsHost(p, from, din);
  assert.ok(m.presses > 50, `${m.presses} presses`);
  console.log(`  ${FILE} by ${how}: longest key ${fmt(longest)} ms, ${fmt(p.nowUs / 1000)} ms emulated in ${Date.now() - t0} ms`);
}

for (const FILE of FILES) {
test(`${FILE} by DIN at wire speed`, () => {
  const t0 = Date.now();
  const timed = host.smfToWire(corpusFile(FILE));
  const { p, from } = booted();
  const start = p.nowNs;
  for (const { us, byte } of timed) p.putDinAt(byte, start + us * 1000); // at its time, or right after the byte before
  finish(p, from, timed.map((t) => t.byte), 'DIN', t0, FILE);
});

test(`${FILE} by USB, a packet a message at its time`, () => {
  const t0 = Date.now();
  const timed = host.smfToWire(corpusFile(FILE));
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
  assert.ok(messages.length > 100);
  finish(p, from, [], 'USB', t0, FILE);
  assert.equal(p.usbIn.length, messages.length, 'every packet reached the device');
});
}
