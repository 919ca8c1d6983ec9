//! Dynamic calibration of a taxel (issue 7): from a record of the calibration protocol
//! (`Protocol::CALIBRATION`: the memo's sum of sinusoids about several load levels, the
//! applicator over that taxel), fit the models each on-chip estimator needs and write them as
//! the core's [`TaxelModel`]; a table of them is what the firmware reads at start-up.
//!
//! - eq. 14 with load-dependent springs (`mk-nonlinear`) on the whole record: the observer's
//!   element, and the strain offset every estimator removes;
//! - the elastic spring and eq. 17 on the whole record: the memo's estimators, recalibrated;
//! - the scheduled inverse's table: the calibrated element's secant springs at each load level
//!   the protocol visited, as eq. 17 (Table I's rows, one per load, from one fit).

use tactile_core::calibration::{secant_schedule, CalibrationTable, TaxelModel};
use tactile_core::profile::{Protocol, CALIBRATION_OFFSETS_G};
use tactile_core::tactile::TaxelId;
use tactile_core::viscoelastic::SecondOrder;

use crate::fit::{fit, Base, ModelSpec, Series};
use crate::rig::{RigConfig, TickRecord};
use crate::scenario::{run_protocol, ScenarioError};

/// Sample period the calibration fits run at, s (the 1 kHz record decimated).
pub const FIT_DT_S: f64 = 0.005;
/// Time left out at the start of each load level (the slew and the transient), s.
const SETTLE_S: f64 = 2.0;

pub use crate::finger::{CALIBRATION_FINGER_SEED as FINGER_SEED, CALIBRATION_TAXELS};

/// What a taxel's calibration fitted, for the report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct TaxelFitReport {
    pub taxel: (usize, usize),
    /// Predicted-strain RMS_n of each whole-record fit (g): elastic, second order, mk-nonlinear.
    pub fit_rms_g: [f64; 3],
    /// Mean load at each level of the protocol (g): the scheduled inverse's table loads.
    pub levels: Vec<f64>,
}

/// Fits one taxel from its calibration record: force (g) and strain (%) sampled every `dt_s`
/// from the start of `protocol` (a `Protocol::Calibration`).
pub fn fit_taxel(
    taxel: TaxelId,
    protocol: Protocol,
    dt_s: f64,
    force_g: &[f64],
    strain_pct: &[f64],
) -> Result<(TaxelModel, TaxelFitReport), String> {
    let Protocol::Calibration { per_offset_s, .. } = protocol else {
        return Err("a taxel is calibrated from a record of the calibration protocol".into());
    };
    if force_g.len() != strain_pct.len() || dt_s.is_nan() || dt_s <= 0.0 {
        return Err("force and strain must have the same, evenly sampled length".into());
    }
    let needed_s = f64::from(per_offset_s) * CALIBRATION_OFFSETS_G.len() as f64;
    let have_s = dt_s * force_g.len() as f64;
    if have_s + 0.5 < needed_s {
        return Err(format!(
            "the record lasts {have_s:.1} s; the calibration protocol needs {needed_s:.0} s"
        ));
    }
    let step = (FIT_DT_S / dt_s).round().max(1.0) as usize;
    let dt = dt_s * step as f64;
    let force: Vec<f64> = force_g.iter().step_by(step).copied().collect();
    let strain: Vec<f64> = strain_pct.iter().step_by(step).copied().collect();
    let failed = |what: &str| format!("taxel {taxel:?}: the {what} fit failed");

    let spec = ModelSpec::new(Base::MkNonlinear);
    let nl = fit(
        &spec,
        &Series::whole(dt, force.clone(), strain.clone()),
        &[],
    )
    .ok_or_else(|| failed("mk-nonlinear"))?;
    let element = spec
        .nonlinear_element(&nl.theta)
        .ok_or_else(|| failed("mk-nonlinear"))?;
    let offset = nl.physical[Base::MkNonlinear.parameter_count()];
    let strain: Vec<f64> = strain.iter().map(|e| e - offset).collect();
    let whole = Series::whole(dt, force.clone(), strain.clone());
    // The memo's linear models, recalibrated as the memo calibrated them: on the sum of
    // sinusoids about 25 g (the protocol's second level), the rest of the record simulated but
    // not scored.
    let (memo_level_load, memo_level) = level_series(&whole, per_offset_s, MEMO_LEVEL);
    let elastic =
        fit(&ModelSpec::new(Base::Elastic), &memo_level, &[]).ok_or_else(|| failed("elastic"))?;
    let so_fit = fit(&ModelSpec::new(Base::SecondOrder), &memo_level, &[])
        .ok_or_else(|| failed("second-order"))?;
    let second_order = Base::SecondOrder
        .second_order(&so_fit.physical)
        .ok_or_else(|| failed("second-order"))?;

    // The scheduled inverse's table: the calibrated element's secant springs at each load
    // level the protocol visited (its mean load there). Fitting eq. 14 to each level's 15 s
    // alone cannot tell the permanent deformation's α and N₁ apart (the fits run to their
    // bounds) and gives tangent, not secant, springs; the whole record's nonlinear fit sees
    // every level at once.
    let levels: Vec<f64> = (0..CALIBRATION_OFFSETS_G.len())
        .map(|k| level_series(&whole, per_offset_s, k).0)
        .collect();
    let schedule = secant_schedule(&element, &levels);
    // The linear models' intercepts made secant at their level's mean load, so they read zero
    // strain as zero force.
    let elastic_g = {
        let (g, c) = (elastic.physical[0], elastic.physical[1]);
        g / secant_factor(memo_level_load / g, c)
    };
    let second_order = secant(
        &second_order,
        memo_level_load,
        so_fit.physical[Base::SecondOrder.parameter_count()],
    );
    let model = TaxelModel {
        taxel,
        strain_offset_pct: offset,
        elastic_g_per_pct: elastic_g,
        second_order,
        schedule,
        element,
        notch_hz: 0.0,
    };
    let report = TaxelFitReport {
        taxel: (taxel.row(), taxel.col()),
        fit_rms_g: [elastic.fit_rms_g, so_fit.fit_rms_g, nl.fit_rms_g],
        levels,
    };
    Ok((model, report))
}

/// The level the memo's own calibration used (its sum of sinusoids about 25 g).
const MEMO_LEVEL: usize = 1;

/// Level `k` of the calibration protocol as the part of `whole` a fit scores (its first
/// seconds left out), with its mean load.
fn level_series(whole: &Series, per_offset_s: f32, k: usize) -> (f64, Series) {
    let t0 = k as f64 * f64::from(per_offset_s) + SETTLE_S;
    let t1 = (k + 1) as f64 * f64::from(per_offset_s);
    let in_fit: Vec<bool> = (0..whole.force.len())
        .map(|i| (t0..t1).contains(&(i as f64 * whole.dt_s)))
        .collect();
    let n = in_fit.iter().filter(|b| **b).count().max(1) as f64;
    let load = whole
        .force
        .iter()
        .zip(&in_fit)
        .filter(|(_, b)| **b)
        .map(|(f, _)| f)
        .sum::<f64>()
        / n;
    let series = Series {
        in_fit,
        held_out_description: format!("all but {t0:.0}–{t1:.0} s"),
        ..whole.clone()
    };
    (load, series)
}

/// A model fitted about `load_g` with a strain intercept (the tangent to a stiffening curve)
/// rescaled to pass through the same static point with none (the secant): its compliance
/// scaled by (ε₀ + L/K)/(L/K), K its static stiffness b₂/a₂.
fn secant(so: &SecondOrder, load_g: f64, intercept_pct: f64) -> SecondOrder {
    let k = secant_factor(load_g * so.a2 / so.b2, intercept_pct);
    SecondOrder {
        b0: so.b0 / k,
        b1: so.b1 / k,
        b2: so.b2 / k,
        ..*so
    }
}

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

/// Writes `table` to `path` as the firmware reads it; returns its length in bytes.
pub fn write_table(path: &std::path::Path, table: &CalibrationTable) -> Result<usize, String> {
    let mut bytes = vec![0u8; table.encoded_len()];
    let n = table.encode(&mut bytes).map_err(|e| e.to_string())?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    std::fs::write(path, &bytes[..n]).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(n)
}

/// The calibration protocol run on the simulator with the probe over `taxel` of the finger
/// drawn from `seed` (the gauge's force and the probed taxel's strain, as the firmware
/// records them).
pub fn simulate_calibration(
    taxel: TaxelId,
    seed: u64,
    stiffening: f64,
) -> Result<Vec<TickRecord>, ScenarioError> {
    let mut config = RigConfig {
        seed,
        probe: taxel,
        scan_array: false,
        ..RigConfig::default()
    };
    config.effects.stiffening = stiffening;
    Ok(run_protocol("calibration", Protocol::CALIBRATION, config, false, |_| {})?.ticks)
}

/// Calibrates `taxels` of the simulated finger `seed` one after the other.
pub fn calibrate_simulated(
    taxels: &[TaxelId],
    seed: u64,
    stiffening: f64,
) -> Result<(CalibrationTable, Vec<TaxelFitReport>), String> {
    let mut table = CalibrationTable::default();
    let mut reports = Vec::new();
    for &taxel in taxels {
        let ticks = simulate_calibration(taxel, seed, stiffening).map_err(|e| e.to_string())?;
        let (force, strain): (Vec<f64>, Vec<f64>) = ticks
            .iter()
            .map(|t| (f64::from(t.sensed_g), f64::from(t.strain_pct)))
            .unzip();
        let (model, report) = fit_taxel(taxel, Protocol::CALIBRATION, 1e-3, &force, &strain)?;
        table
            .taxels
            .push(model)
            .map_err(|_| "more taxels than the array has".to_string())?;
        reports.push(report);
    }
    Ok((table, reports))
}
