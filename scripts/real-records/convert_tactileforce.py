#!/usr/bin/env python3
"""Convert one raw record of vistormu/tactileforce (squishy-skin dataset) to the
project's record format (t_s, force_g, strain_pct).

Source file: skin/datasets/squishy-skin/raw-data/simplified/11-02-2025_14-26-13.csv
(columns fz [N], s0..s3 [relative ADC fraction], time [s]); read from the git
snapshot, never executed.

Steps
  1. resample fz and the chosen sensor channel onto an exact 100 Hz grid by
     linear interpolation (source step is 0.0100 +/- 0.0005 s, max 0.021 s);
  2. force_g = fz * 101.97;
  3. strain_pct = k * (s - mean(s over first 1 s)), k chosen so that the
     least-squares slope of strain_pct on force_g (with intercept) is 0.25 %/g
     (k < 0 would flip the sign; here the output rises with force, k > 0).
"""
import subprocess
import sys

import numpy as np

# GIT_DIR: the .git folder of a clone of vistormu/tactileforce
GIT_DIR = sys.argv[1] if len(sys.argv) > 1 else "tactileforce/.git"
COMMIT = "4e7a10b66ed37fa25c4d2bf9e34beac8cd53046a"
PATH = "skin/datasets/squishy-skin/raw-data/simplified/11-02-2025_14-26-13.csv"
CHANNEL = "s0"
RATE = 100.0
N_PER_G = 101.97
TARGET_GAIN = 0.25  # %/g
OUT = sys.argv[2] if len(sys.argv) > 2 else "out/real/tactileforce_squishy.csv"


def main():
    raw = subprocess.run(["git", "--git-dir", GIT_DIR, "show", f"{COMMIT}:{PATH}"],
                         check=True, capture_output=True, text=True).stdout
    lines = raw.strip().splitlines()
    names = lines[0].split(",")
    data = np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])
    col = {n: i for i, n in enumerate(names)}
    t = data[:, col["time"]]
    fz = data[:, col["fz"]]
    s = data[:, col[CHANNEL]]
    assert np.all(np.diff(t) > 0), "time not increasing"
    dt = np.diff(t)
    print(f"source: {len(t)} samples, dt {dt.mean():.5f} +/- {dt.std():.5f} s, max {dt.max():.4f} s")

    t0 = t[0]
    n = int(np.floor((t[-1] - t0) * RATE)) + 1
    tg = np.arange(n) / RATE
    fz_g = np.interp(tg + t0, t, fz)
    s_g = np.interp(tg + t0, t, s)

    force_g = fz_g * N_PER_G
    base = s_g[tg < 1.0].mean()
    ds = s_g - base
    slope = np.polyfit(force_g, ds, 1)[0]
    k = TARGET_GAIN / slope
    strain = k * ds
    check = np.polyfit(force_g, strain, 1)
    r = np.corrcoef(force_g, strain)[0, 1]
    print(f"k={k:.6g} (raw slope {slope:.6g} per g), LS gain now {check[0]:.4f} %/g, "
          f"intercept {check[1]:.4f} %, r={r:.4f}")
    print(f"length {tg[-1]:.2f} s, {n} samples, force {force_g.min():.1f}..{force_g.max():.1f} g, "
          f"strain {strain.min():.2f}..{strain.max():.2f} %")

    with open(OUT, "w") as f:
        f.write(f"# source=vistormu/tactileforce:{PATH} (commit {COMMIT})\n")
        f.write("# licence=none (no licence file): usable locally only, not to be committed\n")
        f.write(f"# sensor=in-house tactile sensor (4 ADC channels with LED illumination, likely optical) under a soft squishy cap, channel {CHANNEL}; reference Bota Systems SensONE F/T sensor fz\n")
        f.write(f"# processing=linear resample to exact {RATE:g} Hz; force_g=fz*101.97; strain_pct={k:.6g}*({CHANNEL} - ({base:.6g}))\n")
        f.write(f"# sample_rate_hz={RATE:g}\n")
        f.write("t_s,force_g,strain_pct\n")
        for a, b, c in zip(tg, force_g, strain):
            f.write(f"{a:.4f},{b:.3f},{c:.5f}\n")
    print("wrote", OUT)


if __name__ == "__main__":
    sys.exit(main())
