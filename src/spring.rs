//! Load-dependent springs of the finger element (eq. 14): a stiffness that depends on the load
//! the spring carries, as an analytic law (the simulator's fingers) or as a curve tabulated from
//! a calibration record (what the calibration table carries and the observer runs).
//!
//! The curve is the one form the firmware evaluates: strain at a few stresses, linear between
//! them, so the inverse (stress from strain, for the observer) is a search and a division, with
//! no law assumed. Any law becomes a curve through [`SpringLaw::curve`].
//!
//! ```
//! use tactile_core::spring::{SpringCurve, SpringLaw};
//! // G = 2 + 0.5σ g/%, tabulated at the default stresses.
//! let law = SpringLaw::power(2.0, 0.0, 0.5);
//! let curve = law.curve().unwrap();
//! // Exact at the knots (25 g is one), and its inverse returns the stress.
//! let eps = curve.strain_pct(25.0);
//! assert!((f64::from(eps) - law.strain_pct(25.0)).abs() < 1e-5);
//! let (stress, tangent) = curve.stress_g(eps);
//! assert!((stress - 25.0).abs() < 1e-3 && tangent > 0.0);
//! // Between knots, linear: at 30 g within a hundredth of the law's strain.
//! let between = f64::from(curve.strain_pct(30.0));
//! assert!((between - law.strain_pct(30.0)).abs() < 0.01 * law.strain_pct(30.0));
//! ```

use crate::lti::{ModelError, ModelParameter};

/// Knots of a [`SpringCurve`] (besides the origin).
pub const CURVE_KNOTS: usize = 10;

/// A spring's stress–strain curve through the origin: its stiffness at no load, its strain at
/// [`CURVE_KNOTS`] stresses, and between knots a quadratic through both whose slope at the
/// segment's start is the curve's tangent there (estimated from the neighbouring segments as
/// monotone cubic interpolation does), so a smoothly stiffening spring is followed to third
/// order between knots. From no load to the first knot the secant stiffness is the memo's
/// guide law G = G₀ + b√σ + cσ, through the stiffness at no load, the first knot and the
/// tangent there: a spring that starts soft (√σ, as element 4,2's G₁) is followed below its
/// first knot, where one quadratic in the strain cannot bend fast enough. Beyond the last knot
/// the strain grows at the last segment's final slope. Both stress and strain strictly
/// increase and every slope is kept under twice its segment's mean (checked and enforced at
/// construction), so the strain rises everywhere and the curve inverts with one square root.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringCurve {
    stress_g: [f32; CURVE_KNOTS],
    strain_pct: [f32; CURVE_KNOTS],
    /// Compliance dε/dσ at the start of each segment past the first (at knots 0 to 8), %/g.
    start_slope: [f32; CURVE_KNOTS - 1],
    /// The first segment's secant stiffness G = G₀ + β√(σ/σ₁) + γσ/σ₁, g/%: [G₀, β], with
    /// γ = G(σ₁) − G₀ − β (two floats: the curve stays the size it had, as the firmware holds
    /// two per taxel in a RAM budget it fills).
    soft: [f32; 2],
}

impl SpringCurve {
    /// Stresses an analytic law is tabulated at, g: dense at light loads, where a stiffening
    /// spring bends most, to 120 g (beyond the memo's 80 g steps).
    pub const DEFAULT_STRESS_G: [f32; CURVE_KNOTS] =
        [1.0, 3.0, 6.0, 10.0, 16.0, 25.0, 37.0, 55.0, 80.0, 120.0];

    /// A curve through `(stress_g[k], strain_pct[k])`: every value finite and positive, both
    /// strictly increasing. Its stiffness at no load is estimated from the first two segments
    /// (the three-point end formula on the compliance); a spring that starts soft reads stiffer
    /// there than it is: give the stiffness with [`Self::with_origin`] where it is known.
    pub fn new(
        stress_g: [f32; CURVE_KNOTS],
        strain_pct: [f32; CURVE_KNOTS],
    ) -> Result<Self, ModelError> {
        Self::build(stress_g, strain_pct, None)
    }

    /// A curve through the knots (as [`Self::new`]) whose stiffness at no load is
    /// `origin_g_per_pct` (finite, positive).
    pub fn with_origin(
        stress_g: [f32; CURVE_KNOTS],
        strain_pct: [f32; CURVE_KNOTS],
        origin_g_per_pct: f32,
    ) -> Result<Self, ModelError> {
        if !(origin_g_per_pct.is_finite() && origin_g_per_pct > 0.0) {
            return Err(ModelError::InvalidParameter {
                name: ModelParameter::SpringCurve,
            });
        }
        Self::build(stress_g, strain_pct, Some(origin_g_per_pct))
    }

    fn build(
        stress_g: [f32; CURVE_KNOTS],
        strain_pct: [f32; CURVE_KNOTS],
        origin_g_per_pct: Option<f32>,
    ) -> Result<Self, ModelError> {
        let rising = |v: &[f32; CURVE_KNOTS]| {
            v.iter().all(|x| x.is_finite())
                && v.first().is_some_and(|x| *x > 0.0)
                && v.windows(2).all(|w| matches!(w, [a, b] if b > a))
        };
        if !(rising(&stress_g) && rising(&strain_pct)) {
            return Err(ModelError::InvalidParameter {
                name: ModelParameter::SpringCurve,
            });
        }
        // Segment k runs from knot k − 1 (the origin for k = 0) to knot k.
        let at = |v: &[f32; CURVE_KNOTS], k: usize| {
            k.checked_sub(1)
                .and_then(|i| v.get(i))
                .copied()
                .unwrap_or(0.0)
        };
        let width = |k: usize| at(&stress_g, k + 1) - at(&stress_g, k);
        let mean = |k: usize| (at(&strain_pct, k + 1) - at(&strain_pct, k)) / width(k);
        let mut tangent = [0.0f32; CURVE_KNOTS];
        for (k, slot) in tangent.iter_mut().enumerate() {
            let (m, h) = (mean(k), width(k));
            let t = match k.checked_sub(1) {
                // At the origin: the three-point end formula from the first two segments.
                None => {
                    let (m1, h1) = (mean(1), width(1));
                    m + (m - m1) * h / (h + h1)
                }
                // Inside: the weighted harmonic mean of the two segments' means (Fritsch and
                // Butland), between them.
                Some(j) => {
                    let (mj, hj) = (mean(j), width(j));
                    let (w1, w2) = (2.0 * h + hj, h + 2.0 * hj);
                    (w1 + w2) / (w1 / mj + w2 / m)
                }
            };
            // Under twice the mean, the segment's slope stays positive to its end.
            // (max/min, not clamp: clamp panics on NaN bounds, which pulls float formatting
            // into the firmware.)
            *slot = t.max(0.05 * m).min(1.9 * m);
        }
        let mut start_slope = [0.0f32; CURVE_KNOTS - 1];
        for (slot, t) in start_slope.iter_mut().zip(tangent.iter().skip(1)) {
            *slot = *t;
        }
        let g0 = origin_g_per_pct.unwrap_or(1.0 / tangent[0]);
        Ok(Self {
            stress_g,
            strain_pct,
            start_slope,
            soft: soft_start(g0, stress_g[0] / strain_pct[0], tangent[1]),
        })
    }

    /// The stiffness at no load, g/%.
    pub fn origin_g_per_pct(&self) -> f32 {
        self.soft[0]
    }

    /// The knots as (stress g, strain %).
    pub fn knots(&self) -> impl Iterator<Item = (f32, f32)> + '_ {
        self.stress_g
            .iter()
            .copied()
            .zip(self.strain_pct.iter().copied())
    }

    /// The largest stress tabulated, g (beyond it the curve is extrapolated).
    pub fn range_g(&self) -> f32 {
        self.stress_g[CURVE_KNOTS - 1]
    }

    /// The segment past the first knot holding `x` on the strain axis (`along_strain`) or the
    /// stress axis: its start (σ₀, ε₀), its start slope t and its curvature a
    /// (ε = ε₀ + t·d + a·d²). Past the last knot: a straight line at the last segment's final
    /// slope.
    fn segment(&self, x: f32, along_strain: bool) -> (f32, f32, f32, f32) {
        let (mut s0, mut e0) = (self.stress_g[0], self.strain_pct[0]);
        for ((&s1, &e1), &t) in self
            .stress_g
            .iter()
            .zip(&self.strain_pct)
            .skip(1)
            .zip(&self.start_slope)
        {
            if x <= if along_strain { e1 } else { s1 } {
                let h = s1 - s0;
                let mean = (e1 - e0) / h;
                return (s0, e0, t, (mean - t) / h);
            }
            (s0, e0) = (s1, e1);
        }
        let mean = (self.strain_pct[CURVE_KNOTS - 1] - self.strain_pct[CURVE_KNOTS - 2])
            / (self.stress_g[CURVE_KNOTS - 1] - self.stress_g[CURVE_KNOTS - 2]);
        (s0, e0, 2.0 * mean - self.start_slope[CURVE_KNOTS - 2], 0.0)
    }

    /// The first segment's [G₀, β, γ] and its end (σ₁, ε₁).
    fn first(&self) -> ([f32; 3], f32, f32) {
        let (s1, e1) = (self.stress_g[0], self.strain_pct[0]);
        let [g0, beta] = self.soft;
        ([g0, beta, s1 / e1 - g0 - beta], s1, e1)
    }

    /// Strain under `stress_g` (σ ≤ 0: none).
    pub fn strain_pct(&self, stress_g: f32) -> f32 {
        if stress_g.is_nan() || stress_g <= 0.0 {
            return 0.0;
        }
        let ([g0, beta, gamma], s1, _) = self.first();
        if stress_g <= s1 {
            let r = stress_g / s1;
            return stress_g / (g0 + beta * crate::trig::sqrtf(r) + gamma * r);
        }
        let (s0, e0, t, a) = self.segment(stress_g, false);
        let d = stress_g - s0;
        e0 + d * (t + a * d)
    }

    /// The stress that stretches the spring by `strain_pct` (ε ≤ 0: none), and the tangent
    /// stiffness dσ/dε there.
    pub fn stress_g(&self, strain_pct: f32) -> (f32, f32) {
        let e = if strain_pct.is_nan() {
            0.0
        } else {
            strain_pct.max(0.0)
        };
        let ([g0, beta, gamma], s1, e1) = self.first();
        if e <= e1 {
            // σ = ε·G(σ): with v = √(σ/σ₁), (σ₁ − γε)v² − βεv − G₀ε = 0 (σ₁ − γε > 0 on the
            // segment), solved in the form that does not cancel.
            let (qa, qb, qc) = (s1 - gamma * e, beta * e, g0 * e);
            let root = crate::trig::sqrtf((qb * qb + 4.0 * qa * qc).max(0.0));
            let v = if qb >= 0.0 {
                (qb + root) / (2.0 * qa)
            } else {
                2.0 * qc / (root - qb)
            };
            let g = g0 + v * (beta + gamma * v);
            // dε/dσ = (G − σG′)/G² = (G₀ + β v/2)/G².
            return (s1 * v * v, g * g / (g0 + 0.5 * beta * v));
        }
        let (s0, e0, t, a) = self.segment(e, true);
        // a d² + t d = r, in the form that does not cancel.
        let r = e - e0;
        let root = crate::trig::sqrtf((t * t + 4.0 * a * r).max(0.0));
        let d = 2.0 * r / (t + root);
        (s0 + d, 1.0 / (t + 2.0 * a * d))
    }

    /// Secant stiffness σ/ε(σ), g/% (the stiffness at no load at σ ≤ 0).
    pub fn stiffness(&self, stress_g: f32) -> f32 {
        if stress_g.is_nan() || stress_g <= 0.0 {
            return self.soft[0];
        }
        stress_g / self.strain_pct(stress_g)
    }

    /// The same spring `k` times as stiff.
    pub fn scaled(&self, k: f64) -> Self {
        let soft = |e: f32| (f64::from(e) / k) as f32;
        let stiff = |g: f32| (f64::from(g) * k) as f32;
        Self {
            stress_g: self.stress_g,
            strain_pct: self.strain_pct.map(soft),
            start_slope: self.start_slope.map(soft),
            soft: self.soft.map(stiff),
        }
    }
}

/// The first segment's [G₀, β] (G = G₀ + β√(σ/σ₁) + γσ/σ₁) from the stiffness at no load `g0`,
/// the first knot's secant stiffness `g1` = G(σ₁) and the compliance `tangent` there. With
/// D = G(σ₁) − G₀ and S = σ₁G′(σ₁): β = 2(D − S), γ = 2S − D. S is kept at most max(D, D/2),
/// so β ≥ 0 or γ ≤ 0: G, rising or concave in √σ, stays above the lesser of its positive ends,
/// and dε/dσ = (G₀ + β√(σ/σ₁)/2)/G², linear in √σ between positive ends, too.
fn soft_start(g0: f32, g1: f32, tangent: f32) -> [f32; 2] {
    let d = g1 - g0;
    let s = (g1 - tangent * g1 * g1).min(d.max(0.5 * d));
    [g0, 2.0 * (d - s)]
}

/// A spring whose stiffness depends on the load it carries (secant stiffness G(σ), g/%, σ ≥ 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpringLaw {
    /// G = base + sqrt_coeff·√σ + linear_coeff·σ (the memo's guide laws, FACTS.md).
    Power {
        base: f64,
        sqrt_coeff: f64,
        linear_coeff: f64,
    },
    /// G = base + gain·(1 − e^(−σ/scale_g)): stiffens, then saturates.
    Saturating { base: f64, gain: f64, scale_g: f64 },
    /// Tabulated (a calibration's).
    Curve(SpringCurve),
}

impl SpringLaw {
    pub const fn power(base: f64, sqrt_coeff: f64, linear_coeff: f64) -> Self {
        SpringLaw::Power {
            base,
            sqrt_coeff,
            linear_coeff,
        }
    }

    pub const fn constant(g: f64) -> Self {
        Self::power(g, 0.0, 0.0)
    }

    /// Positive stiffness at no load, non-negative stiffening, finite everything: then the
    /// strain σ/G(σ) increases with σ and the law can be inverted.
    pub fn is_valid(&self) -> bool {
        let ok = |v: &[f64]| v.iter().all(|x| x.is_finite() && *x >= 0.0);
        match *self {
            SpringLaw::Power {
                base,
                sqrt_coeff,
                linear_coeff,
            } => base > 0.0 && ok(&[sqrt_coeff, linear_coeff]),
            SpringLaw::Saturating {
                base,
                gain,
                scale_g,
            } => base > 0.0 && scale_g > 0.0 && ok(&[gain, scale_g]),
            // Checked at construction.
            SpringLaw::Curve(_) => true,
        }
    }

    /// Stiffness carrying `stress_g` (σ < 0 is treated as 0).
    #[inline]
    pub fn stiffness(&self, stress_g: f64) -> f64 {
        let s = stress_g.max(0.0);
        match *self {
            SpringLaw::Power {
                base,
                sqrt_coeff,
                linear_coeff,
            } => base + sqrt_coeff * crate::trig::sqrt(s) + linear_coeff * s,
            SpringLaw::Saturating {
                base,
                gain,
                scale_g,
            } => base + gain * (1.0 - libm::exp(-s / scale_g)),
            SpringLaw::Curve(c) => f64::from(c.stiffness(s as f32)),
        }
    }

    /// Strain of the spring under `stress_g`.
    #[inline]
    pub fn strain_pct(&self, stress_g: f64) -> f64 {
        match self {
            SpringLaw::Curve(c) => f64::from(c.strain_pct(stress_g as f32)),
            _ => stress_g / self.stiffness(stress_g),
        }
    }

    /// The stress that stretches the spring by `strain_pct` (≥ 0; the inverse of
    /// [`Self::strain_pct`], which is monotone for a valid law).
    pub fn stress_g(&self, strain_pct: f64) -> f64 {
        if strain_pct.is_nan() || strain_pct <= 0.0 {
            return 0.0;
        }
        let e = strain_pct;
        match *self {
            SpringLaw::Power {
                base,
                sqrt_coeff,
                linear_coeff,
            } => {
                // σ (1 − cε) − b√σ ε − aε = 0 with u = √σ; beyond cε = 1 the spring is rigid at
                // this strain: saturate at a large stress.
                let a = 1.0 - linear_coeff * e;
                if a <= 1e-9 {
                    return 1e9;
                }
                let b = sqrt_coeff * e;
                let u = (b + crate::trig::sqrt(b * b + 4.0 * a * base * e)) / (2.0 * a);
                u * u
            }
            SpringLaw::Saturating {
                base,
                gain,
                scale_g,
            } => {
                // Monotone and bracketed by the end stiffnesses: Newton's method on the strain,
                // kept inside the bracket (bisecting when a step would leave it).
                let (mut lo, mut hi) = (base * e, (base + gain) * e);
                let mut s = 0.5 * (lo + hi);
                for _ in 0..50 {
                    let decay = libm::exp(-s / scale_g);
                    let g = base + gain * (1.0 - decay);
                    let miss = s / g - e;
                    if miss < 0.0 {
                        lo = s;
                    } else {
                        hi = s;
                    }
                    // dε/dσ = (G − σ G')/G², G' = gain e^(−σ/scale)/scale.
                    let slope = (g - s * gain * decay / scale_g) / (g * g);
                    let next = s - miss / slope;
                    let next = if next > lo && next < hi {
                        next
                    } else {
                        0.5 * (lo + hi)
                    };
                    if (next - s).abs() <= 1e-13 * s.max(1e-12) {
                        return next;
                    }
                    s = next;
                }
                s
            }
            SpringLaw::Curve(c) => f64::from(c.stress_g(e as f32).0),
        }
    }

    /// The same law `k` times as stiff.
    pub fn scaled(&self, k: f64) -> Self {
        match *self {
            SpringLaw::Power {
                base,
                sqrt_coeff,
                linear_coeff,
            } => Self::power(base * k, sqrt_coeff * k, linear_coeff * k),
            SpringLaw::Saturating {
                base,
                gain,
                scale_g,
            } => SpringLaw::Saturating {
                base: base * k,
                gain: gain * k,
                scale_g,
            },
            SpringLaw::Curve(c) => SpringLaw::Curve(c.scaled(k)),
        }
    }

    /// The law as a curve: itself if tabulated, else sampled at
    /// [`SpringCurve::DEFAULT_STRESS_G`], with the law's own stiffness at no load.
    pub fn curve(&self) -> Result<SpringCurve, ModelError> {
        match self {
            SpringLaw::Curve(c) => Ok(*c),
            law if law.is_valid() => {
                let stress = SpringCurve::DEFAULT_STRESS_G;
                let strain = stress.map(|s| law.strain_pct(f64::from(s)) as f32);
                SpringCurve::with_origin(stress, strain, law.stiffness(0.0) as f32)
            }
            _ => Err(ModelError::InvalidParameter {
                name: ModelParameter::SpringLaw,
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_law_inverts_its_own_strain() {
        let laws = [
            SpringLaw::power(0.5, 0.54, 0.0),
            SpringLaw::power(17.0, 0.3, 0.91),
            SpringLaw::Saturating {
                base: 10.0,
                gain: 40.0,
                scale_g: 25.0,
            },
            SpringLaw::Curve(SpringLaw::power(2.0, 0.0, 0.1).curve().unwrap()),
        ];
        for law in laws {
            // (Strains the linear law reaches: it is rigid beyond 1/0.91 %.)
            for e in [0.05, 0.5, 1.0, 2.0, 8.0, 20.0] {
                let s = law.stress_g(e);
                if s >= 1e9 {
                    continue;
                }
                let back = law.strain_pct(s);
                // f32 knots for the curve.
                assert!(
                    (back - e).abs() < 1e-5 * e.max(1.0),
                    "{law:?} {e} {s} {back}"
                );
            }
            assert_eq!(law.stress_g(-1.0), 0.0);
            assert_eq!(law.stress_g(f64::NAN), 0.0);
        }
    }

    #[test]
    fn a_saturating_law_by_hand() {
        // G(25) = 10 + 40 (1 − e⁻¹) = 35.285; G(∞) = 50.
        let law = SpringLaw::Saturating {
            base: 10.0,
            gain: 40.0,
            scale_g: 25.0,
        };
        assert!((law.stiffness(25.0) - 35.284_82).abs() < 1e-4);
        assert!((law.stiffness(1e6) - 50.0).abs() < 1e-9);
        assert!((law.scaled(2.0).stiffness(25.0) - 70.569_65).abs() < 1e-4);
    }

    #[test]
    fn a_curve_by_hand() {
        // A straight line (1 %/g) is kept straight: every slope is the mean.
        let stress = [2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 256.0, 512.0, 1024.0];
        let line = SpringCurve::new(stress, stress).unwrap();
        assert_eq!(line.strain_pct(3.0), 3.0);
        assert_eq!(line.stress_g(700.0), (700.0, 1.0));
        assert_eq!(line.strain_pct(2000.0), 2000.0);
        // Strains 1, 2, 3.5, then 1 % per knot: segment means 0.5, 0.5, 0.375, 0.25, …
        let mut strain = [0.0f32; CURVE_KNOTS];
        for (k, e) in strain.iter_mut().enumerate() {
            *e = match k {
                0 => 1.0,
                1 => 2.0,
                _ => 1.5 + k as f32,
            };
        }
        let c = SpringCurve::new(stress, strain).unwrap();
        // Through every knot.
        for (s, e) in stress.iter().zip(&strain) {
            assert!((c.strain_pct(*s) - e).abs() < 1e-6, "{s}");
            assert!((c.stress_g(*e).0 - s).abs() < 1e-4, "{e}");
        }
        // Segment 4–8 g (mean 0.375 %/g) starts at the harmonic mean of 0.5 and 0.375 with
        // weights 2·4 + 2 = 10 and 4 + 2·2 = 8: 18/(10/0.5 + 8/0.375) = 0.43548 %/g; its
        // curvature is (0.375 − 0.43548)/4; at 6 g: 2 + 2·0.43548 + 4·(−0.015121) = 2.81048.
        assert!(
            (c.strain_pct(6.0) - 2.810_48).abs() < 1e-5,
            "{}",
            c.strain_pct(6.0)
        );
        let (s, tangent) = c.stress_g(2.810_48);
        assert!((s - 6.0).abs() < 1e-4, "{s}");
        assert!((1.0 / tangent - (0.435_48 - 2.0 * 0.015_121 * 2.0)).abs() < 1e-4);
        assert_eq!(c.stress_g(-1.0), (0.0, c.origin_g_per_pct()));
        assert_eq!(c.range_g(), 1024.0);
        assert_eq!(c.scaled(2.0).strain_pct(4.0), 1.0);
        // Not rising, or not finite: refused.
        let mut flat = strain;
        flat[5] = flat[4];
        assert!(SpringCurve::new(stress, flat).is_err());
        let mut nan = stress;
        nan[0] = f32::NAN;
        assert!(SpringCurve::new(nan, strain).is_err());
        for g0 in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(
                SpringCurve::with_origin(stress, strain, g0).is_err(),
                "{g0}"
            );
        }
        assert!(SpringLaw::power(-1.0, 0.0, 0.0).curve().is_err());
    }

    #[test]
    fn a_curve_rises_everywhere_whatever_its_knots() {
        // Strains that jump and stall between knots: the slope stays positive on every segment.
        let stress = [1.0, 1.5, 9.0, 10.0, 30.0, 31.0, 60.0, 61.0, 90.0, 200.0];
        let strain = [5.0, 5.01, 5.02, 9.0, 9.01, 12.0, 12.01, 12.02, 20.0, 20.5];
        let c = SpringCurve::new(stress, strain).unwrap();
        let mut last = 0.0f32;
        for i in 1..=2500 {
            let e = c.strain_pct(i as f32 * 0.1);
            assert!(e > last, "{}: {e} after {last}", i as f32 * 0.1);
            last = e;
        }
    }

    #[test]
    fn a_tabulated_law_follows_the_law_between_its_knots() {
        // Element 4,2's G₁ (0.5 + 0.54√σ): within 0.01 % strain (under 0.05 g) from 6 to 100
        // g, within 0.03 % below, where √σ bends hardest.
        let law = SpringLaw::power(0.5, 0.54, 0.0);
        let curve = law.curve().unwrap();
        for s in [2.0f32, 4.5, 8.0, 13.0, 20.0, 30.0, 45.0, 67.0, 100.0] {
            let (exact, tab) = (law.strain_pct(f64::from(s)), f64::from(curve.strain_pct(s)));
            let tolerance = if s < 6.0 { 0.03 } else { 0.01 };
            assert!((exact - tab).abs() < tolerance, "{s}: {exact} vs {tab}");
        }
    }

    #[test]
    fn a_soft_start_is_followed_below_the_first_knot() {
        // Element 4,2's G₁ = 0.5 + 0.54√σ: strain 0.1/(0.5 + 0.54·0.31623) = 0.149084 % at
        // 0.1 g, 0.376993 % at 0.3 g, 0.566998 % at 0.5 g; compliance 2 %/g at no load. The
        // first knot is at 1 g. The curve without the law's stiffness at no load took 1.09 %/g
        // there and read these strains as 39, 20 and 11 % more load.
        let law = SpringLaw::power(0.5, 0.54, 0.0);
        let curve = law.curve().unwrap();
        assert_eq!(curve.origin_g_per_pct(), 0.5);
        assert_eq!(curve.stiffness(0.0), 0.5);
        for (load, strain) in [(0.1f32, 0.149_084f32), (0.3, 0.376_993), (0.5, 0.566_998)] {
            let e = curve.strain_pct(load);
            assert!((e / strain - 1.0).abs() < 0.02, "{load} g: {e} %");
            let (stress, tangent) = curve.stress_g(strain);
            assert!((stress / load - 1.0).abs() < 0.02, "{strain} %: {stress} g");
            // The law's tangent stiffness dσ/dε = G²/(G₀ + b√σ/2) at 0.1 g: G = 0.67076,
            // 0.67076²/(0.5 + 0.27·0.31623) = 0.76860 g/%.
            if load == 0.1 {
                assert!((tangent / 0.768_60 - 1.0).abs() < 0.03, "{tangent}");
            }
        }
        // Rising from no load through the first knot into the next segment, and inverting.
        let mut last = 0.0f32;
        for i in 1..=300 {
            let s = i as f32 * 0.01;
            let e = curve.strain_pct(s);
            assert!(e > last, "{s}: {e} after {last}");
            assert!((curve.stress_g(e).0 - s).abs() < 1e-4 * s.max(1.0), "{s}");
            last = e;
        }
        // A spring linear to its first knot stays straight there, whatever the next segment.
        let stress = SpringCurve::DEFAULT_STRESS_G;
        let mut strain = stress.map(|s| s / 12.0);
        for e in strain.iter_mut().skip(1) {
            *e = 1.0 / 12.0 + (*e - 1.0 / 12.0) * 0.5;
        }
        let c = SpringCurve::with_origin(stress, strain, 12.0).unwrap();
        for s in [0.1f32, 0.4, 0.9] {
            assert!((c.strain_pct(s) - s / 12.0).abs() < 1e-7, "{s}");
        }
        // Scaled, the stiffness at no load scales with it.
        assert_eq!(curve.scaled(2.0).origin_g_per_pct(), 1.0);
    }
}
