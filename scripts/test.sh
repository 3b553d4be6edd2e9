#!/usr/bin/env bash
# The test command: everything CI checks, installing what a fresh machine lacks.
set -euo pipefail
cd "$(dirname "$0")/.."

# No incremental compilation: CI builds once, from a clean clone, where incremental's caches
# (3.7 GB of the 10.6 GB a fresh run once wrote to target/) only fill the disk. A developer's
# own `cargo test` keeps them.
export CARGO_INCREMENTAL=0

step() { printf '\n==> [%4ds] %s\n' "$SECONDS" "$*"; }

# Everything a fresh machine lacks is installed here, before anything builds: every later step
# (the firmware's lint included) finds its tools in place.
step "install: Debian packages, the firmware's nightly (firmware/install.sh), rustup pieces"
# firmware/install.sh: the AVR toolchain, simavr and what avr-tester builds it with, the
# nightly pinned for the firmware with rust-src and rustfmt. tmux: the live view's test drives
# `orch play` in a real pseudo-terminal with it. libasound2-dev: alsa-lib, which orch-io's `alsa`
# feature and orch-calibrate's `mic` feature (tested below with --all-features; the microphone
# is alsa-lib's own `file` plugin, no sound card) link. libclang-dev: the `camera` feature's v4l
# crate generates its kernel bindings with libclang at build time. timgm6mb-soundfont: the
# General MIDI soundfont `orch render`'s tests play through (6 MB, GPL-2; never committed here:
# installed in /usr/share/sounds/sf2). chromium and chromium-driver: `orch serve`'s browser tests
# (tests/serve_browser.rs) drive headless Chromium through chromedriver.
# gcc-aarch64-linux-gnu, g++-aarch64-linux-gnu, libc6-dev-arm64-cross, qemu-user and systemd
# (systemd-analyze, systemd-sysusers): the Raspberry Pi step (scripts/pi.sh) links orch for
# arm64 (with the `link` feature too: Ableton's C++ SDK), runs it, and checks its systemd unit
# and package. curl: the book's web page chapter scripts `orch serve` with
# it (tests/book.rs runs every example of the book). cmake (with libclang-dev): the `link`
# feature's rusty_link builds Ableton's Link SDK with it. iproute2 and nftables: tests/link.rs
# puts each Link peer in a network namespace of its own and loses some of its packets.
bash firmware/install.sh tmux libasound2-dev libclang-dev timgm6mb-soundfont chromium chromium-driver \
    gcc-aarch64-linux-gnu g++-aarch64-linux-gnu libc6-dev-arm64-cross qemu-user systemd curl cmake iproute2 nftables
# pymidi 0.5.0 (PyPI): the independent RTP-MIDI peer of tests/rtpmidi.rs (it imports six
# without declaring it).
python3 -c "import pymidi.server, six" 2>/dev/null || python3 -m pip install -q pymidi==0.5.0 six
# LinkPython-extern 1.3.0 (PyPI, wheels with Ableton's Link SDK built in): the independent
# Link peer of tests/link.rs, which sets the session's tempo and starts and stops it.
python3 -c "import link" 2>/dev/null || python3 -m pip install -q LinkPython-extern==1.3.0
if [ ! -e /dev/snd/seq ]; then
    echo "NOTE: this kernel offers no ALSA sequencer (/dev/snd/seq): the alsa output's real-port test skips (its encoder test runs)"
fi
# Stable's lint and format tools, and the target the no_std check builds for.
installed="$(rustup component list --installed)"
for component in clippy rustfmt; do
    grep -q "^$component" <<<"$installed" || rustup component add "$component"
done
rustup target list --installed | grep -qx thumbv6m-none-eabi || rustup target add thumbv6m-none-eabi
# The Raspberry Pi step's target, and cargo-deb, which packs orch as a .deb (pinned: the
# package's layout is what scripts/pi.sh checks).
rustup target list --installed | grep -qx aarch64-unknown-linux-gnu || rustup target add aarch64-unknown-linux-gnu
[ "$(cargo deb --version 2>/dev/null)" = "cargo-deb 3.8.0" ] || cargo install --locked cargo-deb --version 3.8.0
# mdBook, which builds the book (book/): pinned, with its search and no server or watcher (the
# `serve` and `watch` features). From an empty CARGO_HOME it costs 213 s of CPU (5 min of wall
# time on this project's shared 2-core machine; without search too it is 191 s, so search stays).
# It builds in the background, beside the format, lint and docs steps (its log is shown if it
# fails), and is waited for before the book step.
mdbook_pid=""
if [ "$(mdbook --version 2>/dev/null)" != "mdbook v0.4.52" ]; then
    mdbook_log="$(mktemp)"
    cargo install --locked mdbook --version 0.4.52 --no-default-features --features search \
        >"$mdbook_log" 2>&1 &
    mdbook_pid=$!
fi

step "format"
cargo fmt --all -- --check

step "lint"
cargo clippy --workspace --all-targets --all-features -- -D warnings

step "no_std: orch-core and orch-boards for thumbv6m-none-eabi; orch-core without its default features (as the ATmega16 builds it)"
cargo build -p orch-core -p orch-boards --target thumbv6m-none-eabi
cargo clippy -p orch-core --no-default-features --all-targets -- -D warnings

step "docs"
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --all-features

step "book: mdbook build book (tests/book.rs, in the tests below, checks its links and runs its examples)"
if [ -n "$mdbook_pid" ]; then
    wait "$mdbook_pid" || { cat "$mdbook_log"; rm -f "$mdbook_log"; echo "installing mdbook failed"; exit 1; }
    rm -f "$mdbook_log"
fi
mdbook build book

step "fuzz targets check (stable, without libFuzzer's C++, which only linking needs; running them needs nightly, see fuzz/README.md)"
if [ -f fuzz/Cargo.toml ]; then cargo check --manifest-path fuzz/Cargo.toml --bins --no-default-features; fi

step "tests (every fuzz corpus and crash regression is replayed by the fuzz_replay tests)"
cargo test --workspace --all-features

step "orch without its optional features: a missing feature is named (--mic, --out alsa:, --in alsa:, --link)"
# The tests above build orch with every feature; these four check the message of a build
# without them, which is what `cargo install` gives.
# One cargo, four test files, one filter each (a filter matches nothing in the other files).
cargo test -p orch --test calibrate_mic --test out --test run --test link_cli -- --exact \
    mic_without_the_feature_names_it bad_outs_are_refused_with_exit_2 \
    bad_input_or_output_exits_2 link_without_the_feature_names_it_and_its_licence

step "orch-baton: every generated conductor video at 30 and 60 fps (heavy: release)"
cargo test -p orch-baton --release --test videos -- --ignored

step "firmware: the thesis's ATmega16 board, built and tested in simavr; the Raspberry Pi Pico firmware, built and tested in rp2040js (firmware/test.sh)"
(cd firmware/atmega16 && cargo fmt -- --check)
(cd firmware/atmega16-hil && cargo fmt -- --check && cargo clippy --all-targets -- -D warnings)
(cd firmware/rp2040-emu/expect && cargo fmt -- --check && cargo clippy --all-targets -- -D warnings)
bash firmware/test.sh

step "Raspberry Pi: orch cross-built for aarch64 and run under qemu (play, analyze, serve and SIGTERM), its .deb installed into a scratch root, its systemd unit verified; built with link, in phase with Link peers (scripts/pi.sh)"
bash scripts/pi.sh
step "done in ${SECONDS}s"
