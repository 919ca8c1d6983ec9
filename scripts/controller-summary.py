#!/usr/bin/env python3
"""Summarises `scripts/controller-sweep.sh`'s log: per rig the worst of each sine (dB over
0.5–40 Hz), the slowest step after the first (ms), the largest step overshoot and touch-down
overshoot (g), steps past the commands the gauge's range takes left out (the rig's "gauge"
column: where its commands end, g); then RMS and worst over the rigs, how many sines are within
±1 dB, and the rigs refused with the reason.

    python3 scripts/controller-summary.py LOG [LOG ...]   # several logs side by side
"""
import math
import re
import sys

SINES = ["2 g about 10 g", "5 g about 10 g", "10 g about 50 g", "10 g about 100 g"]
KEYS = SINES + ["settle", "over", "td", "gauge"]


def steps(text, top):
    """(level, value) of a steps line, after the first, the levels the commands reach."""
    pairs = [(float(a), float(b)) for a, b in (x.split(":") for x in text.split()[1:])]
    return [math.inf if math.isnan(v) else v for level, v in pairs if level <= top + 1e-6]


def load(path):
    rigs, cur, top = {}, None, math.inf
    for line in open(path):
        if line.startswith("== ") and "/" in line:
            cur, top = "/".join(line.strip().split("/")[-2:]), math.inf
            rigs[cur] = {}
            continue
        if cur is None:
            continue
        m = re.match(r"commands up to ([\d.]+) g", line)
        if m:
            top = float(m.group(1))
            if top < 100:
                rigs[cur]["gauge"] = top
        m = re.match(r"error: (.*)", line)
        if m:
            rigs[cur]["refused"] = m.group(1).strip()
        m = re.match(r"\s+(\d+ g about \d+ g): (.*)", line)
        if m:
            vals = [float(x) for x in re.findall(r"([-+]\d+\.\d+) dB", m.group(2))]
            if vals and len(vals) == m.group(2).count(" Hz"):
                rigs[cur][m.group(1)] = max(vals, key=abs)
        m = re.match(r"\s+force-steps, settling.*?: (.*)", line)
        if m:  # after the first step, which lands from rest
            rigs[cur]["settle"] = max(steps(m.group(1), top))
        m = re.match(r"\s+force-steps, overshoot.*?: (.*)", line)
        if m:
            rigs[cur]["over"] = max(steps(m.group(1), top))
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
    for k in KEYS[:-1]:
        v = [abs(r[k]) for r in d.values() if k in r]
        if not v:
            continue
        rms = math.sqrt(sum(x * x for x in v) / len(v))
        within = f", ±1 dB on {sum(x <= 1 for x in v)}/{len(v)}" if k in SINES else ""
        parts.append(f"{k}: RMS {rms:.2f}, worst {max(v):.2f}{within}")
    refused = [f"{rig}: {r['refused']}" for rig, r in d.items() if "refused" in r]
    parts.append(f"designed {len(d) - len(refused)} of {len(d)}; refused:")
    print(f"{path}:\n  " + "\n  ".join(parts + ["  " + r for r in refused]))
