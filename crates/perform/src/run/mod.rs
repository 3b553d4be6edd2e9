//! One performance as it runs: its state, and the loop that paces each send by the clock.
//!
//! Each turn of the loop follows the control ([`steer`]: a jump, a tempo change), finds what
//! is due next (a send, a keep-alive byte, an output's own timer), waits for it (showing
//! where it stands and pausing on the way, with a live view), and does it ([`send`]). At
//! the end ([`end`]) the robot settles and every note is accounted for.

mod end;
mod send;
mod steer;

use orch_seq::{Clock, VirtualClock};

use crate::control::{Control, SHOW_EVERY_US};
use crate::ledger::Ledger;
use crate::link::Link;
use crate::performer::{robot_err, Live, PerformError, Performer, KEEP_ALIVE_US};
use crate::plan::{NoteId, Planner, ScoreEvent};
use crate::played::Played;
use crate::robot::{sim_boards, LocalRobot, SimBoards};
use crate::setup::Setup;
use crate::time::{ScoreTime, WallTime};

pub(crate) use send::SendMidi;
use send::{din_burst, Out};

/// A performance under way. See the [module notes](self).
pub(crate) struct Run<'a, S: Iterator<Item = ScoreEvent>> {
    setup: &'a Setup,
    /// The clock asked for, or else `virtual_clock`.
    clock: Option<&'a mut dyn Clock>,
    virtual_clock: VirtualClock,
    control: Option<&'a Control>,
    live: Option<&'a mut dyn FnMut(&Live)>,
    /// The score from its start, for a jump (with a control only).
    origin: Option<S>,
    /// Note-Ons in the score.
    notes: usize,
    robot: LocalRobot<SimBoards>,
    planner: Planner<S>,
    ledger: Ledger,
    out: Out<'a>,
    /// Score time 0.
    start: WallTime,
    /// How often a live view is called, µs.
    every: u64,
    /// Each send's lateness on the clock, µs (when a clock paces the run).
    lateness: Option<Vec<u64>>,
    /// Each note's Note-On's among them, by its record's index.
    note_lateness: Vec<Option<u32>>,
    notes_sent: u64,
    stopped_at: Option<WallTime>,
    line: Line,
    passes: Passes,
    /// The numbers of the last tempo and jump asked of the control that this run took.
    seen_tempo: u64,
    seen_jump: u64,
}

/// Now on `clock`, or else on `virtual_clock` (apart from the rest of a run, so that it can be
/// read while the run's output is borrowed).
fn now_on(clock: &Option<&mut dyn Clock>, virtual_clock: &VirtualClock) -> WallTime {
    WallTime::from_micros(match clock {
        Some(c) => c.now_us(),
        None => virtual_clock.now_us(),
    })
}

/// What was last sent, and when.
struct Line {
    /// The last send's time (nothing is sent before it).
    last_at: WallTime,
    /// The last byte's time, for the keep-alive.
    last_byte: Option<WallTime>,
    /// Sends left in the present DIN burst, and its time.
    burst: usize,
    burst_at: WallTime,
}

/// The passes over the score that jumps make, and the notes sent ahead in this one.
#[derive(Default)]
struct Passes {
    /// Notes sent (early) whose time to sound has not come, with that time (planner wall
    /// µs): a tempo change moves it.
    sent_ahead: Vec<(NoteId, i64)>,
    /// The account's number of a planned note is its score index plus `offset`, which grows
    /// at each jump back (a note played again is a record of its own).
    offset: u32,
    /// The latest score index sent or dropped since the last jump: it tells a jump forward
    /// from one back.
    committed: Option<u32>,
    jumps: u64,
    /// Where the present pass began in the score (the top, or the last jump's target).
    from: ScoreTime,
}

/// What is due next, and when.
struct Due {
    /// When to act.
    at: WallTime,
    /// The next planned send's time.
    next: WallTime,
    what: What,
}

enum What {
    /// The next planned send.
    Send,
    /// Active Sensing, to keep the line alive.
    KeepAlive,
    /// The output's own timer.
    Poll,
}

/// What to do after a wait.
enum Step {
    /// What was due.
    Go,
    /// Look again from the top (a request came, or the wait was cut short).
    Again,
    /// Stop the performance.
    Stop,
}

impl<'a, S: Iterator<Item = ScoreEvent> + Clone> Run<'a, S> {
    /// The robot set up, the planner ready, score time 0 placed on the clock.
    pub(crate) fn start(p: Performer<'a, S>) -> Result<Self, PerformError> {
        let setup = p.setup;
        let origin = p.control.map(|_| p.source.clone());
        let boards = sim_boards(&setup.sim).map_err(robot_err)?;
        let robot = LocalRobot::<SimBoards>::new(setup.config, boards).map_err(robot_err)?;
        // Start once the boards are configured, on a whole millisecond; or later, so that
        // the first place plays at the moment the control asks.
        let ready = robot.boards().bus().bus().free_at().as_micros();
        let ready = WallTime::from_micros(ready.div_ceil(1000) * 1000);
        let mut planner = Planner::new(p.source, setup.rules(), ready.signed(), setup.tempo);
        let asked = p.control.and_then(Control::asked_start);
        // A jump asked before the start (`--from`) is its first place.
        let lead = match p.control.is_some_and(|c| c.jump.pending(0).is_some()) {
            true => planner.jump_lead_us(),
            false => planner.lookahead_us(),
        };
        let ready = match asked.map(|at| at.signed() - lead) {
            Some(later) if later > ready.signed() => {
                planner = planner.starting(later);
                WallTime::from_signed(later)
            }
            _ => ready,
        };
        let start = planner.time_map().wall_at(ScoreTime::ZERO);
        if let Some(c) = p.control {
            c.publish(*planner.time_map());
        }
        Ok(Self {
            setup,
            lateness: p.clock.is_some().then(Vec::new),
            note_lateness: Vec::new(),
            clock: p.clock,
            virtual_clock: VirtualClock::new(),
            control: p.control,
            origin,
            notes: p.notes,
            robot,
            planner,
            ledger: Ledger::new(setup.config.keys()),
            out: Out::new(p.midi),
            start,
            every: p.control.map_or(SHOW_EVERY_US, Control::poll_us),
            live: p.live,
            notes_sent: 0,
            stopped_at: None,
            line: Line {
                last_at: ready,
                last_byte: None,
                burst: 0,
                burst_at: WallTime::ZERO,
            },
            passes: Passes::default(),
            seen_tempo: 0,
            seen_jump: 0,
        })
    }

    /// Plays to the end (or a stop), then accounts for every note.
    pub(crate) fn play(mut self) -> Result<Played, PerformError> {
        loop {
            // The control's rings so far, read before looking at it: a request after this
            // wakes the wait below.
            let seen = self.rung();
            self.follow_jump()?;
            self.follow_tempo();
            let Some(due) = self.due() else {
                break;
            };
            let step = if self.live.is_some() {
                self.wait_live(due.at)?
            } else if self.wait(due.at, seen) {
                Step::Again
            } else {
                Step::Go
            };
            match step {
                Step::Go if !self.act(&due)? => break,
                Step::Go | Step::Again => {}
                Step::Stop => break,
            }
        }
        self.finish()
    }

    /// What is due next: the next planned send, unless the line has been silent too long
    /// while a key is down or waiting (the robot's watchdog must not cut a held chord), or
    /// the output has a timer of its own due first. `None` when the song is over.
    fn due(&mut self) -> Option<Due> {
        let next = self.next_send_at()?;
        // The keep-alive is generated as the time comes, never stored, and only while
        // something could be cut: memory and time follow the events, never the length of a
        // silence.
        let busy = self.robot.interpreter().next_deadline().is_some();
        let mut due = match self.line.last_byte {
            Some(b) if busy && next > b + KEEP_ALIVE_US => Due {
                at: b + KEEP_ALIVE_US,
                next,
                what: What::KeepAlive,
            },
            _ => Due {
                at: next,
                next,
                what: What::Send,
            },
        };
        // An output with timers of its own (a robot driven from this host) is called at them.
        if let Some(d) = self.out.next_deadline().filter(|&d| d < due.at) {
            due.at = d.max(self.line.last_at);
            due.what = What::Poll;
        }
        Some(due)
    }

    /// When the next planned send goes: on a DIN line a chord goes out as one burst, centred
    /// on its time (see [`din_burst`]).
    fn next_send_at(&mut self) -> Option<WallTime> {
        let mut next = WallTime::from_signed(self.planner.peek_time()?);
        if self.line.burst > 0 {
            return Some(self.line.burst_at);
        }
        if let (Link::Din, Out::Midi { status, .. }) = (self.setup.link, &self.out) {
            let (start, members) = din_burst(&self.planner.final_sends(), *status);
            next = WallTime::from_signed(start.max(self.line.last_at.signed()));
            self.line.burst = members;
            self.line.burst_at = next;
        }
        Some(next)
    }

    /// Does what is due: whether the song goes on.
    fn act(&mut self, due: &Due) -> Result<bool, PerformError> {
        match due.what {
            What::Poll => self.out.poll(due.at)?,
            What::KeepAlive => {
                self.deliver(due.at, &[0xFE], None)?;
                self.line.last_byte = Some(due.at);
            }
            What::Send => return self.send_next(due.next),
        }
        Ok(true)
    }

    /// The clock the run is paced by.
    fn clock(&mut self) -> &mut dyn Clock {
        match &mut self.clock {
            Some(c) => &mut **c,
            None => &mut self.virtual_clock,
        }
    }

    /// Now, on the clock.
    fn now(&self) -> WallTime {
        now_on(&self.clock, &self.virtual_clock)
    }

    /// The control's rings so far (0 without a control).
    fn rung(&self) -> u64 {
        self.control.map_or(0, |c| c.bell().rung())
    }

    /// Waits for `until`, or until the control rings after `seen` rings: whether it rang.
    fn wait(&mut self, until: WallTime, seen: u64) -> bool {
        let control = self.control;
        let clock = self.clock();
        match control {
            Some(c) => clock.wait_until_rung(until.as_micros(), c.bell(), seen),
            None => {
                clock.wait_until(until.as_micros());
                false
            }
        }
    }

    /// The robot's note decisions and presses since the last look, into the account.
    fn account_robot(&mut self) {
        for d in self.robot.drain_decided() {
            self.ledger.decided(d.t_us, d.event);
        }
        let ledger = &mut self.ledger;
        self.robot.drain_presses(|p| ledger.press(p));
    }
}
