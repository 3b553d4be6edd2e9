//! The driver's one error type.

use core::fmt;
use embedded_hal::i2c::ErrorKind;

/// What can go wrong driving the boards. The driver never retries: the caller decides,
/// for example with [`Error::is_nack`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Error<E> {
    /// The I2C bus reported an error (the bus's own error, unchanged).
    I2c(E),
    /// A board index at or past the number of boards in the set.
    UnknownBoard(u8),
    /// The write names a board whose address is not the one the set was built with:
    /// the layout and the set disagree, and nothing was written.
    AddressMismatch {
        /// The board index the write named.
        index: u8,
        /// The address the set holds for that index.
        expected: u8,
        /// The address the write named.
        requested: u8,
    },
    /// A PCA9685 channel past 15; nothing was written.
    UnknownChannel(u8),
    /// A PCA9685 duty past 4095; nothing was written.
    DutyOutOfRange {
        /// The channel the duty was for.
        channel: u8,
        /// The duty asked for.
        duty: u16,
    },
    /// A PWM frequency the PCA9685 cannot make from its 25 MHz oscillator (it makes
    /// 24..=1526 Hz); nothing was written.
    Frequency {
        /// The frequency asked for, in Hz.
        hz: u32,
    },
}

impl<E> Error<E> {
    /// The bus error, if this is one.
    pub fn i2c(&self) -> Option<&E> {
        match self {
            Error::I2c(e) => Some(e),
            _ => None,
        }
    }
}

impl<E: embedded_hal::i2c::Error> Error<E> {
    /// The embedded-hal kind of a bus error; `None` for the driver's own errors.
    pub fn i2c_kind(&self) -> Option<ErrorKind> {
        self.i2c().map(embedded_hal::i2c::Error::kind)
    }

    /// Whether the device (or the address or a data byte) was not acknowledged: typically a
    /// board that is unpowered, missing or at another address. Often worth one retry.
    pub fn is_nack(&self) -> bool {
        matches!(self.i2c_kind(), Some(ErrorKind::NoAcknowledge(_)))
    }

    /// Whether the bus was lost to another controller (arbitration loss): a retry is safe.
    pub fn is_arbitration_loss(&self) -> bool {
        matches!(self.i2c_kind(), Some(ErrorKind::ArbitrationLoss))
    }
}

impl<E> From<E> for Error<E> {
    fn from(e: E) -> Self {
        Error::I2c(e)
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::I2c(e) => write!(f, "I2C bus error: {e:?}"),
            Error::UnknownBoard(i) => write!(f, "no finger board with index {i}"),
            Error::AddressMismatch {
                index,
                expected,
                requested,
            } => write!(
                f,
                "board {index} is at address {expected:#04x}, but the write named {requested:#04x}"
            ),
            Error::UnknownChannel(c) => write!(f, "no PWM channel {c} (a PCA9685 has 0..=15)"),
            Error::DutyOutOfRange { channel, duty } => write!(
                f,
                "duty {duty} for channel {channel} is past the largest, 4095 (100 %)"
            ),
            Error::Frequency { hz } => write!(
                f,
                "a PCA9685 cannot make {hz} Hz (it makes 24..=1526 Hz with its 25 MHz oscillator)"
            ),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal::i2c::NoAcknowledgeSource;

    #[test]
    fn nack_of_any_source_is_a_nack() {
        for src in [
            NoAcknowledgeSource::Address,
            NoAcknowledgeSource::Data,
            NoAcknowledgeSource::Unknown,
        ] {
            let e: Error<ErrorKind> = Error::I2c(ErrorKind::NoAcknowledge(src));
            assert!(e.is_nack());
            assert!(!e.is_arbitration_loss());
        }
    }

    #[test]
    fn own_errors_have_no_bus_kind() {
        let e: Error<ErrorKind> = Error::UnknownBoard(9);
        assert_eq!(e.i2c_kind(), None);
        assert!(!e.is_nack());
    }
}
