'use strict';
// The RP2040's I2C controller (Synopsys DW_apb_i2c) as the datasheet has it, where rp2040js
// differs in what embassy-rp uses: IC_INTR_MASK is writable (rp2040js ignores writes to it,
// so no I2C interrupt ever fires and an async transfer never completes), and TX_EMPTY follows
// the transmit FIFO's level (set at or below IC_TX_TL, cleared above it).
const IC_DATA_CMD = 0x10;
const IC_INTR_MASK = 0x30;
const IC_TX_TL = 0x3c;
const TX_EMPTY = 1 << 4;

function dwI2c(i2c) {
  const write = i2c.writeUint32.bind(i2c);
  const txLevel = () => {
    if (i2c.txFIFO.itemCount <= i2c.txThreshold) i2c.setInterrupts(TX_EMPTY);
    else i2c.clearInterrupts(TX_EMPTY);
  };
  i2c.writeUint32 = (offset, value) => {
    if (offset === IC_INTR_MASK) {
      i2c.intEnable = value & 0x1fff;
      i2c.checkInterrupts();
      return;
    }
    write(offset, value);
    if (offset === IC_DATA_CMD || offset === IC_TX_TL) txLevel();
  };
  // The FIFO drains as the bus takes each command.
  const next = i2c.nextCommand.bind(i2c);
  i2c.nextCommand = () => {
    next();
    txLevel();
  };
}

module.exports = { dwI2c };
