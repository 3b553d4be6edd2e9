//! `orch play --out rtpmidi:HOST:PORT`: orch as an AppleMIDI session's initiator. It invites
//! the peer on its control port PORT and its data port PORT + 1 (IN, waiting for OK on each),
//! synchronises clocks (CK0, CK1, CK2), sends the performance as RTP-MIDI with a recovery
//! journal (chapters N and C: a lost Note-Off or pedal release is repaired by the next
//! packet), trims the journal on the receiver's feedback (RS), and ends with BY.

use std::io;
use std::net::{SocketAddr, ToSocketAddrs, UdpSocket};
use std::time::{Duration, Instant};

use orch_perform::MidiOut;

use super::control::{self, Control, Exchange, VERSION};
use super::sender::Sender;
use super::{clock, listen};
use crate::midi::{all_notes_off, PortStats};
use crate::OutError;

/// How long the peer has to answer an invitation or a clock sync.
pub const ANSWER_WITHIN: Duration = Duration::from_secs(5);

/// How often an unanswered invitation is sent again.
pub const ASK_AGAIN: Duration = Duration::from_millis(250);

/// The longest the goodbye waits for the receiver's feedback on the last packet.
pub const LAST_WORD: Duration = Duration::from_millis(100);

/// The name orch gives itself in a session.
pub const NAME: &str = "orch";

/// A random 32-bit number (SSRCs, tokens, the first sequence number): the standard
/// library's randomly keyed hasher over the time.
pub(crate) fn random_u32() -> u32 {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u128(
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos()),
    );
    h.finish() as u32
}

/// An RTP-MIDI session orch began, sending the performance.
pub struct RtpMidiOut {
    name: String,
    ctl: UdpSocket,
    data: UdpSocket,
    peer_ctl: SocketAddr,
    peer_data: SocketAddr,
    peer_name: String,
    ssrc: u32,
    token: u32,
    origin: Instant,
    sender: Sender,
    /// The running status of the stream the performer sends.
    status: u8,
    /// The peer said goodbye: nothing more is sent.
    closed: bool,
    finished: bool,
    stats: PortStats,
}

impl std::fmt::Debug for RtpMidiOut {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RtpMidiOut")
            .field("name", &self.name)
            .field("peer", &self.peer_name)
            .field("stats", &self.stats)
            .finish()
    }
}

fn open_err(target: &str, e: io::Error) -> OutError {
    OutError::Open {
        device: format!("rtpmidi:{target}"),
        source: e,
    }
}

impl RtpMidiOut {
    /// Invites the peer at `target` (`HOST:PORT`, its control port) and synchronises clocks:
    /// an error if it does not answer within [`ANSWER_WITHIN`] or refuses.
    pub fn open(target: &str) -> Result<Self, OutError> {
        let err = |e| open_err(target, e);
        let to = target
            .to_socket_addrs()
            .map_err(err)?
            .next()
            .ok_or_else(|| err(io::Error::new(io::ErrorKind::NotFound, "no address")))?;
        let local: SocketAddr = if to.is_ipv4() {
            ([0, 0, 0, 0], 0).into()
        } else {
            (std::net::Ipv6Addr::UNSPECIFIED, 0).into()
        };
        let (ctl, data) = listen::bind_pair(local).map_err(err)?;
        let mut peer_data = to;
        peer_data.set_port(to.port().wrapping_add(1));
        let (ssrc, token) = (random_u32(), random_u32());
        let mut out = RtpMidiOut {
            name: target.to_string(),
            ctl,
            data,
            peer_ctl: to,
            peer_data,
            peer_name: String::new(),
            ssrc,
            token,
            origin: Instant::now(),
            sender: Sender::new(ssrc, random_u32() as u16),
            status: 0,
            closed: false,
            finished: false,
            stats: PortStats::default(),
        };
        out.peer_name = out.invite(true).map_err(err)?.name;
        out.invite(false).map_err(err)?;
        out.sync().map_err(err)?;
        for s in [&out.ctl, &out.data] {
            s.set_nonblocking(true).map_err(err)?;
        }
        tracing::debug!(peer = %out.peer_name, device = target, "rtpmidi session open");
        Ok(out)
    }

    /// The peer's name, as its OK gave it.
    pub fn peer_name(&self) -> &str {
        &self.peer_name
    }

    /// What happened so far.
    pub fn stats(&self) -> PortStats {
        self.stats
    }

    fn exchange(&self) -> Exchange {
        Exchange {
            version: VERSION,
            token: self.token,
            ssrc: self.ssrc,
            name: NAME.to_string(),
        }
    }

    /// Sends IN on the control or the data port until OK (or NO) comes back.
    fn invite(&self, on_control: bool) -> io::Result<Exchange> {
        let (socket, to) = if on_control {
            (&self.ctl, self.peer_ctl)
        } else {
            (&self.data, self.peer_data)
        };
        let invitation = control::write(&Control::Invite(self.exchange()));
        let deadline = Instant::now() + ANSWER_WITHIN;
        while Instant::now() < deadline {
            socket.send_to(&invitation, to)?;
            let until = Instant::now() + ASK_AGAIN;
            while let Some(c) = answer(socket, until)? {
                match c {
                    Control::Accept(e) if e.token == self.token => return Ok(e),
                    Control::Refuse(e) if e.token == self.token => {
                        return Err(io::Error::new(
                            io::ErrorKind::ConnectionRefused,
                            "the peer refused the invitation (NO)",
                        ))
                    }
                    _ => {}
                }
            }
        }
        Err(io::Error::new(
            io::ErrorKind::TimedOut,
            format!(
                "no answer to the invitation at {to} within {} s",
                ANSWER_WITHIN.as_secs()
            ),
        ))
    }

    /// Clock sync: CK0 sent, CK1 awaited, CK2 sent.
    fn sync(&self) -> io::Result<()> {
        let deadline = Instant::now() + ANSWER_WITHIN;
        while Instant::now() < deadline {
            let t1 = clock(self.origin);
            let ck0 = Control::Sync {
                ssrc: self.ssrc,
                count: 0,
                stamps: [t1, 0, 0],
            };
            self.data.send_to(&control::write(&ck0), self.peer_data)?;
            let until = Instant::now() + ASK_AGAIN;
            while let Some(c) = answer(&self.data, until)? {
                if let Control::Sync {
                    count: 1, stamps, ..
                } = c
                {
                    if stamps[0] == t1 {
                        let ck2 = Control::Sync {
                            ssrc: self.ssrc,
                            count: 2,
                            stamps: [t1, stamps[1], clock(self.origin)],
                        };
                        self.data.send_to(&control::write(&ck2), self.peer_data)?;
                        return Ok(());
                    }
                }
            }
        }
        Err(io::Error::new(
            io::ErrorKind::TimedOut,
            "no answer to the clock sync (CK0)",
        ))
    }

    /// Takes what the peer sent since: its feedback trims the journal, its clock sync is
    /// answered, its goodbye ends the session.
    fn poll_peer(&mut self) {
        let mut buf = [0u8; 512];
        for on_data in [false, true] {
            let socket = if on_data { &self.data } else { &self.ctl };
            while let Ok((n, from)) = socket.recv_from(&mut buf) {
                match control::parse(&buf[..n]) {
                    Ok(Control::Feedback { seq, .. }) => self.sender.feedback(seq),
                    Ok(Control::Sync {
                        count: 0, stamps, ..
                    }) if on_data => {
                        let ck1 = Control::Sync {
                            ssrc: self.ssrc,
                            count: 1,
                            stamps: [stamps[0], clock(self.origin), 0],
                        };
                        let _ = socket.send_to(&control::write(&ck1), from);
                    }
                    Ok(Control::Bye(_)) => {
                        if !self.closed {
                            tracing::warn!(device = %self.name, "the rtpmidi peer ended the session (BY); playing on without it");
                        }
                        self.closed = true;
                    }
                    _ => {}
                }
            }
        }
    }

    /// One packet of whole messages.
    fn send_messages(&mut self, messages: &[Vec<u8>]) {
        if messages.is_empty() {
            return;
        }
        if self.closed {
            self.stats.dropped_bytes += messages.iter().map(|m| m.len() as u64).sum::<u64>();
            return;
        }
        let list: Vec<(u32, &[u8])> = messages.iter().map(|m| (0, m.as_slice())).collect();
        let packet = self.sender.packet(clock(self.origin) as u32, &list);
        match self.data.send_to(&packet, self.peer_data) {
            Ok(_) => {
                self.stats.writes += 1;
                self.stats.bytes += messages.iter().map(|m| m.len() as u64).sum::<u64>();
            }
            Err(e) => {
                self.stats.lost += 1;
                tracing::debug!(error = %e, "rtpmidi: a packet could not be sent (its journal follows in the next)");
            }
        }
    }

    /// Waits up to [`LAST_WORD`] for the receiver's feedback on the last packet sent (a
    /// peer that sends none gets the whole wait), so that the goodbye does not overtake it:
    /// the two go to different ports, and a receiver that reads the goodbye first drops the
    /// packet.
    fn settle(&mut self) {
        let deadline = Instant::now() + LAST_WORD;
        let last = self.sender.next_seq().wrapping_sub(1);
        while Instant::now() < deadline && self.sender.checkpoint() != last.wrapping_add(1) {
            std::thread::sleep(Duration::from_millis(2));
            self.poll_peer();
        }
    }

    fn bye(&mut self) {
        if !self.closed {
            self.settle();
            let _ = self.ctl.send_to(
                &control::write(&Control::Bye(self.exchange())),
                self.peer_ctl,
            );
            self.closed = true;
        }
    }
}

/// The next AppleMIDI command on `socket` before `until`; `None` when the time is up.
fn answer(socket: &UdpSocket, until: Instant) -> io::Result<Option<Control>> {
    let mut buf = [0u8; 512];
    loop {
        let left = until.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Ok(None);
        }
        socket.set_read_timeout(Some(left))?;
        match socket.recv_from(&mut buf) {
            Ok((n, _)) => {
                if let Ok(c) = control::parse(&buf[..n]) {
                    return Ok(Some(c));
                }
            }
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock
                        | io::ErrorKind::TimedOut
                        | io::ErrorKind::Interrupted
                ) => {}
            // Nobody at the port yet (an ICMP port unreachable): ask again later.
            Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => {
                std::thread::sleep(Duration::from_millis(20))
            }
            Err(e) => return Err(e),
        }
    }
}

/// Splits a piece of the performer's stream into whole messages with their status bytes,
/// under (and updating) the running status `status`.
pub fn whole_messages(status: &mut u8, bytes: &[u8]) -> Vec<Vec<u8>> {
    let mut out: Vec<Vec<u8>> = Vec::new();
    let mut cur: Vec<u8> = Vec::new();
    let need = |s: u8| match s {
        0xC0..=0xDF | 0xF1 | 0xF3 => 2,
        0x80..=0xEF | 0xF2 => 3,
        _ => 1,
    };
    for &b in bytes {
        match b {
            0xF8..=0xFF => out.push(vec![b]),
            0xF7 if cur.first() == Some(&0xF0) => {
                cur.push(b);
                out.push(std::mem::take(&mut cur));
            }
            0xF4 | 0xF5 | 0xF7 => {
                // Undefined, or an unpaired end of SysEx: nothing a MIDI list may carry.
                *status = 0;
                cur.clear();
                continue;
            }
            0x80..=0xF6 => {
                *status = if b < 0xF0 { b } else { 0 };
                cur = vec![b];
            }
            _ if cur.first() == Some(&0xF0) => cur.push(b),
            _ if cur.is_empty() && *status != 0 => cur = vec![*status, b],
            _ if cur.is_empty() => continue,
            _ => cur.push(b),
        }
        if cur
            .first()
            .is_some_and(|&s| s != 0xF0 && cur.len() >= need(s))
        {
            out.push(std::mem::take(&mut cur));
        }
    }
    out
}

impl MidiOut for RtpMidiOut {
    type Error = std::convert::Infallible;

    fn send(&mut self, _t_us: u64, bytes: &[u8]) -> Result<(), Self::Error> {
        self.poll_peer();
        let messages = whole_messages(&mut self.status, bytes);
        self.send_messages(&messages);
        Ok(())
    }

    fn finish(&mut self, _t_us: u64) -> Result<(), Self::Error> {
        // The performer has just sent All Notes Off on every channel.
        self.poll_peer();
        self.finished = true;
        self.bye();
        Ok(())
    }
}

impl Drop for RtpMidiOut {
    /// Unless the performance finished: All Notes Off on every channel, then BY.
    fn drop(&mut self) {
        if !self.finished {
            let all: Vec<Vec<u8>> = all_notes_off().chunks(3).map(<[u8]>::to_vec).collect();
            self.send_messages(&all);
        }
        self.bye();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_performers_stream_is_cut_into_whole_messages() {
        let mut status = 0;
        let got = whole_messages(&mut status, &[0x90, 60, 100, 62, 0xF8, 100, 0xC1, 5]);
        assert_eq!(
            got,
            [
                vec![0x90, 60, 100],
                vec![0xF8],
                vec![0x90, 62, 100],
                vec![0xC1, 5]
            ]
        );
        assert_eq!(status, 0xC1);
        let got = whole_messages(&mut status, &[7, 0xF0, 1, 2, 0xF7, 3]);
        assert_eq!(got, [vec![0xC1, 7], vec![0xF0, 1, 2, 0xF7]]);
        assert_eq!(
            status, 0,
            "SysEx ends running status: a stray data byte is dropped"
        );
    }
}
