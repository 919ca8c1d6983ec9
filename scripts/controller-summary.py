#!/usr/bin/env python3
"""Summarises `scripts/controller-sweep.sh`'s log: per rig the worst of each sine (dB over
0.5–40 Hz), the slowest step after the first (ms), the largest step overshoot and touch-down
overshoot (g); then RMS and worst over the rigs, and how many sines are within ±1 dB.

    python3 scripts/controller-summary.py LOG [LOG ...]   # several logs side by side
"""
import math
import re
import sys

SINES = ["2 g about 10 g", "5 g about 10 g", "10 g about 50 g", "10 g about 100 g"]
KEYS = SINES + ["settle", "over", "td"]


def load(path):
    rigs, cur = {}, None
    for line in open(path):
        if line.startswith("== ") and "/" in line:
            cur = "/".join(line.strip().split("/")[-2:])
            rigs[cur] = {}
            continue
        if cur is None:
            continue
        m = re.match(r"\s+(\d+ g about \d+ g): (.*)", line)
        if m:
            vals = [float(x) for x in re.findall(r"([-+]\d+\.\d+) dB", m.group(2))]
            if vals and len(vals) == m.group(2).count(" Hz"):
                rigs[cur][m.group(1)] = max(vals, key=abs)
        m = re.match(r"\s+force-steps, settling.*?: (.*)", line)
        if m:  # after the first step, which lands from rest
            rigs[cur]["settle"] = max(float(x.split(":")[1]) for x in m.group(1).split()[1:])
        m = re.match(r"\s+force-steps, overshoot.*?: (.*)", line)
        if m:
            rigs[cur]["over"] = max(float(x.split(":")[1]) for x in m.group(1).split())
        m = re.match(r"\s+low-force touch-downs.*?: (.*)", line)
        if m:
            rigs[cur]["td"] = max(float(x.split(":")[1]) for x in m.group(1).split())
    return rigs


logs = [load(p) for p in sys.argv[1:]]
print("rig".ljust(30) + "".join(k[:16].rjust(18) for k in KEYS))
for rig in logs[0]:
    cells = []
    for k in KEYS:
        vals = [("%6.2f" % d[rig][k]) if k in d.get(rig, {}) else "   -  " for d in logs]
        cells.append(" / ".join(vals).rjust(18))
    print(rig[-30:].ljust(30) + "".join(cells))
for path, d in zip(sys.argv[1:], logs):
    parts = []
    for k in KEYS:
        v = [abs(r[k]) for r in d.values() if k in r]
        if not v:
            continue
        rms = math.sqrt(sum(x * x for x in v) / len(v))
        within = f", ±1 dB on {sum(x <= 1 for x in v)}/{len(v)}" if k in SINES else ""
        parts.append(f"{k}: RMS {rms:.2f}, worst {max(v):.2f}{within}")
    print(f"{path}:\n  " + "\n  ".join(parts))
