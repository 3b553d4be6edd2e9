//! `orch run --in rtpmidi:[NAME@]PORT`: orch as an AppleMIDI session's responder. It answers
//! invitations on the control port PORT and the data port PORT + 1 with OK and its NAME,
//! answers clock sync (CK0 with CK1, CK2 taken), hands the MIDI that arrives on, repairs a
//! loss from the recovery journal, sends receiver feedback (RS) so the sender can trim its
//! journal, and ends the session on BY.
//!
//! One peer plays at a time: an invitation from another (a sender restarted, or a second
//! one) ends the session in force first, every key released, as a BY would.
//!
//! Two threads, one per port, each blocked on its socket: a packet is handed on the moment
//! it arrives. The data thread keeps the stream's [`Receiver`].

use std::io;
use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::clock;
use super::control::{self, Control, Exchange, VERSION};
use super::receiver::Receiver;
use crate::input::{InEvent, READ_POLL};
use crate::OutError;

/// The longest delta time honoured within one packet: a command is handed on at most this
/// long after its packet arrived.
pub const MAX_DELAY: Duration = Duration::from_millis(100);

/// How often receiver feedback is sent while packets come.
pub const FEEDBACK_EVERY: Duration = Duration::from_millis(250);

/// The session's peer, as both threads see it.
#[derive(Clone, Debug)]
struct Peer {
    ssrc: u32,
    name: String,
    control: SocketAddr,
    /// Its data port answered: the session is open.
    data: Option<SocketAddr>,
    /// Which session this is (the data thread starts a fresh receiver on a new one).
    generation: u64,
}

struct Shared<T> {
    name: String,
    ssrc: u32,
    origin: Instant,
    peer: Mutex<Option<Peer>>,
    generations: std::sync::atomic::AtomicU64,
    events: Sender<T>,
    stop: Arc<AtomicBool>,
}

/// Binds the control port at `addr` and the data port after it (port 0: the first free
/// pair) and starts answering; returns a name for messages, the control port's address and
/// the thread to join.
pub fn start<T: From<InEvent> + Send + 'static>(
    name: &str,
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    events: Sender<T>,
) -> Result<(String, SocketAddr, JoinHandle<()>), OutError> {
    let (ctl, data) = bind_pair(addr).map_err(|e| OutError::Open {
        device: format!("rtpmidi:{addr}"),
        source: e,
    })?;
    let local = ctl.local_addr().map_err(|e| OutError::Open {
        device: format!("rtpmidi:{addr}"),
        source: e,
    })?;
    let shared = Arc::new(Shared {
        name: name.to_string(),
        ssrc: super::out::random_u32(),
        origin: Instant::now(),
        peer: Mutex::new(None),
        generations: 0.into(),
        events,
        stop,
    });
    let spawn = |what: &str, f: Box<dyn FnOnce() + Send>| {
        std::thread::Builder::new()
            .name(format!("orch-in rtpmidi {what}"))
            .spawn(f)
            .map_err(|e| OutError::Open {
                device: format!("rtpmidi:{local}"),
                source: e,
            })
    };
    let s = Arc::clone(&shared);
    let data_thread = spawn(
        "data",
        Box::new(move || {
            let priority = orch_perform::realtime::raise_priority();
            tracing::debug!(?priority, "rtpmidi data reader");
            data_loop(&data, &s)
        }),
    )?;
    let s = Arc::clone(&shared);
    let thread = spawn(
        "control",
        Box::new(move || {
            control_loop(&ctl, &s);
            let _ = data_thread.join();
        }),
    )?;
    let label = format!(
        "rtpmidi session `{name}` on {local} (data port {})",
        local.port() + 1
    );
    Ok((label, local, thread))
}

/// The control socket at `addr` and a data socket at the next port (port 0: tries ephemeral
/// ports until a pair is free).
pub(crate) fn bind_pair(addr: SocketAddr) -> io::Result<(UdpSocket, UdpSocket)> {
    let tries = if addr.port() == 0 { 32 } else { 1 };
    let mut last = io::Error::from(io::ErrorKind::AddrInUse);
    for _ in 0..tries {
        let ctl = UdpSocket::bind(addr)?;
        let port = ctl.local_addr()?.port();
        if port == u16::MAX {
            continue;
        }
        let mut d = addr;
        d.set_port(port + 1);
        match UdpSocket::bind(d) {
            Ok(data) => {
                ctl.set_read_timeout(Some(READ_POLL))?;
                data.set_read_timeout(Some(READ_POLL))?;
                return Ok((ctl, data));
            }
            Err(e) => last = e,
        }
    }
    Err(last)
}

/// Receives on `socket` until stopped, handing each datagram to `f`.
fn recv_loop<T>(socket: &UdpSocket, s: &Shared<T>, mut f: impl FnMut(Instant, &[u8], SocketAddr)) {
    let mut buf = [0u8; 2048];
    while !s.stop.load(Ordering::SeqCst) {
        match socket.recv_from(&mut buf) {
            Ok((n, from)) => f(Instant::now(), &buf[..n], from),
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut
                        | io::ErrorKind::WouldBlock
                        | io::ErrorKind::Interrupted
                ) => {}
            Err(e) => tracing::debug!(error = %e, "rtpmidi: receive failed"),
        }
    }
}

fn reply(socket: &UdpSocket, to: SocketAddr, c: &Control) {
    if let Err(e) = socket.send_to(&control::write(c), to) {
        tracing::debug!(error = %e, %to, "rtpmidi: a reply could not be sent");
    }
}

fn exchange<T>(s: &Shared<T>, token: u32) -> Exchange {
    Exchange {
        version: VERSION,
        token,
        ssrc: s.ssrc,
        name: s.name.clone(),
    }
}

fn control_loop<T: From<InEvent>>(socket: &UdpSocket, s: &Shared<T>) {
    recv_loop(socket, s, |_, datagram, from| {
        match control::parse(datagram) {
            Ok(Control::Invite(e)) => {
                end_session(s, |p| p.ssrc != e.ssrc, "a new invitation took its place");
                let mut peer = s.peer.lock().unwrap_or_else(|p| p.into_inner());
                match peer.as_mut() {
                    // The same peer asking again (its OK was lost): still the same session.
                    Some(p) => p.control = from,
                    None => {
                        let generation = s.generations.fetch_add(1, Ordering::SeqCst) + 1;
                        *peer = Some(Peer {
                            ssrc: e.ssrc,
                            name: e.name.clone(),
                            control: from,
                            data: None,
                            generation,
                        });
                    }
                }
                drop(peer);
                reply(socket, from, &Control::Accept(exchange(s, e.token)));
            }
            Ok(Control::Bye(e)) => {
                end_session(s, |p| p.ssrc == e.ssrc, "the peer said goodbye (BY)")
            }
            Ok(other) => tracing::debug!(?other, "rtpmidi: control command ignored"),
            Err(e) => tracing::debug!(error = %e, %from, "rtpmidi: control packet refused"),
        }
    });
    end_session(s, |_| true, "orch stops");
}

/// Ends the session if its peer matches `which`: said as [`InEvent::Left`] (every key
/// released) if it had opened.
fn end_session<T: From<InEvent>>(s: &Shared<T>, which: impl Fn(&Peer) -> bool, why: &str) {
    let mut peer = s.peer.lock().unwrap_or_else(|p| p.into_inner());
    if peer.as_ref().is_some_and(which) {
        if let Some(p) = peer.take().filter(|p| p.data.is_some()) {
            let _ = s.events.send(T::from(InEvent::Left(format!(
                "`{}` at {}: {why}",
                p.name, p.control
            ))));
        }
    }
}

/// The data port's stream: its receiver, and when feedback was last sent.
struct Stream {
    receiver: Receiver,
    generation: u64,
    fed_back: Instant,
    /// Packets from the peer that could not be read.
    refused: u64,
}

fn data_loop<T: From<InEvent>>(socket: &UdpSocket, s: &Shared<T>) {
    let mut stream = Stream {
        receiver: Receiver::new(),
        generation: 0,
        fed_back: Instant::now(),
        refused: 0,
    };
    recv_loop(socket, s, |at, datagram, from| {
        if control::is_control(datagram) {
            data_control(socket, s, datagram, from);
        } else {
            midi(socket, s, &mut stream, at, datagram);
        }
    });
}

fn data_control<T: From<InEvent>>(
    socket: &UdpSocket,
    s: &Shared<T>,
    datagram: &[u8],
    from: SocketAddr,
) {
    match control::parse(datagram) {
        Ok(Control::Invite(e)) => {
            let mut guard = s.peer.lock().unwrap_or_else(|p| p.into_inner());
            let Some(peer) = guard.as_mut().filter(|p| p.ssrc == e.ssrc) else {
                drop(guard);
                reply(socket, from, &Control::Refuse(exchange(s, e.token)));
                return;
            };
            let opened = peer.data.is_none();
            peer.data = Some(from);
            let label = format!("`{}` at {}", peer.name, peer.control);
            drop(guard);
            reply(socket, from, &Control::Accept(exchange(s, e.token)));
            if opened {
                let _ = s.events.send(T::from(InEvent::Joined(label)));
            }
        }
        Ok(Control::Sync {
            count: 0, stamps, ..
        }) => {
            let ck1 = Control::Sync {
                ssrc: s.ssrc,
                count: 1,
                stamps: [stamps[0], clock(s.origin), 0],
            };
            reply(socket, from, &ck1);
        }
        Ok(Control::Sync {
            count: 2, stamps, ..
        }) => {
            let offset = (stamps[2] as i128 + stamps[0] as i128) / 2 - stamps[1] as i128;
            tracing::debug!(offset_100us = offset as i64, "rtpmidi: clock synchronised");
        }
        Ok(Control::Bye(e)) => end_session(s, |p| p.ssrc == e.ssrc, "the peer said goodbye (BY)"),
        Ok(other) => tracing::debug!(?other, "rtpmidi: data port command ignored"),
        Err(e) => tracing::debug!(error = %e, %from, "rtpmidi: data port command refused"),
    }
}

/// One RTP datagram: from the session's peer, read and handed on; recovered messages first,
/// then each command at its delta time (at most [`MAX_DELAY`] after arrival).
fn midi<T: From<InEvent>>(
    socket: &UdpSocket,
    s: &Shared<T>,
    st: &mut Stream,
    at: Instant,
    datagram: &[u8],
) {
    let peer = s.peer.lock().unwrap_or_else(|p| p.into_inner()).clone();
    let Some(peer) = peer.filter(|p| p.data.is_some()) else {
        return;
    };
    if datagram.len() >= 12 && datagram[8..12] != peer.ssrc.to_be_bytes() {
        return;
    }
    if st.generation != peer.generation {
        st.receiver = Receiver::new();
        st.generation = peer.generation;
    }
    let d = match st.receiver.receive(datagram) {
        Ok(d) => d,
        Err(e) => {
            // Said when the count of refused packets reaches a power of two: a flood of
            // them does not flood the log.
            st.refused += 1;
            if st.refused.is_power_of_two() {
                tracing::warn!(error = %e, refused = st.refused, "rtpmidi: a packet from the peer refused");
            }
            return;
        }
    };
    if let Some(e) = &d.journal_error {
        tracing::warn!(error = %e, lost = d.lost, "rtpmidi: packets lost and the journal unreadable");
    } else if d.lost > 0 {
        tracing::debug!(
            lost = d.lost,
            recovered = d.recovered.len(),
            "rtpmidi: loss repaired"
        );
    }
    if !d.recovered.is_empty() {
        let _ = s.events.send(T::from(InEvent::Bytes {
            at,
            bytes: d.recovered.concat(),
        }));
    }
    hand_on(s, at, d.commands);
    if d.lost > 0 || st.fed_back.elapsed() >= FEEDBACK_EVERY {
        if let Some(seq) = st.receiver.last_seq() {
            reply(
                socket,
                peer.control,
                &Control::Feedback { ssrc: s.ssrc, seq },
            );
            st.fed_back = Instant::now();
        }
    }
}

/// Sends the commands, those of one delta time together, each group when it is due.
fn hand_on<T: From<InEvent>>(s: &Shared<T>, arrived: Instant, commands: Vec<(u32, Vec<u8>)>) {
    let sleeper = spin_sleep::SpinSleeper::default();
    let mut group: Option<(u32, Vec<u8>)> = None;
    let send = |(delta, bytes): (u32, Vec<u8>)| {
        let due = arrived + (Duration::from_micros(100) * delta).min(MAX_DELAY);
        let now = Instant::now();
        if due > now {
            sleeper.sleep(due - now);
        }
        let at = if delta == 0 { arrived } else { due.max(now) };
        let _ = s.events.send(T::from(InEvent::Bytes { at, bytes }));
    };
    for (delta, bytes) in commands {
        match &mut group {
            Some((d, b)) if *d == delta => b.extend_from_slice(&bytes),
            _ => {
                if let Some(g) = group.replace((delta, bytes)) {
                    send(g);
                }
            }
        }
    }
    if let Some(g) = group {
        send(g);
    }
}
