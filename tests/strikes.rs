//! One beater of `orch config --instrument drums`, on the virtual robot: a velocity sweep
//! strikes ever harder (energy, duty × pulse length, never falls as velocity rises) and every
//! isolated strike sounds within 1 ms of the score; a snare roll faster than the beater's
//! rebound keeps the rebound. On on/off and on PCA9685 boards.

use midly::num::{u15, u28, u4, u7};
use midly::{
    Format, Header, MetaMessage, MidiMessage, Smf, Timing, Track, TrackEvent, TrackEventKind,
};
use orch_perform::{Outcome, Played, Tempo};
use orch_robot::{instrument_toml, BoardKind, Instrument, Robot};
use orch_seq::Song;

/// A one-track file at 120 bpm (480 ticks a quarter: a tick is 1.0417 ms): `(tick, velocity)`
/// snare hits on channel 10, each 10 ticks long.
fn snare(hits: &[(u32, u8)]) -> Song {
    let mut events: Vec<(u32, TrackEventKind)> = Vec::new();
    for &(at, v) in hits {
        let message = |m| TrackEventKind::Midi {
            channel: u4::new(9),
            message: m,
        };
        let key = u7::new(38);
        events.push((
            at,
            message(MidiMessage::NoteOn {
                key,
                vel: u7::new(v),
            }),
        ));
        events.push((
            at + 10,
            message(MidiMessage::NoteOff {
                key,
                vel: u7::new(0),
            }),
        ));
    }
    events.sort_by_key(|e| e.0);
    let mut track: Track = vec![TrackEvent {
        delta: u28::new(0),
        kind: TrackEventKind::Meta(MetaMessage::Tempo(500_000.into())),
    }];
    let mut last = 0;
    for (at, kind) in events {
        track.push(TrackEvent {
            delta: u28::new(at - last),
            kind,
        });
        last = at;
    }
    track.push(TrackEvent {
        delta: u28::new(0),
        kind: TrackEventKind::Meta(MetaMessage::EndOfTrack),
    });
    let smf = Smf {
        header: Header::new(Format::SingleTrack, Timing::Metrical(u15::new(480))),
        tracks: vec![track],
    };
    let mut bytes = Vec::new();
    smf.write_std(&mut bytes).unwrap();
    Song::parse(&bytes).unwrap()
}

fn play(song: &Song, kind: BoardKind) -> (Robot, Played) {
    let robot = Robot::from_toml(&instrument_toml(Instrument::Drums, kind)).unwrap();
    let mut setup = orch_stage::setup::setup(&robot, true, Tempo::new(1.0).unwrap());
    setup.sim.keep = orch_sim::Keep::Everything;
    let played = orch_stage::setup::play_fast(song, &setup).unwrap();
    (robot, played)
}

/// The snare is the kit's output 1.
const SNARE: u8 = 1;

#[test]
fn a_velocity_sweep_strikes_ever_harder_and_every_isolated_strike_is_on_time() {
    // Velocity 1, 5, 9 … 125, 127, a quarter note apart.
    let mut velocities: Vec<u8> = (1..=127).step_by(4).collect();
    velocities.push(127);
    let hits: Vec<(u32, u8)> = velocities
        .iter()
        .enumerate()
        .map(|(i, &v)| (i as u32 * 480, v))
        .collect();
    let song = snare(&hits);
    for kind in [BoardKind::OnOff, BoardKind::Pwm] {
        let (_, played) = play(&song, kind);
        for r in &played.records {
            assert!(
                matches!(r.outcome, Outcome::OnTime { error_us } if error_us.unsigned_abs() <= 1_000),
                "{kind:?}: velocity {} {:?}",
                r.velocity,
                r.outcome
            );
        }
        let presses: Vec<_> = played
            .performance
            .presses
            .iter()
            .filter(|p| p.key == SNARE)
            .collect();
        assert_eq!(presses.len(), velocities.len(), "{kind:?}");
        let mut last = 0u64;
        for (p, v) in presses.iter().zip(&velocities) {
            let length = p.pin_low.nanos_since(p.pin_high) / 1000;
            let energy = length * u64::from(p.duty);
            assert!(
                energy >= last,
                "{kind:?}: velocity {v} struck with less energy ({energy}) than the one before ({last})"
            );
            assert!(
                p.sounded.is_some() && p.muted.is_none(),
                "{kind:?}: velocity {v}"
            );
            last = energy;
        }
        // The loudest strike is the soft one's 20 / 8 ms long (and at full duty on PWM).
        let first = presses[0].pin_low.nanos_since(presses[0].pin_high) / 1000;
        let loud = presses.last().unwrap();
        assert_eq!(
            (first, loud.pin_low.nanos_since(loud.pin_high) / 1000),
            (8_000, 20_000)
        );
    }
}

#[test]
fn a_snare_roll_faster_than_the_rebound_keeps_the_rebound() {
    // 64 hits 20 ticks (20.8 ms) apart: twice as fast as the snare's 40 ms rebound.
    let hits: Vec<(u32, u8)> = (0..64).map(|i| (i * 20, 100)).collect();
    let song = snare(&hits);
    for kind in [BoardKind::OnOff, BoardKind::Pwm] {
        let (robot, played) = play(&song, kind);
        let rebound = u64::from(robot.config.strikes.pulse(SNARE).rebound.as_micros());
        let starts: Vec<u64> = played
            .performance
            .presses
            .iter()
            .filter(|p| p.key == SNARE)
            .map(|p| p.pin_high.as_nanos() / 1000)
            .collect();
        assert!(starts.len() >= 25, "{kind:?}: {} strikes", starts.len());
        for w in starts.windows(2) {
            assert!(w[1] - w[0] >= rebound, "{kind:?}: {} µs apart", w[1] - w[0]);
        }
        let r = played.report(None);
        assert!(r.adds_up(), "{kind:?}");
        assert_eq!(r.strikes as usize, starts.len(), "{kind:?}");
        assert!(
            r.onset_ms.max <= 30.0,
            "{kind:?}: none later than the late limit"
        );
        eprintln!("{kind:?}: {:?}", r.outcomes);
    }
}
