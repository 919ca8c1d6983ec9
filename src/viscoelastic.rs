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
//! Linear models run sample by sample through [`Discrete2`]: the bilinear (Tustin)
//! discretization of a biproper second-order transfer function, kept in "delta" form
//! (x ← x + (A_d − I)x + B_d u) with compensated summation. The poles sit a few 10⁻⁴ inside the
//! unit circle at 1 kHz, where a direct-form biquad in f32 loses its DC gain to cancellation;
//! the delta form keeps it. Tustin makes the digital inverse the exact reciprocal of the digital
//! forward model, so inverse(forward(σ)) = σ up to rounding.

use core::ops::{Add, Div, Mul, Neg, Sub};

use num_complex::Complex64;

/// The arithmetic the discrete models run in: f32 on the chip, f64 in the host's fits.
pub trait Real:
    Copy
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    const ZERO: Self;
    fn from_f64(x: f64) -> Self;
    fn to_f64(self) -> f64;
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    #[inline]
    fn from_f64(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    #[inline]
    fn from_f64(x: f64) -> Self {
        x
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
}

/// Why a model could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ModelError {
    /// A parameter is NaN, infinite, or negative where the physics needs it positive.
    #[error("model parameter {name} is not finite, or not positive where it must be")]
    InvalidParameter { name: ModelParameter },
    /// The leading coefficient is zero: the transfer function is not biproper.
    #[error("the transfer function is not biproper (leading coefficient zero)")]
    NotBiproper,
    /// The poles of the requested direction are not in the left half-plane.
    #[error("the model's poles are not in the left half-plane")]
    Unstable,
    /// The inverse would have a zero at the origin (b₂ = 0, pure Maxwell–Kelvin): it cannot
    /// report a static force, which is why the memo adds α.
    #[error("the inverse has no static gain (b2 = 0: a pure Maxwell–Kelvin model needs alpha)")]
    NoStaticGain,
}

/// The parameter a model refused (a byte on the chip; its name on the host).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModelParameter {
    TransferFunction,
    MaxwellKelvin,
    SpringCurve,
    SpringLaw,
    SecondOrder,
    ScheduleLength,
    ScheduleLoad,
    Observer,
    Elastic,
}

impl core::fmt::Display for ModelParameter {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            ModelParameter::TransferFunction => "transfer-function coefficients or dt_s",
            ModelParameter::MaxwellKelvin => "Maxwell–Kelvin G1, N1, N2, G2 or alpha",
            ModelParameter::SpringCurve => "spring curve knots (finite, positive, rising)",
            ModelParameter::SpringLaw => "spring law",
            ModelParameter::SecondOrder => "second-order a1, a2, b0, b1, b2 or dt_s",
            ModelParameter::ScheduleLength => "schedule length",
            ModelParameter::ScheduleLoad => "schedule load",
            ModelParameter::Observer => "observer N1, N2, alpha or dt_s",
            ModelParameter::Elastic => "elastic_g_per_pct",
        })
    }
}

/// A biproper rational function (n₂s² + n₁s + n₀)/(d₂s² + d₁s + d₀), coefficients in order
/// `[s², s¹, s⁰]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rational2 {
    pub num: [f64; 3],
    pub den: [f64; 3],
}

impl Rational2 {
    /// H(s) at a complex s.
    pub fn eval(&self, s: Complex64) -> Complex64 {
        let poly = |c: &[f64; 3]| s * s * c[0] + s * c[1] + c[2];
        poly(&self.num) / poly(&self.den)
    }

    /// DC gain n₀/d₀ (infinite for a pole at the origin).
    pub fn dc_gain(&self) -> f64 {
        self.num[2] / self.den[2]
    }

    /// High-frequency gain n₂/d₂.
    pub fn hf_gain(&self) -> f64 {
        self.num[0] / self.den[0]
    }

    pub fn reciprocal(&self) -> Rational2 {
        Rational2 {
            num: self.den,
            den: self.num,
        }
    }

    /// Tustin discretization for sample period `dt_s`. Poles must be in the closed left
    /// half-plane (a pole at the origin, the Maxwell drift, is allowed).
    pub fn discretize<T: Real>(&self, dt_s: f64) -> Result<Discrete2<T>, ModelError> {
        let all = self.num.iter().chain(self.den.iter());
        if !dt_s.is_finite() || dt_s <= 0.0 || all.clone().any(|c| !c.is_finite()) {
            return Err(ModelError::InvalidParameter {
                name: ModelParameter::TransferFunction,
            });
        }
        let [d2, d1, d0] = self.den;
        if d2 == 0.0 {
            return Err(ModelError::NotBiproper);
        }
        let (e1, e0) = (d1 / d2, d0 / d2);
        // Roots of s² + e1 s + e0 in the closed left half-plane ⇔ e1 ≥ 0 and e0 ≥ 0, not both 0.
        if e1 < 0.0 || e0 < 0.0 || (e1 == 0.0 && e0 == 0.0) {
            return Err(ModelError::Unstable);
        }
        let d = self.num[0] / d2;
        let (r1, r0) = (self.num[1] / d2 - d * e1, self.num[2] / d2 - d * e0);
        // Controllable canonical form: A = [[0, 1], [−e0, −e1]], B = [0, 1], C = [r0, r1].
        let h = dt_s / 2.0;
        // M = (I − A h)⁻¹ with I − A h = [[1, −h], [e0 h, 1 + e1 h]].
        let det = (1.0 + e1 * h) + e0 * h * h;
        let m = [[(1.0 + e1 * h) / det, h / det], [-e0 * h / det, 1.0 / det]];
        // A_d − I = M A T, B_d = M B T, C_d = C M, D_d = D + C M B h, with A = [[0, 1], [−e0, −e1]].
        let [[m00, m01], [m10, m11]] = m;
        let ad_minus_i = [
            [-m01 * e0 * dt_s, (m00 - m01 * e1) * dt_s],
            [-m11 * e0 * dt_s, (m10 - m11 * e1) * dt_s],
        ];
        let bd = [m[0][1] * dt_s, m[1][1] * dt_s];
        let cd = [r0 * m[0][0] + r1 * m[1][0], r0 * m[0][1] + r1 * m[1][1]];
        let dd = d + cd[1] * h; // C M B = cd[1], since B = [0, 1]
        let cv = |x: f64| T::from_f64(x);
        Ok(Discrete2 {
            ad_minus_i: ad_minus_i.map(|r| r.map(cv)),
            bd: bd.map(cv),
            cd: cd.map(cv),
            dd: cv(dd),
        })
    }
}

/// A discretized biproper second-order model (configuration; state in [`Discrete2State`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Discrete2<T> {
    ad_minus_i: [[T; 2]; 2],
    bd: [T; 2],
    cd: [T; 2],
    dd: T,
}

/// State of a [`Discrete2`], with the compensation terms of the summation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Discrete2State<T> {
    x: [T; 2],
    carry: [T; 2],
}

impl<T: Real> Default for Discrete2State<T> {
    fn default() -> Self {
        Self {
            x: [T::ZERO; 2],
            carry: [T::ZERO; 2],
        }
    }
}

impl<T: Real> Discrete2<T> {
    /// One sample: returns the output for input `u` and advances the state.
    #[inline]
    pub fn update(&self, state: &mut Discrete2State<T>, u: T) -> T {
        let [x0, x1] = state.x;
        let y = self.cd[0] * x0 + self.cd[1] * x1 + self.dd * u;
        let [[p, q], [r, s]] = self.ad_minus_i;
        let dx = [
            p * x0 + q * x1 + self.bd[0] * u,
            r * x0 + s * x1 + self.bd[1] * u,
        ];
        for ((x, carry), d) in state.x.iter_mut().zip(state.carry.iter_mut()).zip(dx) {
            // Kahan summation: the increments are ~10⁻⁴ of the state at 1 kHz.
            let y = d - *carry;
            let t = *x + y;
            *carry = (t - *x) - y;
            *x = t;
        }
        y
    }
}

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

    /// Stress over strain, (b₀s² + b₁s + b₂)/(s² + a₁s + a₂); needs a₁, a₂ > 0 and b₂ > 0.
    pub fn inverse<T: Real>(&self, dt_s: f64) -> Result<Discrete2<T>, ModelError> {
        if self.a1 <= 0.0 || self.a2 <= 0.0 {
            return Err(ModelError::Unstable);
        }
        if self.b2 <= 0.0 {
            return Err(ModelError::NoStaticGain);
        }
        self.compliance().reciprocal().discretize(dt_s)
    }
}

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
    Some(g1 * libm::sqrt(sum / predicted.len() as f64))
}

#[cfg(test)]
mod tests {
    use super::*;

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
