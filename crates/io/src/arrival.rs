//! When a UDP datagram arrived: the kernel's own receive time (Linux's `SO_TIMESTAMPNS`), not
//! the moment the thread reading it came to run.
//!
//! On a busy host a thread waiting in `recv` may be woken milliseconds after its datagram came
//! in, even at real-time priority (a virtual machine's CPU stalls now and then). A conductor's
//! beat, a MIDI byte or a note stamped then would be late by as much, and a follower would
//! take the conductor for late. The kernel stamps each datagram as it takes it in, so the
//! stamp does not wait for the reader. [`recv`] turns that stamp into an [`Instant`]: it
//! measures the datagram's age on the wall clock (the kernel's stamp is one) and takes it
//! from the moment of the read on the monotonic clock, so a step of the wall clock can at
//! worst make one datagram's age wrong, never move the monotonic time it is given by more
//! than [`MAX_AGE`]. Elsewhere than Linux, and for a datagram the kernel gave no stamp, the
//! read's own time stands. (The kernel turns its stamping on shortly after the first socket
//! asks, in deferred work: a datagram that arrives before is stamped when it is read.)
//!
//! ```
//! use std::net::UdpSocket;
//! use std::time::Instant;
//!
//! let rx = UdpSocket::bind("127.0.0.1:0")?;
//! orch_io::arrival::stamp_arrivals(&rx)?;
//! let sent = Instant::now();
//! UdpSocket::bind("127.0.0.1:0")?.send_to(b"beat", rx.local_addr()?)?;
//! let mut buf = [0u8; 16];
//! let (n, at) = orch_io::arrival::recv(&rx, &mut buf)?;
//! assert_eq!(&buf[..n], b"beat");
//! assert!(sent <= at && at <= Instant::now());
//! # Ok::<(), std::io::Error>(())
//! ```

use std::io;
use std::net::UdpSocket;
use std::time::{Duration, Instant};

/// The most a datagram's kernel stamp may put its arrival before its read. A datagram older
/// than this (a reader busy elsewhere that long, or a wall clock stepped forward between the
/// two) is given the read's time less this.
pub const MAX_AGE: Duration = Duration::from_secs(1);

/// Asks the kernel to stamp each datagram `socket` receives (Linux; elsewhere nothing).
pub fn stamp_arrivals(socket: &UdpSocket) -> io::Result<()> {
    #[cfg(target_os = "linux")]
    {
        use nix::sys::socket::{setsockopt, sockopt::ReceiveTimestampns};
        setsockopt(socket, ReceiveTimestampns, &true)?;
    }
    #[cfg(not(target_os = "linux"))]
    let _ = socket;
    Ok(())
}

/// Receives one datagram into `buf` (as [`UdpSocket::recv`]: a longer one is cut to fit):
/// its length and when it arrived (see the [module notes](self); the read's own time if the
/// kernel gave none, as before [`stamp_arrivals`]).
pub fn recv(socket: &UdpSocket, buf: &mut [u8]) -> io::Result<(usize, Instant)> {
    #[cfg(target_os = "linux")]
    {
        linux::recv(socket, buf)
    }
    #[cfg(not(target_os = "linux"))]
    {
        let n = socket.recv(buf)?;
        Ok((n, Instant::now()))
    }
}

/// `read`, the read's time, less `age` (the kernel's stamp's age), at most [`MAX_AGE`].
fn before(read: Instant, age: Option<Duration>) -> Instant {
    age.and_then(|a| read.checked_sub(a.min(MAX_AGE)))
        .unwrap_or(read)
}

#[cfg(target_os = "linux")]
mod linux {
    use std::io::{self, IoSliceMut};
    use std::net::UdpSocket;
    use std::os::fd::AsRawFd;
    use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

    use nix::errno::Errno;
    use nix::sys::socket::{recvmsg, ControlMessageOwned, MsgFlags};
    use nix::sys::time::TimeSpec;

    pub(super) fn recv(socket: &UdpSocket, buf: &mut [u8]) -> io::Result<(usize, Instant)> {
        let mut iov = [IoSliceMut::new(buf)];
        let mut space = nix::cmsg_space!(TimeSpec);
        let msg = loop {
            match recvmsg::<()>(
                socket.as_raw_fd(),
                &mut iov,
                Some(&mut space),
                MsgFlags::empty(),
            ) {
                Err(Errno::EINTR) => continue,
                other => break other?,
            }
        };
        let (read, wall) = (Instant::now(), SystemTime::now());
        let stamp = msg.cmsgs()?.find_map(|c| match c {
            ControlMessageOwned::ScmTimestampns(t) => Some(t),
            _ => None,
        });
        // The stamp's age on the wall clock; none if the wall clock stepped back since.
        let age = stamp.and_then(|t| {
            let secs = u64::try_from(t.tv_sec()).ok()?;
            let nanos = u32::try_from(t.tv_nsec()).ok()?;
            wall.duration_since(UNIX_EPOCH + Duration::new(secs, nanos))
                .ok()
        });
        Ok((msg.bytes, super::before(read, age)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_datagram_read_late_is_stamped_when_it_arrived() {
        let rx = UdpSocket::bind("127.0.0.1:0").unwrap();
        stamp_arrivals(&rx).unwrap();
        // The first socket to ask turns the kernel's stamping on in deferred work: until it
        // has run, a datagram is stamped when it is read.
        std::thread::sleep(Duration::from_millis(100));
        let sent = Instant::now();
        let tx = UdpSocket::bind("127.0.0.1:0").unwrap();
        tx.send_to(&[0x90, 60, 100], rx.local_addr().unwrap())
            .unwrap();
        // The reader comes to it 50 ms late: the stamp is still the arrival.
        std::thread::sleep(Duration::from_millis(50));
        let mut buf = [0u8; 8];
        let (n, at) = recv(&rx, &mut buf).unwrap();
        assert_eq!(&buf[..n], &[0x90, 60, 100]);
        let after_send = at.saturating_duration_since(sent);
        if cfg!(target_os = "linux") {
            assert!(
                at >= sent && after_send < Duration::from_millis(20),
                "{after_send:?}"
            );
        } else {
            assert!(after_send >= Duration::from_millis(50));
        }
    }

    #[test]
    fn without_stamps_the_read_time_stands() {
        let rx = UdpSocket::bind("127.0.0.1:0").unwrap();
        let tx = UdpSocket::bind("127.0.0.1:0").unwrap();
        tx.send_to(b"x", rx.local_addr().unwrap()).unwrap();
        std::thread::sleep(Duration::from_millis(30));
        let before_read = Instant::now();
        let (n, at) = recv(&rx, &mut [0u8; 4]).unwrap();
        assert_eq!(n, 1);
        assert!(at >= before_read);
    }

    #[test]
    fn an_age_is_taken_off_the_read_up_to_the_limit() {
        let read = Instant::now() + Duration::from_secs(10);
        assert_eq!(before(read, None), read);
        let ms = Duration::from_millis(7);
        assert_eq!(before(read, Some(ms)), read - ms);
        let hour = Duration::from_secs(3600);
        assert_eq!(before(read, Some(hour)), read - MAX_AGE);
    }
}
