//! Force estimators that run per taxel at the scan rate (issue 7), and the per-taxel
//! calibration table the firmware reads at start-up.
//!
//! - [`InverseEstimator`](crate::viscoelastic::InverseEstimator): the memo's inverted
//!   second-order model, clamped at zero (the baseline).
//! - [`ScheduledInverse`]: the same model, its parameters interpolated over load from a table
//!   fitted at several load levels. Each table entry is written as a chain of springs and
//!   Kelvin branches (eq. 17 in partial fractions), so the state — the strain of each branch —
//!   means the same thing at every load and the schedule can move under it without a jolt.
//! - [`MkObserver`]: an extended Kalman filter on the modified Maxwell–Kelvin element with
//!   load-dependent springs (eq. 10 with α), estimating the stress, the Kelvin strain and the
//!   Maxwell (permanent) strain from the measured strain.
//!
//! Everything on the update path is `f32`, allocation-free and panic-free; construction (once,
//! at start-up) may use `f64`.

use crate::calibration::TaxelModel;
use crate::filter::{Biquad, BiquadState};
use crate::spring::SpringCurve;
use crate::viscoelastic::{InverseEstimator, ModelError, NonlinearMk, SecondOrder};

// The table format owns what the estimators read from it: the kinds and the schedule's size.
pub use crate::calibration::{EstimatorKind, SCHEDULE_POINTS};

/// One load level of a schedule, discretized for the update period: the instantaneous spring
/// and two Kelvin branches, each advancing `x ← φ x + c σ` with the stress held over a period.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ChainStep {
    /// Load the entry was fitted at, grams.
    pub load_g: f32,
    /// Instantaneous spring b₀, g/%.
    pub g0: f32,
    /// Per-period decay of each branch's strain.
    pub phi: [f32; 2],
    /// Branch strain gained per gram held over one period, %/g.
    pub gain: [f32; 2],
}

impl ChainStep {
    /// Eq. 17 as an instantaneous spring and two Kelvin branches: the compliance
    /// (s² + a₁s + a₂)/(b₀s² + b₁s + b₂) = 1/b₀ + r₁/(s + p₁) + r₂/(s + p₂), discretized
    /// exactly for stress held over `dt_s`. The forward poles (roots of b₀s² + b₁s + b₂) must
    /// be real and negative, as for any spring–dashpot network.
    pub fn from_second_order(
        load_g: f32,
        so: &SecondOrder,
        dt_s: f64,
    ) -> Result<ChainStep, ModelError> {
        let c = [so.a1, so.a2, so.b0, so.b1, so.b2];
        if c.iter().any(|v| !v.is_finite()) || !dt_s.is_finite() || dt_s <= 0.0 {
            return Err(ModelError::InvalidParameter {
                name: crate::viscoelastic::ModelParameter::SecondOrder,
            });
        }
        if so.b0 <= 0.0 {
            return Err(ModelError::NotBiproper);
        }
        let (e1, e0) = (so.b1 / so.b0, so.b2 / so.b0);
        let disc = e1 * e1 - 4.0 * e0;
        if e1 <= 0.0 || e0 <= 0.0 || disc <= 0.0 {
            // Complex, repeated or unstable forward poles: not a chain of Kelvin branches.
            return Err(ModelError::Unstable);
        }
        let root = libm::sqrt(disc);
        let p = [(e1 - root) / 2.0, (e1 + root) / 2.0];
        // Strictly proper remainder (n₁s + n₀)/(b₀(s + p₁)(s + p₂)).
        let (n1, n0) = (so.a1 - e1, so.a2 - e0);
        let [p1, p2] = p;
        let residue = |pi: f64, pj: f64| (n1 * -pi + n0) / (so.b0 * (pj - pi));
        let branch = |pi: f64, pj: f64| {
            let decay = libm::exp(-pi * dt_s);
            (decay as f32, (residue(pi, pj) * (1.0 - decay) / pi) as f32)
        };
        let ((phi1, gain1), (phi2, gain2)) = (branch(p1, p2), branch(p2, p1));
        let (phi, gain) = ([phi1, phi2], [gain1, gain2]);
        Ok(ChainStep {
            load_g,
            g0: so.b0 as f32,
            phi,
            gain,
        })
    }

    fn lerp(&self, other: &ChainStep, w: f32) -> ChainStep {
        let l = |a: f32, b: f32| a + (b - a) * w;
        ChainStep {
            load_g: l(self.load_g, other.load_g),
            g0: l(self.g0, other.g0),
            phi: [l(self.phi[0], other.phi[0]), l(self.phi[1], other.phi[1])],
            gain: [
                l(self.gain[0], other.gain[0]),
                l(self.gain[1], other.gain[1]),
            ],
        }
    }
}

/// Parameters over load: up to [`SCHEDULE_POINTS`] entries in increasing load, linearly
/// interpolated between them and held beyond the ends.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Schedule {
    points: [ChainStep; SCHEDULE_POINTS],
    len: usize,
}

impl Schedule {
    /// A schedule from models fitted at the given loads (any order; sorted here).
    pub fn new(fits: &[(f32, SecondOrder)], dt_s: f64) -> Result<Schedule, ModelError> {
        if fits.is_empty() || fits.len() > SCHEDULE_POINTS {
            return Err(ModelError::InvalidParameter {
                name: crate::viscoelastic::ModelParameter::ScheduleLength,
            });
        }
        let mut s = Schedule::default();
        for (slot, (load, so)) in s.points.iter_mut().zip(fits) {
            if !load.is_finite() || *load < 0.0 {
                return Err(ModelError::InvalidParameter {
                    name: crate::viscoelastic::ModelParameter::ScheduleLoad,
                });
            }
            *slot = ChainStep::from_second_order(*load, so, dt_s)?;
        }
        s.len = fits.len();
        // Sorted by load (NaN was refused above, so the order is total).
        if let Some(used) = s.points.get_mut(..fits.len()) {
            used.sort_unstable_by(|a, b| a.load_g.total_cmp(&b.load_g));
        }
        Ok(s)
    }

    pub fn points(&self) -> &[ChainStep] {
        self.points.get(..self.len).unwrap_or(&[])
    }

    /// The parameters at `load_g`.
    #[inline]
    pub fn at(&self, load_g: f32) -> ChainStep {
        let pts = self.points();
        let (Some(first), Some(last)) = (pts.first(), pts.last()) else {
            return ChainStep::default();
        };
        if load_g.is_nan() || load_g <= first.load_g {
            return *first;
        }
        if load_g >= last.load_g {
            return *last;
        }
        for pair in pts.windows(2) {
            if let [a, b] = pair {
                if load_g < b.load_g {
                    let w = (load_g - a.load_g) / (b.load_g - a.load_g);
                    return a.lerp(b, w);
                }
            }
        }
        *last
    }
}

/// The inverted second-order model with its parameters scheduled over the estimated load (the
/// last estimate), clamped at zero.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ScheduledInverse {
    pub schedule: Schedule,
    branch_pct: [f32; 2],
    force_g: f32,
}

impl ScheduledInverse {
    pub fn new(schedule: Schedule) -> Self {
        Self {
            schedule,
            branch_pct: [0.0; 2],
            force_g: 0.0,
        }
    }

    /// Force from the latest strain sample: the strain beyond the branches' is the
    /// instantaneous spring's; the stress it implies then advances the branches.
    #[inline]
    pub fn force_g(&mut self, strain_pct: f32) -> f32 {
        if !strain_pct.is_finite() {
            return 0.0;
        }
        let p = self.schedule.at(self.force_g);
        let [x0, x1] = self.branch_pct;
        let stress = p.g0 * (strain_pct - x0 - x1);
        // The branches only ever carry a compressive stress.
        let held = stress.max(0.0);
        self.branch_pct = [
            p.phi[0] * x0 + p.gain[0] * held,
            p.phi[1] * x1 + p.gain[1] * held,
        ];
        if !(self.branch_pct[0].is_finite() && self.branch_pct[1].is_finite()) {
            self.branch_pct = [0.0; 2];
        }
        self.force_g = held;
        held
    }
}

/// Noise levels of the observer, per update period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObserverTuning {
    /// Standard deviation of the load's random walk, g (how fast a load may change).
    pub force_walk_g: f32,
    /// Of the Kelvin strain's model error, %.
    pub kelvin_walk_pct: f32,
    /// Of the permanent (Maxwell) strain's slow variation, %.
    pub permanent_walk_pct: f32,
    /// Of the strain measurement (read-out noise and quantization), %.
    pub strain_noise_pct: f32,
}

impl ObserverTuning {
    /// For the memo's read-out (0.022 g noise, 12-bit converter: about 0.008 % in all) and
    /// loads that step by up to 20 g: the load may change by many grams a frame, the
    /// viscoelastic strains only as the model lets them, give or take a little.
    pub const DESIGN: ObserverTuning = ObserverTuning {
        force_walk_g: 10.0,
        kelvin_walk_pct: 1e-3,
        permanent_walk_pct: 2e-4,
        strain_noise_pct: 8e-3,
    };
}

/// Load at which the observer converts its load walk (grams) into a spring-strain walk.
const OBSERVER_PIVOT_G: f32 = 30.0;

/// An extended Kalman filter on eq. 14 with load-dependent springs. State: the strain of the
/// instantaneous spring ε_s (a random walk; the stress is G₁'s inverse law of it), the Kelvin
/// strain ε_k and the Maxwell strain ε_m (the permanent deformation, slowly varying). The
/// measurement ε = ε_s + ε_k + ε_m is linear in that state, so a sudden unloading needs no
/// linearization; the spring laws enter the prediction, through their tangent stiffness. A
/// negative spring strain is projected onto zero along the covariance, so the zero-force level
/// follows the permanent deformation after long loads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MkObserver {
    /// The springs as the curves the update evaluates (any law is tabulated at start-up).
    g1: SpringCurve,
    g2: SpringCurve,
    /// dt/N₂, and the Maxwell branch's decay and gain per period.
    dt_over_n2: f32,
    maxwell_phi: f32,
    maxwell_gain: f32,
    q: [f32; 3],
    r: f32,
    /// [ε_s, ε_k, ε_m], percent.
    x: [f32; 3],
    /// Covariance, symmetric: [ss, sk, sm, kk, km, mm].
    p: [f32; 6],
}

impl MkObserver {
    pub fn new(
        model: &NonlinearMk,
        dt_s: f64,
        tuning: ObserverTuning,
    ) -> Result<MkObserver, ModelError> {
        let positive = [model.n1, model.n2, dt_s];
        if positive.iter().any(|v| !v.is_finite() || *v <= 0.0)
            || !model.alpha.is_finite()
            || model.alpha < 0.0
        {
            return Err(ModelError::InvalidParameter {
                name: crate::viscoelastic::ModelParameter::Observer,
            });
        }
        let (g1, g2) = (model.g1.curve()?, model.g2.curve()?);
        let (maxwell_phi, maxwell_gain) = if model.alpha > 0.0 {
            let phi = libm::exp(-model.alpha * dt_s / model.n1);
            (phi, (1.0 - phi) / model.alpha)
        } else {
            (1.0, dt_s / model.n1)
        };
        let sq = |v: f32| v * v;
        let spring_walk_pct = tuning.force_walk_g / g1.stiffness(OBSERVER_PIVOT_G);
        Ok(MkObserver {
            g1,
            g2,
            dt_over_n2: (dt_s / model.n2) as f32,
            maxwell_phi: maxwell_phi as f32,
            maxwell_gain: maxwell_gain as f32,
            q: [
                sq(spring_walk_pct),
                sq(tuning.kelvin_walk_pct),
                sq(tuning.permanent_walk_pct),
            ],
            r: sq(tuning.strain_noise_pct),
            x: [0.0; 3],
            // Unloaded and at rest, the load known to within its walk.
            p: [sq(spring_walk_pct), 0.0, 0.0, 1e-6, 0.0, 1e-6],
        })
    }

    /// The state estimate [ε_s, ε_k, ε_m], percent.
    pub fn state(&self) -> [f32; 3] {
        self.x
    }

    /// The permanent (Maxwell) strain the observer holds, percent.
    pub fn permanent_pct(&self) -> f32 {
        self.x[2]
    }

    /// Force from the latest strain sample: the measurement update, the zero-force projection,
    /// then the prediction to the next sample with the stress held.
    #[inline]
    pub fn force_g(&mut self, strain_pct: f32) -> f32 {
        if !strain_pct.is_finite() {
            return self.g1.stress_g(self.x[0]).0;
        }
        let saved = (self.x, self.p);
        self.update(strain_pct);
        self.project_nonnegative();
        let (force, tangent) = self.g1.stress_g(self.x[0]);
        self.predict(force, tangent);
        if !(self.x.iter().chain(self.p.iter()).all(|v| v.is_finite()) && self.p[0] > 0.0) {
            // Numerically lost: back to the last good estimate.
            (self.x, self.p) = saved;
            return self.g1.stress_g(saved.0[0]).0;
        }
        force
    }

    fn update(&mut self, strain_pct: f32) {
        let [pss, psk, psm, pkk, pkm, pmm] = self.p;
        // P hᵀ with h = [1, 1, 1].
        let ph = [pss + psk + psm, psk + pkk + pkm, psm + pkm + pmm];
        let innovation_var = ph[0] + ph[1] + ph[2] + self.r;
        if innovation_var.is_nan() || innovation_var <= 0.0 {
            return;
        }
        let gain = ph.map(|v| v / innovation_var);
        let y = strain_pct - (self.x[0] + self.x[1] + self.x[2]);
        for (x, k) in self.x.iter_mut().zip(gain) {
            *x += k * y;
        }
        // P − K (P hᵀ)ᵀ.
        self.p = [
            pss - gain[0] * ph[0],
            psk - gain[0] * ph[1],
            psm - gain[0] * ph[2],
            pkk - gain[1] * ph[1],
            pkm - gain[1] * ph[2],
            pmm - gain[2] * ph[2],
        ];
    }

    /// ε_s ≥ 0 (a normal force only pushes) as an estimate projection: the state moves to
    /// ε_s = 0 along its covariance with ε_s.
    fn project_nonnegative(&mut self) {
        let s = self.x[0];
        let [pss, psk, psm, pkk, pkm, pmm] = self.p;
        if s >= 0.0 || pss.is_nan() || pss <= 0.0 {
            return;
        }
        self.x = [0.0, self.x[1] - psk / pss * s, self.x[2] - psm / pss * s];
        // The covariance given ε_s = 0, with ε_s's own variance floored at one period's walk.
        self.p = [
            self.q[0],
            0.0,
            0.0,
            pkk - psk * psk / pss,
            pkm - psk * psm / pss,
            pmm - psm * psm / pss,
        ];
    }

    /// One period ahead with the stress `force_g` held; `tangent` is dσ/dε_s there.
    fn predict(&mut self, force_g: f32, tangent: f32) {
        let [s, k, m] = self.x;
        let g2 = self.g2.stiffness(force_g);
        // e^(−x) for the Kelvin branch; x = G₂ dt/N₂ is below 0.1 at the scan rate, where
        // three Taylor terms are within 2·10⁻⁵ (relative).
        let x = g2 * self.dt_over_n2;
        let phi_k = if x < 0.1 {
            1.0 - x * (1.0 - x * (0.5 - x / 6.0))
        } else {
            libm::expf(-x)
        };
        let ck = (1.0 - phi_k) / g2;
        let (phi_m, cm) = (self.maxwell_phi, self.maxwell_gain);
        self.x = [s, phi_k * k + ck * force_g, phi_m * m + cm * force_g];
        // F = [[1, 0, 0], [ck·σ', φk, 0], [cm·σ', 0, φm]].
        let (fk, fm) = (ck * tangent, cm * tangent);
        let [pss, psk, psm, pkk, pkm, pmm] = self.p;
        // Rows k and m of F P.
        let fp_k = [
            fk * pss + phi_k * psk,
            fk * psk + phi_k * pkk,
            fk * psm + phi_k * pkm,
        ];
        let fp_m = [
            fm * pss + phi_m * psm,
            fm * psk + phi_m * pkm,
            fm * psm + phi_m * pmm,
        ];
        self.p = [
            pss + self.q[0],
            fp_k[0],
            fp_m[0],
            fp_k[0] * fk + fp_k[1] * phi_k + self.q[1],
            fp_k[0] * fm + fp_k[2] * phi_m,
            fp_m[0] * fm + fp_m[2] * phi_m + self.q[2],
        ];
    }
}

/// One taxel's estimator, of one kind, built from its calibration for an update period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TaxelEstimator {
    Elastic { g_per_pct: f32 },
    SecondOrderInverse(InverseEstimator),
    ScheduledInverse(ScheduledInverse),
    Observer(MkObserver),
}

impl TaxelEstimator {
    pub fn new(kind: EstimatorKind, model: &TaxelModel, dt_s: f64) -> Result<Self, ModelError> {
        Ok(match kind {
            EstimatorKind::Elastic => {
                let g = model.elastic_g_per_pct;
                if !(g.is_finite() && g > 0.0) {
                    return Err(ModelError::InvalidParameter {
                        name: crate::viscoelastic::ModelParameter::Elastic,
                    });
                }
                TaxelEstimator::Elastic {
                    g_per_pct: g as f32,
                }
            }
            EstimatorKind::SecondOrderInverse => TaxelEstimator::SecondOrderInverse(
                InverseEstimator::new(model.second_order.inverse(dt_s)?),
            ),
            EstimatorKind::ScheduledInverse => {
                let schedule = Schedule::new(&model.schedule, dt_s)?;
                TaxelEstimator::ScheduledInverse(ScheduledInverse::new(schedule))
            }
            EstimatorKind::Observer => TaxelEstimator::Observer(MkObserver::new(
                &model.element,
                dt_s,
                ObserverTuning::DESIGN,
            )?),
        })
    }

    /// Force from the latest strain of the taxel (its calibration's offset already removed).
    #[inline]
    pub fn force_g(&mut self, strain_pct: f32) -> f32 {
        match self {
            TaxelEstimator::Elastic { g_per_pct } => {
                let f = *g_per_pct * strain_pct;
                if f.is_finite() {
                    f.max(0.0)
                } else {
                    0.0
                }
            }
            TaxelEstimator::SecondOrderInverse(e) => e.force_g(strain_pct),
            TaxelEstimator::ScheduledInverse(e) => e.force_g(strain_pct),
            TaxelEstimator::Observer(e) => e.force_g(strain_pct),
        }
    }
}

/// Quality factor of the interference notch: narrow (−3 dB at f0 ± f0/60), so the steps of a
/// load barely ring through it (measured on the diagnosis tests: Q = 1 made the on-chip
/// inverse 5× worse than no notch, Q = 30 takes 30–40 % off its error).
pub const NOTCH_Q: f64 = 30.0;

/// What a taxel's strain goes through before its estimators: the calibration's offset removed
/// and, when the calibration found a periodic interference, that tone notched.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StrainConditioner {
    offset_pct: f32,
    notch: Option<(Biquad, BiquadState)>,
}

impl StrainConditioner {
    /// For `model` sampled every `dt_s` (no notch where the tone aliases onto DC).
    pub fn new(model: &TaxelModel, dt_s: f64) -> Self {
        let notch = (model.notch_hz > 0.0)
            .then(|| Biquad::notch(model.notch_hz, NOTCH_Q, dt_s))
            .flatten()
            .map(|b| (b, BiquadState::default()));
        Self {
            offset_pct: model.strain_offset_pct as f32,
            notch,
        }
    }

    /// The offset alone (no state), for comparisons.
    #[inline]
    pub fn offset_removed(&self, strain_pct: f32) -> f32 {
        strain_pct - self.offset_pct
    }

    /// The conditioned strain of the latest sample.
    #[inline]
    pub fn update(&mut self, strain_pct: f32) -> f32 {
        let e = strain_pct - self.offset_pct;
        match &mut self.notch {
            Some((b, state)) if e.is_finite() => {
                let y = b.update(state, e);
                if y.is_finite() {
                    y
                } else {
                    *state = BiquadState::default();
                    e
                }
            }
            _ => e,
        }
    }
}

/// Every estimator side by side on one taxel (the probed one, for the comparison stream).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaxelEstimators {
    conditioner: StrainConditioner,
    estimators: [TaxelEstimator; 4],
}

impl TaxelEstimators {
    pub fn new(model: &TaxelModel, dt_s: f64) -> Result<Self, ModelError> {
        let e = |k| TaxelEstimator::new(k, model, dt_s);
        Ok(Self {
            conditioner: StrainConditioner::new(model, dt_s),
            estimators: [
                e(EstimatorKind::Elastic)?,
                e(EstimatorKind::SecondOrderInverse)?,
                e(EstimatorKind::ScheduledInverse)?,
                e(EstimatorKind::Observer)?,
            ],
        })
    }

    /// The read-out's strain less the calibration's offset (no notch: stateless).
    #[inline]
    pub fn corrected(&self, strain_pct: f32) -> f32 {
        self.conditioner.offset_removed(strain_pct)
    }

    /// Each estimator's force, in [`EstimatorKind::ALL`]'s order, from the conditioned strain.
    pub fn update(&mut self, strain_pct: f32) -> [f32; 4] {
        let e = self.conditioner.update(strain_pct);
        let mut out = [0.0; 4];
        for (o, est) in out.iter_mut().zip(self.estimators.iter_mut()) {
            *o = est.force_g(e);
        }
        out
    }

    /// One estimator, by kind (for timing them one at a time).
    #[inline]
    pub fn estimator_mut(&mut self, kind: EstimatorKind) -> &mut TaxelEstimator {
        let [a, b, c, d] = &mut self.estimators;
        match kind {
            EstimatorKind::Elastic => a,
            EstimatorKind::SecondOrderInverse => b,
            EstimatorKind::ScheduledInverse => c,
            EstimatorKind::Observer => d,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::viscoelastic::{MaxwellKelvin, NonlinearMkState};

    const FRAME_S: f64 = 0.016;

    /// Steps in 20–40 g every 2–8 s, sampled every `dt`.
    fn pseudo_random_stress(n: usize, dt: f64) -> Vec<f64> {
        crate::test_support::pseudo_random_steps(n, dt, 0x2545_F491_4F6C_DD1D, 2.0, 6.0)
    }

    /// The element's strain under `stress` held over each frame (the form it is exact for).
    fn strain_of(model: &NonlinearMk, stress: &[f64], dt: f64) -> Vec<f32> {
        let mut st = NonlinearMkState::default();
        stress
            .iter()
            .map(|&s| {
                let e = model.strain_pct(&st, s);
                model.step(&mut st, s, dt);
                e as f32
            })
            .collect()
    }

    #[test]
    fn the_memo_fit_is_a_spring_and_two_kelvin_branches() {
        // By hand: b₀s² + b₁s + b₂ = 5.81 (s + 0.21015)(s + 2.07212); the remainder
        // (0.72773 s + 0.34854)/(5.81 (s + p₁)(s + p₂)) has residues 0.018082 and 0.107172.
        let dt = 1.0;
        let c = ChainStep::from_second_order(25.0, &SecondOrder::MEMO_FIT, dt).unwrap();
        assert!((c.g0 - 5.81).abs() < 1e-6);
        let p1 = -f64::from(c.phi[0]).ln();
        let p2 = -f64::from(c.phi[1]).ln();
        assert!(
            (p1 - 0.21015).abs() < 2e-5 && (p2 - 2.07212).abs() < 2e-5,
            "{p1} {p2}"
        );
        let r1 = f64::from(c.gain[0]) * p1 / (1.0 - f64::from(c.phi[0]));
        let r2 = f64::from(c.gain[1]) * p2 / (1.0 - f64::from(c.phi[1]));
        assert!(
            (r1 - 0.018082).abs() < 2e-5 && (r2 - 0.107172).abs() < 2e-5,
            "{r1} {r2}"
        );
        // DC compliance 1/b₀ + r₁/p₁ + r₂/p₂ = a₂/b₂.
        let so = SecondOrder::MEMO_FIT;
        let dc = 1.0 / so.b0 + r1 / p1 + r2 / p2;
        assert!((dc - so.a2 / so.b2).abs() < 1e-3, "{dc}");
        // Complex forward poles are not a chain.
        let ringing = SecondOrder {
            b1: 0.1,
            ..SecondOrder::MEMO_FIT
        };
        assert_eq!(
            ChainStep::from_second_order(25.0, &ringing, dt),
            Err(ModelError::Unstable)
        );
    }

    #[test]
    fn one_entry_schedule_matches_the_tustin_inverse_of_the_same_model() {
        // Two discretizations of the memo's inverse at the scan rate: the chain (stress held
        // over a frame) and the bilinear one (the baseline estimator) agree on a pseudo-random
        // load to within the change a held frame makes.
        let so = SecondOrder::MEMO_FIT;
        let stress = pseudo_random_stress(10_000, FRAME_S);
        let fwd = so.forward::<f64>(FRAME_S).unwrap();
        let mut st = crate::viscoelastic::Discrete2State::default();
        let strain: Vec<f32> = stress
            .iter()
            .map(|&s| fwd.update(&mut st, s) as f32)
            .collect();
        let mut chain = ScheduledInverse::new(Schedule::new(&[(25.0, so)], FRAME_S).unwrap());
        let mut tustin = crate::viscoelastic::InverseEstimator::new(so.inverse(FRAME_S).unwrap());
        let mut sum = 0.0;
        for e in &strain {
            let d = chain.force_g(*e) - tustin.force_g(*e);
            sum += f64::from(d * d);
        }
        let rms = (sum / strain.len() as f64).sqrt();
        assert!(rms < 0.3, "{rms}");
    }

    #[test]
    fn schedule_interpolates_between_loads_and_holds_beyond() {
        let at = |load: f64| NonlinearMk::ELEMENT_4_2.linearized(load).second_order();
        let mk = |load: f64| MaxwellKelvin {
            alpha: 5.0,
            ..NonlinearMk::ELEMENT_4_2.linearized(load)
        };
        assert_eq!(mk(30.0).second_order(), at(30.0));
        let s = Schedule::new(&[(50.0, at(50.0)), (10.0, at(10.0))], FRAME_S).unwrap();
        let (lo, hi) = (s.at(10.0), s.at(50.0));
        assert_eq!(s.at(0.0), lo);
        assert_eq!(s.at(80.0), hi);
        let mid = s.at(30.0);
        assert!((mid.g0 - 0.5 * (lo.g0 + hi.g0)).abs() < 1e-5);
        assert!((mid.load_g - 30.0).abs() < 1e-5);
        assert_eq!(s.at(f32::NAN), lo);
        assert!(Schedule::new(&[], FRAME_S).is_err());
    }

    #[test]
    fn a_schedule_from_the_element_tracks_it_better_than_one_load() {
        // Element 4,2's secant models at four loads, scheduled, against the single 30 g one.
        let element = NonlinearMk::ELEMENT_4_2;
        let stress: Vec<f64> = pseudo_random_stress(12_000, FRAME_S)
            .iter()
            .map(|s| s * 1.5)
            .collect();
        let strain = strain_of(&element, &stress, FRAME_S);
        let fits: Vec<(f32, SecondOrder)> = [10.0, 30.0, 50.0, 70.0]
            .iter()
            .map(|&l| (l as f32, element.linearized(l).second_order()))
            .collect();
        let rms = |mut est: ScheduledInverse| {
            let sum: f64 = strain
                .iter()
                .zip(&stress)
                .map(|(e, s)| (f64::from(est.force_g(*e)) - s).powi(2))
                .sum();
            (sum / stress.len() as f64).sqrt()
        };
        let scheduled = rms(ScheduledInverse::new(
            Schedule::new(&fits, FRAME_S).unwrap(),
        ));
        let single = rms(ScheduledInverse::new(
            Schedule::new(&fits[1..2], FRAME_S).unwrap(),
        ));
        assert!(
            scheduled < 0.5 && scheduled < 0.25 * single,
            "{scheduled} vs {single}"
        );
    }

    #[test]
    fn the_observer_recovers_stress_and_the_permanent_deformation() {
        let element = NonlinearMk::ELEMENT_4_2;
        // 60 s of pseudo-random load, then 30 s unloaded.
        let mut stress = pseudo_random_stress(3750, FRAME_S);
        stress.extend(std::iter::repeat_n(0.0, 1875));
        let strain = strain_of(&element, &stress, FRAME_S);
        let mut obs = MkObserver::new(&element, FRAME_S, ObserverTuning::DESIGN).unwrap();
        let mut sum = 0.0;
        for (e, s) in strain.iter().zip(&stress) {
            sum += (f64::from(obs.force_g(*e)) - s).powi(2);
        }
        let rms = (sum / stress.len() as f64).sqrt();
        // The strain was made by the observer's own model, whose springs the observer runs
        // tabulated (within 0.01 % strain of the laws above 6 g).
        assert!(rms < 0.03, "{rms}");
        // After the loads: no phantom force, and the permanent strain is the element's.
        let mut st = NonlinearMkState::default();
        for &s in &stress {
            element.step(&mut st, s, FRAME_S);
        }
        let [spring, _, permanent] = obs.state();
        assert!(spring.abs() < 0.02, "{spring}");
        assert!(
            (f64::from(permanent) - st.maxwell_pct).abs() < 0.02 * st.maxwell_pct,
            "{permanent} vs {}",
            st.maxwell_pct
        );
        assert!(st.maxwell_pct > 0.1, "{}", st.maxwell_pct);
    }

    #[test]
    fn bad_samples_do_not_poison_the_estimators() {
        let mut obs =
            MkObserver::new(&NonlinearMk::ELEMENT_4_2, FRAME_S, ObserverTuning::DESIGN).unwrap();
        let mut inv = ScheduledInverse::new(
            Schedule::new(&[(25.0, SecondOrder::MEMO_FIT)], FRAME_S).unwrap(),
        );
        for _ in 0..10 {
            obs.force_g(8.0);
            inv.force_g(8.0);
        }
        let (a, b) = (obs.force_g(f32::NAN), inv.force_g(f32::INFINITY));
        assert!(a.is_finite() && b == 0.0);
        assert!(obs.force_g(8.0).is_finite() && inv.force_g(8.0) > 10.0);
        // A bad model is refused, not run.
        let broken = NonlinearMk {
            n2: -1.0,
            ..NonlinearMk::ELEMENT_4_2
        };
        assert!(MkObserver::new(&broken, FRAME_S, ObserverTuning::DESIGN).is_err());
    }
}
