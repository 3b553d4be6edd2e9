//! The interpreter: decoded messages and the current time in, finger frames out.

use crate::config::{Config, ConfigError, ConfigSource, DutyLimit, GuardConfig, Overlap, Thesis};
use crate::decoder::{Counters, Decoder};
use crate::dynamics::Duty;
use crate::fingers::{
    clamp_across, Fingers, AGE_CAP, DOWN, FOLDED, LATE, PENDING, RELEASE_AFTER, RELEASING,
};
use crate::frame::{FingerFrame, FlushError};
use crate::held::{HeldNotes, NoteTable};
use crate::keymap::KeyOf;
use crate::message::Message;
use crate::outcome::{DropReason, Landing, NoteEvent, NoteSink};
use crate::output::{BoardId, FingerBoards};
use crate::stats::Stats;
use crate::time::{Duration, Instant};
use crate::values::{Channel, Note, Velocity};

#[cfg(feature = "wind")]
mod wind_play;

/// The specification's Active Sensing timeout: 300 ms.
pub const ACTIVE_SENSING_TIMEOUT: Duration = Duration::from_millis(300);

/// What a key is doing, as [`Interpreter::key_phase`] tells it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum KeyPhase {
    /// Up and free to strike.
    Up,
    /// Released recently: a strike now would wait for the re-strike gap.
    Resting,
    /// A strike is waiting for the re-strike gap to pass.
    Waiting,
    /// Down: its solenoid is powered.
    Down,
}

/// A deadline kept in 32 bits: the low 32 bits of its instant, compared with the clock's by
/// wrapping difference, or never. Every kept deadline lies less than 2³¹ µs (35 minutes) from
/// the clock: at the end of every call it is ahead of the clock by at most the longest limit
/// ([`MAX_LIMIT`](crate::MAX_LIMIT), 30 minutes) or has just passed, and a jump of the clock
/// that could take it out of reach is seen by [`advance`](Interpreter::advance), which marks
/// it passed ([`Kept::reach`]). So the interpreter's per-byte work on time is 32-bit (an 8-bit
/// MCU's loads, stores and compares of a 64-bit instant were a fifth of its cycles), and the
/// answers are those of 64-bit instants. "Never" is all zero bits, so that with a constant
/// configuration the interpreter's initial state is all zeros and an MCU keeps it in `.bss`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Kept {
    /// The low 32 bits of the instant.
    at: u32,
    /// Whether a deadline is kept at all.
    set: bool,
}

impl Kept {
    const NEVER: Self = Self { at: 0, set: false };

    /// The deadline at `at`, the low 32 bits of an instant.
    #[inline(always)]
    const fn at(at: u32) -> Self {
        Self { at, set: true }
    }

    /// The instant, given the clock it lies within 2³¹ µs of.
    #[inline(always)]
    fn get(self, clock: Instant) -> Instant {
        let ahead = self.at.wrapping_sub(clock.low32()) as i32;
        Instant::from_micros(clock.as_micros().wrapping_add_signed(ahead as i64))
    }

    /// The earlier of `self` and `t` (the low 32 bits of an instant near the clock).
    #[inline(always)]
    fn min(self, t: u32) -> Self {
        if !self.set || (t.wrapping_sub(self.at) as i32) < 0 {
            Self::at(t)
        } else {
            self
        }
    }

    /// Whether `now` (the low 32 bits of the clock) is at or past the kept instant (never for
    /// [`Kept::NEVER`]).
    #[inline(always)]
    fn passed(self, now: u32) -> bool {
        self.set && now.wrapping_sub(self.at) as i32 >= 0
    }

    /// After the clock jumped from `before` by `jump` µs (`before` and `now` their low 32
    /// bits; `jump` saturated at `u32::MAX`; a cold path, a jump past a multiple of 2³⁰ µs, so out of line): a
    /// deadline the jump reached or passed is kept as passed at `now`, so that it stays within
    /// reach of the clock whatever the jump (its exact instant no longer matters: the next
    /// call runs what falls due, at `now`).
    #[inline(never)]
    fn reach(self, before: u32, jump: u32, now: u32) -> Self {
        let ahead = self.at.wrapping_sub(before) as i32;
        if self.set && (ahead <= 0 || jump >= ahead as u32) {
            Self::at(now)
        } else {
            self
        }
    }
}

/// Per-key ages are clamped whenever the clock passes a multiple of this (half [`AGE_CAP`]).
const CLAMP_EVERY: u64 = 1 << 30;

/// How long a released key rests before it may strike again, in µs: the re-strike gap, but at
/// least 1 µs. A key released at some instant never strikes again at that same instant, even
/// with a zero gap: the release would never reach the boards (the frame would go 1, 0, 1
/// between two flushes), the finger would stay down, and its hold limit would restart from the
/// re-strike, so a note repeated faster than the limit could hold a solenoid on for ever.
fn rest_us(g: &GuardConfig) -> u32 {
    g.restrike_gap.as_micros().max(1)
}

/// Turns MIDI into finger-board outputs, safely.
///
/// `B` is the number of finger boards, `K` the most keys it can serve (the default, 61, is the
/// thesis's keyboard), `H` the store of held notes ([`NoteTable`] by default;
/// [`NotePool`](crate::NotePool) on small MCUs) and `C` where the configuration comes from
/// ([`Config`] itself by default; a constant such as [`Thesis`] on an MCU with a fixed robot,
/// see [`ConfigSource`]). The crate docs give the RAM figures.
///
/// Feed it bytes with [`feed`](Self::feed) (or decoded messages with
/// [`handle`](Self::handle)), call [`tick`](Self::tick) when no input arrives (at the latest at
/// [`next_deadline`](Self::next_deadline)), and hand the frame to the boards with
/// [`flush`](Self::flush). Every method takes the current time; the interpreter never reads a
/// clock. Time must not go backwards; an earlier time is taken as the latest one seen.
///
/// A key goes down when a note lands on it and up only when every note holding it has been
/// released: the same note on two channels, or two notes folded onto one key. A Note-On for a
/// note that is already on (the same channel and note, no Note-Off between) re-strikes the key,
/// unless the key struck less than the guard's `min_press` ago (then it joins that strike).
#[derive(Clone, Debug)]
pub struct Interpreter<
    const B: usize = 4,
    const K: usize = 61,
    H: HeldNotes = NoteTable,
    C: ConfigSource<B> = Config<B>,
> {
    config: Settings<B, C>,
    decoder: Decoder,
    /// The notes that are on, and the keys they hold.
    notes: H,
    fingers: Fingers<K>,
    frame: FingerFrame<B>,
    /// Channels whose sustain pedal is down.
    pedals: u16,
    /// The clock as last seen: its low 32 bits (all that the per-byte work uses)…
    clock: u32,
    /// … and its high 32 bits, kept apart so that the common step (a later time, no multiple
    /// of 2³⁰ µs passed) loads, compares and stores 4 bytes, not 8, on an 8-bit MCU.
    epoch: u32,
    /// When the last input arrived: the low 32 bits, clamped like the keys' stamps so that
    /// its age never wraps.
    last_input: u32,
    /// An Active Sensing byte was seen and the 300 ms rule is in force.
    sensing: bool,
    /// No per-key deadline falls before this ([`Kept::NEVER`] if none runs).
    due: Kept,
    /// The earliest time [`tick`](Self::tick) has anything to do ([`Kept::NEVER`]: nothing),
    /// kept up to date by [`refresh`](Self::refresh) at the end of every call that changes the
    /// state: with a key down or waiting, [`next_deadline`](Self::next_deadline); else `due`,
    /// or earlier when the Active Sensing rule would lapse.
    wake: Kept,
    #[cfg(feature = "stats")]
    stats: Stats,
    /// Strike outputs (one bit a key) whose note's Note-Off came and whose damper fires once
    /// their beater's pulse is over and no sustain pedal of their group holds.
    #[cfg(feature = "strike")]
    damp_due: [u8; 16],
    /// The fingered group's notes and phase ([`wind`](crate::wind)).
    #[cfg(feature = "wind")]
    wind_state: crate::wind::WindState,
    /// The duties last written to each board by [`flush_duties`](Self::flush_duties).
    #[cfg(feature = "dynamics")]
    duties: [[Duty; 16]; B],
}

impl Interpreter<4, 61> {
    /// The thesis's robot with orch's default guard.
    pub const fn thesis() -> Self {
        Self::unchecked(Config::THESIS)
    }
}

impl<H: HeldNotes> Interpreter<4, 61, H> {
    /// [`thesis`](Interpreter::thesis) with another store of held notes, as a `const fn`: an
    /// MCU keeps it in a `static`, built at compile time (built at run time it would pass
    /// through the stack, twice its size in a 1 KB SRAM).
    pub const fn thesis_with() -> Self {
        Self::unchecked(Config::THESIS)
    }
}

impl<H: HeldNotes> Interpreter<4, 61, H, Thesis> {
    /// [`thesis_with`](Interpreter::thesis_with) with the configuration a constant
    /// ([`Thesis`]): the same behaviour, no configuration in RAM, and the compiler folds the
    /// layout and the guard's limits into the code. Its initial state is all zero bits, so an
    /// MCU's `static` of it goes in `.bss` and takes no flash.
    pub const fn thesis_fixed() -> Self {
        Self::unchecked(Thesis)
    }
}

/// The interpreter's configuration, read through [`ConfigSource`].
#[derive(Clone, Debug)]
struct Settings<const B: usize, C>(C);

impl<const B: usize, C: ConfigSource<B>> core::ops::Deref for Settings<B, C> {
    type Target = Config<B>;
    #[inline(always)]
    fn deref(&self) -> &Config<B> {
        self.0.get()
    }
}

impl Default for Interpreter<4, 61> {
    fn default() -> Self {
        Self::thesis()
    }
}

impl<const B: usize, const K: usize, H: HeldNotes> Interpreter<B, K, H> {
    /// An interpreter for `config`, with every key up, at time zero.
    pub fn new(config: Config<B>) -> Result<Self, ConfigError> {
        config.validate(K)?;
        Ok(Self::unchecked(config))
    }
}

impl<const B: usize, const K: usize, H: HeldNotes, C: ConfigSource<B>> Interpreter<B, K, H, C> {
    const fn unchecked(config: C) -> Self {
        Self {
            config: Settings(config),
            decoder: Decoder::new(),
            notes: H::EMPTY,
            fingers: Fingers::new(),
            frame: FingerFrame::new(),
            pedals: 0,
            clock: 0,
            epoch: 0,
            last_input: 0,
            sensing: false,
            due: Kept::NEVER,
            wake: Kept::NEVER,
            #[cfg(feature = "stats")]
            stats: NO_STATS,
            #[cfg(feature = "strike")]
            damp_due: [0; 16],
            #[cfg(feature = "wind")]
            wind_state: crate::wind::WindState::NEW,
            #[cfg(feature = "dynamics")]
            duties: [[Duty::OFF; 16]; B],
        }
    }
}

/// Every count 0.
const NO_STATS: Stats = Stats {
    note_ons: 0,
    played: 0,
    folded: 0,
    folded_octaves: 0,
    dropped_channel: 0,
    dropped_percussion: 0,
    dropped_unmapped: 0,
    dropped_range: 0,
    dropped_power: 0,
    dropped_cancelled: 0,
    dropped_too_fast: 0,
    dropped_monophonic: 0,
    dropped_stopped: 0,
    joined: 0,
    restrikes_delayed: 0,
    cut_by_hold_limit: 0,
    cut_by_duty_limit: 0,
    cut_by_watchdog: 0,
    #[cfg(feature = "strike")]
    extras_skipped: 0,
    peak_keys_down: 0,
};

impl<const B: usize, const K: usize, H: HeldNotes, C: ConfigSource<B>> Interpreter<B, K, H, C> {
    /// The configuration.
    pub fn config(&self) -> &Config<B> {
        &self.config
    }

    /// The wanted outputs of every board.
    pub fn frame(&self) -> &FingerFrame<B> {
        &self.frame
    }

    /// The frame, to mark boards unknown after a bus error ([`FingerFrame::invalidate`]).
    pub fn frame_mut(&mut self) -> &mut FingerFrame<B> {
        &mut self.frame
    }

    /// What happened to the notes so far.
    ///
    /// Without the `stats` feature nothing is counted and every count is 0.
    pub fn stats(&self) -> &Stats {
        #[cfg(feature = "stats")]
        return &self.stats;
        #[cfg(not(feature = "stats"))]
        return &NO_STATS;
    }

    /// Counts into the statistics; nothing without the `stats` feature.
    #[inline(always)]
    fn count(&mut self, f: impl FnOnce(&mut Stats)) {
        #[cfg(feature = "stats")]
        f(&mut self.stats);
        #[cfg(not(feature = "stats"))]
        let _ = f;
    }

    /// The decoder's counters (bytes, messages, dropped, abandoned).
    pub fn counters(&self) -> Counters {
        self.decoder.counters()
    }

    /// Whether `key` (0 = lowest key) is down.
    pub fn is_down(&self, key: u8) -> bool {
        (key as usize) < K && self.fingers.phase(key) == DOWN
    }

    /// What `key` (0 = lowest key) is doing.
    pub fn key_phase(&self, key: u8) -> KeyPhase {
        if key as usize >= K {
            return KeyPhase::Up;
        }
        let g = &self.config.guard;
        match self.fingers.phase(key) {
            DOWN => KeyPhase::Down,
            PENDING => KeyPhase::Waiting,
            RELEASING if g.enabled && self.fingers.age(key, self.clock) < self.rest(key) => {
                KeyPhase::Resting
            }
            _ => KeyPhase::Up,
        }
    }

    /// How many keys are down.
    pub fn keys_down(&self) -> u8 {
        self.fingers.down
    }

    /// The velocity of the note that last struck `key`, for boards that can use it
    /// (on/off boards ignore it).
    pub fn velocity(&self, key: u8) -> Velocity {
        Velocity::from_bits(self.fingers.velocity(key))
    }

    /// The board that the Note-On or Note-Off now waiting for its last byte would write
    /// ([`Decoder::note_ahead`]), if its channel is played and its note lands on a key. Whether
    /// it will change anything is only known once the byte is in (the guard may drop the
    /// note, a Note-Off may end no note): a firmware may address the board on the bus ahead,
    /// hold the bus, and send the outputs if [`flush`](Self::flush) writes that board next,
    /// or end the transaction with no data if it does not.
    pub fn board_ahead(&self) -> Option<BoardId> {
        let (channel, note) = self.decoder.note_ahead()?;
        let key = self.route(channel, note).ok()?.key;
        let f = self.config.layout.finger(key)?;
        Some(BoardId {
            index: f.board,
            address: self.config.layout.boards[f.board as usize].address,
        })
    }

    /// Writes every board whose outputs changed. See [`FingerFrame::flush`].
    ///
    /// On/off outputs only: a robot with PWM boards flushes with
    /// [`flush_duties`](Self::flush_duties).
    pub fn flush<O: FingerBoards>(&mut self, out: &mut O) -> Result<u8, FlushError<O::Error>> {
        self.frame.flush(&self.config.layout, out)
    }

    /// The duty `key` (0 = lowest key) is driven at now: its strike duty within the strike
    /// time of its press, its hold duty after, 0 while it is not down (see
    /// [`dynamics`](crate::dynamics)). [`Duty::FULL`] for a key down with on/off dynamics.
    pub fn key_duty(&self, key: u8) -> Duty {
        if (key as usize) >= K || self.fingers.phase(key) != DOWN {
            return Duty::OFF;
        }
        #[cfg(feature = "dynamics")]
        return if self.is_strike(key) {
            // A strike's pulse is at its velocity's duty throughout: no hold.
            self.config
                .dynamics
                .touch(key)
                .strike_duty(self.velocity(key))
        } else {
            let duty = self.config.dynamics.duty_at(
                key,
                self.velocity(key),
                self.fingers.age(key, self.clock),
            );
            self.wind_breath(key, duty)
        };
        #[cfg(not(feature = "dynamics"))]
        return Duty::FULL;
    }

    /// `duty` scaled by the breath of the fingered group's note if `key` is its valve (high
    /// notes need more air): at least 1 where `duty` is above 0.
    #[cfg(feature = "dynamics")]
    fn wind_breath(&self, key: u8, duty: Duty) -> Duty {
        #[cfg(feature = "wind")]
        if self.config.wind.is_on() && key == self.config.wind.valve() {
            if let Some((_, index, ..)) = self.wind_state.target {
                let breath = self.config.wind.fingering(index).breath as u32;
                let scaled = (duty.get() as u32 * breath).div_ceil(4095);
                return Duty::new(scaled.min(4095) as u16).unwrap_or(duty);
            }
        }
        let _ = key;
        duty
    }

    /// Every board's 16 duties now ([`key_duty`](Self::key_duty) of each key on its output; outputs
    /// with no key are 0).
    pub fn duties(&self) -> [[Duty; 16]; B] {
        let mut all = [[Duty::OFF; 16]; B];
        for key in 0..self.keys() {
            if self.fingers.phase(key) != DOWN {
                continue;
            }
            if let Some(f) = self.config.layout.finger(key) {
                all[f.board as usize][f.bit as usize & 15] = self.key_duty(key);
            }
        }
        all
    }

    /// Writes the duties of every board whose duties changed since the last write (a key
    /// pressed, released, or moved from its strike to its hold), or that the frame says is
    /// dirty (after [`FingerFrame::invalidate`]), one
    /// [`write_duties`](FingerBoards::write_duties) each, in board order. Returns how many
    /// boards were written. On the first failure it stops; that board and the ones after it
    /// are written again by the next flush.
    ///
    /// For robots with PWM boards (needs the `dynamics` feature): call it where an on/off
    /// robot calls [`flush`](Self::flush), and also at [`next_deadline`](Self::next_deadline),
    /// which includes the end of each strike. On/off boards in the same set get their outputs
    /// through `write_duties`'s default (a duty above 0 is on), exactly as `flush` gives them.
    #[cfg(feature = "dynamics")]
    pub fn flush_duties<O: FingerBoards>(
        &mut self,
        out: &mut O,
    ) -> Result<u8, FlushError<O::Error>> {
        let wanted = self.duties();
        let mut n = 0;
        for (board, duties) in wanted.iter().enumerate() {
            if *duties == self.duties[board] && !self.frame.is_dirty(board) {
                continue;
            }
            let id = BoardId {
                index: board as u8,
                address: self.config.layout.boards[board].address,
            };
            out.write_duties(id, duties)
                .map_err(|error| FlushError { board: id, error })?;
            self.duties[board] = *duties;
            self.frame.mark_written(board);
            n += 1;
        }
        self.frame.untouch();
        Ok(n)
    }

    /// Feeds one received byte at time `now`.
    ///
    /// Returns whether anything beyond the decoder's state and the clock may have changed:
    /// `true` when the byte completed a message or the guard's timers ran (flush then, and ask
    /// [`next_deadline`](Self::next_deadline) again); `false` for a byte that only began or
    /// continued a message (a status byte, a first data byte, SysEx data), after which the
    /// frame and `next_deadline` are as they were. A firmware skips its flush check on those,
    /// two bytes of every three-byte message.
    pub fn feed(&mut self, byte: u8, now: Instant) -> bool {
        self.feed_with(byte, now, &mut ())
    }

    /// [`feed`](Self::feed), telling `sink` what became of each note ([`NoteEvent`]).
    pub fn feed_with<S: NoteSink>(&mut self, byte: u8, now: Instant, sink: &mut S) -> bool {
        self.advance(now);
        self.feed_now(byte, sink)
    }

    /// [`feed`](Self::feed) for an 8-bit MCU: `now` is the low 32 bits of the µs clock, and
    /// all the time arithmetic of a byte is 32-bit.
    ///
    /// Exact as long as the times passed to the `*_low32` methods (and to the others, if they
    /// are mixed) come less than 2³⁰ µs (17.8 minutes) apart: a firmware whose input may stay
    /// silent for longer calls [`tick_low32`](Self::tick_low32) now and then, say every
    /// second. A longer gap is taken as time running backwards or a shorter jump, which may
    /// keep a key resting or a deadline waiting for up to another 2³² µs.
    pub fn feed_low32(&mut self, byte: u8, now: u32) -> bool {
        self.advance_low32(now);
        self.feed_now(byte, &mut ())
    }

    /// [`feed_with`](Self::feed_with)'s work once the clock has moved.
    #[inline(always)]
    fn feed_now<S: NoteSink>(&mut self, byte: u8, sink: &mut S) -> bool {
        let mut changed = self.run_if_due(sink);
        let now = self.clock;
        self.last_input = now;
        // A byte completes at most two messages, and only when the first is a System
        // Exclusive message ended by a status byte; the second is then that byte's SysExStart
        // or Tune Request. None of those three acts on the robot, so only the last message
        // is kept and applied: one slot in registers, not a queue of two.
        let mut last = None;
        self.decoder.step(byte, &mut |m| last = Some(m));
        if let Some(message) = last {
            changed = true;
            self.apply(message, now, sink);
        }
        // A byte that completes no message moved only the last input, which moves the quiet
        // rules' deadline later: `wake` stays as it is, early rather than late (a tick then
        // finds nothing to do and sets it anew).
        if changed {
            self.refresh();
        }
        changed
    }

    /// Feeds bytes that all arrived at `now`.
    pub fn feed_slice(&mut self, bytes: &[u8], now: Instant) {
        self.feed_slice_with(bytes, now, &mut ());
    }

    /// [`feed_slice`](Self::feed_slice), telling `sink` what became of each note.
    pub fn feed_slice_with<S: NoteSink>(&mut self, bytes: &[u8], now: Instant, sink: &mut S) {
        for &byte in bytes {
            self.feed_with(byte, now, sink);
        }
    }

    /// Handles a message decoded elsewhere, received at `now`.
    pub fn handle(&mut self, message: Message, now: Instant) {
        self.handle_with(message, now, &mut ());
    }

    /// [`handle`](Self::handle), telling `sink` what became of each note.
    pub fn handle_with<S: NoteSink>(&mut self, message: Message, now: Instant, sink: &mut S) {
        self.tick_with(now, sink);
        let now = self.clock;
        self.last_input = now;
        self.apply(message, now, sink);
        self.refresh();
    }

    /// Releases every key now: for shutdown, panics and errors. Notes waiting to re-strike are
    /// cancelled (counted as stopped) and the sustain pedals let go. Flush afterwards to put it
    /// on the bus.
    pub fn all_off(&mut self, now: Instant) {
        self.all_off_with(now, &mut ());
    }

    /// [`all_off`](Self::all_off), telling `sink` about the notes that were waiting
    /// ([`NoteEvent::WaitEnded`] with [`DropReason::Stopped`]).
    pub fn all_off_with<S: NoteSink>(&mut self, now: Instant, sink: &mut S) {
        self.advance(now);
        let now = self.clock;
        self.release_everything(now, DropReason::Stopped, sink);
        self.refresh();
    }

    /// Says the input has ended or its line was lost (a port closed, a cable unplugged): a
    /// message it cut off is forgotten, and the running status with it, so that the bytes of
    /// a new connection are never joined to it. Returns whether it cut a message off
    /// ([`Decoder::finish`]). The keys are left as they are: [`all_off`](Self::all_off)
    /// releases them.
    #[must_use = "it says whether the end of the input cut a message off"]
    pub fn input_ended(&mut self) -> bool {
        self.decoder.finish()
    }

    /// When [`tick`](Self::tick) should next be called: the earliest hold limit, delayed
    /// re-strike, short press or watchdog deadline, or `None` if no timer is running.
    ///
    /// O(1): the per-key deadlines are kept as they change. The answer is never later than
    /// the first thing to do; it can be earlier (a key released in the meantime), in which case
    /// that tick does nothing and the next call answers anew.
    pub fn next_deadline(&self) -> Option<Instant> {
        // With no key down or waiting, the quiet rules have nothing to cut: only `due`.
        let busy = self.fingers.down + self.fingers.pending > 0;
        let deadline = if busy { self.wake } else { self.due };
        deadline.set.then(|| deadline.get(self.instant()))
    }

    /// [`next_deadline`](Self::next_deadline)'s low 32 bits, for the `*_low32` methods:
    /// compare it with the clock by wrapping difference (it lies less than 2³¹ µs from the
    /// clock as last seen, either way).
    pub fn next_deadline_low32(&self) -> Option<u32> {
        let busy = self.fingers.down + self.fingers.pending > 0;
        let deadline = if busy { self.wake } else { self.due };
        deadline.set.then_some(deadline.at)
    }

    /// Recomputes [`wake`](Self::wake) from `due`,
    /// `last_input`, `sensing` and the key counts: called at the end of every public method
    /// that can change them.
    fn refresh(&mut self) {
        let g = &self.config.guard;
        if !g.enabled {
            return;
        }
        let busy = self.fingers.down + self.fingers.pending > 0;
        let mut wake = self.due;
        if busy || self.sensing {
            // The watchdog and the Active Sensing rule, both counted from the last input:
            // the earlier of the two.
            let mut quiet = g.watchdog;
            if self.sensing {
                quiet =
                    Some(quiet.map_or(ACTIVE_SENSING_TIMEOUT, |wd| wd.min(ACTIVE_SENSING_TIMEOUT)));
            }
            if let Some(quiet) = quiet {
                wake = wake.min(self.last_input.wrapping_add(quiet.as_micros()));
            }
        }
        // Stored once (64-bit stores are dear on 8-bit MCUs).
        self.wake = wake;
    }

    /// Runs the guard's timers at `now`: hold limits, the duty limit, delayed re-strikes, the
    /// watchdog.
    pub fn tick(&mut self, now: Instant) {
        self.tick_with(now, &mut ());
    }

    /// [`tick`](Self::tick), telling `sink` about delayed strikes that happen
    /// ([`NoteEvent::WaitOver`]) or are cancelled.
    #[inline]
    pub fn tick_with<S: NoteSink>(&mut self, now: Instant, sink: &mut S) {
        self.tick_due(now, sink);
    }

    /// [`tick`](Self::tick) for an 8-bit MCU, with the low 32 bits of the µs clock: see
    /// [`feed_low32`](Self::feed_low32) for how far apart the times may be. Returns whether
    /// the guard's timers ran (flush then, and ask for the next deadline again).
    pub fn tick_low32(&mut self, now: u32) -> bool {
        self.advance_low32(now);
        self.run_if_due(&mut ())
    }

    /// [`tick_with`](Self::tick_with), saying whether the guard's timers ran.
    #[inline(always)]
    fn tick_due<S: NoteSink>(&mut self, now: Instant, sink: &mut S) -> bool {
        self.advance(now);
        self.run_if_due(sink)
    }

    /// Runs the guard's timers if `wake` has passed, saying whether they ran.
    #[inline(always)]
    fn run_if_due<S: NoteSink>(&mut self, sink: &mut S) -> bool {
        // Nothing can be due before `wake`: one compare on every byte fed (inlined there; the
        // timers' work is not).
        let due = self.wake.passed(self.clock);
        if due {
            self.run_due(sink);
        }
        due
    }

    /// [`tick_with`](Self::tick_with)'s work once `wake` has passed.
    #[inline(never)]
    fn run_due<S: NoteSink>(&mut self, sink: &mut S) {
        self.run_timers(sink, false);
        self.refresh();
    }

    /// [`tick`](Self::tick) the slow, straightforward way, as a reference for tests: no
    /// early return before the kept deadlines, and every key visited. It must leave the
    /// interpreter exactly as `tick` would. Not for use outside tests.
    #[doc(hidden)]
    pub fn tick_exhaustive_with<S: NoteSink>(&mut self, now: Instant, sink: &mut S) {
        self.advance(now);
        self.run_timers(sink, true);
        self.refresh();
    }

    /// [`tick_with`](Self::tick_with)'s work once `wake` has passed; with `every_key`, ignores
    /// `due` and the timed-key mask (the reference for tests).
    fn run_timers<S: NoteSink>(&mut self, sink: &mut S, every_key: bool) {
        let now = self.clock;
        let g = &self.config.guard;
        if !g.enabled {
            return;
        }
        let busy = self.fingers.down + self.fingers.pending > 0;
        let quiet = now.wrapping_sub(self.last_input);
        let starved = g.watchdog.is_some_and(|wd| quiet >= wd.as_micros())
            || (self.sensing && quiet >= ACTIVE_SENSING_TIMEOUT.as_micros());
        if starved {
            self.sensing = false;
            if busy {
                let down = self.fingers.down as u32;
                self.count(|s| s.cut_by_watchdog += down);
                self.release_everything(now, DropReason::Cancelled, sink);
            }
        }
        if !self.due.passed(now) && !every_key {
            return;
        }
        let g = &self.config.guard;
        let hold = g.max_hold.map(Duration::as_micros);
        // The next per-key deadline, in µs from now.
        // (`u32::MAX`: none. No timer is that long: every limit is at most `MAX_LIMIT`, and a
        // key struck with no limit at all has no deadline. One compare where an `Option` took
        // four copies of its code on an 8-bit MCU.)
        let mut next = u32::MAX;
        let mut soonest = |t: u32| next = next.min(t);
        // Only keys down or waiting have timers; a released key needs no visit (its rest is
        // measured from its stamp when a note comes).
        let mut from = 0;
        loop {
            let key = if every_key {
                match (from < self.keys()).then_some(from) {
                    Some(k) if !matches!(self.fingers.phase(k), DOWN | PENDING) => {
                        from += 1;
                        continue;
                    }
                    k => k,
                }
            } else {
                self.fingers.next_timed(from)
            };
            let Some(key) = key else { break };
            from = key + 1;
            let age = self.fingers.age(key, now);
            let min_press = self.press_len(key);
            if self.fingers.phase(key) == DOWN {
                let duty = self.duty_cut_after(key);
                let short = self.fingers.has(key, RELEASE_AFTER);
                let cut_by_hold = hold.is_some_and(|h| age >= h);
                let cut_by_duty = !cut_by_hold && duty.is_some_and(|d| age >= d);
                if cut_by_hold || cut_by_duty {
                    if cut_by_hold {
                        self.count(|s| s.cut_by_hold_limit += 1);
                    } else {
                        self.count(|s| s.cut_by_duty_limit += 1);
                    }
                    self.forget_key(key);
                    // A finger or the valve: the whole group stops, the valve with it.
                    #[cfg(feature = "wind")]
                    if self.config.is_wind(key) {
                        self.wind_cut(now, sink);
                    }
                }
                if cut_by_hold || cut_by_duty || (short && age >= min_press) {
                    self.release_now(key, now);
                    // A bar whose Note-Off came while its beater struck: its damper now.
                    #[cfg(feature = "strike")]
                    if let Some(limit) = self.try_damp(key, now) {
                        soonest(limit);
                    }
                } else {
                    let mut limit = hold.unwrap_or(u32::MAX).min(duty.unwrap_or(u32::MAX));
                    if short {
                        limit = limit.min(min_press);
                    }
                    let strike_end = self.strike_end(key);
                    if age < strike_end {
                        limit = limit.min(strike_end);
                    }
                    if limit != u32::MAX {
                        soonest(limit - age);
                    }
                }
            } else if age >= self.rest(key) {
                // PENDING: the rest is over, it strikes.
                let folded = self.fingers.has(key, FOLDED);
                self.count_sounded(folded);
                self.press_now(key, now);
                self.fingers.set_flag(key, LATE, true);
                sink.note(NoteEvent::WaitOver { key });
                let mut limit = hold.unwrap_or(u32::MAX);
                limit = limit.min(self.duty_cut_after(key).unwrap_or(u32::MAX));
                limit = limit.min(self.strike_end(key));
                if self.fingers.has(key, RELEASE_AFTER) {
                    limit = limit.min(min_press);
                }
                soonest(limit);
            } else {
                soonest(self.rest(key) - age);
            }
        }
        #[cfg(feature = "wind")]
        if let Some(t) = self.wind_timers(now, sink) {
            next = next.min(t);
        }
        self.due = if next == u32::MAX {
            Kept::NEVER
        } else {
            Kept::at(now.wrapping_add(next))
        };
    }

    fn keys(&self) -> u8 {
        self.config.keys() as u8
    }

    /// Whether `key` is a strike group's output ([`strike`](crate::strike)): its press is a
    /// pulse that ends by itself.
    #[inline(always)]
    fn is_strike(&self, key: u8) -> bool {
        self.config.is_strike(key)
    }

    /// How long a press of `key` flagged `RELEASE_AFTER` lasts, in µs: a strike output's
    /// pulse at its velocity (never past the guard's `max_pulse`), a key's `min_press`.
    #[inline(always)]
    fn press_len(&self, key: u8) -> u32 {
        #[cfg(feature = "strike")]
        if self.is_strike(key) {
            let pulse = self.config.strikes.pulse(key).length(self.velocity(key));
            return pulse.min(self.config.guard.max_pulse).as_micros();
        }
        let _ = key;
        self.config.guard.min_press.as_micros()
    }

    /// How long after its stamp a released `key` rests before it may strike again, in µs:
    /// the guard's re-strike gap (at least 1 µs) from its release for a key; for a strike
    /// output its rebound from its last strike (a strike output keeps its strike's stamp
    /// when its pulse ends or is cut: see [`release_now`](Self::release_now)).
    #[inline(always)]
    fn rest(&self, key: u8) -> u32 {
        #[cfg(feature = "strike")]
        if self.is_strike(key) {
            return self.config.strikes.pulse(key).rebound.as_micros().max(1);
        }
        let _ = key;
        rest_us(&self.config.guard)
    }

    /// The clock as last seen.
    #[inline(always)]
    fn instant(&self) -> Instant {
        Instant::from_micros(((self.epoch as u64) << 32) | self.clock as u64)
    }

    /// Moves the clock to `now` (never back) and keeps per-key ages from wrapping.
    #[inline(always)]
    fn advance(&mut self, now: Instant) {
        let before = self.instant();
        if now <= before {
            return;
        }
        self.clock = now.low32();
        self.epoch = (now.as_micros() >> 32) as u32;
        // Passed a multiple of 2³⁰ µs: the bits above differ.
        if now.as_micros() ^ before.as_micros() >= CLAMP_EVERY {
            self.clamp_ages(before, now);
        }
    }

    /// [`advance`](Self::advance) given the clock's low 32 bits, less than 2³⁰ µs after the
    /// clock as last seen (see [`feed_low32`](Self::feed_low32)): 4-byte loads, compares and
    /// stores on the common step.
    #[inline(always)]
    fn advance_low32(&mut self, now: u32) {
        let before = self.clock;
        if now.wrapping_sub(before) as i32 <= 0 {
            return;
        }
        self.clock = now;
        // Passed a multiple of 2³⁰ µs: bit 30 or 31 differs.
        if now ^ before >= CLAMP_EVERY as u32 {
            self.passed_low32(before);
        }
    }

    /// [`advance_low32`](Self::advance_low32)'s cold path: the high bits follow a wrap of the
    /// low ones, and the ages are clamped.
    #[cold]
    #[inline(never)]
    fn passed_low32(&mut self, before: u32) {
        let now = self.clock;
        if now < before {
            self.epoch = self.epoch.wrapping_add(1);
        }
        // Less than 2³¹ µs (the cap): the jump in 32 bits.
        self.clamp_ages_low32(before, now, now.wrapping_sub(before));
    }

    /// Keeps per-key ages from wrapping, when the clock moved from `before` to `now` past a
    /// multiple of 2³⁰ µs.
    #[cold]
    #[inline(never)]
    fn clamp_ages(&mut self, before: Instant, now: Instant) {
        // In 32 bits from here: a jump of at least the cap reaches everything.
        let jump = now.saturating_since(before);
        let jump = if jump >= AGE_CAP as u64 {
            u32::MAX
        } else {
            jump as u32
        };
        self.clamp_ages_low32(before.low32(), now.low32(), jump);
    }

    /// [`clamp_ages`](Self::clamp_ages) with the low 32 bits of the times, and the jump
    /// saturated at `u32::MAX` (kept apart, so that an MCU fed the `*_low32` methods has no
    /// 64-bit arithmetic here).
    #[cold]
    #[inline(never)]
    fn clamp_ages_low32(&mut self, before: u32, now: u32, jump: u32) {
        // Ages are clamped well before they could wrap: whenever the clock jumps by at least
        // the cap (everything is old), and at least once every cap/2 of clock time (when it
        // passes a multiple of 2³⁰ µs). Ages can be up to 1.5 × cap just before a clamp, so a
        // jump of up to a cap on top of that would wrap 32 bits: clamp at the time before the
        // jump first.
        let far = jump >= AGE_CAP;
        self.fingers.clamp_ages(before, now, far);
        self.last_input = clamp_across(self.last_input, before, now, far);
        // The kept deadlines: one the jump reached is passed, at `now`.
        self.due = self.due.reach(before, jump, now);
        self.wake = self.wake.reach(before, jump, now);
    }

    /// The duty limit, if any. Always `None` without the `duty-limit` feature (a configuration
    /// with one is refused then), so its arithmetic (64-bit multiplications and divisions, 4 KB
    /// of AVR code) is left out of the build.
    #[inline(always)]
    fn duty(&self) -> Option<DutyLimit> {
        if cfg!(feature = "duty-limit") {
            self.config.guard.duty
        } else {
            None
        }
    }

    /// How long after its press `key` (down or about to strike) moves from its strike duty to
    /// a lower hold duty, in µs; `u32::MAX` if it does not (on/off, or no `dynamics`).
    #[inline(always)]
    fn strike_end(&self, key: u8) -> u32 {
        #[cfg(feature = "dynamics")]
        if !self.is_strike(key) {
            let d = &self.config.dynamics;
            let touch = d.touch(key);
            if touch.strike_duty(self.velocity(key)) != touch.hold {
                return d.strike.as_micros();
            }
        }
        let _ = key;
        u32::MAX
    }

    /// Whether the keys' current differs from their count (some key plays below 100 %).
    #[inline(always)]
    #[cfg(feature = "dynamics")]
    fn by_current(&self) -> bool {
        !self.config.dynamics.is_on_off()
    }

    #[cfg(feature = "dynamics")]
    /// The present current of every key down or waiting to strike, in 4095ths of one key at
    /// full power (a waiting key counts its strike to come).
    fn current(&self) -> u32 {
        let mut sum = 0;
        let mut from = 0;
        while let Some(key) = self.fingers.next_timed(from) {
            from = key + 1;
            sum += self.key_current(key) as u32;
        }
        sum
    }

    #[cfg(feature = "dynamics")]
    /// The current of one key down (its duty now) or waiting (its strike to come).
    fn key_current(&self, key: u8) -> u16 {
        match self.fingers.phase(key) {
            DOWN => self.key_duty(key).get(),
            PENDING => self
                .config
                .dynamics
                .touch(key)
                .strike_duty(self.velocity(key))
                .get(),
            _ => 0,
        }
    }

    /// How long after its press the duty limit cuts `key` (down), from its heat at the
    /// press; `None` without a duty limit, or if it never would (held below the duty).
    fn duty_cut_after(&self, key: u8) -> Option<u32> {
        #[cfg(feature = "dynamics")]
        if self.by_current() {
            return self.duty_cut_after_by_energy(key);
        }
        let d = self.duty()?;
        let (on, window) = (d.max_on.as_micros() as u64, d.window.as_micros() as u64);
        if on >= window {
            return None;
        }
        let heat = self.fingers.heat_ms(key) as u64 * 1000;
        // Heat rises at (1 − on/window) while the key is down.
        let left = on.saturating_sub(heat);
        Some((left * window / (window - on)).min(u32::MAX as u64) as u32)
    }

    #[cfg(feature = "dynamics")]
    /// [`duty_cut_after`](Self::duty_cut_after) with dynamics: the key heats at its strike
    /// duty less the allowed duty for the strike time, then at its hold duty less it.
    fn duty_cut_after_by_energy(&self, key: u8) -> Option<u32> {
        let d = self.duty()?;
        let full = Duty::FULL.get() as u64;
        // The allowed duty in 4095ths, rounded down: the key heats a little faster than
        // exactly, so a cut never comes later than the exact one (at most 1/4095 of full
        // power earlier). 64-bit arithmetic throughout: a Cortex-M0+ has no 128-bit divide.
        let allowed = d.max_on.as_micros() as u64 * full / (d.window.as_micros() as u64).max(1);
        let dynamics = &self.config.dynamics;
        let touch = dynamics.touch(key);
        let strike_duty = touch.strike_duty(self.velocity(key)).get() as u64;
        // A strike output has no hold: its pulse is at its strike duty to the end.
        let hold_duty = if self.is_strike(key) {
            strike_duty
        } else {
            touch.hold.get() as u64
        };
        let s = dynamics.strike.as_micros() as u64;
        // Heat in µs at full power: a key at duty `x` (4095ths) adds (x − allowed) / 4095 µs
        // of it each µs.
        let on = d.max_on.as_micros() as u64;
        let heat = self.fingers.heat_ms(key) as u64 * 1000;
        // µs until `left` more heat at `rate` 4095ths over the allowed (rounded down: early).
        let reach = |left: u64, rate: u64| (rate > 0).then(|| left * full / rate);
        if let Some(t) = reach(on.saturating_sub(heat), strike_duty.saturating_sub(allowed)) {
            if t <= s {
                return Some(t.min(u32::MAX as u64) as u32);
            }
        }
        // After the strike: the heat it left (rounded up), then the hold.
        let after = if strike_duty >= allowed {
            heat + (s * (strike_duty - allowed)).div_ceil(full)
        } else {
            heat.saturating_sub(s * (allowed - strike_duty) / full)
        };
        reach(on.saturating_sub(after), hold_duty.saturating_sub(allowed))
            .map(|t| (s + t).min(u32::MAX as u64) as u32)
    }

    fn apply<S: NoteSink>(&mut self, message: Message, now: u32, sink: &mut S) {
        match message {
            Message::NoteOn {
                channel,
                note,
                velocity,
            } if velocity.get() > 0 => self.note_on(channel, note, velocity, now, sink),
            Message::NoteOn { channel, note, .. } | Message::NoteOff { channel, note, .. } => {
                self.note_off(channel, note, now)
            }
            Message::ControlChange {
                channel,
                controller,
                value,
            } => match controller.get() {
                64 if self.config.sustain => {
                    if value.get() >= 64 {
                        self.pedals |= channel.bit();
                    } else {
                        self.pedal_up(channel, now);
                    }
                }
                // Reset All Controllers lets the pedal up.
                121 => self.pedal_up(channel, now),
                // All Sound Off: silence now, the pedal's notes too.
                120 => self.channel_off(channel, true, now),
                // All Notes Off, and the mode messages that imply it: like a Note-Off for each
                // note, so a pedal that is down keeps them sustained (MIDI 1.0).
                123..=127 => self.channel_off(channel, false, now),
                _ => {}
            },
            Message::ActiveSensing => self.sensing = true,
            Message::Reset => {
                self.sensing = false;
                self.release_everything(now, DropReason::Cancelled, sink);
            }
            _ => {}
        }
    }

    /// Whether striking `key` at `velocity` now would pass the power budget (`busy`: the
    /// key is down or waiting already, and its strike takes its place).
    fn over_budget(&self, key: u8, velocity: Velocity, busy: bool) -> bool {
        let g = self.config.guard;
        #[cfg(feature = "dynamics")]
        if self.by_current() {
            // The budget is a current: every key's duty now, this strike's in place of the
            // key's own if it is down or waiting.
            let strike = self.config.dynamics.touch(key).strike_duty(velocity).get() as u32;
            let rest = self.current()
                - if busy {
                    self.key_current(key) as u32
                } else {
                    0
                };
            return g.enabled && rest + strike > g.max_keys_down as u32 * Duty::FULL.get() as u32;
        }
        let _ = (key, velocity);
        !busy && g.enabled && self.fingers.down + self.fingers.pending >= g.max_keys_down
    }

    #[inline(always)]
    fn route(&self, channel: Channel, note: Note) -> Result<KeyOf, DropReason> {
        self.config.land(channel, note)
    }

    fn note_on<S: NoteSink>(
        &mut self,
        channel: Channel,
        note: Note,
        velocity: Velocity,
        now: u32,
        sink: &mut S,
    ) {
        self.count(|s| s.note_ons += 1);
        let drop = |sink: &mut S, at: Option<Landing>, reason| {
            sink.note(NoteEvent::Dropped {
                channel,
                note,
                at,
                reason,
            })
        };
        let (key, octaves) = match self.route(channel, note) {
            Ok(KeyOf { key, octaves }) => (key, octaves),
            Err(reason) => {
                self.count(|s| match reason {
                    DropReason::Channel => s.dropped_channel += 1,
                    DropReason::Percussion => s.dropped_percussion += 1,
                    DropReason::Unmapped => s.dropped_unmapped += 1,
                    _ => s.dropped_range += 1,
                });
                drop(sink, None, reason);
                return;
            }
        };
        let at = Landing { key, octaves };
        #[cfg(feature = "wind")]
        if self.config.is_wind(key) {
            self.wind_note_on(channel, note, velocity, at, now, sink);
            return;
        }
        let folded = octaves != 0;
        if folded {
            self.count(|s| s.folded_octaves += octaves.unsigned_abs() as u32);
        }
        let g = self.config.guard;
        let repeated = self.notes.contains(channel, note);
        let phase = self.fingers.phase(key);
        let busy = phase == DOWN || phase == PENDING;
        // A note arriving less than `min_press` after its key struck (the same note doubled in
        // two tracks of a score, or two notes folded onto one key, arriving together or a few
        // bytes apart) joins the strike: striking again before the key has even sounded would
        // only cut it short. So does one arriving while the key waits to strike.
        let with_strike = phase == PENDING
            || (phase == DOWN && g.enabled && self.fingers.age(key, now) < g.min_press.as_micros());
        let joins = with_strike || (!repeated && self.config.overlap == Overlap::Hold);
        if busy && self.is_strike(key) {
            // A strike arriving while its beater's pulse is on, or while it waits to strike,
            // is the same hit.
            #[cfg(feature = "strike")]
            self.set_damp_due(key, false);
            self.count_sounded(folded);
            self.count(|s| s.joined += 1);
            sink.note(NoteEvent::Joined {
                channel,
                note,
                at,
                with_strike: true,
            });
            return;
        }
        if busy && joins && self.played(key) {
            // Another note holds the key already: this one joins it.
            if self.notes.insert(channel, note, key) {
                self.count_sounded(folded);
                self.count(|s| s.joined += 1);
                sink.note(NoteEvent::Joined {
                    channel,
                    note,
                    at,
                    with_strike,
                });
            } else {
                self.count(|s| s.dropped_power += 1);
                drop(sink, Some(at), DropReason::Power);
            }
            return;
        }
        // A fresh strike, or a re-strike of a key that is down (by the pedal, by this very
        // note again, or by another note under `Overlap::Restrike`) or waiting.
        if self.over_budget(key, velocity, busy) {
            self.count(|s| s.dropped_power += 1);
            drop(sink, Some(at), DropReason::Power);
            return;
        }
        // How long the strike would wait for the key's rest.
        let wait = match phase {
            _ if !g.enabled => 0,
            DOWN => self.rest(key),
            RELEASING | PENDING => self.rest(key).saturating_sub(self.fingers.age(key, now)),
            _ => 0,
        };
        if g.late_limit.is_some_and(|l| wait > l.as_micros()) {
            // It could not sound within the late limit: the key stays as it is.
            self.count(|s| s.dropped_too_fast += 1);
            drop(sink, Some(at), DropReason::TooFast);
            return;
        }
        // A strike's note is no key's: its pulse ends by itself and its Note-Off does nothing.
        if !self.is_strike(key) && !self.notes.insert(channel, note, key) {
            self.count(|s| s.dropped_power += 1);
            drop(sink, Some(at), DropReason::Power);
            return;
        }
        // A new note on a bar: an earlier note's Note-Off no longer damps it.
        #[cfg(feature = "strike")]
        self.set_damp_due(key, false);
        #[cfg(feature = "strike")]
        if let Some((lead, time)) = self.lead_of(key, channel, note) {
            // An open hi-hat: the lift fires now (at full power: a soft note must still open
            // the cymbals), the stick when the lift's time has passed (or its rebound, if
            // that is later).
            self.fire(lead, Velocity::MAX, now);
            self.fingers.set_velocity(key, velocity.get());
            self.strike_after(key, folded, time.as_micros(), now);
            sink.note(NoteEvent::Leading { channel, note, at });
            return;
        }
        if phase == PENDING {
            // Still waiting: the earlier note's strike is taken over by this note.
            self.count(|s| s.dropped_cancelled += 1);
            sink.note(NoteEvent::WaitEnded {
                key,
                reason: DropReason::Cancelled,
            });
            sink.note(NoteEvent::Waiting { channel, note, at });
            self.fingers.set_velocity(key, velocity.get());
            self.fingers.set_flag(key, FOLDED, folded);
            self.fingers
                .set_flag(key, RELEASE_AFTER, self.is_strike(key));
            return;
        }
        if phase == DOWN {
            self.release_now(key, now);
        }
        self.fingers.set_velocity(key, velocity.get());
        if self.strike(key, folded, now) {
            sink.note(NoteEvent::Struck { channel, note, at });
        } else {
            sink.note(NoteEvent::Waiting { channel, note, at });
        }
    }

    fn note_off(&mut self, channel: Channel, note: Note, now: u32) {
        if self.group_note_off(channel, note, now) {
            return;
        }
        let pedal = self.config.sustain && self.pedals & channel.bit() != 0;
        let was_on = if pedal {
            // The pedal holds the note (and its key) until it goes up.
            self.notes.sustain(channel, note)
        } else {
            self.notes.remove(channel, note)
        };
        if !was_on || pedal {
            return;
        }
        if let Some(of) = self.config.range.key_for(note, self.config.out_of_range) {
            if !self.held(of.key) {
                self.release_key(of.key, now);
            }
        }
    }

    /// A Note-Off that a strike group (its damper) or the fingered group takes: whether it
    /// took it. The note is routed once.
    #[cfg(any(feature = "strike", feature = "wind"))]
    fn group_note_off(&mut self, channel: Channel, note: Note, now: u32) -> bool {
        let Ok(KeyOf { key, .. }) = self.route(channel, note) else {
            return false;
        };
        #[cfg(feature = "wind")]
        if self.config.is_wind(key) {
            self.wind_note_off(note, now);
            return true;
        }
        #[cfg(feature = "strike")]
        if self.is_strike(key) {
            if self.config.strikes.damper(key).is_some() {
                self.set_damp_due(key, true);
                self.try_damp(key, now);
            }
            return true;
        }
        let _ = (key, now);
        false
    }

    /// Without strike or fingered groups every Note-Off is the keyboard's.
    #[cfg(not(any(feature = "strike", feature = "wind")))]
    #[inline(always)]
    fn group_note_off(&mut self, _channel: Channel, _note: Note, _now: u32) -> bool {
        false
    }

    fn pedal_up(&mut self, channel: Channel, now: u32) {
        self.pedals &= !channel.bit();
        self.notes.release_sustained(channel);
        self.release_unheld(now);
        #[cfg(feature = "strike")]
        for byte in 0..self.damp_due.len() {
            // Only bars whose Note-Off came wait for the pedal: one bit a key.
            let mut bits = self.damp_due[byte];
            while bits != 0 {
                let key = (byte * 8) as u8 + bits.trailing_zeros() as u8;
                bits &= bits - 1;
                self.try_damp(key, now);
            }
        }
    }

    /// Switches off every note of `channel`. All Sound Off (`sound_off`) lets go of the
    /// pedal's notes as well; All Notes Off leaves a pedal that is down holding them, as
    /// each note's own Note-Off would.
    fn channel_off(&mut self, channel: Channel, sound_off: bool, now: u32) {
        #[cfg(feature = "wind")]
        if self.config.wind.is_on() && self.config.wind.channels.contains(channel) {
            self.wind_all_notes_off(now);
        }
        let pedal = self.config.sustain && self.pedals & channel.bit() != 0;
        if pedal && !sound_off {
            self.notes.sustain_channel(channel);
        } else {
            self.notes.remove_channel(channel);
            self.pedals &= !channel.bit();
        }
        self.release_unheld(now);
    }

    /// Lets go of every key that no note holds any more.
    fn release_unheld(&mut self, now: u32) {
        for key in 0..self.keys() {
            let phase = self.fingers.phase(key);
            // A key striking for `min_press` (RELEASE_AFTER) is no note's any more: it lets
            // go by itself.
            let busy = (phase == DOWN || phase == PENDING)
                && !self.fingers.has(key, RELEASE_AFTER)
                && !self.is_strike(key)
                && !self.config.is_wind(key);
            if busy && !self.held(key) {
                self.release_key(key, now);
            }
        }
    }

    fn release_everything<S: NoteSink>(&mut self, now: u32, why: DropReason, sink: &mut S) {
        self.notes.clear();
        self.pedals = 0;
        #[cfg(feature = "strike")]
        {
            self.damp_due = [0; 16];
        }
        #[cfg(feature = "wind")]
        self.wind_reset(why, sink);
        // Only keys down or waiting have anything to release or cancel.
        let mut from = 0;
        while let Some(key) = self.fingers.next_timed(from) {
            from = key + 1;
            self.cancel_key(key, now, why, sink);
        }
        self.frame.clear();
    }

    /// Whether any note still holds `key`, played or sustained by the pedal.
    fn held(&self, key: u8) -> bool {
        self.notes
            .holds_key(key, self.config.range, self.config.out_of_range, true)
    }

    /// Whether a played note (not only the pedal) holds `key`.
    fn played(&self, key: u8) -> bool {
        self.notes
            .holds_key(key, self.config.range, self.config.out_of_range, false)
    }

    /// Forgets every note holding `key` (after the guard cut it), so its Note-Offs are no-ops
    /// and the next Note-On strikes afresh.
    fn forget_key(&mut self, key: u8) {
        self.notes
            .remove_key(key, self.config.range, self.config.out_of_range);
    }

    /// Strikes `key` now (`true`), or once its re-strike gap has passed (`false`).
    fn strike(&mut self, key: u8, folded: bool, now: u32) -> bool {
        let g = self.config.guard;
        let resting = self.fingers.phase(key) == RELEASING
            && g.enabled
            && self.fingers.age(key, now) < self.rest(key);
        if resting {
            let wait = self.rest(key) - self.fingers.age(key, now);
            self.fingers.set_phase(key, PENDING);
            self.fingers.set_flag(key, FOLDED, folded);
            self.count(|s| s.restrikes_delayed += 1);
            self.due = self.due.min(now.wrapping_add(wait));
            false
        } else {
            self.count_sounded(folded);
            self.press_now(key, now);
            self.arm(key, now);
            true
        }
    }

    /// Sets the guard's next deadline for `key`, pressed now; returns it, in µs from now
    /// (`u32::MAX`: none).
    fn arm(&mut self, key: u8, now: u32) -> u32 {
        let g = self.config.guard;
        let mut limit = g
            .max_hold
            .map_or(u32::MAX, Duration::as_micros)
            .min(self.duty_cut_after(key).unwrap_or(u32::MAX))
            .min(self.strike_end(key));
        if self.is_strike(key) {
            limit = limit.min(self.press_len(key));
        }
        if g.enabled && limit != u32::MAX {
            self.due = self.due.min(now.wrapping_add(limit));
        }
        limit
    }

    /// The lead output of a note that strikes `key`, and its lead time.
    #[cfg(feature = "strike")]
    fn lead_of(&self, key: u8, channel: Channel, note: Note) -> Option<(u8, Duration)> {
        if !self.is_strike(key) || !self.config.guard.enabled {
            return None;
        }
        self.config.strikes.lead(channel, note)
    }

    /// Fires `out` (a lead or a damper: no note's) for its pulse now, if its rebound has
    /// passed and the power budget allows; else counts it skipped. Returns its deadline, in
    /// µs from now.
    #[cfg(feature = "strike")]
    fn fire(&mut self, out: u8, velocity: Velocity, now: u32) -> Option<u32> {
        let phase = self.fingers.phase(out);
        let rested = phase == crate::fingers::READY
            || (phase == RELEASING && self.fingers.age(out, now) >= self.rest(out));
        if !rested || self.over_budget(out, velocity, false) {
            self.count(|s| s.extras_skipped += 1);
            return None;
        }
        self.fingers.set_velocity(out, velocity.get());
        self.press_now(out, now);
        Some(self.arm(out, now))
    }

    /// Makes strike output `key` (up) strike `delay` µs from now, or when its rebound is
    /// over if that is later: it waits as a re-strike does (`PENDING`), stamped so that its
    /// rest ends then. The stamp moves no earlier than the last strike's, so the key's
    /// cooling is never overstated.
    #[cfg(feature = "strike")]
    fn strike_after(&mut self, key: u8, folded: bool, delay: u32, now: u32) {
        let rest = self.rest(key);
        let wait = match self.fingers.phase(key) {
            RELEASING => rest.saturating_sub(self.fingers.age(key, now)),
            _ => 0,
        };
        let delay = delay.max(wait).min(rest);
        self.fingers
            .enter(key, PENDING, now.wrapping_sub(rest - delay));
        self.fingers.set_flag(key, FOLDED, folded);
        self.due = self.due.min(now.wrapping_add(delay));
    }

    /// Marks `key`'s damper as due (its note's Note-Off came) or not.
    #[cfg(feature = "strike")]
    fn set_damp_due(&mut self, key: u8, due: bool) {
        let (byte, bit) = (key as usize / 8 % 16, 1u8 << (key % 8));
        if due {
            self.damp_due[byte] |= bit;
        } else {
            self.damp_due[byte] &= !bit;
        }
    }

    /// Fires `key`'s damper if it is due, its beater is off and no sustain pedal of its
    /// group holds. Returns the damper's deadline, in µs from now, if it fired.
    #[cfg(feature = "strike")]
    fn try_damp(&mut self, key: u8, now: u32) -> Option<u32> {
        let (byte, bit) = (key as usize / 8 % 16, 1u8 << (key % 8));
        if self.damp_due[byte] & bit == 0 || matches!(self.fingers.phase(key), DOWN | PENDING) {
            return None;
        }
        let strikes = &self.config.strikes;
        let channels = strikes.group_of(key).map_or(0, |g| g.channels.0);
        if self.config.sustain && self.pedals & channels != 0 {
            return None;
        }
        let damper = strikes.damper(key)?;
        self.damp_due[byte] &= !bit;
        self.fire(damper, Velocity::MAX, now)
    }

    fn count_sounded(&mut self, folded: bool) {
        if folded {
            self.count(|s| s.folded += 1);
        } else {
            self.count(|s| s.played += 1);
        }
    }

    fn press_now(&mut self, key: u8, now: u32) {
        if let Some(d) = self.duty() {
            // The key cooled at the duty while it was up.
            let up = self.fingers.age(key, now) as u64;
            let cooled = up * d.max_on.as_micros() as u64 / d.window.as_micros().max(1) as u64;
            let heat = (self.fingers.heat_ms(key) as u64 * 1000).saturating_sub(cooled);
            self.fingers.set_heat_ms(key, heat / 1000);
        }
        self.fingers.enter(key, DOWN, now);
        self.fingers.set_flag(key, FOLDED, false);
        if self.is_strike(key) {
            // A strike's pulse ends by itself, whatever its note does.
            self.fingers.set_flag(key, RELEASE_AFTER, true);
            // A bar's damper is never on while its beater strikes.
            #[cfg(feature = "strike")]
            if let Some(d) = self.config.strikes.damper(key) {
                self.release_now(d, now);
            }
        }
        if let Some(f) = self.config.layout.finger(key) {
            self.frame.set(f.board, f.bit, true);
        }
        let down = self.fingers.down;
        self.count(|s| s.peak_keys_down = s.peak_keys_down.max(down));
    }

    /// Lets `key` go because its notes ended. A strike that has not reached the boards yet
    /// (pressed and released within one flush: a zero-length note), that is still waiting for
    /// its re-strike gap, or that struck late after waiting, is not lost: it is held for the
    /// guard's `min_press` from its strike.
    fn release_key(&mut self, key: u8, now: u32) {
        match self.fingers.phase(key) {
            DOWN => {
                let g = &self.config.guard;
                let unwritten = self
                    .config
                    .layout
                    .finger(key)
                    .is_some_and(|f| !self.frame.is_written(f.board, f.bit));
                let unwritten = unwritten || self.fingers.has(key, LATE);
                let age = self.fingers.age(key, now);
                let min = g.min_press.as_micros();
                if unwritten && g.enabled && age < min {
                    self.fingers.set_flag(key, RELEASE_AFTER, true);
                    self.due = self.due.min(now.wrapping_add(min - age));
                } else {
                    self.release_now(key, now);
                }
            }
            PENDING => {
                // Its note is over before it could strike: it strikes anyway once the gap has
                // passed, and is held for `min_press`.
                self.fingers.set_flag(key, RELEASE_AFTER, true);
            }
            _ => {}
        }
    }

    /// Releases `key` now if it is down.
    fn release_now(&mut self, key: u8, now: u32) {
        if self.fingers.phase(key) == DOWN {
            #[cfg(feature = "dynamics")]
            let by_energy = self.duty().filter(|_| self.by_current());
            #[cfg(not(feature = "dynamics"))]
            let by_energy: Option<DutyLimit> = None;
            if let Some(d) = by_energy {
                // It heated by its energy (strike, then hold) and cooled at the allowed duty
                // meanwhile; rounded up, to be safe.
                let (on, window) = (d.max_on.as_micros() as u64, d.window.as_micros() as u64);
                let down = self.fingers.age(key, now);
                #[cfg(feature = "dynamics")]
                let energy = if self.is_strike(key) {
                    let duty = self
                        .config
                        .dynamics
                        .touch(key)
                        .strike_duty(self.velocity(key));
                    (down as u64 * duty.get() as u64).div_ceil(Duty::FULL.get() as u64)
                } else {
                    self.config.dynamics.energy(key, self.velocity(key), down)
                };
                #[cfg(not(feature = "dynamics"))]
                let energy = down as u64;
                // A strike output keeps its strike's stamp (below): its cooling is counted from
                // the strike at its next press, the pulse included.
                let cooled = if self.is_strike(key) {
                    0
                } else {
                    down as u64 * on / window.max(1)
                };
                let heat =
                    (self.fingers.heat_ms(key) as u64 * 1000 + energy).saturating_sub(cooled);
                self.fingers.set_heat_ms(key, heat.div_ceil(1000));
            } else if let Some(d) = self.duty() {
                // It heated at (1 − duty) while it was down; rounded up, to be safe.
                let (on, window) = (d.max_on.as_micros() as u64, d.window.as_micros() as u64);
                let down = self.fingers.age(key, now) as u64;
                let added = if self.is_strike(key) {
                    // Cooled from its strike at the next press (below).
                    down
                } else {
                    down * window.saturating_sub(on) / window.max(1)
                };
                let heat = self.fingers.heat_ms(key) as u64 + added.div_ceil(1000);
                self.fingers.set_heat_ms(key, heat);
            }
            if self.is_strike(key) {
                // Its rebound is counted from its strike, however short the pulse (a pulse cut
                // by a reset or the watchdog too): the stamp stays the strike's.
                self.fingers.set_phase(key, RELEASING);
            } else {
                self.fingers.enter(key, RELEASING, now);
            }
            if let Some(f) = self.config.layout.finger(key) {
                self.frame.set(f.board, f.bit, false);
            }
        }
    }

    /// Releases `key` if down, and cancels a delayed strike: for resets and cuts.
    fn cancel_key<S: NoteSink>(&mut self, key: u8, now: u32, why: DropReason, sink: &mut S) {
        if self.fingers.phase(key) == PENDING {
            // It never struck: it keeps resting from its earlier release.
            if why == DropReason::Stopped {
                self.count(|s| s.dropped_stopped += 1);
            } else {
                self.count(|s| s.dropped_cancelled += 1);
            }
            sink.note(NoteEvent::WaitEnded { key, reason: why });
            self.fingers.set_phase(key, RELEASING);
        } else {
            self.release_now(key, now);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::GuardConfig;
    use crate::held::NotePool;

    #[test]
    fn thesis_with_a_note_pool_plays_like_the_checked_constructor() {
        const BUILT: Interpreter<4, 61, NotePool<32>> = Interpreter::thesis_with();
        let mut a = BUILT;
        let mut b = Interpreter::<4, 61, NotePool<32>>::new(Config::THESIS).unwrap();
        for i in [&mut a, &mut b] {
            i.feed_slice(&[0x90, 60, 1, 0x91, 24, 1], Instant::ZERO);
        }
        assert_eq!(a.frame(), b.frame());
        assert_eq!(a.frame().outputs(1), 1 << 8);
        assert_eq!(a.frame().outputs(0), 1);
    }

    #[test]
    fn a_full_note_pool_refuses_the_note_and_counts_it() {
        let config = Config {
            guard: GuardConfig::OFF,
            ..Config::THESIS
        };
        let mut i = Interpreter::<4, 61, NotePool<2>>::new(config).unwrap();
        i.feed_slice(&[0x90, 60, 1, 61, 1, 62, 1], Instant::ZERO);
        assert_eq!(i.keys_down(), 2);
        #[cfg(feature = "stats")]
        assert_eq!(i.stats().dropped_power, 1);
        i.feed_slice(&[0x80, 62, 0, 60, 0], Instant::ZERO);
        assert_eq!(i.keys_down(), 1);
    }

    /// With no hold limit (and no watchdog), a key that strikes after waiting for its rest
    /// has no deadline: `next_deadline` says none, not one already past.
    #[test]
    fn a_delayed_strike_with_no_hold_limit_leaves_no_deadline() {
        let config = Config {
            guard: GuardConfig {
                max_hold: None,
                watchdog: None,
                late_limit: None,
                duty: None,
                ..GuardConfig::DEFAULT
            },
            ..Config::THESIS
        };
        let mut i = Interpreter::<4, 61, NotePool<32>>::new(config).unwrap();
        let t = Instant::from_millis;
        i.feed_slice(&[0x90, 60, 100], t(0));
        i.feed_slice(&[0x80, 60, 0], t(30));
        i.feed_slice(&[0x90, 60, 100], t(40)); // waits for the 60 ms rest
        assert_eq!(i.key_phase(24), KeyPhase::Waiting);
        let strike = i.next_deadline().expect("the rest's end");
        assert_eq!(strike, t(90));
        i.tick(strike);
        assert_eq!(i.key_phase(24), KeyPhase::Down);
        assert_eq!(i.next_deadline(), None);
    }

    #[test]
    fn feed_says_whether_a_byte_completed_a_message_or_a_timer_ran() {
        let mut i = Interpreter::<4, 61, NotePool<32>>::new(Config::THESIS).unwrap();
        let t = Instant::from_micros;
        let steps: [(u8, u64, bool); 12] = [
            (0x90, 0, false),    // a status byte
            (60, 320, false),    // a first data byte
            (100, 640, true),    // the Note-On
            (64, 960, false),    // running status
            (0xF8, 1_000, true), // a real-time byte inside it is a message
            (100, 1_280, true),
            (0xF0, 1_600, true), // SysEx starts
            (0x7E, 1_920, false),
            (0xF7, 2_240, true), // and ends
            (0x80, 2_560, false),
            // The watchdog fell due meanwhile (4 s): its timer runs before this byte.
            (60, 4_100_000, true),
            (0, 4_100_320, true),
        ];
        for (byte, at, changed) in steps {
            assert_eq!(i.feed(byte, t(at)), changed, "{byte:#04x} at {at} µs");
        }
        assert_eq!(i.keys_down(), 0, "the watchdog released both");
    }

    #[test]
    fn board_ahead_names_the_board_of_a_note_waiting_for_its_velocity() {
        let config = Config {
            channels: crate::ChannelMask(0x7FFF), // channel 16 not played
            ..Config::THESIS
        };
        let mut i = Interpreter::<4, 61, NotePool<32>>::new(config).unwrap();
        let board = |i: &Interpreter<4, 61, NotePool<32>>| i.board_ahead().map(|b| b.index);
        let t = Instant::ZERO;
        i.feed(0x90, t);
        assert_eq!(board(&i), None, "no note yet");
        i.feed(60, t); // key 24: board 1
        assert_eq!(
            i.board_ahead(),
            Some(BoardId {
                index: 1,
                address: 0x22
            })
        );
        i.feed(0xF8, t);
        assert_eq!(board(&i), Some(1), "a real-time byte keeps it waiting");
        i.feed(100, t);
        assert_eq!(board(&i), None, "complete");
        i.feed(96, t); // running status: key 60, board 3
        assert_eq!(board(&i), Some(3));
        i.feed(0, t);
        i.feed(0x80, t);
        i.feed(0, t); // folded up three octaves: key 0, board 0
        assert_eq!(board(&i), Some(0));
        i.feed(0x90, t);
        assert_eq!(board(&i), None, "a status byte abandons it");
        i.feed(0x9F, t);
        i.feed(60, t);
        assert_eq!(board(&i), None, "channel 16 is not played");
        i.feed(0xA0, t);
        i.feed(60, t);
        assert_eq!(board(&i), None, "poly pressure writes no board");
        i.feed(0xF0, t);
        i.feed(60, t);
        assert_eq!(board(&i), None, "SysEx data");
    }

    #[test]
    fn a_lost_line_forgets_the_cut_message_and_running_status_but_not_the_keys() {
        let mut i = Interpreter::<4, 61, NotePool<32>>::new(Config::THESIS).unwrap();
        // A note, then a second cut off after its key.
        i.feed_slice(&[0x90, 60, 100, 62], Instant::ZERO);
        assert!(i.input_ended());
        assert!(!i.input_ended(), "nothing is pending any more");
        assert!(i.is_down(24), "the keys are all_off's to release");
        // The new connection's first bytes are data under no status: not a Note-On with the
        // old running status, not the rest of the cut message.
        i.feed_slice(&[64, 100], Instant::from_micros(1_000));
        assert!(!i.is_down(26) && !i.is_down(28));
        assert_eq!(i.keys_down(), 1);
        assert_eq!(i.counters().dropped, 2);
    }
}
