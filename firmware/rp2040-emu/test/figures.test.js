'use strict';
// The figures in firmware/rp2040/README.md: flash, RAM, the deepest stack, CPU cycles per
// note message, and the latency from a message's arrival (USB packet in the device's buffer,
// or DIN last stop bit) to the end (STOP) of its board write.
const test = require('node:test');
const assert = require('node:assert/strict');
const { booted, floodStream, midiEvent, fmt } = require('./common.js');

/** Plays `send` and measures: CPU cycles awake from the send to 3 ms after the arrival, and arrival -> write STOP. */
function measure(p, send, arrivalNs) {
  const from = p.bus.log.length;
  const cycles0 = p.cycles;
  send();
  const at = arrivalNs();
  p.runUntilNs(at + 3e6);
  const cycles = p.cycles - cycles0;
  const write = p.bus.outputWrites(from)[0];
  assert.ok(write, 'the message made a board write');
  const latencyUs = (write.tNs - at) / 1000;
  p.runUs(100_000); // past the guard's shortest press and restrike gap
  return { cycles, latencyUs };
}

function span(v) {
  return `${fmt(Math.min(...v))}..${fmt(Math.max(...v))}`;
}

function mean(v) {
  return v.reduce((a, b) => a + b, 0) / v.length;
}

test('figures', () => {
  const { p } = booted();
  const sec = (n) => (p.elf.sections[n] ? p.elf.sections[n].size : 0);
  const flash = sec('.boot2') + sec('.vector_table') + sec('.text') + sec('.rodata') + sec('.data');
  const ram = sec('.data') + sec('.bss') + sec('.uninit');

  // A quiet 3 ms: what the loop costs with nothing to do.
  const idle0 = p.cycles;
  p.runUs(3_000);
  const idle = p.cycles - idle0;

  const din = [[0x90, 60, 100], [0x90, 64, 100], [67, 100], [0x80, 60, 0], [64, 0], [67, 0]];
  const usb = [[0x90, 60, 100], [0x90, 64, 100], [0x90, 67, 100], [0x80, 60, 0], [0x80, 64, 0], [0x80, 67, 0]];
  const dinM = din.map((m) => measure(p, () => p.sendDin(m), () => p.dinIn.at(-1).ns));
  const usbM = usb.map((m) =>
    measure(
      p,
      () => p.sendUsb(midiEvent(m)),
      () => {
        const n = p.usbIn.length;
        while (p.usbIn.length === n) p.runUs(1); // until the packet is in the device's buffer
        return p.usbIn.at(-1).ns;
      },
    ),
  );

  // The deepest stack, after a busy stretch: a full-rate DIN flood with USB packets inside.
  const stream = floodStream(1);
  for (let i = 0; i < stream.length; i += 50) {
    p.sendDin(stream.slice(i, i + 50));
    p.sendUsb([...midiEvent([0x91, 40 + (i % 40), 90]), ...midiEvent([0x81, 40 + (i % 40), 0])]);
  }
  p.runUs(200_000);
  const stack = p.stackHighWater();
  assert.equal(p.resets.length, 0);

  const i2c = p.chip.i2c[0];
  const sclHz = p.chip.clkSys / (i2c.fsClockHighPeriod + i2c.fsClockLowPeriod);
  const writeUs = (38 * 1e6) / sclHz; // START, address + 3 bytes with their acknowledges, STOP
  console.log('\n== Raspberry Pi Pico firmware figures (rp2040js, clk_sys %d MHz) ==', p.chip.clkSys / 1e6);
  console.log(`ELF: ${require('../lib/pico.js').elfPath()}`);
  console.log(
    `flash: ${flash} bytes (.boot2 ${sec('.boot2')} + .vector_table ${sec('.vector_table')} + .text ${sec('.text')} + .rodata ${sec('.rodata')} + .data ${sec('.data')}) of 2 MiB`,
  );
  console.log(
    `RAM: ${ram} bytes static (.data ${sec('.data')} + .bss ${sec('.bss')} + .uninit ${sec('.uninit')}) + ${stack} bytes deepest stack seen = ${ram + stack} of 264 KiB`,
  );
  console.log(`CPU cycles awake in a quiet 3 ms: ${idle}`);
  console.log(
    `CPU cycles per note message by DIN (first byte to 3 ms after the last stop bit: UART and I2C interrupts, decoding, interpreting, the write): ${dinM.map((m) => m.cycles).join(', ')}; mean ${fmt(mean(dinM.map((m) => m.cycles)))} (${(mean(dinM.map((m) => m.cycles)) / 125).toFixed(1)} µs at 125 MHz)`,
  );
  console.log(
    `CPU cycles per note message by USB (packet sent to 3 ms after it is in: USB and I2C interrupts, interpreting, the write): ${usbM.map((m) => m.cycles).join(', ')}; mean ${fmt(mean(usbM.map((m) => m.cycles)))} (${(mean(usbM.map((m) => m.cycles)) / 125).toFixed(1)} µs)`,
  );
  console.log(
    `USB-MIDI packet in the device's buffer -> I2C write done (STOP): ${span(usbM.map((m) => m.latencyUs))} µs (mean ${fmt(mean(usbM.map((m) => m.latencyUs)))}); DIN last stop bit -> I2C write done: ${span(dinM.map((m) => m.latencyUs))} µs (mean ${fmt(mean(dinM.map((m) => m.latencyUs)))})`,
  );
  console.log(`  of which the write on the bus: 38 SCL periods at ${(sclHz / 1000).toFixed(1)} kHz = ${fmt(writeUs)} µs`);
  din.forEach((m, i) => console.log(`  DIN ${JSON.stringify(m)}: ${fmt(dinM[i].latencyUs)} µs, ${dinM[i].cycles} cycles`));
  usb.forEach((m, i) => console.log(`  USB ${JSON.stringify(m)}: ${fmt(usbM[i].latencyUs)} µs, ${usbM[i].cycles} cycles`));
  assert.ok(flash < 2 * 1024 * 1024 - 256);
  assert.ok(ram + stack < 256 * 1024);
});
