//! The observer: an extended Kalman filter on eq. 14 with load-dependent springs.

use crate::spring::SpringCurve;
use crate::viscoelastic::{ModelError, ModelParameter, NonlinearMk};

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
                name: ModelParameter::Observer,
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
