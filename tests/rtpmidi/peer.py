"""An RTP-MIDI session initiator and sender for orch's tests, independent of orch's code.

pymidi 0.5.0 (the independent peer) can answer a session but not begin one, and it sends
no MIDI at all: its client is a stub. So this side is written here from RFC 6295 and
Apple's session protocol, with pymidi's own packet definitions (construct structs) for
the AppleMIDI commands and the RTP header, and the MIDI command section and recovery
journal (chapters N and C) coded by hand from the RFC's figures.

    python3 peer.py SCRIPT.json

SCRIPT: {"port": orch's control port, "name": "...", "journal": true,
         "steps": [{"send": [[delta, [bytes...]], ...], "drop": false},
                   {"sleep_ms": 100}, {"garbage": "hex", "to": "data" | "control"},
                   {"bye": true}, {"vanish": true}],
         "linger_ms": 300}

Prints one JSON line per event: ok (an invitation answered), ck1, sent / dropped (a
packet and its sequence number), rs (receiver feedback from orch), done.
"""

import json
import random
import select
import socket
import sys
import time

from pymidi import packets


def out(**event):
    print(json.dumps(event), flush=True)


class Journal:
    """The sender's side of RFC 6295's recovery journal, for chapters N and C."""

    def __init__(self, first_seq):
        self.checkpoint = first_seq
        self.notes = {}  # (channel, note) -> ("on", velocity, seq) | ("off", None, seq)
        self.ctls = {}  # (channel, number) -> (value, toggles, seq)

    def track(self, msg, seq):
        status = msg[0]
        ch, kind = status & 0x0F, status & 0xF0
        if kind == 0x90 and msg[2] > 0:
            self.notes[(ch, msg[1])] = ("on", msg[2], seq)
        elif kind in (0x80, 0x90):
            self.notes[(ch, msg[1])] = ("off", None, seq)
        elif kind == 0xB0:
            value, toggles, _ = self.ctls.get((ch, msg[1]), (0, 0, 0))
            if (msg[2] >= 64) != (value >= 64):
                toggles = (toggles + 1) % 64
            self.ctls[(ch, msg[1])] = (msg[2], toggles, seq)
            if msg[1] == 120 or msg[1] >= 123:
                for key in [k for k in self.notes if k[0] == ch]:
                    del self.notes[key]

    def covered(self, seq, now):
        return (seq - self.checkpoint) % 65536 < (now - self.checkpoint) % 65536

    def feedback(self, seq, now):
        if (seq - self.checkpoint) % 65536 < (now - self.checkpoint) % 65536:
            self.checkpoint = (seq + 1) % 65536

    def section(self, now):
        """The journal for packet `now` (Figures 8, 9, A.3.1, A.6.1)."""
        prev = (now - 1) % 65536
        channels = []
        single = True
        for ch in range(16):
            body, toc, s_chan = b"", 0, True
            ctls = sorted(
                (seq, num, value, toggles)
                for (c, num), (value, toggles, seq) in self.ctls.items()
                if c == ch and self.covered(seq, now)
            )
            logs = b""
            for seq, num, value, toggles in ctls:
                s = seq != prev
                s_chan &= s
                logs += bytes([(s << 7) | num, value])
                if num == 64:
                    logs += bytes([(s << 7) | num, 0x80 | toggles])
            if logs:
                toc |= 0x40
                body += bytes([(s_chan << 7) | (len(logs) // 2 - 1)]) + logs
            ons = sorted(
                (seq, note, vel)
                for (c, note), (st, vel, seq) in self.notes.items()
                if c == ch and st == "on" and self.covered(seq, now)
            )
            offs = [
                (note, seq)
                for (c, note), (st, _, seq) in self.notes.items()
                if c == ch and st == "off" and self.covered(seq, now)
            ]
            if ons or offs:
                toc |= 0x08
                b = all(seq != prev for _, seq in offs)
                s_chan &= b
                if offs:
                    low = min(n for n, _ in offs) // 8
                    high = max(n for n, _ in offs) // 8
                else:
                    low, high = 15, 1
                body += bytes([(b << 7) | len(ons), (low << 4) | high])
                for seq, note, vel in ons:
                    s = seq != prev
                    s_chan &= s
                    body += bytes([(s << 7) | note, 0x80 | vel])
                if offs:
                    bits = bytearray(high - low + 1)
                    for note, _ in offs:
                        bits[note // 8 - low] |= 0x80 >> (note % 8)
                    body += bytes(bits)
            if toc:
                single &= s_chan
                length = 3 + len(body)
                head = (s_chan << 15) | (ch << 11) | length
                channels.append(head.to_bytes(2, "big") + bytes([toc]) + body)
        top = (single << 7) | ((len(channels) > 0) << 5) | max(len(channels) - 1, 0)
        return bytes([top]) + self.checkpoint.to_bytes(2, "big") + b"".join(channels)


def delta_time(d):
    """Figure 4: 1-4 octets, 7 bits each, most significant first."""
    groups = [(d >> s) & 0x7F for s in (21, 14, 7)]
    while groups and groups[0] == 0:
        groups.pop(0)
    return bytes(0x80 | g for g in groups) + bytes([d & 0x7F])


def command_section(commands, journal):
    """Figure 2 and 3: Z = 1 (every command with its delta time), running status used."""
    lst, running = b"", None
    for delta, msg in commands:
        lst += delta_time(delta)
        if msg[0] < 0xF0 and msg[0] == running:
            lst += bytes(msg[1:])
        else:
            lst += bytes(msg)
            running = msg[0] if msg[0] < 0xF0 else (running if msg[0] >= 0xF8 else None)
    j = 0x40 if journal is not None else 0
    if len(lst) > 15:
        head = bytes([0x80 | j | 0x20 | (len(lst) >> 8), len(lst) & 0xFF])
    else:
        head = bytes([j | 0x20 | len(lst)])
    return head + lst + (journal or b"")


def exchange(command, token, ssrc, name=None):
    return packets.AppleMIDIExchangePacket.build(
        dict(command=command, protocol_version=2, initiator_token=token, ssrc=ssrc, name=name)
    )


def main():
    script = json.load(open(sys.argv[1]))
    host, port = "127.0.0.1", script["port"]
    ctl = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    ctl.bind(("127.0.0.1", 0))
    data = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    data.bind(("127.0.0.1", ctl.getsockname()[1] + 1))
    ssrc, token = random.randrange(1, 2**32), random.randrange(2**32)
    name = script.get("name", "peer")
    origin = time.monotonic()

    def clock():
        return int((time.monotonic() - origin) * 10000)

    for sock, to in ((ctl, port), (data, port + 1)):
        sock.sendto(exchange(b"IN", token, ssrc, name), (host, to))
        sock.settimeout(5)
        ok = packets.AppleMIDIExchangePacket.parse(sock.recv(1024))
        assert ok.command == b"OK" and ok.initiator_token == token, ok
        out(event="ok", port=to, name=ok.name)
    ck0 = dict(command=b"CK", ssrc=ssrc, count=0, timestamp_1=clock(), timestamp_2=0, timestamp_3=0)
    data.sendto(packets.AppleMIDITimestampPacket.build(ck0), (host, port + 1))
    ck1 = packets.AppleMIDITimestampPacket.parse(data.recv(1024))
    assert ck1.count == 1 and ck1.timestamp_1 == ck0["timestamp_1"], ck1
    ck2 = dict(ck0, count=2, timestamp_2=ck1.timestamp_2, timestamp_3=clock())
    data.sendto(packets.AppleMIDITimestampPacket.build(ck2), (host, port + 1))
    out(event="ck1", peer_time=ck1.timestamp_2)

    seq = random.randrange(65536)
    journal = Journal(seq) if script.get("journal", True) else None

    def take_feedback(wait):
        end = time.monotonic() + wait
        while True:
            left = end - time.monotonic()
            r, _, _ = select.select([ctl, data], [], [], max(left, 0))
            if not r:
                return
            for s in r:
                pkt = s.recv(1024)
                if pkt[:4] == b"\xff\xffRS":
                    rs = int.from_bytes(pkt[8:10], "big")
                    out(event="rs", seq=rs)
                    if journal:
                        journal.feedback(rs, seq)

    for step in script["steps"]:
        if "send" in step:
            cmds = [(d, bytes(m)) for d, m in step["send"]]
            header = packets.MIDIPacketHeader.build(
                {
                    "rtp_header": {
                        "flags": {"v": 2, "p": 0, "x": 0, "cc": 0, "m": 1, "pt": 0x61},
                        "sequence_number": seq,
                    },
                    "timestamp": clock() & 0xFFFFFFFF,
                    "ssrc": ssrc,
                }
            )
            section = journal.section(seq) if journal else None
            pkt = header + command_section(cmds, section)
            if step.get("drop"):
                out(event="dropped", seq=seq)
            else:
                data.sendto(pkt, (host, port + 1))
                out(event="sent", seq=seq, t=time.monotonic())
            if journal:
                for _, m in cmds:
                    journal.track(m, seq)
            seq = (seq + 1) % 65536
        elif "sleep_ms" in step:
            take_feedback(step["sleep_ms"] / 1000)
        elif "garbage" in step:
            to = port + 1 if step.get("to", "data") == "data" else port
            data.sendto(bytes.fromhex(step["garbage"]), (host, to))
        elif step.get("bye"):
            ctl.sendto(exchange(b"BY", token, ssrc), (host, port))
            out(event="bye")
        elif step.get("vanish"):
            out(event="vanish")
            break
    take_feedback(script.get("linger_ms", 300) / 1000)
    out(event="done")


if __name__ == "__main__":
    main()
