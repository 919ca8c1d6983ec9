#!/usr/bin/env bash
# Runs every test of the project on a fresh machine: installs what is missing, then formatting,
# lints, the firmware-target build and all host tests. Exit code non-zero on any failure.
set -euo pipefail
cd "$(dirname "$0")/.."

step() { printf '\n==> [%d s] %s\n' "$SECONDS" "$*"; }

step "toolchain pieces"
if ! rustup target list --installed | grep -qx thumbv7em-none-eabihf; then
    echo "installing the thumbv7em-none-eabihf target"
    rustup target add thumbv7em-none-eabihf
fi
for component in rustfmt clippy; do
    if ! rustup component list --installed | grep -q "^$component"; then
        echo "installing $component"
        rustup component add "$component"
    fi
done
rustup target list --installed | grep -x thumbv7em-none-eabihf
# The thumb target links with flip-link (.cargo/config.toml): stack-overflow protection.
if ! command -v flip-link >/dev/null 2>&1; then
    echo "installing flip-link (the linker of the thumb target): cargo install flip-link --locked"
    cargo install flip-link --locked
fi
echo "flip-link: $(command -v flip-link)"

step "formatting (cargo fmt --check)"
cargo fmt --all --check

step "lints (cargo clippy --release --all-targets -- -D warnings)"
# NOTE: --release, so that the build scripts and proc macros it compiles are the release
# build's below (the dev profile builds them again, at the dependencies' opt-level 2).
cargo clippy --release --all-targets -- -D warnings

# The core for the Cortex-M4F is compiled by the firmware's lints here and built into both
# firmware images by the tests below (`cargo core-thumb` builds it alone).
step "firmware lints for the Cortex-M4F: no unwrap, expect, panicking index or panic (clippy -D warnings)"
# NOTE: --release too: the proc macros (host code) are then the lints' above, not built again at
# the dev profile's opt-level 2.
cargo clippy --release -p tactile-firmware -p tactile-qemu -p tactile-f407 --target thumbv7em-none-eabihf -- -D warnings
cargo clippy --release -p tactile-f407 --target thumbv7em-none-eabihf --features controller-designed -- -D warnings

step "QEMU for the firmware-in-the-loop test (qemu-system-arm)"
if ! command -v qemu-system-arm >/dev/null 2>&1; then
    echo "installing qemu-system-arm"
    sudo=""
    if [ "$(id -u)" != 0 ] && command -v sudo >/dev/null 2>&1; then sudo=sudo; fi
    $sudo apt-get update
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y qemu-system-arm
fi
qemu-system-arm --version | sed -n 1p

step "host tests of the whole workspace: the release build (cargo test --no-run)"
# NOTE: the targets named, so the release build skips the examples (diagnostics and benchmarks;
# the lints above compile them): ten links of the simulator the tests do not run. The firmware
# tests below are built by this one build: with `-p tactile-decode` alone the features of the
# dependencies differ (no dev-dependencies of the others), and half the tree built twice.
cargo test --release --lib --bins --tests --no-run

step "firmware in the loop: QEMU netduinoplus2 against the host simulator, injected faults, crash handlers"
cargo test --release --test qemu_fil -- --ignored --nocapture

step "STM32F407G-DISC1 firmware: build and ELF checks"
cargo test --release --test f407_elf -- --ignored --nocapture

step "host tests of the whole workspace (cargo test)"
log=$(mktemp)
trap 'rm -f "$log"' EXIT
# Then the doc tests, which naming targets leaves out.
cargo test --release --lib --bins --tests 2>&1 | tee "$log"
cargo test --release --doc 2>&1 | tee -a "$log"
# One closing line for the whole run, summed over every test binary.
awk '/^test result:/ { for (i = 1; i <= NF; i++) { if ($(i+1) ~ /^passed/) p += $i; if ($(i+1) ~ /^failed/) f += $i } }
     END { printf "\n%d passed, %d failed\n", p, f }' "$log"
echo "whole run: $SECONDS s"
