//! Regressors: signals built from the force (and time) whose weighted sum models the strain.

use rustfft::{num_complex::Complex, FftPlanner};

/// First-order lowpass 1/(1 + sτ) of `x`, exact for an input that is linear between samples
/// (so a sampled ramp is followed without the half-sample lag of a zero-order hold). Starts at
/// rest at the first sample's value.
pub fn lowpass(x: &[f64], tau_s: f64, dt_s: f64) -> Vec<f64> {
    let (a, b0, b1) = lowpass_coefficients(tau_s, dt_s);
    let mut y = Vec::with_capacity(x.len());
    let (mut prev_x, mut prev_y) = match x.first() {
        Some(&v) => (v, v),
        None => return y,
    };
    for &v in x {
        prev_y = a * prev_y + b0 * v + b1 * prev_x;
        prev_x = v;
        y.push(prev_y);
    }
    y
}

/// Coefficients (a, b₀, b₁) of [`lowpass`]: y[n] = a·y[n−1] + b₀·x[n] + b₁·x[n−1], exact for an
/// input linear between samples.
pub fn lowpass_coefficients(tau_s: f64, dt_s: f64) -> (f64, f64, f64) {
    let h = dt_s / tau_s;
    let a = (-h).exp();
    let g = if h > 1e-6 {
        (1.0 - a) / h
    } else {
        1.0 - h / 2.0
    };
    (a, 1.0 - g, g - a)
}

/// Running integral of `x` (trapezoid), divided by `scale_s` so it stays of the order of `x`.
pub fn integral(x: &[f64], dt_s: f64, scale_s: f64) -> Vec<f64> {
    let mut s = 0.0;
    let mut prev = x.first().copied().unwrap_or(0.0);
    x.iter()
        .map(|&v| {
            s += 0.5 * (v + prev) * dt_s / scale_s;
            prev = v;
            s
        })
        .collect()
}

/// Prandtl–Ishlinskii play operator of radius `r`: the output follows the input only once the
/// input has moved `r` away from it. It starts at the input (the middle of its loop: a sensor
/// never loaded) or, if `settled`, where one pass over the record leaves it (a sensor cycled the
/// same way before the record began).
pub fn play(x: &[f64], r: f64, settled: bool) -> Vec<f64> {
    let step = |y: f64, v: f64| y.clamp(v - r, v + r);
    let first = x.first().copied().unwrap_or(0.0);
    let mut y = if settled {
        x.iter().fold(first, |y, &v| step(y, v))
    } else {
        first
    };
    x.iter()
        .map(|&v| {
            y = step(y, v);
            y
        })
        .collect()
}

/// A Duhem operator of radius `r` (Bouc-Wen with n = 1): dz/dσ = 1 − sign(dσ)·z/r, solved
/// exactly over each sample's monotone step, so z approaches ±r exponentially in the force's
/// travel (scale r) and every movement, back and forth, draws z toward the side it moves to:
/// unlike a play, it forgets under small reversals. Starts at 0.
pub fn duhem(x: &[f64], r: f64) -> Vec<f64> {
    let mut z = 0.0;
    let mut prev = x.first().copied().unwrap_or(0.0);
    x.iter()
        .map(|&v| {
            let d = v - prev;
            prev = v;
            if d != 0.0 {
                let side = r * d.signum();
                z = side + (z - side) * (-d.abs() / r).exp();
            }
            z
        })
        .collect()
}

/// cos(π·k·t/T) over the record (k = 1 is one half-period: a smooth step from one end to the
/// other).
pub fn cosine(n: usize, k: usize) -> Vec<f64> {
    cosine_span(n, k, 0, n)
}

/// cos(π·k·(i + ½)/n) for `len` samples i from `start`: eight lanes, each rotated by eight
/// samples at a time (one rotation a sample is a chain of dependent multiplies).
pub(crate) fn cosine_span(n: usize, k: usize, start: usize, len: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(len);
    Rotation::new(n, k, start).fill(&mut out, len);
    out
}

/// The half-cosine `k` of a record of `n` samples from sample `start` on, as eight lanes
/// rotated eight samples at a time.
pub(crate) struct Rotation {
    /// Each lane's sine and cosine, apart (the eight rotations run side by side).
    sin: [f64; 8],
    cos: [f64; 8],
    sin8: f64,
    cos8: f64,
}

impl Rotation {
    pub(crate) fn new(n: usize, k: usize, start: usize) -> Rotation {
        let step = std::f64::consts::PI * k as f64 / n.max(1) as f64;
        let (sin8, cos8) = (8.0 * step).sin_cos();
        let (mut sin, mut cos) = ([0.0f64; 8], [0.0f64; 8]);
        for j in 0..8 {
            (sin[j], cos[j]) = (step * ((start + j) as f64 + 0.5)).sin_cos();
        }
        Rotation {
            sin,
            cos,
            sin8,
            cos8,
        }
    }

    /// The next `len` values onto `out` (a whole number of eights but at the end: the lanes
    /// move on by eight samples after each group).
    pub(crate) fn fill(&mut self, out: &mut Vec<f64>, len: usize) {
        let start = out.len();
        out.resize(start + len, 0.0);
        // Whole eights copied as eights (a copy of a length known only at run time is a call).
        let mut groups = out[start..].chunks_exact_mut(8);
        for group in &mut groups {
            group.copy_from_slice(&self.cos);
            self.advance();
        }
        let rest = groups.into_remainder();
        if !rest.is_empty() {
            let n = rest.len();
            rest.copy_from_slice(&self.cos[..n]);
            self.advance();
        }
    }

    /// Each lane on by eight samples.
    #[inline(always)]
    fn advance(&mut self) {
        for j in 0..8 {
            let (s, c) = (self.sin[j], self.cos[j]);
            self.sin[j] = s * self.cos8 + c * self.sin8;
            self.cos[j] = c * self.cos8 - s * self.sin8;
        }
    }
}

/// Legendre polynomial of degree `k` over the record, from −1 to 1 (Bonnet's recursion): a gain
/// that changes linearly, bends, or settles.
pub fn legendre(n: usize, k: usize) -> Vec<f64> {
    (0..n).map(|i| legendre_at(n, k, i)).collect()
}

/// Sample `i` of [`legendre`].
pub fn legendre_at(n: usize, k: usize, i: usize) -> f64 {
    let x = 2.0 * (i as f64 + 0.5) / n as f64 - 1.0;
    let (mut below, mut p) = (1.0, x);
    if k == 0 {
        return below;
    }
    for m in 1..k {
        let m = m as f64;
        (below, p) = (p, ((2.0 * m + 1.0) * x * p - m * below) / (m + 1.0));
    }
    p
}

/// sin and cos at `hz`.
pub fn sinusoid(n: usize, dt_s: f64, hz: f64) -> (Vec<f64>, Vec<f64>) {
    let w = 2.0 * std::f64::consts::PI * hz * dt_s;
    (0..n)
        .map(|i| ((w * i as f64).sin(), (w * i as f64).cos()))
        .unzip()
}

/// `x` delayed by `samples` (fractional: linear interpolation), held at its first value.
pub fn delayed(x: &[f64], samples: f64) -> Vec<f64> {
    let whole = samples.floor() as usize;
    let frac = samples - whole as f64;
    let first = x.first().copied().unwrap_or(0.0);
    (0..x.len())
        .map(|i| {
            let a = if i >= whole { x[i - whole] } else { first };
            let b = if i > whole { x[i - whole - 1] } else { first };
            a * (1.0 - frac) + b * frac
        })
        .collect()
}

/// `x` smoothed without phase by a Wiener filter built from its own spectrum: each frequency
/// kept in the share of its power that stands above white noise of variance `noise_var`. Returns
/// the smoothed signal and the share of the noise's variance that passes (the filter's mean
/// gain). The record is mirrored so its ends do not wrap into each other.
pub fn wiener(x: &[f64], noise_var: f64) -> (Vec<f64>, f64) {
    let n = x.len();
    if n < 16 || noise_var.is_nan() || noise_var <= 0.0 {
        return (x.to_vec(), 1.0);
    }
    let m = crate::stats::mean(x);
    let mut buf: Vec<Complex<f64>> = x
        .iter()
        .chain(x.iter().rev())
        .map(|v| Complex::new(v - m, 0.0))
        .collect();
    let len = buf.len();
    let mut planner = FftPlanner::new();
    planner.plan_fft_forward(len).process(&mut buf);
    // One bin's power is χ²(2)-scattered: averaged over neighbours before it gates.
    let power: Vec<f64> = buf.iter().map(|c| c.norm_sqr() / len as f64).collect();
    let smooth = crate::stats::moving_mean(&power, (len / 2000).max(16) | 1);
    let mut passed = 0.0;
    for (c, p) in buf.iter_mut().zip(&smooth) {
        // Where noise alone scatters above its level, a little of it passes: a harder gate
        // drops signal the floor would then have to count (tried: 207 of 238 against 225).
        let gain = (1.0 - noise_var / p.max(f64::MIN_POSITIVE)).max(0.0);
        passed += gain;
        *c *= gain / len as f64;
    }
    planner.plan_fft_inverse(len).process(&mut buf);
    (
        buf[..n].iter().map(|c| c.re + m).collect(),
        passed / len as f64,
    )
}

/// `x` smoothed without phase by a short-time Wiener filter: frames of `frame` samples (rounded
/// up to a power of two, at least 16; half-overlapped root-Hann windows whose squares add back
/// to one), each frequency of each frame
/// kept in the share of its power that stands above white noise of variance `noise_var`, the
/// power averaged over neighbouring bins and frames. A quiet stretch of the record is smoothed
/// hard, a fast ramp's corners are kept: one filter for the whole record would pass the noise
/// of every quiet stretch at the frequencies its ramps need. Returns the smoothed signal and the
/// share of the noise's variance that passes (the filter's mean gain).
pub fn wiener_local(x: &[f64], noise_var: f64, frame: usize) -> (Vec<f64>, f64) {
    let n = x.len();
    let w = frame.next_power_of_two().max(16);
    if n < 2 * w || noise_var.is_nan() || noise_var <= 0.0 {
        return wiener(x, noise_var);
    }
    let m = crate::stats::mean(x);
    // The record mirrored a frame's length at each end, so its ends are covered like its middle.
    let padded: Vec<f64> = x[1..=w]
        .iter()
        .rev()
        .chain(x)
        .chain(x[n - 1 - w..n - 1].iter().rev())
        .map(|v| v - m)
        .collect();
    let hop = w / 2;
    let frames = (padded.len() - w) / hop + 1;
    let window: Vec<f64> = (0..w)
        .map(|i| (std::f64::consts::PI * i as f64 / w as f64).sin())
        .collect();
    let mut planner = FftPlanner::new();
    let (fwd, inv) = (planner.plan_fft_forward(w), planner.plan_fft_inverse(w));
    // Each frame's own line is kept whole and only what is left around it is filtered: the
    // window's leakage of a level or a ramp would otherwise spread over the low bins, which
    // the gate then shrinks by amounts that change from frame to frame (a slow error).
    let centre = (w as f64 - 1.0) / 2.0;
    let sxx: f64 = (0..w).map(|i| (i as f64 - centre).powi(2)).sum();
    let lines: Vec<(f64, f64)> = (0..frames)
        .map(|k| {
            let seg = &padded[k * hop..k * hop + w];
            let a = crate::stats::mean(seg);
            let b = seg
                .iter()
                .enumerate()
                .map(|(i, v)| (i as f64 - centre) * v)
                .sum::<f64>()
                / sxx;
            (a, b)
        })
        .collect();
    let spectra: Vec<Vec<Complex<f64>>> = (0..frames)
        .map(|k| {
            let (a, b) = lines[k];
            let mut buf: Vec<Complex<f64>> = (0..w)
                .map(|i| {
                    let line = a + b * (i as f64 - centre);
                    Complex::new((padded[k * hop + i] - line) * window[i], 0.0)
                })
                .collect();
            fwd.process(&mut buf);
            buf
        })
        .collect();
    // White noise of variance σ² has expected power σ²·Σw² = σ²·w/2 in every bin.
    let noise_power = noise_var * w as f64 / 2.0;
    let power: Vec<Vec<f64>> = spectra
        .iter()
        .map(|b| crate::stats::moving_mean(&b.iter().map(|c| c.norm_sqr()).collect::<Vec<_>>(), 7))
        .collect();
    let mut out = vec![0.0; padded.len()];
    let (mut passed, mut bins) = (0.0, 0usize);
    for (k, mut buf) in spectra.into_iter().enumerate() {
        let near = &power[k.saturating_sub(1)..(k + 2).min(frames)];
        for (j, c) in buf.iter_mut().enumerate() {
            let p = near.iter().map(|row| row[j]).sum::<f64>() / near.len() as f64;
            let gain = (1.0 - noise_power / p.max(f64::MIN_POSITIVE)).max(0.0);
            passed += gain;
            bins += 1;
            *c *= gain / w as f64;
        }
        inv.process(&mut buf);
        let (a, b) = lines[k];
        for i in 0..w {
            let line = a + b * (i as f64 - centre);
            out[k * hop + i] += (buf[i].re + line * window[i]) * window[i];
        }
    }
    (
        out[w..w + n].iter().map(|v| v + m).collect(),
        passed / bins.max(1) as f64,
    )
}

/// Time derivative by central differences (one-sided at the ends).
pub fn derivative(x: &[f64], dt_s: f64) -> Vec<f64> {
    let n = x.len();
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n.saturating_sub(1)));
            if b > a {
                (x[b] - x[a]) / ((b - a) as f64 * dt_s)
            } else {
                0.0
            }
        })
        .collect()
}

/// Periodogram with a Hann window: (bin width in Hz, power per bin up to Nyquist).
pub fn periodogram(x: &[f64], dt_s: f64) -> (f64, Vec<f64>) {
    let n = x.len();
    if n < 16 {
        return (0.0, Vec::new());
    }
    let m = crate::stats::mean(x);
    let mut buf: Vec<Complex<f64>> = x
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let w = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / (n - 1) as f64).cos();
            Complex::new((v - m) * w, 0.0)
        })
        .collect();
    FftPlanner::new().plan_fft_forward(n).process(&mut buf);
    (
        1.0 / (n as f64 * dt_s),
        buf[..n / 2].iter().map(|c| c.norm_sqr()).collect(),
    )
}

/// The spectrum's local background: the median of blocks of bins (a line does not move a
/// median), each bin taking its block's.
fn background(p: &[f64]) -> Vec<f64> {
    let w = (p.len() / 200).clamp(16, 400);
    let mut out = vec![0.0; p.len()];
    for (block, chunk) in out.chunks_mut(w).enumerate() {
        let a = (block * w).saturating_sub(w / 2);
        let b = ((block + 1) * w + w / 2).min(p.len());
        let m = crate::stats::quantile(&p[a..b], 0.5).max(f64::MIN_POSITIVE);
        chunk.iter_mut().for_each(|v| *v = m);
    }
    out
}

/// A spectral line of a residual: frequency, and its height over the local background.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    pub hz: f64,
    pub ratio: f64,
}

/// Lines of `residual` above `min_hz` that stand `min_ratio` times over the local median of
/// the residual's spectrum and are not lines of the force (the excitation's own frequencies
/// show in a wrong model's residual; interference is what the force does not carry). At most
/// `max` lines, strongest first, frequency refined between bins.
pub fn lines(
    residual: &[f64],
    force: &[f64],
    dt_s: f64,
    min_hz: f64,
    min_ratio: f64,
    max: usize,
) -> Vec<Line> {
    let (df, p) = periodogram(residual, dt_s);
    let (_, pf) = periodogram(force, dt_s);
    lines_in(&p, &pf, df, min_hz, min_ratio, max)
}

/// [`lines`] from the two periodograms (bin width `df`).
pub fn lines_in(
    p: &[f64],
    pf: &[f64],
    df: f64,
    min_hz: f64,
    min_ratio: f64,
    max: usize,
) -> Vec<Line> {
    if p.len() < 32 || df <= 0.0 || pf.len() != p.len() {
        return Vec::new();
    }
    let first = ((min_hz / df).ceil() as usize).max(2);
    let last = p.len().saturating_sub(2);
    let (bg, bgf) = (background(p), background(pf));
    let mut found: Vec<(usize, f64)> = Vec::new();
    for k in first..last {
        if p[k] < p[k - 1] || p[k] < p[k + 1] {
            continue;
        }
        let ratio = p[k] / bg[k];
        if ratio < min_ratio {
            continue;
        }
        // The force has a line within two bins: an excitation frequency, not interference.
        let force_line =
            (k.saturating_sub(2)..=(k + 2).min(pf.len() - 1)).any(|j| pf[j] / bgf[j] > 20.0);
        if !force_line {
            found.push((k, ratio));
        }
    }
    found.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut out: Vec<Line> = Vec::new();
    for (k, ratio) in found {
        if out.len() >= max {
            break;
        }
        // Parabolic interpolation of the log power over three bins.
        let (a, b, c) = (p[k - 1].ln(), p[k].ln(), p[k + 1].ln());
        let denom = a - 2.0 * b + c;
        let shift = if denom.abs() > 1e-12 {
            (0.5 * (a - c) / denom).clamp(-0.5, 0.5)
        } else {
            0.0
        };
        let hz = (k as f64 + shift) * df;
        if out.iter().all(|l| (l.hz - hz).abs() > 5.0 * df) {
            out.push(Line { hz, ratio });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legendre_polynomials_are_the_closed_forms() {
        // P1 = x, P2 = (3x² − 1)/2, P3 = (5x³ − 3x)/2 at the sample centres of 4 samples:
        // x = −0.75, −0.25, 0.25, 0.75.
        let x = [-0.75, -0.25, 0.25, 0.75];
        for (k, f) in [
            (1, (|x: f64| x) as fn(f64) -> f64),
            (2, |x: f64| (3.0 * x * x - 1.0) / 2.0),
            (3, |x: f64| (5.0 * x * x * x - 3.0 * x) / 2.0),
        ] {
            let p = legendre(4, k);
            for (p, x) in p.iter().zip(x) {
                assert!((p - f(x)).abs() < 1e-15, "P{k}({x}) = {p}");
            }
        }
        // P3(0.75) by hand: (5·0.421875 − 2.25)/2 = −0.0703125.
        assert_eq!(legendre(4, 3)[3], -0.0703125);
    }

    #[test]
    fn cosine_by_rotation_is_the_cosine() {
        // A 20 min record at 1 kHz: the rotation's rounding stays far below f32's.
        let n = 1_200_000;
        for k in [1, 7, 16] {
            let v = cosine(n, k);
            for i in (0..n).step_by(997).chain([n - 1]) {
                let exact = (std::f64::consts::PI * k as f64 * (i as f64 + 0.5) / n as f64).cos();
                assert!(
                    (v[i] - exact).abs() < 1e-9,
                    "k {k}, {i}: {} vs {exact}",
                    v[i]
                );
            }
        }
    }

    #[test]
    fn wiener_takes_the_noise_off_a_slow_sine_without_a_lag() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        // 60 s at 200 Hz of a 0.5 Hz sine (amplitude 10) under white noise of variance 1.
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(7);
        let noise = Normal::new(0.0, 1.0).unwrap();
        let dt = 0.005;
        let clean: Vec<f64> = (0..12_000)
            .map(|i| 10.0 * (std::f64::consts::TAU * 0.5 * i as f64 * dt).sin())
            .collect();
        let noisy: Vec<f64> = clean.iter().map(|c| c + noise.sample(&mut rng)).collect();
        let (smooth, passed) = wiener(&noisy, 1.0);
        let err: f64 = smooth
            .iter()
            .zip(&clean)
            .map(|(s, c)| (s - c).powi(2))
            .sum();
        let rms = (err / clean.len() as f64).sqrt();
        // The sine's bins pass, those its mirrored end leaks into, and a little of the bins where
        // noise alone scatters above its level: about a tenth of the noise's variance.
        assert!(passed < 0.15, "{passed}");
        assert!(rms < 0.35, "{rms}");
        // No lag: the phase against the clean sine, where one sample is 2π·0.5·0.005 = 0.016 rad.
        let (mut ps, mut pc) = (0.0, 0.0);
        for (i, v) in smooth.iter().enumerate() {
            let w = std::f64::consts::TAU * 0.5 * i as f64 * dt;
            ps += v * w.sin();
            pc += v * w.cos();
        }
        let phase = pc.atan2(ps);
        assert!(phase.abs() < 0.003, "{phase}");
        // And not shrunk: amplitude 2·⟨x, sin⟩/n.
        let amplitude = 2.0 * (ps * ps + pc * pc).sqrt() / clean.len() as f64;
        assert!((amplitude - 10.0).abs() < 0.1, "{amplitude}");
        // No noise: the signal back as it was.
        assert_eq!(wiener(&clean, 0.0), (clean.clone(), 1.0));
    }

    #[test]
    fn short_time_wiener_flattens_holds_and_keeps_ramps() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        // 120 s at 200 Hz: holds of 10 s at 0, 40, 10, 70 … g joined by 0.2 s ramps (200 g/s),
        // under white noise of variance 0.04 (0.2 g, the synthetic records' order).
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(3);
        let noise = Normal::new(0.0, 0.2).unwrap();
        let dt = 0.005;
        let levels = [0.0, 40.0, 10.0, 70.0, 30.0, 50.0];
        let at = |t: f64| {
            let k = (t / 10.0) as usize;
            let (a, b) = (levels[k % 6], levels[(k + 1) % 6]);
            let into = t - 10.0 * k as f64;
            if into < 9.8 {
                a
            } else {
                a + (b - a) * (into - 9.8) / 0.2
            }
        };
        let clean: Vec<f64> = (0..24_000).map(|i| at(i as f64 * dt)).collect();
        let noisy: Vec<f64> = clean.iter().map(|c| c + noise.sample(&mut rng)).collect();
        let rms = |x: &[f64], range: std::ops::Range<usize>| {
            (range
                .clone()
                .map(|i| (x[i] - clean[i]).powi(2))
                .sum::<f64>()
                / range.len() as f64)
                .sqrt()
        };
        let (local, passed) = wiener_local(&noisy, 0.04, 200);
        let (whole, _) = wiener(&noisy, 0.04);
        // Inside a hold (3 to 7 s into it) the noise is down to under a fifth.
        let hold = 2_600..3_400;
        assert!(
            rms(&local, hold.clone()) < 0.04,
            "{}",
            rms(&local, hold.clone())
        );
        // One filter for the whole record passes there the noise the ramps' band lets through
        // (0.075 g against 0.033 g when written).
        assert!(rms(&whole, hold.clone()) > 1.8 * rms(&local, hold.clone()));
        // Across a ramp and its corners (9.5 to 10.5 s), no worse than the noise itself.
        let ramp = 3_900..4_100;
        assert!(
            rms(&local, ramp.clone()) < 0.15,
            "{}",
            rms(&local, ramp.clone())
        );
        assert!(passed < 0.2, "{passed}");
        // Levels and ramps pass whole: no noise, no change.
        let (same, _) = wiener_local(&clean, 1e-12, 200);
        assert!(
            rms(&same, 0..clean.len()) < 1e-6,
            "{}",
            rms(&same, 0..clean.len())
        );
    }

    #[test]
    fn lowpass_step_follows_the_exponential() {
        // A step at t = 0 from 0 to 1: y(t) = 1 − e^{−t/τ}; the first sample sees the ramp over
        // one period, so compare from the second on against the exact response to that ramp.
        let dt = 0.01;
        let tau = 0.5;
        let mut x = vec![0.0; 1];
        x.extend(vec![1.0; 500]);
        let y = lowpass(&x, tau, dt);
        for (i, v) in y.iter().enumerate().skip(1) {
            let t = i as f64 * dt;
            // Response to a ramp 0→1 over [0, dt], then constant:
            // 1 − (τ/dt)(1 − e^{−dt/τ})·e^{−(t − dt)/τ}.
            let exact = 1.0 - tau / dt * (1.0 - (-dt / tau).exp()) * (-(t - dt) / tau).exp();
            assert!((v - exact).abs() < 1e-9, "{i}: {v} vs {exact}");
        }
    }

    #[test]
    fn duhem_operator_hand_sequence() {
        // r = 1: a rise of 1 from 0 reaches 1 − e⁻¹; a fall of 1 from there, −1 + (2 − e⁻¹)·e⁻¹.
        let z = duhem(&[0.0, 1.0, 0.0, 0.0], 1.0);
        let e = (-1.0f64).exp();
        assert_eq!(z[0], 0.0);
        assert!((z[1] - (1.0 - e)).abs() < 1e-15);
        assert!((z[2] - (-1.0 + (2.0 - e) * e)).abs() < 1e-15);
        assert_eq!(z[3], z[2]);
        // Small steps sum to the exact solution of one large one: 1 − e⁻²  after a travel of 2.
        let x: Vec<f64> = (0..=2000).map(|i| i as f64 * 1e-3).collect();
        assert!((duhem(&x, 1.0)[2000] - (1.0 - (-2.0f64).exp())).abs() < 1e-12);
    }

    #[test]
    fn play_operator_hand_sequence() {
        let x = [0.0, 1.0, 3.0, 2.5, 1.0, 0.0];
        assert_eq!(play(&x, 1.0, false), vec![0.0, 0.0, 2.0, 2.0, 2.0, 1.0]);
        // Settled: one pass ends at 1, so the second starts there.
        assert_eq!(play(&x, 1.0, true), vec![1.0, 1.0, 2.0, 2.0, 2.0, 1.0]);
    }

    #[test]
    fn a_line_is_found_at_its_frequency_and_force_lines_are_not() {
        let dt = 0.005;
        let n = 40_000;
        let force: Vec<f64> = (0..n)
            .map(|i| (i as f64 * dt * 2.0 * std::f64::consts::PI * 1.9).sin())
            .collect();
        let residual: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64 * dt;
                0.1 * (2.0 * std::f64::consts::PI * 7.3 * t).sin()
                    + 0.2 * (2.0 * std::f64::consts::PI * 1.9 * t).sin()
                    + 0.01 * (((i * 7919) % 97) as f64 / 97.0 - 0.5)
            })
            .collect();
        let l = lines(&residual, &force, dt, 0.3, 20.0, 3);
        assert!((l[0].hz - 7.3).abs() < 0.005, "{l:?}");
        // The 1.9 Hz line is the force's own: an excitation, not interference.
        assert!(l.iter().all(|x| (x.hz - 1.9).abs() > 0.1), "{l:?}");
    }
}
