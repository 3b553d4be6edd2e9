'use strict';
// The RP2040 USB controller's OUT buffers as the datasheet has them, over rp2040js's: an OUT
// buffer the firmware makes AVAILABLE stays AVAILABLE until a packet from the host has landed
// in it; then the controller clears AVAILABLE, sets FULL and the length. (rp2040js clears
// AVAILABLE at once, and embassy-rp, which waits for it to clear, would then take the empty
// buffer for a 64-byte packet, again and again.)
const AVAILABLE = 1 << 10;
const EP0_OUT_BUFFER_CONTROL = 0x84;
const EP15_OUT_BUFFER_CONTROL = 0xfc;

function usbOutBuffers(usb) {
  const dpram = usb.rp2040.usbDPRAMView;
  const updated = usb.DPRAMUpdated.bind(usb);
  usb.DPRAMUpdated = (offset, value) => {
    updated(offset, value);
    const out =
      offset >= EP0_OUT_BUFFER_CONTROL && offset <= EP15_OUT_BUFFER_CONTROL && (offset & 7) === 4;
    if (!usb.hostMode && out && value & AVAILABLE) {
      dpram.setUint32(offset, dpram.getUint32(offset, true) | AVAILABLE, true);
    }
  };
  const finishRead = usb.finishRead.bind(usb);
  usb.finishRead = (endpoint, buffer) => {
    const at = EP0_OUT_BUFFER_CONTROL + endpoint * 8;
    dpram.setUint32(at, dpram.getUint32(at, true) & ~AVAILABLE, true);
    finishRead(endpoint, buffer);
  };
}

module.exports = { usbOutBuffers };
