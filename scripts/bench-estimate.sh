#!/usr/bin/env bash
# Measures, on measured records, the chip's force estimate against a ridge FIR inverse a user
# would write in numpy, on the same split: per record, `tactile diagnose` on
# the first 60 % writes a table, `tactile estimate` runs the chip's estimators on the last 40 %,
# and the ridge is trained on the first 60 % and scored on the last 40 %. Prints a markdown table
# (RMS force error, g) and a closing line: mean chip / ridge ratio, records with chip <= ridge.
#
#   scripts/bench-estimate.sh [--csv OUT.csv] [--mlp] [FILE.csv]...
#       default files: ../shared/data/real/*.csv and out/real/*.csv (scripts/real-records/)
#       --mlp: also a scikit-learn MLP on the last 1 s of strain (installs scikit-learn)
#       TACTILE=path: the tactile binary to use (default target/release/tactile, built if missing)
set -euo pipefail
opts=() files=()
while [ $# -gt 0 ]; do
    case $1 in
        --csv) opts+=(--csv "$(realpath -m "$2")"); shift 2 ;;
        --mlp) opts+=(--mlp); shift ;;
        *) files+=("$(realpath -m "$1")"); shift ;;
    esac
done
if [ -n "${TACTILE:-}" ]; then TACTILE=$(realpath -m "$TACTILE"); fi
cd "$(dirname "$0")/.."
if [ ${#files[@]} -eq 0 ]; then
    shopt -s nullglob
    files=(../shared/data/real/*.csv out/real/*.csv)
    shopt -u nullglob
fi
[ ${#files[@]} -gt 0 ] || { echo "no records" >&2; exit 1; }

python3 -c 'import numpy' 2>/dev/null || python3 -m pip install --user --quiet numpy
if [[ " ${opts[*]} " == *" --mlp "* ]]; then
    python3 -c 'import sklearn' 2>/dev/null || python3 -m pip install --user --quiet scikit-learn
fi
tactile=${TACTILE:-target/release/tactile}
if [ -z "${TACTILE:-}" ] && [ ! -x "$tactile" ]; then
    cargo build --release -p sim-host --bin tactile
fi

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python3 scripts/bench_estimate.py --tactile "$(realpath "$tactile")" --tmp "$tmp" "${opts[@]}" "${files[@]}"
