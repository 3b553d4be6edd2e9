'use strict';
// A 32-bit little-endian ELF file: its loadable segments (at their load addresses), its
// section sizes and its symbols.
const fs = require('node:fs');

function readElf(path) {
  const f = fs.readFileSync(path);
  if (f.readUInt32BE(0) !== 0x7f454c46 || f[4] !== 1 || f[5] !== 1) {
    throw new Error(`${path}: not a 32-bit little-endian ELF file`);
  }
  const phoff = f.readUInt32LE(0x1c);
  const shoff = f.readUInt32LE(0x20);
  const phentsize = f.readUInt16LE(0x2a);
  const phnum = f.readUInt16LE(0x2c);
  const shentsize = f.readUInt16LE(0x2e);
  const shnum = f.readUInt16LE(0x30);
  const shstrndx = f.readUInt16LE(0x32);
  const entry = f.readUInt32LE(0x18);

  const segments = [];
  for (let i = 0; i < phnum; i++) {
    const p = phoff + i * phentsize;
    const type = f.readUInt32LE(p);
    const filesz = f.readUInt32LE(p + 0x10);
    if (type !== 1 || filesz === 0) continue; // PT_LOAD with bytes in the file
    const offset = f.readUInt32LE(p + 4);
    segments.push({ paddr: f.readUInt32LE(p + 0x0c), data: f.subarray(offset, offset + filesz) });
  }

  const header = (i) => shoff + i * shentsize;
  const cstr = (at) => f.toString('latin1', at, f.indexOf(0, at));
  const names = f.readUInt32LE(header(shstrndx) + 0x10);
  const sections = {};
  let symtab = null;
  let strtab = null;
  for (let i = 0; i < shnum; i++) {
    const h = header(i);
    const s = {
      name: cstr(names + f.readUInt32LE(h)),
      type: f.readUInt32LE(h + 4),
      addr: f.readUInt32LE(h + 0x0c),
      offset: f.readUInt32LE(h + 0x10),
      size: f.readUInt32LE(h + 0x14),
      link: f.readUInt32LE(h + 0x18),
      entsize: f.readUInt32LE(h + 0x24),
    };
    sections[s.name] = s;
    if (s.type === 2) symtab = s; // SHT_SYMTAB
  }
  const symbols = {};
  if (symtab) {
    strtab = header(symtab.link);
    const strOff = f.readUInt32LE(strtab + 0x10);
    for (let at = symtab.offset; at < symtab.offset + symtab.size; at += 16) {
      const name = cstr(strOff + f.readUInt32LE(at));
      if (name) symbols[name] = { value: f.readUInt32LE(at + 4), size: f.readUInt32LE(at + 8) };
    }
  }
  return { entry, segments, sections, symbols };
}

module.exports = { readElf };
