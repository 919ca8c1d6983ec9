#!/usr/bin/env python3
"""Convert eFlesh normal-force runs (notvenky/eFlesh, commit ab5ca56, MIT) to the tactile record format.

Source layout (per run folder characterization/datasets/normal_force/<run>/):
  states.csv : no header; t_unix_s, x, y, z (robot probe position, mm), scale reading
               (grams; -1 = no fresh reading, invalid). Valid readings come every ~0.2 s.
  sensor.csv : no header; t_unix_s, then 15 magnetometer channels = 5 magnetometers x (Bx, By, Bz),
               ~13.7 Hz.
Force units: the scale reading goes up to ~3500 for a 12 mm indentation; in kg or N this would be
absurd, and the paper reports normal-force RMSE 0.27 N, which fits a ~35 N (3.5 kg) range. So the
column is taken to be grams already (factor 1.0, neither the kg x1000 nor the N x101.97 case).

Processing per run:
  1. keep states rows with force != -1;
  2. common span = [max(first valid force t, first sensor t), min(last ...)], grid at 5 Hz from its start;
  3. linear interpolation of force (valid rows) and of every magnetometer channel onto the grid;
  4. candidates: 15 single channels, and for each magnetometer the norm of the 3-axis change from
     its first-second baseline; choose the one with the largest |Pearson r| with force on the grid;
  5. strain_pct = k * (s - mean(s over first second)), k chosen so the least-squares slope (with
     intercept) of strain_pct on force_g is +0.25 %/g (k negative = sign flipped).
"""
import os
import sys

import numpy as np

# SRC: a checkout of notvenky/eFlesh at ab5ca56, folder characterization/datasets/normal_force
SRC = sys.argv[1] if len(sys.argv) > 1 else "eFlesh/characterization/datasets/normal_force"
OUT = sys.argv[2] if len(sys.argv) > 2 else "out/real"
RUNS = ["20250401_014340_probe", "20250401_015037_probe", "20250401_015717_probe"]
RATE = 5.0
TARGET_GAIN = 0.25  # %/g
FORCE_TO_G = 1.0  # scale reading already in grams (see docstring)
AXES = "xyz"


def convert(run, idx):
    st = np.loadtxt(os.path.join(SRC, run, "states.csv"), delimiter=",")
    se = np.loadtxt(os.path.join(SRC, run, "sensor.csv"), delimiter=",")
    assert st.shape[1] == 5 and se.shape[1] == 16, (st.shape, se.shape)
    valid = st[:, 4] != -1
    ft, fv = st[valid, 0], st[valid, 4] * FORCE_TO_G
    assert np.all(np.diff(ft) > 0) and np.all(np.diff(se[:, 0]) > 0)
    mt, mag = se[:, 0], se[:, 1:]

    t0 = max(ft[0], mt[0])
    t1 = min(ft[-1], mt[-1])
    n = int(np.floor((t1 - t0) * RATE + 1e-9)) + 1
    tg = t0 + np.arange(n) / RATE
    force = np.interp(tg, ft, fv)
    chans = np.column_stack([np.interp(tg, mt, mag[:, j]) for j in range(15)])

    first = tg < tg[0] + 1.0
    cands = {}
    for j in range(15):
        cands[f"mag{j // 3}_B{AXES[j % 3]}"] = chans[:, j]
    for m in range(5):
        d = chans[:, 3 * m:3 * m + 3] - chans[first, 3 * m:3 * m + 3].mean(axis=0)
        cands[f"mag{m}_|dB|"] = np.linalg.norm(d, axis=1)
    corr = {k: np.corrcoef(force, v)[0, 1] for k, v in cands.items()}
    best = max(corr, key=lambda k: abs(corr[k]))
    s = cands[best]
    base = s[first].mean()
    ds = s - base
    slope = np.polyfit(force, ds, 1)[0]
    k = TARGET_GAIN / slope
    strain = k * ds
    gain = np.polyfit(force, strain, 1)[0]

    # gaps in the valid force log inside the span
    fin = (ft >= t0) & (ft <= t1)
    gaps = np.diff(ft[fin])
    big = gaps[gaps > 0.5]
    sgaps = np.diff(mt[(mt >= t0) & (mt <= t1)])
    sbig = sgaps[sgaps > 0.5]

    fname = f"eflesh_normal_{idx}.csv"
    path = os.path.join(OUT, fname)
    with open(path, "w") as f:
        f.write(f"# source=notvenky/eFlesh:characterization/datasets/normal_force/{run}/states.csv+sensor.csv "
                f"(commit ab5ca56), licence=MIT\n")
        f.write(f"# sample_rate_hz={RATE:g}\n")
        f.write("t_s,force_g,strain_pct\n")
        for i in range(n):
            f.write(f"{i / RATE:.3f},{force[i]:.3f},{strain[i]:.4f}\n")

    info = dict(
        run=run, file=path, n=n, dur=(n - 1) / RATE, best=best, r=corr[best], k=k, base=base, gain=gain,
        n_valid=int(valid.sum()), n_rows=len(st), n_sensor=len(se),
        fdt=float(np.median(np.diff(ft))), sdt=float(np.median(np.diff(mt))),
        ngap=len(big), gap_s=float(big.sum()), gap_max=float(big.max()) if len(big) else 0.0,
        nsgap=len(sbig), sgap_s=float(sbig.sum()),
        fmin=float(force.min()), fmax=float(force.max()), smin=float(strain.min()), smax=float(strain.max()),
        top=sorted(corr.items(), key=lambda kv: -abs(kv[1]))[:5],
        start_offset=float(t0 - min(ft[0], mt[0])),
    )
    return info


def main():
    infos = [convert(r, i + 1) for i, r in enumerate(RUNS)]
    for d in infos:
        print(f"{d['file']}: {d['n']} samples, {d['dur']:.1f} s at {RATE:g} Hz; source rows {d['n_rows']} "
              f"(valid force {d['n_valid']}, median dt {d['fdt']:.4f} s), sensor rows {d['n_sensor']} "
              f"(median dt {d['sdt']:.4f} s)")
        print(f"  chosen {d['best']} r={d['r']:+.4f}; baseline {d['base']:.3f}; k={d['k']:.6g} %/unit; "
              f"LS gain {d['gain']:.4f} %/g")
        print(f"  force gaps >0.5 s: {d['ngap']} totalling {d['gap_s']:.2f} s (max {d['gap_max']:.2f} s); "
              f"sensor gaps >0.5 s: {d['nsgap']} totalling {d['sgap_s']:.2f} s")
        print(f"  force {d['fmin']:.2f}..{d['fmax']:.2f} g, strain {d['smin']:.3f}..{d['smax']:.3f} %")
        print("  top candidates: " + ", ".join(f"{k} {v:+.4f}" for k, v in d["top"]))
    return infos


if __name__ == "__main__":
    main()
