//! A record's series as the fit sees it: the part the fit may see and the part held out.

use super::ModelSpec;
use crate::record::Record;
use tactile_ident::Series;

/// A record's series (force, strain and the samples at the rail, left out of everything),
/// with the fit/held-out split.
#[derive(Clone, Debug)]
pub struct Split {
    pub series: Series,
    /// true for samples the fit may see.
    pub in_fit: Vec<bool>,
    pub held_out_description: String,
}

/// Length of the blocks of the split, seconds.
pub const BLOCK_S: f64 = 10.0;

impl Split {
    /// Every fourth 10 s block (the 4th, 8th, …) is held out: 25 % of the record, spread over
    /// every regime it contains.
    pub fn from_record(r: &Record) -> Self {
        let series = Series {
            dt_s: r.sample_period_s().unwrap_or(0.005),
            force_g: r.force_g.clone(),
            strain_pct: r.strain_pct.clone(),
            excluded: crate::chip_diagnosis::at_top_rail(&r.strain_pct),
            intake: Default::default(),
        };
        Self::in_blocks(series)
    }

    /// A record checked as `tactile diagnose` checks it ([`crate::chip_diagnosis::series_of`]:
    /// finite and plausible values, long enough, a force and a strain that vary and follow
    /// each other), then split as [`Split::from_record`] splits it.
    pub fn checked(r: &Record) -> Result<Self, tactile_ident::Refusal> {
        Ok(Self::in_blocks(crate::chip_diagnosis::series_of(r)?))
    }

    /// `series` with every fourth [`BLOCK_S`] block held out.
    fn in_blocks(series: Series) -> Self {
        let (n, dt) = (series.force_g.len(), series.dt_s);
        let block = (BLOCK_S / dt).round().max(1.0) as usize;
        let in_fit = (0..n).map(|i| (i / block) % 4 != 3).collect();
        let held_out_description = if n > 3 * block {
            format!("every fourth {BLOCK_S:.0} s block (blocks 4, 8, 12, …: 25 % of the record)")
        } else {
            format!(
                "none: the record ({:.1} s) is too short to hold a block out (the first held out, \
                 the fourth {BLOCK_S:.0} s block, starts at {:.0} s; a whole one needs {:.0} s)",
                n as f64 * dt,
                3.0 * BLOCK_S,
                4.0 * BLOCK_S
            )
        };
        Self {
            series,
            in_fit,
            held_out_description,
        }
    }

    /// A whole record fitted without a held-out part (the memo's own procedure for its tables).
    pub fn whole(dt_s: f64, force_g: Vec<f64>, strain_pct: Vec<f64>) -> Self {
        let n = force_g.len();
        Self {
            series: Series {
                dt_s,
                force_g,
                strain_pct,
                excluded: vec![false; n],
                intake: Default::default(),
            },
            in_fit: vec![true; n],
            held_out_description: "none (the whole record is fitted, as in the memo)".into(),
        }
    }

    /// Predicted-strain RMS_n (g) of `spec` with parameters `theta` on this series, normalized
    /// by `g1`.
    pub fn rms_n_g(&self, spec: &ModelSpec, theta: &[f64], g1: f64) -> Option<f64> {
        let p = spec.simulate(theta, self)?;
        let ms = p
            .iter()
            .zip(&self.series.strain_pct)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / p.len().max(1) as f64;
        Some(g1 * ms.sqrt())
    }

    pub(super) fn secant_g_per_pct(&self) -> f64 {
        let (f, e): (f64, f64) = self
            .series
            .force_g
            .iter()
            .zip(&self.series.strain_pct)
            .fold((0.0, 0.0), |(a, b), (f, s)| (a + f * s, b + s * s));
        if e > 0.0 && f > 0.0 {
            f / e
        } else {
            4.0
        }
    }
}
