//! A delayed column's Gram products from its source's. Delayed by L samples, a column's sum
//! over a fold is its source's sum over the fold moved back by L: the fold's own sum (taken
//! once) and two pieces of L samples at its ends. A delay search scores tens of delays of the
//! same columns; each costs O(L) a pair, not a pass over the record. Only where every sample
//! counts (a left-out sample would move with the fold).

use std::f64::consts::PI;

/// Per fold, for sources `a` and `b` over [max(s, 1), e): Σ a_j·b_j and
/// Σ (a_j·b_{j−1} + a_{j−1}·b_j) (what a fractional delay mixes in).
pub(super) fn pair_base(a: &[f32], b: &[f32], (s, e): (usize, usize)) -> [f64; 2] {
    let r = lagged(a, b, s.max(1), e);
    [r[0], r[1]]
}

/// Σ over samples [lo, hi), lo ≥ 1, of (a_j·b_j, a_j·b_{j−1} + a_{j−1}·b_j), in eight running
/// sums (one is a chain of dependent additions).
fn lagged(a: &[f32], b: &[f32], lo: usize, hi: usize) -> [f64; 2] {
    if hi <= lo {
        return [0.0; 2];
    }
    let (x, xp) = (&a[lo..hi], &a[lo - 1..hi - 1]);
    let (y, yp) = (&b[lo..hi], &b[lo - 1..hi - 1]);
    let mut acc = [[0.0f64; 8]; 2];
    let whole = x.len() - x.len() % 8;
    for c in (0..whole).step_by(8) {
        for l in 0..8 {
            let i = c + l;
            let (u, v) = (f64::from(x[i]), f64::from(y[i]));
            acc[0][l] += u * v;
            acc[1][l] += u * f64::from(yp[i]) + f64::from(xp[i]) * v;
        }
    }
    let mut out = acc.map(|a| a.iter().sum::<f64>());
    for i in whole..x.len() {
        let (u, v) = (f64::from(x[i]), f64::from(y[i]));
        out[0] += u * v;
        out[1] += u * f64::from(yp[i]) + f64::from(xp[i]) * v;
    }
    out
}

/// Σ over the fold [s, e) of x_i·y_i, x and y the sources `a` and `b` delayed by `whole +
/// frac` samples as `span` reads them (held at their first value), from the fold's
/// [`pair_base`].
pub(super) fn delayed_pair(
    (a, b): (&[f32], &[f32]),
    (whole, frac): (usize, f32),
    (s, e): (usize, usize),
    base: [f64; 2],
) -> f64 {
    let f = f64::from(frac);
    let ab = |j: usize| f64::from(a[j]) * f64::from(b[j]);
    // Samples at or before `whole` hold the first value.
    let split = (whole + 1).clamp(s, e);
    let head = (split - s) as f64 * ab(0);
    if split == e {
        return head;
    }
    // Sample i > whole reads j = i − whole and j − 1: j over [p, q), p ≥ 1.
    let (p, q, s1) = (split - whole, e - whole, s.max(1));
    let sums = moved(base, (s1, e), (p, q), |lo, hi| lagged(a, b, lo, hi));
    // Σ a_{j−1}·b_{j−1} over [p, q) is Σ a_j·b_j over [p − 1, q − 1).
    let previous = sums[0] + ab(p - 1) - ab(q - 1);
    head + (1.0 - f) * (1.0 - f) * sums[0] + f * (1.0 - f) * sums[1] + f * f * previous
}

/// The sums over [p, q) from those over [s, e) (`base`): the pieces between their ends added
/// or taken off, or [p, q) summed by `sum` where that is shorter.
fn moved(
    base: [f64; 2],
    (s, e): (usize, usize),
    (p, q): (usize, usize),
    sum: impl Fn(usize, usize) -> [f64; 2],
) -> [f64; 2] {
    if p.abs_diff(s) + q.abs_diff(e) >= q.saturating_sub(p) {
        return sum(p, q);
    }
    let signed = |from: usize, to: usize| {
        if from <= to {
            sum(from, to)
        } else {
            sum(to, from).map(|v| -v)
        }
    };
    let (lead, tail) = (signed(p, s), signed(q, e));
    [0, 1].map(|m| base[m] + lead[m] - tail[m])
}

/// Per fold [s, e): Σ cos θ_j·a_j and Σ sin θ_j·a_j, θ_j = π·k·(j + ½)/n (the half-cosine
/// `k` of a record of `n` samples, and its quadrature).
pub(super) fn cosine_base(a: &[f32], n: usize, k: usize, (s, e): (usize, usize)) -> [f64; 2] {
    quadrature(a, n, k, s, e)
}

/// Σ over samples [lo, hi) of (cos θ_j·a_j, sin θ_j·a_j): eight lanes, each rotated by eight
/// samples at a time (a sine a sample costs as much as the rest).
fn quadrature(a: &[f32], n: usize, k: usize, lo: usize, hi: usize) -> [f64; 2] {
    let step = PI * k as f64 / n.max(1) as f64;
    let (sin8, cos8) = (8.0 * step).sin_cos();
    let mut lanes = [(0.0f64, 0.0f64); 8];
    for (l, lane) in lanes.iter_mut().enumerate() {
        *lane = (step * ((lo + l) as f64 + 0.5)).sin_cos();
    }
    let mut acc = [[0.0f64; 8]; 2];
    for chunk in a[lo..hi.max(lo)].chunks(8) {
        for (l, x) in chunk.iter().enumerate() {
            let (sin, cos) = lanes[l];
            acc[0][l] += cos * f64::from(*x);
            acc[1][l] += sin * f64::from(*x);
        }
        for lane in &mut lanes {
            let (sn, cs) = *lane;
            *lane = (sn * cos8 + cs * sin8, cs * cos8 - sn * sin8);
        }
    }
    acc.map(|a| a.iter().sum::<f64>())
}

/// Σ over the fold [s, e) of cos θ_i·x_i, x the source `a` delayed by `whole + frac` samples
/// as `span` reads it, from the fold's [`cosine_base`]: the half-cosine moved by L samples is
/// cos θ_j·cos φ − sin θ_j·sin φ, φ = π·k·L/n.
pub(super) fn delayed_cosine(
    a: &[f32],
    (n, k): (usize, usize),
    (whole, frac): (usize, f32),
    (s, e): (usize, usize),
    base: [f64; 2],
) -> f64 {
    let step = PI * k as f64 / n.max(1) as f64;
    let split = (whole + 1).clamp(s, e);
    // The held samples: a constant against the half-cosine, Σ cos θ_i in closed form.
    let head = f64::from(a.first().copied().unwrap_or(0.0)) * cosine_sum(step, s, split);
    if split == e {
        return head;
    }
    // Σ over i in [split, e) of cos θ_i·a_{i−L}: a over [split − L, e − L).
    let shifted = |lag: usize| -> f64 {
        let range = (split - lag, e - lag);
        let sums = moved(base, (s, e), range, |lo, hi| quadrature(a, n, k, lo, hi));
        let (sin, cos) = (step * lag as f64).sin_cos();
        cos * sums[0] - sin * sums[1]
    };
    let f = f64::from(frac);
    let later = if f == 0.0 {
        0.0
    } else {
        f * shifted(whole + 1)
    };
    head + (1.0 - f) * shifted(whole) + later
}

/// Σ cos(step·(i + ½)) over samples [lo, hi): the Dirichlet kernel's sum,
/// sin(m·step/2)·cos(step·(lo + hi)/2)/sin(step/2) for m = hi − lo samples.
fn cosine_sum(step: f64, lo: usize, hi: usize) -> f64 {
    let m = hi.saturating_sub(lo) as f64;
    let half = (0.5 * step).sin();
    if half.abs() < 1e-300 {
        return m;
    }
    (0.5 * m * step).sin() * (0.5 * step * (lo + hi) as f64).cos() / half
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sample i of `v` delayed as `span` reads it, in f64.
    fn at(v: &[f32], whole: usize, frac: f32, i: usize) -> f64 {
        let f = f64::from(frac);
        if i > whole {
            f64::from(v[i - whole]) * (1.0 - f) + f64::from(v[i - whole - 1]) * f
        } else {
            f64::from(v[0])
        }
    }

    fn columns(n: usize) -> (Vec<f32>, Vec<f32>) {
        let a = (0..n)
            .map(|i| ((i * 37) % 101) as f32 / 50.0 - 1.0 + 0.3)
            .collect();
        let b = (0..n)
            .map(|i| (i as f32 * 0.013).sin() + ((i * 7) % 13) as f32 / 20.0)
            .collect();
        (a, b)
    }

    const FOLDS: [(usize, usize); 6] = [
        (0, 4000),
        (0, 3),
        (2, 9),
        (4000, 8000),
        (7990, 10_007),
        (5, 10_007),
    ];
    const DELAYS: [(usize, f32); 7] = [
        (0, 0.25),
        (1, 0.0),
        (3, 0.5),
        (40, 0.75),
        (517, 0.0),
        (517, 0.3),
        (9000, 0.5),
    ];

    #[test]
    fn a_delayed_pair_sums_as_its_samples_do() {
        let n = 10_007;
        let (a, b) = columns(n);
        for (whole, frac) in DELAYS {
            for fold in FOLDS {
                let naive: f64 = (fold.0..fold.1)
                    .map(|i| at(&a, whole, frac, i) * at(&b, whole, frac, i))
                    .sum();
                let fast = delayed_pair((&a, &b), (whole, frac), fold, pair_base(&a, &b, fold));
                assert!(
                    (fast - naive).abs() <= 1e-9 * (fold.1 - fold.0) as f64,
                    "delay {whole}+{frac} fold {fold:?}: {fast} {naive}"
                );
            }
        }
    }

    #[test]
    fn a_delayed_column_against_a_half_cosine_sums_as_its_samples_do() {
        let n = 10_007;
        let (a, _) = columns(n);
        for k in [1, 2, 7, 16] {
            let c = crate::terms::cosine(n, k);
            for (whole, frac) in DELAYS {
                for fold in FOLDS {
                    let naive: f64 = (fold.0..fold.1)
                        .map(|i| c[i] * at(&a, whole, frac, i))
                        .sum();
                    let base = cosine_base(&a, n, k, fold);
                    let fast = delayed_cosine(&a, (n, k), (whole, frac), fold, base);
                    assert!(
                        (fast - naive).abs() <= 1e-9 * (fold.1 - fold.0) as f64,
                        "k {k} delay {whole}+{frac} fold {fold:?}: {fast} {naive}"
                    );
                }
            }
        }
    }
}
