#!/usr/bin/env bash
# Benchmark (not a test): wall time and peak memory of `tactile diagnose` on records of the second
# generator, 240 s at 200 Hz and 600 s at 1 kHz, a drift and a hysteresis (the issue's budgets:
# 1 s; 5 s and 200 MB).
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x /usr/bin/time ] || { apt-get update -q && apt-get install -y -q time; }
cargo build --release -q -p sim-host --bin tactile
cargo build --release -q -p tactile-ident --example synth_record
dir=target/bench-diagnose
mkdir -p "$dir"
target/release/examples/synth_record "$dir/240s_200Hz.csv" 15 200 240 hysteresis=0.05
target/release/examples/synth_record "$dir/600s_1kHz.csv" 14 1000 600 drift=0.03
target/release/examples/synth_record "$dir/600s_1kHz_hysteresis.csv" 14 1000 600 hysteresis=0.05
for f in "$dir/240s_200Hz.csv" "$dir/600s_1kHz.csv" "$dir/600s_1kHz_hysteresis.csv"; do
    /usr/bin/time -f "%e s wall, %M KB peak" target/release/tactile diagnose "$f" 2>&1 >/dev/null | sed "s|^|$(basename "$f"): |"
done
