//! The noise floors a model is judged above: the strain's own noise, and the reference force's
//! noise fed through the model (a model that smooths the force passes less of it).

use crate::residual::ResidualTests;
use crate::solve::Scored;
use crate::{stats, terms};

use super::work::Work;
use super::Term;

/// The record's noise, and the floor of the baseline.
pub(super) struct Floors {
    /// The variance of the reference force's noise, as measured.
    pub(super) force_noise: f64,
    /// The variance of the force's noise left in the smoothed force every model sees.
    passed_var: f64,
    /// The strain's own noise variance (never below the columns' rounding).
    strain_floor: f64,
    /// The baseline's floor: the strain's noise and the force's through the baseline.
    pub(super) floor: f64,
}

impl Floors {
    /// The floors of a record whose force noise has variance `force_noise`, of which the
    /// smoothing passes the share `force_noise_passed`, with the baseline `scored`.
    pub(super) fn new(
        work: &Work,
        scored: &Scored,
        force_noise: f64,
        force_noise_passed: f64,
        window: usize,
    ) -> Floors {
        let passed_var = force_noise * force_noise_passed;
        // The noise floor of a model: the strain's own noise and the force's through the model.
        // The columns are single precision: what a fit of them holds out on an exact record (130
        // of its rounding steps of the strain's scale, 1.6·10⁻⁵, a noise-free linear record that
        // read `unexplained`) is arithmetic, not the finger; 3·10⁻⁵ of the strain is the least
        // floor.
        let kept_y = work.s.kept(work.pool.y());
        let rounding = 256.0 * f64::from(f32::EPSILON) * stats::rms(&kept_y);
        let strain_floor = stats::noise_variance(&kept_y, window).max(rounding * rounding);
        Floors {
            force_noise,
            passed_var,
            strain_floor,
            floor: strain_floor + Floors::energy_of(work, scored) * passed_var,
        }
    }

    /// The energy of a fitted model's impulse response from the force: the force's noise
    /// reaches the strain through it (a model that smooths the force passes less).
    pub(super) fn energy_of(work: &Work, sc: &Scored) -> f64 {
        impulse_energy(
            &sc.columns
                .iter()
                .zip(&sc.beta)
                .map(|(c, b)| (work.terms[*c], *b))
                .collect::<Vec<_>>(),
            work.s.dt_s,
        )
    }

    /// The floor of models of impulse-response energy up to `energy`.
    ///
    /// An effect is judged above the floor of the models compared (of the larger of their
    /// energies), never below the baseline's: a baseline standing in for a delay smooths the
    /// force and passes less of its noise (its floor is half the delayed model's, `try synth 21
    /// 200 180 delay=3`), so what a right delay leaves looked like a third of the error left
    /// unexplained.
    pub(super) fn floor_at(&self, energy: f64) -> f64 {
        self.floor.max(self.strain_floor + energy * self.passed_var)
    }

    /// A candidate's fold errors less the force noise it passes beyond what a model of energy
    /// `to_energy` (the one it is judged against) passes: a model that smooths the force (the
    /// baseline standing in for a delay with a fast branch) wins the quiet folds by passing
    /// less of the reference's noise, not by fitting the finger better.
    pub(super) fn noise_matched(&self, work: &Work, sc: &Scored, to_energy: f64) -> Vec<f64> {
        let extra = (Floors::energy_of(work, sc) - to_energy) * self.passed_var;
        sc.fold_mse
            .iter()
            .map(|m| (m - extra).max(0.5 * m))
            .collect()
    }
}

/// The floor to beat: a first-order linear model (a spring and one Kelvin branch, the
/// standard linear solid) on the same folds as the baseline `base`, its time constant the best
/// held out.
pub(super) fn first_order(work: &mut Work, base: &[usize]) -> Option<Scored> {
    base.iter()
        .filter(|c| matches!(work.terms[**c], Term::Relaxation(_)))
        .map(|&c| {
            let elastic = base[1];
            work.pool.score(&[base[0], elastic, c])
        })
        .min_by(|a, b| a.cv_mse.total_cmp(&b.cv_mse))
}

/// A residual far from white (Ljung–Box over 20× its 5 % level, most lags outside the bound)
/// and a held-out error over twice the floor: what a model that leaves it does not explain.
pub(super) fn far_from_white(tests: &ResidualTests, cv_mse: f64, floor: f64) -> bool {
    tests.ljung_box_ratio > 20.0 && tests.acf_outside > 0.5 && cv_mse > 2.0 * floor
}

/// Σh² of the force-to-strain impulse response of the elastic term and the Kelvin branches
/// (the discrete forms of [`terms::lowpass`]: h₀ = b₀, h₁ = a·b₀ + b₁, hₖ = a^(k−1)·h₁).
fn impulse_energy(terms: &[(Term, f64)], dt: f64) -> f64 {
    let k_max = 20_000usize;
    let mut h = vec![0.0f64; k_max];
    for (t, b) in terms {
        match t {
            Term::Elastic => h[0] += b,
            Term::Relaxation(tau) | Term::SlowRelaxation(tau) => {
                let (a, b0, b1) = terms::lowpass_coefficients(*tau, dt);
                h[0] += b * b0;
                let mut v = b * (a * b0 + b1);
                for hk in h.iter_mut().skip(1) {
                    *hk += v;
                    v *= a;
                    if v.abs() < 1e-12 * b.abs() {
                        break;
                    }
                }
            }
            _ => {}
        }
    }
    h.iter().map(|v| v * v).sum()
}
