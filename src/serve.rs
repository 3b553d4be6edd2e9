//! `orch serve`: the web page (`orch-serve`), on the robot and outputs given, at the address
//! given; its URL printed at start (with the token, off loopback). SIGINT, SIGTERM and SIGHUP
//! stop any performance, every key released, and end the server.

use std::io::Write;
use std::net::{IpAddr, SocketAddr};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use orch_perform::Tempo;
use orch_serve::{Access, Config};

use crate::cli::ServeArgs;
use crate::error::bad_input;
use crate::live::init_logging;
use crate::play::out_specs;

pub fn run(args: &ServeArgs) -> anyhow::Result<()> {
    init_logging(args.verbose);
    let robot = orch_stage::load_robot(args.robot.as_deref())?;
    let setup = orch_stage::setup::setup(&robot, !args.no_compensation, Tempo::NORMAL);
    let outs = out_specs(&args.outs)?;
    // Every output opened once at start: one that cannot be is said now, not at the first play.
    drop(crate::play::open_lanes(outs.clone(), &setup)?);
    if let Some(dir) = &args.library {
        if !dir.is_dir() {
            return Err(bad_input(format!(
                "--library {}: not a folder",
                dir.display()
            )));
        }
    }
    let signalled = Arc::new(AtomicBool::new(false));
    for sig in [
        signal_hook::consts::SIGINT,
        signal_hook::consts::SIGTERM,
        signal_hook::consts::SIGHUP,
    ] {
        signal_hook::flag::register(sig, Arc::clone(&signalled))?;
    }
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    runtime.block_on(async {
        let listener = tokio::net::TcpListener::bind(args.listen)
            .await
            .map_err(|e| bad_input(format!("--listen {}: {e}", args.listen)))?;
        let addr = listener.local_addr()?;
        let access = Access::new(addr)?;
        print_urls(&access)?;
        let config = Config {
            robot,
            setup,
            outs,
            named: !args.outs.is_empty(),
            library: args.library.clone(),
            access,
        };
        let shutdown = async move {
            while !signalled.load(Ordering::SeqCst) {
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        };
        orch_serve::serve(listener, config, shutdown).await?;
        anyhow::Ok(())
    })
}

/// The page's URLs, one a line on standard output (off loopback, each carrying the token).
fn print_urls(access: &Access) -> anyhow::Result<()> {
    let addr = access.addr();
    let hosts: Vec<IpAddr> = if addr.ip().is_unspecified() {
        let mut hosts = vec![if addr.is_ipv4() {
            IpAddr::from([127, 0, 0, 1])
        } else {
            IpAddr::from(std::net::Ipv6Addr::LOCALHOST)
        }];
        hosts.extend(machine_addresses(addr));
        hosts
    } else {
        vec![addr.ip()]
    };
    let mut out = std::io::stdout().lock();
    for host in hosts {
        writeln!(out, "orch serve: the page is at {}", access.url(host))?;
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

/// This machine's addresses other than loopback, of `addr`'s family.
fn machine_addresses(addr: SocketAddr) -> Vec<IpAddr> {
    let Ok(ifaces) = nix::ifaddrs::getifaddrs() else {
        return Vec::new();
    };
    let mut found: Vec<IpAddr> = ifaces
        .filter_map(|i| i.address)
        .filter_map(|a| {
            if let Some(v4) = a.as_sockaddr_in() {
                Some(IpAddr::V4(v4.ip()))
            } else {
                a.as_sockaddr_in6().map(|v6| IpAddr::V6(v6.ip()))
            }
        })
        .filter(|ip| !ip.is_loopback() && ip.is_ipv4() == addr.is_ipv4())
        .filter(|ip| match ip {
            // Link-local IPv6 needs a zone in a URL: left out.
            IpAddr::V6(v6) => (v6.segments()[0] & 0xffc0) != 0xfe80,
            IpAddr::V4(_) => true,
        })
        .collect();
    found.sort();
    found.dedup();
    found
}
