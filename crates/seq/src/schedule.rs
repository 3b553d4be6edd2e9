//! When to send each message: tempo scale and latency compensation.
//!
//! A solenoid takes time to strike and to let go. The sequencer knows the future, so it sends
//! each key's press early by that key's press delay and each release early by its release
//! delay: the note sounds, and stops, on the score's time. [`schedule`] turns a song's events
//! into `(send time, score time, bytes)` entries sorted by send time.
//!
//! # Rules
//!
//! 1. **Tempo scale** first: a score time `t` becomes `t / scale` ([`TempoScale`]: 2.0 plays
//!    twice as fast, 0.5 at half speed). Mechanical delays and gaps are physical and are not
//!    scaled.
//! 2. **Compensation** ([`Compensation`], on whenever the robot has mechanics delays; off, or
//!    `None`, sends everything at its score time): a Note-On (velocity > 0) of a mapped key is
//!    sent at `score − press_delay(key)`, a Note-Off (or velocity 0) at
//!    `score − release_delay(key)`. Notes the key map drops are sent at score time.
//! 3. **One key's messages are never reordered**: per key, the send order equals the score
//!    order. A message that would overtake the key's previous one is held back to it (equal
//!    send times keep score order). A release is also held back to at least
//!    `min(min_press, the note's own score length)` after its press, so a note that a longer
//!    release delay would swallow still sounds for as long as the score says (or `min_press`).
//! 4. **The re-strike gap is never broken**: a press is sent at least `restrike_gap` after the
//!    key's previous release. If compensation would bring it closer, the **release is moved
//!    earlier** first (the note is cut a little short, which the ear forgives), but not before
//!    the message ahead of it on that key nor before its own press + `min(min_press, note
//!    length)`; if that is not enough, the **press is delayed** to release + gap (a late note
//!    rather than a smeared one). The same applies when the score itself repeats a key faster
//!    than the gap. Counts are in [`ScheduleStats`].
//! 5. **Other messages** go at their score time, except the channel-wide controllers that act
//!    on held notes — sustain (64), sostenuto (66), all sound off (120), reset controllers
//!    (121), all notes off (123) and the mode messages 124–127: on their channel such a
//!    message is sent no earlier than the sends of the mapped note messages before it in the
//!    score and, where possible, no later than those after it, so a pedal or an all-notes-off
//!    still acts on exactly the notes the score says (a Note-Off sent early does not escape a
//!    pedal-down, a Note-On sent early is not killed by the all-notes-off before it). If the
//!    two bounds cross, the earlier notes win. The releases a pedal-up causes are not
//!    compensated: they are late by the key's release delay.
//! 6. **Lead-in**: sends may fall before 0; then the whole schedule (send and score times)
//!    is shifted so the first send is at 0, and the shift is reported as
//!    [`Schedule::lead_in_us`]. A song that starts later than its first send needs no shift.

use std::collections::BTreeMap;

use orch_core::{Channel, ChannelMask, KeyRange, Note, OutOfRange};

use crate::clock::Clock;
use crate::song::{Event, WireBytes};
use crate::stream::{wire, RunningStatus, Wire};

/// How fast to play: score times are divided by it. 1.0 is as written, 2.0 twice as fast.
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd)]
pub struct TempoScale(f64);

impl TempoScale {
    /// As written.
    pub const NORMAL: Self = Self(1.0);

    /// A scale, if `scale` is finite and above 0.
    pub fn new(scale: f64) -> Option<Self> {
        (scale.is_finite() && scale > 0.0).then_some(Self(scale))
    }

    /// The factor.
    pub fn get(self) -> f64 {
        self.0
    }

    /// A score time played at this scale: `time / scale`, rounded to the nearest µs.
    pub fn apply(self, time_us: u64) -> u64 {
        if self.0 == 1.0 {
            return time_us;
        }
        let t = (time_us as f64 / self.0).round();
        if t >= u64::MAX as f64 {
            u64::MAX
        } else {
            t as u64
        }
    }
}

impl Default for TempoScale {
    fn default() -> Self {
        Self::NORMAL
    }
}

type KeyOfFn<'a> = Box<dyn Fn(u8, u8) -> Option<u16> + 'a>;
type DelayFn<'a> = Box<dyn Fn(u16) -> u64 + 'a>;

/// What latency compensation needs to know about the robot.
pub struct Compensation<'a> {
    key_of: KeyOfFn<'a>,
    press_delay_us: DelayFn<'a>,
    release_delay_us: DelayFn<'a>,
    restrike_gap_us: u64,
    min_press_us: u64,
    enabled: bool,
}

impl<'a> Compensation<'a> {
    /// Compensation with a key map (`(channel 0..=15, note) → key`, `None` if the robot does
    /// not play it) and each key's press and release delays in µs. No re-strike gap and no
    /// minimum press until set.
    pub fn new(
        key_of: impl Fn(u8, u8) -> Option<u16> + 'a,
        press_delay_us: impl Fn(u16) -> u64 + 'a,
        release_delay_us: impl Fn(u16) -> u64 + 'a,
    ) -> Self {
        Self {
            key_of: Box::new(key_of),
            press_delay_us: Box::new(press_delay_us),
            release_delay_us: Box::new(release_delay_us),
            restrike_gap_us: 0,
            min_press_us: 0,
            enabled: true,
        }
    }

    /// The same press and release delay for every key.
    pub fn uniform(
        key_of: impl Fn(u8, u8) -> Option<u16> + 'a,
        press_delay_us: u64,
        release_delay_us: u64,
    ) -> Self {
        Self::new(key_of, move |_| press_delay_us, move |_| release_delay_us)
    }

    /// The guard's re-strike gap: how long a key stays up before it strikes again.
    pub fn restrike_gap_us(mut self, gap_us: u64) -> Self {
        self.restrike_gap_us = gap_us;
        self
    }

    /// The shortest press the schedule makes by moving releases (rule 3 of the module docs).
    pub fn min_press_us(mut self, min_us: u64) -> Self {
        self.min_press_us = min_us;
        self
    }

    /// Switches compensation on or off (off: every message at its score time).
    pub fn enabled(mut self, on: bool) -> Self {
        self.enabled = on;
        self
    }

    /// Whether compensation is on.
    pub fn is_enabled(&self) -> bool {
        self.enabled
    }

    /// The key map of the interpreter in `orch-core`: notes on `channels` land on
    /// `range.key_for(note, policy)`.
    pub fn core_key_map(
        range: KeyRange,
        policy: OutOfRange,
        channels: ChannelMask,
    ) -> impl Fn(u8, u8) -> Option<u16> + Copy {
        move |channel, note| {
            let ch = Channel::new(channel)?;
            if !channels.contains(ch) {
                return None;
            }
            let note = Note::new(note)?;
            range.key_for(note, policy).map(|k| u16::from(k.key))
        }
    }
}

impl std::fmt::Debug for Compensation<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Compensation")
            .field("restrike_gap_us", &self.restrike_gap_us)
            .field("min_press_us", &self.min_press_us)
            .field("enabled", &self.enabled)
            .finish_non_exhaustive()
    }
}

/// One message to send.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Scheduled {
    /// When to send it, µs from the start of playing.
    pub send_us: u64,
    /// When the score wants it to sound, on the same clock (scaled, plus the lead-in).
    pub score_us: u64,
    /// The key it presses or releases, for mapped notes under compensation.
    pub key: Option<u16>,
    /// Index of the song event it comes from.
    pub event: usize,
    /// The track it comes from.
    pub track: u16,
    /// The message.
    pub bytes: WireBytes,
}

/// What the schedule had to change to keep its rules.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScheduleStats {
    /// Releases moved earlier than `score − release_delay` to keep the re-strike gap.
    pub releases_moved_early: usize,
    /// Presses sent later than `score − press_delay` (gap or key order).
    pub presses_delayed: usize,
    /// The most a press was delayed, in µs.
    pub max_press_delay_us: u64,
    /// Messages held back so one key's messages keep their order (releases and presses).
    pub order_holds: usize,
    /// Channel-wide controllers sent at other than their score time.
    pub controllers_moved: usize,
}

/// Messages sorted by send time.
#[derive(Clone, Debug, Default)]
pub struct Schedule {
    entries: Vec<Scheduled>,
    lead_in_us: u64,
    stats: ScheduleStats,
}

impl Schedule {
    /// The entries, by send time (ties in score order).
    pub fn entries(&self) -> &[Scheduled] {
        &self.entries
    }

    /// How far everything was shifted so the first send is at 0.
    pub fn lead_in_us(&self) -> u64 {
        self.lead_in_us
    }

    /// What had to change.
    pub fn stats(&self) -> ScheduleStats {
        self.stats
    }

    /// `(send_us, bytes)` in sending order, for [`wire`](crate::wire).
    pub fn messages(&self) -> impl Iterator<Item = (u64, &[u8])> + '_ {
        self.entries.iter().map(|e| (e.send_us, e.bytes.as_slice()))
    }

    /// The wire form, with or without running status.
    pub fn wire(&self, mode: RunningStatus) -> Wire<impl Iterator<Item = (u64, &[u8])> + '_> {
        wire(self.messages(), mode)
    }

    /// Plays the schedule against `clock`: waits for each send time, then hands the wire
    /// bytes to `send`. Returns the clock's lateness statistics.
    pub fn play<C: Clock>(
        &self,
        clock: &mut C,
        mode: RunningStatus,
        mut send: impl FnMut(u64, &[u8]),
    ) -> crate::clock::Lateness {
        for (t, bytes) in self.wire(mode) {
            clock.wait_until(t);
            send(t, bytes);
        }
        clock.lateness()
    }
}

/// Channel-wide controllers that act on held notes.
fn is_channel_wide(bytes: &WireBytes) -> Option<u8> {
    match bytes.control_change() {
        Some((ch, 64 | 66 | 120 | 121 | 123..=127, _)) => Some(ch),
        _ => None,
    }
}

/// Schedules `events` (a song's, in playing order) at `scale`, with optional compensation.
pub fn schedule(
    events: &[Event],
    scale: TempoScale,
    compensation: Option<&Compensation<'_>>,
) -> Schedule {
    let n = events.len();
    let score: Vec<i64> = events
        .iter()
        .map(|e| i64::try_from(scale.apply(e.time_us)).unwrap_or(i64::MAX / 2))
        .collect();
    let mut send = score.clone();
    let mut keys: Vec<Option<u16>> = vec![None; n];
    let mut stats = ScheduleStats::default();

    if let Some(c) = compensation.filter(|c| c.enabled) {
        let gap = i64::try_from(c.restrike_gap_us).unwrap_or(i64::MAX / 4);
        let min_press = i64::try_from(c.min_press_us).unwrap_or(i64::MAX / 4);
        // Per key, its note messages in score order: (event index, is press).
        let mut per_key: BTreeMap<u16, Vec<(usize, bool)>> = BTreeMap::new();
        let mut desired = vec![0i64; n];
        for (i, e) in events.iter().enumerate() {
            let (ch, note, press) = if let Some((ch, note, _)) = e.bytes.note_on() {
                (ch, note, true)
            } else if let Some((ch, note)) = e.bytes.note_off() {
                (ch, note, false)
            } else {
                continue;
            };
            let Some(key) = (c.key_of)(ch, note) else {
                continue;
            };
            keys[i] = Some(key);
            let delay = if press {
                (c.press_delay_us)(key)
            } else {
                (c.release_delay_us)(key)
            };
            desired[i] = score[i].saturating_sub(i64::try_from(delay).unwrap_or(i64::MAX / 4));
            per_key.entry(key).or_default().push((i, press));
        }

        for seq in per_key.values() {
            // Index (in `seq`) of the latest press.
            let mut last_press: Option<usize> = None;
            for pos in 0..seq.len() {
                let (i, press) = seq[pos];
                let prev = pos.checked_sub(1).map(|p| seq[p]);
                if press {
                    let mut p = desired[i];
                    match prev {
                        Some((r, false)) if p - send[r] < gap => {
                            // Too close after (or before) the key's release: move the release
                            // earlier, within its bounds, then delay the press if still needed.
                            let mut lower = i64::MIN;
                            if pos >= 2 {
                                lower = lower.max(send[seq[pos - 2].0]);
                            }
                            if let Some(lp) = last_press {
                                let (pi, _) = seq[lp];
                                let hold = min_press.min(score[r] - score[pi]).max(0);
                                lower = lower.max(send[pi] + hold);
                            }
                            let moved = (p - gap).max(lower);
                            if moved < send[r] {
                                send[r] = moved;
                                stats.releases_moved_early += 1;
                            }
                            p = p.max(send[r] + gap);
                        }
                        Some((j, true)) if p < send[j] => {
                            p = send[j];
                            stats.order_holds += 1;
                        }
                        _ => {}
                    }
                    if p > desired[i] {
                        stats.presses_delayed += 1;
                        stats.max_press_delay_us =
                            stats.max_press_delay_us.max((p - desired[i]) as u64);
                    }
                    send[i] = p;
                    last_press = Some(pos);
                } else {
                    let mut r = desired[i];
                    let mut floor = i64::MIN;
                    if let Some((j, _)) = prev {
                        floor = floor.max(send[j]);
                    }
                    if let Some(lp) = last_press {
                        let (pi, _) = seq[lp];
                        let hold = min_press.min(score[i] - score[pi]).max(0);
                        floor = floor.max(send[pi] + hold);
                    }
                    if r < floor {
                        r = floor;
                        stats.order_holds += 1;
                    }
                    send[i] = r;
                }
            }
        }

        // Channel-wide controllers keep their place among their channel's note messages.
        let wide: Vec<Option<u8>> = events.iter().map(|e| is_channel_wide(&e.bytes)).collect();
        if wide.iter().any(Option::is_some) {
            let mut hi = vec![i64::MAX; n];
            let mut min_after = [i64::MAX; 16];
            for i in (0..n).rev() {
                if let Some(ch) = wide[i] {
                    hi[i] = min_after[usize::from(ch)];
                } else if keys[i].is_some() {
                    let ch = usize::from(events[i].bytes.channel().unwrap_or(0));
                    min_after[ch] = min_after[ch].min(send[i]);
                }
            }
            let mut max_before = [i64::MIN; 16];
            for i in 0..n {
                if let Some(ch) = wide[i] {
                    let lo = max_before[usize::from(ch)];
                    let s = score[i].min(hi[i]).max(lo);
                    if s != score[i] {
                        stats.controllers_moved += 1;
                    }
                    send[i] = s;
                } else if keys[i].is_some() {
                    let ch = usize::from(events[i].bytes.channel().unwrap_or(0));
                    max_before[ch] = max_before[ch].max(send[i]);
                }
            }
        }
    }

    let first = send.iter().copied().min().unwrap_or(0);
    let lead_in = if first < 0 { -first } else { 0 };
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&i| (send[i], i));
    let entries = order
        .into_iter()
        .map(|i| Scheduled {
            send_us: (send[i] + lead_in) as u64,
            score_us: (score[i] + lead_in) as u64,
            key: keys[i],
            event: i,
            track: events[i].track,
            bytes: events[i].bytes.clone(),
        })
        .collect();
    Schedule {
        entries,
        lead_in_us: lead_in as u64,
        stats,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(time_us: u64, bytes: &[u8]) -> Event {
        Event {
            time_us,
            tick: time_us,
            track: 0,
            bytes: WireBytes::new(bytes),
        }
    }

    #[test]
    fn tempo_scale_rejects_nonsense() {
        assert!(TempoScale::new(0.0).is_none());
        assert!(TempoScale::new(-1.0).is_none());
        assert!(TempoScale::new(f64::NAN).is_none());
        assert_eq!(TempoScale::new(2.0).unwrap().apply(1000), 500);
    }

    #[test]
    fn pedal_down_is_not_overtaken_by_a_release_it_sustains() {
        // Pedal down at 100; note released at 110 with a 30 ms release delay → sent at 80.
        let events = [
            ev(0, &[0x90, 60, 100]),
            ev(100_000, &[0xB0, 64, 127]),
            ev(110_000, &[0x80, 60, 0]),
        ];
        let comp = Compensation::uniform(|_, n| Some(u16::from(n)), 0, 30_000);
        let s = schedule(&events, TempoScale::NORMAL, Some(&comp));
        let pos = |b: u8| s.entries().iter().position(|e| e.bytes[0] == b).unwrap();
        assert!(pos(0xB0) < pos(0x80));
        assert_eq!(s.stats().controllers_moved, 1);
    }

    #[test]
    fn all_notes_off_does_not_kill_an_early_press_after_it() {
        let events = [ev(100_000, &[0xB0, 123, 0]), ev(110_000, &[0x90, 60, 100])];
        let comp = Compensation::uniform(|_, n| Some(u16::from(n)), 30_000, 0);
        let s = schedule(&events, TempoScale::NORMAL, Some(&comp));
        assert_eq!(s.entries()[0].bytes[0], 0xB0);
        assert_eq!(s.entries()[1].bytes[0], 0x90);
    }
}
