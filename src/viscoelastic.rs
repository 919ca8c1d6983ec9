//! Viscoelastic models of a tactile element (memo sections 3–4).
//!
//! Stress σ is in grams at the probe, strain ε in percent deflection, springs in g/%, dashpots
//! in g·s/%.
//!
//! - [`Elastic`]: ε = σ/G.
//! - [`MaxwellKelvin`]: eq. 11, and with the small spring α parallel to N₁, eq. 14.
//! - [`SecondOrder`]: eq. 17, ε/σ = (s² + a₁s + a₂)/(b₀s² + b₁s + b₂).
//! - [`NonlinearMk`]: eq. 14 with load-dependent springs and exact per-step integration; the
//!   finger of the simulator.
//!
//! Linear models run sample by sample through [`Discrete2`] ([`crate::lti`]); the estimators
//! that invert them live in [`crate::estimator`].

use num_complex::Complex64;

pub use crate::lti::{Discrete2, Discrete2State, ModelError, ModelParameter, Rational2, Real};

/// Elastic model ε = σ / G.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Elastic {
    pub g: f32,
}

impl Elastic {
    pub fn strain_pct(&self, stress_g: f32) -> f32 {
        stress_g / self.g
    }
    /// Force estimate from strain, clamped at zero (a normal force only pushes).
    pub fn force_g(&self, strain_pct: f32) -> f32 {
        (self.g * strain_pct).max(0.0)
    }
}

/// Maxwell–Kelvin parameters (eq. 11 with `alpha = 0`, eq. 14 otherwise).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaxwellKelvin {
    pub g1: f64,
    pub n1: f64,
    pub alpha: f64,
    pub n2: f64,
    pub g2: f64,
}

/// A row of the memo's Table I: the step load it was fitted at, and the element.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableIRow {
    pub load_g: f64,
    pub element: MaxwellKelvin,
}

impl TableIRow {
    const fn new(load_g: f64, g1: f64, n1: f64, n2: f64, g2: f64) -> TableIRow {
        TableIRow {
            load_g,
            element: MaxwellKelvin {
                g1,
                n1,
                alpha: 0.0,
                n2,
                g2,
            },
        }
    }
}

impl MaxwellKelvin {
    /// The memo's Table I: element 4,2 fitted to step responses, one row per step load (α is
    /// not part of the table: zero).
    pub const TABLE_I: [TableIRow; 4] = [
        TableIRow::new(10.0, 2.4, 5000.0, 500.0, 26.0),
        TableIRow::new(30.0, 3.6, 5770.0, 500.0, 47.0),
        TableIRow::new(50.0, 4.4, 6670.0, 500.0, 66.0),
        TableIRow::new(80.0, 5.3, 8250.0, 300.0, 90.0),
    ];
    /// Table I's rows by load.
    pub const TABLE_I_10G: MaxwellKelvin = Self::TABLE_I[0].element;
    pub const TABLE_I_30G: MaxwellKelvin = Self::TABLE_I[1].element;
    pub const TABLE_I_50G: MaxwellKelvin = Self::TABLE_I[2].element;
    pub const TABLE_I_80G: MaxwellKelvin = Self::TABLE_I[3].element;

    pub fn is_valid(&self) -> bool {
        let p = [self.g1, self.n1, self.alpha, self.n2, self.g2];
        p.iter().all(|v| v.is_finite() && *v >= 0.0)
            && self.g1 > 0.0
            && self.n1 > 0.0
            && self.n2 > 0.0
    }

    /// ε(s)/σ(s) = 1/G₁ + 1/(sN₁ + α) + 1/(sN₂ + G₂), evaluated directly from eq. 14.
    pub fn compliance(&self, s: Complex64) -> Complex64 {
        (s * self.n1 + self.alpha).inv() + (s * self.n2 + self.g2).inv() + 1.0 / self.g1
    }

    /// The mapping of eq. 16 to the coefficients of eq. 17 (FACTS.md).
    pub fn second_order(&self) -> SecondOrder {
        let MaxwellKelvin {
            g1,
            n1,
            alpha,
            n2,
            g2,
        } = *self;
        SecondOrder {
            a1: g2 / n2 + alpha / n1 + g1 / n1 + g1 / n2,
            a2: (alpha * g2 + g1 * g2 + g1 * alpha) / (n1 * n2),
            b0: g1,
            b1: g1 * (g2 / n2 + alpha / n1),
            b2: g1 * alpha * g2 / (n1 * n2),
        }
    }

    /// Forward model strain(stress) at sample period `dt_s`.
    pub fn forward<T: Real>(&self, dt_s: f64) -> Result<Discrete2<T>, ModelError> {
        if !self.is_valid() {
            return Err(ModelError::InvalidParameter {
                name: ModelParameter::MaxwellKelvin,
            });
        }
        self.second_order().forward(dt_s)
    }

    /// Inverse model stress(strain); needs α > 0 (pure Maxwell–Kelvin has a zero at the origin).
    pub fn inverse<T: Real>(&self, dt_s: f64) -> Result<Discrete2<T>, ModelError> {
        if !self.is_valid() {
            return Err(ModelError::InvalidParameter {
                name: ModelParameter::MaxwellKelvin,
            });
        }
        self.second_order().inverse(dt_s)
    }
}

/// General second-order model, eq. 17: ε/σ = (s² + a₁s + a₂)/(b₀s² + b₁s + b₂).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SecondOrder {
    pub a1: f64,
    pub a2: f64,
    pub b0: f64,
    pub b1: f64,
    pub b2: f64,
}

impl SecondOrder {
    /// The memo's fit to the sum-of-sinusoids excitation (section 4).
    pub const MEMO_FIT: SecondOrder = SecondOrder {
        a1: 3.01,
        a2: 0.784,
        b0: 5.81,
        b1: 13.26,
        b2: 2.53,
    };

    /// Strain over stress.
    pub fn compliance(&self) -> Rational2 {
        Rational2 {
            num: [1.0, self.a1, self.a2],
            den: [self.b0, self.b1, self.b2],
        }
    }

    pub fn forward<T: Real>(&self, dt_s: f64) -> Result<Discrete2<T>, ModelError> {
        self.compliance().discretize(dt_s)
    }

    /// Whether the inverse, stress over strain, is stable: the compliance's zeros (the roots
    /// of s² + a₁s + a₂) in the left half-plane, a₁, a₂ > 0. Every inverse of eq. 17 needs it.
    pub fn inverse_is_stable(&self) -> bool {
        self.a1 > 0.0 && self.a2 > 0.0
    }

    /// Stress over strain, (b₀s² + b₁s + b₂)/(s² + a₁s + a₂); needs a₁, a₂ > 0 and b₂ > 0.
    pub fn inverse<T: Real>(&self, dt_s: f64) -> Result<Discrete2<T>, ModelError> {
        if !self.inverse_is_stable() {
            return Err(ModelError::Unstable);
        }
        if self.b2 <= 0.0 {
            return Err(ModelError::NoStaticGain);
        }
        self.compliance().reciprocal().discretize(dt_s)
    }
}

pub use crate::spring::SpringLaw;

/// Eq. 14 with load-dependent springs: the finger element of the simulator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NonlinearMk {
    pub g1: SpringLaw,
    pub n1: f64,
    pub alpha: f64,
    pub n2: f64,
    pub g2: SpringLaw,
}

/// Internal strains of a [`NonlinearMk`] (percent).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NonlinearMkState {
    /// Strain of the Maxwell dashpot N₁ (∥ α): the permanent deformation.
    pub maxwell_pct: f64,
    /// Strain of the Kelvin element G₂ ∥ N₂.
    pub kelvin_pct: f64,
}

impl NonlinearMk {
    /// Element 4,2 as the simulator's nominal finger: the FACTS.md guide laws G₁(σ) = 0.5 +
    /// 0.54√σ and G₂(σ) = 17 + 0.91σ (Table I within 10 %), N₁ = 5000 (the memo's permanent
    /// deformation, 0.2 % after 1000 g·s), N₂ = 500, and α = 5 g/% (a 1000 s recovery).
    pub const ELEMENT_4_2: NonlinearMk = NonlinearMk {
        g1: SpringLaw::power(0.5, 0.54, 0.0),
        n1: 5000.0,
        alpha: 5.0,
        n2: 500.0,
        g2: SpringLaw::power(17.0, 0.0, 0.91),
    };

    /// The linear model this element behaves like for small changes about `stress_g` (secant
    /// springs at that load).
    pub fn linearized(&self, stress_g: f64) -> MaxwellKelvin {
        MaxwellKelvin {
            g1: self.g1.stiffness(stress_g),
            n1: self.n1,
            alpha: self.alpha,
            n2: self.n2,
            g2: self.g2.stiffness(stress_g),
        }
    }

    /// Total strain under `stress_g` with internal state `state`.
    #[inline]
    pub fn strain_pct(&self, state: &NonlinearMkState, stress_g: f64) -> f64 {
        self.g1.strain_pct(stress_g) + state.maxwell_pct + state.kelvin_pct
    }

    /// Strain of the surface when unloaded (what a lifted probe leaves behind).
    #[inline]
    pub fn rest_strain_pct(&self, state: &NonlinearMkState) -> f64 {
        state.maxwell_pct + state.kelvin_pct
    }

    /// Advances the internal strains by `dt_s` with `stress_g` held constant: exact for
    /// piecewise-constant stress (first-order lags solved in closed form).
    #[inline]
    pub fn step(&self, state: &mut NonlinearMkState, stress_g: f64, dt_s: f64) {
        let s = stress_g.max(0.0);
        let g2 = self.g2.stiffness(s);
        let phi_k = decay(g2 * dt_s / self.n2);
        state.kelvin_pct = state.kelvin_pct * phi_k + (1.0 - phi_k) * s / g2;
        if self.alpha > 0.0 {
            let phi_m = decay(self.alpha * dt_s / self.n1);
            state.maxwell_pct = state.maxwell_pct * phi_m + (1.0 - phi_m) * s / self.alpha;
        } else {
            state.maxwell_pct += s * dt_s / self.n1;
        }
    }
}

/// e^(−x) for x ≥ 0. The viscoelastic time constants are seconds to hours, so a step of a
/// millisecond has x below 10⁻³, where five Taylor terms are exact to f64 rounding (the next
/// term is below 10⁻¹⁷); larger x uses `exp`.
#[inline]
fn decay(x: f64) -> f64 {
    if x < 1e-3 {
        1.0 - x * (1.0 - x * (0.5 - x * (1.0 / 6.0 - x / 24.0)))
    } else {
        libm::exp(-x)
    }
}

/// The memo's normalized RMS error, eq. 12b: `G₁ · sqrt(mean((ε̂ − ε)²))`, in grams.
/// `None` for empty or mismatched input.
pub fn rms_n_g<T: Real>(g1: f64, predicted: &[T], measured: &[T]) -> Option<f64> {
    if predicted.is_empty() || predicted.len() != measured.len() {
        return None;
    }
    let sum: f64 = predicted
        .iter()
        .zip(measured)
        .map(|(p, m)| {
            let d = p.to_f64() - m.to_f64();
            d * d
        })
        .sum();
    Some(g1 * crate::trig::sqrt(sum / predicted.len() as f64))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimator::{InverseEstimator, StructuralInverse};

    /// Eqs. 8 + 9 for a step σ₀ applied at 0 and removed at `t_off`, α = 0.
    fn analytic_step(mk: &MaxwellKelvin, sigma: f64, t_off: f64, t: f64) -> f64 {
        let kelvin = |tau: f64| sigma / mk.g2 * (1.0 - (-tau * mk.g2 / mk.n2).exp());
        if t < t_off {
            sigma / mk.g1 + sigma * t / mk.n1 + kelvin(t)
        } else {
            sigma * t_off / mk.n1 + kelvin(t_off) * (-(t - t_off) * mk.g2 / mk.n2).exp()
        }
    }

    #[test]
    fn discrete_maxwell_kelvin_matches_eqs_8_and_9_on_the_memo_step() {
        let dt = 0.001;
        for mk in [MaxwellKelvin::TABLE_I_50G, MaxwellKelvin::TABLE_I_80G] {
            let model = mk.forward::<f32>(dt).unwrap();
            let mut state = Discrete2State::default();
            let mut worst: f64 = 0.0;
            for k in 0..75_000 {
                let t = k as f64 * dt;
                let sigma = if t < 50.0 { 50.0 } else { 0.0 };
                let eps = f64::from(model.update(&mut state, sigma as f32));
                // Skip the sample at the unloading instant, where the Tustin sample is the mean of
                // the two sides of the jump.
                if k != 50_000 {
                    worst = worst.max((eps - analytic_step(&mk, 50.0, 50.0, t)).abs());
                }
            }
            assert!(worst < 1e-3, "worst {worst} percentage points for {mk:?}");
        }
    }

    #[test]
    fn mapping_reproduces_eq_16_at_several_points() {
        let mk = MaxwellKelvin {
            g1: 4.4,
            n1: 6670.0,
            alpha: 3.0,
            n2: 500.0,
            g2: 66.0,
        };
        let tf = mk.second_order().compliance();
        for s in [
            (0.0, 0.01),
            (-0.05, 0.3),
            (0.2, 1.0),
            (0.0, 31.4),
            (1.5, -2.0),
            (3.0, 0.0),
        ] {
            let s = Complex64::new(s.0, s.1);
            let direct = mk.compliance(s);
            let mapped = tf.eval(s);
            let err = (direct - mapped).norm();
            let size = direct.norm();
            assert!(err < 1e-9 * size, "at {s:?}: {direct:?} vs {mapped:?}");
        }
        // And the eq. 16 coefficients written out by hand for these values.
        let so = mk.second_order();
        let n1n2 = 6670.0 * 500.0;
        assert!((so.a2 - (3.0 * 66.0 + 4.4 * 66.0 + 4.4 * 3.0) / n1n2).abs() < 1e-15);
        assert!((so.b1 - 4.4 * (66.0 / 500.0 + 3.0 / 6670.0)).abs() < 1e-12);
    }

    /// A deterministic pseudo-random step sequence in 20–40 g (xorshift).
    fn pseudo_random_stress(n: usize, dt: f64) -> Vec<f32> {
        crate::test_support::pseudo_random_steps(n, dt, 0x9E37_79B9_7F4A_7C15, 0.5, 4.0)
            .into_iter()
            .map(|s| s as f32)
            .collect()
    }

    #[test]
    fn inverse_of_forward_recovers_a_pseudo_random_stress() {
        for dt in [0.001, 0.01, 0.1] {
            for so in [
                SecondOrder::MEMO_FIT,
                MaxwellKelvin {
                    alpha: 5.0,
                    ..MaxwellKelvin::TABLE_I_30G
                }
                .second_order(),
            ] {
                let fwd = so.forward::<f32>(dt).unwrap();
                let inv = so.inverse::<f32>(dt).unwrap();
                let (mut sf, mut si) = (Discrete2State::default(), Discrete2State::default());
                let n = (100.0 / dt) as usize;
                let mut worst: f32 = 0.0;
                for sigma in pseudo_random_stress(n, dt) {
                    let eps = fwd.update(&mut sf, sigma);
                    let back = inv.update(&mut si, eps);
                    worst = worst.max((back - sigma).abs());
                }
                assert!(worst < 1e-3, "dt {dt}: worst {worst} g for {so:?}");
            }
        }
    }

    #[test]
    fn memo_inverse_has_dc_gain_b2_over_a2_and_hf_gain_b0() {
        let so = SecondOrder::MEMO_FIT;
        let dt = 0.001;
        let inv = so.inverse::<f32>(dt).unwrap();
        // DC: hold strain at 1 % for 60 s (time constants 3.4 s and 0.37 s).
        let mut state = Discrete2State::default();
        let mut y = 0.0;
        for _ in 0..60_000 {
            y = inv.update(&mut state, 1.0f32);
        }
        let dc = 2.53 / 0.784; // 3.227 g/%
        assert!((f64::from(y) - dc).abs() < 1e-3 * dc, "DC {y} vs {dc}");
        // The first sample of a step from rest is the Tustin high-frequency gain: within T/2 of
        // b₀ = 5.81 at 1 kHz.
        let mut state = Discrete2State::default();
        let first = inv.update(&mut state, 1.0f32);
        assert!((f64::from(first) - 5.81).abs() < 0.01, "HF {first}");
        assert!((so.compliance().reciprocal().dc_gain() - dc).abs() < 1e-12);
        assert_eq!(so.compliance().reciprocal().hf_gain(), 5.81);
    }

    #[test]
    fn pure_maxwell_kelvin_has_no_inverse_but_alpha_gives_one() {
        let mk = MaxwellKelvin::TABLE_I_50G;
        assert_eq!(
            mk.inverse::<f32>(0.001).unwrap_err(),
            ModelError::NoStaticGain
        );
        assert!(MaxwellKelvin { alpha: 2.0, ..mk }
            .inverse::<f32>(0.001)
            .is_ok());
        let bad = MaxwellKelvin { g1: f64::NAN, ..mk };
        let e = bad.forward::<f32>(0.001).unwrap_err();
        assert!(matches!(e, ModelError::InvalidParameter { .. }), "{e:?}");
        assert!(e.to_string().contains("G1, N1, N2, G2 or alpha"), "{e}");
    }

    #[test]
    fn inverse_estimator_clamps_at_zero() {
        let mut est = InverseEstimator::new(SecondOrder::MEMO_FIT.inverse(0.01).unwrap());
        assert!(est.force_g(3.0) > 0.0);
        // A sudden drop of strain makes the linear inverse go negative: reported as 0.
        assert_eq!(est.force_g(-5.0), 0.0);
        assert_eq!(est.force_g(f32::NAN), 0.0);
    }

    #[test]
    fn nonlinear_element_follows_the_guide_laws_and_steps_exactly() {
        let el = NonlinearMk::ELEMENT_4_2;
        // G₁(50) = 0.5 + 0.54·√50 = 4.318 (Table I: 4.4); G₂(50) = 17 + 45.5 = 62.5 (66).
        assert!((el.g1.stiffness(50.0) - 4.318_38).abs() < 1e-4);
        assert!((el.g2.stiffness(50.0) - 62.5).abs() < 1e-12);
        for e in [0.1, 1.0, 8.0, 20.0] {
            let s = el.g1.stress_g(e);
            assert!((el.g1.strain_pct(s) - e).abs() < 1e-9);
        }
        let lin = SpringLaw::power(17.0, 0.3, 0.91);
        for e in [0.1, 0.5, 1.0] {
            let s = lin.stress_g(e);
            assert!((lin.strain_pct(s) - e).abs() < 1e-9, "{e} {s}");
        }
        // Permanent deformation: 50 g for 20 s puts 1000 g·s into N₁ = 5000 → 0.2 % (less the
        // α leak, 1 %).
        let mut st = NonlinearMkState::default();
        for _ in 0..2000 {
            el.step(&mut st, 50.0, 0.01);
        }
        assert!((st.maxwell_pct - 0.2).abs() < 0.003, "{}", st.maxwell_pct);
        // One 20 s step equals 2000 steps of 10 ms: the integration is exact for constant load.
        let mut one = NonlinearMkState::default();
        el.step(&mut one, 50.0, 20.0);
        assert!((one.maxwell_pct - st.maxwell_pct).abs() < 1e-12);
        assert!((one.kelvin_pct - st.kelvin_pct).abs() < 1e-12);
    }

    #[test]
    fn decay_matches_exp_on_both_branches() {
        for x in [0.0, 1e-9, 1e-6, 1.2e-4, 9.99e-4, 1e-3, 0.5, 7.0] {
            assert!((decay(x) - (-x).exp()).abs() <= 4.0 * f64::EPSILON, "{x}");
        }
    }

    #[test]
    fn the_structural_inverse_undoes_the_element() {
        let el = NonlinearMk::ELEMENT_4_2;
        let dt = 0.001;
        let mut forward = NonlinearMkState::default();
        let mut inverse = StructuralInverse::new(el, dt);
        let mut worst: f64 = 0.0;
        for (k, sigma) in pseudo_random_stress(200_000, dt).into_iter().enumerate() {
            // The last 40 s at rest: the inverse must read zero despite the permanent deformation.
            let sigma = if k > 160_000 { 0.0 } else { f64::from(sigma) };
            let eps = el.strain_pct(&forward, sigma);
            el.step(&mut forward, sigma, dt);
            let back = f64::from(inverse.force_g(eps as f32));
            worst = worst.max((back - sigma).abs());
        }
        // f32 strain (7 digits of ~15 %) limits it to about 1e-3 g.
        assert!(worst < 5e-3, "worst {worst} g");
        assert!(
            forward.maxwell_pct > 0.5,
            "the record left a permanent deformation"
        );
    }

    #[test]
    fn rms_n_by_hand() {
        // Errors 0.1, −0.1, 0.2, 0 → mean square 0.015 → RMS 0.12247 %, × G₁ 4 = 0.4899 g.
        let p = [1.1f32, 0.9, 2.2, 3.0];
        let m = [1.0f32, 1.0, 2.0, 3.0];
        let r = rms_n_g(4.0, &p, &m).unwrap();
        assert!((r - 0.489_898).abs() < 1e-5, "{r}");
        assert_eq!(rms_n_g::<f32>(1.0, &[], &[]), None);
        assert_eq!(rms_n_g(1.0, &p[..2], &m), None);
    }
}
