#!/usr/bin/env python3
"""Convert the underwater 1D records of SDUSoftRobotics/2025_TactileFSI (commit 906a184, CC BY 4.0)
to the record format, the way ../shared/data/real/ converts the same laboratory's preliminary ones.

Source: `Raw Data Processing/underwater/1D_underwater_{10mm,30mm,50mm,nowater}.mat`, read from the
git snapshot: a soft skin with a fluid channel, under 10/30/50 mm of water or none, pressed nine
times to about 500 g against a load cell. Each file holds a MATLAB timetable (an MCOS object that
scipy.io cannot decode as such; its serialized workspace is read with scipy's MAT v5 reader):
Dev1_ai0 (load cell, V), Dev1_ai1 and Dev1_ai3 (the channel's two pressure transducers, V), row
times in ms (exactly 10 ms apart, 8000 rows).

What is changed (as CC BY 4.0 asks us to say): force_g = -4.1448 N/V x V x 101.97 (the repository's
own factor), shifted so that the first second reads zero; of the two pressure transducers and
their sum, the one best correlated with force (the sum: the presses move along the channel, from
one transducer towards the other), shifted the same way and scaled by one constant so its
least-squares gain is 0.25 %/g, is given as strain_pct. Nothing is filtered, resampled or cut.

    python3 convert_tactilefsi_underwater.py TactileFSI/.git out/real
"""
import io
import os
import subprocess
import sys

import numpy as np
import scipy.io as sio
from scipy.io.matlab._mio5 import MatFile5Reader

GIT_DIR = sys.argv[1] if len(sys.argv) > 1 else "2025_TactileFSI/.git"
OUT = sys.argv[2] if len(sys.argv) > 2 else "out/real"
COMMIT = "906a184"
RUNS = ["10mm", "30mm", "50mm", "nowater"]
N_PER_V, G_PER_N, TARGET_GAIN = -4.1448, 101.97, 0.25


def leaves(o):
    """Every numeric array inside a decoded MCOS blob, depth first."""
    if isinstance(o, np.ndarray) and o.dtype.names:
        for e in o.flat:
            for f in o.dtype.names:
                yield from leaves(e[f])
    elif isinstance(o, np.ndarray) and o.dtype == object:
        for e in o.flat:
            yield from leaves(e)
    elif hasattr(o, "_fieldnames"):
        yield o
        for f in o._fieldnames:
            yield from leaves(getattr(o, f))
    elif isinstance(o, np.ndarray):
        yield o


def read_timetable(path):
    raw = subprocess.run(["git", "--git-dir", GIT_DIR, "show", f"{COMMIT}:{path}"],
                         check=True, capture_output=True).stdout
    fw = sio.loadmat(io.BytesIO(raw))["__function_workspace__"].tobytes()
    # The workspace is a MAT v5 stream without the 128-byte file header (4 bytes version and
    # endianness, 4 of padding): give it one.
    r = MatFile5Reader(io.BytesIO(b"\0" * 124 + fw[:4] + fw[8:]), struct_as_record=False, squeeze_me=True)
    r.initialize_read()
    r.mat_stream.seek(128)
    hdr, _ = r.read_var_header()
    blob = list(leaves(r.read_var_array(hdr, False)))
    tab = next(o for o in blob if hasattr(o, "_fieldnames") and "varNames" in o._fieldnames)
    n = int(tab.numRows)
    t_ms = next(a for a in blob if isinstance(a, np.ndarray) and a.dtype == float and a.shape == (n,) and a[0] == 0)
    return t_ms / 1000.0, dict(zip(tab.varNames, tab.data))


def main():
    for run in RUNS:
        path = f"Raw Data Processing/underwater/1D_underwater_{run}.mat"
        t, d = read_timetable(path)
        dt = np.diff(t)
        assert np.allclose(dt, 0.01, atol=1e-9), (dt.min(), dt.max())
        first = t < t[0] + 1.0
        force = N_PER_V * d["Dev1_ai0"] * G_PER_N
        force -= force[first].mean()
        cands = {"Dev1_ai1": d["Dev1_ai1"], "Dev1_ai3": d["Dev1_ai3"], "Dev1_ai1+Dev1_ai3": d["Dev1_ai1"] + d["Dev1_ai3"]}
        r = {c: np.corrcoef(force, v)[0, 1] for c, v in cands.items()}
        chan = max(r, key=lambda c: abs(r[c]))
        p = cands[chan] - cands[chan][first].mean()
        k = TARGET_GAIN / np.polyfit(force, p, 1)[0]
        strain = k * p
        out = os.path.join(OUT, f"fsi_underwater_{run}.csv")
        with open(out, "w") as f:
            f.write(f"# source=SDUSoftRobotics/2025_TactileFSI:{path} (commit {COMMIT}), licence=CC BY 4.0\n")
            f.write(f"# processing=force_g={N_PER_V}*Dev1_ai0*{G_PER_N} zeroed on the first second; "
                    f"strain_pct={k:.6g}*({chan} zeroed on the first second); nothing filtered or resampled\n")
            f.write("# sample_rate_hz=100\n")
            f.write("t_s,force_g,strain_pct\n")
            for a, b, c in zip(t - t[0], force, strain):
                f.write(f"{a:.2f},{b:.3f},{c:.5f}\n")
        print(f"{out}: {len(t)} samples, {t[-1] - t[0]:.2f} s at 100 Hz; {chan} (r: "
              + ", ".join(f"{c} {v:+.3f}" for c, v in r.items()) + f"); force {force.min():.1f}..{force.max():.1f} g, "
              f"strain {strain.min():.2f}..{strain.max():.2f} %")


if __name__ == "__main__":
    main()
