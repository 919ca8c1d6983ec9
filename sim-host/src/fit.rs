//! Fitting the memo's models (and their augmentations) to a record: strain simulated from the
//! measured force with the core library's discrete models, parameters found by
//! Levenberg–Marquardt (the `levenberg-marquardt` crate) from several starts, positivity by
//! fitting logarithms, uncertainty from the Jacobian at the optimum, and the error reported
//! on a held-out part of the record the fit did not see.

mod split;

use crate::least_squares::{minimize, Problem, Residuals};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use tactile_core::viscoelastic::{
    Discrete2State, MaxwellKelvin, NonlinearMk, NonlinearMkState, SecondOrder, SpringLaw,
};

pub use split::*;

/// The memo's base models (the names `tactile fit --model` takes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Base {
    Elastic,
    MaxwellKelvin,
    MkAlpha,
    SecondOrder,
    /// Eq. 14 with load-dependent springs, G₁(σ) = a + b√σ and G₂(σ) = c + dσ (the core's
    /// `NonlinearMk`): the model a taxel's dynamic calibration fits.
    MkNonlinear,
}

impl Base {
    pub const ALL: [Base; 5] = [
        Base::Elastic,
        Base::MaxwellKelvin,
        Base::MkAlpha,
        Base::SecondOrder,
        Base::MkNonlinear,
    ];
    pub fn name(self) -> &'static str {
        match self {
            Base::Elastic => "elastic",
            Base::MaxwellKelvin => "maxwell-kelvin",
            Base::MkAlpha => "mk-alpha",
            Base::SecondOrder => "second-order",
            Base::MkNonlinear => "mk-nonlinear",
        }
    }
    /// The model called `name` (the names clap offers for `--model`).
    pub fn parse(name: &str) -> Result<Base, String> {
        <Base as clap::ValueEnum>::from_str(name, false).map_err(|_| {
            format!(
                "unknown model '{name}'; valid models: {}",
                Base::ALL.map(Base::name).join(", ")
            )
        })
    }
    /// Plausible ranges of the physical parameters (the fit works inside them).
    fn bounds(self) -> &'static [(f64, f64)] {
        match self {
            Base::Elastic => &[(0.05, 500.0)],
            Base::MaxwellKelvin => &[(0.05, 500.0), (10.0, 1e7), (0.1, 1e5), (0.05, 1e4)],
            Base::MkAlpha => &[
                (0.05, 500.0),
                (10.0, 1e7),
                (0.1, 1e5),
                (0.05, 1e4),
                (1e-4, 1e3),
            ],
            Base::SecondOrder => &[
                (1e-7, 1e4),
                (1e-9, 1e4),
                (0.05, 500.0),
                (1e-7, 1e5),
                (1e-9, 1e5),
            ],
            // α at most 30 g/%: the permanent deformation recovers over many minutes (the
            // memo still sees it after 80 s of rest), N₁/α ≳ 10³ s with N₁ ~ 5000 g·s/%. A
            // one-minute calibration record cannot tell a larger α from a smaller N₁ itself,
            // and with α free its fits ran to 10³ (measured: `tactile calibrate`).
            Base::MkNonlinear => &[
                (0.01, 50.0),
                (1e-4, 10.0),
                (10.0, 1e7),
                (1e-4, 30.0),
                (0.1, 1e5),
                (0.05, 1e3),
                (1e-4, 10.0),
            ],
        }
    }
    /// The linear models as eq. 17, from their physical parameters (`None` for the elastic and
    /// the load-dependent models, which are not of that form).
    pub fn second_order(self, p: &[f64]) -> Option<SecondOrder> {
        let mk = |alpha: f64| -> Option<SecondOrder> {
            Some(
                MaxwellKelvin {
                    g1: *p.first()?,
                    n1: *p.get(1)?,
                    alpha,
                    n2: *p.get(2)?,
                    g2: *p.get(3)?,
                }
                .second_order(),
            )
        };
        match self {
            Base::MaxwellKelvin => mk(0.0),
            Base::MkAlpha => mk(*p.get(4)?),
            Base::SecondOrder => Some(SecondOrder {
                a1: *p.first()?,
                a2: *p.get(1)?,
                b0: *p.get(2)?,
                b1: *p.get(3)?,
                b2: *p.get(4)?,
            }),
            Base::Elastic | Base::MkNonlinear => None,
        }
    }

    /// Number of physical parameters (the strain offset follows them).
    pub fn parameter_count(self) -> usize {
        self.parameter_names().len()
    }
    fn parameter_names(self) -> &'static [&'static str] {
        match self {
            Base::Elastic => &["G"],
            Base::MaxwellKelvin => &["G1", "N1", "N2", "G2"],
            Base::MkAlpha => &["G1", "N1", "N2", "G2", "alpha"],
            Base::SecondOrder => &["a1", "a2", "b0", "b1", "b2"],
            Base::MkNonlinear => &[
                "G1_base",
                "G1_sqrt",
                "N1",
                "alpha",
                "N2",
                "G2_base",
                "G2_linear",
            ],
        }
    }
}

/// How an internal parameter maps to a physical one.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Transform {
    /// ln x = ln lo + (ln hi − ln lo)·sigmoid(θ): positive and inside a plausible range, so a
    /// ridge cannot run the fit off to 10²⁴.
    Log {
        lo: f64,
        hi: f64,
    },
    Linear,
}

impl Transform {
    fn physical(self, theta: f64) -> f64 {
        match self {
            Transform::Log { lo, hi } => (lo.ln() + (hi.ln() - lo.ln()) * sigmoid(theta)).exp(),
            Transform::Linear => theta,
        }
    }
    fn internal(self, x: f64) -> f64 {
        match self {
            Transform::Log { lo, hi } => {
                let f = ((x.clamp(lo, hi).ln() - lo.ln()) / (hi.ln() - lo.ln()))
                    .clamp(1e-9, 1.0 - 1e-9);
                (f / (1.0 - f)).ln()
            }
            Transform::Linear => x,
        }
    }
    /// d(ln x)/dθ for Log (so SE_θ times it is a relative error), 1 for Linear.
    fn slope(self, theta: f64) -> f64 {
        match self {
            Transform::Log { lo, hi } => {
                let s = sigmoid(theta);
                (hi.ln() - lo.ln()) * s * (1.0 - s)
            }
            Transform::Linear => 1.0,
        }
    }
}

fn sigmoid(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

/// A model to fit. Parameters are kept as a flat vector of internal values: the base's
/// physical parameters bounded-logarithmic (so they stay positive and plausible), then an
/// additive strain offset. (The effects a record shows are the diagnosis's, `tactile-ident`.)
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ModelSpec {
    pub base: Base,
}

impl ModelSpec {
    pub fn new(base: Base) -> Self {
        Self { base }
    }
    pub fn parameter_names(&self) -> Vec<String> {
        let mut v: Vec<String> = self
            .base
            .parameter_names()
            .iter()
            .map(|s| s.to_string())
            .collect();
        v.push("offset_pct".into());
        v
    }
    pub fn len(&self) -> usize {
        self.parameter_names().len()
    }
    pub fn is_empty(&self) -> bool {
        false
    }
    fn base_len(&self) -> usize {
        self.base.parameter_names().len()
    }
    fn transforms(&self) -> Vec<Transform> {
        let mut t: Vec<Transform> = self
            .base
            .bounds()
            .iter()
            .map(|&(lo, hi)| Transform::Log { lo, hi })
            .collect();
        t.push(Transform::Linear);
        t
    }
    /// Whether parameter `i` is positive (fitted on a bounded logarithmic scale).
    fn is_log(&self, i: usize) -> bool {
        matches!(self.transforms().get(i), Some(Transform::Log { .. }))
    }
    /// The bound of its plausible range parameter `i` sits at (its logistic scale saturated),
    /// if it does.
    pub fn bound_reached(&self, i: usize, theta: &[f64]) -> Option<f64> {
        let (Some(Transform::Log { lo, hi }), Some(&t)) =
            (self.transforms().get(i).copied(), theta.get(i))
        else {
            return None;
        };
        let s = sigmoid(t);
        if s < 1e-6 {
            Some(lo)
        } else if 1.0 - s < 1e-6 {
            Some(hi)
        } else {
            None
        }
    }
    /// Physical values of an internal parameter vector.
    pub fn physical(&self, theta: &[f64]) -> Vec<f64> {
        theta
            .iter()
            .zip(self.transforms())
            .map(|(v, t)| t.physical(*v))
            .collect()
    }
    /// Internal values of a physical parameter vector.
    pub fn internal(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .zip(self.transforms())
            .map(|(v, t)| t.internal(*v))
            .collect()
    }

    /// The instantaneous spring G₁ (g/%) that normalizes RMS_n (eq. 12b).
    pub fn g1(&self, theta: &[f64]) -> f64 {
        let p = self.physical(theta);
        match self.base {
            Base::SecondOrder => p.get(2).copied().unwrap_or(f64::NAN),
            // The instantaneous spring's secant stiffness at 30 g.
            Base::MkNonlinear => match (p.first(), p.get(1)) {
                (Some(a), Some(b)) => a + b * 30f64.sqrt(),
                _ => f64::NAN,
            },
            _ => p.first().copied().unwrap_or(f64::NAN),
        }
    }

    /// Starting points for the fit, from the memo's tables and fits.
    pub fn starts(&self, data: &Split) -> Vec<Vec<f64>> {
        let mk_rows = [
            MaxwellKelvin::TABLE_I_10G,
            MaxwellKelvin::TABLE_I_30G,
            MaxwellKelvin::TABLE_I_80G,
        ];
        let ln = |x: f64| x;
        let offset = data.series.strain_pct.first().copied().unwrap_or(0.0);
        let bases: Vec<Vec<f64>> = match self.base {
            Base::Elastic => vec![vec![ln(data.secant_g_per_pct())]],
            Base::MaxwellKelvin => mk_rows
                .iter()
                .map(|m| vec![ln(m.g1), ln(m.n1), ln(m.n2), ln(m.g2)])
                .collect(),
            // Table I's 30 g row, and (below) the two best points of the data-driven grid.
            Base::MkAlpha => {
                let m = MaxwellKelvin::TABLE_I_30G;
                vec![vec![ln(m.g1), ln(m.n1), ln(m.n2), ln(m.g2), ln(5.0)]]
            }
            Base::SecondOrder => {
                let m = SecondOrder::MEMO_FIT;
                let mk = MaxwellKelvin {
                    alpha: 5.0,
                    ..MaxwellKelvin::TABLE_I_30G
                }
                .second_order();
                vec![
                    vec![ln(m.a1), ln(m.a2), ln(m.b0), ln(m.b1), ln(m.b2)],
                    vec![ln(mk.a1), ln(mk.a2), ln(mk.b0), ln(mk.b1), ln(mk.b2)],
                ]
            }
            // Element 4,2's law and two variations (added below).
            Base::MkNonlinear => Vec::new(),
        };
        let mut bases = bases;
        if self.base == Base::MkNonlinear {
            // Element 4,2's laws (FACTS.md): G₁ = 0.5 + 0.54√σ, G₂ = 17 + 0.91σ.
            let m = NonlinearMk::ELEMENT_4_2;
            for k in [1.0, 0.7, 1.4] {
                bases.push(vec![
                    0.5 * k,
                    0.54 * k,
                    m.n1,
                    m.alpha,
                    m.n2,
                    17.0 * k,
                    0.91 * k,
                ]);
            }
        }
        if self.base == Base::MkAlpha {
            bases.extend(grid_starts(data));
        }
        bases
            .into_iter()
            .map(|mut b| {
                b.push(offset);
                self.internal(&b)
            })
            .collect()
    }

    /// Predicted strain for the whole series.
    pub fn simulate(&self, theta: &[f64], data: &Split) -> Option<Vec<f64>> {
        let p = self.physical(theta);
        let nb = self.base_len();
        let offset = *p.get(nb)?;
        let mut out = self.base_response(&p[..nb], &data.series.force_g, data.series.dt_s)?;
        for y in out.iter_mut() {
            *y += offset;
        }
        out.iter().all(|v| v.is_finite()).then_some(out)
    }

    /// The calibrated element of an `mk-nonlinear` fit.
    pub fn nonlinear_element(&self, theta: &[f64]) -> Option<NonlinearMk> {
        if self.base != Base::MkNonlinear {
            return None;
        }
        let p = self.physical(theta);
        Some(NonlinearMk {
            g1: SpringLaw::power(*p.first()?, *p.get(1)?, 0.0),
            n1: *p.get(2)?,
            alpha: *p.get(3)?,
            n2: *p.get(4)?,
            g2: SpringLaw::power(*p.get(5)?, 0.0, *p.get(6)?),
        })
    }

    fn base_response(&self, p: &[f64], input: &[f64], dt: f64) -> Option<Vec<f64>> {
        if self.base == Base::MkNonlinear {
            let el = NonlinearMk {
                g1: SpringLaw::power(p[0], p[1], 0.0),
                n1: p[2],
                alpha: p[3],
                n2: p[4],
                g2: SpringLaw::power(p[5], 0.0, p[6]),
            };
            let mut state = NonlinearMkState::default();
            return Some(
                input
                    .iter()
                    .map(|u| {
                        let s = u.max(0.0);
                        el.step(&mut state, s, dt);
                        el.strain_pct(&state, s)
                    })
                    .collect(),
            );
        }
        if self.base == Base::Elastic {
            return Some(input.iter().map(|u| u / p[0]).collect());
        }
        let model = self.base.second_order(p)?.forward::<f64>(dt).ok()?;
        let mut state = Discrete2State::default();
        Some(input.iter().map(|u| model.update(&mut state, *u)).collect())
    }
}

/// Data-driven starts for eq. 14: for a grid of the two time constants the strain is linear in
/// the compliances (1/G₁, 1/G₂, 1/α) and the offset, so each grid point is a small linear
/// least-squares problem; the best two become starting points for Levenberg–Marquardt. This is
/// what keeps the fit off the local minima a ridge invites.
fn grid_starts(data: &Split) -> Vec<Vec<f64>> {
    let lowpass = |tau: f64| -> Vec<f64> {
        let phi = (-data.series.dt_s / tau).exp();
        let mut x = 0.0;
        data.series
            .force_g
            .iter()
            .map(|f| {
                x = x * phi + (1.0 - phi) * f;
                x
            })
            .collect()
    };
    let rows: Vec<usize> = (0..data.series.force_g.len())
        .filter(|&i| data.in_fit[i] && !data.series.excluded.get(i).copied().unwrap_or(false))
        .step_by(4)
        .collect();
    // Fewer rows than unknowns (a record all at its rail) or values no solve can take: no
    // data-driven starts (the memo's remain).
    let finite =
        |i: &usize| data.series.force_g[*i].is_finite() && data.series.strain_pct[*i].is_finite();
    if rows.len() < 4 || !rows.iter().all(finite) {
        return Vec::new();
    }
    let b = DVector::from_iterator(rows.len(), rows.iter().map(|&i| data.series.strain_pct[i]));
    let mut scored: Vec<(f64, Vec<f64>)> = Vec::new();
    let kelvin_taus = [0.5, 2.0, 8.0, 30.0];
    let maxwell_taus = [60.0, 300.0, 2000.0, 20000.0];
    let kelvin: Vec<Vec<f64>> = kelvin_taus.iter().map(|t| lowpass(*t)).collect();
    let maxwell: Vec<Vec<f64>> = maxwell_taus.iter().map(|t| lowpass(*t)).collect();
    for (tk, lk) in kelvin_taus.iter().zip(&kelvin) {
        for (tm, lm) in maxwell_taus.iter().zip(&maxwell) {
            let a = DMatrix::from_fn(rows.len(), 4, |r, c| match c {
                0 => data.series.force_g[rows[r]],
                1 => lk[rows[r]],
                2 => lm[rows[r]],
                _ => 1.0,
            });
            let Some(Ok(x)) = a
                .clone()
                .try_svd(true, true, f64::EPSILON, 1000)
                .map(|svd| svd.solve(&b, 1e-12))
            else {
                continue;
            };
            let rss = (&a * &x - &b).norm_squared();
            let pos = |v: f64| v.max(1e-4);
            let (g1, g2, alpha) = (1.0 / pos(x[0]), 1.0 / pos(x[1]), 1.0 / pos(x[2]));
            scored.push((rss, vec![g1, tm * alpha, tk * g2, g2, alpha]));
        }
    }
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    scored.into_iter().take(2).map(|(_, p)| p).collect()
}

/// A finished fit.
#[derive(Clone, Debug, Serialize)]
pub struct Fit {
    pub model: ModelSpec,
    pub parameter_names: Vec<String>,
    /// Internal parameter vector (logs for positive parameters).
    pub theta: Vec<f64>,
    pub physical: Vec<f64>,
    /// Relative standard error of each physical parameter (absolute for the unlogged ones);
    /// null where it cannot be determined: a parameter at a bound of its plausible range
    /// (held there; the others' errors are with it held), or every parameter where the
    /// Jacobian's normal matrix is singular (a ridge: the covariance is undefined).
    pub standard_error: Vec<Option<f64>>,
    pub poorly_determined: Vec<String>,
    /// Strongest correlation between two parameters (a ridge shows as |ρ| near 1).
    pub max_correlation: f64,
    pub g1: f64,
    pub fit_rms_pct: f64,
    /// Null where nothing is held out, as `held_out_rms_g`.
    pub held_out_rms_pct: Option<f64>,
    pub fit_rms_g: f64,
    /// Null where nothing is held out (`held_out` says why: a record too short to hold a
    /// block out, or the whole record fitted).
    pub held_out_rms_g: Option<f64>,
    pub held_out: String,
    pub evaluations: usize,
}

/// The strain a model predicts minus the record's, over the fitted samples.
struct StrainMiss<'a> {
    spec: &'a ModelSpec,
    data: &'a Split,
    fit_index: Vec<usize>,
}

impl StrainMiss<'_> {
    /// The misses of the prediction `pred` (every sample's strain) at the fitted samples.
    fn of_prediction(&self, pred: &[f64]) -> Vec<f64> {
        self.fit_index
            .iter()
            .map(|&i| pred[i] - self.data.series.strain_pct[i])
            .collect()
    }
}

impl Residuals for StrainMiss<'_> {
    fn residuals(&self, theta: &[f64]) -> Option<Vec<f64>> {
        Some(self.of_prediction(&self.spec.simulate(theta, self.data)?))
    }
    fn step(&self, theta: &[f64], c: usize) -> f64 {
        1e-6 * theta[c].abs().max(1e-2)
    }
}

/// RMS of (prediction − strain) over the samples where `mask` equals `want` (`None`: no such
/// sample).
fn rms_where(pred: &[f64], data: &Split, want: bool) -> Option<f64> {
    let (s, n) = pred
        .iter()
        .zip(&data.series.strain_pct)
        .zip(data.in_fit.iter().zip(&data.series.excluded))
        .filter(|(_, (m, x))| **m == want && !**x)
        .fold((0.0, 0usize), |(s, n), ((p, e), _)| {
            (s + (p - e).powi(2), n + 1)
        });
    (n > 0).then(|| (s / n as f64).sqrt())
}

/// Fits `spec` from each of its starts (and from `extra_starts`), keeping the best.
pub fn fit(spec: &ModelSpec, data: &Split, extra_starts: &[Vec<f64>]) -> Option<Fit> {
    let starts: Vec<Vec<f64>> = spec
        .starts(data)
        .into_iter()
        .chain(extra_starts.iter().cloned())
        .collect();
    fit_from(spec, data, &starts)
}

/// Fits `spec` from exactly the given starts (internal parameter vectors).
pub fn fit_from(spec: &ModelSpec, data: &Split, starts: &[Vec<f64>]) -> Option<Fit> {
    let fit_index: Vec<usize> = (0..data.series.force_g.len())
        .filter(|&i| data.in_fit[i] && !data.series.excluded.get(i).copied().unwrap_or(false))
        .collect();
    let miss = StrainMiss {
        spec,
        data,
        fit_index,
    };
    let mut best: Option<(f64, Vec<f64>)> = None;
    let mut evaluations = 0;
    for start in starts {
        if start.len() != spec.len() {
            continue;
        }
        let Some(solved) = minimize(&miss, start, 25) else {
            continue;
        };
        evaluations += solved.evaluations;
        if !solved.objective.is_finite() {
            continue;
        }
        if best.as_ref().is_none_or(|b| solved.objective < b.0) {
            best = Some((solved.objective, solved.theta));
        }
    }
    let (_, mut theta) = best?;
    canonical_order(spec, &mut theta);
    summarize_fit(&miss, theta, evaluations)
}

/// Eq. 14's two branches, 1/(sN₁ + α) and 1/(sN₂ + G₂), are interchangeable: the fit can land on
/// either labelling. The Maxwell branch is by definition the slow one (N₁/α > N₂/G₂).
fn canonical_order(spec: &ModelSpec, theta: &mut Vec<f64>) {
    if spec.base == Base::MkAlpha {
        // [G1, N1, N2, G2, alpha, ...]
        let mut p = spec.physical(theta);
        if p[1] / p[4] < p[2] / p[3] {
            p.swap(1, 2);
            p.swap(3, 4);
            *theta = spec.internal(&p);
        }
    }
}

fn summarize_fit(miss: &StrainMiss, theta: Vec<f64>, evaluations: usize) -> Option<Fit> {
    let (spec, data) = (miss.spec, miss.data);
    let pred = spec.simulate(&theta, data)?;
    // Nothing fitted (every sample held out or at the rail): no fit.
    let fit_rms = rms_where(&pred, data, true)?;
    let held_rms = rms_where(&pred, data, false);
    let g1 = spec.g1(&theta);
    // Uncertainty: s² (JᵀJ)⁻¹, with s² inflated by the residual's lag-1 correlation (the
    // effective number of independent samples is smaller than N when it is correlated).
    let problem = Problem::with_residuals(miss, &theta, Some(miss.of_prediction(&pred)));
    let r = DVector::from_column_slice(problem.residuals_here()?);
    let n = r.len() as f64;
    let p = theta.len() as f64;
    let rho1 = tactile_ident::stats::acf(r.as_slice(), 1)[0].clamp(-0.99, 0.99);
    let inflation = (1.0 + rho1) / (1.0 - rho1);
    let s2 = r.norm_squared() / (n - p).max(1.0) * inflation.max(1.0);
    // A parameter at its bound moves nothing (its Jacobian column is zero): it is held there,
    // and the covariance is the others'.
    let free: Vec<usize> = (0..theta.len())
        .filter(|&i| spec.bound_reached(i, &theta).is_none())
        .collect();
    let (standard_error, max_correlation) = match problem.jacobian_here().and_then(|j| {
        let j = j.select_columns(&free);
        (j.transpose() * &j).try_inverse()
    }) {
        Some(cov) => {
            let cov = cov * s2;
            let transforms = spec.transforms();
            let se_theta: Vec<f64> = (0..free.len())
                .map(|k| cov[(k, k)].max(0.0).sqrt())
                .collect();
            let mut se: Vec<Option<f64>> = vec![None; theta.len()];
            for (k, &i) in free.iter().enumerate() {
                let slope = transforms[i].slope(theta[i]).abs();
                se[i] = Some(se_theta[k] * slope).filter(|v| v.is_finite());
            }
            let mut worst: f64 = 0.0;
            for a in 0..free.len() {
                for b in 0..a {
                    let d = se_theta[a] * se_theta[b];
                    if d > 0.0 {
                        worst = worst.max((cov[(a, b)] / d).abs());
                    }
                }
            }
            (se, worst)
        }
        None => (vec![None; theta.len()], 1.0),
    };
    let names = spec.parameter_names();
    let poorly_determined = names
        .iter()
        .enumerate()
        .filter(|(i, _)| spec.is_log(*i) && standard_error[*i].is_none_or(|se| se > 0.3))
        .map(|(_, n)| n.clone())
        .collect();
    Some(Fit {
        model: spec.clone(),
        parameter_names: names,
        physical: spec.physical(&theta),
        theta,
        standard_error,
        poorly_determined,
        max_correlation,
        g1,
        fit_rms_pct: fit_rms,
        held_out_rms_pct: held_rms,
        fit_rms_g: g1 * fit_rms,
        held_out_rms_g: held_rms.map(|r| g1 * r),
        held_out: data.held_out_description.clone(),
        evaluations,
    })
}

/// Human-readable report of a fit.
pub fn describe(fit: &Fit) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "model {}", fit.model.base.name());
    for (i, name) in fit.parameter_names.iter().enumerate() {
        let v = fit.physical[i];
        let unc = match fit.standard_error[i] {
            None => match fit.model.bound_reached(i, &fit.theta) {
                Some(b) => format!("± not determined (at the bound of its range, {b:e})"),
                None => "± not determined".to_string(),
            },
            Some(se) if fit.model.is_log(i) => format!("±{:.0} %", 100.0 * se),
            Some(se) => format!("±{se:.3}"),
        };
        let flag = if fit.poorly_determined.contains(name) {
            "  (poorly determined)"
        } else {
            ""
        };
        let _ = writeln!(s, "  {name:<16} {v:>12.5}  {unc}{flag}");
    }
    if fit.max_correlation > 0.98 {
        let _ = writeln!(
            s,
            "  strongest parameter correlation |rho| = {:.3}: the optimum is a ridge, not a point",
            fit.max_correlation
        );
    }
    let _ = writeln!(
        s,
        "  RMS_n on the fitted part: {:.3} g ({:.4} % strain)",
        fit.fit_rms_g, fit.fit_rms_pct
    );
    match (fit.held_out_rms_g, fit.held_out_rms_pct) {
        (Some(g), Some(pct)) => {
            let _ = writeln!(
                s,
                "  RMS_n held out ({}): {g:.3} g ({pct:.4} %)",
                fit.held_out
            );
        }
        _ => {
            let _ = writeln!(s, "  RMS_n held out: {}", fit.held_out);
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn synthetic(mk: MaxwellKelvin, seconds: f64) -> Split {
        let dt = 0.005;
        let n = (seconds / dt) as usize;
        let force: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64 * dt;
                25.0 + 8.0 * (0.23 * std::f64::consts::TAU * t).sin()
                    + 6.0 * (0.062 * std::f64::consts::TAU * t).sin()
                    + 4.0 * (1.9 * std::f64::consts::TAU * t).sin()
            })
            .collect();
        let model = mk.forward::<f64>(dt).unwrap();
        let mut st = Discrete2State::default();
        let strain = force.iter().map(|f| model.update(&mut st, *f)).collect();
        let block = (BLOCK_S / dt) as usize;
        Split {
            series: tactile_ident::Series {
                dt_s: dt,
                force_g: force,
                strain_pct: strain,
                excluded: vec![false; n],
                intake: Default::default(),
            },
            in_fit: (0..n).map(|i| (i / block) % 4 != 3).collect(),
            held_out_description: "test".into(),
        }
    }

    #[test]
    fn recovers_mk_alpha_parameters_from_noise_free_data() {
        let truth = MaxwellKelvin {
            g1: 4.0,
            n1: 6000.0,
            alpha: 6.0,
            n2: 400.0,
            g2: 50.0,
        };
        let data = synthetic(truth, 120.0);
        let f = fit(&ModelSpec::new(Base::MkAlpha), &data, &[]).unwrap();
        assert!(f.held_out_rms_g.unwrap() < 1e-3, "{}", describe(&f));
        // G1 and the Kelvin pair are well determined by this excitation.
        assert!((f.physical[0] - 4.0).abs() < 0.01 * 4.0, "{}", describe(&f));
        assert!(
            (f.physical[3] - 50.0).abs() < 0.02 * 50.0,
            "{}",
            describe(&f)
        );
    }

    #[test]
    fn elastic_misses_the_drift_that_maxwell_kelvin_captures() {
        let data = synthetic(MaxwellKelvin::TABLE_I_30G, 100.0);
        let e = fit(&ModelSpec::new(Base::Elastic), &data, &[]).unwrap();
        let m = fit(&ModelSpec::new(Base::MaxwellKelvin), &data, &[]).unwrap();
        let (e_g, m_g) = (e.held_out_rms_g.unwrap(), m.held_out_rms_g.unwrap());
        assert!(m_g < 0.1 * e_g, "elastic {} mk {}", e_g, m_g);
    }
}
