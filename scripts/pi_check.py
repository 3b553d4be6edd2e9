#!/usr/bin/env python3
"""Checks an `orch` binary built for the Raspberry Pi, run under qemu-user (scripts/pi.sh).

    pi_check.py reports --orch PI_ORCH --host HOST_ORCH SONG...
    pi_check.py serve   --orch PI_ORCH SONG

`--orch` runs the Pi's orch (scripts/pi.sh gives a script that execs `qemu-aarch64 -L
/usr/aarch64-linux-gnu target/aarch64-unknown-linux-gnu/debug/orch "$@"`); `--host` is this
machine's own build of the same source, the reference.

- reports: for each song, `orch play --fast` and `orch analyze --json` on the Pi's build: the
  notes counted equal the song's Note-Ons with a velocity (counted here, from the file), every
  note has exactly one outcome (README.md: on_time + late + unison + joined + dropped.* +
  skipped == notes + replayed, strikes == on_time + late), the text report says what the JSON
  says, and both print exactly what the host's build prints.
- serve: `orch serve --listen 127.0.0.1:0 --library DIR --out udp:…` on the Pi's build: the
  page, its JSON API (the state, the library, a song analysed exactly as `orch analyze --json`
  does), the song played until Note-Ons arrive on the UDP output, then SIGTERM: exit 0 within
  20 s, the output's last bytes All Notes Off on all 16 channels (every key released).

Exits 1 with what went wrong; Python's standard library only.
"""

import argparse
import json
import os
import re
import select
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request


class Failed(Exception):
    pass


def check(cond, what):
    if not cond:
        raise Failed(what)


def run(cmd, timeout=120):
    """Runs cmd; its standard output, or Failed with its standard error."""
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise Failed(f"{' '.join(cmd)}: no end after {timeout} s")
    if p.returncode != 0:
        raise Failed(f"{' '.join(cmd)}: exit {p.returncode}\n{p.stderr.strip()}")
    return p.stdout


def note_ons(path):
    """Note-Ons with a velocity in a Standard MIDI File, counted from its bytes."""
    data = open(path, "rb").read()
    check(data[:4] == b"MThd", f"{path}: not a Standard MIDI File")
    pos, count = 8 + int.from_bytes(data[4:8], "big"), 0
    while pos + 8 <= len(data):
        kind, length = data[pos : pos + 4], int.from_bytes(data[pos + 4 : pos + 8], "big")
        body, pos = data[pos + 8 : pos + 8 + length], pos + 8 + length
        if kind != b"MTrk":
            continue
        i, status = 0, 0

        def varlen():
            nonlocal i
            v = 0
            while True:
                b = body[i]
                i += 1
                v = (v << 7) | (b & 0x7F)
                if b < 0x80:
                    return v

        while i < len(body):
            varlen()  # delta time
            if body[i] >= 0x80:
                status = body[i]
                i += 1
            if status == 0xFF:  # meta: type, length, data
                i += 1
                n = varlen()  # (not `i += varlen()`: that adds to i as it was before the call)
                i += n
                status = 0  # meta and sysex events cancel running status
            elif status in (0xF0, 0xF7):
                n = varlen()
                i += n
                status = 0
            else:
                size = 1 if 0xC0 <= status < 0xE0 else 2
                if status & 0xF0 == 0x90 and body[i + 1] > 0:
                    count += 1
                i += size
    return count


def figures(text):
    """The play report's figures, by their line's label: its first number."""
    got = {}
    for line in text.splitlines():
        m = re.match(r"([a-z][a-z ']*[a-z])\s+(\d+)", line)
        if m:
            got[m.group(1)] = int(m.group(2))
    return got


def check_counts(song, report, notes):
    o = report["outcomes"]
    dropped = sum(o["dropped"].values())
    accounted = o["on_time"] + o["late"] + o["unison"] + o["joined"] + dropped + o["skipped"]
    check(
        report["notes"] == notes,
        f"{song}: analyze --json counts {report['notes']} notes, the file has {notes} Note-Ons",
    )
    check(
        accounted == report["notes"] + report["replayed"],
        f"{song}: outcomes add up to {accounted}, not notes + replayed = "
        f"{report['notes'] + report['replayed']}: {o}",
    )
    check(
        report["strikes"] == o["on_time"] + o["late"],
        f"{song}: {report['strikes']} strikes, but {o['on_time']} on time + {o['late']} late",
    )
    check(report["unmatched"] == 0, f"{song}: {report['unmatched']} strikes made no sound")
    check(isinstance(report["went_wrong"], list), f"{song}: no went_wrong list")
    return o, dropped


def reports(args):
    for song in args.songs:
        notes = note_ons(song)
        text = run([args.orch, "play", "--fast", song])
        host_text = run([args.host, "play", "--fast", song])
        check(
            text == host_text,
            f"{song}: orch play --fast prints on the Pi's build\n{text}\nand on the host's\n"
            f"{host_text}",
        )
        raw = run([args.orch, "analyze", "--json", song])
        try:
            report = json.loads(raw)
        except json.JSONDecodeError as e:
            raise Failed(f"{song}: orch analyze --json is not JSON ({e}): {raw[:300]}")
        host_raw = run([args.host, "analyze", "--json", song])
        check(
            report == json.loads(host_raw),
            f"{song}: orch analyze --json differs from the host's:\n{raw}\n{host_raw}",
        )
        o, dropped = check_counts(song, report, notes)
        f = figures(text)
        for label, want in [
            ("notes in the file", report["notes"]),
            ("struck on time", o["on_time"]),
            ("struck late", o["late"]),
            ("unison", o["unison"]),
            ("joined", o["joined"]),
            ("dropped", dropped),
            ("strikes heard", report["strikes"]),
        ]:
            check(
                f.get(label) == want,
                f"{song}: orch play --fast says {label} {f.get(label)}, analyze --json {want}",
            )
        print(
            f"{song}: {notes} notes, {o['on_time']} on time, {o['late']} late, "
            f"{dropped} dropped; the same report as the host's build"
        )


def http(url, method="GET", body=None, headers=None):
    req = urllib.request.Request(url, data=body, method=method, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=60) as r:
            return r.status, r.headers.get("Content-Type", ""), r.read()
    except urllib.error.HTTPError as e:
        raise Failed(f"{method} {url}: {e.code} {e.read()[:300]!r}")
    except OSError as e:
        raise Failed(f"{method} {url}: {e}")


def http_json(url, method="GET", payload=None):
    body = None if payload is None else json.dumps(payload).encode()
    headers = {} if payload is None else {"Content-Type": "application/json"}
    _, kind, raw = http(url, method, body, headers)
    check(kind.startswith("application/json"), f"{method} {url}: {kind}, not JSON")
    return json.loads(raw)


def serve(args):
    (song,) = args.songs
    name = os.path.basename(song)
    expected = json.loads(run([args.orch, "analyze", "--json", song]))
    library = tempfile.mkdtemp(prefix="orch-pi-library.")
    shutil.copy(song, library)
    udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    udp.bind(("127.0.0.1", 0))
    out = "udp:127.0.0.1:%d" % udp.getsockname()[1]
    cmd = [args.orch, "serve", "--listen", "127.0.0.1:0", "--library", library, "--out", out]
    server = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        # Its URL, the first line it prints (qemu takes a moment to start it).
        ready, _, _ = select.select([server.stdout], [], [], 60)
        line = server.stdout.readline() if ready else ""
        m = re.match(r"orch serve: the page is at (http://127\.0\.0\.1:\d+/)$", line.strip())
        check(m, f"orch serve printed no URL in 60 s: {line!r}, exit {server.poll()}")
        base = m.group(1)

        status, kind, page = http(base)
        check(status == 200 and kind.startswith("text/html"), f"GET /: {status} {kind}")
        check(b'data-testid="stop"' in page, "GET /: the page has no STOP button")

        state = http_json(base + "api/state")
        check(
            state["keyboard"] == {"low": 36, "high": 96} and state["outs"] == [out],
            f"GET /api/state: {state}",
        )
        library_files = http_json(base + "api/library")
        check(library_files == {"files": [name]}, f"GET /api/library: {library_files}")

        loaded = http_json(base + "api/library", "POST", {"name": name})
        check(
            loaded["analysis"] == expected,
            f"POST /api/library: the analysis is not orch analyze --json's: {loaded['analysis']}",
        )
        played = http_json(base + "api/command", "POST", {"cmd": "play", "song": loaded["id"]})
        check(
            (played["state"]["playing"] or {}).get("name") == name,
            f"play: the state shows no {name} playing: {played}",
        )

        # The performance under way: Note-Ons on the output.
        udp.settimeout(0.2)
        bytes_out, t0 = b"", time.monotonic()
        while sum(1 for b in bytes_out if b & 0xF0 == 0x90) < 3:
            check(time.monotonic() - t0 < 60, f"no Note-Ons on {out} in 60 s: {bytes_out.hex()}")
            try:
                bytes_out += udp.recv(256)
            except socket.timeout:
                pass

        t_term = time.monotonic()
        server.send_signal(signal.SIGTERM)
        try:
            code = server.wait(timeout=20)
        except subprocess.TimeoutExpired:
            raise Failed("orch serve was still running 20 s after SIGTERM")
        stop_s = time.monotonic() - t_term
        stderr = server.stderr.read()
        check(code == 0, f"orch serve exited {code} on SIGTERM:\n{stderr}")
        check("panic" not in stderr, f"orch serve panicked:\n{stderr}")
        while True:
            try:
                bytes_out += udp.recv(256)
            except socket.timeout:
                break
        all_off = bytes(b for ch in range(16) for b in (0xB0 | ch, 123, 0))
        check(
            bytes_out.endswith(all_off),
            f"the output's last bytes are not All Notes Off on every channel: {bytes_out[-60:].hex()}",
        )
        print(
            f"orch serve: the page, /api/state, /api/library, {name} analysed as by analyze --json "
            f"and played ({len(bytes_out)} bytes out); SIGTERM: exit 0 in {stop_s:.1f} s, "
            "All Notes Off on all 16 channels last"
        )
    finally:
        if server.poll() is None:
            server.kill()
            server.wait()
        shutil.rmtree(library, ignore_errors=True)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("what", choices=["reports", "serve"])
    p.add_argument("--orch", required=True, help="runs the Pi's orch")
    p.add_argument("--host", help="this machine's orch, the reference (reports)")
    p.add_argument("songs", nargs="+")
    args = p.parse_args()
    if args.what == "reports" and not args.host:
        p.error("reports needs --host")
    if args.what == "serve" and len(args.songs) != 1:
        p.error("serve takes one song")
    try:
        (reports if args.what == "reports" else serve)(args)
    except Failed as e:
        print(f"pi_check.py {args.what}: FAILED: {e}", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
