//! What a residual looks like: how far from white, and where it lives (load, time, loading
//! rate, direction, frequency), in numbers and in words.

use serde::Serialize;

use crate::stats;
use crate::terms;

/// Lags of the portmanteau (Ljung–Box) statistic.
pub const PORTMANTEAU_LAGS: usize = 20;

/// The residual tests.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ResidualTests {
    pub rms_pct: f64,
    /// Autocorrelation at lags 1..=50 and its 95 % bound ±1.96/√N.
    pub acf: Vec<f64>,
    pub acf_bound: f64,
    /// Share of those lags outside the bound (about 0.05 for white noise).
    pub acf_outside: f64,
    /// Ljung–Box Q over [`PORTMANTEAU_LAGS`] lags, and Q over its 5 % critical value.
    pub ljung_box: f64,
    pub ljung_box_ratio: f64,
    /// Share of the residual's variance that each explains: the load (10 bins), a smooth
    /// function of time (8 half-cosines), the loading rate (10 bins of the force's rate),
    /// the loading direction at equal load.
    pub load_r2: f64,
    pub time_r2: f64,
    pub rate_r2: f64,
    pub direction_r2: f64,
    /// Strongest spectral line above 0.3 Hz (not a line of the force) and its height over the
    /// local median of the spectrum.
    pub line_hz: f64,
    pub line_ratio: f64,
    /// Share of the residual's power below 0.1 Hz, 0.1–1 Hz, 1–10 Hz and above 10 Hz.
    pub band_shares: [f64; 4],
    /// Share of the residual's power within [`JUMP_SAMPLES`] samples after the force's fastest
    /// one-sample changes (its top tenth), and the share of the samples they are: a force that
    /// moves within a sample (a step at 20 Hz) leaves what no discrete model can place there.
    pub jump_power_share: f64,
    pub jump_sample_share: f64,
}

/// Samples after a fast change of the force that [`ResidualTests::jump_power_share`] counts.
pub const JUMP_SAMPLES: usize = 3;

/// Share of `r`'s power, and of its samples, within [`JUMP_SAMPLES`] samples after the top
/// tenth of `force`'s one-sample changes.
fn after_jumps(r: &[f64], force: &[f64]) -> (f64, f64) {
    let n = r.len().min(force.len());
    if n < 100 {
        return (0.0, 0.0);
    }
    let steps: Vec<f64> = (0..n)
        .map(|k| (force[k] - force[k.saturating_sub(1)]).abs())
        .collect();
    let threshold = stats::quantile(&steps, 0.9);
    let mut near = vec![false; n];
    for (k, d) in steps.iter().enumerate() {
        // A force that holds between jumps has a zero threshold: every move counts.
        if *d > threshold {
            near[k..(k + JUMP_SAMPLES).min(n)].fill(true);
        }
    }
    let total: f64 = r[..n].iter().map(|v| v * v).sum();
    if total <= 0.0 {
        return (0.0, 0.0);
    }
    let power: f64 = (0..n).filter(|k| near[*k]).map(|k| r[k] * r[k]).sum();
    let count = near.iter().filter(|x| **x).count();
    (power / total, count as f64 / n as f64)
}

/// Share of the variance of `r` explained by bin means over `key` (`bins` equal-count bins).
fn binned_r2(r: &[f64], key: &[f64], bins: usize) -> f64 {
    let n = r.len();
    if n < bins * 4 {
        return 0.0;
    }
    // Indices in 32 bits: half the memory, and these sorts run beside the spectra (a record
    // of 2³² samples would not fit in memory as its three series).
    let mut order: Vec<u32> = (0..u32::try_from(n).unwrap_or(u32::MAX)).collect();
    order.sort_by(|a, b| key[*a as usize].total_cmp(&key[*b as usize]));
    let m = stats::mean(r);
    let var: f64 = r.iter().map(|v| (v - m) * (v - m)).sum();
    if var <= 0.0 {
        return 0.0;
    }
    let explained: f64 = order
        .chunks(n.div_ceil(bins))
        .map(|c| {
            let bm = c.iter().map(|&i| r[i as usize]).sum::<f64>() / c.len() as f64;
            c.len() as f64 * (bm - m) * (bm - m)
        })
        .sum();
    // Minus what `bins` means of pure noise explain by chance.
    ((explained / var) - bins as f64 / n as f64).max(0.0)
}

/// Fastest rate the whiteness tests look at, Hz: a 1 kHz residual is averaged over 5 samples
/// first, so 20 lags span the same 0.1 s at any rate and a fast record's sample-to-sample
/// noise does not hide its structure.
pub const WHITENESS_RATE_HZ: f64 = 200.0;

/// `residual` averaged over blocks so its rate is at most [`WHITENESS_RATE_HZ`].
pub fn on_common_scale(residual: &[f64], dt_s: f64) -> Vec<f64> {
    let m = ((1.0 / dt_s) / WHITENESS_RATE_HZ).floor().max(1.0) as usize;
    if m == 1 {
        return residual.to_vec();
    }
    residual
        .chunks_exact(m)
        .map(|c| c.iter().sum::<f64>() / m as f64)
        .collect()
}

/// Runs the tests on `residual` (model − strain) of a record with `force` (the model's input)
/// sampled every `dt_s`; `measured_force` is the force as recorded, whose lines are the
/// excitation's and not the residual's own.
pub fn residual_tests(
    residual: &[f64],
    force: &[f64],
    measured_force: &[f64],
    dt_s: f64,
) -> ResidualTests {
    let common = on_common_scale(residual, dt_s);
    let n = common.len();
    let acf = stats::acf(&common, 50);
    let bound = 1.96 / (n.max(1) as f64).sqrt();
    let outside = acf.iter().filter(|r| r.abs() > bound).count() as f64 / acf.len().max(1) as f64;
    let (q, ratio) = stats::ljung_box(&acf, n, PORTMANTEAU_LAGS);
    // The load's three sorts beside the spectra: each on a core of its own.
    let ((load_r2, rate_r2, direction_r2), (line_hz, line_ratio, band_shares)) =
        std::thread::scope(|scope| {
            let loads = scope.spawn(|| by_load(residual, force, dt_s));
            let spectral = spectral(residual, measured_force, dt_s);
            let loads = loads
                .join()
                .unwrap_or_else(|_| by_load(residual, force, dt_s));
            (loads, spectral)
        });
    let (jump_power_share, jump_sample_share) = after_jumps(residual, measured_force);
    ResidualTests {
        rms_pct: stats::rms(residual),
        acf,
        acf_bound: bound,
        acf_outside: outside,
        ljung_box: q,
        ljung_box_ratio: ratio,
        load_r2,
        time_r2: time_r2(residual),
        rate_r2,
        direction_r2,
        line_hz,
        line_ratio,
        band_shares,
        jump_power_share,
        jump_sample_share,
    }
}

/// Shares of `residual`'s variance the load explains, the loading rate, and the loading
/// direction at equal load (bins of (load, sign of rate) less bins of load alone).
fn by_load(residual: &[f64], force: &[f64], dt_s: f64) -> (f64, f64, f64) {
    let load_r2 = binned_r2(residual, force, 10);
    let w = ((0.05 / dt_s).round() as usize).max(1);
    let mut rate = terms::derivative(&stats::moving_mean(force, 2 * w + 1), dt_s);
    let range = 1e-9 + force.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let signed: Vec<f64> = force
        .iter()
        .zip(&rate)
        .map(|(f, r)| f / range + if *r > 0.0 { 10.0 } else { 0.0 })
        .collect();
    let direction_r2 = (binned_r2(residual, &signed, 20) - load_r2).max(0.0);
    drop(signed);
    rate.iter_mut().for_each(|v| *v = v.abs());
    let rate_r2 = binned_r2(residual, &rate, 10);
    (load_r2, rate_r2, direction_r2)
}

/// A smooth function of time's share: means over 16 contiguous stretches (no sort, no copy).
fn time_r2(residual: &[f64]) -> f64 {
    let m = stats::mean(residual);
    let var: f64 = residual.iter().map(|v| (v - m) * (v - m)).sum();
    let chunk = residual.len().div_ceil(16).max(1);
    let explained: f64 = residual
        .chunks(chunk)
        .map(|c| c.len() as f64 * (stats::mean(c) - m).powi(2))
        .sum();
    if var > 0.0 {
        (explained / var - 16.0 / residual.len().max(1) as f64).max(0.0)
    } else {
        0.0
    }
}

/// The strongest line of `residual` that is not `measured_force`'s (Hz, its height over the
/// local median), and the shares of the residual's power in the four bands.
fn spectral(residual: &[f64], measured_force: &[f64], dt_s: f64) -> (f64, f64, [f64; 4]) {
    let (df, p) = terms::periodogram(residual, dt_s);
    let (_, pf) = terms::periodogram(measured_force, dt_s);
    let lines = terms::lines_in(&p, &pf, df, 0.3, 1.0, 1);
    drop(pf);
    let (line_hz, line_ratio) = lines.first().map_or((0.0, 0.0), |l| (l.hz, l.ratio));
    let mut band_shares = [0.0; 4];
    let total: f64 = p.iter().skip(1).sum::<f64>().max(f64::MIN_POSITIVE);
    for (k, v) in p.iter().enumerate().skip(1) {
        let hz = k as f64 * df;
        let b = if hz < 0.1 {
            0
        } else if hz < 1.0 {
            1
        } else if hz < 10.0 {
            2
        } else {
            3
        };
        band_shares[b] += v / total;
    }
    (line_hz, line_ratio, band_shares)
}

impl ResidualTests {
    /// Where the residual lives, in words with the numbers, strongest first.
    pub fn describe(&self) -> String {
        let mut parts: Vec<(f64, String)> = vec![
            (
                self.load_r2,
                format!("the load explains {:.0} % of it", 100.0 * self.load_r2),
            ),
            (
                self.time_r2,
                format!("a slow function of time {:.0} %", 100.0 * self.time_r2),
            ),
            (
                self.rate_r2,
                format!("the loading rate {:.0} %", 100.0 * self.rate_r2),
            ),
            (
                self.direction_r2,
                format!(
                    "the loading direction at equal load {:.0} %",
                    100.0 * self.direction_r2
                ),
            ),
        ];
        parts.sort_by(|a, b| b.0.total_cmp(&a.0));
        let bands = ["below 0.1 Hz", "0.1–1 Hz", "1–10 Hz", "above 10 Hz"];
        let (bi, bv) = self
            .band_shares
            .iter()
            .enumerate()
            .fold((0, 0.0), |m, (i, v)| if *v > m.1 { (i, *v) } else { m });
        let mut s = parts
            .into_iter()
            .map(|p| p.1)
            .collect::<Vec<_>>()
            .join(", ");
        s.push_str(&format!(
            "; {:.0} % of its power is {}",
            100.0 * bv,
            bands[bi]
        ));
        // Said where it is the residual's larger part and over twice the samples' share.
        if self.jump_power_share > 0.5 && self.jump_power_share > 2.0 * self.jump_sample_share {
            s.push_str(&format!(
                "; {:.0} % of its power lies within {JUMP_SAMPLES} samples after the force's \
                 fastest one-sample changes ({:.0} % of the samples): the force moves within a \
                 sample, or the strain lags it",
                100.0 * self.jump_power_share,
                100.0 * self.jump_sample_share
            ));
        }
        if self.line_ratio > 20.0 {
            s.push_str(&format!(
                "; a line at {:.2} Hz stands {:.0}× over its neighbours",
                self.line_hz, self.line_ratio
            ));
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A staircase of 1 g every 50 samples, and a residual that is 1, ½, ¼ at each jump and
    /// its next two samples, ±0.01 elsewhere: 57 of 1 000 samples hold 19 × 1.3125 of the
    /// power against 943 × 10⁻⁴.
    #[test]
    fn a_residual_after_the_forces_jumps_is_said_to_be_there() {
        let force: Vec<f64> = (0..1000).map(|k| (k / 50) as f64).collect();
        let mut r: Vec<f64> = (0..1000)
            .map(|k| if k % 2 == 0 { 0.01 } else { -0.01 })
            .collect();
        for j in (50..1000).step_by(50) {
            r[j..j + 3].copy_from_slice(&[1.0, 0.5, 0.25]);
        }
        let (power, samples) = after_jumps(&r, &force);
        let expected = 19.0 * 1.3125 / (19.0 * 1.3125 + 943.0 * 1e-4);
        assert!((power - expected).abs() < 1e-12, "{power} {expected}");
        assert!((samples - 0.057).abs() < 1e-12, "{samples}");
        let t = residual_tests(&r, &force, &force, 0.05);
        assert!(
            t.describe()
                .contains("100 % of its power lies within 3 samples after the force's fastest"),
            "{}",
            t.describe()
        );
        // The same residual without its pulses lives nowhere in particular.
        let flat: Vec<f64> = (0..1000)
            .map(|k| if k % 2 == 0 { 0.01 } else { -0.01 })
            .collect();
        let t = residual_tests(&flat, &force, &force, 0.05);
        assert!((t.jump_power_share - 0.057).abs() < 1e-12);
        assert!(!t.describe().contains("lies within"), "{}", t.describe());
    }
}
