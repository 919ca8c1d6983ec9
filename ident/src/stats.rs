//! The statistics the identification uses, each written once: RMS, autocorrelation and the
//! Ljung–Box test, the paired test over folds, quantiles, a robust line, the noise floor.

use statrs::distribution::{ChiSquared, ContinuousCDF, StudentsT};

pub fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len().max(1) as f64
}

pub fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// The `q` quantile (0..=1) by sorting a copy; 0 for an empty slice.
pub fn quantile(x: &[f64], q: f64) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let mut v = x.to_vec();
    let i = (((v.len() - 1) as f64 * q.clamp(0.0, 1.0)).round() as usize).min(v.len() - 1);
    // Selection, not a sort: linear time on a 20 min record at 1 kHz.
    *v.select_nth_unstable_by(i, f64::total_cmp).1
}

pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let (ma, mb) = (mean(a), mean(b));
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        ab += (x - ma) * (y - mb);
        aa += (x - ma) * (x - ma);
        bb += (y - mb) * (y - mb);
    }
    if aa > 0.0 && bb > 0.0 {
        ab / (aa * bb).sqrt()
    } else {
        0.0
    }
}

/// Centred moving mean over `w` samples (shorter at the ends).
pub fn moving_mean(x: &[f64], w: usize) -> Vec<f64> {
    let n = x.len();
    let h = w / 2;
    let mut prefix = vec![0.0; n + 1];
    for i in 0..n {
        prefix[i + 1] = prefix[i] + x[i];
    }
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(h), (i + h + 1).min(n));
            (prefix[b] - prefix[a]) / (b - a) as f64
        })
        .collect()
}

/// Autocorrelation of `x` at lags `1..=lags`.
pub fn acf(x: &[f64], lags: usize) -> Vec<f64> {
    let m = mean(x);
    let var: f64 = x.iter().map(|v| (v - m) * (v - m)).sum();
    (1..=lags)
        .map(|k| {
            if var <= 0.0 || k >= x.len() {
                return 0.0;
            }
            x.iter()
                .zip(&x[k..])
                .map(|(a, b)| (a - m) * (b - m))
                .sum::<f64>()
                / var
        })
        .collect()
}

/// Ljung–Box Q over the first `lags` autocorrelations of a series of `n`, and Q over its 5 %
/// critical value (χ² with `lags` degrees of freedom): above 1, not white at that level.
pub fn ljung_box(acf: &[f64], n: usize, lags: usize) -> (f64, f64) {
    let n = n as f64;
    let q = n
        * (n + 2.0)
        * acf
            .iter()
            .take(lags)
            .enumerate()
            .map(|(i, r)| r * r / (n - i as f64 - 1.0).max(1.0))
            .sum::<f64>();
    let critical = ChiSquared::new(lags as f64)
        .map(|c| c.inverse_cdf(0.95))
        .unwrap_or(31.41);
    (q, q / critical)
}

/// Share of a series' variance left unpredicted by an autoregression on its past, from its
/// autocorrelation at lags 1.. (Levinson–Durbin: the product of 1 − k² over the reflection
/// coefficients). 1 for white noise, near 0 for a smooth signal.
pub fn innovation_share(acf: &[f64]) -> f64 {
    let p = acf.len();
    let r = |k: usize| if k == 0 { 1.0 } else { acf[k - 1] };
    let mut a = vec![0.0; p + 1];
    let mut err = 1.0;
    for m in 1..=p {
        let acc = r(m) - (1..m).map(|j| a[j] * r(m - j)).sum::<f64>();
        let k = (acc / err).clamp(-0.999_999, 0.999_999);
        let prev = a.clone();
        a[m] = k;
        for (j, aj) in a.iter_mut().enumerate().take(m).skip(1) {
            *aj = prev[j] - k * prev[m - j];
        }
        err *= 1.0 - k * k;
    }
    err
}

/// One-sided paired test that the gains `d` (one per fold) are positive: the p-value of
/// Student's t with `d.len() − 1` degrees of freedom. Folds are contiguous blocks longer than
/// the residual's correlation, so their gains are nearly independent even when the samples are
/// not.
pub fn paired_p_value(d: &[f64]) -> f64 {
    let k = d.len();
    if k < 2 {
        return 1.0;
    }
    let m = mean(d);
    let sd = (d.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (k - 1) as f64).sqrt();
    if sd <= 0.0 {
        return if m > 0.0 { 0.0 } else { 1.0 };
    }
    let t = m / (sd / (k as f64).sqrt());
    // A gain of no size (a fold's error of zero or beyond f64) is no evidence either way; the
    // distribution's code would panic on it.
    if !t.is_finite() {
        return 1.0;
    }
    StudentsT::new(0.0, 1.0, (k - 1) as f64)
        .map(|dist| 1.0 - dist.cdf(t))
        .unwrap_or(1.0)
}

/// One-sided exact Wilcoxon signed-rank test that the gains `d` are positive: the chance that
/// random signs on the ranks of |d| give a positive rank sum at least as large. One fold with a
/// gain far above the others widens Student's t and hides them; it is one rank here. Zero gains
/// are left out, tied ones share their mean rank.
pub fn signed_rank_p_value(d: &[f64]) -> f64 {
    let mut v: Vec<f64> = d
        .iter()
        .copied()
        .filter(|x| *x != 0.0 && x.is_finite())
        .collect();
    if v.is_empty() {
        return 1.0;
    }
    v.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
    // Ranks doubled, so tied (half-integer) ranks stay integers.
    let mut ranks = vec![0usize; v.len()];
    let mut i = 0;
    while i < v.len() {
        let mut j = i;
        while j + 1 < v.len() && v[j + 1].abs() == v[i].abs() {
            j += 1;
        }
        (i..=j).for_each(|k| ranks[k] = i + j + 2);
        i = j + 1;
    }
    let observed: usize = v
        .iter()
        .zip(&ranks)
        .filter(|(x, _)| **x > 0.0)
        .map(|(_, r)| r)
        .sum();
    // Ways each rank sum arises under random signs.
    let total: usize = ranks.iter().sum();
    let mut ways = vec![0f64; total + 1];
    ways[0] = 1.0;
    for &r in &ranks {
        for s in (r..=total).rev() {
            ways[s] += ways[s - r];
        }
    }
    let all: f64 = ways.iter().sum();
    ways[observed..].iter().sum::<f64>() / all
}

/// The line y = a + b·x by weighted least squares; (a, b), `None` if the weights or the x
/// values cannot fix it (fewer than two distinct x).
pub fn weighted_line(x: &[f64], y: &[f64], w: &[f64]) -> Option<(f64, f64)> {
    let (mut sw, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for ((xi, yi), wi) in x.iter().zip(y).zip(w) {
        sw += wi;
        sx += wi * xi;
        sy += wi * yi;
        sxx += wi * xi * xi;
        sxy += wi * xi * yi;
    }
    let det = sw * sxx - sx * sx;
    if det.abs() <= f64::MIN_POSITIVE || sw <= 0.0 {
        return None;
    }
    let b = (sw * sxy - sx * sy) / det;
    let a = (sy - b * sx) / sw;
    (a.is_finite() && b.is_finite()).then_some((a, b))
}

/// The line y = a + b·x by least squares; (a, b), `None` without two distinct x.
pub fn line(x: &[f64], y: &[f64]) -> Option<(f64, f64)> {
    weighted_line(x, y, &vec![1.0; x.len()])
}

/// A line y = a + b·x fitted robustly (Huber weights, ten reweightings): a few wild samples do
/// not tilt it. Returns (a, b).
pub fn robust_line(x: &[f64], y: &[f64]) -> (f64, f64) {
    let mut w = vec![1.0; x.len()];
    let (mut a, mut b) = (0.0, 0.0);
    for _ in 0..10 {
        let Some(fit) = weighted_line(x, y, &w) else {
            break;
        };
        (a, b) = fit;
        let r: Vec<f64> = x.iter().zip(y).map(|(xi, yi)| yi - a - b * xi).collect();
        let abs: Vec<f64> = r.iter().map(|v| v.abs()).collect();
        let scale = 1.4826 * quantile(&abs, 0.5);
        if scale <= 0.0 {
            break;
        }
        let c = 1.345 * scale;
        for (wi, ri) in w.iter_mut().zip(&r) {
            *wi = if ri.abs() <= c { 1.0 } else { c / ri.abs() };
        }
    }
    (a, b)
}

/// Variance of the white noise on `x`, from second differences (a smooth signal has almost
/// none): over windows of `window` samples, mean (Δ²x)²/6, and the 10th percentile of the
/// windows, so the quiet stretches of a record (rest, held loads) set it. That percentile of
/// noise alone lies below its variance (by a fifth for 200-sample windows): it is divided by
/// where it lies, the 10 % quantile of the windows' χ² scatter.
pub fn noise_variance(x: &[f64], window: usize) -> f64 {
    let window = window.max(8);
    let d2: Vec<f64> = x.windows(3).map(|w| w[2] - 2.0 * w[1] + w[0]).collect();
    let per: Vec<f64> = d2
        .chunks(window)
        .filter(|c| c.len() >= window / 2)
        .map(|c| c.iter().map(|v| v * v).sum::<f64>() / c.len() as f64 / 6.0)
        .collect();
    // (Δ²x)² of white noise: mean 6σ², variance 72σ⁴, correlated at lags 1 and 2 by (−4/6)²
    // and (1/6)², so a window's mean has relative variance 2·(1 + 2·17/36)/window; as χ²/ν,
    // ν = window / (1 + 2·17/36).
    let dof = window as f64 / (1.0 + 2.0 * 17.0 / 36.0);
    let low = ChiSquared::new(dof)
        .map(|c| c.inverse_cdf(0.1) / dof)
        .unwrap_or(1.0);
    quantile(&per, 0.1) / low.max(0.1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gains_of_no_size_give_no_evidence_and_no_panic() {
        assert_eq!(paired_p_value(&[1.0, f64::INFINITY, 2.0]), 1.0);
        assert_eq!(paired_p_value(&[1.0, f64::NAN, 2.0]), 1.0);
        // Hand-checked: gains 1, 2, 3 → t = 2/(1/√3) = 3.46 on 2 degrees of freedom, p = 0.037.
        let p = paired_p_value(&[1.0, 2.0, 3.0]);
        assert!((p - 0.0371).abs() < 1e-3, "{p}");
    }

    #[test]
    fn ljung_box_critical_value_is_the_chi_square_quantile() {
        // χ²(20) at 5 % is 31.41 (tables).
        let (q, ratio) = ljung_box(&[0.0; 20], 1000, 20);
        assert_eq!(q, 0.0);
        assert_eq!(ratio, 0.0);
        let (q, ratio) = ljung_box(&[0.1; 20], 1000, 20);
        assert!((q / ratio - 31.41).abs() < 0.01, "{}", q / ratio);
    }

    #[test]
    fn signed_rank_test_counts_sign_patterns() {
        // Six positive gains: one pattern of 2⁶ has every sign positive.
        let p = signed_rank_p_value(&[0.1, 0.2, 0.3, 0.4, 0.5, 3.0]);
        assert!((p - 1.0 / 64.0).abs() < 1e-12, "{p}");
        // Ten gains, the two smallest negative: W+ = 55 − 3 = 52; the rank sums at least that
        // large are the complements of {}, {1}, {2}, {3}, {1, 2}: 5 of 1024.
        let d = [-0.1, -0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 20.0];
        assert!((signed_rank_p_value(&d) - 5.0 / 1024.0).abs() < 1e-12);
        // Student's t on the same gains is held back by the one outsized gain.
        assert!(paired_p_value(&d) > 0.05, "{}", paired_p_value(&d));
        // Ties share a rank, zeros leave: |0.5| twice takes ranks 1.5 and 1.5; W+ = 1.5 + 3 of a
        // total of 6, reached by the patterns {1.5 or 1.5, 3}, {both, 3}: 3 of 8.
        let p = signed_rank_p_value(&[0.5, -0.5, 2.0, 0.0]);
        assert!((p - 3.0 / 8.0).abs() < 1e-12, "{p}");
        assert_eq!(signed_rank_p_value(&[]), 1.0);
    }

    #[test]
    fn noise_variance_is_unbiased_on_white_noise_under_a_slow_signal() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(5);
        let noise = Normal::new(0.0, 0.5).unwrap();
        for window in [50, 200, 1000] {
            let x: Vec<f64> = (0..100_000)
                .map(|i| 20.0 * (i as f64 * 1e-3).sin() + noise.sample(&mut rng))
                .collect();
            // Without the χ² correction the 10th percentile reads 0.81 × 0.25 at 200 samples.
            let v = noise_variance(&x, window);
            assert!((v / 0.25 - 1.0).abs() < 0.05, "window {window}: {v}");
        }
    }

    #[test]
    fn paired_test_matches_students_t() {
        let d = [1.0, 2.0, 3.0, 0.0, 1.0, 2.0, -1.0, 1.0, 0.0, 1.0];
        let m = mean(&d);
        let sd = (d.iter().map(|x| (x - m).powi(2)).sum::<f64>() / 9.0).sqrt();
        let t = m / (sd / 10f64.sqrt());
        // Mean 1, sample variance 12/9: t = 1/(√(4/3)/√10) = 2.7386.
        assert!((t - 2.7386).abs() < 1e-3, "{t}");
        // 9 dof: t(0.99) = 2.821 and t(0.975) = 2.262 (tables), so 0.01 < p < 0.025, near 0.01.
        let p = paired_p_value(&d);
        assert!(p > 0.010 && p < 0.0125, "{p}");
        assert!(paired_p_value(&[-1.0, -2.0, -1.5]) > 0.9);
    }

    #[test]
    fn innovation_share_of_an_ar1_is_one_minus_phi_squared() {
        // AR(1) with φ = 0.8: ρ_k = 0.8^k, innovation variance share 1 − 0.64.
        let acf: Vec<f64> = (1..=20).map(|k| 0.8f64.powi(k)).collect();
        assert!((innovation_share(&acf) - 0.36).abs() < 1e-9);
        assert!((innovation_share(&[0.0; 20]) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn robust_line_ignores_wild_samples() {
        let x: Vec<f64> = (0..200).map(|i| i as f64).collect();
        let mut y: Vec<f64> = x.iter().map(|v| 1.0 + 0.25 * v).collect();
        for i in (0..200).step_by(20) {
            y[i] += 500.0;
        }
        let (a, b) = robust_line(&x, &y);
        assert!((b - 0.25).abs() < 1e-3 && (a - 1.0).abs() < 0.2, "{a} {b}");
    }

    #[test]
    fn noise_variance_of_white_noise_on_a_slow_signal() {
        // Deterministic ±1 noise has variance 1; the slow sine adds almost nothing.
        let x: Vec<f64> = (0..20_000)
            .map(|i| {
                (i as f64 * 1e-3).sin() * 50.0 + if (i * 7 + i / 3) % 2 == 0 { 1.0 } else { -1.0 }
            })
            .collect();
        let v = noise_variance(&x, 200);
        assert!((0.5..2.0).contains(&v), "{v}");
    }
}
