#!/usr/bin/env bash
# Diagnoses records and prints docs/results.md's table: record, length, rate, verdict, held-out error
# before and after (g through the record's secant, and % strain), the first-order linear model
# on the same folds (the floor to beat), and the on-chip observer's held-out force error.
#
#   scripts/diagnose-table.sh [FILE.csv]...      (default: ../shared/data/real/*.csv)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p sim-host --bin tactile
files=("$@")
if [ ${#files[@]} -eq 0 ]; then files=(../shared/data/real/*.csv); fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for f in "${files[@]}"; do
    name=$(basename "$f" .csv)
    if ! target/release/tactile diagnose "$f" --json "$out/$name.json" > "$out/$name.txt" 2> "$out/$name.err"; then
        echo "$name: refused: $(cat "$out/$name.err")"
    fi
done
python3 - "$out" "${files[@]}" <<'PY'
import json, os, sys
out, files = sys.argv[1], sys.argv[2:]
print("| record | length | rate | verdict | held out before → after | first-order model | on-chip observer before → after |")
print("| --- | --- | --- | --- | --- | --- | --- |")
for f in files:
    name = os.path.basename(f)[:-4]
    path = os.path.join(out, name + ".json")
    if not os.path.exists(path):
        continue
    d = json.load(open(path))
    n = sum(fold["samples"] for fold in d["folds"])
    length = d["folds"][-1]["end_s"]
    rate = n / length if length else 0
    verdict = d["effect"] if len(d["effects"]) < 2 else ", ".join(d["effects"])
    b, a, fo = d["before"], d["after"], d["first_order"]
    fe = d["force_estimate"]
    chip = "—" if fe["before_rms_g"] is None else f'{fe["before_rms_g"]:.2f} → {fe["after_rms_g"]:.2f} g' + ("" if fe["exported"] or not d["effects"] else " (not exported)")
    print(f'| `{name}` | {length:.0f} s | {rate:.0f} Hz | {verdict} | {b["held_out_rms_g"]:.2f} → {a["held_out_rms_g"]:.2f} g ({b["held_out_rms_pct"]:.3f} → {a["held_out_rms_pct"]:.3f} %) | {fo["held_out_rms_g"]:.2f} g | {chip} |')
PY
