#!/usr/bin/env bash
# Builds the ATmega16 firmware and runs its hardware-in-the-loop tests in simavr, and builds
# the Raspberry Pi Pico firmware (firmware/rp2040) for thumbv6m-none-eabi, both variants (the
# default on PCA9555 boards, and `--features pca9685` on PCA9685 PWM boards, kept beside it as
# orch-rp2040-pca9685), and runs their tests in the rp2040js emulator (firmware/rp2040-emu:
# node's test runner, orch-core on the host through firmware/rp2040-emu/expect), each booted
# from the UF2 that elf2uf2-rs makes of it (what a Pico is flashed with).
#
# From a fresh machine: installs what is missing (Debian packages, the nightly's rust-src),
# builds the firmware ELF at
#     firmware/atmega16/target/avr-none/release/orch-atmega16.elf
# prints its size, then builds and runs firmware/atmega16-hil (avr-tester, which builds
# simavr from source), among them the thesis's whole chain (`orch play` into a pty, bridged into
# simavr: it builds the root workspace's `orch` first). Extra arguments go to the test binary,
# e.g. `firmware/test.sh figures`.
set -euo pipefail
# The firmware packages build in their own target folders (the ELF path below), whatever the
# caller's CARGO_TARGET_DIR says.
unset CARGO_TARGET_DIR
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"

# Debian packages and the pinned nightly with rust-src and rustfmt: firmware/install.sh.
bash "$here/install.sh"
channel="$(sed -n 's/^channel *= *"\(.*\)"/\1/p' "$here/atmega16/rust-toolchain.toml")"

echo "== building the firmware ($channel, avr-none, atmega16)"
(cd "$here/atmega16" && cargo build --release --locked)
elf="$here/atmega16/target/avr-none/release/orch-atmega16.elf"
echo "== $elf"
avr-size --format=avr --mcu=atmega16 "$elf" | grep -E 'Program|Data'

echo "== building the Raspberry Pi Pico firmware (stable, thumbv6m-none-eabi), PCA9685 then PCA9555"
if ! rustup target list --toolchain stable --installed | grep -q '^thumbv6m-none-eabi$'; then
    rustup target add thumbv6m-none-eabi --toolchain stable
fi
# Both in one target folder (they share every dependency but orch-core's features): the
# pca9685 build is copied aside, the default one built last stays at the README's path.
pico="$here/rp2040/target/thumbv6m-none-eabi/release/orch-rp2040"
pico_pwm="$pico-pca9685"
(cd "$here/rp2040" && cargo fmt --check &&
    cargo build --release --locked --features pca9685 && cp "$pico" "$pico_pwm" &&
    cargo build --release --locked)
size_tool="$(command -v llvm-size || command -v arm-none-eabi-size || true)"
for elf_file in "$pico" "$pico_pwm"; do
    echo "== $elf_file"
    [ -z "$size_tool" ] || "$size_tool" "$elf_file"
done

echo "== the Pico's UF2, what a Pico is flashed with (elf2uf2-rs, as the README says)"
# Without its default `serial` feature (a serial monitor after deploying, which needs libudev).
cargo_bin="${CARGO_HOME:-$HOME/.cargo}/bin"
e2u="$(command -v elf2uf2-rs || true)"
if [ -z "$e2u" ]; then
    [ -x "$cargo_bin/elf2uf2-rs" ] ||
        cargo install elf2uf2-rs --locked --no-default-features --version 2.2.0
    e2u="$cargo_bin/elf2uf2-rs"
fi
"$e2u" "$pico" "$pico.uf2"
"$e2u" "$pico_pwm" "$pico_pwm.uf2"
ls -l "$pico.uf2" "$pico_pwm.uf2"

echo "== the Pico firmware in an RP2040 emulator (rp2040js, firmware/rp2040-emu), booted from the UF2"
(cd "$here/rp2040-emu/expect" && cargo build --release --locked)
(cd "$here/rp2040-emu" && ORCH_RP2040_ELF="$pico" ORCH_RP2040_UF2="$pico.uf2" \
    ORCH_RP2040_PCA9685_ELF="$pico_pwm" ORCH_RP2040_PCA9685_UF2="$pico_pwm.uf2" \
    timeout 600 node --test test/*.test.js)

echo "== the orch command, for the thesis's whole chain (tests/chain.rs: orch play -> pty -> simavr)"
# Built as orch's own tests build it (`cargo test` unifies its dependencies' features with the
# dev-dependencies', `cargo build` does not): scripts/test.sh's step before this one has, so
# this builds nothing there (a plain `cargo build -p orch` rebuilt tokio, serde, axum ... and
# orch, 75 s of the test command).
(cd "$here/.." && cargo test --locked -p orch --test out --no-run)
orch_bin="$here/../target/debug/orch"

echo "== hardware-in-the-loop tests (simavr via avr-tester)"
cd "$here/atmega16-hil"
ORCH_ATMEGA16_ELF="$elf" ORCH_BIN="$orch_bin" timeout 900 cargo test --locked -- --nocapture "$@"
