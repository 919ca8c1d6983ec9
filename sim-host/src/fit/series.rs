//! A record's force and strain as the fit sees them, with the part held out of the fit.

use super::ModelSpec;
use crate::record::Record;

/// A record's force and strain, with the fit/held-out split.
#[derive(Clone, Debug)]
pub struct Series {
    pub dt_s: f64,
    pub force: Vec<f64>,
    pub strain: Vec<f64>,
    /// true for samples the fit may see.
    pub in_fit: Vec<bool>,
    /// true for samples neither fitted nor scored (the strain at its converter's rail).
    pub excluded: Vec<bool>,
    pub held_out_description: String,
}

/// Length of the blocks of the split, seconds.
pub const BLOCK_S: f64 = 10.0;

impl Series {
    /// Every fourth 10 s block (the 4th, 8th, …) is held out: 25 % of the record, spread over
    /// every regime it contains.
    pub fn from_record(r: &Record) -> Self {
        let dt = r.sample_period_s().unwrap_or(0.005);
        let block = (BLOCK_S / dt).round().max(1.0) as usize;
        let in_fit = (0..r.len()).map(|i| (i / block) % 4 != 3).collect();
        let held_out_description = if r.len() > 3 * block {
            format!("every fourth {BLOCK_S:.0} s block (blocks 4, 8, 12, …: 25 % of the record)")
        } else {
            format!(
                "none: the record ({:.1} s) is too short to hold a block out (the first held out, \
                 the fourth {BLOCK_S:.0} s block, starts at {:.0} s; a whole one needs {:.0} s)",
                r.len() as f64 * dt,
                3.0 * BLOCK_S,
                4.0 * BLOCK_S
            )
        };
        Self {
            dt_s: dt,
            force: r.force_g.clone(),
            strain: r.strain_pct.clone(),
            in_fit,
            excluded: crate::chip_diagnosis::at_top_rail(&r.strain_pct),
            held_out_description,
        }
    }

    /// A record checked as `tactile diagnose` checks it ([`crate::chip_diagnosis::series_of`]: finite
    /// and plausible values, long enough, a force and a strain that vary and follow each
    /// other), then split as [`Series::from_record`] splits it.
    pub fn checked(r: &Record) -> Result<Self, tactile_ident::Refusal> {
        let checked = crate::chip_diagnosis::series_of(r)?;
        Ok(Self {
            excluded: checked.excluded,
            ..Self::from_record(r)
        })
    }
    /// A whole record fitted without a held-out part (the memo's own procedure for its tables).
    pub fn whole(dt_s: f64, force: Vec<f64>, strain: Vec<f64>) -> Self {
        let n = force.len();
        Self {
            dt_s,
            force,
            strain,
            in_fit: vec![true; n],
            excluded: vec![false; n],
            held_out_description: "none (the whole record is fitted, as in the memo)".into(),
        }
    }

    /// Predicted-strain RMS_n (g) of `spec` with parameters `theta` on this series, normalized
    /// by `g1`.
    pub fn rms_n_g(&self, spec: &ModelSpec, theta: &[f64], g1: f64) -> Option<f64> {
        let p = spec.simulate(theta, self)?;
        let ms = p
            .iter()
            .zip(&self.strain)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / p.len().max(1) as f64;
        Some(g1 * ms.sqrt())
    }

    pub(super) fn secant_g_per_pct(&self) -> f64 {
        let (f, e): (f64, f64) = self
            .force
            .iter()
            .zip(&self.strain)
            .fold((0.0, 0.0), |(a, b), (f, s)| (a + f * s, b + s * s));
        if e > 0.0 && f > 0.0 {
            f / e
        } else {
            4.0
        }
    }
}
