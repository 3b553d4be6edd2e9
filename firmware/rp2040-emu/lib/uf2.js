'use strict';
// A UF2 file for the RP2040, as the Pico's boot ROM takes it from its USB drive (UF2
// specification: 512-byte blocks, each with two start magics, flags, a target address, a
// payload size, its number, the block count, the family ID and an end magic). Read into the
// bytes it puts in flash, so that the emulator can run exactly what a Pico would be flashed
// with.
const fs = require('node:fs');

const MAGIC_START0 = 0x0a324655;
const MAGIC_START1 = 0x9e5d5157;
const MAGIC_END = 0x0ab16f30;
/** The family ID field is set. */
const FLAG_FAMILY_ID = 0x2000;
/** A block not meant for the main flash. */
const FLAG_NOT_MAIN_FLASH = 0x0001;
/** The RP2040's family ID. */
const RP2040_FAMILY = 0xe48bff56;
const FLASH_BASE = 0x10000000;
const FLASH_SIZE = 2 * 1024 * 1024;

/**
 * The flash image a UF2 file writes: `{ base, data }` from its lowest to its highest address
 * (gaps 0xff, as erased flash), and the blocks it had. Throws, naming the block, for a file
 * that is not a whole, consistent RP2040 UF2: a size not a multiple of 512, a bad magic, a
 * family other than the RP2040's, a payload that is not 256 bytes or leaves the flash, a
 * block number or count that does not follow, or a block written twice.
 */
function readUf2(file) {
  const f = typeof file === 'string' ? fs.readFileSync(file) : file;
  if (f.length === 0 || f.length % 512 !== 0) {
    throw new Error(`UF2: ${f.length} bytes is not a whole number of 512-byte blocks`);
  }
  const n = f.length / 512;
  const blocks = [];
  for (let i = 0; i < n; i++) {
    const b = f.subarray(i * 512, (i + 1) * 512);
    const w = (o) => b.readUInt32LE(o);
    const where = `UF2 block ${i}`;
    if (w(0) !== MAGIC_START0 || w(4) !== MAGIC_START1 || w(508) !== MAGIC_END) {
      throw new Error(`${where}: bad magic`);
    }
    const flags = w(8);
    if (flags & FLAG_NOT_MAIN_FLASH) continue;
    if (!(flags & FLAG_FAMILY_ID) || w(28) !== RP2040_FAMILY) {
      throw new Error(`${where}: not for the RP2040 (family ${w(28).toString(16)})`);
    }
    const addr = w(12);
    const size = w(16);
    if (size !== 256) throw new Error(`${where}: a payload of ${size} bytes, not 256`);
    if (addr < FLASH_BASE || addr + size > FLASH_BASE + FLASH_SIZE || addr % 256 !== 0) {
      throw new Error(`${where}: address ${addr.toString(16)} is not a flash page`);
    }
    if (w(20) !== i || w(24) !== n) {
      throw new Error(`${where}: numbered ${w(20)} of ${w(24)}, not ${i} of ${n}`);
    }
    blocks.push({ addr, data: b.subarray(32, 32 + size) });
  }
  if (blocks.length === 0) throw new Error('UF2: no block for the main flash');
  const lo = Math.min(...blocks.map((b) => b.addr));
  const hi = Math.max(...blocks.map((b) => b.addr + 256));
  const data = Buffer.alloc(hi - lo, 0xff);
  const seen = new Set();
  for (const b of blocks) {
    if (seen.has(b.addr)) throw new Error(`UF2: page ${b.addr.toString(16)} written twice`);
    seen.add(b.addr);
    b.data.copy(data, b.addr - lo);
  }
  return { base: lo, data, blocks: n };
}

module.exports = { readUf2, RP2040_FAMILY };
