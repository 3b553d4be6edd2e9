#!/usr/bin/env python3
"""Writes ode-to-joy.mid: the "Ode to Joy" theme from Beethoven's Ninth Symphony (1824, public
domain), arranged here for orch's 61-key robot: melody on channel 1, left-hand chords on
channel 2, a low pedal note below the keyboard on channel 2 (it folds up an octave), and the
theme's repeated notes (E E, G G) that the guard must lift and strike again.

Run: python3 examples/make_ode_to_joy.py  (standard library only)."""
import struct
from pathlib import Path

TPQ = 480  # ticks per quarter note
BPM = 112

# (note, quarters); 0 = rest
MELODY = [
    (64, 1), (64, 1), (65, 1), (67, 1), (67, 1), (65, 1), (64, 1), (62, 1),
    (60, 1), (60, 1), (62, 1), (64, 1), (64, 1.5), (62, 0.5), (62, 2),
    (64, 1), (64, 1), (65, 1), (67, 1), (67, 1), (65, 1), (64, 1), (62, 1),
    (60, 1), (60, 1), (62, 1), (64, 1), (62, 1.5), (60, 0.5), (60, 2),
    (62, 1), (62, 1), (64, 1), (60, 1), (62, 1), (64, 0.5), (65, 0.5), (64, 1), (60, 1),
    (62, 1), (64, 0.5), (65, 0.5), (64, 1), (62, 1), (60, 1), (62, 1), (55, 2),
    (64, 1), (64, 1), (65, 1), (67, 1), (67, 1), (65, 1), (64, 1), (62, 1),
    (60, 1), (60, 1), (62, 1), (64, 1), (62, 1.5), (60, 0.5), (60, 2),
]
# One chord a bar (4 quarters): C, G, C, G | C, G, C, G | G, C, G, C+G | C, G, C, G(C)
CHORDS = {"C": (48, 52, 55), "G": (47, 50, 55), "F": (48, 53, 57)}
BARS = ["C", "G", "C", "G", "C", "G", "C", "C", "G", "C", "G", "C", "C", "G", "C", "C"]


def vlq(n):
    out = [n & 0x7F]
    n >>= 7
    while n:
        out.append(0x80 | (n & 0x7F))
        n >>= 7
    return bytes(reversed(out))


def track(events):
    """events: (tick, bytes); sorted, note-offs first at equal ticks."""
    events.sort(key=lambda e: (e[0], 0 if (e[1][0] & 0xF0) == 0x80 else 1))
    data, now = b"", 0
    for tick, msg in events:
        data += vlq(tick - now) + msg
        now = tick
    data += vlq(0) + b"\xFF\x2F\x00"
    return b"MTrk" + struct.pack(">I", len(data)) + data


def main():
    tempo = [(0, b"\xFF\x51\x03" + struct.pack(">I", 60_000_000 // BPM)[1:]),
             (0, b"\xFF\x58\x04\x04\x02\x18\x08"),
             (0, b"\xFF\x03" + bytes([len(b"Ode to Joy")]) + b"Ode to Joy")]
    right, t = [], 0
    for note, q in MELODY:
        length = int(q * TPQ)
        if note:
            right.append((t, bytes([0x90, note, 90])))
            right.append((t + length - 30, bytes([0x80, note, 64])))
        t += length
    left = [(0, bytes([0xC1, 0]))]
    for bar, name in enumerate(BARS):
        start = bar * 4 * TPQ
        for n in CHORDS[name]:
            left.append((start, bytes([0x91, n, 60])))
            left.append((start + 4 * TPQ - 60, bytes([0x81, n, 0])))
        if bar % 4 == 0:  # a low C1 (24) pedal note: folds up to C2 (36)
            left.append((start, bytes([0x91, 24, 70])))
            left.append((start + 2 * TPQ, bytes([0x81, 24, 0])))
    left.append((len(BARS) * 4 * TPQ, bytes([0xB1, 123, 0])))
    header = b"MThd" + struct.pack(">IHHH", 6, 1, 3, TPQ)
    smf = header + track(tempo) + track(right) + track(left)
    Path(__file__).with_name("ode-to-joy.mid").write_bytes(smf)


if __name__ == "__main__":
    main()
