"""The independent Link peer of tests/link.rs: Ableton's own Link SDK (LinkPython-extern,
from PyPI), not orch. It sets the session's tempo and starts and stops it, as told on its
standard input, and it is the robots' collector: each robot sends its MIDI to one of its UDP
ports, and every message is stamped with the moment it arrived (the kernel's receive
timestamp, so that this process's own scheduling delays nothing) in this peer's view of the
session (its host time, beat and tempo).

Commands, one a line: `tempo BPM`, `start`, `stop`, `cross` (plays again since the start the
session had when this peer last saw it play: what an announcement that crossed a stop
leaves), `now` (prints the host
time, beat, tempo and 1 if the session plays), `peers` (prints the number of other peers),
`report` (prints every message received as one JSON line), `quit`. Each command is
answered with one line (`ok ...`) once done."""

import json
import select
import socket
import struct
import sys
import threading
import time

import link

QUANTUM = 4.0
# Linux's SO_TIMESTAMPNS (asm-generic and x86: 35), which Python 3.11's socket lacks.
SO_TIMESTAMPNS = getattr(socket, "SO_TIMESTAMPNS", 35)


def arrival_us(ancillary, now_us):
    """The kernel's receive time (CLOCK_REALTIME) on the session's host clock (Link's:
    CLOCK_MONOTONIC_RAW, µs); `now_us` if the kernel gave none."""
    for level, kind, data in ancillary:
        if level == socket.SOL_SOCKET and kind == SO_TIMESTAMPNS:
            sec, nsec = struct.unpack("qq", data[:16])
            real = time.clock_gettime_ns(time.CLOCK_REALTIME)
            raw = time.clock_gettime_ns(time.CLOCK_MONOTONIC_RAW)
            return (sec * 1_000_000_000 + nsec - real + raw) // 1000
    return now_us


def main():
    address, first_port, ports = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    session = link.Link(100.0)
    session.startStopSyncEnabled = True
    session.enabled = True
    socks = []
    for i in range(ports):
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.setsockopt(socket.SOL_SOCKET, SO_TIMESTAMPNS, 1)
        s.bind((address, first_port + i))
        socks.append(s)
    received = []
    lock = threading.Lock()

    def collect():
        while True:
            ready, _, _ = select.select(socks, [], [])
            for s in ready:
                data, ancillary, _, _ = s.recvmsg(64, 64)
                t = arrival_us(ancillary, session.clock().micros())
                state = session.captureAppSessionState()
                with lock:
                    received.append({
                        "peer": socks.index(s),
                        "bytes": list(data),
                        "host_us": t,
                        "beat": state.beatAtTime(t, QUANTUM),
                        "bpm": state.tempo(),
                    })

    threading.Thread(target=collect, daemon=True).start()
    print("ready", flush=True)
    played_since = None
    for line in sys.stdin:
        words = line.split()
        if not words:
            continue
        now = session.clock().micros()
        state = session.captureAppSessionState()
        if state.isPlaying():
            played_since = state.timeForIsPlaying()
        if words[0] == "tempo":
            state.setTempo(float(words[1]), now)
            session.commitAppSessionState(state)
        elif words[0] == "start":
            state.setIsPlaying(True, now)
            session.commitAppSessionState(state)
        elif words[0] == "stop":
            state.setIsPlaying(False, now)
            session.commitAppSessionState(state)
        elif words[0] == "cross" and played_since is not None:
            # What a peer's announcement that crossed a stop leaves: the session playing
            # again since the start it had (a µs off, as an orch peer announces it).
            state.setIsPlaying(True, played_since + 1)
            session.commitAppSessionState(state)
        elif words[0] == "peers":
            print("ok", session.numPeers(), flush=True)
            continue
        elif words[0] == "report":
            with lock:
                print(json.dumps(received), flush=True)
            continue
        elif words[0] == "quit":
            break
        elif words[0] != "now":
            print("unknown command", words[0], flush=True)
            continue
        state = session.captureAppSessionState()
        print("ok", now, state.beatAtTime(now, QUANTUM), state.tempo(),
              int(state.isPlaying()), flush=True)


main()
