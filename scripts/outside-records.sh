#!/usr/bin/env bash
# The diagnosis on records of a third finger, written apart from both of the project's
# generators (scripts/outside/gen.py: two or three Kelvin modes, triangles, staircases and
# filtered noise; Hertzian stiffening, Bouc-Wen hysteresis, an exponential and sinusoidal drift,
# a 40 s mode, a 40 ms delay, 60 + 180 Hz interference, an exponential gain sag) and on the same
# records with an untared force, a negative force and units of newtons. Prints
# scripts/diagnose-table.sh's table. Installs numpy if it is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -c 'import numpy' 2>/dev/null || pip install -q numpy
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
g() { python3 scripts/outside/gen.py "$out/$1.csv" "${@:2}" 2>/dev/null; }
for s in 1 2 3; do
    g clean_$s $s 200 240
    g hertz_$s $s 200 240 hertz=0.6
    g boucwen_$s $s 200 240 boucwen=0.3
    g drift_$s $s 200 240 drift=0.05
    g slow_$s $s 200 240 slow=0.4
    g delay_$s $s 200 240 delay_ms=40
    g tone_$s $s 500 240 tone=0.01
    g sag_$s $s 200 240 gainsag=0.1
done
g short_clean 4 50 8
g clean_20hz 9 20 300
g clean_20hz_slow_probe 9 20 300 bw=2
g quantized_clean 6 200 240 quant=0.01
g clean_1khz 7 1000 120
g hertz_1khz 7 1000 120 hertz=0.5
python3 - "$out" <<'PY'
import sys, os
out = sys.argv[1]
def rows(name):
    lines = open(os.path.join(out, name + ".csv")).read().splitlines()
    return [l for l in lines if l[:1].isdigit() or l[:1] == "-"]
for src in ["hertz_1", "drift_1", "clean_2"]:
    data = [r.split(",") for r in rows(src)]
    for tag, f in [("untared", lambda F: F + 300), ("negative", lambda F: -F), ("newtons", lambda F: F * 0.00980665)]:
        with open(os.path.join(out, f"{src}_{tag}.csv"), "w") as fh:
            fh.write("t_s,force_g,strain_pct\n")
            for t, F, S in data:
                fh.write(f"{t},{f(float(F)):.6g},{S}\n")
PY
scripts/diagnose-table.sh "$out"/*.csv
