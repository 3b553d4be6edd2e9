//! Whole messages out of a live byte stream, for passing it through (`--thru`) and for knowing
//! when the stream is between messages (where a robot's configuration may be swapped).

use orch_io::Channels;

/// Splits a live byte stream into whole messages for `--thru` and says when the stream is
/// between messages (where the robot's configuration may be swapped).
#[derive(Debug, Default)]
pub struct Framer {
    status: u8,
    data: [u8; 2],
    have: usize,
    sysex: Vec<u8>,
    in_sysex: bool,
    /// The status of the last message sent on (running status, re-encoded).
    sent_status: u8,
}

/// The longest SysEx kept whole for `--thru`; a longer one goes on in pieces.
const SYSEX_CHUNK: usize = 4096;

impl Framer {
    /// The data bytes a message with `status` takes.
    fn need(status: u8) -> usize {
        match status {
            0xC0..=0xDF | 0xF1 | 0xF3 => 1,
            0x80..=0xEF | 0xF2 => 2,
            _ => 0,
        }
    }

    /// The channel status in force (running status), if any.
    pub fn running_status(&self) -> Option<u8> {
        (0x80..=0xEF).contains(&self.status).then_some(self.status)
    }

    /// Forgets a message half received (the input's device went away); the running status
    /// last sent on stays, as the receiver keeps it.
    pub fn forget(&mut self) {
        self.status = 0;
        self.have = 0;
        self.in_sysex = false;
        self.sysex.clear();
    }

    /// Whether no message is half received.
    pub fn idle(&self) -> bool {
        self.have == 0 && !self.in_sysex
    }

    /// Takes one byte; hands every message it completes that `channels` passes to `emit`,
    /// with running status (a channel message whose status is the last one sent goes without
    /// it).
    pub fn push(&mut self, byte: u8, channels: Channels, emit: &mut impl FnMut(&[u8])) {
        match byte {
            0xF8..=0xFF => emit(&[byte]),
            0xF0 => {
                self.status = 0;
                self.have = 0;
                self.in_sysex = true;
                self.sysex.clear();
                self.sysex.push(byte);
                self.sent_status = 0;
            }
            0xF7 if self.in_sysex => {
                self.sysex.push(byte);
                emit(&self.sysex);
                self.sysex.clear();
                self.in_sysex = false;
            }
            0x80..=0xF7 => {
                if self.in_sysex {
                    // A status byte ends a SysEx (MIDI 1.0): what came goes on, closed.
                    self.sysex.push(0xF7);
                    emit(&self.sysex);
                    self.sysex.clear();
                    self.in_sysex = false;
                }
                self.have = 0;
                if byte >= 0xF0 {
                    self.status = 0;
                    self.sent_status = 0;
                    if Self::need(byte) == 0 {
                        emit(&[byte]);
                    } else {
                        self.status = byte;
                    }
                } else {
                    self.status = byte;
                }
            }
            _ if self.in_sysex => {
                self.sysex.push(byte);
                if self.sysex.len() >= SYSEX_CHUNK {
                    emit(&self.sysex);
                    self.sysex.clear();
                }
            }
            _ => {
                let need = Self::need(self.status);
                if need == 0 {
                    return; // no status in force: dropped, as the interpreter drops it
                }
                self.data[self.have] = byte;
                self.have += 1;
                if self.have == need {
                    self.have = 0;
                    let status = self.status;
                    let data = self.data;
                    if status >= 0xF0 {
                        // System common: no running status after it.
                        self.status = 0;
                        let mut m = vec![status];
                        m.extend_from_slice(&data[..need]);
                        emit(&m);
                    } else if channels.passes(&[status]) {
                        if status == self.sent_status {
                            emit(&data[..need]);
                        } else {
                            self.sent_status = status;
                            let mut m = vec![status];
                            m.extend_from_slice(&data[..need]);
                            emit(&m);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use orch_io::OutSpec;

    fn frame(bytes: &[u8], channels: Channels) -> Vec<Vec<u8>> {
        let mut f = Framer::default();
        let mut out = Vec::new();
        for &b in bytes {
            f.push(b, channels, &mut |m| out.push(m.to_vec()));
        }
        out
    }

    #[test]
    fn framer_keeps_running_status_and_filters_channels() {
        let all = frame(
            &[0x90, 60, 100, 62, 100, 0xF8, 64, 0, 0x91, 1, 2],
            Channels::ALL,
        );
        assert_eq!(
            all,
            vec![
                vec![0x90, 60, 100],
                vec![62, 100],
                vec![0xF8],
                vec![64, 0],
                vec![0x91, 1, 2]
            ]
        );
        let ch2 = OutSpec::parse("udp:127.0.0.1:9:ch=2").unwrap().channels;
        let some = frame(&[0x90, 60, 100, 0x91, 1, 2, 3, 4, 0x90, 5, 6], ch2);
        assert_eq!(some, vec![vec![0x91, 1, 2], vec![3, 4]]);
        // Stray data bytes go nowhere; a SysEx goes on whole.
        let sx = frame(&[7, 8, 0xF0, 1, 2, 0xF7, 0xC0, 5], Channels::ALL);
        assert_eq!(sx, vec![vec![0xF0, 1, 2, 0xF7], vec![0xC0, 5]]);
    }
}
