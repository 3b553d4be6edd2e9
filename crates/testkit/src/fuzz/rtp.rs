//! The checks of the `rtp_packet` fuzz target, shared with its stable replay test
//! (`crates/io/tests/fuzz_replay_rtp.rs`): every reader of what comes off the network in
//! `orch_io::rtp` takes any datagram without panicking, and what it accepts is well formed
//! and writes back to itself.
//!
//! - `packet::parse`: every command it gives is whole (a channel or system common message
//!   has its status byte and exactly its data bytes, all below 0x80); a packet of whole
//!   messages written again with `packet::write` reads back to the same messages.
//! - `journal::parse` (on the datagram itself and on a packet's journal section): a journal
//!   it accepts, written again with `journal::write`, reads back the same.
//! - `Receiver::receive`, after a packet of sequence number 0: never panics; whatever it
//!   recovers from a journal is Note-Offs, Note-Ons and Control Changes, whole.
//! - `control::parse`: a command it accepts, written again, reads back the same.
#![allow(dead_code)]

use orch_io::rtp::{control, journal, packet, receiver::Receiver};

fn whole(m: &[u8]) -> bool {
    let data = |n: usize| m.len() == n + 1 && m[1..].iter().all(|&b| b < 0x80);
    match m.first() {
        Some(0x80..=0xBF | 0xE0..=0xEF) => data(2),
        Some(0xC0..=0xDF) => data(1),
        Some(0xF1 | 0xF3) => data(1),
        Some(0xF2) => data(2),
        Some(0xF6 | 0xF8..=0xFF) => m.len() == 1,
        Some(0xF0) => m[1..].iter().all(|&b| b < 0x80 || b == 0xF7),
        _ => true, // a SysEx segment's data, or a cancelling 0xF7
    }
}

fn check_packet(data: &[u8]) {
    let Ok(p) = packet::parse(data) else {
        return;
    };
    for c in &p.commands {
        assert!(!c.bytes.is_empty(), "an empty command");
        assert!(whole(&c.bytes), "not a whole message: {:02x?}", c.bytes);
    }
    let messages = p.commands.iter().all(|c| match c.bytes[0] {
        0xF0 => c.bytes.ends_with(&[0xF7]),
        0xF7 => false, // a cancel: no command of its own
        s => s >= 0x80,
    });
    if messages && !p.commands.is_empty() {
        let list: Vec<(u32, &[u8])> = p.commands.iter().map(|c| (c.delta, &c.bytes[..])).collect();
        let again = packet::write(p.header, &list, p.journal);
        let q = packet::parse(&again).expect("a written packet reads");
        let first = p.commands[0].delta;
        let shifted: Vec<(u32, &[u8])> = p
            .commands
            .iter()
            .map(|c| (c.delta.wrapping_sub(first), &c.bytes[..]))
            .collect();
        let back: Vec<(u32, &[u8])> = q.commands.iter().map(|c| (c.delta, &c.bytes[..])).collect();
        if shifted
            .windows(2)
            .all(|w| w[1].0.wrapping_sub(w[0].0) < 1 << 28)
        {
            assert_eq!(back, shifted, "written and read back");
        }
        assert_eq!(q.journal, p.journal);
    }
    if let Some(j) = p.journal {
        check_journal(j);
    }
}

fn check_journal(data: &[u8]) {
    let Ok(j) = journal::parse(data) else {
        return;
    };
    let fits = j
        .channels
        .iter()
        .all(|c| c.notes.as_ref().is_none_or(|n| n.on.len() < 128) && c.controllers.len() <= 128);
    if fits {
        let again = journal::parse(&journal::write(&j)).expect("a written journal reads");
        assert_eq!(again, j, "written and read back");
    }
}

fn check_receiver(data: &[u8]) {
    let mut r = Receiver::new();
    r.receive(&[0x80, 0x61, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0x00])
        .expect("an empty packet");
    if let Ok(d) = r.receive(data) {
        for m in &d.recovered {
            assert!(
                m.len() == 3 && matches!(m[0] & 0xF0, 0x80 | 0x90 | 0xB0) && whole(m),
                "recovered {m:02x?}"
            );
        }
    }
}

fn check_control(data: &[u8]) {
    let Ok(c) = control::parse(data) else {
        return;
    };
    let again = control::parse(&control::write(&c)).expect("a written command reads");
    let unnamed = |c: &control::Control| match c {
        control::Control::Refuse(e) | control::Control::Bye(e) => {
            let mut e = e.clone();
            e.name.clear();
            e
        }
        control::Control::Invite(e) | control::Control::Accept(e) => e.clone(),
        _ => control::Exchange {
            version: 0,
            token: 0,
            ssrc: 0,
            name: String::new(),
        },
    };
    assert_eq!(unnamed(&again), unnamed(&c));
    if !matches!(c, control::Control::Refuse(_) | control::Control::Bye(_)) {
        assert_eq!(again, c);
    }
}

/// Every check on one input.
pub fn check(data: &[u8]) {
    check_packet(data);
    check_journal(data);
    check_receiver(data);
    check_control(data);
    orch_io::rtp::parse_any(data);
}
