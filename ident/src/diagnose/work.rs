//! The regressors of a record and what is read from a fit of them: residuals, their tests,
//! the force-driven part of a prediction; the baseline's columns.

use crate::residual::{residual_tests, ResidualTests};
use crate::series::Series;
use crate::solve::{Pool, Sign};
use crate::{par, stats, terms};

use super::Term;

/// The record's regressors, each with its term.
pub(super) struct Work<'a> {
    pub(super) s: &'a Series,
    pub(super) pool: Pool,
    pub(super) terms: Vec<Term>,
    pub(super) kept: Vec<bool>,
    /// The (smoothed) force at the samples that count (what the residual is tested against).
    pub(super) force_kept: Vec<f64>,
    /// The force as measured at those samples: its lines are the excitation's, not
    /// interference (the smoothed force has no spectrum left above its passband to compare).
    pub(super) measured_force_kept: Vec<f64>,
    pub(super) force_scale: f64,
    pub(super) force_origin: f64,
}

impl Work<'_> {
    /// Adds a term of stored values; returns its column.
    pub(super) fn add(&mut self, term: Term, values: &[f64], sign: Sign) -> usize {
        self.add_stored(term, values.iter().map(|v| *v as f32).collect(), sign)
    }

    /// Adds a term of values already as the pool stores them; returns its column.
    pub(super) fn add_stored(&mut self, term: Term, values: Vec<f32>, sign: Sign) -> usize {
        let name = format!("{term:?}");
        let j = self.pool.add_stored(name, values, sign);
        self.terms.push(term);
        j
    }

    /// [`Work::add_computed`] of a recipe that gives the values as the pool stores them.
    pub(super) fn add_computed_stored(
        &mut self,
        term: Term,
        recipe: impl Fn() -> Vec<f32> + Send + Sync + 'static,
        sign: Sign,
    ) -> usize {
        let j = self.pool.add_computed(format!("{term:?}"), recipe, sign);
        self.terms.push(term);
        j
    }

    /// Adds a term computed from `recipe` wherever it is read (see `Pool::add_computed`).
    pub(super) fn add_computed(
        &mut self,
        term: Term,
        recipe: impl Fn() -> Vec<f64> + Send + Sync + 'static,
        sign: Sign,
    ) -> usize {
        let recipe = move || recipe().into_iter().map(|v| v as f32).collect();
        self.add_computed_stored(term, recipe, sign)
    }

    /// Adds column `c` delayed by `delay_s` (a view of it, the same term; so are the views a
    /// fraction of a sample brings).
    pub(super) fn add_delayed(&mut self, c: usize, delay_s: f64) -> usize {
        let j = self.pool.add_delayed(c, delay_s / self.s.dt_s);
        let term = self.terms[c];
        self.terms.resize(self.pool.columns(), term);
        j
    }

    /// The residual of `cols` with `beta` at the samples that count.
    pub(super) fn residual(&self, cols: &[usize], beta: &[f64]) -> Vec<f64> {
        // In place over the prediction: a 600 s record at 1 kHz has no room for two copies.
        let mut r = self.pool.predict(cols, beta);
        let mut n = 0;
        for i in 0..r.len() {
            if self.kept[i] {
                r[n] = r[i] - self.pool.y()[i];
                n += 1;
            }
        }
        r.truncate(n);
        r
    }

    /// The residual's tests (`residual_tests`) of `cols` with `beta`.
    pub(super) fn tests(&self, cols: &[usize], beta: &[f64]) -> ResidualTests {
        residual_tests(
            &self.residual(cols, beta),
            &self.force_kept,
            &self.measured_force_kept,
            self.s.dt_s,
        )
    }

    /// Ljung–Box ratio and colored power (the residual's variance that its own past predicts)
    /// on the common time scale.
    pub(super) fn whiteness(&self, cols: &[usize], beta: &[f64]) -> (f64, f64) {
        let r = crate::residual::on_common_scale(&self.residual(cols, beta), self.s.dt_s);
        let acf = stats::acf(&r, crate::residual::PORTMANTEAU_LAGS);
        let lb = stats::ljung_box(&acf, r.len(), crate::residual::PORTMANTEAU_LAGS).1;
        let var = stats::mean(&r.iter().map(|v| v * v).collect::<Vec<_>>());
        (lb, var * (1.0 - stats::innovation_share(&acf)))
    }

    /// Force-driven part of the prediction of `cols` with `beta`.
    pub(super) fn force_part(&self, cols: &[usize], beta: &[f64]) -> Vec<f64> {
        let (c, b): (Vec<usize>, Vec<f64>) = cols
            .iter()
            .zip(beta)
            .filter(|(c, _)| self.terms[**c].force_driven())
            .map(|(c, b)| (*c, *b))
            .unzip();
        self.pool.predict(&c, &b)
    }
}

/// The grid of time constants from `lo` to `hi`, `per_decade` a decade.
pub(super) fn grid(lo: f64, hi: f64, per_decade: f64) -> Vec<f64> {
    if hi < lo {
        return Vec::new();
    }
    let steps = ((hi / lo).log10() * per_decade).ceil().max(1.0) as usize;
    (0..=steps)
        .map(|i| lo * (hi / lo).powf(i as f64 / steps as f64))
        .collect()
}

/// The baseline's creep: eq. 11's permanent creep (the Maxwell dashpot alone), or eq. 14's,
/// levelling off with time constant N₁/α (s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Creep {
    Permanent,
    Alpha(f64),
}

/// Builds the baseline's columns into `work` (offset, elastic, the Kelvin branches of `taus`,
/// the creep last); returns them.
pub(super) fn baseline_columns(work: &mut Work, taus: &[f64], creep: Creep) -> Vec<usize> {
    let f = work.s.force_g.clone();
    let mut cols = vec![
        work.add(Term::Offset, &vec![1.0; f.len()], Sign::Free),
        work.add(Term::Elastic, &f, Sign::NonNegative),
    ];
    cols.extend(relaxation_columns(work, &f, taus));
    cols.push(creep_column(work, creep));
    cols
}

/// Kelvin branches of force `f` at the time constants `taus`, stored.
pub(super) fn relaxation_columns(work: &mut Work, f: &[f64], taus: &[f64]) -> Vec<usize> {
    let dt = work.s.dt_s;
    let branch = |tau: f64| -> Vec<f32> {
        let v = terms::lowpass(f, tau, dt);
        v.iter().map(|x| *x as f32).collect()
    };
    let built = par::map(taus, |&tau| branch(tau));
    taus.iter()
        .zip(built)
        .map(|(&tau, v)| work.add_stored(Term::Relaxation(tau), v, Sign::NonNegative))
        .collect()
}

/// The baseline's creep column.
pub(super) fn creep_column(work: &mut Work, creep: Creep) -> usize {
    let (f, dt) = (&work.s.force_g, work.s.dt_s);
    match creep {
        Creep::Permanent => {
            let v = terms::integral(f, dt, work.s.duration_s());
            work.add(Term::Creep, &v, Sign::NonNegative)
        }
        Creep::Alpha(tau) => {
            let v = terms::lowpass(f, tau, dt);
            work.add(Term::Alpha(tau), &v, Sign::NonNegative)
        }
    }
}
