//! Guards the per-note account: every Note-On gets exactly one first event, a waiting note
//! exactly one more; `overlap` (hold | restrike), `late_limit` (too fast) and the duty limit.

use orch_core::{
    Config, DropReason, GuardConfig, Instant, Interpreter, NoteEvent, Overlap, Recording,
};
#[cfg(feature = "duty-limit")]
use orch_core::{Duration, DutyLimit};

fn ms(t: u64) -> Instant {
    Instant::from_millis(t)
}

struct Rig {
    i: Interpreter,
    events: Vec<(u64, NoteEvent)>,
    boards: Recording<4096>,
}

impl Rig {
    fn new(config: Config<4>) -> Self {
        Self {
            i: Interpreter::new(config).unwrap(),
            events: Vec::new(),
            boards: Recording::new(),
        }
    }

    fn feed(&mut self, bytes: &[u8], t: Instant) {
        self.run_until(t);
        let ev = &mut self.events;
        self.i
            .feed_slice_with(bytes, t, &mut |e| ev.push((t.as_micros() / 1000, e)));
        self.i.flush(&mut self.boards).unwrap();
    }

    fn run_until(&mut self, t: Instant) {
        while let Some(d) = self.i.next_deadline().filter(|d| *d <= t) {
            let ev = &mut self.events;
            self.i
                .tick_with(d, &mut |e| ev.push((d.as_micros() / 1000, e)));
            self.i.flush(&mut self.boards).unwrap();
            if self.i.next_deadline() == Some(d) {
                break;
            }
        }
    }

    fn kinds(&self) -> Vec<(u64, &'static str)> {
        self.events
            .iter()
            .map(|(t, e)| {
                let k = match e {
                    NoteEvent::Struck { .. } => "struck",
                    NoteEvent::Waiting { .. } => "waiting",
                    NoteEvent::Leading { .. } => "leading",
                    NoteEvent::Preparing { .. } => "preparing",
                    NoteEvent::Joined {
                        with_strike: true, ..
                    } => "unison",
                    NoteEvent::Joined { .. } => "joined",
                    NoteEvent::Dropped { reason, .. } => reason.name(),
                    NoteEvent::WaitOver { .. } => "wait over",
                    NoteEvent::WaitEnded { .. } => "wait ended",
                };
                (*t, k)
            })
            .collect()
    }
}

fn config(overlap: Overlap) -> Config<4> {
    Config {
        overlap,
        ..Config::THESIS
    }
}

#[test]
fn a_doubling_on_two_channels_is_one_strike_and_a_unison() {
    for overlap in [Overlap::Hold, Overlap::Restrike] {
        let mut r = Rig::new(config(overlap));
        r.feed(&[0x90, 60, 100, 0x91, 60, 100], ms(0));
        assert_eq!(r.kinds(), vec![(0, "struck"), (0, "unison")], "{overlap:?}");
        assert_eq!(r.i.stats().joined, 1);
    }
}

#[test]
fn a_note_landing_on_a_held_key_joins_under_hold_and_is_too_fast_under_restrike() {
    let mut hold = Rig::new(config(Overlap::Hold));
    hold.feed(&[0x90, 60, 100], ms(0));
    hold.feed(&[0x91, 60, 100], ms(100));
    assert_eq!(hold.kinds(), vec![(0, "struck"), (100, "joined")]);

    // Restrike: the key would have to lift and rest 60 ms, more than the 30 ms late limit.
    let mut re = Rig::new(config(Overlap::Restrike));
    re.feed(&[0x90, 60, 100], ms(0));
    re.feed(&[0x91, 60, 100], ms(100));
    assert_eq!(re.kinds(), vec![(0, "struck"), (100, "too_fast")]);
    assert!(re.boards.outputs(1) & (1 << 8) != 0, "the key stays down");
    assert_eq!(re.i.stats().dropped_too_fast, 1);

    // With no late limit it lifts, rests and strikes again.
    let mut patient = Rig::new(Config {
        guard: GuardConfig {
            late_limit: None,
            ..GuardConfig::DEFAULT
        },
        ..config(Overlap::Restrike)
    });
    patient.feed(&[0x90, 60, 100], ms(0));
    patient.feed(&[0x91, 60, 100], ms(100));
    patient.run_until(ms(300));
    assert_eq!(
        patient.kinds(),
        vec![(0, "struck"), (100, "waiting"), (160, "wait over")]
    );
}

#[test]
fn a_re_strike_within_the_late_limit_waits_and_one_past_it_is_too_fast() {
    let mut r = Rig::new(Config::THESIS);
    r.feed(&[0x90, 60, 100], ms(0));
    r.feed(&[0x80, 60, 0], ms(10));
    r.feed(&[0x90, 60, 100], ms(45)); // rest left: 25 ms ≤ 30: waits
    r.feed(&[0x80, 60, 0], ms(100));
    r.feed(&[0x90, 60, 100], ms(110)); // rest left: 50 ms > 30: too fast
    r.run_until(ms(500));
    assert_eq!(
        r.kinds(),
        vec![
            (0, "struck"),
            (45, "waiting"),
            (70, "wait over"),
            (110, "too_fast")
        ]
    );
    let s = r.i.stats();
    assert_eq!(s.note_ons, s.played + s.folded + s.dropped());
}

#[test]
fn a_waiting_strike_is_stopped_by_all_off_and_cancelled_by_reset() {
    for (stop, reason) in [(true, DropReason::Stopped), (false, DropReason::Cancelled)] {
        let mut r = Rig::new(Config::THESIS);
        // A zero-length note is held min_press (20 ms): the key rests until 80 ms.
        r.feed(&[0x90, 60, 100, 0x80, 60, 0], ms(0));
        r.feed(&[0x90, 60, 100], ms(60));
        if stop {
            let ev = &mut r.events;
            r.i.all_off_with(ms(70), &mut |e| ev.push((70, e)));
        } else {
            r.feed(&[0xFF], ms(70));
        }
        assert_eq!(
            r.kinds(),
            vec![(0, "struck"), (60, "waiting"), (70, "wait ended")]
        );
        assert_eq!(
            r.events.last(),
            Some(&(70, NoteEvent::WaitEnded { key: 24, reason })),
        );
    }
}

#[test]
fn every_note_on_gets_exactly_one_first_event_and_waits_end_once() {
    // A busy stream over few keys: repeats, folds, channels, resets.
    let mut r = Rig::new(Config {
        guard: GuardConfig {
            max_keys_down: 3,
            ..GuardConfig::DEFAULT
        },
        ..Config::THESIS
    });
    let mut t = 0;
    let mut x: u32 = 12345;
    let mut ons = 0;
    for _ in 0..3000 {
        x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
        let note = [24u8, 36, 48, 60, 72, 127][(x >> 8) as usize % 6];
        let ch = (x >> 12) as u8 % 3;
        let on = (x >> 16) % 3 != 0;
        if on {
            ons += 1;
        }
        let status = if on { 0x90 } else { 0x80 } | ch;
        t += (x >> 20) as u64 % 40;
        r.feed(&[status, note, 100], ms(t));
        if (x >> 24) % 200 == 0 {
            r.feed(&[0xFF], ms(t));
        }
    }
    r.run_until(ms(t + 10_000));
    let firsts = r
        .events
        .iter()
        .filter(|(_, e)| !matches!(e, NoteEvent::WaitOver { .. } | NoteEvent::WaitEnded { .. }))
        .count();
    assert_eq!(firsts, ons);
    let waits = r.kinds().iter().filter(|k| k.1 == "waiting").count();
    let ends = r
        .kinds()
        .iter()
        .filter(|k| k.1 == "wait over" || k.1 == "wait ended")
        .count();
    assert_eq!(waits, ends);
    let s = r.i.stats();
    assert_eq!(s.note_ons, s.played + s.folded + s.dropped());
}

#[test]
#[cfg(feature = "duty-limit")]
fn the_duty_limit_cuts_a_key_struck_again_just_before_the_hold_limit() {
    // Struck every 9.9 s, held 9.8 s: 99 % duty. The hold limit never fires.
    let mut r = Rig::new(quiet_ok());
    let mut cut_at = None;
    for i in 0..20u64 {
        let t = i * 9_900;
        r.feed(&[0x90, 60, 100], ms(t));
        r.feed(&[0x80, 60, 0], ms(t + 9_800));
        if cut_at.is_none() && r.i.stats().cut_by_duty_limit > 0 {
            cut_at = Some(t);
        }
    }
    assert_eq!(r.i.stats().cut_by_hold_limit, 0);
    let cut_at = cut_at.expect("the duty limit cuts it");
    assert!(cut_at <= 70_000, "cut only at {cut_at} ms");
}

#[test]
#[cfg(feature = "duty-limit")]
fn the_duty_limit_leaves_music_alone() {
    // A repeated note at 48 % duty for ten minutes is never cut; at 60 % (more than the
    // 50 % allowed) its heat grows by 0.1 s a second and it is cut after about 300 s.
    for (on, cut) in [(240, false), (300, true)] {
        let mut r = Rig::new(quiet_ok());
        for i in 0..1200u64 {
            let t = i * 500;
            r.feed(&[0x90, 60, 100], ms(t));
            r.feed(&[0x80, 60, 0], ms(t + on));
        }
        assert_eq!(r.i.stats().cut_by_duty_limit > 0, cut, "{on} ms of 500");
    }
    // And the limit is a setting.
    let d = DutyLimit {
        window: Duration::from_secs(10),
        max_on: Duration::from_secs(2),
    };
    let mut tight = Rig::new(Config {
        guard: GuardConfig {
            duty: Some(d),
            ..GuardConfig::DEFAULT
        },
        ..Config::THESIS
    });
    tight.feed(&[0x90, 60, 100], ms(0));
    tight.run_until(ms(5_000));
    // From cold: cut after max_on / (1 − 0.2) = 2.5 s.
    assert_eq!(tight.i.stats().cut_by_duty_limit, 1);
    assert_eq!(tight.boards.outputs(1) & (1 << 8), 0);
}

/// The thesis's robot with no watchdog: tests here feed nothing between far-apart notes.
#[cfg(feature = "duty-limit")]
fn quiet_ok() -> Config<4> {
    Config {
        guard: GuardConfig {
            watchdog: None,
            ..GuardConfig::DEFAULT
        },
        ..Config::THESIS
    }
}
