#!/usr/bin/env python3
"""An outside user's records: a finger written apart from both of the project's generators.

Finger: elastic compliance plus two or three Kelvin modes (SLS/Burgers-like), simulated at 10x the
record's rate by exact discretization; excitation: filtered random force, triangles, staircases
(not the project's shapes). Effects in forms the project did not write: Hertzian stiffening
(strain ~ F^(2/3)), Bouc-Wen hysteresis, exponential + sinusoidal drift, 60 Hz + harmonic
interference, fractional delay, exponential gain sag, extra slow mode.
usage: gen.py OUT.csv SEED RATE DURATION [effect=value ...]
effects: hertz=S (blend of F^(2/3)), boucwen=W, drift=A, slow=SHARE (tau 40 s), delay_ms=MS,
tone=A (60 and 180 Hz), gainsag=FRACTION; record: snoise=, fnoise=, quant=, bw= (probe Hz).
Ran by scripts/outside-records.sh; not used by the tests (numpy, and a generator apart).
"""
import sys, numpy as np

def excitation(rng, t):
    f = np.zeros_like(t)
    T = t[-1]
    # segments of different kinds
    s = 1.0
    segs = []
    while s < T:
        kind = rng.random()
        L = rng.uniform(4, 15)
        segs.append((s, min(s + L, T), kind, rng.uniform(8, 70), rng.uniform(0.05, 3.0)))
        s += L + rng.uniform(0.5, 3)
    dt = t[1] - t[0]
    for (a, b, kind, lev, hz) in segs:
        m = (t >= a) & (t < b)
        tt = t[m] - a
        if kind < 0.35:  # triangle waves
            per = 1.0 / hz
            ph = (tt / per) % 1.0
            f[m] = lev * (1 - np.abs(2 * ph - 1))
        elif kind < 0.7:  # filtered random
            w = rng.normal(size=m.sum())
            # one-pole lowpass at hz*3
            a1 = np.exp(-2 * np.pi * min(hz * 3, 0.2 / dt) * dt)
            y = np.zeros_like(w); acc = 0
            for i in range(len(w)):
                acc = a1 * acc + (1 - a1) * w[i]; y[i] = acc
            y = y / (np.std(y) + 1e-9)
            f[m] = np.clip(lev * 0.5 + lev * 0.3 * y, 0, None)
        else:  # staircase
            steps = rng.integers(2, 6)
            k = np.minimum((tt / ((b - a) / steps)).astype(int), steps - 1)
            f[m] = lev * (k + 1) / steps
    # smooth the corners a little (probe bandwidth ~ 30 Hz)
    a1 = np.exp(-2 * np.pi * BW * dt)
    y = np.zeros_like(f); acc = 0
    for i in range(len(f)):
        acc = a1 * acc + (1 - a1) * f[i]; y[i] = acc
    return y

def main():
    out, seed, rate, dur = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
    eff = dict(a.split("=") for a in sys.argv[5:])
    rng = np.random.default_rng(seed)
    global BW; BW = float(eff.get("bw", 30))
    over = 10
    h = 1 / (rate * over)
    n = int(round(dur * rate))
    t = np.arange(n * over) * h
    F = excitation(rng, t)
    c0 = rng.uniform(0.15, 0.3)          # %/g elastic
    nm = rng.integers(2, 4)
    taus = np.sort(rng.uniform(np.log(0.02), np.log(5), nm)); taus = np.exp(taus)
    cs = c0 * rng.uniform(0.1, 0.5, nm)
    drive = F.copy()
    if "hertz" in eff:  # strain ~ F^(2/3) blended: s=strength
        s = float(eff["hertz"]); F0 = 30.0
        drive = (1 - s) * F + s * F0 * np.sign(F) * (np.abs(F) / F0) ** (2 / 3)
    if "slow" in eff:
        taus = np.append(taus, 40.0); cs = np.append(cs, c0 * float(eff["slow"]))
    if "boucwen" in eff:
        # Bouc-Wen on force: z' = A F' - b|F'||z|^(n-1) z - g F'|z|^n, hysteretic part added to drive
        w = float(eff["boucwen"]); z = 0.0; zs = np.zeros_like(F)
        dF = np.diff(F, prepend=F[0])
        for i in range(len(F)):
            d = dF[i]
            z += d - 0.05 * abs(d) * z - 0.0 * d * abs(z)
            zs[i] = z
        # zs saturates at about 20 g: loop width ~ w * 20 g
        drive = drive + w * (F - zs)  # strain lags: higher on unloading at equal load
    sys.stderr.write(f"taus {taus} cs/c0 {cs/c0}\n")
    x = np.zeros(len(taus)); strain = np.zeros_like(F)
    ea = np.exp(-h / taus)
    for i in range(len(F)):
        x = ea * x + (1 - ea) * drive[i]
        strain[i] = c0 * drive[i] + np.dot(cs, x)
    # decimate by sampling (records are sampled)
    idx = np.arange(n) * over
    tr = t[idx]; Ftrue = F[idx]; S = strain[idx].copy()
    peak = np.max(np.abs(S))
    if "delay_ms" in eff:
        dly = float(eff["delay_ms"]) / 1000
        S = np.interp(tr - dly, tr, S, left=S[0])
    if "drift" in eff:
        a = float(eff["drift"]) * peak
        S += a * (0.6 * (1 - np.exp(-tr / (dur / 5))) + 0.4 * np.sin(2 * np.pi * tr / (dur / 2.3) + 1.0))
    if "gainsag" in eff:
        S *= 1 - float(eff["gainsag"]) * (1 - np.exp(-tr / (dur / 3)))
    if "tone" in eff:
        a = float(eff["tone"]) * peak
        S += a * np.sin(2 * np.pi * 60 * tr) + 0.4 * a * np.sin(2 * np.pi * 180 * tr + 0.3)
    noise_s = float(eff.get("snoise", 0.005))
    S += rng.normal(0, noise_s, n)
    Fm = Ftrue + rng.normal(0, float(eff.get("fnoise", 0.14)), n)
    if "quant" in eff:
        q = float(eff["quant"]); S = np.round(S / q) * q
    with open(out, "w") as fh:
        fh.write(f"# source=outside generator seed={seed} effects={eff}\n# sample_rate_hz={rate:g}\n")
        fh.write("t_s,force_g,strain_pct\n")
        for i in range(n):
            fh.write(f"{tr[i]:.6f},{Fm[i]:.4f},{S[i]:.6f}\n")

main()
