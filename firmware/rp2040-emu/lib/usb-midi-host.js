'use strict';
// A USB host for the emulated RP2040's USB controller (device mode): it enumerates the
// device as a host does (bus reset, SET_ADDRESS, the device descriptor, the configuration
// descriptor's header then all of it, SET_CONFIGURATION), finds the USB-MIDI streaming
// interface (audio class 1, subclass 3) and its bulk endpoints, then sends USB-MIDI event
// packets to its OUT endpoint whenever the device has a buffer armed there.
//
// rp2040js's controller hands the host each IN packet (onEndpointWrite) and each armed OUT
// buffer (onEndpointRead); control transfers are SETUP, data, then the status stage (a
// zero-length packet the other way).

const DEVICE = 1;
const CONFIGURATION = 2;
const INTERFACE = 4;
const ENDPOINT = 5;

function setup(requestType, request, value, index, length) {
  return new Uint8Array([
    requestType, request, value & 0xff, value >> 8, index & 0xff, index >> 8, length & 0xff, length >> 8,
  ]);
}

class UsbMidiHost {
  constructor() {
    this.device = null;
    this.configuration = null;
    this.outEndpoint = -1;
    this.inEndpoint = -1;
    this.configured = false;
    /** Packets waiting for the device's OUT buffer: Uint8Array of 4·n bytes. */
    this.queue = [];
    /** Called with (bytes, ns) when a packet lands in the device's buffer. */
    this.onPacketIn = null;
  }

  /** Connects to `chip`'s USB controller (after every chip reset). */
  attach(chip) {
    const usb = chip.usbCtrl;
    this.usb = usb;
    this.chip = chip;
    this.configured = false;
    this.armed = new Map(); // endpoint -> armed OUT buffer length
    this.control = null; // { setup, in: bool, length, data: [], then }
    const steps = [];
    const run = () => {
      const next = steps.shift();
      if (next) next();
    };
    const transfer = (packet, then) => {
      const length = packet[6] | (packet[7] << 8);
      this.control = { in: !!(packet[0] & 0x80), length, data: [], then, statusSent: false };
      usb.sendSetupPacket(packet);
    };
    steps.push(
      () => transfer(setup(0x00, 5, 1, 0, 0), run), // SET_ADDRESS 1
      () =>
        transfer(setup(0x80, 6, DEVICE << 8, 0, 18), (d) => {
          this.device = d;
          run();
        }),
      () =>
        transfer(setup(0x80, 6, CONFIGURATION << 8, 0, 9), (d) => {
          steps.unshift(() => full(d[2] | (d[3] << 8))); // then all wTotalLength bytes
          run();
        }),
      () =>
        transfer(setup(0x00, 9, 1, 0, 0), () => {
          // SET_CONFIGURATION 1
          this.configured = true;
          this.pump();
        }),
    );
    const full = (total) =>
      transfer(setup(0x80, 6, CONFIGURATION << 8, 0, total), (d) => {
        this.configuration = d;
        this.findMidiEndpoints(d);
        run();
      });

    usb.onUSBEnabled = () => usb.resetDevice();
    usb.onResetReceived = () => run();
    usb.onEndpointWrite = (endpoint, buffer) => {
      if (endpoint !== 0 || !this.control) return;
      const c = this.control;
      if (c.in && !c.statusSent) {
        c.data.push(...buffer);
        if (c.data.length >= c.length || buffer.length < 64) {
          // Data stage done: the status stage is a zero-length OUT.
          c.statusSent = true;
          this.statusOut();
        }
        return;
      }
      if (!c.in && buffer.length === 0) {
        // The device acknowledged a control OUT transfer.
        this.control = null;
        c.then(Uint8Array.from(c.data));
      }
    };
    usb.onEndpointRead = (endpoint, length) => {
      this.armed.set(endpoint, length);
      if (endpoint === 0) this.statusOut();
      else this.pump();
    };
    // The moment a packet is in the device's buffer (BUFF_STATUS raised).
    const finishRead = usb.finishRead.bind(usb);
    usb.finishRead = (endpoint, buffer) => {
      finishRead(endpoint, buffer);
      if (endpoint === this.outEndpoint && buffer.length && this.onPacketIn) {
        this.onPacketIn(buffer, chip.clock.nanos);
      }
    };
  }

  statusOut() {
    const c = this.control;
    if (!c || !c.in || !c.statusSent || !this.armed.has(0)) return;
    this.armed.delete(0);
    this.control = null;
    this.usb.endpointReadDone(0, new Uint8Array(0));
    c.then(Uint8Array.from(c.data.slice(0, c.length)));
  }

  findMidiEndpoints(d) {
    let midi = false;
    for (let i = 0; i + 1 < d.length && d[i] >= 2; i += d[i]) {
      const type = d[i + 1];
      if (type === INTERFACE) midi = d[i + 5] === 1 && d[i + 6] === 3;
      if (type === ENDPOINT && midi && (d[i + 3] & 3) === 2) {
        if (d[i + 2] & 0x80) this.inEndpoint = d[i + 2] & 0x0f;
        else this.outEndpoint = d[i + 2] & 0x0f;
      }
    }
    if (this.outEndpoint < 0) throw new Error('no USB-MIDI streaming interface with a bulk OUT endpoint');
  }

  /** Queues one packet of USB-MIDI events (4 bytes each). */
  send(packet) {
    if (packet.length % 4 || packet.length === 0 || packet.length > 64) {
      throw new Error(`a USB-MIDI packet is 4..64 bytes, 4 a event: ${packet.length}`);
    }
    this.queue.push(Uint8Array.from(packet));
    this.pump();
  }

  pump() {
    if (!this.configured || !this.queue.length) return;
    const length = this.armed.get(this.outEndpoint);
    if (length === undefined) return;
    this.armed.delete(this.outEndpoint);
    const packet = this.queue.shift();
    if (packet.length > length) throw new Error(`packet of ${packet.length} bytes for a ${length}-byte buffer`);
    this.usb.endpointReadDone(this.outEndpoint, packet);
  }
}

/** The USB-MIDI event packet (cable 0) of one MIDI message's bytes. */
function midiEvent(bytes) {
  const status = bytes[0];
  let cin;
  if (status >= 0xf8) cin = 0xf;
  else if (status >= 0x80 && status < 0xf0) cin = status >> 4;
  else throw new Error(`no event packet here for ${bytes}`);
  return [cin, bytes[0], bytes[1] ?? 0, bytes[2] ?? 0];
}

module.exports = { UsbMidiHost, midiEvent };
