//! Dynamic calibration of a taxel: from a record of the calibration protocol
//! (`Protocol::CALIBRATION`: rest, then the memo's sum of sinusoids about several load levels,
//! the applicator over that taxel), fit the models each on-chip estimator needs, score every
//! estimator on parts of the record its fit did not see, and write the core's [`TaxelModel`]
//! with the estimator the firmware is to run; a table of them is what the firmware reads.
//!
//! - The strain offset is the strain at the protocol's leading rest (not a free parameter).
//! - eq. 14 whose springs are curves learned from the record ([`fit_element`]): each spring's
//!   strain at ten loads over the calibrated range, monotone by construction (log segment
//!   compliances), with a small penalty on how fast the segments' stiffness changes so loads
//!   the record barely visits are bridged smoothly. No stiffening law is assumed. The fit's
//!   rows are the force the element reads from the strain (as the chip runs it) and the
//!   strain it makes under the force (weighted by the record's stiffness at the top of its
//!   range): run backwards alone, a model that creeps too much reads the rest as no force,
//!   which costs nothing, and the slow branches came out wrong by grams on long loads.
//! - the elastic spring fitted on the memo's level, and eq. 17 as the element's secant springs
//!   there (Table I's way): the memo's estimators, recalibrated;
//! - the scheduled inverse's table: the element's secant springs at each load level.
//! - Held out: each level is cut into [`FOLDS`] blocks; fold j fits everything but block j of
//!   every level, its estimators run over the whole record at the scan rate, and block j is
//!   scored against the record's force. The firmware runs the estimator that held out best —
//!   the nominal models' if they hold out better than any calibrated one (flagged
//!   [`CalibrationFlags::NOMINAL`]).

mod element;

use tactile_core::calibration::CalibrationTable;
use tactile_core::estimator::StructuralInverse;
use tactile_core::estimator::{
    secant_schedule, CalibrationFlags, TaxelModel, LARGE_OFFSET_PCT, POOR_FIT_G,
};
use tactile_core::estimator::{BankModel, EstimatorKind, TaxelEstimators};
use tactile_core::profile::{Protocol, CALIBRATION_OFFSETS_G, CALIBRATION_REST_S};
use tactile_core::spring::{SpringLaw, CURVE_KNOTS};
use tactile_core::tactile::{ScanConfig, TaxelId};
use tactile_core::viscoelastic::NonlinearMk;

use crate::finger::Effects;
use crate::fit::{fit, Base, ModelSpec, Split};
use crate::rig::TickRecord;
use crate::scenario::ScenarioError;
use element::{alpha_prior_share, fit_element, ElementFit};

/// Time left out at the start of each load level (the slew and the transient), s.
const SETTLE_S: f64 = 2.0;
/// The nominal models replace a calibration only if they hold out below this share of its
/// error (a tie keeps the taxel's own).
const NOMINAL_MARGIN: f64 = 0.9;
/// Levenberg–Marquardt's budget: evaluations per parameter (each also costs a finite-difference
/// Jacobian of 23 runs of the element over the record).
const PATIENCE: usize = 8;
/// The forward rows score every this many frames (the creep they pin is slow; fewer rows
/// keep the fit's QR small).
const FORWARD_STEP: usize = 4;
/// Blocks each load level is cut into for the held-out scores.
pub const FOLDS: usize = 4;

pub use crate::finger::{CALIBRATION_FINGER_SEED as FINGER_SEED, CALIBRATION_TAXELS};

/// What a taxel's calibration found, for the report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct TaxelFitReport {
    pub taxel: (usize, usize),
    /// Strain at the protocol's rest, removed before everything else, percent.
    pub rest_offset_pct: f64,
    /// The element's RMS strain error on the whole record, and its mean (what an offset
    /// would have had to absorb), percent.
    pub element_rms_pct: f64,
    pub mean_miss_pct: f64,
    /// Mean load at each level of the protocol (g): the scheduled inverse's table loads.
    pub levels: Vec<f64>,
    /// The largest load the record covered (99.5th percentile), g.
    pub range_g: f64,
    /// The share of the fit's knowledge of α (the permanent deformation's spring) that is its
    /// prior's, element 4,2's value, rather than the record's: above a half, α is the prior's.
    pub alpha_prior_share: f64,
    /// Held-out RMS force error (g) of each estimator, calibrated and nominal, in
    /// `EstimatorKind::ALL`'s order.
    pub held_out_g: [f64; EstimatorKind::COUNT],
    pub nominal_held_out_g: [f64; EstimatorKind::COUNT],
    pub estimator: String,
    pub flags: Vec<String>,
}

/// A fold: which frames its fit saw, and every estimator's output over the record.
type FoldRun = (Vec<bool>, Vec<[f32; EstimatorKind::COUNT]>);

/// Each frame's level and fold (`None` outside the levels' settled parts).
type Placed = Vec<Option<(usize, usize)>>;

/// Frame period the estimators run at on the chip, s.
fn frame_s() -> f64 {
    f64::from(ScanConfig::DESIGN.frame_period_s())
}

/// The record as the chip sees one taxel: every `step`-th sample, `step` the whole number of
/// samples nearest the scan frame.
struct Frames {
    dt_s: f64,
    force: Vec<f64>,
    strain: Vec<f64>,
}

impl Frames {
    fn new(dt_s: f64, force_g: &[f64], strain_pct: &[f64]) -> Frames {
        let step = (frame_s() / dt_s).round().max(1.0) as usize;
        Frames {
            dt_s: dt_s * step as f64,
            force: force_g.iter().step_by(step).copied().collect(),
            strain: strain_pct.iter().step_by(step).copied().collect(),
        }
    }
    fn time(&self, i: usize) -> f64 {
        i as f64 * self.dt_s
    }
}

/// Why a calibration record could not be fitted.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CalibrationError {
    #[error("a taxel is calibrated from a record of the calibration protocol")]
    NotTheCalibrationProtocol,
    #[error("force and strain must have the same, evenly sampled length")]
    Unsampled,
    #[error("the record has a non-finite force or strain")]
    NonFinite,
    #[error("the record lasts {have_s:.1} s; the calibration protocol needs {needed_s:.0} s")]
    TooShort { have_s: f64, needed_s: f64 },
    #[error(
        "no rest at the start of the record (the protocol's first {rest_s:.0} s, force under 1 g)"
    )]
    NoRest { rest_s: f64 },
    #[error("the force never rises above 1 g: nothing was calibrated")]
    NoLoad,
    #[error("the force does not follow the calibration protocol: its {offset_g} g level averages {mean_g:.1} g (a record of another protocol, or the force and strain columns swapped?)")]
    NotTheProtocolsLoads { offset_g: f32, mean_g: f64 },
    #[error("taxel ({}, {}): the {what} fit failed", .taxel.row(), .taxel.col())]
    FitFailed { taxel: TaxelId, what: &'static str },
    #[error("taxel ({}, {}): its model cannot run on the chip: {source}", .taxel.row(), .taxel.col())]
    Model {
        taxel: TaxelId,
        #[source]
        source: tactile_core::viscoelastic::ModelError,
    },
    #[error("more taxels than the array has")]
    TooManyTaxels,
}

/// How far a level's mean force may be from its offset: grams, and a share of the offset.
pub const LEVEL_TOLERANCE: (f64, f64) = (3.0, 0.3);

/// Fits one taxel from its calibration record: force (g) and strain (%) sampled every `dt_s`
/// from the start of `protocol` (a `Protocol::Calibration`).
pub fn fit_taxel(
    taxel: TaxelId,
    protocol: Protocol,
    dt_s: f64,
    force_g: &[f64],
    strain_pct: &[f64],
) -> Result<(TaxelModel, TaxelFitReport), CalibrationError> {
    let per_offset_s = per_offset_of(protocol, dt_s, force_g, strain_pct)?;
    let raw = Frames::new(dt_s, force_g, strain_pct);
    let offset = rest_offset(&raw)?;
    let frames = Frames {
        dt_s: raw.dt_s,
        force: raw.force.clone(),
        strain: raw.strain.iter().map(|e| e - offset).collect(),
    };
    let (placed, levels) = place_levels(&frames, per_offset_s)?;
    let range_g = tactile_ident::stats::quantile(&frames.force, 0.995);
    if range_g.is_nan() || range_g <= 1.0 {
        return Err(CalibrationError::NoLoad);
    }
    let knots = knots_for(range_g);
    let failed = |what: &'static str| CalibrationError::FitFailed { taxel, what };

    // The whole record, then each fold from the whole record's parameters.
    let everything = vec![true; frames.force.len()];
    let whole = fit_element(&frames, &everything, &knots, None).ok_or_else(|| failed("element"))?;
    let model_from = |fit: &ElementFit, in_fit: &[bool]| -> Result<TaxelModel, CalibrationError> {
        memo_models(
            taxel, &frames, in_fit, &placed, fit, &levels, range_g, offset,
        )
        .ok_or_else(|| failed("second-order"))
    };
    // The nominal models do not depend on the fold: their estimates are run once.
    let nominal = TaxelModel {
        strain_offset_pct: offset,
        ..TaxelModel::nominal(taxel)
    };
    let nominal_est = run_estimators(&nominal, &raw)?;
    let folds = fold_runs(taxel, &frames, &raw, &placed, &knots, &whole, &model_from);
    let [held_out, nominal_held_out] = held_out_rms(folds, &nominal_est, &frames.force)?;
    let model = chosen_model(
        model_from(&whole, &everything)?,
        nominal,
        [held_out, nominal_held_out],
        range_g,
        &whole,
    );
    let report = TaxelFitReport {
        taxel: (taxel.row(), taxel.col()),
        rest_offset_pct: offset,
        element_rms_pct: whole.rms_pct,
        mean_miss_pct: whole.mean_miss_pct,
        levels,
        range_g,
        alpha_prior_share: alpha_prior_share(&frames, &everything, &knots, &whole),
        held_out_g: held_out,
        nominal_held_out_g: nominal_held_out,
        estimator: model.estimator.name().to_string(),
        flags: model
            .flags
            .iter_names()
            .map(|(n, _)| n.to_lowercase())
            .collect(),
    };
    Ok((model, report))
}

/// The time the calibration `protocol` spends at each offset, s, once the record is one it
/// can be fitted from: force and strain evenly sampled, finite, and as long as the protocol.
fn per_offset_of(
    protocol: Protocol,
    dt_s: f64,
    force_g: &[f64],
    strain_pct: &[f64],
) -> Result<f64, CalibrationError> {
    let Protocol::Calibration { per_offset_s, .. } = protocol else {
        return Err(CalibrationError::NotTheCalibrationProtocol);
    };
    let per_offset_s = f64::from(per_offset_s);
    if force_g.len() != strain_pct.len() || !dt_s.is_finite() || dt_s <= 0.0 {
        return Err(CalibrationError::Unsampled);
    }
    if force_g.iter().chain(strain_pct).any(|v| !v.is_finite()) {
        return Err(CalibrationError::NonFinite);
    }
    let rest_s = f64::from(CALIBRATION_REST_S);
    let needed_s = rest_s + per_offset_s * CALIBRATION_OFFSETS_G.len() as f64;
    let have_s = dt_s * force_g.len() as f64;
    if have_s + 0.5 < needed_s {
        return Err(CalibrationError::TooShort { have_s, needed_s });
    }
    Ok(per_offset_s)
}

/// The strain's offset, %, from the record's leading rest.
fn rest_offset(raw: &Frames) -> Result<f64, CalibrationError> {
    let rest_s = f64::from(CALIBRATION_REST_S);
    // The offset: the strain at the leading rest, its first half second left out.
    let rest: Vec<f64> = (0..raw.force.len())
        .filter(|&i| (0.5..rest_s - 0.1).contains(&raw.time(i)) && raw.force[i].abs() < 1.0)
        .map(|i| raw.strain[i])
        .collect();
    if rest.len() < 20 {
        return Err(CalibrationError::NoRest { rest_s });
    }
    Ok(tactile_ident::stats::mean(&rest))
}

/// Each frame's level and fold (`None` before the levels, past them, and while a level
/// settles), and each level's mean force, checked to be the protocol's.
fn place_levels(
    frames: &Frames,
    per_offset_s: f64,
) -> Result<(Placed, Vec<f64>), CalibrationError> {
    let rest_s = f64::from(CALIBRATION_REST_S);
    let level_of = |i: usize| -> Option<(usize, usize)> {
        let t = frames.time(i) - rest_s;
        let k = (t / per_offset_s).floor();
        let into = t - k * per_offset_s;
        (t >= 0.0 && (k as usize) < CALIBRATION_OFFSETS_G.len() && into >= SETTLE_S).then(|| {
            let block = ((into - SETTLE_S) / (per_offset_s - SETTLE_S) * FOLDS as f64) as usize;
            (k as usize, block.min(FOLDS - 1))
        })
    };
    let placed: Placed = (0..frames.force.len()).map(level_of).collect();
    let levels: Vec<f64> = (0..CALIBRATION_OFFSETS_G.len())
        .map(|k| {
            let at: Vec<f64> = placed
                .iter()
                .zip(&frames.force)
                .filter(|(p, _)| p.is_some_and(|(l, _)| l == k))
                .map(|(_, f)| *f)
                .collect();
            tactile_ident::stats::mean(&at)
        })
        .collect();
    // Each level's mean force is its offset (the sines about it average out) within what a
    // loop without integral action leaves and a fifth: else the record is not this protocol's.
    for (&offset_g, &mean_g) in CALIBRATION_OFFSETS_G.iter().zip(&levels) {
        let off = (mean_g - f64::from(offset_g)).abs();
        if off.is_nan() || off > LEVEL_TOLERANCE.0 + LEVEL_TOLERANCE.1 * f64::from(offset_g) {
            return Err(CalibrationError::NotTheProtocolsLoads { offset_g, mean_g });
        }
    }
    Ok((placed, levels))
}

/// Each fold's fit (from the `whole` record's parameters, its frames held out), its models
/// (`model_from`) and their estimates over the record, on threads.
fn fold_runs(
    taxel: TaxelId,
    frames: &Frames,
    raw: &Frames,
    placed: &[Option<(usize, usize)>],
    knots: &[f32; CURVE_KNOTS],
    whole: &ElementFit,
    model_from: &(impl Fn(&ElementFit, &[bool]) -> Result<TaxelModel, CalibrationError> + Sync),
) -> Vec<Result<FoldRun, CalibrationError>> {
    let failed = |what: &'static str| CalibrationError::FitFailed { taxel, what };
    std::thread::scope(|scope| {
        let runs: Vec<_> = (0..FOLDS)
            .map(|fold| {
                scope.spawn(move || {
                    let in_fit: Vec<bool> = placed
                        .iter()
                        .map(|p| p.is_none_or(|(_, b)| b != fold))
                        .collect();
                    let fold_fit = fit_element(frames, &in_fit, knots, Some(&whole.theta))
                        .ok_or_else(|| failed("element"))?;
                    let est = run_estimators(&model_from(&fold_fit, &in_fit)?, raw)?;
                    Ok((in_fit, est))
                })
            })
            .collect();
        runs.into_iter()
            .map(|r| r.join().unwrap_or_else(|_| Err(failed("element"))))
            .collect()
    })
}

/// The RMS error of each estimator over the frames each fold held out, g: of the folds' own
/// models, and of the nominal models (`nominal_est`), against the measured `force`.
fn held_out_rms(
    folds: Vec<Result<FoldRun, CalibrationError>>,
    nominal_est: &[[f32; EstimatorKind::COUNT]],
    force: &[f64],
) -> Result<[[f64; EstimatorKind::COUNT]; 2], CalibrationError> {
    let mut sums = [[0.0f64; EstimatorKind::COUNT]; 2];
    let mut scored = 0usize;
    for fold in folds {
        let (in_fit, calibrated_est) = fold?;
        for (sum, est) in sums.iter_mut().zip([&calibrated_est[..], nominal_est]) {
            for (i, e) in est.iter().enumerate() {
                if !in_fit[i] {
                    for (s, v) in sum.iter_mut().zip(e) {
                        *s += (f64::from(*v) - force[i]).powi(2);
                    }
                }
            }
        }
        scored += in_fit.iter().filter(|b| !**b).count();
    }
    Ok(sums.map(|s| s.map(|v| (v / scored.max(1) as f64).sqrt())))
}

/// The model the taxel runs, `calibrated` or `nominal` by their held-out errors (in that
/// order), with its best estimator, its flags, its range and its held-out errors.
fn chosen_model(
    calibrated: TaxelModel,
    nominal: TaxelModel,
    [held_out, nominal_held_out]: [[f64; EstimatorKind::COUNT]; 2],
    range_g: f64,
    whole: &ElementFit,
) -> TaxelModel {
    let mut model = calibrated;
    let mut flags = CalibrationFlags::empty();
    let (calibrated_best, nominal_best) = (
        EstimatorKind::best(&held_out),
        EstimatorKind::best(&nominal_held_out),
    );
    let mut chosen = held_out[calibrated_best.index()];
    // The taxel's own calibration unless the nominal models hold out clearly better.
    if nominal_held_out[nominal_best.index()] < NOMINAL_MARGIN * chosen {
        model = nominal;
        model.estimator = nominal_best;
        chosen = nominal_held_out[nominal_best.index()];
        flags |= CalibrationFlags::NOMINAL;
    } else {
        model.estimator = calibrated_best;
    }
    if chosen > POOR_FIT_G {
        flags |= CalibrationFlags::POOR;
    }
    if whole.mean_miss_pct.abs() > LARGE_OFFSET_PCT {
        flags |= CalibrationFlags::OFFSET;
    }
    model.flags = flags;
    model.range_g = range_g;
    model.held_out_g = Some(if flags.contains(CalibrationFlags::NOMINAL) {
        nominal_held_out
    } else {
        held_out
    });
    model
}

/// Every on-chip estimator of `model` over the record (its frames, from its raw strain: the
/// conditioner removes the offset as on the chip).
fn run_estimators(
    model: &TaxelModel,
    raw: &Frames,
) -> Result<Vec<[f32; EstimatorKind::COUNT]>, CalibrationError> {
    let mut chip =
        TaxelEstimators::new(model, raw.dt_s).map_err(|source| CalibrationError::Model {
            taxel: model.taxel,
            source,
        })?;
    Ok(raw.strain.iter().map(|e| chip.update(*e as f32)).collect())
}

/// Knot stresses over `range_g`: spread over the range the protocol loads evenly, a little
/// denser at light loads, where a stiffening spring bends most (the k-th of n at
/// range·(k/n)^1.25).
fn knots_for(range_g: f64) -> [f32; CURVE_KNOTS] {
    core::array::from_fn(|k| {
        (range_g * ((k + 1) as f64 / CURVE_KNOTS as f64).powf(KNOT_SKEW)) as f32
    })
}

/// Exponent of [`knots_for`]'s spacing: 1 is even; the curve's default stresses (dense at
/// light loads) are near 2.5.
const KNOT_SKEW: f64 = 1.25;

/// The memo's linear models (elastic and eq. 17 on its level, made secant) and the schedule,
/// around an element fit, fitted on the samples `in_fit`.
#[allow(clippy::too_many_arguments)]
fn memo_models(
    taxel: TaxelId,
    frames: &Frames,
    in_fit: &[bool],
    placed: &[Option<(usize, usize)>],
    element: &ElementFit,
    levels: &[f64],
    range_g: f64,
    offset: f64,
) -> Option<TaxelModel> {
    // The memo's linear models, recalibrated as the memo calibrated them: on the sum of
    // sinusoids about 25 g (the protocol's second level), the rest of the record simulated
    // but not scored.
    let memo_fit: Vec<bool> = placed
        .iter()
        .zip(in_fit)
        .map(|(p, f)| *f && p.is_some_and(|(l, _)| l == MEMO_LEVEL))
        .collect();
    let n = memo_fit.iter().filter(|b| **b).count().max(1) as f64;
    let load = frames
        .force
        .iter()
        .zip(&memo_fit)
        .filter(|(_, b)| **b)
        .map(|(f, _)| f)
        .sum::<f64>()
        / n;
    let series = Split {
        in_fit: memo_fit,
        held_out_description: "all but the memo's level".into(),
        ..Split::whole(frames.dt_s, frames.force.clone(), frames.strain.clone())
    };
    let elastic = fit(&ModelSpec::new(Base::Elastic), &series, &[])?;
    // The linear model's intercept made secant at the level's mean load, so it reads zero
    // strain as zero force.
    let elastic_g = {
        let (g, c) = (elastic.physical[0], elastic.physical[1]);
        g / secant_factor(load / g, c)
    };
    // Eq. 17 as Table I writes it: the element's secant springs at the level's load. (Fitted
    // on the level's 13 s alone, its slow pole runs to zero: the 0.017 Hz sinusoid does not
    // complete a period.)
    let second_order = element.element.linearized(load).second_order();
    // The force bank, fitted for force on the same samples.
    let bank =
        tactile_ident::force_fit::fit_bank(frames.dt_s, &frames.force, &frames.strain, in_fit)
            .map_or(BankModel::elastic(elastic_g), |b| b.model);
    Some(TaxelModel {
        taxel,
        strain_offset_pct: offset,
        elastic_g_per_pct: elastic_g,
        second_order,
        schedule: secant_schedule(&element.element, levels),
        element: element.element,
        range_g,
        bank,
        ..TaxelModel::nominal(taxel)
    })
}

/// The level the memo's own calibration used (its sum of sinusoids about 25 g).
const MEMO_LEVEL: usize = 1;

/// How much a model's compliance grows to pass through (load, strain at load with the
/// intercept) with none: (ε_static + ε₀)/ε_static, or 1 where that is not a sensible scale
/// (beyond 0.1–10, or not finite).
fn secant_factor(static_pct: f64, intercept_pct: f64) -> f64 {
    let k = (static_pct + intercept_pct) / static_pct;
    if k.is_finite() && k > 0.1 && k < 10.0 {
        k
    } else {
        1.0
    }
}

/// `table`'s bytes as the firmware reads them (`path` names the file in an error).
pub fn encode_table(
    path: &std::path::Path,
    table: &CalibrationTable,
) -> Result<Vec<u8>, crate::Error> {
    let mut bytes = vec![0u8; table.encoded_len()];
    let n = table
        .encode(&mut bytes)
        .map_err(|source| crate::Error::Table {
            path: path.to_path_buf(),
            source,
        })?;
    bytes.truncate(n);
    Ok(bytes)
}

/// The calibration protocol run on the simulator with the probe over `taxel` of the finger
/// drawn from `seed` with `effects` (the gauge's force and the probed taxel's strain, as the
/// firmware records them).
pub fn simulate_calibration(
    taxel: TaxelId,
    seed: u64,
    effects: Effects,
) -> Result<Vec<TickRecord>, ScenarioError> {
    crate::scenario::run_on_taxel("calibration", Protocol::CALIBRATION, taxel, seed, effects)
}

/// Calibrates `taxels` of the simulated finger `seed` (with `effects`) one after the other.
pub fn calibrate_simulated(
    taxels: &[TaxelId],
    seed: u64,
    effects: Effects,
) -> Result<(CalibrationTable, Vec<TaxelFitReport>), crate::Error> {
    let mut table = CalibrationTable::default();
    let mut reports = Vec::new();
    for &taxel in taxels {
        let ticks = simulate_calibration(taxel, seed, effects)?;
        let (force, strain): (Vec<f64>, Vec<f64>) = ticks
            .iter()
            .map(|t| (f64::from(t.sensed_g), f64::from(t.strain_pct)))
            .unzip();
        let (model, report) = fit_taxel(taxel, Protocol::CALIBRATION, 1e-3, &force, &strain)?;
        table
            .taxels
            .push(model)
            .map_err(|_| CalibrationError::TooManyTaxels)?;
        reports.push(report);
    }
    Ok((table, reports))
}

#[cfg(test)]
mod tests {
    use super::*;
    use element::simulate;

    #[test]
    fn a_record_whose_force_is_not_the_protocols_levels_is_refused() {
        // The protocol's shape (2 s at rest, four 15 s holds) with each hold at 0.4 of its
        // offset: 12 g reads 4.8 g, 7.2 g off (the tolerance there is 3 + 0.3·12 = 6.6 g).
        let dt = 0.005;
        let force: Vec<f64> = (0..12_400)
            .map(|i| {
                let t = i as f64 * dt - f64::from(CALIBRATION_REST_S);
                let k = (t / 15.0).floor();
                if (0.0..4.0).contains(&k) {
                    0.4 * f64::from(CALIBRATION_OFFSETS_G[k as usize])
                } else {
                    0.0
                }
            })
            .collect();
        let strain: Vec<f64> = force.iter().map(|f| f / 3.0).collect();
        let taxel = TaxelId::new(3, 2).unwrap();
        let e = fit_taxel(taxel, Protocol::CALIBRATION, dt, &force, &strain).unwrap_err();
        assert!(
            matches!(e, CalibrationError::NotTheProtocolsLoads { offset_g, mean_g }
                if offset_g == 12.0 && (mean_g - 4.8).abs() < 1e-9),
            "{e}"
        );
    }

    /// A record from element 4,2 itself at 1 s frames: rest, `hold_s` at 50 g, then the same
    /// unloaded.
    fn creep_record(hold_s: usize) -> Frames {
        let m = NonlinearMk::ELEMENT_4_2;
        let force: Vec<f64> = (0..2 * hold_s + 10)
            .map(|i| {
                if (10..10 + hold_s).contains(&i) {
                    50.0
                } else {
                    0.0
                }
            })
            .collect();
        let strain = simulate(&m, &force, 1.0);
        Frames::new(1.0, &force, &strain)
    }

    #[test]
    fn alpha_is_the_records_only_where_a_hold_outlasts_its_time_constant() {
        // α sets the permanent deformation's time constant N₁/α ≈ 1 000 s on element 4,2.
        // A 3 000 s hold and recovery bend it; a 20 s one does not.
        let share = |hold_s: usize| {
            let frames = creep_record(hold_s);
            let all = vec![true; frames.force.len()];
            let knots = knots_for(50.0);
            let fit = fit_element(&frames, &all, &knots, None).unwrap();
            alpha_prior_share(&frames, &all, &knots, &fit)
        };
        let (long, short) = (share(3000), share(20));
        eprintln!("prior's share of α: 3 000 s hold {long:.3}, 20 s hold {short:.3}");
        assert!(long < 0.2, "3 000 s hold: prior's share {long}");
        assert!(short > 0.5, "20 s hold: prior's share {short}");
    }
}
