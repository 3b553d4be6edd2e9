#!/usr/bin/env bash
# What `orch play` costs, against midly alone, and how late the real clock is.
#
# 1. Throughput: the largest MIDI file in ../shared/midi, rendered with
#    `orch play --fast --json` (parse, schedule, interpreter, guard and virtual robot on the
#    virtual clock) and parsed with `benches/midly_parse` (midly alone, every event walked).
#    Wall time (best of 5) and peak RSS from /usr/bin/time, and the ratios.
# 2. Real-clock lateness per message sent: `orch play --json --no-view` of a ~36-second piece
#    in real time, on an idle machine and with a busy loop on every core; the report's
#    lateness_ms (median, p99, max) against a DIN byte time (320 µs).
# 3. Bus latency: `cargo bench -p orch-core --bench bus`.
#
# Run from anywhere in a checkout with ../shared beside it: bash scripts/bench-play.sh
set -euo pipefail
cd "$(dirname "$0")/.."

RUNS=5
DIN_BYTE_MS=0.320
MIDI_DIR=../shared/midi

step() { printf '\n==> %s\n' "$*"; }

if [ ! -x /usr/bin/time ]; then
    step "installing GNU time (Debian package time)"
    (apt-get update -qq && apt-get install -y -qq time) >/dev/null 2>&1 ||
        (sudo apt-get update -qq && sudo apt-get install -y -qq time) >/dev/null
fi
if [ ! -d "$MIDI_DIR" ]; then
    echo "bench-play: $MIDI_DIR is missing (the shared MIDI corpus must sit beside the checkout)" >&2
    exit 2
fi

step "build (release)"
cargo build --release --quiet --bin orch
TARGET_DIR=$(cargo metadata --format-version 1 --no-deps |
    sed -n 's/.*"target_directory":"\([^"]*\)".*/\1/p')
TARGET_DIR=${TARGET_DIR:-target}
ORCH=$TARGET_DIR/release/orch
# The baseline is a bench target (benches/midly_parse.rs): built, and its file named, by cargo.
MIDLY=$(cargo bench --quiet --no-run --bench midly_parse --message-format=json |
    sed -n 's/.*"executable":"\([^"]*\)".*/\1/p' | tail -n 1)
[ -x "$MIDLY" ] || { echo "bench-play: benches/midly_parse did not build" >&2; exit 1; }

# The largest MIDI file by size.
BIG=$(find "$MIDI_DIR" -maxdepth 1 -type f \( -name '*.mid' -o -name '*.midi' -o -name '*.kar' \) \
    -printf '%s\t%p\n' | sort -n | tail -n 1 | cut -f2)
[ -n "$BIG" ] || { echo "bench-play: no MIDI file in $MIDI_DIR" >&2; exit 2; }

TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

# measure NAME CMD...: runs CMD $RUNS times under /usr/bin/time; prints and records
# the best wall time (ms: /usr/bin/time's %e has 10 ms steps, so the wall clock is also read
# in ns around each run) and the largest peak RSS (KiB).
measure() {
    local name=$1
    shift
    local best_ms="" best_e="" rss=0 i t0 t1 ms e m
    for ((i = 0; i < RUNS; i++)); do
        t0=$(date +%s%N)
        /usr/bin/time -f "%e %M" -o "$TMP/time" "$@" >"$TMP/$name.out"
        t1=$(date +%s%N)
        ms=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f", (b - a) / 1e6 }')
        read -r e m <"$TMP/time"
        if [ -z "$best_ms" ] || awk -v x="$ms" -v y="$best_ms" 'BEGIN { exit !(x < y) }'; then
            best_ms=$ms
            best_e=$e
        fi
        if [ "$m" -gt "$rss" ]; then rss=$m; fi
    done
    printf '%s %s %s\n' "$best_ms" "$best_e" "$rss" >"$TMP/$name.best"
}

step "throughput: $(basename "$BIG") ($(stat -c %s "$BIG") bytes), best of $RUNS"
measure play "$ORCH" play --fast --json "$BIG"
measure midly "$MIDLY" "$BIG"
read -r play_ms play_e play_rss <"$TMP/play.best"
read -r midly_ms midly_e midly_rss <"$TMP/midly.best"
field() { sed -n "s/.*\"$1\":\([0-9.]*\).*/\1/p" "$2"; }
printf '  piece: %s notes, %s s of music; midly: %s\n' \
    "$(field notes "$TMP/play.out")" "$(field seconds "$TMP/play.out")" "$(cat "$TMP/midly.out")"
printf '  %-34s %10s %12s %14s\n' "" "wall ms" "time %e (s)" "peak RSS KiB"
printf '  %-34s %10s %12s %14s\n' "orch play --fast --json" "$play_ms" "$play_e" "$play_rss"
printf '  %-34s %10s %12s %14s\n' "midly_parse (midly alone)" "$midly_ms" "$midly_e" "$midly_rss"
awk -v a="$play_ms" -v b="$midly_ms" -v c="$play_rss" -v d="$midly_rss" 'BEGIN {
    printf "  ratio orch/midly: wall %.1fx, peak RSS %.1fx\n", a / b, c / d }'
awk -v a="$play_ms" -v s="$(field seconds "$TMP/play.out")" 'BEGIN {
    if (s > 0) printf "  orch renders %.0f s of music in %.0f ms: %.0fx real time\n", s, a, s * 1000 / a }'
echo "  (wall ms: best run, from process start to exit, read around /usr/bin/time)"

step "memory at the limits: a 50 MB valid file and a 37-byte file holding one note for 0x0FFFFFFF ticks"
python3 - "$TMP" <<'PY'
import random, struct, sys
d = sys.argv[1]
random.seed(1)
ev = bytearray()
first = True
while len(ev) < 50 * 1024 * 1024 - 100:
    note = 36 + random.randrange(61)
    ev += bytes([6]) + (bytes([0x90]) if first else b"") + bytes([note, 100])
    first = False
    ev += bytes([5, note, 0])
ev += bytes([0, 0xFF, 0x2F, 0])
open(f"{d}/big50.mid", "wb").write(b"MThd" + struct.pack(">IHHH", 6, 0, 1, 480) + b"MTrk" + struct.pack(">I", len(ev)) + ev)
trk = bytes([0, 0x90, 60, 100, 0xFF, 0xFF, 0xFF, 0x7F, 0x80, 60, 0, 0, 0xFF, 0x2F, 0])
open(f"{d}/long.mid", "wb").write(b"MThd" + struct.pack(">IHHH", 6, 0, 1, 480) + b"MTrk" + struct.pack(">I", len(trk)) + trk)
PY
for f in big50 long; do
    /usr/bin/time -f "%e %M" -o "$TMP/$f.time" "$ORCH" play --fast --json "$TMP/$f.mid" >"$TMP/$f.json"
    read -r e m <"$TMP/$f.time"
    size=$(stat -c %s "$TMP/$f.mid")
    awk -v f="$f" -v s="$size" -v e="$e" -v m="$m" -v n="$(field notes "$TMP/$f.json")" 'BEGIN {
        printf "  %-6s %10d bytes, %8d notes: %6.2f s, peak RSS %8d KiB = %.1fx the file\n", f, s, n, e, m, m * 1024 / s }'
done

PIECE=examples/ode-to-joy.mid
[ -f "$PIECE" ] || PIECE=$MIDI_DIR/m21-test06.mid

# lateness LABEL: plays $PIECE in real time and prints the report's lateness per message sent.
lateness() {
    "$ORCH" play --json --no-view "$PIECE" >"$TMP/real.json"
    LATE=$(sed -n 's/.*"lateness_ms":{"median":\([-0-9.e]*\),"p99":\([-0-9.e]*\),"max":\([-0-9.e]*\)}.*/\1 \2 \3/p' "$TMP/real.json")
    if [ -z "$LATE" ]; then
        echo "bench-play: no lateness_ms in the report:" >&2
        cat "$TMP/real.json" >&2
        exit 1
    fi
    read -r med p99 max <<<"$LATE"
    awk -v l="$1" -v med="$med" -v p99="$p99" -v max="$max" -v din="$DIN_BYTE_MS" 'BEGIN {
        printf "  %-22s median %7.3f ms (%5.2f DIN bytes)  p99 %7.3f ms (%5.2f)  max %7.3f ms (%5.2f)\n",
            l, med, med / din, p99, p99 / din, max, max / din }'
}

step "real-clock lateness per message sent: orch play --json --no-view $PIECE (real time, $(nproc) cores)"
lateness "idle machine"
# A competing load: a busy loop on every core, for the length of the piece.
pids=()
for ((i = 0; i < $(nproc); i++)); do
    (while :; do :; done) &
    pids+=($!)
done
lateness "every core busy"
kill "${pids[@]}" 2>/dev/null || true
wait 2>/dev/null || true
echo "  (against the 320 us a DIN byte takes; the sender asks for real-time priority and sleeps with spin_sleep)"

step "bus latency: cargo bench -p orch-core --bench bus"
cargo bench --quiet -p orch-core --bench bus
