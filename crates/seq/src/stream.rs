//! Timed messages turned into the bytes a sequencer sends down a MIDI line.
//!
//! [`Wire`] takes `(time_us, message)` pairs (from [`Song::messages`](crate::Song::messages)
//! or [`Schedule::messages`](crate::Schedule::messages)) and yields what goes on the wire:
//! with [`RunningStatus::On`] a channel message whose status equals the last one sent goes
//! without its status byte, as a sequencer would send it (a 3-byte note takes 640 µs instead
//! of 960 µs on a DIN line). The rules are the MIDI 1.0 specification's: channel messages
//! set running status; System Exclusive and System Common messages (0xF0–0xF7) cancel it;
//! System Real-Time bytes (0xF8–0xFF) leave it alone. The output depends only on the input:
//! the same song gives the same bytes every time.
//!
//! Every byte of a message carries the message's time; pacing the bytes at 320 µs each is
//! the line's job.

/// Whether to leave out repeated status bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum RunningStatus {
    /// Every message is sent whole.
    #[default]
    Off,
    /// A channel message with the same status as the previous one is sent without it.
    On,
}

/// The wire form of timed messages: `(time_us, bytes to send)`.
#[derive(Clone, Debug)]
pub struct Wire<I> {
    inner: I,
    mode: RunningStatus,
    status: Option<u8>,
}

/// Serialises `messages` for the wire.
pub fn wire<'a, I>(messages: I, mode: RunningStatus) -> Wire<I::IntoIter>
where
    I: IntoIterator<Item = (u64, &'a [u8])>,
{
    Wire {
        inner: messages.into_iter(),
        mode,
        status: None,
    }
}

impl<'a, I> Wire<I>
where
    I: Iterator<Item = (u64, &'a [u8])>,
{
    /// One byte at a time: `(time_us, byte)`.
    pub fn bytes(self) -> impl Iterator<Item = (u64, u8)> + 'a
    where
        I: 'a,
    {
        self.flat_map(|(t, m)| m.iter().map(move |&b| (t, b)))
    }
}

impl<'a, I> Iterator for Wire<I>
where
    I: Iterator<Item = (u64, &'a [u8])>,
{
    type Item = (u64, &'a [u8]);

    fn next(&mut self) -> Option<Self::Item> {
        let (t, m) = self.inner.next()?;
        let Some(&status) = m.first() else {
            return Some((t, m));
        };
        match status {
            0x80..=0xEF => {
                if self.mode == RunningStatus::On && self.status == Some(status) {
                    return Some((t, &m[1..]));
                }
                self.status = Some(status);
            }
            0xF0..=0xF7 => self.status = None,
            _ => {}
        }
        Some((t, m))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn running_status_drops_repeated_status_only() {
        let msgs: Vec<(u64, &[u8])> = vec![
            (0, &[0x90, 60, 100]),
            (1, &[0x90, 62, 100]),
            (2, &[0xF8]),
            (3, &[0x90, 60, 0]),
            (4, &[0xF0, 1, 0xF7]),
            (5, &[0x90, 62, 0]),
            (6, &[0x80, 62, 0]),
        ];
        let out: Vec<(u64, u8)> = wire(msgs.clone(), RunningStatus::On).bytes().collect();
        let bytes: Vec<u8> = out.iter().map(|&(_, b)| b).collect();
        assert_eq!(
            bytes,
            [0x90, 60, 100, 62, 100, 0xF8, 60, 0, 0xF0, 1, 0xF7, 0x90, 62, 0, 0x80, 62, 0]
        );
        let plain: usize = wire(msgs, RunningStatus::Off).map(|(_, m)| m.len()).sum();
        assert_eq!(plain, 19);
    }
}
