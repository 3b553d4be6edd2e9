'use strict';
// The RP2040's UART (an ARM PL011) as the datasheet has it, over rp2040js's simpler model
// (whose transmit interrupt is always raised and whose receive interrupt comes with every
// byte): embassy-rp's buffered UART relies on the real behaviour, and the receive timeout is
// part of the DIN latency.
//
// - Receive: a 32-byte FIFO (FEN) or a 1-byte holding register. RXRIS when the FIFO holds at
//   least the trigger level (UARTIFLS RXIFLSEL: 1/8, 1/4, 1/2, 3/4, 7/8 of 32), cleared by
//   reading below it; RTRIS when the FIFO is not empty and no character has come for 32 bit
//   periods, cleared by reading it empty or by UARTICR. A byte into a full FIFO is lost (OE).
// - Transmit: a 32-byte FIFO shifted out one character every 10 bit periods; each leaves at
//   the end of its stop bit (onByte). TXRIS when the FIFO level drops through the trigger
//   level (TXIFLSEL), or the holding register empties when the FIFO is off; UARTICR clears it.
//   Flags TXFF, TXFE, BUSY, RXFF, RXFE as the level says. UARTDMACR reads back (reset 0).

const DR = 0x00;
const FR = 0x18;
const LCR_H = 0x2c;
const IFLS = 0x34;
const IMSC = 0x38;
const RIS = 0x3c;
const MIS = 0x40;
const ICR = 0x44;
const DMACR = 0x48;

const FEN = 1 << 4;
const RXI = 1 << 4;
const TXI = 1 << 5;
const RTI = 1 << 6;
const OEI = 1 << 10;
const LEVELS = [4, 8, 16, 24, 28];

function pl011(uart) {
  const chip = uart.rp2040;
  const clock = chip.clock;
  const rx = [];
  const tx = [];
  let ifls = 0x12; // reset: both 1/2
  let ris = 0;
  let shifting = false;
  let overruns = 0;
  let dmacr = 0; // rp2040js reads it as all ones: DMA on, and embassy-rp's handler then returns

  const fifo = () => !!(uart.lineCtrlRegister & FEN);
  const depth = () => (fifo() ? 32 : 1);
  const rxTrigger = () => (fifo() ? LEVELS[(ifls >> 3) & 7] ?? 28 : 1);
  const txTrigger = () => (fifo() ? LEVELS[ifls & 7] ?? 4 : 0);
  const bitNs = () => 1e9 / uart.baudRate;

  const update = () => chip.setInterrupt(uart.irq, !!(ris & uart.interruptMask));
  const timeout = clock.createAlarm(() => {
    if (rx.length) {
      ris |= RTI;
      update();
    }
  });
  const shifter = clock.createAlarm(() => {
    const before = tx.length;
    const byte = tx.shift();
    if (uart.onByte) uart.onByte(byte);
    const level = tx.length;
    const trigger = txTrigger();
    if ((fifo() && before > trigger && level <= trigger) || (!fifo() && level === 0)) {
      ris |= TXI;
      update();
    }
    shifting = level > 0;
    if (shifting) shifter.schedule(10 * bitNs());
  });

  uart.feedByte = (value) => {
    if (rx.length >= depth()) {
      overruns++;
      ris |= OEI;
    } else {
      rx.push(value & 0xff);
    }
    if (rx.length >= rxTrigger()) ris |= RXI;
    timeout.schedule(32 * bitNs());
    update();
  };
  Object.defineProperty(uart, 'overruns', { get: () => overruns });

  const read = uart.readUint32.bind(uart);
  uart.readUint32 = (offset) => {
    switch (offset) {
      case DR: {
        const value = rx.length ? rx.shift() : 0;
        if (rx.length < rxTrigger()) ris &= ~RXI;
        if (!rx.length) {
          ris &= ~RTI;
          timeout.cancel();
        }
        update();
        return value;
      }
      case FR:
        return (
          (tx.length === 0 ? 1 << 7 : 0) | // TXFE
          (rx.length >= depth() ? 1 << 6 : 0) | // RXFF
          (tx.length >= depth() ? 1 << 5 : 0) | // TXFF
          (rx.length === 0 ? 1 << 4 : 0) | // RXFE
          (shifting ? 1 << 3 : 0) // BUSY
        );
      case IFLS:
        return ifls;
      case DMACR:
        return dmacr;
      case RIS:
        return ris;
      case MIS:
        return ris & uart.interruptMask;
      default:
        return read(offset);
    }
  };
  const write = uart.writeUint32.bind(uart);
  uart.writeUint32 = (offset, value) => {
    switch (offset) {
      case DR:
        if (tx.length < depth()) tx.push(value & 0xff);
        if (!shifting) {
          shifting = true;
          shifter.schedule(10 * bitNs());
        }
        return;
      case IFLS:
        ifls = value & 0x3f;
        return;
      case DMACR:
        dmacr = value & 7;
        return;
      case IMSC:
        uart.interruptMask = value & 0x7ff;
        update();
        return;
      case ICR:
        ris &= ~(uart.rawWriteValue & 0x7ff & ~RXI); // RXRIS follows the level
        update();
        return;
      case LCR_H:
        uart.lineCtrlRegister = value;
        return;
      default:
        write(offset, value);
    }
  };
  // rp2040js calls this from its own register writes (UARTCR, …): keep our interrupt state.
  uart.checkInterrupts = update;
}

module.exports = { pl011 };
