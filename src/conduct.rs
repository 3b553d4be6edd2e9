//! `orch conduct`: a Standard MIDI File played live, following a conductor: a baton video
//! (through `orch-baton`), tap tempo (a key in the live view), incoming MIDI clock (raw bytes
//! from standard input, a file or device, or a UDP port) or OSC over UDP. The sources and the
//! loop that follows them are `orch-stage`'s (`orch_stage::sources`, started on a thread of
//! their own by `orch_stage::conductor`); the follower (`orch_perform::Follower`) turns their
//! cues into tempo changes of the performance, through the performance's `Control`. Here: the
//! arguments, the view, the report.

use orch_perform::{Follow, Tempo};
use orch_stage::conductor::Conducting;
use orch_stage::sources::SourceSpec;
use orch_stage::SourceError;

use crate::cli::{ConductArgs, FollowMode};
use crate::error::bad_input;
use crate::live::{self, LiveOptions};
use crate::play;

/// Runs `orch conduct`.
pub fn run(args: &ConductArgs) -> anyhow::Result<()> {
    live::init_logging(args.verbose);
    let spec = SourceSpec::parse(&args.source).map_err(bad_input)?;
    let tap = spec == SourceSpec::Tap;
    if tap && (args.no_view || !std::io::IsTerminal::is_terminal(&std::io::stdout())) {
        return Err(bad_input(
            "--source tap: the taps are keys in the live view; run it in a terminal, without \
             --no-view",
        ));
    }
    let song = orch_stage::load_song(&args.file)?;
    let from_us = play::from_bar(&song, args.from)?;
    let robot = orch_stage::load_robot(args.robot.as_deref())?;
    let setup = orch_stage::setup::setup(&robot, !args.no_compensation, Tempo::NORMAL);
    let lanes = play::open_lanes(play::out_specs(&args.outs)?, &setup)?;
    let mode = match args.follow {
        FollowMode::Immediate => Follow::Immediate,
        FollowMode::Phase => Follow::PHASE,
    };
    let conducting = Conducting::start(&spec, &song, mode).map_err(|e| match e {
        SourceError::BadInput(m) => bad_input(format!("--source {m}")),
        e => anyhow::Error::new(e),
    })?;
    // With --link: the session started for bar one, where the performance starts.
    #[cfg(feature = "link")]
    let leader = match args.link {
        true => Some(crate::link::lead(
            &song,
            &conducting.control,
            conducting.origin,
        )?),
        false => None,
    };
    #[cfg(not(feature = "link"))]
    if args.link {
        crate::link::lead(&song, &conducting.control, conducting.origin)?;
    }
    let played = live::play_live(
        song,
        lanes,
        LiveOptions {
            command: "orch conduct",
            from_us,
            view: !args.no_view,
            file: &args.file,
            conductor: Some(&conducting),
            steered: None,
        },
    );
    #[cfg(feature = "link")]
    if let Some(leader) = leader {
        leader.end();
    }
    let played = played?;
    if !args.json {
        println!("{}", conducting.line());
    }
    play::print_reports(&played, args.json, &args.file, !args.outs.is_empty())
}
