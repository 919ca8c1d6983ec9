//! From residual to effect: fit the baseline, test its residual, try each candidate effect as an
//! augmentation of the baseline, keep those that lower the held-out error by a clear margin and
//! leave the residual closer to white, and say what was found.

use std::fmt::Write as _;

use rustfft::{num_complex::Complex, FftPlanner};
use serde::Serialize;
use tactile_core::viscoelastic::Discrete2State;

use crate::fit::{fit, lag_correlation, Augment, Base, Fit, ModelSpec, Series};

/// An effect is accepted when it lowers the held-out RMS by at least this fraction...
pub const ACCEPT_RELATIVE: f64 = 0.10;
/// ...and by at least this much strain (%), so noise-level gains never count.
pub const ACCEPT_ABSOLUTE_PCT: f64 = 0.002;
/// Lags of the portmanteau (Ljung–Box) statistic.
pub const PORTMANTEAU_LAGS: usize = 20;

/// What the residual tests saw.
#[derive(Clone, Debug, Serialize)]
pub struct ResidualTests {
    pub rms_pct: f64,
    /// Autocorrelation at lags 1..=50 samples and its 95 % bound ±1.96/√N.
    pub acf: Vec<f64>,
    pub acf_bound: f64,
    /// Fraction of those lags outside the bound (about 0.05 for white noise).
    pub acf_outside: f64,
    /// Ljung–Box Q over the first [`PORTMANTEAU_LAGS`] lags, and Q divided by its 5 % critical
    /// value (≈ 31.4 for 20 lags): above 1 the residual is not white at that level.
    pub ljung_box: f64,
    pub ljung_box_ratio: f64,
    /// Lag (s) of the largest cross-correlation of the residual with the force's rate of change
    /// (positive: the strain lags the model), and that correlation.
    pub xcorr_peak_lag_s: f64,
    pub xcorr_peak: f64,
    /// Share of the residual variance explained by the load level (10 bins).
    pub load_r2: f64,
    /// Mean residual while loading minus while unloading, at equal load (% strain), and the
    /// share of variance that split explains.
    pub direction_gap_pct: f64,
    pub direction_r2: f64,
    /// Strongest spectral line above 0.3 Hz: frequency and its height over the median.
    pub spectral_peak_hz: f64,
    pub spectral_peak_ratio: f64,
    /// Share of the residual variance explained by a quadratic in time.
    pub trend_r2: f64,
}

/// Runs the residual tests on `residual` (prediction − strain) of `data`.
pub fn residual_tests(residual: &[f64], data: &Series) -> ResidualTests {
    let n = residual.len().max(1);
    let rms = (residual.iter().map(|r| r * r).sum::<f64>() / n as f64).sqrt();
    let acf: Vec<f64> = (1..=50).map(|k| lag_correlation(residual, k)).collect();
    let bound = 1.96 / (n as f64).sqrt();
    let outside = acf.iter().filter(|r| r.abs() > bound).count() as f64 / acf.len() as f64;
    let q = n as f64
        * (n as f64 + 2.0)
        * acf
            .iter()
            .take(PORTMANTEAU_LAGS)
            .enumerate()
            .map(|(i, r)| r * r / (n - i - 1) as f64)
            .sum::<f64>();
    // χ²(20) at 5 %.
    let q_ratio = q / 31.41;

    // Cross-correlation with the force's rate of change, ±0.5 s.
    let rate: Vec<f64> = data
        .force
        .windows(2)
        .map(|w| w[1] - w[0])
        .chain(std::iter::once(0.0))
        .collect();
    let max_lag = (0.5 / data.dt_s) as i64;
    let (mut peak_lag, mut peak) = (0i64, 0.0f64);
    let norm = (residual.iter().map(|r| r * r).sum::<f64>()
        * rate.iter().map(|r| r * r).sum::<f64>())
    .sqrt();
    if norm > 0.0 {
        for lag in -max_lag..=max_lag {
            let mut s = 0.0;
            for (i, r) in residual.iter().enumerate() {
                let j = i as i64 - lag;
                if j >= 0 && (j as usize) < rate.len() {
                    s += r * rate[j as usize];
                }
            }
            let c = s / norm;
            if c.abs() > peak.abs() {
                peak = c;
                peak_lag = lag;
            }
        }
    }

    // Residual against load and against the direction of loading.
    let (lo, hi) = data
        .force
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), f| (a.min(*f), b.max(*f)));
    let bins = 10usize;
    let bin_of = |f: f64| {
        (((f - lo) / (hi - lo).max(1e-9)) * bins as f64).clamp(0.0, bins as f64 - 1.0) as usize
    };
    let mean_r = residual.iter().sum::<f64>() / n as f64;
    let var_r = residual
        .iter()
        .map(|r| (r - mean_r).powi(2))
        .sum::<f64>()
        .max(1e-300);
    let mut sums = vec![(0.0, 0usize); bins];
    for (r, f) in residual.iter().zip(&data.force) {
        let b = &mut sums[bin_of(*f)];
        b.0 += r;
        b.1 += 1;
    }
    let explained: f64 = sums
        .iter()
        .filter(|b| b.1 > 0)
        .map(|b| b.1 as f64 * (b.0 / b.1 as f64 - mean_r).powi(2))
        .sum();
    let load_r2 = explained / var_r;
    // Direction: smoothed rate over 50 ms.
    let w = (0.05 / data.dt_s).round().max(1.0) as usize;
    let mut dir_sums = vec![[(0.0, 0usize); 2]; bins];
    for i in w..data.force.len().saturating_sub(w) {
        let d = data.force[i + w] - data.force[i - w];
        if d.abs() < 0.5 {
            continue;
        }
        let k = usize::from(d > 0.0);
        let b = &mut dir_sums[bin_of(data.force[i])][k];
        b.0 += residual[i]
            - sums[bin_of(data.force[i])].0 / sums[bin_of(data.force[i])].1.max(1) as f64;
        b.1 += 1;
    }
    let (mut gap, mut weight, mut dir_explained) = (0.0, 0.0, 0.0);
    for b in &dir_sums {
        let [down, up] = *b;
        if down.1 > 10 && up.1 > 10 {
            let (m_down, m_up) = (down.0 / down.1 as f64, up.0 / up.1 as f64);
            let nn = (down.1 + up.1) as f64;
            gap += (m_up - m_down) * nn;
            weight += nn;
            dir_explained += down.1 as f64 * m_down * m_down + up.1 as f64 * m_up * m_up;
        }
    }
    let direction_gap = if weight > 0.0 { gap / weight } else { 0.0 };

    // Spectrum.
    let (peak_hz, peak_ratio) = spectral_peak(residual, data.dt_s, 0.3);

    // Slow trend: least squares on [1, x, x²].
    let trend_r2 = {
        let xs: Vec<f64> = (0..n).map(|i| i as f64 / n as f64).collect();
        let fitted = quadratic_fit(&xs, residual);
        let ss: f64 = fitted.iter().map(|f| (f - mean_r).powi(2)).sum();
        ss / var_r
    };

    ResidualTests {
        rms_pct: rms,
        acf,
        acf_bound: bound,
        acf_outside: outside,
        ljung_box: q,
        ljung_box_ratio: q_ratio,
        xcorr_peak_lag_s: peak_lag as f64 * data.dt_s,
        xcorr_peak: peak,
        load_r2,
        direction_gap_pct: direction_gap,
        direction_r2: dir_explained / var_r,
        spectral_peak_hz: peak_hz,
        spectral_peak_ratio: peak_ratio,
        trend_r2,
    }
}

/// Frequency and height-over-median of the strongest line above `min_hz`.
pub fn spectral_peak(x: &[f64], dt: f64, min_hz: f64) -> (f64, f64) {
    let n = x.len();
    if n < 16 {
        return (0.0, 0.0);
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let mut buf: Vec<Complex<f64>> = x
        .iter()
        .enumerate()
        .map(|(i, v)| {
            // Hann window against leakage from the slow parts.
            let w = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / (n - 1) as f64).cos();
            Complex::new((v - mean) * w, 0.0)
        })
        .collect();
    FftPlanner::new().plan_fft_forward(n).process(&mut buf);
    let df = 1.0 / (n as f64 * dt);
    let first = (min_hz / df).ceil() as usize;
    let power: Vec<f64> = buf[..n / 2].iter().map(|c| c.norm_sqr()).collect();
    let band = &power[first.min(power.len())..];
    if band.is_empty() {
        return (0.0, 0.0);
    }
    let mut sorted = band.to_vec();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2].max(1e-300);
    let (k, p) = band
        .iter()
        .enumerate()
        .fold((0, 0.0), |b, (k, p)| if *p > b.1 { (k, *p) } else { b });
    ((first + k) as f64 * df, p / median)
}

fn quadratic_fit(x: &[f64], y: &[f64]) -> Vec<f64> {
    let a = nalgebra::DMatrix::from_fn(x.len(), 3, |i, j| x[i].powi(j as i32));
    let b = nalgebra::DVector::from_column_slice(y);
    match a.clone().svd(true, true).solve(&b, 1e-12) {
        Ok(c) => (&a * c).iter().copied().collect(),
        Err(_) => vec![0.0; x.len()],
    }
}

/// One candidate's outcome.
#[derive(Clone, Debug, Serialize)]
pub struct Candidate {
    pub effect: String,
    pub round: usize,
    pub held_out_rms_g: f64,
    pub fit_rms_g: f64,
    pub ljung_box_ratio: f64,
    pub accepted: bool,
    /// What the residual tests said for this effect, before it was tried (higher = more
    /// suspected); candidates are tried in this order.
    pub evidence: f64,
}

/// The before/after pair of the JSON.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Errors {
    pub fit_rms_g: f64,
    pub held_out_rms_g: f64,
}

/// Force estimated from strain by the on-chip inverse, before and after the accepted effects.
#[derive(Clone, Debug, Serialize)]
pub struct ForceEstimate {
    pub before_rms_g: f64,
    pub after_rms_g: f64,
    /// What the firmware's estimator takes from the accepted model.
    pub estimator_config: serde_json::Value,
}

/// The diagnosis.
#[derive(Clone, Debug, Serialize)]
pub struct Diagnosis {
    pub effect: String,
    pub effects: Vec<String>,
    pub before: Errors,
    pub after: Errors,
    pub candidates: Vec<Candidate>,
    pub baseline_model: String,
    pub held_out: String,
    pub residual_before: ResidualTests,
    pub residual_after: ResidualTests,
    pub force_estimate: ForceEstimate,
    pub summary: String,
    #[serde(skip)]
    pub baseline_fit: Option<Fit>,
    #[serde(skip)]
    pub final_fit: Option<Fit>,
}

fn residual_of(fit: &Fit, data: &Series) -> Vec<f64> {
    // Samples at the converter's rail carry no residual (they say nothing about the model).
    fit.model
        .simulate(&fit.theta, data)
        .map(|p| {
            p.iter()
                .zip(&data.strain)
                .zip(&data.excluded)
                .map(|((a, b), x)| if *x { 0.0 } else { a - b })
                .collect()
        })
        .unwrap_or_default()
}

/// How strongly the tests point at each effect (used to order the candidates and to explain).
fn evidence(t: &ResidualTests, aug: &Augment) -> f64 {
    match aug {
        Augment::LoadDependentStiffness => t.load_r2,
        Augment::Hysteresis => t.direction_r2,
        Augment::BaselineDrift => t.trend_r2,
        Augment::PeriodicInterference { .. } => (t.spectral_peak_ratio / 1000.0).min(1.0),
        Augment::TimeDelay => t.xcorr_peak.abs(),
        Augment::SlowRelaxation => t.acf.get(49).copied().unwrap_or(0.0).max(0.0),
    }
}

/// A candidate effect, its evidence, and its refit with the residual tests (if it converged).
type CandidateFit = (Augment, f64, Option<(Fit, ResidualTests)>);

/// Diagnoses a record already split into fit and held-out parts.
pub fn diagnose(data: &Series) -> Option<Diagnosis> {
    // Baseline: the modified Maxwell–Kelvin model (eq. 14); the general second-order model only
    // when that fit fails. Its G₁ is physical, so it is the one that turns strain into grams.
    let baseline = match fit(&ModelSpec::new(Base::MkAlpha), data, &[]) {
        Some(f) => f,
        None => fit(&ModelSpec::new(Base::SecondOrder), data, &[])?,
    };
    // RMS_n (eq. 12b) of every model is normalized by the baseline's G₁, so the grams compare:
    // an augmentation such as the load nonlinearity rescales its own G₁.
    let g1 = baseline.g1;
    let mut current = baseline.clone();
    let mut current_tests = residual_tests(&residual_of(&current, data), data);
    let before_tests = current_tests.clone();
    let mut accepted: Vec<String> = Vec::new();
    let mut candidates = Vec::new();
    for round in 1..=3 {
        let mut tries: Vec<(Augment, f64)> = [
            Augment::LoadDependentStiffness,
            Augment::Hysteresis,
            Augment::BaselineDrift,
            Augment::PeriodicInterference {
                hz: current_tests.spectral_peak_hz.max(0.3),
            },
            Augment::TimeDelay,
            Augment::SlowRelaxation,
        ]
        .into_iter()
        .filter(|a| !accepted.iter().any(|e| e == a.name()))
        .map(|a| {
            let e = evidence(&current_tests, &a);
            (a, e)
        })
        .collect();
        tries.sort_by(|a, b| b.1.total_cmp(&a.1));
        // Fit the candidates on every core; each is a warm start from the current optimum with
        // the new effect at its neutral value.
        let fits: Vec<CandidateFit> = std::thread::scope(|scope| {
            let handles: Vec<_> = tries
                .iter()
                .map(|&(aug, ev)| {
                    let current = &current;
                    scope.spawn(move || {
                        let spec = current.model.with(aug);
                        let mut start = spec.starts(data).into_iter().next().unwrap_or_default();
                        if start.len() >= current.theta.len() {
                            start[..current.theta.len()].copy_from_slice(&current.theta);
                        }
                        // A delay is a poor target for a local search from one guess (the error
                        // has a minimum per step the force takes): also start from 2, 10, 30 and
                        // 100 ms, and from the lag where the residual meets the force rate.
                        let mut starts = vec![start.clone()];
                        if aug == Augment::TimeDelay {
                            // A large delay also spoils the baseline the warm start comes from:
                            // start from the model's own starts too.
                            let lag = current_tests.xcorr_peak_lag_s;
                            let fresh = spec.starts(data);
                            for base in std::iter::once(&start).chain(fresh.iter()) {
                                for d in [0.002, 0.03, 0.1, lag] {
                                    if d > 0.0 {
                                        let mut p = spec.physical(base);
                                        if let Some(last) = p.last_mut() {
                                            *last = d;
                                        }
                                        starts.push(spec.internal(&p));
                                    }
                                }
                            }
                        }
                        let mut outcome = crate::fit::fit_from(&spec, data, &starts);
                        // Stiffening has a second form: eq. 14 with its own load-dependent
                        // springs (G₁ = a + b√σ, G₂ = c + dσ, the memo's Table I), which a
                        // common scale on the load cannot mimic when the two springs stiffen
                        // differently. The better held-out error of the two stands for it.
                        if aug == Augment::LoadDependentStiffness
                            && current.model.base == Base::MkAlpha
                        {
                            let springs = ModelSpec {
                                base: Base::MkNonlinear,
                                augments: current.model.augments.clone(),
                            };
                            let mut nl_starts = springs.starts(data);
                            nl_starts.extend(springs_start(current, &springs));
                            if let Some(f) = crate::fit::fit_from(&springs, data, &nl_starts) {
                                if outcome
                                    .as_ref()
                                    .is_none_or(|o| f.held_out_rms_pct < o.held_out_rms_pct)
                                {
                                    outcome = Some(f);
                                }
                            }
                        }
                        let outcome = outcome.map(|f| {
                            let tests = residual_tests(&residual_of(&f, data), data);
                            (f, tests)
                        });
                        (aug, ev, outcome)
                    })
                })
                .collect();
            handles.into_iter().filter_map(|h| h.join().ok()).collect()
        });
        let mut best: Option<(Fit, ResidualTests, usize)> = None;
        for (aug, ev, outcome) in fits {
            let Some((f, tests)) = outcome else { continue };
            candidates.push(Candidate {
                effect: aug.name().to_string(),
                round,
                held_out_rms_g: g1 * f.held_out_rms_pct,
                fit_rms_g: g1 * f.fit_rms_pct,
                ljung_box_ratio: tests.ljung_box_ratio,
                accepted: false,
                evidence: ev,
            });
            let gain = current.held_out_rms_pct - f.held_out_rms_pct;
            let clear =
                gain >= ACCEPT_RELATIVE * current.held_out_rms_pct && gain >= ACCEPT_ABSOLUTE_PCT;
            let whiter = tests.ljung_box < current_tests.ljung_box;
            if clear
                && whiter
                && best
                    .as_ref()
                    .is_none_or(|b| f.held_out_rms_pct < b.0.held_out_rms_pct)
            {
                let index = candidates.len() - 1;
                best = Some((f, tests, index));
            }
        }
        match best {
            Some((f, tests, index)) => {
                candidates[index].accepted = true;
                accepted.push(candidates[index].effect.clone());
                current = f;
                current_tests = tests;
            }
            None => break,
        }
    }
    let effect = if let Some(first) = accepted.first() {
        first.clone()
    } else if before_tests.ljung_box_ratio > 20.0 && before_tests.acf_outside > 0.5 {
        "unexplained".to_string()
    } else {
        "none".to_string()
    };
    let force_estimate = force_estimate(&baseline, &current, data);
    let mut summary = String::new();
    let _ = writeln!(
        summary,
        "baseline: {} (held out: {})",
        baseline.model.base.name(),
        data.held_out_description
    );
    let railed = data.excluded.iter().filter(|x| **x).count();
    if railed > 0 {
        let _ = writeln!(
            summary,
            "  the strain sits at its converter's rail for {railed} samples ({:.1} % of the record, at {:.3} %): left out of every fit and score",
            100.0 * railed as f64 / data.excluded.len().max(1) as f64,
            data.strain
                .iter()
                .zip(&data.excluded)
                .find(|(_, x)| **x)
                .map_or(f64::NAN, |(v, _)| *v)
        );
    }
    let _ = writeln!(
        summary,
        "  RMS_n fitted {:.3} g, held out {:.3} g; residual Ljung–Box Q = {:.0} ({:.1}× the 5 % level), {:.0} % of 50 lags outside ±{:.4}",
        baseline.fit_rms_g,
        baseline.held_out_rms_g,
        before_tests.ljung_box,
        before_tests.ljung_box_ratio,
        100.0 * before_tests.acf_outside,
        before_tests.acf_bound
    );
    let _ = writeln!(
        summary,
        "  tests: load explains {:.0} % of the residual, loading direction {:.0} %, time trend {:.0} %; spectral line {:.2} Hz at {:.0}× the median; force-rate cross-correlation {:.2} at {:+.3} s",
        100.0 * before_tests.load_r2,
        100.0 * before_tests.direction_r2,
        100.0 * before_tests.trend_r2,
        before_tests.spectral_peak_hz,
        before_tests.spectral_peak_ratio,
        before_tests.xcorr_peak,
        before_tests.xcorr_peak_lag_s
    );
    for c in &candidates {
        let _ = writeln!(
            summary,
            "  round {} {:<25} held out {:.3} g  Q ratio {:>8.1}  {}",
            c.round,
            c.effect,
            c.held_out_rms_g,
            c.ljung_box_ratio,
            if c.accepted { "ACCEPTED" } else { "" }
        );
    }
    let verdict = match effect.as_str() {
        "none" => "no effect beyond the linear model: its residual is close to white and no candidate lowers the held-out error by 10 %".to_string(),
        "unexplained" => "the residual is not white, but no candidate lowers the held-out error by 10 %: the record has an effect this diagnosis does not model".to_string(),
        _ => format!("found {}", accepted.join(", then ")),
    };
    let _ = writeln!(
        summary,
        "verdict: {verdict}\n  held-out RMS_n {:.3} g → {:.3} g; force from strain (on-chip inverse) {:.3} g → {:.3} g",
        baseline.held_out_rms_g,
        g1 * current.held_out_rms_pct,
        force_estimate.before_rms_g, force_estimate.after_rms_g
    );
    Some(Diagnosis {
        effect,
        effects: accepted,
        before: Errors {
            fit_rms_g: baseline.fit_rms_g,
            held_out_rms_g: baseline.held_out_rms_g,
        },
        after: Errors {
            fit_rms_g: g1 * current.fit_rms_pct,
            held_out_rms_g: g1 * current.held_out_rms_pct,
        },
        candidates,
        baseline_model: baseline.model.base.name().to_string(),
        held_out: data.held_out_description.clone(),
        residual_before: before_tests,
        residual_after: current_tests,
        force_estimate,
        summary,
        baseline_fit: Some(baseline),
        final_fit: Some(current),
    })
}

/// A start for eq. 14 with load-dependent springs from a fitted eq. 14 (mk-alpha) and its
/// augmentations: its springs as they are at 30 g, a little load dependence, the rest as fitted.
fn springs_start(mk: &Fit, springs: &ModelSpec) -> Option<Vec<f64>> {
    let p = &mk.physical;
    let (g1, n1, n2, g2, alpha) = (*p.first()?, *p.get(1)?, *p.get(2)?, *p.get(3)?, *p.get(4)?);
    let root = 30f64.sqrt();
    let mut x = vec![
        0.5 * g1,
        0.5 * g1 / root,
        n1,
        alpha.min(29.0),
        n2,
        0.5 * g2,
        0.5 * g2 / 30.0,
    ];
    x.extend_from_slice(p.get(5..)?);
    Some(springs.internal(&x))
}

/// The base model's inverse (stress from strain) as the chip runs it.
fn inverse_of(fit: &Fit, dt: f64) -> Option<tactile_core::viscoelastic::Discrete2<f64>> {
    fit.model.base.second_order(&fit.physical)?.inverse(dt).ok()
}

/// Force from strain with the baseline's inverse, then with the accepted effects folded in
/// where the chip can take them: strain offset and drift removed, interference subtracted (a
/// notch on the chip), the stiffening nonlinearity inverted, the delay accounted for.
fn force_estimate(baseline: &Fit, current: &Fit, data: &Series) -> ForceEstimate {
    let run = |fit: &Fit, strain: &[f64]| -> Vec<f64> {
        if let Some(element) = fit.model.nonlinear_element(&fit.theta) {
            // Eq. 14 with load-dependent springs: run backwards, as the chip's observer does.
            let mut inv = tactile_core::viscoelastic::StructuralInverse::new(element, data.dt_s);
            return strain
                .iter()
                .map(|e| f64::from(inv.force_g(*e as f32)))
                .collect();
        }
        let Some(inv) = inverse_of(fit, data.dt_s) else {
            return vec![0.0; strain.len()];
        };
        let mut st = Discrete2State::default();
        strain.iter().map(|e| inv.update(&mut st, *e)).collect()
    };
    let rms = |a: &[f64], b: &[f64]| {
        (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len().max(1) as f64).sqrt()
    };
    let offset = |fit: &Fit| {
        fit.physical
            .get(fit.model.base.parameter_count())
            .copied()
            .unwrap_or(0.0)
    };
    let base_strain: Vec<f64> = data.strain.iter().map(|e| e - offset(baseline)).collect();
    let before: Vec<f64> = run(baseline, &base_strain)
        .into_iter()
        .map(|f| f.max(0.0))
        .collect();
    let before_rms = rms(&before, &data.force);

    // Additive parts of the accepted model, removed from the strain before inversion.
    let additive = current.model.additive_parts(&current.theta, data);
    let corrected: Vec<f64> = data
        .strain
        .iter()
        .zip(&additive)
        .map(|(e, a)| e - a - offset(current))
        .collect();
    let mut after = run(current, &corrected);
    let mut config = serde_json::json!({ "base": current.model.base.name(), "parameters": current.physical[..current.model.base.parameter_count()] });
    if current.model.base == Base::MkNonlinear {
        config["load_dependent_springs"] = serde_json::json!(
            "G1 = G1_base + G1_sqrt·√σ, G2 = G2_base + G2_linear·σ (the parameters above)"
        );
    }
    let mut reference = data.force.clone();
    for (name, value) in current.model.augment_values(&current.theta) {
        match name {
            "load_dependent_stiffness" => {
                let (kappa, lambda) = (value[0], value[1]);
                for f in after.iter_mut() {
                    *f = invert_load_nonlinearity(f.max(0.0), kappa, lambda);
                }
                config["stiffening_kappa"] = serde_json::json!(kappa);
                config["stiffening_lambda"] = serde_json::json!(lambda);
            }
            "time_delay" => {
                let d = value[0];
                reference = crate::fit::delayed_pub(&data.force, d / data.dt_s);
                config["delay_s"] = serde_json::json!(d);
            }
            "periodic_interference" => {
                config["notch_hz"] = serde_json::json!(value[3]);
            }
            "baseline_drift" => {
                config["drift_tracker"] = serde_json::json!(true);
            }
            other => {
                config[other] = serde_json::json!(
                    "kept in the forward model only: no causal inverse on the chip yet"
                );
            }
        }
    }
    let after: Vec<f64> = after.into_iter().map(|f| f.max(0.0)).collect();
    ForceEstimate {
        before_rms_g: before_rms,
        after_rms_g: rms(&after, &reference),
        estimator_config: config,
    }
}

/// Load levels the exported schedule samples a stiffening law at, grams.
pub const EXPORT_LOADS_G: [f64; 4] = [10.0, 25.0, 45.0, 70.0];

/// The accepted model as a taxel's calibration, the table entry the firmware reads at start-up
/// (`tactile diagnose FILE --table OUT.bin`): the base as eq. 17 with its strain offset; an
/// accepted `load_dependent_stiffness` (ε = C(s)·σ/d(σ), d = 1 + κ√σ + λσ) becomes the
/// scheduled inverse's table (the compliance divided by d at each of [`EXPORT_LOADS_G`]) and,
/// for a Maxwell–Kelvin base, the observer's spring laws (G·d(σ)); an accepted
/// `periodic_interference` becomes a notch at its frequency on the strain. The delay and the
/// drift have no on-chip form yet: they stay in the JSON's `estimator_config`. `None` if the model has no eq. 17 form.
pub fn taxel_model(
    d: &Diagnosis,
    taxel: tactile_core::tactile::TaxelId,
) -> Option<tactile_core::calibration::TaxelModel> {
    use tactile_core::calibration::TaxelModel;
    use tactile_core::viscoelastic::{NonlinearMk, SecondOrder, SpringLaw};
    let fit = d.final_fit.as_ref()?;
    let base = fit.model.base;
    let offset = *fit.physical.get(base.parameter_count())?;
    // An accepted interference: its frequency, notched on the chip.
    let notch_hz = fit
        .model
        .augment_values(&fit.theta)
        .into_iter()
        .find(|(name, _)| *name == "periodic_interference")
        .and_then(|(_, v)| v.get(3).copied())
        .unwrap_or(0.0);
    if let Some(element) = fit.model.nonlinear_element(&fit.theta) {
        // Stiffening as load-dependent springs: the observer runs the element itself, the
        // schedule its secant springs at each load.
        let schedule = tactile_core::calibration::secant_schedule(&element, &EXPORT_LOADS_G);
        let at_25 = element.linearized(25.0).second_order();
        return Some(TaxelModel {
            taxel,
            strain_offset_pct: offset,
            elastic_g_per_pct: at_25.b2 / at_25.a2,
            second_order: at_25,
            schedule,
            element,
            notch_hz,
        });
    }
    let so = base.second_order(&fit.physical)?;
    let (kappa, lambda) = fit
        .model
        .augment_values(&fit.theta)
        .into_iter()
        .find(|(name, _)| *name == "load_dependent_stiffness")
        .and_then(|(_, v)| Some((*v.first()?, *v.get(1)?)))
        .unwrap_or((0.0, 0.0));
    let stiffening = |load: f64| (1.0 + kappa * load.sqrt() + lambda * load).max(0.05);
    let scaled = |load: f64| {
        let k = stiffening(load);
        SecondOrder {
            b0: so.b0 * k,
            b1: so.b1 * k,
            b2: so.b2 * k,
            ..so
        }
    };
    let mut schedule = heapless::Vec::new();
    if kappa == 0.0 && lambda == 0.0 {
        schedule.push((25.0, so)).ok()?;
    } else {
        for load in EXPORT_LOADS_G {
            schedule.push((load as f32, scaled(load))).ok()?;
        }
    }
    let law = |g: f64| SpringLaw {
        base: g,
        sqrt_coeff: g * kappa,
        linear_coeff: g * lambda,
    };
    let p = &fit.physical;
    let element = match base {
        Base::MaxwellKelvin | Base::MkAlpha => NonlinearMk {
            g1: law(*p.first()?),
            n1: *p.get(1)?,
            alpha: if base == Base::MkAlpha {
                *p.get(4)?
            } else {
                0.0
            },
            n2: *p.get(2)?,
            g2: law(*p.get(3)?),
        },
        _ => NonlinearMk::ELEMENT_4_2,
    };
    let at_25 = scaled(25.0);
    Some(TaxelModel {
        taxel,
        strain_offset_pct: offset,
        elastic_g_per_pct: at_25.b2 / at_25.a2,
        second_order: so,
        schedule,
        element,
        notch_hz,
    })
}

/// Solves u = σ/(1 + κ√σ + λσ) for σ ≥ 0: with x = √σ, (1 − λu)x² − κu·x − u = 0.
pub fn invert_load_nonlinearity(u: f64, kappa: f64, lambda: f64) -> f64 {
    let a = 1.0 - lambda * u;
    if a <= 1e-9 {
        return u;
    }
    let b = kappa * u;
    let x = (b + (b * b + 4.0 * a * u).sqrt()) / (2.0 * a);
    x * x
}
