//! The force controller designed from the identified applicator: the
//! excitation protocol run at several preloads, a low-order model fitted at each
//! ([`crate::applicator_model::fit_model`] to the drive less the friction, then refined with the
//! motor's friction simulated, [`crate::stick_slip::fit_with_friction`]), and from those
//! models the core's [`DesignedConfig`]:
//!
//! - the feed-forward's schedule: at each preload, the inverse of the model's path to the
//!   contact force as a series in s up to s³ (the delay left out: no controller can undo it),
//!   over the static gain of the holds before the chirps, or of the chirps' means where the
//!   holds stopped unlike in the friction band ([`crate::applicator_model::static_line`], which
//!   also gives the stiction compensated); below the lightest identified load (and above
//!   the heaviest, where a design load gave no model), models
//!   extrapolated by the modes' power law in load ([`extrapolate`]);
//! - the feedback: integral action (and a proportional term) on the error through a biquad
//!   ([`ErrorFilter`]: none, a notch at the beam's mode, or a double pole), the gains as large
//!   as the margins allow at every load on the model and its [`variants`] (each parameter
//!   [`PLANT_TOLERANCE`] off, the modes' damping down to [`DAMPING_FLOOR`], a tick more delay):
//!   gain margin ≥ [`GAIN_MARGIN`] and phase margin ≥ [`PHASE_MARGIN_DEG`]; of the filters and
//!   proportional gains tried, the one whose sensitivity peaks least in the band
//!   ([`BAND_HZ`]) with integral action of at least [`MIN_KI_PER_S`].
//!
//! The design method is loop shaping on the identified frequency responses; the reference
//! model's bandwidth puts the closed loop's −0.5 dB point past 40 Hz.
//!
//! By stage: `identified` (the excitation at each preload and what it identifies),
//! `models` (the models' plausibility and their extrapolation), `feedforward` (each load's
//! inverse series and the friction's compensation), `feedback` (the error's filter, the
//! margins and the variants they hold on) and `controller` (the design itself).

mod controller;
mod feedback;
mod feedforward;
mod identified;
mod models;

pub use controller::*;
pub use feedback::*;
pub use feedforward::*;
pub use identified::*;
pub use models::*;

use crate::applicator_model::IdentifyError;
use crate::scenario::ScenarioError;
use identified::left_out_list;

/// The preloads the applicator is identified at, g (the core's, which the firmware's
/// identification session runs too). Not lighter: a chirp small enough to keep the probe on the
/// finger at 2–5 g hardly moves the motor through its stiction (the fits came out with gains of
/// 0.05–0.12 and errors of 130 %).
pub use tactile_core::profile::DESIGN_PRELOADS_G as DESIGN_LOADS_G;
/// Loads below the identified ones the design extrapolates to ([`extrapolate`]), g. Reaching
/// down to 0.5 g took the memo rig's first step from rest from 1.5 g of overshoot to 0.03–0.24 g
/// (seeds 1–4) but slowed the heavy rig's 20 g step to 44 ms (1.6 g over) and the light rig's
/// to 41 ms: not kept.
pub const EXTRAPOLATED_LOADS_G: [f32; 3] = [1.0, 2.0, 5.0];
/// Least gain margin of the designed loop on every identified model and its [`variants`].
pub const GAIN_MARGIN: f64 = 2.0;
/// Least phase margin there, degrees.
pub const PHASE_MARGIN_DEG: f64 = 45.0;
/// How far each of a model's parameters may be off (gain, each mode's frequency and damping,
/// the amplifier's pole): the margins hold on every one moved by this share either way.
pub const PLANT_TOLERANCE: f64 = 0.2;
/// The share of an identified damping ratio the margins must also hold at (half of it at an
/// extrapolated load): a swept sine on a rig with stiction reads the damping high (the motor's
/// friction damps what it moves, and the sweep passes a sharp peak faster than it rings up).
/// Designed on the identified damping alone, the feedback (kp 0.2, ki 48/s, no filter) had a
/// gain margin of 0.6–1.0 on the memo rig's friction-free linearization; the test
/// `the_designed_feedback_keeps_its_margins_on_the_friction_free_plant` checks it on three rigs.
pub const DAMPING_FLOOR: f64 = 0.2;
/// The double poles the design tries on the error, Hz. The feed-forward tracks; the feedback
/// is for what it leaves at low frequency (the stiction's stops, the gain's error), so a pole
/// under the light loads' inertia–finger mode (20–35 Hz) is tried: on the heavy rig, whose
/// mode at 10 g sits near 25 Hz, a double pole at 40 Hz allowed an integral of 3.8/s (a 5 g
/// hold after 20 g stood 0.31 g short after 3 s), one at 15 Hz 28/s (within 0.01 g).
pub const FEEDBACK_POLES_HZ: [f64; 6] = [15.0, 25.0, 40.0, 60.0, 90.0, 140.0];
/// The notch's pole damping ratios the design tries.
pub const NOTCH_DAMPINGS: [f64; 4] = [0.3, 0.5, 0.7, 1.0];
/// The least integral gain the design accepts, 1/s: with less, the stiction's 1 g takes over
/// 50 ms to be pushed through.
pub const MIN_KI_PER_S: f64 = 20.0;
/// The reference model's triple pole, Hz: 0.45 dB down at 40 Hz.
pub const REFERENCE_HZ: f32 = 200.0;

/// Why a controller could not be designed.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    #[error(transparent)]
    Run(#[from] ScenarioError),
    /// What the record is not, before any preload is read from it.
    #[error(transparent)]
    Record(IdentifyError),
    #[error("identification at {load_g} g: {source}")]
    Identify {
        load_g: f32,
        #[source]
        source: IdentifyError,
    },
    #[error("the holds before the chirps give no static line: their drive and gauge do not rise together")]
    NoStaticLine,
    #[error("not a record of the excitation: no command_g column holding a preload from half the first {settle_s} s on")]
    NotExcitation { settle_s: f32 },
    #[error("the static line needs the excitation at two preloads or more; {have} distinct given (the holds' drive and gauge give the gain and the stiction){}", left_out_list(left_out))]
    TooFewPreloads { have: usize, left_out: Vec<LeftOut> },
    #[error(
        "the design needs models at two preloads or more; {have} usable{}",
        left_out_list(left_out)
    )]
    TooFewModels { have: usize, left_out: Vec<LeftOut> },
    #[error("the drive at its rail holds {reach_g:.0} g at the probe (its gain {static_gain:.2} of the firmware's scale, less the stiction), under the {top_g:.0} g the force steps reach: a stronger motor, amplifier or a shorter arm")]
    OutOfReach {
        reach_g: f64,
        top_g: f64,
        static_gain: f64,
    },
    #[error("no integral gain gives the margins at every load (the model at {load_g} g has a gain margin of {margin:.2} with none)")]
    NoMargin { load_g: f32, margin: f64 },
    #[error("the holds read {stiction_g:.3} g of stiction at the drive, under the {least_g:.3} g the touch-down needs to stop the probe between its pushes of {push_g:.2} g: the probe would strike the finger after a rest (a rig this free needs a sensor of the motor's position)")]
    TooLittleFriction {
        stiction_g: f32,
        push_g: f32,
        least_g: f32,
    },
    #[error("the gauge's noise ({noise_g:.2} g a reading) puts the touch-down's contact reading at {contact_g:.2} g; pulses that press the finger there push {push_g:.2} g at the drive, and the {stiction_g:.3} g of stiction there is under the {least_g:.3} g that stops the probe between them: it would strike the finger (a quieter gauge, or a sensor of the motor's position)")]
    NoisyContact {
        noise_g: f32,
        contact_g: f32,
        push_g: f32,
        stiction_g: f32,
        least_g: f32,
    },
}

#[cfg(test)]
mod tests {
    use num_complex::Complex64;
    use tactile_core::CONTROL_PERIOD_S;

    use super::*;
    use crate::applicator_model::{ApplicatorModel, Resonance};
    use feedback::biquad_at;

    #[test]
    fn the_series_of_a_single_mode_is_its_quadratic_and_a_lead_is_taken_in() {
        // One mode at 50 Hz (ζ 0.1), static gain 2, the beam, the pole and the anti-resonance far
        // away: C = (1 + 2ζs/ω + s²/ω²)/2 (the anti-resonance is the gauge's, not the force's,
        // and never enters).
        let far = Resonance {
            hz: 1e7,
            damping_ratio: 0.0,
        };
        let m = ApplicatorModel {
            gain: 2.0,
            anti_resonance: Resonance {
                hz: 80.0,
                damping_ratio: 0.05,
            },
            modes: [
                Resonance {
                    hz: 50.0,
                    damping_ratio: 0.1,
                },
                far,
            ],
            pole_hz: 1e9,
            delay_s: 1e-3,
            rms_log_error: 0.0,
        };
        let c = inverse_series(&LoadModel {
            load_g: 50.0,
            model: m,
            static_gain: 2.0,
        });
        let w = 2.0 * std::f64::consts::PI * 50.0;
        let expected = [0.5, 0.1 / w, 0.5 / (w * w)];
        for k in 0..3 {
            assert!(
                (c[k] - expected[k]).abs() <= 1e-6 * expected[k].abs(),
                "c{k} {} vs {}",
                c[k],
                expected[k]
            );
        }
        assert!(c[3].abs() < 1e-6 / (w * w * w), "c3 {}", c[3]);
        // The same mode with a lead of 0.5 ms: the inverse is C·e^(−0.5 ms·s), no polynomial;
        // its Taylor series to s³, by hand ½(1 + as + bs²)(1 − τs + τ²s²/2 − τ³s³/6) with
        // a = 2ζ/ω, b = 1/ω², is within 2 % of the fit's coefficients, and the fit's worst
        // relative error to 50 Hz (the mode) is the smaller, within 0.05 dB and 0.3° to 40 Hz.
        let tau = 0.5e-3;
        let c = inverse_series(&LoadModel {
            load_g: 50.0,
            model: ApplicatorModel { delay_s: -tau, ..m },
            static_gain: 2.0,
        });
        let (a, b) = (0.2 / w, 1.0 / (w * w));
        let taylor = [
            0.5,
            0.5 * (a - tau),
            0.5 * (b - a * tau + tau * tau / 2.0),
            0.5 * (-b * tau + a * tau * tau / 2.0 - tau * tau * tau / 6.0),
        ];
        for k in 0..4 {
            assert!(
                (c[k] - taylor[k]).abs() <= 0.02 * taylor[k].abs(),
                "with the lead, c{k} {} vs {}",
                c[k],
                taylor[k]
            );
        }
        let series = |c: &[f64; 4], s: Complex64| c[0] + c[1] * s + c[2] * s * s + c[3] * s * s * s;
        let (mut worst_fit, mut worst_cut) = (0.0f64, 0.0f64);
        for hz in (1..=50).map(f64::from) {
            let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * hz);
            let exact = 0.5 * (1.0 + a * s + b * s * s) * (-s * tau).exp();
            let (fit, cut) = (series(&c, s) / exact, series(&taylor, s) / exact);
            assert!(
                hz > BAND_HZ
                    || (fit.norm().ln().abs() < 0.05 / 8.686 && fit.arg().to_degrees().abs() < 0.3),
                "{hz} Hz: {fit}"
            );
            worst_fit = worst_fit.max((fit - 1.0).norm());
            worst_cut = worst_cut.max((cut - 1.0).norm());
        }
        assert!(worst_fit < worst_cut, "{worst_fit} vs {worst_cut}");
    }

    #[test]
    fn the_series_fits_the_inverse_over_the_band_where_truncation_misses_the_mode() {
        // The memo rig's linearization at 10 g: the inertia–finger mode at 35.7 Hz (ζ 0.07), the
        // beam's at 181.4 Hz (ζ 0.04), the amplifier's pole at 160 Hz. The inverse is of degree
        // five; truncated after s³ it drops s⁴(1/(ω₁²ω₂²) + …), which at 40 Hz is 0.06 against an
        // inverse of 0.3 in magnitude: 1.7 dB. The fit stays within 0.3 dB to 40 Hz.
        let mode = |hz: f64, damping_ratio: f64| Resonance { hz, damping_ratio };
        let m = ApplicatorModel {
            gain: 1.0,
            anti_resonance: mode(61.7, 0.05),
            modes: [mode(35.7, 0.07), mode(181.4, 0.04)],
            pole_hz: 160.0,
            delay_s: 0.0,
            rms_log_error: 0.0,
        };
        let c = inverse_series(&LoadModel {
            load_g: 10.0,
            model: m,
            static_gain: 1.0,
        });
        let q = |r: Resonance| {
            let w = 2.0 * std::f64::consts::PI * r.hz;
            [1.0, 2.0 * r.damping_ratio / w, 1.0 / (w * w)]
        };
        let (q1, q2) = (q(m.modes[0]), q(m.modes[1]));
        let p = 1.0 / (2.0 * std::f64::consts::PI * m.pole_hz);
        // (q1·q2)·(1 + ps), by hand to s³.
        let qq = [
            1.0,
            q1[1] + q2[1],
            q1[2] + q1[1] * q2[1] + q2[2],
            q1[1] * q2[2] + q1[2] * q2[1],
        ];
        let cut = [1.0, qq[1] + p, qq[2] + p * qq[1], qq[3] + p * qq[2]];
        let series = |c: &[f64; 4], s: Complex64| c[0] + c[1] * s + c[2] * s * s + c[3] * s * s * s;
        let db = |z: Complex64| 20.0 * z.norm().log10();
        for hz in [10.0, 20.0, 30.0, 35.0, 40.0] {
            let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * hz);
            let at = |k: [f64; 3]| k[0] + k[1] * s + k[2] * s * s;
            let exact = at(q1) * at(q2) * (1.0 + p * s);
            let fit = series(&c, s) / exact;
            assert!(db(fit).abs() < 0.3, "{hz} Hz: fit {:+.2} dB", db(fit));
            if hz == 40.0 {
                let cut = series(&cut, s) / exact;
                assert!(db(cut) > 1.5, "truncated {:+.2} dB", db(cut));
            }
        }
    }

    #[test]
    fn a_fit_against_the_physics_or_the_other_loads_amplifier_is_left_out() {
        // The light motor with 2.8 g of stiction at 75 g (kept) and its 100 g fit: the
        // anti-resonance under the inertia–finger mode and the pole at 30 Hz.
        let mode = |hz: f64, damping_ratio: f64| Resonance { hz, damping_ratio };
        let fit = |load_g: f32, first: f64, anti: f64, pole_hz: f64| LoadModel {
            load_g,
            model: ApplicatorModel {
                gain: 0.73,
                anti_resonance: mode(anti, 0.1),
                modes: [mode(first, 0.32), mode(292.0, 0.21)],
                pole_hz,
                delay_s: -0.86e-3,
                rms_log_error: 0.25,
            },
            static_gain: 1.0,
        };
        let kept = fit(75.0, 88.6, 119.4, 167.0);
        assert!(plausible(&kept.model));
        assert_eq!(
            implausible(&fit(100.0, 69.4, 51.9, 167.0).model),
            Some("its anti-resonance or beam mode is under the inertia–finger mode")
        );
        // The inertia–finger mode undamped (a rig with 3.9 g of stiction read its 35 g fit's
        // 27.2 Hz mode at ζ 0.00): the friction simulated took the rubber's damping.
        let mut undamped = kept.model;
        undamped.modes[0] = mode(27.2, 4e-4);
        assert_eq!(
            implausible(&undamped),
            Some(
                "its inertia–finger mode is undamped (the friction simulated took all its damping)"
            )
        );
        // A drive that was one spike: the fit's gain 0.00 and its pole at 6.5e30 Hz (the gain
        // is the first reason named).
        let mut spike = kept.model;
        spike.gain = 0.003;
        spike.pole_hz = 6.5e30;
        assert_eq!(implausible(&spike), Some("its gain is not within 0.2–5"));
        spike.gain = 0.9;
        assert_eq!(
            implausible(&spike),
            Some("its amplifier's pole is not within 20–500 Hz")
        );
        // A pole more than 2.5× off the loads' median (223 Hz) is another amplifier's: 30 Hz
        // goes, 400 Hz (1.8×) stays.
        let loads = [
            fit(20.0, 60.0, 80.6, 223.0),
            fit(35.0, 66.0, 96.2, 230.0),
            fit(50.0, 84.3, 113.7, 173.0),
            kept,
            fit(100.0, 97.0, 130.0, 30.0),
            fit(120.0, 99.0, 135.0, 400.0),
        ];
        let one: Vec<f32> = one_amplifier(&loads).iter().map(|m| m.load_g).collect();
        assert_eq!(one, vec![20.0, 35.0, 50.0, 75.0, 120.0]);
    }

    #[test]
    fn extrapolation_follows_the_modes_power_law_from_the_nearest_model() {
        // Modes on an exact power law, f₁ = 10·L^¼ and f_z = 20·L^0.3 Hz, at 10, 20 and 50 g; the
        // beam's mode marks which model the rest comes from.
        let at = |load_g: f64| LoadModel {
            load_g: load_g as f32,
            model: ApplicatorModel {
                gain: 1.0,
                anti_resonance: Resonance {
                    hz: 20.0 * load_g.powf(0.3),
                    damping_ratio: 0.1,
                },
                modes: [
                    Resonance {
                        hz: 10.0 * load_g.powf(0.25),
                        damping_ratio: 0.1,
                    },
                    Resonance {
                        hz: 100.0 + load_g,
                        damping_ratio: 0.05,
                    },
                ],
                pole_hz: 160.0,
                delay_s: 0.0,
                rms_log_error: 0.0,
            },
            static_gain: 1.0,
        };
        let models = [at(10.0), at(20.0), at(50.0)];
        // 15 g is nearer 20 g than 10 g in ratio (4/3 against 3/2).
        for (load_g, beam_hz) in [(2.0f64, 110.0), (100.0, 150.0), (15.0, 120.0)] {
            let m = extrapolate(&models, load_g as f32).unwrap().model;
            let (f1, fz) = (10.0 * load_g.powf(0.25), 20.0 * load_g.powf(0.3));
            assert!((m.modes[0].hz - f1).abs() < 1e-6 * f1, "{load_g} g: {m:?}");
            assert!(
                (m.anti_resonance.hz - fz).abs() < 1e-6 * fz,
                "{load_g} g: {m:?}"
            );
            assert_eq!(m.modes[1].hz, beam_hz, "{load_g} g");
        }
    }

    #[test]
    fn margins_of_an_integrator_with_a_delay_by_hand() {
        // L = (k/s)·e^(−sτ): the phase reaches −180° where ωτ = π/2, |L| = k/ω there; the gain
        // crossover at ω = k with phase −90° − kτ.
        let (k, tau) = (20.0f64, 0.005f64);
        let l: Vec<Complex64> = loop_grid_hz()
            .into_iter()
            .map(|hz| {
                let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * hz);
                k / s * (-s * tau).exp()
            })
            .collect();
        let m = margins(&l);
        let w180 = std::f64::consts::FRAC_PI_2 / tau;
        assert!((m.gain - w180 / k).abs() < 0.01 * w180 / k, "{m:?}");
        let pm = 90.0 - (k * tau).to_degrees();
        assert!((m.phase_deg - pm).abs() < 0.2, "{m:?} vs {pm}");
    }

    #[test]
    fn the_error_filters_pass_the_static_error_and_the_notch_removes_its_frequency() {
        let at = |f: ErrorFilter, hz: f64| {
            biquad_at(
                f.biquad(),
                Complex64::from_polar(1.0, -2.0 * std::f64::consts::PI * hz * CONTROL_PERIOD_S),
            )
        };
        for f in [
            ErrorFilter::Pass,
            ErrorFilter::Notch {
                hz: 190.0,
                damping: 0.5,
            },
            ErrorFilter::Lowpass { hz: 60.0 },
        ] {
            assert!((at(f, 0.0) - 1.0).norm() < 1e-12, "{f:?}");
        }
        let notch = ErrorFilter::Notch {
            hz: 190.0,
            damping: 0.5,
        };
        assert!(at(notch, 190.0).norm() < 1e-9);
        // The analog notch (1 − x²)/(1 − x² + 2jζx) at the frequency the bilinear transform
        // prewarped to 190 Hz maps 40 Hz to: x = tan(π·40·T)/tan(π·190·T).
        let w = |hz: f64| (std::f64::consts::PI * hz * CONTROL_PERIOD_S).tan();
        let x = w(40.0) / w(190.0);
        let analog = (1.0 - x * x) / Complex64::new(1.0 - x * x, 2.0 * 0.5 * x);
        assert!(
            (at(notch, 40.0) - analog).norm() < 1e-9,
            "{}",
            at(notch, 40.0)
        );
        // A double pole: |1/(1 + jf/fc)|² at 60 Hz, half a power at its corner.
        let lp = at(ErrorFilter::Lowpass { hz: 60.0 }, 60.0).norm();
        assert!((lp - 0.5).abs() < 0.03, "{lp}");
    }
}
