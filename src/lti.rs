//! Linear time-invariant helpers the models and estimators share: the arithmetic they run in
//! ([`Real`]), why a model is refused ([`ModelError`]), biproper second-order transfer
//! functions ([`Rational2`]) and their Tustin discretization ([`Discrete2`]).
//!
//! [`Discrete2`] keeps the bilinear discretization in "delta" form (x ← x + (A_d − I)x +
//! B_d u) with compensated summation. The poles sit a few 10⁻⁴ inside the unit circle at 1 kHz,
//! where a direct-form biquad in f32 loses its DC gain to cancellation; the delta form keeps it.
//! Tustin makes the digital inverse the exact reciprocal of the digital forward model, so
//! inverse(forward(σ)) = σ up to rounding.

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
    /// A schedule entry's eq. 17 coefficients.
    ScheduleEntry,
    Observer,
    Elastic,
    /// A force-fitted bank's scale, time constants, radii, weights or re-zero.
    Bank,
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
            ModelParameter::ScheduleEntry => "schedule entry a1, a2, b0, b1, b2",
            ModelParameter::Observer => "observer N1, N2, alpha or dt_s",
            ModelParameter::Elastic => "elastic_g_per_pct",
            ModelParameter::Bank => "force bank scale, time constants, radii, weights or re-zero",
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
