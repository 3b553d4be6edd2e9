//! `orch serve`: the web page (`orch-serve`), on the robot and outputs given, at the address
//! given; its URL printed at start (with the token, off loopback). SIGINT, SIGTERM and SIGHUP
//! stop any performance, every key released, and end the server.

use std::io::Write;

use orch_perform::Tempo;
use orch_serve::{Access, Config, ServeError};

use crate::cli::ServeArgs;
use crate::error::{bad_input, lift};
use crate::live::init_logging;
use crate::play::out_specs;

pub fn run(args: &ServeArgs) -> anyhow::Result<()> {
    init_logging(args.verbose);
    let robot = orch_stage::load_robot(args.robot.as_deref())?;
    let setup = orch_stage::setup::setup(&robot, !args.no_compensation, Tempo::NORMAL);
    let outs = out_specs(&args.outs)?;
    orch_serve::check(&setup, &outs, args.library.as_deref())
        .map_err(|e| lift(e, ServeError::is_bad_input))?;
    let session = match args.link {
        true => Some(crate::link::page_session()?),
        false => None,
    };
    let signalled = orch_stage::signals::stop_flag()?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    runtime.block_on(async {
        let listener = tokio::net::TcpListener::bind(args.listen)
            .await
            .map_err(|e| bad_input(format!("--listen {}: {e}", args.listen)))?;
        let access = Access::new(listener.local_addr()?)?;
        print_urls(&access)?;
        let config = Config {
            robot,
            setup,
            outs,
            named: !args.outs.is_empty(),
            library: args.library.clone(),
            access,
            session,
        };
        orch_serve::serve(listener, config, orch_serve::until_set(signalled))
            .await
            .map_err(|e| lift(e, ServeError::is_bad_input))
    })
}

/// The page's URLs, one a line on standard output (off loopback, each carrying the token).
fn print_urls(access: &Access) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    for url in access.urls() {
        writeln!(out, "orch serve: the page is at {url}")?;
    }
    if access.token().is_some() {
        writeln!(
            out,
            "orch serve: off loopback the page asks for the token in that URL; keep it private"
        )?;
    }
    out.flush()?;
    Ok(())
}
