#!/usr/bin/env bash
# Builds the QEMU firmware, runs its session (force-steps, then 10 s of pseudo-random) on
# QEMU's netduinoplus2 with deterministic instruction counting, and decodes the defmt stream
# into records: OUT/force-steps.csv, OUT/pseudo-random.csv (+ _frames.csv, _array.csv).
# Usage: boards/qemu-netduinoplus2/run.sh [OUT] [WORDS…]   (default out/qemu)
# WORDS go to the firmware's command line: session=calibration (the calibration protocol over
# two taxels, for `tactile calibrate`), session=excitation (the applicator's excitation at six
# preloads, for `tactile design --records OUT/excitation-*.csv`), run=N (one run of the session),
# applicator=FILE.toml (the simulated plant of an applicator file, `applicators/*.toml`,
# checked and converted by `tactile applicator`; the memo's otherwise).
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-out/qemu}
shift || true
target=${CARGO_TARGET_DIR:-target}
mkdir -p "$out"
cargo fw-qemu
cargo build --release -p tactile-decode
words=()
for w in "$@"; do
    case "$w" in
    applicator=*.toml)
        cargo build --release -q -p sim-host --bin tactile
        "$target/release/tactile" applicator "${w#applicator=}" --out "$out/applicator.bin"
        w="applicator=$out/applicator.bin" ;;
    esac
    words+=("$w")
done
set -- "${words[@]+"${words[@]}"}"
elf="$target/thumbv7em-none-eabihf/release/tactile-qemu"
# -icount shift=0: one instruction per virtual nanosecond, no host timing in the run;
# sleep=off: WFI jumps virtual time to the next interrupt. Output: raw defmt on stdout.
timeout 1200 qemu-system-arm -machine netduinoplus2 -nographic -monitor none -serial none \
    -icount shift=0,align=off,sleep=off \
    -semihosting-config enable=on,target=native \
    -kernel "$elf" ${1:+-append "$*"} >"$out/session.defmt"
"$target/release/tactile-decode" --elf "$elf" --log "$out/session.defmt" --out "$out"
