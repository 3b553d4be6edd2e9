//! AppleMIDI's session protocol: the commands that start with 0xFFFF on the control port
//! (invitations, goodbyes, receiver feedback) and the data port (the same invitations, and
//! clock sync).
//!
//! ```text
//! IN / OK / NO / BY   FFFF cmd  version(4) = 2  token(4)  ssrc(4)  [name, NUL-terminated]
//! CK                  FFFF CK   ssrc(4)  count(1)  pad(3)  timestamp(8) × 3   (100 µs units)
//! RS                  FFFF RS   ssrc(4)  seq(2)  pad(2)
//! ```

use super::error::{PacketError, Reader};

/// The AppleMIDI protocol version this end speaks.
pub const VERSION: u32 = 2;

/// The longest name sent or kept.
pub const MAX_NAME: usize = 64;

/// One AppleMIDI command.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Control {
    /// An invitation (IN).
    Invite(Exchange),
    /// An invitation accepted (OK).
    Accept(Exchange),
    /// An invitation refused (NO).
    Refuse(Exchange),
    /// The session ends (BY).
    Bye(Exchange),
    /// Clock sync (CK): `count` 0, 1 or 2 and the timestamps so far.
    Sync {
        /// The sender's SSRC.
        ssrc: u32,
        /// Which of the three messages.
        count: u8,
        /// The timestamps, 100 µs units.
        stamps: [u64; 3],
    },
    /// Receiver feedback (RS): every packet up to `seq` arrived.
    Feedback {
        /// The receiver's SSRC.
        ssrc: u32,
        /// The last sequence number received.
        seq: u16,
    },
}

/// The fields of IN, OK, NO and BY.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Exchange {
    /// The protocol version.
    pub version: u32,
    /// The initiator's token (the answer carries the invitation's).
    pub token: u32,
    /// The sender's SSRC.
    pub ssrc: u32,
    /// The sender's name (empty if none was sent).
    pub name: String,
}

/// Whether a datagram is an AppleMIDI command.
pub fn is_control(datagram: &[u8]) -> bool {
    datagram.starts_with(&[0xFF, 0xFF])
}

/// Reads an AppleMIDI command.
pub fn parse(datagram: &[u8]) -> Result<Control, PacketError> {
    let mut r = Reader::new(datagram);
    if r.u16("the AppleMIDI signature")? != 0xFFFF {
        return Err(PacketError::UnknownCommand([0, 0]));
    }
    let c = r.take(2, "the AppleMIDI command")?;
    let cmd = [c[0], c[1]];
    match &cmd {
        b"IN" => exchange(&mut r).map(Control::Invite),
        b"OK" => exchange(&mut r).map(Control::Accept),
        b"NO" => exchange(&mut r).map(Control::Refuse),
        b"BY" => exchange(&mut r).map(Control::Bye),
        b"CK" => {
            let ssrc = r.u32("CK")?;
            let count = r.u8("CK")?;
            r.take(3, "CK")?;
            let stamps = [r.u64("CK")?, r.u64("CK")?, r.u64("CK")?];
            Ok(Control::Sync {
                ssrc,
                count,
                stamps,
            })
        }
        b"RS" => {
            let ssrc = r.u32("RS")?;
            let seq = r.u16("RS")?;
            Ok(Control::Feedback { ssrc, seq })
        }
        _ => Err(PacketError::UnknownCommand(cmd)),
    }
}

fn exchange(r: &mut Reader<'_>) -> Result<Exchange, PacketError> {
    let version = r.u32("an invitation")?;
    let token = r.u32("an invitation")?;
    let ssrc = r.u32("an invitation")?;
    let rest = r.rest();
    let end = rest.iter().position(|&b| b == 0).unwrap_or(rest.len());
    let name: String = String::from_utf8_lossy(&rest[..end])
        .chars()
        .filter(|c| !c.is_control())
        .take(MAX_NAME)
        .collect();
    Ok(Exchange {
        version,
        token,
        ssrc,
        name,
    })
}

/// Writes an AppleMIDI command.
pub fn write(c: &Control) -> Vec<u8> {
    let mut out = vec![0xFF, 0xFF];
    let ex = |out: &mut Vec<u8>, cmd: &[u8; 2], e: &Exchange, named: bool| {
        out.extend_from_slice(cmd);
        out.extend_from_slice(&e.version.to_be_bytes());
        out.extend_from_slice(&e.token.to_be_bytes());
        out.extend_from_slice(&e.ssrc.to_be_bytes());
        if named {
            let name: String = e.name.chars().take(MAX_NAME).collect();
            out.extend_from_slice(name.replace('\0', "").as_bytes());
            out.push(0);
        }
    };
    match c {
        Control::Invite(e) => ex(&mut out, b"IN", e, true),
        Control::Accept(e) => ex(&mut out, b"OK", e, true),
        Control::Refuse(e) => ex(&mut out, b"NO", e, false),
        Control::Bye(e) => ex(&mut out, b"BY", e, false),
        Control::Sync {
            ssrc,
            count,
            stamps,
        } => {
            out.extend_from_slice(b"CK");
            out.extend_from_slice(&ssrc.to_be_bytes());
            out.extend_from_slice(&[*count, 0, 0, 0]);
            for s in stamps {
                out.extend_from_slice(&s.to_be_bytes());
            }
        }
        Control::Feedback { ssrc, seq } => {
            out.extend_from_slice(b"RS");
            out.extend_from_slice(&ssrc.to_be_bytes());
            out.extend_from_slice(&seq.to_be_bytes());
            out.extend_from_slice(&[0, 0]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_invitation_as_apple_sends_it() {
        // FFFF "IN", version 2, token 0x12345678, SSRC 0x0A0B0C0D, "mac\0".
        let bytes = [
            0xFF, 0xFF, b'I', b'N', 0, 0, 0, 2, 0x12, 0x34, 0x56, 0x78, 0x0A, 0x0B, 0x0C, 0x0D,
            b'm', b'a', b'c', 0,
        ];
        let c = parse(&bytes).unwrap();
        let e = Exchange {
            version: 2,
            token: 0x1234_5678,
            ssrc: 0x0A0B_0C0D,
            name: "mac".into(),
        };
        assert_eq!(c, Control::Invite(e.clone()));
        assert_eq!(write(&c), bytes);
        let bye = write(&Control::Bye(e));
        assert_eq!(bye.len(), 16);
        assert!(matches!(parse(&bye), Ok(Control::Bye(b)) if b.name.is_empty()));
    }

    #[test]
    fn clock_sync_and_feedback_round_trip() {
        let ck = Control::Sync {
            ssrc: 7,
            count: 1,
            stamps: [1, 2, 0],
        };
        assert_eq!(write(&ck).len(), 36);
        assert_eq!(parse(&write(&ck)).unwrap(), ck);
        let rs = Control::Feedback { ssrc: 7, seq: 513 };
        let w = write(&rs);
        assert_eq!(
            &w[8..12],
            [2, 1, 0, 0],
            "the sequence number in the upper 16 bits"
        );
        assert_eq!(parse(&w).unwrap(), rs);
    }

    #[test]
    fn hostile_commands_are_refused() {
        assert!(parse(&[0xFF, 0xFF, b'C', b'K', 0]).is_err());
        assert!(parse(&[0xFF, 0xFF, b'I', b'N', 0, 0, 0, 2]).is_err());
        assert_eq!(
            parse(&[0xFF, 0xFF, b'Z', b'Z']),
            Err(PacketError::UnknownCommand(*b"ZZ"))
        );
        let mut named = write(&Control::Invite(Exchange {
            version: 2,
            token: 1,
            ssrc: 2,
            name: String::new(),
        }));
        named.pop();
        named.extend_from_slice(&[b'x'; 500]); // no NUL, too long, kept short
        match parse(&named).unwrap() {
            Control::Invite(e) => assert_eq!(e.name.len(), MAX_NAME),
            other => panic!("{other:?}"),
        }
    }
}
