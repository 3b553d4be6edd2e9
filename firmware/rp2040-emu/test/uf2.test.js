'use strict';
// The UF2 file the README has a builder copy onto the Pico: `firmware/test.sh` makes it with
// elf2uf2-rs and sets ORCH_RP2040_UF2, so every emulator test boots from its bytes. Here: those
// bytes are the ELF's flash segments, nothing more; the firmware plays from them; and a file
// that is not a whole RP2040 UF2 is refused, naming what is wrong.
const test = require('node:test');
const assert = require('node:assert/strict');
const { Pico, elfPath, uf2Path } = require('../lib/pico.js');
const { readElf } = require('../lib/elf.js');
const { readUf2, RP2040_FAMILY } = require('../lib/uf2.js');

/** A UF2 file of `pages` 256-byte payloads from `base`, each filled with its index. */
function makeUf2(pages, { base = 0x10000000, family = RP2040_FAMILY } = {}) {
  const f = Buffer.alloc(512 * pages);
  for (let i = 0; i < pages; i++) {
    const b = f.subarray(i * 512, (i + 1) * 512);
    b.writeUInt32LE(0x0a324655, 0);
    b.writeUInt32LE(0x9e5d5157, 4);
    b.writeUInt32LE(0x2000, 8);
    b.writeUInt32LE(base + 256 * i, 12);
    b.writeUInt32LE(256, 16);
    b.writeUInt32LE(i, 20);
    b.writeUInt32LE(pages, 24);
    b.writeUInt32LE(family, 28);
    b.fill(i & 0xff, 32, 32 + 256);
    b.writeUInt32LE(0x0ab16f30, 508);
  }
  return f;
}

test('the UF2 file holds exactly the ELF flash segments', (t) => {
  const file = uf2Path();
  if (!file) {
    t.skip('ORCH_RP2040_UF2 is not set (firmware/test.sh sets it)');
    return;
  }
  const uf2 = readUf2(file);
  const elf = readElf(elfPath());
  const flash = elf.segments.filter((s) => s.paddr >= 0x10000000 && s.paddr < 0x11000000 && s.data.length > 0);
  assert.ok(flash.length > 0);
  let covered = 0;
  for (const s of flash) {
    const at = s.paddr - uf2.base;
    assert.ok(at >= 0 && at + s.data.length <= uf2.data.length, `segment at ${s.paddr.toString(16)} is in the UF2`);
    assert.ok(uf2.data.subarray(at, at + s.data.length).equals(s.data), `segment at ${s.paddr.toString(16)} byte for byte`);
    covered += s.data.length;
  }
  const lo = Math.min(...flash.map((s) => s.paddr));
  const hi = Math.max(...flash.map((s) => s.paddr + s.data.length));
  assert.equal(uf2.base, lo - (lo % 256), 'the UF2 starts at the first segment');
  assert.ok(uf2.base + uf2.data.length <= hi + 255, 'and ends with the last one');
  t.diagnostic(`${uf2.blocks} blocks, ${covered} bytes of segments`);
});

test('the firmware flashed from the UF2 file plays', (t) => {
  if (!uf2Path()) {
    t.skip('ORCH_RP2040_UF2 is not set (firmware/test.sh sets it)');
    return;
  }
  const p = new Pico();
  assert.ok(p.uf2, 'booted from the UF2');
  p.runUs(100_000);
  p.sendDin([0x90, 60, 100]);
  p.runUs(5_000);
  assert.deepEqual(p.outputs(), [0, 1 << 8, 0, 0]);
});

test('a file that is not a whole RP2040 UF2 is refused, naming the fault', () => {
  const good = makeUf2(3);
  const image = readUf2(good);
  assert.equal(image.base, 0x10000000);
  assert.equal(image.data.length, 3 * 256);
  assert.equal(image.data[2 * 256], 2);

  assert.throws(() => readUf2(good.subarray(0, 1000)), /not a whole number of 512-byte blocks/);
  const magic = Buffer.from(good);
  magic.writeUInt32LE(0, 512 + 508);
  assert.throws(() => readUf2(magic), /UF2 block 1: bad magic/);
  assert.throws(() => readUf2(makeUf2(2, { family: 0x12345678 })), /not for the RP2040/);
  assert.throws(() => readUf2(makeUf2(2, { base: 0x20000000 })), /is not a flash page/);
  const numbered = Buffer.from(good);
  numbered.writeUInt32LE(0, 512 + 20);
  assert.throws(() => readUf2(numbered), /numbered 0 of 3, not 1 of 3/);
  const twice = Buffer.from(good);
  twice.writeUInt32LE(0x10000000, 512 + 12);
  assert.throws(() => readUf2(twice), /written twice/);
});
