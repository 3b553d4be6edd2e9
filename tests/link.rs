//! Robots on several hosts in phase: `orch play --link` peers, each in a network namespace of
//! its own on one bridge (made here: CI runs as root), and an independent Link peer that is
//! not orch (`tests/link/peer.py`: Ableton's own SDK through LinkPython-extern, PyPI) which
//! sets the tempo, starts and stops the session, and collects every robot's MIDI (`--out
//! udp:`) stamped with its own view of the session's beat.
//!
//! Every robot's host loses Link datagrams, in and out (nftables: this kernel has no
//! `sch_netem`): one in twenty of those to a multicast group (Link's discovery and its news:
//! who is there, the tempo, start and stop), one in fifty of the rest (Link's clock
//! measurement, ping and pong between two peers). Wi-Fi resends a lost unicast frame, not a
//! multicast one, so a real network loses far more of the first. Why not one in twenty of
//! both: Ableton's SDK gives up measuring a session after five lost pings, and goes on
//! measuring whichever peer it sees first; at one in twenty both ways at every host, a
//! measurement between two robots nearly always fails, and in a trial 24 of 96 newcomers had
//! not joined a playing session 6 s later (with the loss on unicast alone, 7 of 12; on
//! multicast alone, or on IPv4 alone with IPv6 spared, none of 12).
//!
//! One piece, as a rehearsal goes: three robots wait; the independent peer starts the
//! session; they come in together on bar one; it changes the tempo; a fourth robot joins
//! mid-piece and comes in on the beat, at the score's place there; it stops the session, and
//! every robot stops with every key up; it plays the session again since its old start, as
//! a robot's announcement that crossed the stop would, and the robots stop it again. Four
//! robots send at the score's time (`--no-compensation`), so the moment a message arrives is
//! the moment its note sounds on a robot that strikes at once; a fifth sends each note early
//! by its own mechanics, and its report says its copy sounded each on time.

#![cfg(feature = "link")]

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

const ORCH: &str = env!("CARGO_BIN_EXE_orch");
const PEER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/link/peer.py");

/// The most a note may arrive off its beat, ms.
const ON_BEAT_MS: f64 = 3.0;
/// How long after a tempo change, µs, a robot's notes may be off their beat: see the first
/// test.
const CHANGE_US: f64 = 1e6;
/// The most a lone note may arrive off its beat through a stall of the host, ms: see the
/// first test.
const STALL_MS: f64 = 20.0;
/// The most the arm64 robot's Note-Ons may leave late under qemu, by its own clock, ms: see its
/// test.
const QEMU_LATE_MS: f64 = 50.0;
/// The most the arm64 robot's phase may be off the session's under qemu, ms: Link measures the
/// session's clock through the emulator, whose delays skew the measurement (0.5 ms on a quiet
/// machine, 2.9 ms while it compiled on both cores).
const QEMU_PHASE_MS: f64 = 6.0;

fn ip(args: &[&str]) {
    let out = Command::new("ip")
        .args(args)
        .output()
        .expect("ip (iproute2)");
    assert!(
        out.status.success(),
        "ip {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A bridge and `hosts` namespaces on it, 10.77.N.10 + i/24 (N the test's own); taken down
/// when dropped.
struct Net {
    /// One net at a time: each plays in real time with several processes, on a machine that
    /// may have two cores.
    _serial: std::sync::MutexGuard<'static, ()>,
    /// 10.77.`subnet`.0/24: each test's own.
    subnet: u32,
    bridge: String,
    hosts: Vec<String>,
}

impl Net {
    fn new(hosts: usize) -> Net {
        assert!(
            nix_is_root(),
            "tests/link.rs makes network namespaces: run as root (CI does)"
        );
        static NETS: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let n = NETS.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        let tag = std::process::id() % 10_000 * 10 + n;
        // Each test's subnet its own, and (likely) each process's: 10.77.S.0/24.
        let subnet = std::process::id() % 50 * 5 + n;
        let bridge = format!("orchbr{tag}");
        static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());
        let net = Net {
            _serial: SERIAL.lock().unwrap_or_else(|e| e.into_inner()),
            subnet,
            bridge: bridge.clone(),
            hosts: (0..hosts).map(|i| format!("orchl{tag}-{i}")).collect(),
        };
        ip(&[
            "link",
            "add",
            &bridge,
            "type",
            "bridge",
            "mcast_snooping",
            "0",
        ]);
        ip(&["link", "set", &bridge, "up"]);
        // The test itself (a conductor's OSC) reaches the hosts from 10.77.S.1.
        ip(&[
            "addr",
            "add",
            &format!("10.77.{subnet}.1/24"),
            "dev",
            &bridge,
        ]);
        for (i, ns) in net.hosts.iter().enumerate() {
            let veth = format!("ol{tag}v{i}");
            ip(&["netns", "add", ns]);
            ip(&[
                "link", "add", &veth, "type", "veth", "peer", "name", "eth0", "netns", ns,
            ]);
            ip(&["link", "set", &veth, "master", &bridge, "up"]);
            let addr = format!("{}/24", net.addr(i));
            ip(&["-n", ns, "addr", "add", &addr, "dev", "eth0"]);
            ip(&["-n", ns, "link", "set", "eth0", "up"]);
            ip(&["-n", ns, "link", "set", "lo", "up"]);
            ip(&["-n", ns, "route", "add", "224.0.0.0/4", "dev", "eth0"]);
        }
        net
    }

    fn addr(&self, i: usize) -> String {
        format!("10.77.{}.{}", self.subnet, 10 + i)
    }

    /// Host `i` loses, in and out, one in `multicast` of the Link datagrams to a multicast
    /// group (IPv4 or IPv6) and one in `unicast` of the others (UDP but the robots' MIDI to
    /// the collector, ports 9001–9009: a lost datagram there would be the test's loss, not
    /// the robot's): nftables' `numgen random`, as this kernel has no `sch_netem` to lose
    /// packets with.
    fn lossy(&self, i: usize, multicast: u32, unicast: u32) {
        let mut out = String::new();
        let mut into = String::new();
        for (to, every) in [
            ("ip daddr 224.0.0.0/4", multicast),
            ("ip6 daddr ff00::/8", multicast),
            ("ip daddr != 224.0.0.0/4", unicast),
            ("ip6 daddr != ff00::/8", unicast),
        ] {
            let drop = format!("numgen random mod {every} 0 drop; ");
            out += &format!("{to} udp dport != 9001-9009 {drop}");
            into += &format!("{to} udp sport != 9001-9009 {drop}");
        }
        let rules = format!(
            "table inet orchloss {{\n\
             chain out {{ type filter hook output priority 0; {out}}}\n\
             chain in {{ type filter hook input priority 0; {into}}}\n\
             }}\n"
        );
        let mut nft = self
            .command(i, "nft", &["-f", "-"])
            .stdin(Stdio::piped())
            .spawn()
            .expect("nft (nftables)");
        nft.stdin
            .take()
            .unwrap()
            .write_all(rules.as_bytes())
            .unwrap();
        assert!(nft.wait().unwrap().success(), "nft -f: {rules}");
    }

    /// `program` with `args` in host `i`'s namespace.
    fn command(&self, i: usize, program: &str, args: &[&str]) -> Command {
        let mut c = Command::new("ip");
        c.args(["netns", "exec", &self.hosts[i], program])
            .args(args);
        c
    }
}

impl Drop for Net {
    /// Every process still in a host (a robot left waiting by a failed test) killed, then the
    /// hosts and the bridge taken down.
    fn drop(&mut self) {
        for ns in &self.hosts {
            if let Ok(out) = Command::new("ip").args(["netns", "pids", ns]).output() {
                for pid in String::from_utf8_lossy(&out.stdout).split_whitespace() {
                    let _ = Command::new("kill").args(["-KILL", pid]).status();
                }
            }
            let _ = Command::new("ip").args(["netns", "del", ns]).status();
        }
        let _ = Command::new("ip")
            .args(["link", "del", &self.bridge])
            .status();
    }
}

fn nix_is_root() -> bool {
    std::fs::read_to_string("/proc/self/status").is_ok_and(|s| {
        s.lines()
            .any(|l| l.starts_with("Uid:") && l.split_whitespace().nth(1) == Some("0"))
    })
}

/// The independent peer, talked to a line at a time.
struct Peer {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
}

impl Peer {
    fn start(net: &Net, host: usize, ports: usize) -> Peer {
        let addr = net.addr(host);
        let ports = ports.to_string();
        let mut child = net
            .command(host, "python3", &[PEER, &addr, "9001", &ports])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .expect("python3");
        let stdin = child.stdin.take().unwrap();
        let stdout = BufReader::new(child.stdout.take().unwrap());
        let mut peer = Peer {
            child,
            stdin,
            stdout,
        };
        assert_eq!(peer.line(), "ready");
        peer
    }

    fn line(&mut self) -> String {
        let mut l = String::new();
        self.stdout.read_line(&mut l).unwrap();
        l.trim().to_string()
    }

    /// Sends a command; its answer's words after `ok`.
    fn ask(&mut self, command: &str) -> Vec<f64> {
        writeln!(self.stdin, "{command}").unwrap();
        let answer = self.line();
        let words: Vec<&str> = answer.split_whitespace().collect();
        assert_eq!(words.first(), Some(&"ok"), "{command}: {answer}");
        words[1..].iter().map(|w| w.parse().unwrap()).collect()
    }

    fn report(&mut self) -> Vec<Value> {
        writeln!(self.stdin, "report").unwrap();
        serde_json::from_str::<Value>(&self.line())
            .unwrap()
            .as_array()
            .unwrap()
            .clone()
    }

    fn wait_peers(&mut self, n: usize) {
        let until = Instant::now() + Duration::from_secs(15);
        while self.ask("peers")[0] < n as f64 {
            assert!(
                Instant::now() < until,
                "the Link peers did not find each other"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

impl Drop for Peer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// An `orch play --link` robot in host `host`, sending to the collector's port `port`.
fn robot(net: &Net, host: usize, file: &str, port: u16) -> Child {
    robot_with(net, host, file, port, &[])
}

/// [`robot`] with `more` arguments.
fn robot_with(net: &Net, host: usize, file: &str, port: u16, more: &[&str]) -> Child {
    let mut args = robot_args(net, file, port, more);
    args.push("--no-compensation".into());
    spawn(args, |args| net.command(host, ORCH, args))
}

/// `orch play FILE --link` to the collector's port `port`, with `more`.
fn robot_args(net: &Net, file: &str, port: u16, more: &[&str]) -> Vec<String> {
    let out = format!("udp:{}:{port}", net.addr(0));
    let mut args: Vec<String> = ["play", file, "--link", "--no-view", "--json", "--out", &out]
        .map(String::from)
        .to_vec();
    args.extend(more.iter().map(|m| m.to_string()));
    args
}

fn spawn(args: Vec<String>, command: impl Fn(&[&str]) -> Command) -> Child {
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    command(&args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("orch")
}

/// `robot`'s output once it has exited; killed, and the test failed, if it has not within
/// `within`.
fn exited(mut robot: Child, within: Duration) -> std::process::Output {
    let until = Instant::now() + within;
    while robot.try_wait().unwrap().is_none() {
        if Instant::now() > until {
            let _ = robot.kill();
            let out = robot.wait_with_output().unwrap();
            panic!(
                "a robot did not stop within {within:?} of the session: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    robot.wait_with_output().unwrap()
}

/// A Note-On as the collector stamped it.
#[derive(Clone, Copy, Debug)]
struct Onset {
    /// The robot, from 0 (the fourth, 3, joins mid-piece).
    robot: usize,
    note: u8,
    host_us: f64,
    beat: f64,
    bpm: f64,
}

impl Onset {
    /// How far off its beat it arrived, ms (positive: late).
    fn off_ms(&self) -> f64 {
        (self.beat - self.beat.round()) * 60e3 / self.bpm
    }
}

fn onsets(report: &[Value]) -> Vec<Onset> {
    report
        .iter()
        .filter_map(|m| {
            let b: Vec<u64> = m["bytes"]
                .as_array()?
                .iter()
                .filter_map(Value::as_u64)
                .collect();
            (b.len() == 3 && b[0] & 0xF0 == 0x90 && b[2] > 0).then(|| Onset {
                robot: m["peer"].as_u64().unwrap() as usize,
                note: b[1] as u8,
                host_us: m["host_us"].as_f64().unwrap(),
                beat: m["beat"].as_f64().unwrap(),
                bpm: m["bpm"].as_f64().unwrap(),
            })
        })
        .collect()
}

/// How late each Note-On a robot sent left by its own clock, ms, in the order sent: from its
/// note-by-note account (`--notes`).
fn sent_late_ms(account: &std::path::Path) -> Vec<f64> {
    let text = std::fs::read_to_string(account).expect("the robot's --notes account");
    let mut sent: Vec<(f64, f64)> = text
        .lines()
        .map(|l| serde_json::from_str::<Value>(l).unwrap())
        .filter_map(|v| Some((v["sent_ms"].as_f64()?, v["sent_late_ms"].as_f64()?)))
        .collect();
    sent.sort_by(|a, b| a.0.total_cmp(&b.0));
    sent.into_iter().map(|(_, late)| late).collect()
}

/// Robot `r`'s onsets, in order.
fn of_robot(all: &[Onset], r: usize) -> Vec<Onset> {
    all.iter().filter(|o| o.robot == r).copied().collect()
}

/// The notes of one robot's `notes` (in order) that are ON_BEAT_MS or more off their beat
/// while the notes on either side of them are within 1 ms: late alone, as a stall of the host
/// makes a note, where a phase error moves every note after it.
fn lone_late(notes: &[Onset]) -> Vec<Onset> {
    let on_beat = |o: Option<&Onset>| o.is_none_or(|o| o.off_ms().abs() < 1.0);
    (0..notes.len())
        .filter(|&i| notes[i].off_ms().abs() >= ON_BEAT_MS)
        .filter(|&i| {
            notes.len() > 1
                && on_beat(i.checked_sub(1).map(|j| &notes[j]))
                && on_beat(notes.get(i + 1))
        })
        .map(|i| notes[i])
        .collect()
}

#[test]
fn a_lone_late_note_is_a_stall_and_notes_late_together_are_not() {
    // Beats at 120 BPM, each note `off` ms after its beat.
    let notes = |offs: &[f64]| -> Vec<Onset> {
        offs.iter()
            .enumerate()
            .map(|(i, off)| Onset {
                robot: 0,
                note: 48,
                host_us: i as f64 * 5e5 + off * 1e3,
                beat: i as f64 + off / 500.0,
                bpm: 120.0,
            })
            .collect()
    };
    let late =
        |offs: &[f64]| -> Vec<f64> { lone_late(&notes(offs)).iter().map(Onset::off_ms).collect() };
    let near = |a: &[f64], b: &[f64]| {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6)
    };
    assert!(near(&late(&[0.1, 6.3, 0.1, 0.2]), &[6.3]));
    assert!(near(&late(&[6.3, 0.1, 0.2]), &[6.3]));
    assert!(late(&[0.1, 6.3, 5.0, 0.2]).is_empty());
    assert!(late(&[0.1, 6.3, 1.5]).is_empty());
    assert!(late(&[0.1, 2.9, 0.1]).is_empty());
    assert!(late(&[6.3]).is_empty());
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((p * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len()) - 1]
}

#[test]
fn robots_on_four_hosts_play_in_phase_with_an_independent_peer() {
    let net = Net::new(6);
    let file = testkit::in_test("4.mid");
    // 400 quarter notes at 120 BPM, notes 48..71 in turn: a note tells its quarter.
    std::fs::write(&file, testkit::smf::quarters_smf(400, 120.0)).unwrap();
    let file = file.to_str().unwrap();
    for robot in 1..=5 {
        net.lossy(robot, 20, 50);
    }
    let mut peer = Peer::start(&net, 0, 5);
    // Its session is older than the robots' by more than Link's 0.5 s: theirs join it (two
    // sessions met within 0.5 s go by their ids).
    std::thread::sleep(Duration::from_millis(1_500));
    let mut robots: Vec<Child> = (1..=3)
        .map(|i| robot(&net, i, file, 9000 + i as u16))
        .collect();
    // A fifth robot sends each note early by its own mechanics, as robots do.
    let compensated = spawn(robot_args(&net, file, 9005, &[]), |args| {
        net.command(5, ORCH, args)
    });
    peer.wait_peers(4);
    let started = peer.ask("start");
    std::thread::sleep(Duration::from_secs(6));
    let changed = peer.ask("tempo 130");
    std::thread::sleep(Duration::from_secs(3));
    let joined_at = peer.ask("now")[0];
    robots.push(robot(&net, 4, file, 9004));
    std::thread::sleep(Duration::from_secs(5));
    // The first robot leaves (SIGTERM: every key up, the report); nobody else notices.
    let left_at = peer.ask("now")[0];
    let killed = Command::new("kill")
        .args(["-TERM", &robots[0].id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    std::thread::sleep(Duration::from_secs(3));
    let stopped = peer.ask("stop");
    let stop_us = stopped[0];
    // A robot that says the session plays (as each does every second, for newcomers) before
    // the stop has reached it leaves the session playing again, since its old start: the
    // peer does that here, once the robots have stopped. They stop the session again.
    std::thread::sleep(Duration::from_millis(300));
    peer.ask("cross");
    let compensated = exited(compensated, Duration::from_secs(10));
    let compensated_err = String::from_utf8_lossy(&compensated.stderr).into_owned();
    assert!(compensated.status.success(), "{compensated_err}");
    let mut said = vec![compensated_err.clone()];
    let compensated: Value = serde_json::from_slice(&compensated.stdout).unwrap();
    let mut ended = Vec::new();
    for (i, r) in robots.into_iter().enumerate() {
        let out = exited(r, Duration::from_secs(10));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "robot {}: {err}", i + 1);
        // The one that left did not wait for the session to stop.
        assert_eq!(
            err.contains("the session stopped"),
            i > 0,
            "robot {}: {err}",
            i + 1
        );
        ended.push(serde_json::from_slice::<Value>(&out.stdout).unwrap());
        said.push(err.into_owned());
    }
    assert_eq!(peer.ask("now")[3], 0.0, "the crossed stop: playing again");
    assert!(
        said.iter().any(|e| e.contains("stopped the session again")),
        "{said:?}"
    );
    let report = peer.report();
    let all = onsets(&report);
    let by = |r: usize| of_robot(&all, r);

    if let Ok(path) = std::env::var("ORCH_LINK_DUMP") {
        std::fs::write(path, serde_json::to_string(&report).unwrap()).unwrap();
    }
    // The compensated robot: each note sent early by its key's own delay (the same for every
    // repeat of a note, within the bound every note is held to), and its copy at the far end
    // sounded each on the beat.
    // (The second after the tempo change aside, as for every robot below.)
    let changed_us = changed[0];
    let settled = |o: &&Onset| !(changed_us..changed_us + CHANGE_US).contains(&o.host_us);
    let early = by(4);
    assert!(early.len() > 10, "{} notes: {compensated_err}", early.len());
    for note in 48..72 {
        let offs: Vec<f64> = early
            .iter()
            .filter(settled)
            .filter(|o| o.note == note)
            .map(Onset::off_ms)
            .collect();
        let (lo, hi) = offs
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), &o| (l.min(o), h.max(o)));
        // Each repeat as exact as any robot's note (ON_BEAT_MS): each rides the steering's
        // error of its moment (a CI run sent note 48 at -14.98 and -13.23 ms).
        assert!(
            hi < -1.0 && hi - lo < ON_BEAT_MS,
            "note {note}: sent {offs:?} ms off its beat"
        );
    }
    let onset = &compensated["onset_ms"];
    // Its own report: each note's copy sounded within the bound every note is held to (a run
    // had one 1.54 ms late; the 1 ms it was held to before is tighter than any other note).
    assert!(onset["max"].as_f64().unwrap() < ON_BEAT_MS, "{onset}");
    let all: Vec<Onset> = all.iter().filter(|o| o.robot != 4).copied().collect();

    // Every note of every robot on its beat, but in the second after the tempo change: the
    // change reaches the robots some 20 ms after the peer made it (Link's own pace), and a note
    // due in that time comes up to 30 % of it late (100 -> 130 BPM). A robot whose copy of the
    // change was lost (one multicast Link datagram in twenty, at every robot host) hears of it
    // later and catches up (at most 25 % faster): a CI run had a note 13.09 ms off after the
    // first beat.
    let changing: Vec<f64> = all
        .iter()
        .filter(|o| !settled(o))
        .map(|o| o.off_ms().abs())
        .collect();
    eprintln!(
        "in the second after the tempo change: {} notes, the worst {:.2} ms off its beat",
        changing.len(),
        changing.iter().copied().fold(0.0, f64::max)
    );
    // A note farther off than ON_BEAT_MS is set aside as the host's when it stands alone: the
    // robot's notes on either side of it on the beat, one such note a robot at most, and less
    // than STALL_MS off. This machine is a virtual one whose CPUs stall now and then: an idle
    // SCHED_FIFO thread sleeping 1 ms woke 2.9 ms late within 30 s, and 2 runs in some 20 had
    // one note 6-8 ms late (where saved, its neighbours within 0.11 ms). Link's phase, what is
    // tested here, moves every note after it, not one.
    let stalls: Vec<Onset> = (0..4)
        .flat_map(|r| {
            let notes: Vec<Onset> = by(r).into_iter().filter(|o| settled(&o)).collect();
            lone_late(&notes)
        })
        .collect();
    for r in 0..4 {
        let of_r: Vec<&Onset> = stalls.iter().filter(|o| o.robot == r).collect();
        assert!(of_r.len() <= 1, "robot {r}: {of_r:?}");
    }
    for o in &stalls {
        assert!(o.off_ms().abs() < STALL_MS, "{o:?}");
        eprintln!(
            "set aside as the host's stall: {o:?}, {:.2} ms off",
            o.off_ms()
        );
    }
    let is_stall = |o: &Onset| {
        stalls
            .iter()
            .any(|s| s.robot == o.robot && s.host_us == o.host_us)
    };
    let mut kept: Vec<&Onset> = all
        .iter()
        .filter(settled)
        .filter(|o| !is_stall(o))
        .collect();
    kept.sort_by(|a, b| a.off_ms().abs().total_cmp(&b.off_ms().abs()));
    assert!(kept.len() > 4 * 20, "{} notes", kept.len());
    let worst_note = kept[kept.len() - 1];
    let worst = worst_note.off_ms().abs();
    // Which note, and when, against the piece's events (ms; negative: before).
    let at = |o: &Onset| {
        let ms = |t: f64| (o.host_us - t) / 1e3;
        format!(
            "{o:?}: {:.0} ms from the start, {:.0} from the tempo change, {:.0} from the \
             newcomer's start, {:.0} from the leave, {:.0} from the stop",
            ms(started[0]),
            ms(changed[0]),
            ms(joined_at),
            ms(left_at),
            ms(stop_us)
        )
    };
    assert!(
        worst < ON_BEAT_MS,
        "a note {worst:.2} ms off its beat: {}",
        at(worst_note)
    );

    // Bar one: the first bar line at least a beat after the start, the same for the three
    // (and for the newcomer, below, that reads the start after the tempo change).
    let (start_us, start_beat) = (started[0], started[1]);
    let bar_one = ((start_beat + orch_link::LEAD_IN_BEATS) / 4.0).ceil() * 4.0;
    for r in 0..3 {
        let first = by(r)[0];
        assert_eq!(first.beat.round(), bar_one, "{first:?}");
        assert_eq!(first.note, 48, "{first:?}: not the top");
        assert!(first.host_us > start_us);
    }

    // At every beat, every robot that plays it plays the same quarter of the score.
    let quarter_of = |o: &Onset| (o.beat.round() - bar_one) as i64;
    for o in &all {
        assert_eq!(
            i64::from(o.note) - 48,
            quarter_of(o).rem_euclid(24),
            "robot {} at beat {:.3}",
            o.robot,
            o.beat
        );
    }

    // The tempo change is followed: a second after it, each robot's notes come a 130 BPM beat
    // apart (and on the beat, above).
    let beat_after = changed[0] + CHANGE_US;
    for r in 0..3 {
        let after: Vec<Onset> = by(r)
            .into_iter()
            .filter(|o| o.host_us > beat_after)
            .collect();
        assert!(after.len() > 10);
        for w in after.windows(2) {
            let gap_ms = (w[1].host_us - w[0].host_us) / 1e3;
            assert!(
                (gap_ms - 60e3 / 130.0).abs() < ON_BEAT_MS,
                "{:?}: {gap_ms:.2} ms",
                w[1]
            );
        }
    }

    // The robot that joined mid-piece came in on a beat, at the score's place there, soon.
    let late = by(3);
    assert!(!late.is_empty(), "the fourth robot never came in");
    assert!(quarter_of(&late[0]) > 8, "{:?}", late[0]);
    let waited = late[0].host_us - joined_at;
    assert!(
        waited < 8e6,
        "it came in {:.0} ms after it was started",
        waited / 1e3
    );
    let skipped = ended[3]["outcomes"]["skipped"].as_u64().unwrap();
    assert!(skipped as i64 >= quarter_of(&late[0]), "{skipped}");

    // Joining changed nobody's tempo.
    assert_eq!(peer.ask("tempo 130")[2], 130.0);

    // The robot that left let every key go as it left; the others played on, on the beat
    // (above), three of them to the stop.
    let last_of = |r: usize| report.iter().rfind(|m| m["peer"] == r).unwrap();
    let left_ms = (last_of(0)["host_us"].as_f64().unwrap() - left_at) / 1e3;
    assert!(
        (0.0..500.0).contains(&left_ms),
        "it let go {left_ms:.0} ms after it was told to leave"
    );
    // (The two that began with it: the newcomer may still be joining.)
    for r in 1..3 {
        assert!(
            by(r).iter().filter(|o| o.host_us > left_at + 1e6).count() >= 4,
            "robot {r}"
        );
    }

    // The stop: every robot's last message is an All Notes Off or All Sound Off, soon after.
    for r in 0..5 {
        let last = last_of(r);
        let b: Vec<u64> = last["bytes"]
            .as_array()
            .unwrap()
            .iter()
            .filter_map(Value::as_u64)
            .collect();
        assert!(
            b[0] & 0xF0 == 0xB0 && (b[1] == 123 || b[1] == 120),
            "robot {}: {b:?}",
            r + 1
        );
        let after_ms = (last["host_us"].as_f64().unwrap() - stop_us) / 1e3;
        assert!(
            r == 0 || after_ms < 500.0,
            "robot {} stopped {after_ms:.0} ms after",
            r + 1
        );
    }

    // The figure: the spread of each beat's onsets across the robots that played it.
    let mut spreads = Vec::new();
    let mut beats: Vec<i64> = all.iter().map(|o| o.beat.round() as i64).collect();
    beats.dedup();
    for b in beats {
        let at: Vec<f64> = all
            .iter()
            .filter(|o| o.beat.round() as i64 == b)
            .map(|o| o.host_us)
            .collect();
        if at.len() >= 3 {
            let (lo, hi) = at
                .iter()
                .fold((f64::MAX, f64::MIN), |(l, h), &t| (l.min(t), h.max(t)));
            spreads.push((hi - lo) / 1e3);
        }
    }
    spreads.sort_by(f64::total_cmp);
    eprintln!(
        "the fourth robot came in {:.0} ms after it was started",
        waited / 1e3
    );
    eprintln!(
        "onset spread across robots: median {:.3}, p99 {:.3}, max {:.3} ms over {} beats; off the beat max {worst:.3} ms",
        percentile(&spreads, 0.5),
        percentile(&spreads, 0.99),
        spreads[spreads.len() - 1],
        spreads.len()
    );
    let _ = std::fs::remove_file(file);
}

/// A robot that finds no other peer says so once, after `ALONE_AFTER`, with where Link's
/// discovery must pass, and goes on waiting; a signal ends the wait, nothing sent.
#[test]
fn a_robot_alone_says_it_found_no_peer_and_waits() {
    let net = Net::new(1);
    let file = testkit::in_test("alone.mid");
    std::fs::write(&file, testkit::smf::quarters_smf(4, 120.0)).unwrap();
    let alone = robot(&net, 0, file.to_str().unwrap(), 9001);
    std::thread::sleep(orch_link::session::ALONE_AFTER + Duration::from_millis(1_500));
    let stopped = Command::new("kill")
        .args(["-TERM", &alone.id().to_string()])
        .status()
        .unwrap();
    assert!(stopped.success());
    let out = exited(alone, Duration::from_secs(5));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let said: Vec<&str> = err
        .lines()
        .filter(|l| l.contains("no other Link peer"))
        .collect();
    assert_eq!(said.len(), 1, "{err}");
    assert!(
        said[0].contains("224.76.78.75") && said[0].contains("20808"),
        "{err}"
    );
    assert!(!err.contains("coming in"), "{err}");
    assert!(
        out.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let _ = std::fs::remove_file(file);
}

/// `--start` starts a session nobody has started, once it has listened for one for a second;
/// the robot comes in on bar one, and the other peers see the session play.
#[test]
fn a_robot_with_start_starts_the_session_and_comes_in_on_bar_one() {
    let net = Net::new(2);
    let file = testkit::in_test("1.mid");
    std::fs::write(&file, testkit::smf::quarters_smf(12, 120.0)).unwrap();
    let mut peer = Peer::start(&net, 0, 1);
    std::thread::sleep(Duration::from_millis(1_500));
    let begun = peer.ask("now")[0];
    let robot = robot_with(&net, 1, file.to_str().unwrap(), 9001, &["--start"]);
    let out = exited(robot, Duration::from_secs(20));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = peer.report();
    let all = onsets(&report);
    assert_eq!(all.len(), 12);
    // The file played to its end on the beat; the session still plays.
    assert!(all.iter().all(|o| o.off_ms().abs() < ON_BEAT_MS), "{all:?}");
    assert!(
        all[0].beat.round() % 4.0 == 0.0,
        "bar one is on a bar line: {:?}",
        all[0]
    );
    let first_ms = (all[0].host_us - begun) / 1e3;
    eprintln!("--start: the first note {first_ms:.0} ms after the robot was started");
    // A second to listen, a beat of lead-in (0.6 s at the session's 100 BPM), and at most a
    // bar (2.4 s) more to its line.
    assert!((1_600.0..4_500.0).contains(&first_ms), "{first_ms}");
    let _ = std::fs::remove_file(file);
}

/// The Raspberry Pi's orch (aarch64, built with `link`) finds the session, comes in on the
/// same bar one and plays in phase with this machine's own. scripts/pi.sh builds it and runs this test with `ORCH_ARM64`
/// naming a script that runs it under qemu-user; `cargo test` alone skips it.
#[test]
#[ignore = "scripts/pi.sh runs it, with ORCH_ARM64 naming its arm64 orch under qemu"]
fn an_arm64_robot_plays_in_phase_under_qemu() {
    let arm64 = std::env::var("ORCH_ARM64").expect("ORCH_ARM64: a script running the arm64 orch");
    let net = Net::new(3);
    let file = testkit::in_test("arm64.mid");
    std::fs::write(&file, testkit::smf::quarters_smf(24, 120.0)).unwrap();
    let file = file.to_str().unwrap();
    let mut peer = Peer::start(&net, 0, 2);
    std::thread::sleep(Duration::from_millis(1_500));
    let host = robot(&net, 1, file, 9001);
    let account = testkit::in_test("arm64-notes.jsonl");
    let notes = account.to_str().unwrap();
    let mut args = robot_args(&net, file, 9002, &["--notes", notes]);
    args.push("--no-compensation".into());
    let pi = spawn(args, |args| net.command(2, &arm64, args));
    peer.wait_peers(2);
    // Under qemu the arm64 robot takes longer to start listening: time to join.
    std::thread::sleep(Duration::from_secs(2));
    let started = peer.ask("start");
    for (name, robot) in [("this machine's", host), ("the arm64", pi)] {
        let out = exited(robot, Duration::from_secs(30));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{name} robot: {err}");
    }
    let all = onsets(&peer.report());
    let by = |r: usize| of_robot(&all, r);
    let (host, pi) = (by(0), by(1));
    assert_eq!((host.len(), pi.len()), (24, 24), "{all:?}");
    // Bar one the same for both, each note on its beat, the two together.
    let bar_one = ((started[1] + orch_link::LEAD_IN_BEATS) / 4.0).ceil() * 4.0;
    let mut spreads: Vec<f64> = Vec::new();
    for (h, p) in host.iter().zip(&pi) {
        assert_eq!(
            (h.note, h.beat.round()),
            (p.note, p.beat.round()),
            "{h:?} {p:?}"
        );
        spreads.push((h.host_us - p.host_us).abs() / 1e3);
    }
    assert_eq!(host[0].beat.round(), bar_one, "{:?}", host[0]);
    let offs: Vec<String> = pi.iter().map(|o| format!("{:.2}", o.off_ms())).collect();
    eprintln!(
        "arm64 (qemu): each note off its beat, ms: {}",
        offs.join(" ")
    );
    spreads.sort_by(f64::total_cmp);
    eprintln!(
        "arm64 (qemu) against this machine's robot: onsets apart median {:.3}, max {:.3} ms over {} beats",
        percentile(&spreads, 0.5),
        spreads[spreads.len() - 1],
        spreads.len()
    );
    // This machine's notes on their beat. The arm64 robot's are judged in two parts. First,
    // how late each Note-On left by its own clock (`sent_late_ms` in its account), held to
    // QEMU_LATE_MS: qemu translates the code that sends a note the first time it runs it (the
    // first note's 6-10 ms), and an emulated unoptimised build on a busy machine sends late now
    // and then (a CI run had one note 29 ms late, its neighbours within 1.7 ms). The rest is
    // where the robot put the beat: its median is its phase against the session, held to
    // QEMU_PHASE_MS, and each note is held to ON_BEAT_MS of it.
    for o in &host {
        assert!(o.off_ms().abs() < ON_BEAT_MS, "{o:?}");
    }
    let late = sent_late_ms(&account);
    assert_eq!(late.len(), pi.len(), "{late:?}");
    let shown: Vec<String> = late.iter().map(|l| format!("{l:.2}")).collect();
    eprintln!(
        "arm64 (qemu): each Note-On sent late by its own clock, ms: {}",
        shown.join(" ")
    );
    let rest: Vec<f64> = pi.iter().zip(&late).map(|(o, l)| o.off_ms() - l).collect();
    let mut sorted = rest.clone();
    sorted.sort_by(f64::total_cmp);
    let phase = percentile(&sorted, 0.5);
    eprintln!("arm64 (qemu): its phase against the session {phase:.2} ms");
    assert!(phase.abs() < QEMU_PHASE_MS, "{rest:?}");
    for ((o, late), rest) in pi.iter().zip(&late).zip(&rest) {
        assert!(*late < QEMU_LATE_MS, "{o:?} sent {late} ms late");
        assert!(
            (rest - phase).abs() < ON_BEAT_MS,
            "{o:?} sent {late} ms late; phase {phase}"
        );
    }
    let _ = std::fs::remove_file(account);
    let _ = std::fs::remove_file(file);
}

/// `orch conduct --link` leads the session: it starts it for bar one, where its own
/// performance starts, and publishes the tempo its conductor gives (here OSC tempo
/// statements), so robots waiting on other hosts come in with it and follow; when its
/// performance ends the session stops, and so do they.
#[test]
fn a_conductor_leads_robots_on_other_hosts() {
    let net = Net::new(4);
    let short = testkit::in_test("c24.mid");
    let long = testkit::in_test("c400.mid");
    std::fs::write(&short, testkit::smf::quarters_smf(24, 120.0)).unwrap();
    std::fs::write(&long, testkit::smf::quarters_smf(400, 120.0)).unwrap();
    let mut peer = Peer::start(&net, 0, 3);
    std::thread::sleep(Duration::from_millis(1_500));
    let robots: Vec<Child> = (2..=3)
        .map(|i| robot(&net, i, long.to_str().unwrap(), 9000 + i as u16))
        .collect();
    peer.wait_peers(2);
    let osc_at = format!("{}:9100", net.addr(1));
    let source = format!("osc:{osc_at}");
    let mut args = robot_args(&net, short.to_str().unwrap(), 9001, &["--source", &source]);
    args[0] = "conduct".into();
    args.retain(|a| a != "--link");
    args.extend(["--link".into(), "--no-compensation".into()]);
    let conductor = spawn(args, |a| net.command(1, ORCH, a));
    // A second listening, then bar one a second or two later; then 150 BPM, then 100.
    std::thread::sleep(Duration::from_secs(5));
    let osc = std::net::UdpSocket::bind(format!("10.77.{}.1:0", net.subnet)).unwrap();
    let mut tempo = |bpm: f32| {
        let m = orch_perform::conduct::encode_osc(
            "/orch/tempo",
            &[orch_perform::conduct::OscArg::Float(bpm)],
        );
        osc.send_to(&m, &osc_at).unwrap();
        peer.ask("now")[0]
    };
    let fast_at = tempo(150.0);
    std::thread::sleep(Duration::from_secs(3));
    let slow_at = tempo(100.0);
    // Once the conductor has stopped the session, an announcement that crossed its stop (here
    // the independent peer's): the conductor and the robots stop the session again.
    let until = Instant::now() + Duration::from_secs(20);
    while peer.ask("now")[3] == 1.0 {
        assert!(
            Instant::now() < until,
            "the conductor never stopped the session"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    peer.ask("cross");
    let conductor = exited(conductor, Duration::from_secs(10));
    let err = String::from_utf8_lossy(&conductor.stderr).into_owned();
    assert!(conductor.status.success(), "{err}");
    assert!(err.contains("stopped the Link session"), "{err}");
    let mut said = vec![err];
    for r in robots {
        let out = exited(r, Duration::from_secs(10));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("the session stopped"), "{err}");
        said.push(err.into_owned());
    }
    assert_eq!(peer.ask("now")[3], 0.0, "the crossed stop: playing again");
    assert!(
        said.iter().any(|e| e.contains("stopped the session again")),
        "{said:?}"
    );
    let all = onsets(&peer.report());
    let by = |r: usize| of_robot(&all, r);
    // The conductor played its 24 quarters; the robots with it, on the same beats, the same
    // quarter of the score, and stopped with it.
    assert_eq!(by(0).len(), 24);
    let first = by(0)[0].beat.round();
    // On the beat, but in the second after each tempo change: the robots hear of it through
    // Link some 20 ms after the conductor makes it (more on a busy machine: one note of a CI
    // run came 31 ms early after 150 -> 100 BPM), as in the first test.
    let changing = |o: &Onset| {
        [fast_at, slow_at]
            .iter()
            .any(|&at| (at..at + CHANGE_US).contains(&o.host_us))
    };
    for o in &all {
        assert!(changing(o) || o.off_ms().abs() < ON_BEAT_MS, "{o:?}");
        let quarter = (o.beat.round() - first) as i64;
        assert_eq!(i64::from(o.note) - 48, quarter.rem_euclid(24), "{o:?}");
    }
    for r in 1..=2 {
        assert_eq!(
            by(r)[0].beat.round(),
            first,
            "robot {r} came in with the conductor"
        );
        assert!(by(r).len() >= 23, "robot {r}: {} notes", by(r).len());
    }
    // Each tempo followed by every robot within a beat.
    for r in 0..=2 {
        let gaps = |from: f64, to: f64| {
            let notes: Vec<Onset> = by(r)
                .into_iter()
                .filter(|o| o.host_us > from && o.host_us < to)
                .collect();
            notes
                .windows(2)
                .map(|w| (w[1].host_us - w[0].host_us) / 1e3)
                .collect::<Vec<_>>()
        };
        for (gap, from, to) in [
            (400.0, fast_at + 400e3, slow_at),
            (600.0, slow_at + 600e3, f64::MAX),
        ] {
            let g = gaps(from, to);
            assert!(g.len() >= 3, "robot {r}: {g:?}");
            assert!(
                g.iter().all(|x| (x - gap).abs() < ON_BEAT_MS),
                "robot {r}: {g:?}"
            );
        }
    }
    let _ = std::fs::remove_file(short);
    let _ = std::fs::remove_file(long);
}

/// `curl` in host `host`'s namespace: the status and body of `method path` (with `body`) on
/// `orch serve` there.
fn curl(net: &Net, host: usize, port: u16, method: &str, body: Option<&str>) -> (u16, Value) {
    let url = format!("http://127.0.0.1:{port}/api/session");
    let mut args = vec![
        "-s",
        "-o",
        "-",
        "-w",
        "\n%{http_code}",
        "-X",
        method,
        url.as_str(),
    ];
    if let Some(b) = body {
        args.extend(["-H", "Content-Type: application/json", "--data", b]);
    }
    let out = net.command(host, "curl", &args).output().expect("curl");
    let text = String::from_utf8_lossy(&out.stdout);
    let (json, code) = text.rsplit_once('\n').unwrap();
    (
        code.parse().unwrap(),
        serde_json::from_str(json).unwrap_or(Value::Null),
    )
}

/// `orch serve --link`: the page's API shows the session (peers, tempo, playing) and starts,
/// stops and sets the tempo of it, as an independent peer sees; a tempo out of Link's range
/// is refused and changes nothing.
#[test]
fn the_web_page_shows_and_steers_the_session() {
    let net = Net::new(2);
    let mut peer = Peer::start(&net, 0, 1);
    std::thread::sleep(Duration::from_millis(1_500));
    let mut serve = net
        .command(1, ORCH, &["serve", "--link", "--listen", "127.0.0.1:8790"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("orch serve");
    let mut first = String::new();
    BufReader::new(serve.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    assert!(first.contains("the page is at"), "{first}");
    peer.wait_peers(1);
    let until = Instant::now() + Duration::from_secs(10);
    let shown = loop {
        let (code, s) = curl(&net, 1, 8790, "GET", None);
        assert_eq!(code, 200, "{s}");
        if s["peers"] == 1 && s["bpm"].as_f64().is_some_and(|b| (b - 100.0).abs() < 0.01) {
            break s;
        }
        assert!(
            Instant::now() < until,
            "the page never showed the session: {s}"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    assert_eq!(shown["playing"], false);
    let settle = || std::thread::sleep(Duration::from_millis(500));
    let (code, s) = curl(&net, 1, 8790, "POST", Some(r#"{"start": true}"#));
    assert_eq!((code, &s["playing"]), (200, &Value::Bool(true)));
    settle();
    assert_eq!(peer.ask("now")[3], 1.0, "the independent peer sees it play");
    curl(&net, 1, 8790, "POST", Some(r#"{"bpm": 140}"#));
    settle();
    // Link sends a tempo as µs a beat: 140 BPM arrives as 140.00014.
    let near = |a: f64, b: f64| (a - b).abs() < 0.01;
    assert!(near(peer.ask("now")[2], 140.0));
    peer.ask("tempo 90");
    settle();
    let shown = curl(&net, 1, 8790, "GET", None).1["bpm"].as_f64().unwrap();
    assert!(near(shown, 90.0), "{shown}");
    let (code, s) = curl(&net, 1, 8790, "POST", Some(r#"{"bpm": 5}"#));
    assert_eq!(code, 400, "{s}");
    let (code, _) = curl(
        &net,
        1,
        8790,
        "POST",
        Some(r#"{"start": true, "stop": true}"#),
    );
    assert_eq!(code, 400);
    curl(&net, 1, 8790, "POST", Some(r#"{"stop": true}"#));
    // An announcement that crossed the page's stop (here the peer's): the page stops the
    // session again.
    std::thread::sleep(Duration::from_millis(200));
    peer.ask("cross");
    settle();
    let now = peer.ask("now");
    assert!(near(now[2], 90.0) && now[3] == 0.0, "{now:?}");
    // The page says so when its guard ends, a second after its last stop.
    std::thread::sleep(Duration::from_secs(1));
    let _ = serve.kill();
    let out = serve.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("stopped the session again"), "{err}");
}
