//! The feed-forward: each load's inverse series, the amplifier's time constant and the shares
//! of the stiction it pushes against and holds.

use num_complex::Complex64;

use super::models::median;
use super::*;

/// 1 + (2ζ/ω)s + s²/ω² as coefficients in s.
fn quadratic(r: crate::applicator_model::Resonance) -> [f64; 3] {
    let w = 2.0 * std::f64::consts::PI * r.hz;
    [1.0, 2.0 * r.damping_ratio / w, 1.0 / (w * w)]
}

/// The feed-forward's series c₀ + c₁s + c₂s² + c₃s³ for one load: the inverse of the model's
/// path from drive to contact force. The gauge reads the contact force plus the tip's inertia,
/// gauge = contact·(1 + s²/ω_z²), the anti-resonance ω_z being the tip on the finger alone; the
/// contact force, which the user asks for, is the model without that factor, and its inverse
/// N(s) is the modes' quadratics times the amplifier's pole over the static gain (the hold's,
/// not the chirp's: measured, the chirp's gain overdrove the memo's rig by 0.7 dB across the
/// band). A lead the fit found (τ < 0: what the form leaves of the contact's damping and the
/// stiction's phase, 0.3–0.6 ms on the simulated rigs) is the plant's, and its inverse e^(sτ)
/// a delay, causal: taken in (left out, the feed-forward was 0.8 dB too hot at 40 Hz about
/// 50 g on the memo's rig). A lag cannot be undone and stays out.
///
/// N is of degree five and the series stops at s³ (each further derivative of a step's
/// reference is an impulse more), so c₁…c₃ are N's best fit over the band
/// ([`SERIES_BAND_HZ`]) in relative error, c₀ = N(0): at s = jω the series is
/// (c₀ − c₂ω²) + j(c₁ω − c₃ω³), so c₂ fits N's real part and c₁, c₃ its imaginary part, each
/// by weighted least squares (weight 1/|N|²). N truncated after s³ instead was 1.7 dB hot at
/// 40 Hz about 10 g on the memo rig's linearization, −0.8 dB about 50 g: the dropped
/// s⁴/(ω₁²ω₂²) moves the series' zero off the inertia–finger mode.
///
/// Tried and dropped: matching the series to the measured response by least squares over
/// 1–50 Hz (the stiction lowers the small chirp's gain to 0.92 at every frequency, and the
/// feed-forward then drove 1.3 dB too hard across the band).
pub fn inverse_series(load: &LoadModel) -> [f64; 4] {
    let m = &load.model;
    let tau = m.delay_s.min(0.0);
    let inverse = |hz: f64| {
        let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * hz);
        let q = |r: crate::applicator_model::Resonance| -> Complex64 {
            let [a, b, c] = quadratic(r);
            a + b * s + c * s * s
        };
        q(m.modes[0])
            * q(m.modes[1])
            * (1.0 + s / (2.0 * std::f64::consts::PI * m.pole_hz))
            * (s * tau).exp()
            / load.static_gain
    };
    let c0 = 1.0 / load.static_gain;
    // Normal equations: real part Σw·ω⁴·c₂ = Σw·ω²(c₀ − A); imaginary part
    // [Σwω², −Σwω⁴; −Σwω⁴, Σwω⁶]·(c₁, c₃) = (ΣwωB, −Σwω³B).
    let (mut r11, mut r1, mut i11, mut i13, mut i33, mut i1, mut i3) =
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    let steps = (SERIES_BAND_HZ / SERIES_STEP_HZ).round() as usize;
    for k in 1..=steps {
        let hz = k as f64 * SERIES_STEP_HZ;
        let w = 2.0 * std::f64::consts::PI * hz;
        let n = inverse(hz);
        let weight = 1.0 / n.norm_sqr().max(1e-12);
        let (w2, w3) = (w * w, w * w * w);
        r11 += weight * w2 * w2;
        r1 += weight * w2 * (c0 - n.re);
        i11 += weight * w2;
        i13 -= weight * w * w3;
        i33 += weight * w3 * w3;
        i1 += weight * w * n.im;
        i3 -= weight * w3 * n.im;
    }
    let c2 = r1 / r11;
    let det = i11 * i33 - i13 * i13;
    let (c1, c3) = ((i1 * i33 - i13 * i3) / det, (i11 * i3 - i13 * i1) / det);
    [c0, c1, c2, c3]
}

/// The band the feed-forward's series is fitted over, Hz: the closed loop's ([`BAND_HZ`]) and
/// a quarter beyond, so the fit's error does not gather at its edge.
pub const SERIES_BAND_HZ: f64 = 1.25 * BAND_HZ;
/// The fit's frequency step, Hz.
const SERIES_STEP_HZ: f64 = 0.5;

/// The share of the identified stiction the feed-forward pushes against, in the direction the
/// reference moves (through the amplifier's inverse where it turns, [`amplifier_tau_s`]): all
/// of it, now that the models are fitted to the drive less the friction
/// ([`crate::applicator_model::PeriodMeans::less_friction`]) and refined with it simulated
/// ([`crate::stick_slip`]). Near the
/// inertia–finger mode a sine needs less drive than the stiction, and only a compensation of
/// the whole moves the motor there. Measured (`FRICTION=G ONLY=1 cargo run --release -p
/// sim-host --example design_controller [applicators/FILE.toml]`): with models fitted to the
/// plain ratio, which read the friction as the modes' damping, a quarter was all the
/// feed-forward could take (a half overshot the heavy rig's 20 g step by 1.34 g, a whole
/// peaked the memo rig's 2 g sine about 10 g +8.5 dB at 30 Hz), and that quarter left the
/// sine stuck from 25 Hz (−24.9 dB at 30 Hz on the memo's rig; −70 dB on the heavy rig's);
/// now within −0.86…+0.72 dB to 40 Hz on the memo's rig, −3.3…+1.0 dB on the heavy rig's.
pub const FRICTION_SHARE: f64 = 1.0;

/// The current amplifier's time constant, s (`DesignedConfig::amplifier_tau_s`): 1/(2πf_p) of
/// the identified pole, the median over the loads (the amplifier is one whatever the load;
/// the light loads' fits scatter most). The feed-forward's series already undoes the amplifier
/// for the force; the friction compensation, added after it, passes (1 + τs) on the chip so
/// its step at a reversal reaches the motor as the motor turns. Measured (`ONLY=1 SINES=10:2
/// cargo run --release -p sim-host --example design_controller applicators/slow-amplifier.toml`):
/// the slow amplifier's (80 Hz) 2 g sine about 10 g at 40 Hz −11.6 dB while the compensation
/// only turned 1/(2πf_p) + τ ahead, −1.7 dB through (1 + τs). The fitted delay stays out: it
/// is the series' (`inverse_series`).
pub fn amplifier_tau_s(models: &[LoadModel]) -> f64 {
    median(
        models
            .iter()
            .map(|m| 1.0 / (2.0 * std::f64::consts::PI * m.model.pole_hz))
            .collect(),
    )
    .unwrap_or(0.0)
}

/// The share of the identified stiction held, once the reference stops, in the direction it
/// last moved (`DesignedConfig::held_friction_g`): the rest of the stiction is a dead band
/// about the target, where a motor that stops short stays until the integral pushes it on.
/// Measured (`HELD=S ONLY=1 cargo run --release -p sim-host --example design_controller
/// applicators/FILE.toml`), every step after the first into ±1 g, worst, memo / heavy / light
/// rig: none 53 / 78 / 82 ms (with the flat chirp's models), a half 25 / 23 / 62 ms (the light
/// rig's 2.1 g of stiction left its 60 g step stopped 1.1 g short: it did so on the analytic
/// models too), three quarters 25 / 23 / 20 ms, a whole 37 / – / 33 ms; the closed loop's
/// magnitude the same to 0.03 dB.
pub const HELD_FRICTION_SHARE: f64 = 0.75;
