#!/usr/bin/env bash
# Installs what the ATmega16 firmware and its hardware-in-the-loop tests need, if it is missing:
#
# - Debian packages: gcc-avr, binutils-avr and avr-libc (the firmware's link step and avr-size),
#   simavr, and what avr-tester needs to build simavr from source and bind it (libclang-dev,
#   libelf-dev, libzstd-dev, pkg-config, make and a C compiler: build-essential);
# - the toolchain pinned in firmware/atmega16/rust-toolchain.toml, with rust-src (build-std for
#   avr-none) and rustfmt (the test command checks the firmware's formatting);
# - node and npm (Debian's, if the machine has none) and the npm packages of the Pico
#   firmware's emulator tests, firmware/rp2040-emu (rp2040js, at the version its
#   package-lock.json pins).
#
# Extra Debian packages to install in the same apt-get run can be given as arguments
# (scripts/test.sh passes tmux). Quiet and quick when everything is there. Called by
# firmware/test.sh and by scripts/test.sh before anything builds.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"

# Installed means "install ok installed": `dpkg -s` also succeeds for a package removed but not
# purged (its configuration files left), which is not there.
installed() { [ "$(dpkg-query -W -f='${Status}' "$1" 2>/dev/null)" = "install ok installed" ]; }
need=()
for pkg in gcc-avr binutils-avr avr-libc simavr libclang-dev libelf-dev libzstd-dev pkg-config \
    build-essential "$@"; do
    installed "$pkg" || need+=("$pkg")
done
# node and npm run the Pico firmware's emulator tests (firmware/rp2040-emu); Debian's if the
# machine has none.
command -v node >/dev/null && command -v npm >/dev/null || need+=(nodejs npm)
if ((${#need[@]})); then
    echo "== installing ${need[*]}"
    sudo_=""
    [ "$(id -u)" = 0 ] || sudo_="sudo"
    # Wait for another apt or dpkg run to finish rather than fail on its lock, and try again if
    # one ran in between (another checkout's test command installing the same packages); show
    # apt's output only if it fails for good.
    lock=(-o DPkg::Lock::Timeout=600)
    log="$(mktemp)"
    for attempt in 1 2 3; do
        if $sudo_ apt-get "${lock[@]}" update -qq >"$log" 2>&1 &&
            DEBIAN_FRONTEND=noninteractive $sudo_ apt-get "${lock[@]}" install -y -qq "${need[@]}" \
                >>"$log" 2>&1; then
            break
        fi
        if ((attempt == 3)); then
            cat "$log" >&2
            rm -f "$log"
            echo "firmware/install.sh: apt-get could not install ${need[*]}" >&2
            exit 1
        fi
        echo "== apt-get failed (attempt $attempt); trying again in 10 s"
        sleep 10
    done
    rm -f "$log"
fi

# The toolchain pinned in firmware/atmega16/rust-toolchain.toml, with rust-src and rustfmt.
channel="$(sed -n 's/^channel *= *"\(.*\)"/\1/p' "$here/atmega16/rust-toolchain.toml")"
if ! rustup run "$channel" rustc --version >/dev/null 2>&1; then
    echo "== installing toolchain $channel"
    rustup toolchain install "$channel" --profile minimal
fi
installed="$(rustup component list --toolchain "$channel" --installed)"
for component in rust-src rustfmt; do
    if ! grep -q "^$component" <<<"$installed"; then
        echo "== adding $component to $channel"
        rustup component add "$component" --toolchain "$channel"
    fi
done

# The Pico emulator's npm packages, as firmware/rp2040-emu/package-lock.json pins them (its
# .npmrc keeps registry hosts out of the lockfile).
emu="$here/rp2040-emu"
want="$(node -p "require('$emu/package-lock.json').packages['node_modules/rp2040js'].version")"
have="$(node -p "try { require('$emu/node_modules/rp2040js/package.json').version } catch { '' }")"
if [ "$want" != "$have" ]; then
    echo "== installing the Pico emulator's npm packages (rp2040js $want)"
    (cd "$emu" && npm ci --no-audit --no-fund --loglevel=error)
fi
