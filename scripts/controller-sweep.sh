#!/usr/bin/env bash
# The designed controller on 29 rigs (the five applicator files and `random-applicators.py`
# 2026, 2029 and 2031), each identified, designed and measured by the `design_controller`
# example: per rig and in all, the worst of each sine over 0.5–40 Hz, the slowest step after
# the first, the largest overshoots; RMS over the rigs and how many are within ±1 dB. About
# 5 minutes. Run from anywhere; extra arguments are the example's knobs (see its header):
#
#   scripts/controller-sweep.sh                      the design as it is
#   scripts/controller-sweep.sh TRUE_FRICTION=1      the file's stiction compensated
#   SWEEP_OUT=DIR scripts/controller-sweep.sh ...    keep the raw output in DIR (else a temp dir)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${SWEEP_OUT:-$(mktemp -d)}
mkdir -p "$out"
cargo build --release -q -p sim-host --example design_controller
for seed in 2026 2029 2031; do
  python3 scripts/random-applicators.py "$seed" 8 "$out/rigs$seed" >/dev/null
done
log="$out/sweep.log"
: >"$log"
for f in applicators/*.toml "$out"/rigs20*/*.toml; do
  echo "== $f" >>"$log"
  env "$@" SINES=10:2,10:5,50:10,100:10 ONLY=1 target/release/examples/design_controller "$f" \
    >>"$log" 2>&1 || echo "   (failed)" >>"$log"
done
python3 scripts/controller-summary.py "$log"
echo "raw output: $log"
