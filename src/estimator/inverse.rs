//! Inverse models run on the strain: the memo's inverted second-order model (the baseline) and
//! the modified Maxwell–Kelvin element run backwards.

use crate::lti::{Discrete2, Discrete2State};
use crate::viscoelastic::{NonlinearMk, NonlinearMkState};

/// A force estimator from one element's strain: a discretized inverse, clamped at ≥ 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InverseEstimator {
    pub model: Discrete2<f32>,
    pub state: Discrete2State<f32>,
}

impl InverseEstimator {
    pub fn new(model: Discrete2<f32>) -> Self {
        Self {
            model,
            state: Discrete2State::default(),
        }
    }
    /// Force from the latest strain sample. The linear state runs unclamped; only the reported
    /// force is clamped at zero (a normal force only pushes).
    #[inline]
    pub fn force_g(&mut self, strain_pct: f32) -> f32 {
        if !strain_pct.is_finite() {
            return 0.0;
        }
        let f = self.model.update(&mut self.state, strain_pct);
        if f.is_finite() {
            f.max(0.0)
        } else {
            self.state = Discrete2State::default();
            0.0
        }
    }
}

/// Force from strain by running the modified Maxwell–Kelvin element (eq. 14 with its
/// load-dependent springs) backwards, sample by sample: the strain beyond the element's current
/// rest strain (its dashpots' ε_m + ε_k) is the instantaneous spring's, which gives the stress
/// through the inverse spring law; that stress then advances the dashpots. It is the exact
/// inverse of [`NonlinearMk`] for piecewise-constant stress, so the zero-force level follows the
/// permanent deformation after long loads, and it needs no linearization about a load.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StructuralInverse {
    pub model: NonlinearMk,
    pub state: NonlinearMkState,
    pub dt_s: f64,
}

impl StructuralInverse {
    pub fn new(model: NonlinearMk, dt_s: f64) -> Self {
        Self {
            model,
            state: NonlinearMkState::default(),
            dt_s,
        }
    }

    /// Force (≥ 0) from the latest strain sample; a non-finite strain holds the state and
    /// reports 0.
    #[inline]
    pub fn force_g(&mut self, strain_pct: f32) -> f32 {
        self.force_g_f64(f64::from(strain_pct)) as f32
    }

    /// [`Self::force_g`] in `f64` throughout (host-side fits run the element backwards).
    #[inline]
    pub fn force_g_f64(&mut self, strain_pct: f64) -> f64 {
        if !strain_pct.is_finite() {
            return 0.0;
        }
        let spring_pct = strain_pct - self.model.rest_strain_pct(&self.state);
        let stress_g = self.model.g1.stress_g(spring_pct);
        self.model.step(&mut self.state, stress_g, self.dt_s);
        stress_g
    }
}
