//! The record as every model sees it: the force smoothed, the strain's sign and secant, the
//! force's range and the load basis's origin and scale, the baseline's grid of time constants
//! and the part of it a first fit uses, and the folds.

use crate::series::{Folds, Series};
use crate::solve::Pool;
use crate::{stats, terms};

use super::work::{baseline_columns, creep_column, grid, Creep, Work};
use super::{Settings, Term};

/// The record prepared for the fits.
pub(super) struct Prepared {
    /// The force as every model sees it (the strain is not copied: it is read from the
    /// record).
    pub(super) smoothed: Series,
    /// Samples of the noise estimates' window.
    pub(super) window: usize,
    /// The force as measured at the samples that count, the variance of its noise, and the
    /// share of that variance the smoothing passes.
    pub(super) measured_force_kept: Vec<f64>,
    pub(super) force_noise: f64,
    pub(super) force_noise_passed: f64,
    /// The samples that count, and the smoothed force at them.
    pub(super) kept: Vec<bool>,
    pub(super) force_kept: Vec<f64>,
    /// −1 when the strain falls as the force rises, and grams per % strain (the secant).
    pub(super) orientation: f64,
    pub(super) secant: f64,
    /// The strain in the force's sign: what every model fits.
    pub(super) y: Vec<f64>,
    /// The force's range between its 1st and 99th percentiles, g, and the load basis's origin
    /// and scale.
    pub(super) force_range: f64,
    pub(super) force_origin: f64,
    pub(super) force_scale: f64,
    /// The baseline's grid of time constants, s.
    pub(super) taus: Vec<f64>,
}

/// Prepares a checked record: the force smoothed, the strain's sign and secant, the load
/// basis's origin and scale, the baseline's grid of time constants.
pub(super) fn prepare(series: &Series, settings: &Settings) -> Prepared {
    // The reference force is measured too: its noise, fed through a model, is error no model can
    // remove, and a model that smooths it with later samples beats the right one (a delay).
    // Every model sees the same zero-phase, short-time Wiener estimate of the force instead:
    // quiet stretches smoothed hard, ramps kept sharp (what tells a delay from a fast branch).
    let window = ((1.0 / series.dt_s) as usize).max(20);
    let measured_force_kept = series.kept(&series.force_g);
    let force_noise = stats::noise_variance(&measured_force_kept, window);
    let (force_g, force_noise_passed) = terms::wiener_local(&series.force_g, force_noise, window);
    let smoothed = Series {
        dt_s: series.dt_s,
        force_g,
        // Not copied (a 600 s record at 1 kHz: 4.8 MB): the strain is read from `series`.
        strain_pct: Vec::new(),
        excluded: series.excluded.clone(),
        intake: series.intake.clone(),
    };
    let s = &smoothed;
    let (dt, t_s) = (s.dt_s, s.duration_s());
    let kept: Vec<bool> = s.excluded.iter().map(|x| !x).collect();
    let (fk, ek) = (s.kept(&s.force_g), s.kept(&series.strain_pct));
    let slope = secant_slope(&fk, &ek);
    let orientation = if slope < 0.0 { -1.0 } else { 1.0 };
    let secant = 1.0 / slope.abs().max(f64::MIN_POSITIVE);
    let y: Vec<f64> = series.strain_pct.iter().map(|e| orientation * e).collect();
    let (q01, q99) = (stats::quantile(&fk, 0.01), stats::quantile(&fk, 0.99));
    let force_range = (q99 - q01).max(1e-12);
    let force_origin = force_origin(q01, q99);
    // The load basis's scale: the load's size from zero, or its swing from the origin.
    let force_scale = if force_origin == 0.0 {
        let abs_f: Vec<f64> = fk.iter().map(|v| v.abs()).collect();
        stats::quantile(&abs_f, 0.99).max(f64::MIN_POSITIVE)
    } else {
        force_range
    };
    let tau_lo = settings.tau_min_s.max(2.0 * dt);
    let tau_hi = settings.base_tau_max_s.min(t_s / 2.0).max(tau_lo);
    let taus = grid(tau_lo, tau_hi, settings.per_decade);
    Prepared {
        smoothed,
        window,
        measured_force_kept,
        force_noise,
        force_noise_passed,
        kept,
        force_kept: fk,
        orientation,
        secant,
        y,
        force_range,
        force_origin,
        force_scale,
        taus,
    }
}

/// The slope of the strain `ek` on the force `fk`: a robust line's, or where that is
/// degenerate, the least-squares size with the correlation's sign.
fn secant_slope(fk: &[f64], ek: &[f64]) -> f64 {
    let (_, slope) = stats::robust_line(fk, ek);
    if slope.abs() > 0.0 && slope.is_finite() {
        slope
    } else {
        // Degenerate robust line: fall back on least squares through the data.
        stats::correlation(fk, ek).signum().max(-1.0) * (stats::rms(ek) / stats::rms(fk))
    }
}

/// The origin of the load basis for a force whose 1st and 99th percentiles are `q01`, `q99`:
/// zero where the force comes within a tenth of its range of zero, else the end nearest zero.
fn force_origin(q01: f64, q99: f64) -> f64 {
    let range = q99 - q01;
    if q01 > 0.1 * range {
        q01
    } else if q99 < -0.1 * range {
        q99
    } else {
        0.0
    }
}

/// The baseline's support, its creep and the folds. A first fit of the baseline over the whole
/// grid sets the folds' length (its slowest branch) and the grid's support: NNLS leaves most
/// time constants at zero, so the folds see only the branches that fit used and their
/// neighbours (memory for long records: a column of a 600 s record at 1 kHz is 2.4 MB). Then
/// the creep: eq. 11's, or eq. 14's levelling off at the N₁/α that fits best. The folds' blocks
/// are at most `longest_block_s` long.
pub(super) fn support_and_folds(
    prep: &Prepared,
    settings: &Settings,
    longest_block_s: f64,
) -> (Vec<f64>, Creep, Folds) {
    let s = &prep.smoothed;
    let taus = &prep.taus;
    let (slowest, support, creep) = {
        let mut work = Work {
            s,
            pool: Pool::new(&prep.y, &s.excluded, Folds::blocked(&s.excluded, 4)),
            terms: Vec::new(),
            kept: prep.kept.clone(),
            force_kept: Vec::new(),
            measured_force_kept: Vec::new(),
            force_scale: prep.force_scale,
            force_origin: prep.force_origin,
        };
        let cols = baseline_columns(&mut work, taus, Creep::Permanent);
        let fit = work.pool.score(&cols);
        let total: f64 = cols
            .iter()
            .zip(&fit.beta)
            .filter(|(c, _)| matches!(work.terms[**c], Term::Elastic | Term::Relaxation(_)))
            .map(|(_, b)| *b)
            .sum();
        let slowest = cols
            .iter()
            .zip(&fit.beta)
            .filter_map(|(c, b)| match work.terms[*c] {
                Term::Relaxation(tau) if *b > 0.05 * total => Some(tau),
                _ => None,
            })
            .fold(1.0, f64::max);
        let used: Vec<bool> = taus
            .iter()
            .map(|tau| {
                cols.iter()
                    .zip(&fit.beta)
                    .any(|(c, b)| work.terms[*c] == Term::Relaxation(*tau) && *b > 0.0)
            })
            .collect();
        // The slow end stays whole: an effect the first fit did not have (a gain that sags, a
        // drift) bends it there, and a slow mode it left out cannot come back later.
        let slowest_used = used.iter().rposition(|u| *u).unwrap_or(0);
        let support: Vec<f64> = taus
            .iter()
            .enumerate()
            .filter(|(i, _)| {
                *i > slowest_used
                    || (i.saturating_sub(1)..=(i + 1).min(taus.len() - 1)).any(|j| used[j])
            })
            .map(|(_, t)| *t)
            .collect();
        let creep = creep_of(&mut work, &cols, fit.fit_mse, settings);
        (slowest, support, creep)
    };
    let taus = if support.is_empty() {
        taus.clone()
    } else {
        support
    };
    (
        taus,
        creep,
        Folds::for_record_within(s, slowest, longest_block_s),
    )
}

/// The creep that fits the baseline `cols` (its creep last, eq. 11's, fitted to `permanent_mse`)
/// best: eq. 11's, or eq. 14's with N₁/α within [`Settings::alpha_tau_s`], on the grid and
/// then between its neighbours (a golden-section search in ln N₁/α: a slow branch a grid
/// step off leaves a residual a slow mode would take). Both have one coefficient; on a record
/// much shorter than N₁/α the two are the same shape and either serves.
fn creep_of(work: &mut Work, cols: &[usize], permanent_mse: f64, settings: &Settings) -> Creep {
    let mut trial = cols.to_vec();
    let mut mse_at = |tau: f64| {
        let c = creep_column(work, Creep::Alpha(tau));
        if let Some(last) = trial.last_mut() {
            *last = c;
        }
        let mse = work.pool.score(&trial).fit_mse;
        work.pool.drop_column(c);
        mse
    };
    let (lo, hi) = settings.alpha_tau_s;
    let taus = grid(lo, hi, settings.per_decade);
    let scores: Vec<f64> = taus.iter().map(|&tau| mse_at(tau)).collect();
    let Some(k) = (0..scores.len()).min_by(|a, b| scores[*a].total_cmp(&scores[*b])) else {
        return Creep::Permanent;
    };
    let (mut a, mut b) = (
        taus[k.saturating_sub(1)].ln(),
        taus[(k + 1).min(taus.len() - 1)].ln(),
    );
    let mut best = (scores[k], taus[k]);
    let mut keep = |m: f64, x: f64| {
        if m < best.0 {
            best = (m, x.exp());
        }
    };
    // Golden section: each step keeps one inner point and its score, and scores one new one.
    let phi = (5f64.sqrt() - 1.0) / 2.0;
    let (mut x1, mut x2) = (b - phi * (b - a), a + phi * (b - a));
    let (mut m1, mut m2) = (mse_at(x1.exp()), mse_at(x2.exp()));
    keep(m1, x1);
    keep(m2, x2);
    for _ in 0..8 {
        if m1 < m2 {
            (b, x2, m2) = (x2, x1, m1);
            x1 = b - phi * (b - a);
            m1 = mse_at(x1.exp());
            keep(m1, x1);
        } else {
            (a, x1, m1) = (x1, x2, m2);
            x2 = a + phi * (b - a);
            m2 = mse_at(x2.exp());
            keep(m2, x2);
        }
    }
    if best.0 < permanent_mse {
        Creep::Alpha(best.1)
    } else {
        Creep::Permanent
    }
}
