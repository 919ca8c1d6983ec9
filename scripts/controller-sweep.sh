#!/usr/bin/env bash
# The designed controller on the five applicator files and eight rigs of each seed of
# `random-applicators.py` (SEEDS, default 7001 7002 7003: never used to tune the design), each
# identified, designed and measured by the `design_controller` example: per rig and in all, the
# worst of each sine over 0.5–40 Hz, the slowest step after the first, the largest overshoots;
# RMS over the rigs and how many are within ±1 dB; the rigs refused, with the reason. About
# 10 minutes. Run from anywhere; extra arguments are the example's knobs (see its header):
#
#   scripts/controller-sweep.sh                      the design as it is
#   scripts/controller-sweep.sh TRUE_FRICTION=1      the file's stiction compensated
#   SWEEP_OUT=DIR scripts/controller-sweep.sh ...    keep the raw output in DIR (else a temp dir)
#   SEEDS="1 2" scripts/controller-sweep.sh          other seeds
set -euo pipefail
cd "$(dirname "$0")/.."
out=${SWEEP_OUT:-$(mktemp -d)}
mkdir -p "$out"
cargo build --release -q -p sim-host --example design_controller
seeds=${SEEDS:-7001 7002 7003}
for seed in $seeds; do
  python3 scripts/random-applicators.py "$seed" 8 "$out/rigs$seed" >/dev/null
done
log="$out/sweep.log"
: >"$log"
for f in applicators/*.toml "$out"/rigs*/*.toml; do
  echo "== $f" >>"$log"
  env "$@" SINES=10:2,10:5,50:10,100:10 ONLY=1 "${CARGO_TARGET_DIR:-target}"/release/examples/design_controller "$f" \
    >>"$log" 2>&1 || echo "   (failed)" >>"$log"
done
python3 scripts/controller-summary.py "$log"
echo "raw output: $log"
