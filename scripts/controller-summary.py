#!/usr/bin/env python3
"""Summarises `scripts/controller-sweep.sh`'s log: per rig the worst of each sine (dB over
0.5–40 Hz), the slowest step after the first (ms), the largest step overshoot and touch-down
overshoot (g), steps the gauge's range clamps left out (the rig's "gauge" column: where its
commands end, g); then RMS and worst over the rigs, how many sines are within
±1 dB, and the rigs refused with the reason.

    python3 scripts/controller-summary.py LOG [LOG ...]   # several logs side by side
"""
import math
import re
import sys

SINES = ["2 g about 10 g", "5 g about 10 g", "10 g about 50 g", "10 g about 100 g"]
KEYS = SINES + ["settle", "over", "td", "gauge"]
# The targets of the steps (ms after the first, g over) and touch-downs (g over); ±1 dB else.
TARGETS = {"settle": (30, "ms"), "over": (1, "g"), "td": (1, "g")}


def steps(text, top):
    """The values of a steps line after the first, but for the steps the gauge's range clamps:
    those past the commands' top and the first down from the top (from the clamp, not 10 g)."""
    pairs = [(float(a), float(b)) for a, b in (x.split(":") for x in text.split()[1:])]
    if top < 100 and pairs:
        peak = max(range(len(pairs)), key=lambda i: pairs[i][0])
        pairs = [p for i, p in enumerate(pairs) if i != peak + 1 and p[0] <= top + 1e-6]
    return [math.inf if math.isnan(v) else v for _, v in pairs]


def load(path):
    rigs, cur, top = {}, None, math.inf
    for line in open(path):
        if line.startswith("== ") and "/" in line:
            cur, top = "/".join(line[3:].strip().split("/")[-2:]), math.inf
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
print("rig".ljust(44) + "".join(k[:16].rjust(18) for k in KEYS))
for rig in logs[0]:
    cells = []
    for k in KEYS:
        vals = [("%6.2f" % d[rig][k]) if k in d.get(rig, {}) else "   -  " for d in logs]
        cells.append(" / ".join(vals).rjust(18))
    print(rig[-44:].ljust(44) + "".join(cells))
for path, d in zip(sys.argv[1:], logs):
    parts = []
    for k in KEYS[:-1]:
        v = [abs(r[k]) for r in d.values() if k in r]
        if not v:
            continue
        rms = math.sqrt(sum(x * x for x in v) / len(v))
        bound, unit = TARGETS.get(k, (1, "dB"))
        within = f", within {bound} {unit} on {sum(x <= bound for x in v)}/{len(v)}"
        parts.append(f"{k}: RMS {rms:.2f}, worst {max(v):.2f}{within}")
    refused = [f"{rig}: {r['refused']}" for rig, r in d.items() if "refused" in r]
    parts.append(f"designed {len(d) - len(refused)} of {len(d)}; refused:")
    print(f"{path}:\n  " + "\n  ".join(parts + ["  " + r for r in refused]))
