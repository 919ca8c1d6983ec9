//! A record as the identification sees it: checked once, then split into contiguous folds.

use serde::Serialize;
use thiserror::Error;

use crate::stats;

/// Fewest samples a record needs: four folds of 25.
pub const MIN_SAMPLES: usize = 100;
/// Largest plausible force magnitude, grams (ten tonnes: anything beyond is a unit error).
pub const MAX_FORCE_G: f64 = 1e7;
/// Largest plausible strain magnitude, percent.
pub const MAX_STRAIN_PCT: f64 = 1e5;

/// Why a record cannot be identified. Each says what was found, so the user can mend the file.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum Refusal {
    #[error("the sample period is {dt_s} s: a tactile record is sampled between 1 Hz and 1 MHz (is t_s in seconds?)")]
    BadPeriod { dt_s: f64 },
    #[error("the force and strain columns differ in length ({force} and {strain} samples)")]
    Lengths { force: usize, strain: usize },
    #[error("too short to identify: {samples} usable samples ({seconds:.2} s); at least {min} are needed (four held-out folds of 25)")]
    TooShort {
        samples: usize,
        seconds: f64,
        min: usize,
    },
    #[error("{column} at sample {index} is {value}, not a finite number")]
    NonFinite {
        column: &'static str,
        index: usize,
        value: f64,
    },
    #[error("{column} at sample {index} is {value:e}: beyond any plausible value (|{column}| ≤ {limit:e}); check the column's unit")]
    AbsurdScale {
        column: &'static str,
        index: usize,
        value: f64,
        limit: f64,
    },
    #[error("the force does not vary (1–99 % spread {spread:e} g): a record under constant or no load says nothing about the sensor's dynamics")]
    ForceConstant { spread: f64 },
    #[error("the strain does not vary (1–99 % spread {spread:e} %): the sensor did not respond, or the column is not its output")]
    StrainConstant { spread: f64 },
    #[error("the strain does not follow the force (correlation {correlation:.3} even after 10 s of smoothing): nothing to identify between these two columns")]
    NoResponse { correlation: f64 },
}

/// Every force and strain finite and within a plausible magnitude ([`MAX_FORCE_G`],
/// [`MAX_STRAIN_PCT`]): the first of [`Series::new`]'s checks, and the whole of it for a use
/// that needs no variation (running the chip's estimators over a record).
pub fn check_scale(force_g: &[f64], strain_pct: &[f64]) -> Result<(), Refusal> {
    for (column, values, limit) in [
        ("force_g", force_g, MAX_FORCE_G),
        ("strain_pct", strain_pct, MAX_STRAIN_PCT),
    ] {
        for (index, &value) in values.iter().enumerate() {
            if !value.is_finite() {
                return Err(Refusal::NonFinite {
                    column,
                    index,
                    value,
                });
            }
            if value.abs() > limit {
                return Err(Refusal::AbsurdScale {
                    column,
                    index,
                    value,
                    limit,
                });
            }
        }
    }
    Ok(())
}

/// The sample periods a record of a tactile sensor can have, s: 1 MHz to 1 Hz. Outside, the
/// time column is not in seconds (milliseconds read as seconds put a 1 kHz record at 1 Hz).
pub const PERIOD_RANGE_S: (f64, f64) = (1e-6, 1.0);

/// Refuses a sample period outside [`PERIOD_RANGE_S`].
pub fn check_period(dt_s: f64) -> Result<(), Refusal> {
    if (PERIOD_RANGE_S.0..=PERIOD_RANGE_S.1).contains(&dt_s) {
        Ok(())
    } else {
        Err(Refusal::BadPeriod { dt_s })
    }
}

/// How a record was taken in before the identification, for the report: its time stamps
/// mended on reading, and why samples are left out.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Intake {
    /// The reader's resampling of jittered stamps and merging of rows stamped alike; `None`:
    /// the record as written.
    pub resampling: Option<tactile_record::Resampling>,
    /// Samples at the strain's converter rail.
    pub rail_samples: usize,
    /// Samples a logger repeated instead of reading (`tactile_record::held_values`), and in
    /// how many runs.
    pub held_samples: usize,
    pub held_runs: usize,
}

/// A checked record: evenly sampled force (g) and strain (%), with the samples to leave out of
/// every fit and score (the strain at its converter's rail, a logger's held values).
#[derive(Clone, Debug)]
pub struct Series {
    pub dt_s: f64,
    pub force_g: Vec<f64>,
    pub strain_pct: Vec<f64>,
    pub excluded: Vec<bool>,
    pub intake: Intake,
}

impl Series {
    /// Checks a record. `excluded` may be empty (nothing left out).
    pub fn new(
        dt_s: f64,
        force_g: Vec<f64>,
        strain_pct: Vec<f64>,
        excluded: Vec<bool>,
    ) -> Result<Series, Refusal> {
        check_period(dt_s)?;
        if force_g.len() != strain_pct.len() {
            return Err(Refusal::Lengths {
                force: force_g.len(),
                strain: strain_pct.len(),
            });
        }
        let excluded = if excluded.len() == force_g.len() {
            excluded
        } else {
            vec![false; force_g.len()]
        };
        check_scale(&force_g, &strain_pct)?;
        let usable = excluded.iter().filter(|x| !**x).count();
        if usable < MIN_SAMPLES {
            return Err(Refusal::TooShort {
                samples: usable,
                seconds: usable as f64 * dt_s,
                min: MIN_SAMPLES,
            });
        }
        let kept = |v: &[f64]| -> Vec<f64> {
            v.iter()
                .zip(&excluded)
                .filter(|(_, x)| !**x)
                .map(|(a, _)| *a)
                .collect()
        };
        let (f, e) = (kept(&force_g), kept(&strain_pct));
        let spread = |v: &[f64]| stats::quantile(v, 0.99) - stats::quantile(v, 0.01);
        let scale = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let (fs, es) = (spread(&f), spread(&e));
        // Relative to the column's own size, so a unit change does not move the verdict.
        if fs <= 1e-9 * scale(&f).max(f64::MIN_POSITIVE) || fs == 0.0 {
            return Err(Refusal::ForceConstant { spread: fs });
        }
        if es <= 1e-9 * scale(&e).max(f64::MIN_POSITIVE) || es == 0.0 {
            return Err(Refusal::StrainConstant { spread: es });
        }
        // A slow sensor lags, so compare both smoothed over 10 s (or a tenth of the record).
        let w = ((10.0 / dt_s) as usize).clamp(1, f.len() / 10);
        let correlation =
            stats::correlation(&stats::moving_mean(&f, w), &stats::moving_mean(&e, w))
                .abs()
                .max(stats::correlation(&f, &e).abs());
        if correlation.is_nan() || correlation < 0.1 {
            return Err(Refusal::NoResponse { correlation });
        }
        Ok(Series {
            dt_s,
            force_g,
            strain_pct,
            excluded,
            intake: Intake::default(),
        })
    }

    /// A logger's record checked: `rail` (the strain's converter rail) and the values the
    /// logger held ([`tactile_record::held_values`]) left out, a held force bridged (the
    /// models' input needs a value at every sample), and the reader's `resampling` kept for
    /// the report.
    pub fn logged(
        dt_s: f64,
        mut force_g: Vec<f64>,
        strain_pct: Vec<f64>,
        rail: Vec<bool>,
        resampling: Option<tactile_record::Resampling>,
    ) -> Result<Series, Refusal> {
        let rail = if rail.len() == force_g.len() {
            rail
        } else {
            vec![false; force_g.len()]
        };
        let held_force = tactile_record::held_values(&force_g);
        let held: Vec<bool> = held_force
            .iter()
            .zip(tactile_record::held_values(&strain_pct))
            .zip(&rail)
            .map(|((f, s), at_rail)| (*f || s) && !at_rail)
            .collect();
        let intake = Intake {
            resampling,
            rail_samples: rail.iter().filter(|x| **x).count(),
            held_samples: held.iter().filter(|x| **x).count(),
            held_runs: tactile_record::runs_of(&held),
        };
        tactile_record::bridge_held(&mut force_g, &held_force);
        let excluded = rail.iter().zip(&held).map(|(a, b)| *a || *b).collect();
        Ok(Series::new(dt_s, force_g, strain_pct, excluded)?.with_intake(intake))
    }

    /// The series with how its record was taken in (its samples left out already in
    /// `excluded`).
    pub fn with_intake(self, intake: Intake) -> Series {
        Series { intake, ..self }
    }

    pub fn len(&self) -> usize {
        self.force_g.len()
    }
    pub fn is_empty(&self) -> bool {
        self.force_g.is_empty()
    }
    pub fn duration_s(&self) -> f64 {
        self.len() as f64 * self.dt_s
    }
    /// Values of `v` at the samples that count.
    pub fn kept(&self, v: &[f64]) -> Vec<f64> {
        // Sized first: a filter's collect grows by doubling (8 MB for 4.8 on a long record).
        let mut out = Vec::with_capacity(self.excluded.iter().filter(|x| !**x).count());
        out.extend(
            v.iter()
                .zip(&self.excluded)
                .filter(|(_, x)| !**x)
                .map(|(a, _)| *a),
        );
        out
    }
}

/// Fewest and most folds.
pub const MIN_FOLDS: usize = 4;
pub const MAX_FOLDS: usize = 10;

/// Contiguous blocks of the record, each held out in turn: the same folds for every model.
#[derive(Clone, Debug)]
pub struct Folds {
    /// Sample ranges `[start, end)`, in order.
    pub ranges: Vec<(usize, usize)>,
    /// Usable samples in each fold.
    pub counts: Vec<usize>,
}

impl Folds {
    /// Block length from the record's length and its slowest time constant: two slowest time
    /// constants (so a held-out block shows a whole relaxation), but between a tenth and a quarter
    /// of the record, hence 4 to 10 folds.
    pub fn for_record(series: &Series, slowest_tau_s: f64) -> Folds {
        Folds::for_record_within(series, slowest_tau_s, f64::INFINITY)
    }

    /// As [`Folds::for_record`], but blocks no longer than `longest_block_s` (more than ten
    /// folds where the record is longer than ten such blocks).
    pub fn for_record_within(series: &Series, slowest_tau_s: f64, longest_block_s: f64) -> Folds {
        let t = series.duration_s();
        let most = MAX_FOLDS.max((t / longest_block_s).ceil() as usize);
        let block = (2.0 * slowest_tau_s)
            .clamp(t / most as f64, t / MIN_FOLDS as f64)
            .min(longest_block_s);
        let k = ((t / block).round() as usize)
            .max((t / longest_block_s).ceil() as usize)
            .clamp(MIN_FOLDS, most);
        Folds::blocked(&series.excluded, k)
    }

    /// `k` contiguous folds of (nearly) equal length.
    pub fn blocked(excluded: &[bool], k: usize) -> Folds {
        let n = excluded.len();
        let ranges: Vec<(usize, usize)> = (0..k).map(|j| (j * n / k, (j + 1) * n / k)).collect();
        let counts = ranges
            .iter()
            .map(|&(a, b)| excluded[a..b].iter().filter(|x| !**x).count())
            .collect();
        Folds { ranges, counts }
    }

    pub fn len(&self) -> usize {
        self.ranges.len()
    }
    pub fn is_empty(&self) -> bool {
        self.ranges.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| (i as f64 * 0.1).sin() * 10.0 + 20.0)
            .collect()
    }

    #[test]
    fn bad_records_are_refused_with_the_reason() {
        let f = ramp(1000);
        let e: Vec<f64> = f.iter().map(|x| x * 0.25).collect();
        assert!(Series::new(0.01, f.clone(), e.clone(), vec![]).is_ok());
        assert!(matches!(
            Series::new(0.01, vec![0.0; 1000], vec![0.0; 1000], vec![]),
            Err(Refusal::ForceConstant { .. })
        ));
        assert!(matches!(
            Series::new(0.01, f.clone(), vec![1.0; 1000], vec![]),
            Err(Refusal::StrainConstant { .. })
        ));
        assert!(matches!(
            Series::new(0.01, f[..2].to_vec(), e[..2].to_vec(), vec![]),
            Err(Refusal::TooShort { samples: 2, .. })
        ));
        let mut huge = e.clone();
        huge[7] = 1e30;
        let r = Series::new(0.01, f.clone(), huge, vec![]).unwrap_err();
        assert!(matches!(r, Refusal::AbsurdScale { index: 7, .. }), "{r}");
        assert!(r.to_string().contains("sample 7"));
        let mut nan = f.clone();
        nan[3] = f64::NAN;
        assert!(matches!(
            Series::new(0.01, nan, e.clone(), vec![]),
            Err(Refusal::NonFinite { index: 3, .. })
        ));
        // Noise that does not follow the force.
        let noise: Vec<f64> = (0..1000).map(|i| ((i * 7919) % 101) as f64).collect();
        assert!(matches!(
            Series::new(0.01, f, noise, vec![]),
            Err(Refusal::NoResponse { .. })
        ));
    }

    #[test]
    fn folds_are_contiguous_and_between_four_and_ten() {
        let f = ramp(24_000);
        let e: Vec<f64> = f.iter().map(|x| x * 0.25).collect();
        let s = Series::new(0.01, f, e, vec![]).unwrap();
        // 240 s, slowest τ 10 s: 20 s blocks → 10 folds (clamped by T/10 = 24 s).
        let folds = Folds::for_record(&s, 10.0);
        assert_eq!(folds.len(), 10);
        assert_eq!(folds.ranges[0], (0, 2400));
        assert_eq!(folds.ranges[9].1, 24_000);
        // Slowest τ 40 s: 80 s blocks → 3, raised to 4.
        assert_eq!(Folds::for_record(&s, 40.0).len(), 4);
        // Slowest τ 15 s: 30 s blocks → 8 folds.
        assert_eq!(Folds::for_record(&s, 15.0).len(), 8);
        // Blocks of at most 15 s: 16 folds, though 2τ is 20 s; 14 s: 18 (not 17 of 14.1 s);
        // at most 45 s changes nothing on 240 s.
        assert_eq!(Folds::for_record_within(&s, 10.0, 15.0).len(), 16);
        assert_eq!(Folds::for_record_within(&s, 10.0, 14.0).len(), 18);
        assert_eq!(Folds::for_record_within(&s, 10.0, 45.0).len(), 10);
    }
}
