//! Force estimators side by side on the simulator: the elastic model, the memo's
//! inverted second-order model, the scheduled inverse and the observer — the core's
//! [`TaxelEstimators`], exactly as the firmware runs them per taxel at the scan rate — with
//! the memo's nominal models and with each taxel's own dynamic calibration, on four taxels of
//! one simulated finger. The structural inverse (the calibrated eq. 14 element run backwards,
//! `f64`, host only) is the reference.

use std::fmt::Write as _;

use serde::Serialize;
use tactile_core::calibration::CalibrationTable;
use tactile_core::estimator::StructuralInverse;
use tactile_core::estimator::TaxelModel;
use tactile_core::estimator::{EstimatorKind, TaxelEstimators};
use tactile_core::profile::Protocol;
use tactile_core::tactile::ScanConfig;

use crate::dynamic_calibration::CalibrationError;
use crate::dynamic_calibration::{calibrate_simulated, TaxelFitReport, CALIBRATION_TAXELS};
use crate::finger::Effects;
use crate::fingers::FingerKind;
use crate::rig::TickRecord;
use crate::scenario::{protocol, ScenarioOptions};

/// The protocols of the table: the memo's pseudo-random record, its four step loads, its sum
/// of sinusoids.
pub const PROTOCOLS: [&str; 3] = ["pseudo-random", "step-loads", "sines"];

/// Control ticks per scan frame: each taxel is sampled once a frame (16 ms).
pub const TICKS_PER_FRAME: usize = 16;

/// Columns: the four on-chip estimators, then the host-only structural inverse.
pub const COLUMNS: usize = 5;

#[derive(Clone, Debug, Serialize)]
pub struct EstimatorTable {
    pub taxels: Vec<(usize, usize)>,
    /// `nominal_g[protocol][column]`, `calibrated_g[protocol][column]`: RMS of estimate − true
    /// contact force (g), mean over the taxels.
    pub nominal_g: Vec<[f64; COLUMNS]>,
    pub calibrated_g: Vec<[f64; COLUMNS]>,
    /// Pseudo-random, calibrated, per taxel.
    pub pseudo_random_per_taxel_g: Vec<[f64; COLUMNS]>,
    /// Largest estimate above 30 g in the first 5 s of a 30 g step, worst over the taxels,
    /// calibrated.
    pub overshoot_30g_rise_g: [f64; COLUMNS],
    pub fits: Vec<TaxelFitReport>,
}

pub fn column_names() -> [&'static str; COLUMNS] {
    let k = EstimatorKind::ALL.map(EstimatorKind::name);
    [k[0], k[1], k[2], k[3], "structural inverse (host, f64)"]
}

/// Each column's estimate at each frame of a run (the probed taxel sampled every 16 ticks).
fn estimates(
    ticks: &[TickRecord],
    model: &TaxelModel,
    frame_s: f64,
) -> Result<Vec<[f64; COLUMNS]>, CalibrationError> {
    let mut chip =
        TaxelEstimators::new(model, frame_s).map_err(|source| CalibrationError::Model {
            taxel: model.taxel,
            source,
        })?;
    let mut structural = StructuralInverse::new(model.element, frame_s);
    Ok(frames(ticks)
        .map(|t| {
            let f = chip.update(t.strain_pct);
            let s = structural.force_g(chip.corrected(t.strain_pct));
            [f[0], f[1], f[2], f[3], s].map(f64::from)
        })
        .collect())
}

fn frames(ticks: &[TickRecord]) -> impl Iterator<Item = &TickRecord> {
    ticks
        .iter()
        .skip(TICKS_PER_FRAME - 1)
        .step_by(TICKS_PER_FRAME)
}

fn rms(est: &[[f64; COLUMNS]], ticks: &[TickRecord]) -> [f64; COLUMNS] {
    let mut sum = [0.0; COLUMNS];
    for (e, t) in est.iter().zip(frames(ticks)) {
        for (s, v) in sum.iter_mut().zip(e) {
            *s += (v - f64::from(t.true_force_g)).powi(2);
        }
    }
    sum.map(|s| (s / est.len().max(1) as f64).sqrt())
}

/// Calibrates the four taxels of the simulated finger `finger_seed` (`FINGER_SEED` in the
/// report) of kind `finger`, then scores every estimator on each.
pub fn compare(finger_seed: u64, finger: FingerKind) -> Result<EstimatorTable, crate::Error> {
    let (table, fits) = calibrate_simulated(&CALIBRATION_TAXELS, finger_seed, finger.effects())?;
    compare_with(&table, fits, finger_seed, finger.effects())
}

/// [`compare`] on the memo's finger with the table the firmware builds carry instead of a
/// fresh calibration: the same table (a test holds them byte for byte), without the fits' 20 s.
pub fn compare_firmware_table() -> Result<EstimatorTable, crate::Error> {
    let table = CalibrationTable::decode(FIRMWARE_CALIBRATION_TABLE)
        .map_err(|e| crate::Error::Failed(format!("boards/calibration/table.bin: {e}")))?;
    compare_with(
        &table,
        Vec::new(),
        crate::dynamic_calibration::FINGER_SEED,
        FingerKind::Memo.effects(),
    )
}

/// The calibration table the firmware builds carry: `tactile calibrate`'s for the memo's
/// finger ([`crate::dynamic_calibration::FINGER_SEED`]).
pub const FIRMWARE_CALIBRATION_TABLE: &[u8] = include_bytes!("../../boards/calibration/table.bin");

/// Scores every estimator on the taxels of `table`, nominal and calibrated, on the finger
/// `finger_seed` with `effects`.
pub fn compare_with(
    table: &CalibrationTable,
    fits: Vec<TaxelFitReport>,
    finger_seed: u64,
    effects: Effects,
) -> Result<EstimatorTable, crate::Error> {
    let frame_s = f64::from(ScanConfig::DESIGN.frame_period_s());
    let n = table.taxels.len().max(1) as f64;
    let mut out = EstimatorTable {
        taxels: table
            .taxels
            .iter()
            .map(|m| (m.taxel.row(), m.taxel.col()))
            .collect(),
        nominal_g: vec![[0.0; COLUMNS]; PROTOCOLS.len()],
        calibrated_g: vec![[0.0; COLUMNS]; PROTOCOLS.len()],
        pseudo_random_per_taxel_g: Vec::new(),
        overshoot_30g_rise_g: [f64::MIN; COLUMNS],
        fits,
    };
    let options = ScenarioOptions::default();
    for model in &table.taxels {
        // Element 4,2's models; the strain offset is the rest calibration's (none).
        let nominal = TaxelModel::nominal(model.taxel);
        for (k, name) in PROTOCOLS.iter().enumerate() {
            let p = protocol(name, &options)?;
            let ticks = crate::scenario::run_on_taxel(name, p, model.taxel, finger_seed, effects)?;
            let cal = rms(&estimates(&ticks, model, frame_s)?, &ticks);
            let nom = rms(&estimates(&ticks, &nominal, frame_s)?, &ticks);
            for c in 0..COLUMNS {
                out.calibrated_g[k][c] += cal[c] / n;
                out.nominal_g[k][c] += nom[c] / n;
            }
            if k == 0 {
                out.pseudo_random_per_taxel_g.push(cal);
            }
        }
        let step = Protocol::Step {
            load_g: 30.0,
            lead_s: 2.0,
            on_s: 50.0,
            off_s: 25.0,
        };
        let ticks = crate::scenario::run_on_taxel("step", step, model.taxel, finger_seed, effects)?;
        let est = estimates(&ticks, model, frame_s)?;
        // The step is applied at 2 s: its first 5 s, in frames.
        let window = (2.0 / frame_s) as usize..(7.0 / frame_s) as usize;
        for c in 0..COLUMNS {
            let peak = est[window.clone()]
                .iter()
                .fold(f64::MIN, |m, e| m.max(e[c]));
            out.overshoot_30g_rise_g[c] = out.overshoot_30g_rise_g[c].max(peak - 30.0);
        }
    }
    Ok(out)
}

pub fn render(t: &EstimatorTable) -> String {
    let names = column_names();
    let mut s = format!(
        "RMS of estimate − true contact force (g), mean over taxels {:?} of one simulated finger, each estimator run on the probed taxel at the scan rate (62.5 frames/s) as the firmware runs it. \"nominal\": the memo's models for element 4,2 (Table IV's fit, Table I's rows, FACTS.md's laws); \"calibrated\": the taxel's own fit of the calibration protocol (`tactile calibrate`). The memo's inverse had 2.23 g on its pseudo-random record.\n\n| protocol |",
        t.taxels
    );
    for n in names {
        let _ = write!(s, " {n}, nominal | {n}, calibrated |");
    }
    s.push_str("\n|---|");
    s.push_str(&"---|".repeat(2 * COLUMNS));
    s.push('\n');
    for (k, name) in PROTOCOLS.iter().enumerate() {
        let _ = write!(s, "| {name} |");
        for c in 0..COLUMNS {
            let _ = write!(
                s,
                " {:.3} | {:.3} |",
                t.nominal_g[k][c], t.calibrated_g[k][c]
            );
        }
        s.push('\n');
    }
    let _ = write!(s, "\nPseudo-random, calibrated, per taxel:\n\n| taxel |");
    for n in names {
        let _ = write!(s, " {n} |");
    }
    s.push_str("\n|---|");
    s.push_str(&"---|".repeat(COLUMNS));
    s.push('\n');
    for (taxel, row) in t.taxels.iter().zip(&t.pseudo_random_per_taxel_g) {
        let _ = writeln!(
            s,
            "| {taxel:?} | {} |",
            row.map(|v| format!("{v:.3}")).join(" | ")
        );
    }
    let _ = writeln!(
        s,
        "\nOvershoot on the memo's 30 g rise (largest estimate − 30 g in the 5 s after the step, worst taxel, calibrated): {}",
        names
            .iter()
            .zip(t.overshoot_30g_rise_g)
            .map(|(n, v)| format!("{n} {v:+.2} g"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    s
}
