//! Fingers to calibrate and score the estimators on: the memo's element 4,2 and
//! fingers of the same physics (eq. 14) whose springs stiffen by other laws, with other α and
//! relaxation times. Each taxel of a finger varies about its element as the simulator's do.

use serde::Serialize;
use tactile_core::spring::{SpringCurve, SpringLaw};
use tactile_core::viscoelastic::NonlinearMk;

use crate::finger::{Effects, LINEAR_SATURATING_ELEMENT};

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FingerKind {
    /// Element 4,2: G₁ = 0.5 + 0.54√σ, G₂ = 17 + 0.91σ, α = 5 (what the calibration once assumed).
    Memo,
    /// G₁ linear in load, G₂ saturating, α = 6 (`LINEAR_SATURATING_ELEMENT`).
    LinearSaturating,
    /// G₁ saturating, G₂ linear and stiff, α = 2, a slower Kelvin branch (N₂ = 1500).
    Saturating,
    /// Piecewise-linear stress–strain curves with kinks between the calibration's knots, α =
    /// 10, a faster Kelvin branch (N₂ = 250).
    Piecewise,
}

impl FingerKind {
    pub const ALL: [FingerKind; 4] = [
        FingerKind::Memo,
        FingerKind::LinearSaturating,
        FingerKind::Saturating,
        FingerKind::Piecewise,
    ];

    pub fn name(self) -> &'static str {
        match self {
            FingerKind::Memo => "memo (√ and linear)",
            FingerKind::LinearSaturating => "linear G1, saturating G2",
            FingerKind::Saturating => "saturating G1, linear G2",
            FingerKind::Piecewise => "piecewise",
        }
    }

    /// The element the finger's taxels vary about.
    pub fn element(self) -> NonlinearMk {
        match self {
            FingerKind::Memo => NonlinearMk::ELEMENT_4_2,
            FingerKind::LinearSaturating => LINEAR_SATURATING_ELEMENT,
            FingerKind::Saturating => NonlinearMk {
                g1: SpringLaw::Saturating {
                    base: 1.5,
                    gain: 4.0,
                    scale_g: 40.0,
                },
                n1: 8000.0,
                alpha: 2.0,
                n2: 1500.0,
                g2: SpringLaw::power(25.0, 0.0, 0.5),
            },
            FingerKind::Piecewise => NonlinearMk {
                g1: piecewise(&[1.8, 1.8, 3.75, 3.75, 3.75, 7.5, 7.5, 12.0, 12.0, 18.0]),
                n1: 4000.0,
                alpha: 10.0,
                n2: 250.0,
                g2: piecewise(&[12.0, 20.0, 20.0, 35.0, 35.0, 60.0, 60.0, 60.0, 90.0, 90.0]),
            },
        }
    }

    /// The simulator's effects for this finger (nothing else switched on).
    pub fn effects(self) -> Effects {
        Effects {
            element: (self != FingerKind::Memo).then(|| self.element()),
            ..Effects::MEMO
        }
    }
}

/// A spring of stiffness `segment_g_per_pct[k]` between knots at 5, 11, 18, 27, 33, 48, 62,
/// 77, 96 and 140 g (not the calibration's; the first segment from no load): a stiffness that
/// doubles within a few grams. (The finger's G₁ is 1.5 times the first version's, which
/// strained 30 % at 100 g where the read-out's converter rails, near 25 %.)
fn piecewise(segment_g_per_pct: &[f64; 10]) -> SpringLaw {
    const KNOTS_G: [f32; 10] = [5.0, 11.0, 18.0, 27.0, 33.0, 48.0, 62.0, 77.0, 96.0, 140.0];
    let mut strain = [0.0f32; 10];
    let (mut e, mut s0) = (0.0f64, 0.0f64);
    for ((slot, s), g) in strain.iter_mut().zip(KNOTS_G).zip(segment_g_per_pct) {
        e += (f64::from(s) - s0) / g;
        s0 = f64::from(s);
        *slot = e as f32;
    }
    // Positive stiffnesses on rising knots: the curve is valid, straight to its first knot.
    SpringCurve::with_origin(KNOTS_G, strain, segment_g_per_pct[0] as f32)
        .map_or(SpringLaw::constant(1.0), SpringLaw::Curve)
}
