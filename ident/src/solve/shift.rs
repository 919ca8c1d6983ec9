//! A column delayed by whole samples: its Gram products from its source's. Delayed by L samples, a column's sum
//! over a fold is its source's sum over the fold moved back by L: the fold's own sum (taken
//! once) and two pieces of L samples at its ends. A delay search scores tens of delays of the
//! same columns; each costs O(L) a pair, not a pass over the record. Only where every sample
//! counts (a left-out sample would move with the fold).

use std::f64::consts::PI;

/// Per fold, for sources `a` and `b`, `b` read `lag` samples behind: Σ a_j·b_{j−lag} over
/// [s, e) (from j = lag), each product in f32 as the Gram products take it.
pub(super) fn pair_base(a: &[f32], b: &[f32], lag: usize, (s, e): (usize, usize)) -> f64 {
    lagged_products(a, b, lag, s, e)
}

/// Σ over samples j in [lo, hi), j ≥ `lag`, of a_j·b_{j−lag} (the product in f32).
fn lagged_products(a: &[f32], b: &[f32], lag: usize, lo: usize, hi: usize) -> f64 {
    let lo = lo.max(lag);
    if hi <= lo {
        return 0.0;
    }
    products(&a[lo..hi], &b[lo - lag..hi - lag], 0, hi - lo)
}

/// Σ over samples [lo, hi) of a_j·b_j (the product in f32), in eight running sums (one is a
/// chain of dependent additions).
fn products(a: &[f32], b: &[f32], lo: usize, hi: usize) -> f64 {
    if hi <= lo {
        return 0.0;
    }
    let (x, y) = (&a[lo..hi], &b[lo..hi]);
    let mut acc = [0.0f64; 8];
    let (cx, cy) = (x.chunks_exact(8), y.chunks_exact(8));
    let tail: f64 = cx
        .remainder()
        .iter()
        .zip(cy.remainder())
        .map(|(u, v)| f64::from(u * v))
        .sum();
    for (u, v) in cx.zip(cy) {
        for l in 0..8 {
            acc[l] += f64::from(u[l] * v[l]);
        }
    }
    acc.iter().sum::<f64>() + tail
}

/// The sum over [p, q) from the one over [s, e) (`base`): the pieces between their ends added
/// or taken off, or [p, q) summed by `sum` where that is shorter.
fn moved<T: Copy + core::ops::Add<Output = T> + core::ops::Sub<Output = T>>(
    base: T,
    (s, e): (usize, usize),
    (p, q): (usize, usize),
    sum: impl Fn(usize, usize) -> T,
) -> T {
    if p.abs_diff(s) + q.abs_diff(e) >= q.saturating_sub(p) {
        return sum(p, q);
    }
    // [p, q) = [p, s) + [s, e) − [q, e), each piece signed by its direction.
    let add = |acc: T, from: usize, to: usize, forward: bool| {
        if (from <= to) == forward {
            acc + sum(from.min(to), from.max(to))
        } else {
            acc - sum(from.min(to), from.max(to))
        }
    };
    add(add(base, p, s, true), q, e, false)
}

/// Σ over the fold [s, e) of x_i·y_i, x the source `a` delayed by `whole` samples and y the
/// source `b` delayed by `lag` more (0, or 1: the two whole-sample neighbours of a delay between
/// samples), as `span` reads them (held at their first values), from the fold's [`pair_base`].
pub(super) fn delayed_pair(
    (a, b): (&[f32], &[f32]),
    whole: usize,
    lag: usize,
    (s, e): (usize, usize),
    base: f64,
) -> f64 {
    // Samples at or before `whole` hold both first values; after them sample i reads a_j and
    // b_{j−lag}, j = i − whole (at j = lag = 1 that is b_0, b's held value too).
    let split = (whole + 1).clamp(s, e);
    let head = (split - s) as f64 * f64::from(a[0] * b[0]);
    if split == e {
        return head;
    }
    let range = (split - whole, e - whole);
    head + moved(base, (s, e), range, |lo, hi| {
        lagged_products(a, b, lag, lo, hi)
    })
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

/// Two sums side by side, as [`moved`] adds them.
#[derive(Clone, Copy)]
struct Pair([f64; 2]);

impl core::ops::Add for Pair {
    type Output = Pair;
    fn add(self, o: Pair) -> Pair {
        Pair([self.0[0] + o.0[0], self.0[1] + o.0[1]])
    }
}

impl core::ops::Sub for Pair {
    type Output = Pair;
    fn sub(self, o: Pair) -> Pair {
        Pair([self.0[0] - o.0[0], self.0[1] - o.0[1]])
    }
}

/// Σ over the fold [s, e) of cos θ_i·x_i, x the source `a` delayed by `whole` samples as
/// `span` reads it, from the fold's [`cosine_base`]: the half-cosine moved by L samples is
/// cos θ_j·cos φ − sin θ_j·sin φ, φ = π·k·L/n.
pub(super) fn delayed_cosine(
    a: &[f32],
    (n, k): (usize, usize),
    whole: usize,
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
    let range = (split - whole, e - whole);
    let sums = moved(Pair(base), (s, e), range, |lo, hi| {
        Pair(quadrature(a, n, k, lo, hi))
    });
    let (sin, cos) = (step * whole as f64).sin_cos();
    head + cos * sums.0[0] - sin * sums.0[1]
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

/// Per fold [s, e): Σ a_j and Σ (j − s)·a_j, the pieces of a delayed column's sums against the
/// fold's own offset and slope ([`delayed_local`]).
pub(super) fn local_base(a: &[f32], (s, e): (usize, usize)) -> [f64; 2] {
    level_and_ramp(a, s, (s, e))
}

/// Σ over samples [lo, hi) of (a_j, (j − s)·a_j).
fn level_and_ramp(a: &[f32], s: usize, (lo, hi): (usize, usize)) -> [f64; 2] {
    a[lo..hi.max(lo)]
        .iter()
        .enumerate()
        .fold([0.0; 2], |acc, (k, x)| {
            let x = f64::from(*x);
            [acc[0] + x, acc[1] + ((lo + k) as f64 - s as f64) * x]
        })
}

/// Over the fold [s, e): Σ x_i and Σ τ_i·x_i, x the source `a` delayed by `whole` samples as
/// `span` reads it and τ the time across the fold from −1 to 1 (as `Pool::local_sums` takes
/// them), from the fold's [`local_base`].
pub(super) fn delayed_local(
    a: &[f32],
    whole: usize,
    (s, e): (usize, usize),
    base: [f64; 2],
) -> [f64; 2] {
    let half = ((e - s).max(2) - 1) as f64 / 2.0;
    // The held samples, c of them from the fold's start: Σ τ_i = c·(c − 1)/2/half − c.
    let split = (whole + 1).clamp(s, e);
    let c = (split - s) as f64;
    let first = f64::from(a.first().copied().unwrap_or(0.0));
    let head = [first * c, first * (c * (c - 1.0) / 2.0 / half - c)];
    if split == e {
        return head;
    }
    // Sample i reads j = i − L: τ_i = (j − s + L)/half − 1.
    let range = (split - whole, e - whole);
    let sums = moved(Pair(base), (s, e), range, |lo, hi| {
        Pair(level_and_ramp(a, s, (lo, hi)))
    });
    let [level, ramp] = sums.0;
    [
        head[0] + level,
        head[1] + ramp / half + (whole as f64 / half - 1.0) * level,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sample i of `v` delayed by `whole` samples as `span` reads it.
    fn at(v: &[f32], whole: usize, i: usize) -> f32 {
        if i > whole {
            v[i - whole]
        } else {
            v[0]
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
    const DELAYS: [usize; 6] = [0, 1, 3, 40, 517, 9000];

    #[test]
    fn a_delayed_pair_sums_as_its_samples_do() {
        let n = 10_007;
        let (a, b) = columns(n);
        for whole in DELAYS {
            for fold in FOLDS {
                let naive: f64 = (fold.0..fold.1)
                    .map(|i| f64::from(at(&a, whole, i) * at(&b, whole, i)))
                    .sum();
                let fast = delayed_pair((&a, &b), whole, 0, fold, pair_base(&a, &b, 0, fold));
                assert!(
                    (fast - naive).abs() <= 1e-9 * (fold.1 - fold.0) as f64,
                    "delay {whole} fold {fold:?}: {fast} {naive}"
                );
            }
        }
    }

    #[test]
    fn a_pair_delayed_a_sample_apart_sums_as_its_samples_do() {
        let n = 10_007;
        let (a, b) = columns(n);
        for whole in DELAYS {
            for fold in FOLDS {
                for (lead, lag) in [(&a, &b), (&b, &a), (&a, &a)] {
                    let naive: f64 = (fold.0..fold.1)
                        .map(|i| f64::from(at(lead, whole, i) * at(lag, whole + 1, i)))
                        .sum();
                    let base = pair_base(lead, lag, 1, fold);
                    let fast = delayed_pair((lead, lag), whole, 1, fold, base);
                    assert!(
                        (fast - naive).abs() <= 1e-9 * (fold.1 - fold.0) as f64,
                        "delay {whole} fold {fold:?}: {fast} {naive}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_delayed_column_against_a_fold_offset_and_slope_sums_as_its_samples_do() {
        let n = 10_007;
        let (a, _) = columns(n);
        for whole in DELAYS {
            for fold in FOLDS {
                let half = ((fold.1 - fold.0).max(2) - 1) as f64 / 2.0;
                let naive = (fold.0..fold.1).fold([0.0; 2], |acc, i| {
                    let x = f64::from(at(&a, whole, i));
                    let tau = (i - fold.0) as f64 / half - 1.0;
                    [acc[0] + x, acc[1] + tau * x]
                });
                let fast = delayed_local(&a, whole, fold, local_base(&a, fold));
                for (f, v) in fast.iter().zip(naive) {
                    assert!(
                        (f - v).abs() <= 1e-9 * (fold.1 - fold.0) as f64,
                        "delay {whole} fold {fold:?}: {fast:?} {naive:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_delayed_column_against_a_half_cosine_sums_as_its_samples_do() {
        let n = 10_007;
        let (a, _) = columns(n);
        for k in [1, 2, 7, 16] {
            let c = crate::terms::cosine(n, k);
            for whole in DELAYS {
                for fold in FOLDS {
                    let naive: f64 = (fold.0..fold.1)
                        .map(|i| c[i] * f64::from(at(&a, whole, i)))
                        .sum();
                    let base = cosine_base(&a, n, k, fold);
                    let fast = delayed_cosine(&a, (n, k), whole, fold, base);
                    assert!(
                        (fast - naive).abs() <= 1e-9 * (fold.1 - fold.0) as f64,
                        "k {k} delay {whole} fold {fold:?}: {fast} {naive}"
                    );
                }
            }
        }
    }
}
