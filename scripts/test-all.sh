#!/usr/bin/env bash
# Runs every test of the project on a fresh machine: installs what is missing, then formatting,
# lints, the firmware-target build and all host tests. Exit code non-zero on any failure.
set -euo pipefail
cd "$(dirname "$0")/.."

step() { printf '\n==> %s\n' "$*"; }

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

step "formatting (cargo fmt --check)"
cargo fmt --all --check

step "lints (cargo clippy --all-targets -- -D warnings)"
cargo clippy --all-targets -- -D warnings

step "core library for the Cortex-M4F (thumbv7em-none-eabihf)"
cargo core-thumb

step "host tests of the whole workspace (cargo test)"
log=$(mktemp)
trap 'rm -f "$log"' EXIT
cargo test --release 2>&1 | tee "$log"
# One closing line for the whole run, summed over every test binary.
awk '/^test result:/ { for (i = 1; i <= NF; i++) { if ($(i+1) ~ /^passed/) p += $i; if ($(i+1) ~ /^failed/) f += $i } }
     END { printf "\n%d passed, %d failed\n", p, f }' "$log"
