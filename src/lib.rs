//! The `orch` program's pieces, so that tests can reach them; `main.rs` only parses the
//! arguments and calls [`run()`].
//!
//! A thin shell: each command parses its arguments, calls the libraries (`orch-stage` for
//! everything a session, a report or an analysis needs; `orch-render`, `orch-calibrate`,
//! `orch-baton` for theirs), and prints; the terminal's live view ([`view`]) is drawn here.
//!
//! Cargo features, off by default: `alsa`, `orch play --out alsa:CLIENT:PORT`, through
//! orch-io's own `alsa` feature (it links alsa-lib: `libasound2-dev` to build); `camera`,
//! `orch conduct --source camera:/dev/video0`, through orch-baton's own `camera` feature (a
//! V4L2 camera; the `v4l` crate's bindings are generated with libclang: `libclang-dev`);
//! `mic`, `orch calibrate --out OUT --mic DEVICE`, through orch-calibrate's own `mic` feature
//! (ALSA capture: it links alsa-lib, `libasound2-dev`).

pub mod analyze;
pub mod baton;
pub mod calibrate;
pub mod cli;
pub mod conduct;
pub mod decode;
pub mod error;
pub mod input;
pub mod interpret;
pub mod link;
pub mod live;
pub mod play;
pub mod render;
pub mod robot;
pub mod run;
pub mod serve;
pub mod view;

/// Runs one command.
pub fn run(command: cli::Command) -> anyhow::Result<()> {
    match command {
        cli::Command::Decode(args) => decode::run(&args),
        cli::Command::Interpret(args) => interpret::run(&args),
        cli::Command::Play(args) => play::run_play(&args),
        cli::Command::Analyze(args) => analyze::run(&args),
        cli::Command::Config(args) => robot::print_default(&args.instrument, &args.boards),
        cli::Command::Baton(args) => baton::run(&args),
        cli::Command::Run(args) => run::run(&args),
        cli::Command::Conduct(args) => conduct::run(&args),
        cli::Command::Render(args) => render::run(&args),
        cli::Command::Calibrate(args) => calibrate::run(&args),
        cli::Command::Serve(args) => serve::run(&args),
    }
}
