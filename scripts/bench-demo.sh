#!/usr/bin/env bash
# Benchmark (not a test): wall time and peak memory of the README's main job, `tactile demo`, after
# the build (the budget: 10 s on the 2-core machine). Runs it RUNS times (default 3) and prints
# each and the best.
#
#   scripts/bench-demo.sh [RUNS]
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x /usr/bin/time ] || { apt-get update -q && apt-get install -y -q time; }
cargo build --release -q -p sim-host --bin tactile
runs=${1:-3}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
best=""
for i in $(seq 1 "$runs"); do
    line=$(/usr/bin/time -f "%e %M" target/release/tactile demo --out "$out/demo-$i" 2>&1 >/dev/null | tail -1)
    read -r wall kb <<< "$line"
    echo "run $i: $wall s wall, $kb KB peak"
    if [ -z "$best" ] || awk -v a="$wall" -v b="$best" 'BEGIN { exit !(a < b) }'; then best=$wall; fi
done
echo "best of $runs: $best s (budget 10 s)"
