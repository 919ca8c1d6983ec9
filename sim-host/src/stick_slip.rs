//! The applicator's model refined with the motor's Coulomb friction in it: the
//! chirp's record simulated tick by tick through the model, the motor sticking where the
//! friction can hold it, and the model's parameters fitted to the simulated gauge's spectrum.
//!
//! A chirp small enough to keep the probe on a light preload moves the motor little, and on a
//! rig with a large stiction the motor sticks through much of each cycle. A linear model
//! fitted to that response, even with the friction taken off the drive as a constant against
//! the motion ([`crate::applicator_model::PeriodMeans::less_friction`]), reads the sticking as damping
//! of the inertia–finger mode: on a rig with 2.2 g of stiction its 10 g fit read ζ 0.17 for
//! the plant's 0.06 (41 % RMS), and the feed-forward built on it, which compensates the
//! friction besides, lifted a 2 g sine about 10 g by 17 dB at 30 Hz.
//!
//! The model's form is [`ApplicatorModel`]'s. The friction acts on the motor, after the
//! amplifier, where the drive's torque does; the motor's velocity is the model's path to the
//! gauge with the tip on the finger alone (the anti-resonance, ω_z) replaced by the tip on the
//! finger and the beam together, ω_t² = ω₁² + ω₂² − ω₁²ω₂²/ω_z² (the two-mass plant:
//! ω₁²ω₂² = ω_z²·k_b/J and ω₁² + ω₂² = ω_t² + k_b/J). Each sub-step the friction is the force
//! that would stop the motor by the step's end, clamped to ± the stiction (time-stepping
//! friction after Moreau: sticking and sliding without a switch or a smoothing velocity).

use nalgebra::{SMatrix, SVector};
use num_complex::Complex64;

use crate::applicator_model::{
    ApplicatorModel, ModelProblem, PeriodMeans, ResponsePoint, Spectrum,
};

/// Sub-steps per tick: the friction is decided this often, and the gauge read at each step's
/// end and averaged over the tick (the firmware averages eight samples; the half sub-step
/// between the two averages' centres is in the fitted delay). A stop or a start falls on a
/// sub-step's end, so the simulated gauge, and the fit's cost, moves in small jumps as a
/// parameter or the drive moves: with 8 a tick, the 10 g chirp's cost rippled by 3e-5 (of 0.09)
/// every 0.005 of the inertia–finger mode's damping, and the fit stopped in one ripple or the
/// next (ζ 0.072 or 0.076) as the record's drive moved in its fifth digit (the firmware's ticks
/// against the same run's CSV). With 32, each averaged, the ripples are a third as deep and the
/// two records give the same damping to four digits (reading only every fourth of the 32, as
/// the firmware's eight, left them 0.3 % apart at 10 g and 3 % at 20 g).
const SUBSTEPS: usize = 32;
/// Periods simulated before the one compared: the inertia–finger mode's transient (ζ 0.05 at
/// 30 Hz decays by e in 0.1 s) is gone after one.
const WARM_PERIODS: usize = 1;

/// States: the amplifier's output (drive grams), then w, w′ and r, r′ of the two modes in
/// cascade (M₁ w = a − f, M₂ r = w); the gauge and the motor's velocity are rows over them.
type State = SVector<f64, 5>;
type Row = nalgebra::SMatrix<f64, 1, 5>;

struct Discrete {
    a: SMatrix<f64, 5, 5>,
    drive: State,
    friction: State,
    gauge: Row,
    velocity: Row,
    /// velocity · friction: how much a gram of friction over a sub-step slows the motor.
    stopping: f64,
}

impl Discrete {
    fn of(m: &ApplicatorModel, dt_s: f64) -> Option<Self> {
        let tau = 2.0 * std::f64::consts::PI;
        let (w1, z1) = (tau * m.modes[0].hz, m.modes[0].damping_ratio);
        let (w2, z2) = (tau * m.modes[1].hz, m.modes[1].damping_ratio);
        let (wz, zz) = (tau * m.anti_resonance.hz, m.anti_resonance.damping_ratio);
        let wa = tau * m.pole_hz;
        let wt2 = w1 * w1 + w2 * w2 - (w1 * w2 / wz).powi(2);
        if wt2.is_nan() || wt2 <= 0.0 {
            return None;
        }
        let wt = wt2.sqrt();
        // The contact's damping over the tip's mass, the same whichever springs it sits on.
        let zt = zz * wz / wt;
        let mut a = SMatrix::<f64, 7, 7>::zeros();
        a[(0, 0)] = -wa;
        a[(0, 5)] = wa; // the drive
        a[(1, 2)] = 1.0;
        a[(2, 0)] = w1 * w1;
        a[(2, 1)] = -w1 * w1;
        a[(2, 2)] = -2.0 * z1 * w1;
        a[(2, 6)] = -w1 * w1; // the friction, against the torque
        a[(3, 4)] = 1.0;
        a[(4, 1)] = w2 * w2;
        a[(4, 3)] = -w2 * w2;
        a[(4, 4)] = -2.0 * z2 * w2;
        // A parameter the search sent far off (a mode at 10⁸ Hz) overflows the exponential's
        // norm estimate to an endless count of squarings: a rig's sub-step is far under 10⁸.
        let a_step = a * (dt_s / SUBSTEPS as f64);
        if !a_step.iter().all(|v| v.is_finite() && v.abs() < 1e8) {
            return None;
        }
        let e = a_step.exp();
        let ad: SMatrix<f64, 5, 5> = e.fixed_view::<5, 5>(0, 0).into();
        let drive: State = e.fixed_view::<5, 1>(0, 5).into();
        let friction: State = e.fixed_view::<5, 1>(0, 6).into();
        // r″ and r‴ as rows over the state.
        let r2 = Row::from_row_slice(&[0.0, w2 * w2, 0.0, -w2 * w2, -2.0 * z2 * w2]);
        let r3 = Row::from_row_slice(&[0.0, 0.0, w2 * w2, 0.0, -w2 * w2]) - 2.0 * z2 * w2 * r2;
        let r0 = Row::from_row_slice(&[0.0, 0.0, 0.0, 1.0, 0.0]);
        let r1 = Row::from_row_slice(&[0.0, 0.0, 0.0, 0.0, 1.0]);
        // Q(s)·r and s·Q(s)·r for Q = 1 + 2ζs/ω + s²/ω².
        let gauge = m.gain * (r0 + (2.0 * zz / wz) * r1 + r2 / (wz * wz));
        let velocity = m.gain * (r1 + (2.0 * zt / wt) * r2 + r3 / wt2);
        let stopping = (velocity * friction)[0];
        (stopping < 0.0).then_some(Self {
            a: ad,
            drive,
            friction,
            gauge,
            velocity,
            stopping,
        })
    }

    /// The gauge over the last of `WARM_PERIODS + 1` periods of `drive` (one period, one
    /// value per tick), from rest, with `stiction_g` of friction.
    fn periodic_gauge(&self, drive: &[f64], stiction_g: f64) -> Vec<f64> {
        let mut x = State::zeros();
        let mut out = vec![0.0; drive.len()];
        for period in 0..=WARM_PERIODS {
            for (i, &d) in drive.iter().enumerate() {
                let mut sum = 0.0;
                for _ in 0..SUBSTEPS {
                    let free = self.a * x + self.drive * d;
                    // The friction that stops the motor this sub-step, if it can.
                    let f =
                        (-(self.velocity * free)[0] / self.stopping).clamp(-stiction_g, stiction_g);
                    x = free + self.friction * f;
                    sum += (self.gauge * x)[0];
                }
                if period == WARM_PERIODS {
                    out[i] = sum / SUBSTEPS as f64;
                }
            }
        }
        out
    }
}

/// The gauge's spectrum the model gives with `stiction_g` of friction, driven by the
/// record's `drive` (centred, sampled every `dt_s`), over the measured one: ln of their ratio at
/// each frequency as (log-magnitude, phase) pairs, the model's delay applied to the simulated
/// gauge.
fn log_errors(
    m: &ApplicatorModel,
    drive: &[f64],
    dt_s: f64,
    spectrum: &Spectrum,
    measured: &[Complex64],
    stiction_g: f64,
) -> Option<Vec<f64>> {
    let plant = Discrete::of(m, dt_s)?;
    let gauge = plant.periodic_gauge(drive, stiction_g);
    let simulated = spectrum.transform(&gauge);
    Some(
        simulated
            .iter()
            .zip(measured)
            .zip(&spectrum.hz)
            .flat_map(|((s, y), hz)| {
                let delay = Complex64::new(0.0, -2.0 * std::f64::consts::PI * hz * m.delay_s).exp();
                let e = (s * delay / y).ln();
                [e.re, e.im]
            })
            .collect(),
    )
}

/// The model refined from `start` (a fit of the response less the friction) with
/// `stiction_g` of Coulomb friction on the motor; `None` if it fits the record no better than
/// `start` does with the same friction. Its `rms_log_error` is the refined fit's.
pub fn fit_with_friction(
    means: &PeriodMeans,
    stiction_g: f64,
    start: &ApplicatorModel,
) -> Option<ApplicatorModel> {
    fit_with_friction_and_pole(means, stiction_g, start, None)
}

/// [`fit_with_friction`] with the amplifier's pole held at `pole_hz` where given.
pub fn fit_with_friction_and_pole(
    means: &PeriodMeans,
    stiction_g: f64,
    start: &ApplicatorModel,
    pole_hz: Option<f64>,
) -> Option<ApplicatorModel> {
    refine(means, stiction_g, start, (false, pole_hz)).map(|r| r.0)
}

/// [`fit_with_friction`] with the stiction fitted too, from `stiction_g`: the model and the
/// stiction (g) that fit the chirp's record best.
pub fn fit_with_stiction(
    means: &PeriodMeans,
    stiction_g: f64,
    start: &ApplicatorModel,
) -> Option<(ApplicatorModel, f64)> {
    refine(means, stiction_g, start, (true, None))
}

fn refine(
    means: &PeriodMeans,
    stiction_g: f64,
    start: &ApplicatorModel,
    (fit_stiction, pole_hz): (bool, Option<f64>),
) -> Option<(ApplicatorModel, f64)> {
    use crate::applicator_model::{searched, with_pole};
    let spectrum = Spectrum::of(means);
    let measured = spectrum.transform(&means.gauge_g);
    let drive = means.centred_drive_g();
    // The model's parameters, then (where fitted) ln of the stiction.
    let stiction = |theta: &[f64]| {
        with_pole(theta, pole_hz)
            .get(9)
            .map_or(stiction_g, |v| v.exp())
    };
    let errors = |theta: &[f64]| {
        log_errors(
            &ApplicatorModel::from_theta(with_pole(theta, pole_hz).get(..9)?)?,
            &drive,
            means.dt_s,
            &spectrum,
            &measured,
            stiction(theta),
        )
    };
    let cost = |theta: &[f64]| -> Option<f64> {
        let e = errors(theta)?;
        let c = e.iter().map(|v| v * v).sum::<f64>() / e.len().max(1) as f64;
        c.is_finite().then_some(c)
    };
    let mut from = searched(&start.theta(), pole_hz);
    if fit_stiction {
        // A rig without friction starts at a hundredth of a gram.
        from.push(stiction_g.max(0.01).ln());
    }
    let before = cost(&from)?;
    let solved = ModelProblem::solve(&errors, &from);
    let after = cost(&solved)?;
    if after >= before {
        return None;
    }
    let mut m = ApplicatorModel::from_theta(with_pole(&solved, pole_hz).get(..9)?)?;
    if m.modes[0].hz > m.modes[1].hz {
        return None;
    }
    m.rms_log_error = after.sqrt();
    Some((m, stiction(&solved)))
}

/// The model's response with no friction, as [`fit_with_friction`] simulates it, at the
/// record's frequencies (for checking the simulation against [`ApplicatorModel::response`]).
pub fn simulated_response(m: &ApplicatorModel, means: &PeriodMeans) -> Option<Vec<ResponsePoint>> {
    let spectrum = Spectrum::of(means);
    let plant = Discrete::of(m, means.dt_s)?;
    let drive = means.centred_drive_g();
    let gauge = plant.periodic_gauge(&drive, 0.0);
    let (u, y) = (spectrum.transform(&drive), spectrum.transform(&gauge));
    Some(
        spectrum
            .hz
            .iter()
            .zip(u.iter().zip(&y))
            .map(|(&hz, (u, y))| {
                let g =
                    y / u * Complex64::new(0.0, -2.0 * std::f64::consts::PI * hz * m.delay_s).exp();
                ResponsePoint {
                    hz,
                    re: g.re,
                    im: g.im,
                }
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::applicator_model::Resonance;

    /// A memo-like model: gain 1, modes at 35 and 180 Hz, the tip on the finger at 60 Hz, the
    /// amplifier at 160 Hz.
    fn model() -> ApplicatorModel {
        let r = |hz, damping_ratio| Resonance { hz, damping_ratio };
        ApplicatorModel {
            gain: 1.0,
            anti_resonance: r(60.0, 0.1),
            modes: [r(35.0, 0.07), r(180.0, 0.05)],
            pole_hz: 160.0,
            delay_s: 0.0,
            rms_log_error: 0.0,
        }
    }

    /// One second at 1 kHz of `drive`, the gauge zero.
    fn means(drive: impl Fn(f64) -> f64) -> PeriodMeans {
        PeriodMeans {
            drive_g: (0..1000).map(|i| drive(i as f64 * 1e-3)).collect(),
            gauge_g: vec![0.0; 1000],
            dt_s: 1e-3,
        }
    }

    #[test]
    fn without_friction_the_simulation_is_the_models_response() {
        // Sines at every seventh hertz with spread phases: the simulated spectrum's ratio is
        // the model's response to 0.3 dB and 3° up to 100 Hz (the tick's hold and the
        // average of its samples cancel to a sixty-fourth of a tick: 0.5° at 91 Hz).
        let drive = |t: f64| {
            (1..43)
                .map(|k| {
                    let hz = 7.0 * k as f64;
                    (2.0 * std::f64::consts::PI * hz * t + 0.37 * (k * k) as f64).sin()
                })
                .sum::<f64>()
        };
        let m = model();
        let sim = simulated_response(&m, &means(drive)).expect("simulated");
        let mut checked = 0;
        for p in sim
            .iter()
            .filter(|p| (p.hz as usize).is_multiple_of(7) && p.hz <= 100.0)
        {
            let ratio = p.value() / m.response(p.hz);
            let db = 20.0 * ratio.norm().log10();
            assert!(db.abs() < 0.3, "{} Hz: {db:+.2} dB", p.hz);
            assert!(ratio.arg().to_degrees().abs() < 3.0, "{} Hz: {ratio}", p.hz);
            checked += 1;
        }
        assert_eq!(checked, 14);
    }

    #[test]
    fn a_slow_drive_moves_the_motor_by_what_exceeds_the_friction() {
        // A 1 Hz sine of 3 g, far under the modes: the motor slides once the drive is 1 g past
        // it and sticks at the turn, so the gauge swings ±(3 − 1) g; against 5 g of friction
        // it never moves (within the sub-steps' creep, 1e-5 g).
        let plant = Discrete::of(&model(), 1e-3).expect("a plant");
        let drive: Vec<f64> = (0..1000)
            .map(|i| 3.0 * (2.0 * std::f64::consts::PI * i as f64 * 1e-3).sin())
            .collect();
        let gauge = plant.periodic_gauge(&drive, 1.0);
        let (lo, hi) = gauge
            .iter()
            .fold((f64::MAX, f64::MIN), |(lo, hi), g| (lo.min(*g), hi.max(*g)));
        assert!(
            (hi - 2.0).abs() < 0.05 && (lo + 2.0).abs() < 0.05,
            "{lo} {hi}"
        );
        let stuck = plant.periodic_gauge(&drive, 5.0);
        assert!(stuck.iter().all(|g| g.abs() < 1e-3), "{:?}", &stuck[..10]);
    }

    #[test]
    fn the_fit_recovers_a_model_whose_friction_read_as_damping() {
        // A record made by the simulation itself (2 g chirp-like drive, 1.5 g of friction) and
        // a start whose inertia–finger damping is 2.5 times the truth, its gain 20 % low (what
        // the linear fit reads through the sticking): the fit returns to the truth.
        let truth = model();
        let plant = Discrete::of(&truth, 1e-3).expect("a plant");
        let mut record = means(|t| {
            let cycles = t + 150.0 * t * t;
            2.0 * (2.0 * std::f64::consts::PI * cycles).sin()
        });
        record.gauge_g = plant.periodic_gauge(&record.drive_g, 1.5);
        let mut start = truth;
        start.modes[0].damping_ratio *= 2.5;
        start.gain *= 0.8;
        let fitted = fit_with_friction(&record, 1.5, &start).expect("a better fit");
        assert!((fitted.gain - 1.0).abs() < 0.02, "{fitted}");
        assert!(
            (fitted.modes[0].damping_ratio / 0.07 - 1.0).abs() < 0.1,
            "{fitted}"
        );
        assert!((fitted.modes[0].hz / 35.0 - 1.0).abs() < 0.02, "{fitted}");
    }
}
