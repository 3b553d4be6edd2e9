//! The robot side: where the planned bytes go.
//!
//! A performance drives one virtual robot (a [`LocalRobot`](crate::LocalRobot) on
//! [`SimBoards`](crate::SimBoards)), which gives the view and the report. With a
//! [`MidiOut`] the bytes also go out as MIDI to a robot that interprets MIDI itself (the
//! thesis's ATmega16 board); the virtual robot is then its copy, fed each byte when it
//! arrives at the far end of the line ([`Link::Din`]).

/// How bytes reach the robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Link {
    /// At once: the robot is on this host.
    Direct,
    /// Over a DIN MIDI line: 31250 baud, 10 bits a byte, one byte after another, with
    /// running status. A message arrives when its last byte has; a chord queues.
    Din,
}

impl Link {
    /// One DIN byte: 1 start + 8 data + 1 stop bit at 31250 baud, 320 µs.
    pub const DIN_BYTE_US: u64 = 320;

    /// How early to send a note message so that it arrives on time, if the line is free: two
    /// bytes under running status on a DIN line, nothing for a direct link.
    pub fn note_lead_us(self) -> u64 {
        match self {
            Link::Direct => 0,
            Link::Din => 2 * Self::DIN_BYTE_US,
        }
    }
}

/// A MIDI byte output: a serial line, a raw MIDI device, a socket, or a recording.
pub trait MidiOut {
    /// What can go wrong while sending.
    type Error: std::error::Error + Send + Sync + 'static;

    /// Sends one message's bytes (with running status where it applies) at `t_us` on the
    /// performer's clock.
    fn send(&mut self, t_us: u64, bytes: &[u8]) -> Result<(), Self::Error>;

    /// When the output must next be called with [`poll`](Self::poll), µs on the performer's
    /// clock, if ever: a robot driven from this host has guard timers (a delayed re-strike,
    /// the shortest press) that fire between messages. A byte sink has none.
    fn next_deadline(&self) -> Option<u64> {
        None
    }

    /// Runs what is due at `t_us` (see [`next_deadline`](Self::next_deadline)).
    fn poll(&mut self, _t_us: u64) -> Result<(), Self::Error> {
        Ok(())
    }

    /// The performance ends at `t_us`, played out or stopped, after the All Notes Off on every
    /// channel: let go of everything that is still held.
    fn finish(&mut self, _t_us: u64) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// A [`MidiOut`] that keeps what it was given: for tests and for `--out` dry runs.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MidiRecording {
    /// Every send: its time and bytes.
    pub sent: Vec<(u64, Vec<u8>)>,
}

impl MidiOut for MidiRecording {
    type Error = std::convert::Infallible;
    fn send(&mut self, t_us: u64, bytes: &[u8]) -> Result<(), Self::Error> {
        self.sent.push((t_us, bytes.to_vec()));
        Ok(())
    }
}

/// Running status on the sending side: leaves out a channel status byte equal to the last
/// one sent; system common messages cancel it, real-time bytes leave it alone.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RunningStatus {
    status: u8,
}

impl RunningStatus {
    /// The bytes to send for `message` (a whole message, status first).
    pub fn compress<'a>(&mut self, message: &'a [u8]) -> &'a [u8] {
        let Some(&first) = message.first() else {
            return message;
        };
        match first {
            0x80..=0xEF => {
                let skip = first == self.status;
                self.status = first;
                if skip {
                    &message[1..]
                } else {
                    message
                }
            }
            0xF0..=0xF7 => {
                self.status = 0;
                message
            }
            _ => message,
        }
    }
}

/// A DIN line's timing: when each byte sent arrives at the far end.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DinWire {
    free_at: u64,
}

impl DinWire {
    /// Queues `len` bytes sent at `t_us`; returns when each arrives, in order.
    pub fn arrivals(&mut self, t_us: u64, len: usize) -> impl Iterator<Item = u64> + '_ {
        (0..len).map(move |_| {
            let start = self.free_at.max(t_us);
            self.free_at = start + Link::DIN_BYTE_US;
            self.free_at
        })
    }

    /// When the line is free again.
    pub fn free_at(&self) -> u64 {
        self.free_at
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ten_note_chord_on_din_spreads_over_six_ms() {
        let mut wire = DinWire::default();
        let mut rs = RunningStatus::default();
        let mut last = 0;
        for n in 0..10u8 {
            let m = [0x90, 60 + n, 100];
            let bytes = rs.compress(&m);
            last = wire.arrivals(0, bytes.len()).last().unwrap();
        }
        // 3 bytes, then 9 × 2 under running status: 21 bytes of 320 µs.
        assert_eq!(last, 21 * 320);
    }

    #[test]
    fn running_status_is_cancelled_by_system_common_only() {
        let mut rs = RunningStatus::default();
        assert_eq!(rs.compress(&[0x90, 60, 1]).len(), 3);
        assert_eq!(rs.compress(&[0xFE]).len(), 1);
        assert_eq!(rs.compress(&[0x90, 61, 1]).len(), 2);
        assert_eq!(rs.compress(&[0xF3, 1]).len(), 2);
        assert_eq!(rs.compress(&[0x90, 62, 1]).len(), 3);
    }
}
