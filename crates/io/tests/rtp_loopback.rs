//! orch-io's two RTP-MIDI halves on loopback, in one process: `RtpMidiOut` begins a session
//! with a `MidiIn` on `rtpmidi:`, the messages sent arrive whole and in order, and dropping
//! the output (as on a panic's way out) sends All Notes Off and a goodbye, which the input
//! says as the session's end.

use std::sync::mpsc;
use std::time::Duration;

use orch_io::{InEvent, InTarget, MidiIn, RtpMidiOut};
use orch_perform::MidiOut;

fn next(rx: &mpsc::Receiver<InEvent>) -> InEvent {
    rx.recv_timeout(Duration::from_secs(5)).expect("an event")
}

#[test]
fn a_session_on_loopback_from_invitation_to_goodbye() {
    let (tx, rx) = mpsc::channel::<InEvent>();
    let target = InTarget::parse("rtpmidi:looped@127.0.0.1:0").unwrap();
    let input = MidiIn::open(&target, tx).unwrap();
    let port = input.local_addr().unwrap().port();
    assert!(input.name().contains("`looped`"), "{}", input.name());

    let mut out = RtpMidiOut::open(&format!("127.0.0.1:{port}")).unwrap();
    assert_eq!(out.peer_name(), "looped");
    match next(&rx) {
        InEvent::Joined(who) => assert!(who.contains("`orch`"), "{who}"),
        other => panic!("{other:?}"),
    }
    // Running status in what the performer sends; whole messages on the far side.
    out.send(0, &[0x90, 60, 100, 64, 100]).unwrap();
    out.send(1, &[0xB0, 64, 127]).unwrap();
    let mut got = Vec::new();
    while got.len() < 9 {
        match next(&rx) {
            InEvent::Bytes { bytes, .. } => got.extend(bytes),
            other => panic!("{other:?}"),
        }
    }
    assert_eq!(got, [0x90, 60, 100, 0x90, 64, 100, 0xB0, 64, 127]);
    assert_eq!(out.stats().writes, 2);

    drop(out);
    let mut off = Vec::new();
    loop {
        match next(&rx) {
            InEvent::Bytes { bytes, .. } => off.extend(bytes),
            InEvent::Left(why) => {
                assert!(why.contains("goodbye"), "{why}");
                break;
            }
            other => panic!("{other:?}"),
        }
    }
    assert_eq!(off, orch_io::midi::all_notes_off());
}

#[test]
fn an_invitation_nobody_answers_is_an_error_naming_the_peer() {
    let silent = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let port = silent.local_addr().unwrap().port();
    let t0 = std::time::Instant::now();
    let e = RtpMidiOut::open(&format!("127.0.0.1:{port}"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("no answer to the invitation"), "{e}");
    assert!(t0.elapsed() >= orch_io::rtp::out::ANSWER_WITHIN);
}
