#!/usr/bin/env bash
# Benchmarks the eq. 14 (mk-alpha) fit: `tactile fit` against SciPy's least_squares + lsim on the
# same simulated bench record, and prints one table (wall time, strain RMS, parameters, ratio).
#
#   scripts/bench-fit-vs-scipy.sh [OUT_DIR]     (default target/bench-fit)
#   SCIPY_REPEAT=3 ...                          time SciPy best of 3 too (one fit is ~1 min)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-target/bench-fit}
venv=target/bench-venv
mkdir -p "$out"

# A venv under target/ so the benchmark never touches the system Python.
if [[ ! -x $venv/bin/python ]]; then
    python3 -m venv "$venv"
fi
if ! "$venv/bin/python" -c 'import numpy, scipy' 2>/dev/null; then
    "$venv/bin/pip" install --quiet numpy scipy
fi
"$venv/bin/python" -c 'import numpy, scipy; print(f"numpy {numpy.__version__}, scipy {scipy.__version__}")'

cargo build --release -p sim-host --bin tactile
tactile=target/release/tactile

# bench-record has a fixed length (180 s; --duration only applies to pseudo-random and sines).
"$tactile" experiment bench-record --out "$out" --no-plot
record=$out/bench-record.csv

# Wall clock of the whole command (process start, CSV read, fit, JSON), best of 3.
best=
for _ in 1 2 3; do
    start=$EPOCHREALTIME
    "$tactile" fit "$record" --model mk-alpha --json "$out/rust_fit.json" >"$out/rust_fit.txt"
    secs=$(awk -v a="$start" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.4f", b - a }')
    if [[ -z $best ]] || awk -v s="$secs" -v b="$best" 'BEGIN { exit !(s < b) }'; then
        best=$secs
    fi
done
echo "rust: best of 3 wall-clock $best s (its own report: $out/rust_fit.txt)"

"$venv/bin/python" scripts/bench_fit_scipy.py "$record" --json "$out/scipy_fit.json" \
    --rust "$out/rust_fit.json" --rust-seconds "$best" --repeat "${SCIPY_REPEAT:-1}"
