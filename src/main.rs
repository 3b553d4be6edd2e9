//! `orch`: make MIDI-driven solenoid instruments play.
//!
//! Thin glue: parse the arguments, run, and exit with 0 (success), 1 (something failed while
//! running) or 2 (bad usage or bad input: the command line, a file, a configuration).

use std::process::ExitCode;

use clap::Parser;
use orch::{cli, error};

fn main() -> ExitCode {
    let cli = match cli::Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() {
                ExitCode::from(2)
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    match orch::run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if error::is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("orch: error: {e:#}");
            ExitCode::from(error::exit_code(&e))
        }
    }
}
