#!/usr/bin/env bash
# The test command: everything CI checks, installing what a fresh machine lacks.
set -euo pipefail
cd "$(dirname "$0")/.."

step() { printf '\n==> %s\n' "$*"; }

step "toolchain pieces"
rustup component list --installed 2>/dev/null | grep -q '^clippy' || rustup component add clippy
rustup component list --installed 2>/dev/null | grep -q '^rustfmt' || rustup component add rustfmt
rustup target list --installed | grep -qx thumbv6m-none-eabi || rustup target add thumbv6m-none-eabi

# The live view's test drives `orch play` in a real pseudo-terminal with tmux.
if ! command -v tmux >/dev/null 2>&1; then
    (apt-get update -qq && apt-get install -y -qq tmux) >/dev/null || sudo apt-get install -y -qq tmux
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

step "fuzz target builds (stable; running it needs nightly, see fuzz/README.md)"
if [ -f fuzz/Cargo.toml ]; then cargo check --manifest-path fuzz/Cargo.toml --bins; fi

step "tests (every fuzz corpus and crash regression is replayed by the fuzz_replay tests)"
cargo test --workspace --all-features

step "firmware: the thesis's ATmega16 board, built and tested in simavr (firmware/test.sh)"
(cd firmware/atmega16 && cargo fmt -- --check)
(cd firmware/atmega16-hil && cargo fmt -- --check && cargo clippy --all-targets -- -D warnings)
bash firmware/test.sh
