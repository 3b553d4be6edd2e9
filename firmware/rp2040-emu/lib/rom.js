'use strict';
// The project's stand-in for the RP2040 boot ROM (Raspberry Pi's is in no package registry).
//
// It does what the real ROM does on a flash boot and nothing else: the initial stack pointer
// and reset vector at 0x0, and a reset routine that enters the image's second-stage boot
// loader (boot2, the first 256 bytes of flash) with lr = 0, which makes boot2 set up XIP,
// point VTOR at the vector table at 0x10000100 and jump to the firmware's reset handler.
// Everything else, including the ROM's function and data tables (magic 'Mu' at 0x10, table
// pointers at 0x14/0x16/0x18), leads to UDF #0xEE: a firmware that called any ROM function
// (flash, memcpy, floating point, …) stops there with `RomCallError`.
const ROM_BYTES = 16 * 1024;
const TRAP = 0xee;
const RESET_ROUTINE = 0x100;
const TRAP_AT = 0x200;

function standInRom() {
  const rom = new Uint16Array(ROM_BYTES / 2).fill(0xde00 | TRAP); // udf #0xee
  const words = new Uint32Array(rom.buffer);
  words[0] = 0x20042000; // initial SP: the top of the SRAM (the real ROM's)
  words[1] = RESET_ROUTINE | 1; // reset vector (Thumb)
  // 0x10: magic 'M' 'u' and version 1; 0x14..0x19: the function table, data table and
  // lookup function pointers, all to a trap.
  rom[0x10 / 2] = 0x754d;
  rom[0x12 / 2] = 0x0101;
  rom[0x14 / 2] = TRAP_AT;
  rom[0x16 / 2] = TRAP_AT;
  rom[0x18 / 2] = TRAP_AT;
  const code = [
    0x2000, // movs r0, #0
    0x4686, // mov  lr, r0      (boot2 returns through lr; 0 = "vector into the image")
    0x4900, // ldr  r1, [pc, #0]
    0x4708, // bx   r1
  ];
  code.forEach((op, i) => (rom[RESET_ROUTINE / 2 + i] = op));
  words[(RESET_ROUTINE + 8) / 4] = 0x10000001; // boot2, Thumb
  return words;
}

class RomCallError extends Error {}

module.exports = { standInRom, RomCallError, ROM_BYTES, TRAP };
