'use strict';
// orch-core on the host (expect/, `orch-rp2040-expect`), fed what the emulator fed the
// firmware at the same times, and the comparison of its board writes with the bus's.
const path = require('node:path');
const { spawnSync } = require('node:child_process');

const EXPECT =
  process.env.ORCH_RP2040_EXPECT ||
  path.join(__dirname, '../expect/target/release/orch-rp2040-expect');

function runExpect(args, input = '') {
  const r = spawnSync(EXPECT, args, { input, encoding: 'utf8', maxBuffer: 1 << 28 });
  if (r.error) throw r.error;
  if (r.status !== 0) throw new Error(`orch-rp2040-expect ${args.join(' ')}: ${r.stderr}`);
  return r.stdout;
}

/**
 * The host's writes for what `pico` was fed (DIN bytes at the end of their stop bits, USB
 * packets when they landed in the device's buffer), with the guard's timers run to `untilNs`:
 * { writes: [{ tUs, board, outputs }], outputs: [4] }.
 */
function hostRun(pico, untilNs = pico.nowNs, fromNs = 0) {
  const text = hostInput(pico, untilNs, fromNs);
  const writes = [];
  let outputs = null;
  for (const line of runExpect([], text).split('\n')) {
    const w = line.split(' ');
    if (w[0] === 'write') writes.push({ tUs: +w[1], board: +w[2], outputs: +w[3] });
    if (w[0] === 'outputs') outputs = w.slice(1).map(Number);
  }
  return { writes, outputs };
}

/**
 * The same for the `pca9685` build (`orch-rp2040-expect pca9685`: the firmware's robot.rs
 * settings, flush_duties): { writes: [{ tUs, board, duties[16] }], duties: 5 × 16 at the end }.
 */
function hostRunPwm(pico, untilNs = pico.nowNs, fromNs = 0) {
  const text = hostInput(pico, untilNs, fromNs);
  const writes = [];
  const duties = [];
  for (const line of runExpect(['pca9685'], text).split('\n')) {
    const w = line.split(' ');
    if (w[0] === 'duties') writes.push({ tUs: +w[1], board: +w[2], duties: w.slice(3).map(Number) });
    if (w[0] === 'final') duties[+w[1]] = w.slice(2).map(Number);
  }
  return { writes, duties };
}

/** What `pico` was fed, as `orch-rp2040-expect`'s input lines. */
function hostInput(pico, untilNs, fromNs) {
  const inputs = [];
  for (const d of pico.dinIn) if (d.ns >= fromNs) inputs.push({ ns: d.ns, line: `din ${us(d.ns)} ${d.byte}` });
  for (const p of pico.usbIn) {
    if (p.ns < fromNs) continue;
    for (let i = 0; i + 4 <= p.bytes.length; i += 4) {
      const n = eventLength(p.bytes[i]);
      if (n) inputs.push({ ns: p.ns, line: `usb ${us(p.ns)} ${p.bytes.slice(i + 1, i + 1 + n).join(' ')}` });
    }
  }
  inputs.sort((a, b) => a.ns - b.ns); // stable: a packet's events stay in order
  return inputs.map((i) => i.line).join('\n') + `\nend ${us(untilNs)}\n`;
}

/** How many MIDI bytes a USB-MIDI event carries, by its code index number (as the firmware). */
function eventLength(header) {
  const cin = header & 0x0f;
  if (cin === 0x5 || cin === 0xf) return 1;
  if ([0x2, 0x6, 0xc, 0xd].includes(cin)) return 2;
  if ([0x3, 0x4, 0x7, 0x8, 0x9, 0xa, 0xb, 0xe].includes(cin)) return 3;
  return 0;
}

/** A Standard MIDI File as timed wire bytes: [{ us, byte }]. */
function smfToWire(file) {
  return runExpect(['smf', file])
    .trim()
    .split('\n')
    .map((l) => l.split(' ').map(Number))
    .map(([t, b]) => ({ us: t, byte: b }));
}

/** The µs clock a time in ns reads on the firmware's 1 MHz timer. */
function us(ns) {
  return Math.floor(ns / 1000);
}

/** The bus's output writes (STOP times in µs) from log entry `from` on. */
function firmwareWrites(pico, from = 0) {
  return pico.bus.outputWrites(from).map((w) => ({ tUs: w.tNs / 1000, board: w.board, outputs: w.outputs }));
}

/** Each press and release in a series of writes (every board starts at 0). */
function keyEvents(writes) {
  const last = [0, 0, 0, 0];
  const out = [];
  for (const w of writes) {
    const changed = last[w.board] ^ w.outputs;
    for (let bit = 0; bit < 16; bit++) {
      if (changed & (1 << bit)) out.push({ tUs: w.tUs, key: w.board * 16 + bit, down: !!(w.outputs & (1 << bit)) });
    }
    last[w.board] = w.outputs;
  }
  return out;
}

function perBoard(writes) {
  const out = [[], [], [], []];
  for (const w of writes) out[w.board].push(w.outputs);
  return out;
}

/**
 * Every press and release the host made reaches the boards, key by key in the same order,
 * none missing and none extra, no earlier than the host made it and at most `maxLateUs`
 * after. Returns { presses, releases, late (sorted µs) }; throws on the first difference.
 */
function sameKeyEvents(firmware, host, maxLateUs) {
  const f = keyEvents(firmware);
  const h = keyEvents(host);
  const m = { presses: 0, releases: 0, late: [] };
  for (let key = 0; key < 64; key++) {
    const fk = f.filter((e) => e.key === key);
    const hk = h.filter((e) => e.key === key);
    hk.forEach((he, i) => {
      const what = he.down ? 'press' : 'release';
      const fe = fk[i];
      if (!fe) {
        throw new Error(
          `key ${key} (board ${key >> 4}, bit ${key & 15}): the host's ${what} #${i} at ${he.tUs} µs never reached the boards (${fk.length} events on the bus, ${hk.length} on the host)`,
        );
      }
      if (fe.down !== he.down) {
        throw new Error(`key ${key}: event #${i} is a ${fe.down ? 'press' : 'release'} on the bus at ${fe.tUs} µs, the host's a ${what} at ${he.tUs} µs`);
      }
      const late = fe.tUs - he.tUs;
      if (late < 0 || late > maxLateUs) {
        throw new Error(`key ${key}: ${what} #${i} on the bus at ${fe.tUs} µs, the host made it at ${he.tUs} µs (allowed: 0..${maxLateUs} µs later)`);
      }
      m.late.push(late);
      if (he.down) m.presses++;
      else m.releases++;
    });
    if (fk.length > hk.length) {
      const e = fk[hk.length];
      throw new Error(`key ${key}: the bus has a ${e.down ? 'press' : 'release'} at ${e.tUs} µs that the host never made`);
    }
  }
  m.late.sort((a, b) => a - b);
  return m;
}

/** The bus's duty writes (STOP times in µs, the board's 16 duties after each) from `from` on. */
function firmwareDutyWrites(pico, from = 0) {
  return pico.bus.dutyWrites(from).map((w) => ({ tUs: w.tNs / 1000, board: w.board, duties: w.duties }));
}

/**
 * A series of duty writes without those that change nothing on their board (every board
 * starts all off): the driver writes only the channels whose duty changed, so a flush that
 * hands a board its duties unchanged puts nothing on the bus. Returns { writes, dropped }.
 */
function changingDutyWrites(writes) {
  const last = [];
  const out = [];
  for (const w of writes) {
    last[w.board] ??= new Array(16).fill(0);
    if (w.duties.every((d, c) => d === last[w.board][c])) continue;
    last[w.board] = w.duties;
    out.push(w);
  }
  return { writes: out, dropped: writes.length - out.length };
}

/** Each channel's duty changes in a series of duty writes: [{ tUs, board, channel, duty }]. */
function dutyEvents(writes) {
  const last = [];
  const out = [];
  for (const w of writes) {
    last[w.board] ??= new Array(16).fill(0);
    w.duties.forEach((d, c) => {
      if (d !== last[w.board][c]) out.push({ tUs: w.tUs, board: w.board, channel: c, duty: d });
    });
    last[w.board] = w.duties;
  }
  return out;
}

/**
 * Every duty change the host made (strike, hold, release) reaches its channel, channel by
 * channel in the same order with the same duty, none missing and none extra, no earlier than
 * the host made it and at most `maxLateUs` after. Returns { changes (to a duty above 0), releases (to 0), late (sorted µs) }.
 */
function sameDutyEvents(firmware, host, maxLateUs) {
  const f = dutyEvents(firmware);
  const h = dutyEvents(host);
  const m = { changes: 0, releases: 0, late: [] };
  const boards = Math.max(0, ...f.map((e) => e.board + 1), ...h.map((e) => e.board + 1));
  for (let board = 0; board < boards; board++) {
    for (let channel = 0; channel < 16; channel++) {
      const fc = f.filter((e) => e.board === board && e.channel === channel);
      const hc = h.filter((e) => e.board === board && e.channel === channel);
      const where = `board ${board} channel ${channel}`;
      hc.forEach((he, i) => {
        const fe = fc[i];
        if (!fe) throw new Error(`${where}: the host's change #${i} to ${he.duty} at ${he.tUs} µs never reached the board (${fc.length} changes on the bus, ${hc.length} on the host)`);
        if (fe.duty !== he.duty) throw new Error(`${where}: change #${i} is to ${fe.duty} on the bus at ${fe.tUs} µs, the host's to ${he.duty} at ${he.tUs} µs`);
        const late = fe.tUs - he.tUs;
        if (late < 0 || late > maxLateUs) {
          throw new Error(`${where}: change #${i} to ${he.duty} on the bus at ${fe.tUs} µs, the host made it at ${he.tUs} µs (allowed: 0..${maxLateUs} µs later)`);
        }
        m.late.push(late);
        if (he.duty === 0) m.releases++;
        else m.changes++;
      });
      if (fc.length > hc.length) {
        const e = fc[hc.length];
        throw new Error(`${where}: the bus has a change to ${e.duty} at ${e.tUs} µs that the host never made`);
      }
    }
  }
  m.late.sort((a, b) => a - b);
  return m;
}

function percentile(sorted, p) {
  return sorted.length ? sorted[Math.floor(((sorted.length - 1) * p) / 100)] : 0;
}

module.exports = {
  hostRun,
  hostRunPwm,
  smfToWire,
  firmwareWrites,
  firmwareDutyWrites,
  changingDutyWrites,
  dutyEvents,
  keyEvents,
  perBoard,
  sameKeyEvents,
  sameDutyEvents,
  percentile,
  us,
  EXPECT,
};
