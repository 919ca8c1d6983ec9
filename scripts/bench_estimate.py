#!/usr/bin/env python3
"""The chip's force estimate against a ridge FIR inverse on measured records.

Per record, the workflow of a user with a sensor and a load cell: the first 60 % of the samples to
`tactile diagnose --table`, the last 40 % to `tactile estimate` with that table; each estimator's
RMS force error is computed here from the estimate file. On the same split, a ridge regression of
force on the last `span` s of strain (`taps` taps, standardized, span/taps/lambda chosen by blocked
5-fold cross-validation on the first 60 % only), scored on the last 40 % from a cold start (history
padded with its first sample), as the chip's estimators start cold. With --mlp also a scikit-learn
MLPRegressor on the last 1 s of strain. Run it through scripts/bench-estimate.sh.

    bench_estimate.py --tactile BIN --tmp DIR [--csv OUT.csv] [--mlp] RECORD.csv...
"""
import argparse
import os
import subprocess
import sys

import numpy as np

SPANS_S = (1, 2, 5, 10)
TAPS = (24, 32, 64)
ALPHAS = np.logspace(-6, 3, 19)  # lambda = alpha * training rows (features standardized)
FOLDS = 5


def read_record(path):
    """(comment lines, header line, data lines, t, force, strain); raises ValueError."""
    comments, data, header = [], [], None
    for ln in open(path):
        ln = ln.rstrip("\r\n")
        if not ln.strip():
            continue
        if ln.lstrip().startswith("#"):
            comments.append(ln)
        elif header is None:
            header = ln
        else:
            data.append(ln)
    if header is None:
        raise ValueError("no header line")
    names = [c.strip() for c in header.split(",")]
    if any(c not in names for c in ("t_s", "force_g", "strain_pct")):
        raise ValueError(f"header {header!r} lacks t_s,force_g,strain_pct")
    idx = [names.index(c) for c in ("t_s", "force_g", "strain_pct")]
    arr = np.array([[float(ln.split(",")[i]) for i in idx] for ln in data])
    if arr.ndim != 2 or len(arr) < 50 or not np.all(np.isfinite(arr)):
        raise ValueError("fewer than 50 finite samples")
    return comments, header, data, arr[:, 0], arr[:, 1], arr[:, 2]


def read_estimates(path):
    """(the column the chip runs, {estimate column: RMS error g}) from `tactile estimate --out`."""
    chip, rows, header = None, [], None
    for ln in open(path):
        ln = ln.strip()
        if ln.startswith("#"):
            if ln[1:].strip().startswith("chip_runs="):
                chip = ln.split("=", 1)[1].strip()
        elif ln and header is None:
            header = [c.strip() for c in ln.split(",")]
        elif ln:
            rows.append([float(v) for v in ln.split(",")])
    a = np.array(rows)
    force = a[:, header.index("force_g")]
    cols = [c for c in header if c.endswith("_g") and c != "force_g"]
    rms = {c: float(np.sqrt(np.mean((a[:, header.index(c)] - force) ** 2))) for c in cols}
    chip = chip or "elastic_g"
    if chip not in rms and chip + "_g" in rms:
        chip += "_g"
    if chip not in rms:
        raise ValueError(f"{path}: chip_runs={chip} names no estimate column ({', '.join(cols)})")
    return chip, rms


def lagged(x, taps, m, pad):
    """Rows n of [x[n], x[n-m], ..., x[n-(taps-1)m]] over x prefixed by `pad` samples."""
    L = (taps - 1) * m
    xp = np.concatenate([pad[:L], x]) if pad is not None else x
    n = len(xp) - L
    return np.column_stack([xp[L - k * m: L - k * m + n] for k in range(taps)])


def ridge_fit(X, y, lams):
    """Standardized ridge for each lambda: list of (mean, std, coef, intercept)."""
    mu, sd = X.mean(0), X.std(0) + 1e-12
    Z = (X - mu) / sd
    e, V = np.linalg.eigh(Z.T @ Z)
    vy = V.T @ (Z.T @ (y - y.mean()))
    return [(mu, sd, V @ (vy / (np.maximum(e, 0) + lam)), y.mean()) for lam in lams]


def ridge_predict(model, X):
    mu, sd, b, c = model
    return c + ((X - mu) / sd) @ b


def ridge(t1, f1, s1, f2, s2, dt):
    """Chooses span, taps, lambda by blocked CV on part 1; returns (rms on part 2, history s, taps).

    The history reported is the one the taps cover, taps * m * dt (over `span` at low rates)."""
    best = None
    seen = set()
    for span in SPANS_S:
        for taps in TAPS:
            m = max(1, round(span / (taps * dt)))
            L = (taps - 1) * m
            if (taps, m) in seen or len(s1) - L < 10 * FOLDS:
                continue
            seen.add((taps, m))
            X, y = lagged(s1, taps, m, None), f1[L:]
            edges = np.linspace(0, len(y), FOLDS + 1).astype(int)
            sse = np.zeros(len(ALPHAS))
            for a, b in zip(edges[:-1], edges[1:]):
                tr = np.r_[0:a, min(b + L, len(y)):len(y)]  # no training row sees the held-out block
                models = ridge_fit(X[tr], y[tr], ALPHAS * len(tr))
                sse += [np.sum((ridge_predict(mdl, X[a:b]) - y[a:b]) ** 2) for mdl in models]
            k = int(np.argmin(sse))
            if best is None or sse[k] < best[0]:
                best = (sse[k], span, taps, m, ALPHAS[k])
    _, _, taps, m, alpha = best
    L = (taps - 1) * m
    model = ridge_fit(lagged(s1, taps, m, None), f1[L:], [alpha * (len(s1) - L)])[0]
    pred = ridge_predict(model, lagged(s2, taps, m, np.full(L, s2[0])))
    return float(np.sqrt(np.mean((pred - f2) ** 2))), taps * m * dt, taps


def mlp(f1, s1, f2, s2, dt):
    from sklearn.neural_network import MLPRegressor
    taps = max(1, round(1.0 / dt))
    L = taps - 1
    X1, y = lagged(s1, taps, 1, None), f1[L:]
    mu, sd, fm, fs = X1.mean(0), X1.std(0) + 1e-12, y.mean(), y.std() + 1e-12
    net = MLPRegressor(hidden_layer_sizes=(64, 64), max_iter=500, early_stopping=True, random_state=0)
    net.fit((X1 - mu) / sd, (y - fm) / fs)
    X2 = lagged(s2, taps, 1, np.full(L, s2[0]))
    pred = fm + fs * net.predict((X2 - mu) / sd)
    return float(np.sqrt(np.mean((pred - f2) ** 2)))


def bench(path, args):
    comments, header, data, t, force, strain = read_record(path)
    name = os.path.splitext(os.path.basename(path))[0]
    dt = float(np.median(np.diff(t)))
    n1 = int(len(t) * 0.6)
    work = os.path.join(args.tmp, name)
    os.makedirs(work, exist_ok=True)
    first, last = os.path.join(work, "first.csv"), os.path.join(work, "last.csv")
    table, est = os.path.join(work, "T.bin"), os.path.join(work, "E.csv")
    for p, rows in ((first, data[:n1]), (last, data[n1:])):
        with open(p, "w") as f:
            f.write("\n".join(comments + [header] + rows) + "\n")
    row = dict(record=name, length_s=len(t) * dt, rate_hz=1.0 / dt, chip=None, chip_rms=None, cols={})
    d = subprocess.run([args.tactile, "diagnose", first, "--table", table], capture_output=True, text=True)
    if d.returncode == 0 and os.path.exists(table):
        e = subprocess.run([args.tactile, "estimate", last, "--table", table, "--out", est],
                           capture_output=True, text=True)
        if e.returncode != 0:
            raise RuntimeError(f"{path}: tactile estimate failed: {e.stderr.strip()}")
        row["chip"], row["cols"] = read_estimates(est)
        row["chip_rms"] = row["cols"].get(row["chip"])
    row["ridge"], row["span"], row["taps"] = ridge(t[:n1], force[:n1], strain[:n1], force[n1:], strain[n1:], dt)
    if args.mlp:
        row["mlp"] = mlp(force[:n1], strain[:n1], force[n1:], strain[n1:], dt)
    row["ratio"] = row["chip_rms"] / row["ridge"] if row["chip_rms"] is not None else None
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("records", nargs="+")
    ap.add_argument("--tactile", required=True)
    ap.add_argument("--tmp", required=True)
    ap.add_argument("--csv")
    ap.add_argument("--mlp", action="store_true")
    args = ap.parse_args()
    for p in args.records:  # every record readable before any work
        try:
            read_record(p)
        except (OSError, ValueError, IndexError) as e:
            sys.exit(f"{p}: cannot be read: {e}")
    rows = [bench(p, args) for p in args.records]
    cols = list(dict.fromkeys(c for r in rows for c in r["cols"]))
    head = ["record", "length_s", "rate_hz", "chip_runs", "chip_rms_g"] + [f"{c[:-2]}_rms_g" for c in cols] \
        + ["ridge_rms_g", "ridge_history_s", "ridge_taps"] + (["mlp_rms_g"] if args.mlp else []) + ["chip_over_ridge"]
    g = lambda v: "" if v is None else f"{v:.2f}" if np.isfinite(v) else "not finite"
    table = []
    for r in rows:
        table.append([r["record"], f"{r['length_s']:.0f}", f"{r['rate_hz']:.0f}", r["chip"] or "no table",
                      g(r["chip_rms"])] + [g(r["cols"].get(c)) for c in cols]
                     + [g(r["ridge"]), f"{r['span']:.1f}", str(r["taps"])]
                     + ([g(r["mlp"])] if args.mlp else []) + [g(r["ratio"])])
    ratios = [r["ratio"] for r in rows if r["ratio"] is not None and np.isfinite(r["ratio"])]
    wins = sum(1 for r in rows if r["ratio"] is not None and r["ratio"] <= 1.0)
    mean = f"{np.mean(ratios):.2f}" if ratios else "none"
    close = (f"mean chip / ridge ratio {mean} over {len(ratios)} record(s) with a finite chip estimate; "
             f"chip <= ridge on {wins} of {len(rows)}")
    if args.mlp:
        mr = [r["mlp"] / r["ridge"] for r in rows]
        close += f"; mean MLP / ridge ratio {np.mean(mr):.2f}"
    print("| " + " | ".join(head) + " |")
    print("|" + " --- |" * len(head))
    for cells in table:
        print("| " + " | ".join(c if c else "—" for c in cells) + " |")
    print()
    print(close)
    if args.csv:
        with open(args.csv, "w") as f:
            f.write(",".join(head) + "\n")
            f.writelines(",".join(cells) + "\n" for cells in table)
            f.write(f"# {close}\n")


if __name__ == "__main__":
    main()
