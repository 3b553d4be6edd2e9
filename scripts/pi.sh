#!/usr/bin/env bash
# orch on a Raspberry Pi (book/src/raspberry-pi.md), checked on this machine:
#
# 1. cross-builds `orch` for aarch64-unknown-linux-gnu (64-bit Raspberry Pi OS), linked by
#    Debian's gcc-aarch64-linux-gnu, with the default features only (`alsa`, `camera` and
#    `mic` would need arm64 alsa-lib and libclang's kernel headers to build against);
# 2. runs it under qemu-user (scripts/pi_check.py): `orch play --fast` and `orch analyze
#    --json` (every count adds up, and the same reports as this machine's own build), then
#    `orch serve` answering its page and JSON API, playing, and ending on SIGTERM with exit 0
#    and every key released; and checks that the checker fails on a broken report; and runs
#    tests/rtpmidi.rs with it (RTP-MIDI in and out against independent peers);
# 3. packs it with cargo-deb (Cargo.toml's [package.metadata.deb]), installs the package into
#    a scratch root with dpkg (its maintainer scripts run: the user orch in the i2c group), runs
#    the installed binary, verifies the installed unit with `systemd-analyze verify`, and
#    removes the package again;
# 4. builds it again with the `link` feature and plays it, under qemu in a network namespace,
#    in phase with this machine's orch and an independent Link peer (tests/link.rs's
#    an_arm64_robot_plays_in_phase_under_qemu; run as root, as CI is).
#
# It installs nothing: scripts/test.sh's install step does (gcc-aarch64-linux-gnu,
# g++-aarch64-linux-gnu, libc6-dev-arm64-cross, qemu-user, systemd, cmake, the rustup target,
# cargo-deb).
# The corpus song it plays is in ../shared/midi, beside the checkout, as the tests' corpus is.
set -euo pipefail
cd "$(dirname "$0")/.."

triple=aarch64-unknown-linux-gnu
sysroot=/usr/aarch64-linux-gnu
target_dir="${CARGO_TARGET_DIR:-target}"
songs=(examples/ode-to-joy.mid ../shared/midi/freedoom1-e1m1.mid)

# The Pi's build: the dev profile without debug info, as a profile of its own (`pi`, defined
# here). Debug info would make the link twice as slow and the binary 117 MB instead of 21;
# cargo-deb will not package the dev profile itself. Unoptimised is fast enough under qemu (a
# song's report in well under a second).
export CARGO_PROFILE_PI_INHERITS=dev CARGO_PROFILE_PI_DEBUG=false
export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_LINKER=aarch64-linux-gnu-gcc

fail() {
    echo "scripts/pi.sh: $*" >&2
    exit 1
}
t0=$SECONDS
took() { printf '    (%d s so far)\n' $((SECONDS - t0)); }

# What it needs, each with the package that brings it.
for need in aarch64-linux-gnu-gcc:gcc-aarch64-linux-gnu aarch64-linux-gnu-g++:g++-aarch64-linux-gnu \
    aarch64-linux-gnu-objdump:binutils-aarch64-linux-gnu cmake:cmake \
    qemu-aarch64:qemu-user systemd-analyze:systemd systemd-sysusers:systemd dpkg-deb:dpkg python3:python3; do
    command -v "${need%%:*}" >/dev/null ||
        fail "${need%%:*} not found: apt-get install ${need#*:} (scripts/test.sh's install step does)"
done
[ -e "$sysroot/lib/ld-linux-aarch64.so.1" ] ||
    fail "no arm64 C library in $sysroot: apt-get install libc6-dev-arm64-cross (scripts/test.sh's install step does)"
rustup target list --installed | grep -qx "$triple" ||
    fail "no Rust standard library for $triple: rustup target add $triple"
cargo deb --version >/dev/null 2>&1 || fail "cargo-deb not found: cargo install --locked cargo-deb"
for song in "${songs[@]}"; do
    [ -f "$song" ] || fail "$song not found (the corpus is ../shared/midi, beside the checkout)"
done

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

echo "== cross-build: orch for $triple (profile pi: dev, no debug info)"
cargo build --locked -p orch --bin orch --target "$triple" --profile pi
bin="$target_dir/$triple/pi/orch"
# ELF e_machine (bytes 18-19, little-endian): 0xb7 is AArch64.
[ "$(od -An -tx1 -j18 -N2 "$bin" | tr -d ' ')" = b700 ] || fail "$bin is not an AArch64 ELF file"
took

echo "== the reference: this machine's own orch, as the tests build it"
cargo test --locked -p orch --test out --no-run
host="$target_dir/debug/orch"
[ -x "$host" ] || fail "$host was not built"
took

# The Pi's orch, run by qemu-user; exec, so that a signal sent to it reaches orch.
printf '#!/bin/sh\nexec qemu-aarch64 -L %q %q "$@"\n' "$sysroot" "$(realpath "$bin")" >"$tmp/orch-pi"
chmod +x "$tmp/orch-pi"

echo "== under qemu: orch play --fast and orch analyze --json of ${songs[*]}"
python3 scripts/pi_check.py reports --orch "$tmp/orch-pi" --host "$host" "${songs[@]}"
took

echo "== the check itself fails on a report whose counts do not add up"
# One strike too many, in the text report and the JSON alike (so the two still agree).
printf '#!/bin/sh\n%q "$@" | sed -E '\''s/(strikes heard +|"strikes":)([0-9]+)/\\1999/'\''\n' \
    "$tmp/orch-pi" >"$tmp/orch-broken"
chmod +x "$tmp/orch-broken"
if python3 scripts/pi_check.py reports --orch "$tmp/orch-broken" --host "$tmp/orch-broken" \
    "${songs[0]}" 2>"$tmp/broken.err"; then
    fail "pi_check.py passed a report with 999 strikes"
fi
grep -q "999 strikes" "$tmp/broken.err" || fail "pi_check.py failed, but not on the strikes: $(cat "$tmp/broken.err")"
echo "refused, as it should be: $(tail -1 "$tmp/broken.err")"

echo "== under qemu: orch serve, its page and API, a song played, SIGTERM"
python3 scripts/pi_check.py serve --orch "$tmp/orch-pi" "${songs[0]}"
took

echo "== under qemu: RTP-MIDI in and out against independent peers (tests/rtpmidi.rs, the Pi's orch)"
# The test binary is the one the workspace's tests built (same packages, features, profile).
ORCH_ARM64="$tmp/orch-pi" cargo test --locked --workspace --all-features --test rtpmidi
took

echo "== the .deb (cargo-deb), for arm64"
# --fast: lighter compression (3.2 MB, not 2.6), 2 s instead of 10, for a package made only to be checked.
cargo deb --fast --no-build --target "$triple" --profile pi --output "$tmp/deb/"
debs=("$tmp"/deb/orch_*_arm64.deb)
deb="${debs[0]}"
[ -f "$deb" ] || fail "cargo deb made no orch_*_arm64.deb in $tmp/deb: $(ls "$tmp/deb")"
[ "$(dpkg-deb --field "$deb" Architecture)" = arm64 ] || fail "$deb is not for arm64"
# The libc6 the package asks for is at least the newest GLIBC symbol version the binary uses.
needs_glibc="$(aarch64-linux-gnu-objdump -T "$bin" | grep -o 'GLIBC_[0-9.]*' | sed 's/GLIBC_//' | sort -uV | tail -1)"
depends="$(dpkg-deb --field "$deb" Depends)"
says_glibc="$(sed -nE 's/.*libc6 \(>= ([0-9.]+)\).*/\1/p' <<<"$depends")"
[ -n "$says_glibc" ] || fail "the package's Depends names no libc6 version: $depends"
dpkg --compare-versions "$says_glibc" ge "$needs_glibc" ||
    fail "orch uses GLIBC_$needs_glibc, but Cargo.toml's [package.metadata.deb] depends on libc6 (>= $says_glibc)"
echo "$(basename "$deb"): $(du -k "$deb" | cut -f1) KiB, Depends: $depends (the binary uses GLIBC_$needs_glibc at most)"

echo "== the .deb installed into a scratch root (dpkg --root; its maintainer scripts run outside a chroot)"
root="$tmp/root"
mkdir -p "$root/var/lib/dpkg/info" "$root/var/lib/dpkg/updates" "$root/etc"
touch "$root/var/lib/dpkg/status"
dpkg --root="$root" --add-architecture arm64
# Its dependencies (libc6, i2c-tools, systemd) are this machine's business, not the scratch
# root's; the maintainer scripts see DPKG_ROOT and touch nothing outside it.
dpkg --root="$root" --force-depends --force-script-chrootless -i "$deb" 2>&1 |
    grep -v -e '^ orch:arm64 depends on' -e 'dependency problems, but configuring anyway'
[ "$(dpkg-query --root="$root" -W -f='${Status}' orch)" = "install ok installed" ] ||
    fail "dpkg did not install orch into $root"
for f in usr/bin/orch usr/lib/systemd/system/orch-serve.service usr/lib/sysusers.d/orch.conf \
    usr/lib/modules-load.d/orch.conf usr/share/doc/orch/raspberry-pi.md usr/share/doc/orch/examples/ode-to-joy.mid; do
    [ -f "$root/$f" ] || fail "the package did not install /$f"
done
cmp dist/orch-serve.service "$root/usr/lib/systemd/system/orch-serve.service" ||
    fail "the installed unit is not dist/orch-serve.service"
grep -qx 'orch:x:[0-9]*:[0-9]*:orch serve:/var/lib/orch:/usr/sbin/nologin' "$root/etc/passwd" ||
    fail "postinst made no user orch: $(cat "$root/etc/passwd" 2>/dev/null)"
grep -qE '^i2c:x:[0-9]+:(.*,)?orch(,.*)?$' "$root/etc/group" ||
    fail "the user orch is not in the i2c group: $(cat "$root/etc/group" 2>/dev/null)"
# The installed binary (stripped by cargo-deb) runs, and says what this machine's build says.
diff <(qemu-aarch64 -L "$sysroot" "$root/usr/bin/orch" config --boards pca9685) \
    <("$host" config --boards pca9685) >/dev/null ||
    fail "the installed orch's \`orch config --boards pca9685\` differs from this machine's build"
echo "installed: /usr/bin/orch (runs), the unit, the user orch in the i2c group, i2c-dev at boot, the docs"

echo "== systemd-analyze verify: the unit as installed, beside this machine's own units"
# verify --root resolves every unit the service names (multi-user.target, network-online.target)
# and the ExecStart binary inside the root: this machine's units are copied in beside it.
cp -rn /usr/lib/systemd/system/. "$root/usr/lib/systemd/system/"
ln -sfn usr/lib "$root/lib"
said="$(systemd-analyze verify --root="$root" orch-serve.service 2>&1)" ||
    fail "systemd-analyze verify failed: $said"
[ -z "$said" ] || fail "systemd-analyze verify is not clean: $said"
# ... and it would have said something of a broken unit.
sed 's/^Restart=on-failure$/Restart=on-failur/' dist/orch-serve.service \
    >"$root/usr/lib/systemd/system/orch-serve-broken.service"
said="$(systemd-analyze verify --root="$root" orch-serve-broken.service 2>&1 || true)"
grep -q 'on-failur' <<<"$said" || fail "systemd-analyze verify let a misspelt Restart= pass: $said"
echo "clean (and a misspelt Restart= is caught)"

echo "== the .deb removed from the scratch root"
dpkg --root="$root" --force-script-chrootless -r orch >/dev/null
[ ! -e "$root/usr/bin/orch" ] || fail "dpkg -r left /usr/bin/orch"
[ "$(dpkg-query --root="$root" -W -f='${Status}' orch 2>/dev/null)" != "install ok installed" ] ||
    fail "orch is still installed in $root"
echo "removed"
took

echo "== Link on arm64: orch built with --features link, run under qemu in a network namespace, in phase with this machine's orch and the independent peer (tests/link.rs)"
# Ableton's SDK is C++: Debian's g++-aarch64-linux-gnu builds it (rusty_link's cmake), and
# bindgen reads its C header against the arm64 C library. The package above was made
# before, from the build without `link`: a binary built with it is GPL (book: orchestra.md).
export BINDGEN_EXTRA_CLANG_ARGS_aarch64_unknown_linux_gnu="--sysroot=$sysroot"
cargo build --locked -p orch --bin orch --features link --target "$triple" --profile pi
# qemu-user 7.2 refuses three multicast socket options the SDK sets; the shim answers them
# (see the file for why nothing is lost by that in the test's namespaces).
aarch64-linux-gnu-gcc -shared -fPIC -O2 -o "$tmp/multicast_if.so" tests/link/qemu_multicast_if.c -ldl
printf '#!/bin/sh\nexec qemu-aarch64 -L %q -E LD_PRELOAD=%q %q "$@"\n' \
    "$sysroot" "$tmp/multicast_if.so" "$(realpath "$bin")" >"$tmp/orch-pi-link"
chmod +x "$tmp/orch-pi-link"
# The test binary is the one the workspace's tests built (same packages, features, profile).
ORCH_ARM64="$tmp/orch-pi-link" cargo test --locked --workspace --all-features --test link -- \
    --ignored --exact an_arm64_robot_plays_in_phase_under_qemu --nocapture
took

echo "== scripts/pi.sh: all passed in $((SECONDS - t0)) s"
