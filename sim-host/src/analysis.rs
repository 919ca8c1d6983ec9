//! Frequency-domain views of the rig: the applicator's response from amplifier input to gauge
//! (analytic, linearized about a load, and measured from the simulation by sine excitation),
//! and the Nyquist count of the A1 loop that shows which error gains are stable.

use num_complex::Complex64;
use tactile_core::control::ForceLawConfig;
use tactile_core::filter::LowpassNotch;
use tactile_core::viscoelastic::SpringLaw;

use crate::applicator::{self, ApplicatorParams, ApplicatorState, Contact, NEWTONS_PER_GRAM};

/// Tangent stiffness dσ/dε (g/%) of a spring law at a load.
pub fn tangent_stiffness(law: &SpringLaw, load_g: f64) -> f64 {
    let h = 1e-4;
    let e = law.strain_pct(load_g);
    (law.stress_g(e + h) - law.stress_g((e - h).max(0.0))) / (e + h - (e - h).max(0.0))
}

/// Gauge grams per gram of motor force, linearized about `load_g` on the spring `law`
/// (friction ignored; amplifier not included).
pub fn mechanical_response(
    p: &ApplicatorParams,
    law: &SpringLaw,
    load_g: f64,
    omega_rad_s: f64,
) -> Complex64 {
    let s = Complex64::new(0.0, omega_rad_s);
    let m = p.motor_inertia_kg_m2 / (p.arm_m * p.arm_m);
    let b = p.viscous_nm_s_per_rad / (p.arm_m * p.arm_m);
    let cb = 2.0 * p.beam_damping_ratio * (p.beam_stiffness_n_per_m * p.tip_mass_kg).sqrt();
    let kf = tangent_stiffness(law, load_g) * 100.0 / p.indentation_mm_per_100pct
        * 1e3
        * NEWTONS_PER_GRAM;
    let kb = Complex64::new(p.beam_stiffness_n_per_m, 0.0) + cb * s;
    let compression = law.strain_pct(load_g);
    let kc = Complex64::new(kf, 0.0) + p.contact_damping_n_s_per_m(load_g, compression) * s;
    let d = p.tip_mass_kg * s * s + kb + kc;
    let x = 1.0 / (m * s * s + b * s + kb - kb * kb / d);
    p.beam_stiffness_n_per_m * x * (p.tip_mass_kg * s * s + kc) / d
}

/// Amplifier input (expressed as grams of commanded force) to gauge grams.
pub fn applicator_response(
    p: &ApplicatorParams,
    law: &SpringLaw,
    load_g: f64,
    omega_rad_s: f64,
) -> Complex64 {
    let amp = 1.0
        / Complex64::new(
            1.0,
            omega_rad_s / (2.0 * core::f64::consts::PI * p.amplifier_pole_hz),
        );
    amp * mechanical_response(p, law, load_g, omega_rad_s)
}

/// [`applicator_response`] at `hz` as the control loop sees it: through the drive's hold over
/// a tick, (1 − e^(−sT))/(sT). What the designed feedback's margins are checked on.
pub fn held_response(p: &ApplicatorParams, law: &SpringLaw, load_g: f64, hz: f64) -> Complex64 {
    let t = tactile_core::CONTROL_PERIOD_S;
    let s = Complex64::new(0.0, 2.0 * core::f64::consts::PI * hz);
    applicator_response(p, law, load_g, s.im) * ((1.0 - (-s * t).exp()) / (s * t))
}

/// One of an applicator's parameters, to move it.
pub type ParamField = fn(&mut ApplicatorParams) -> &mut f64;

/// The mechanical parameters the margins must hold against, each 20 % off in turn.
pub const MECHANICAL_PARAMETERS: [(&str, ParamField); 6] = [
    ("motor inertia", |p| &mut p.motor_inertia_kg_m2),
    ("beam stiffness", |p| &mut p.beam_stiffness_n_per_m),
    ("tip mass", |p| &mut p.tip_mass_kg),
    ("amplifier pole", |p| &mut p.amplifier_pole_hz),
    ("contact loss", |p| &mut p.contact_loss_factor),
    ("indentation scale", |p| &mut p.indentation_mm_per_100pct),
];

/// Measures the same response from the simulated plant: a sine of `amplitude_g` about
/// `load_g` at `hz`, friction off, lock-in over whole periods after the transient.
pub fn measured_response(
    p: &ApplicatorParams,
    law: &SpringLaw,
    load_g: f64,
    amplitude_g: f64,
    hz: f64,
) -> Complex64 {
    let p = ApplicatorParams {
        static_friction_nm: 0.0,
        ..*p
    };
    let contact = Contact::new(&p, *law, 0.0);
    let volts_per_g = 1.0 / p.drive_g_per_v();
    let dt = 1e-5;
    // Start at the static equilibrium of the load.
    let mut s = ApplicatorState::default();
    for _ in 0..200_000 {
        applicator::step(&p, &mut s, &contact, load_g * volts_per_g, 1e-4);
    }
    let periods_settle = (0.3 * hz).ceil().max(3.0);
    let periods_measure = (0.5 * hz).ceil().max(5.0);
    let n_settle = (periods_settle / hz / dt).round() as usize;
    let n_measure = (periods_measure / hz / dt).round() as usize;
    let w = 2.0 * core::f64::consts::PI * hz;
    let mut acc = Complex64::new(0.0, 0.0);
    for k in 0..(n_settle + n_measure) {
        let t = k as f64 * dt;
        let drive = load_g + amplitude_g * (w * t).sin();
        applicator::step(&p, &mut s, &contact, drive * volts_per_g, dt);
        if k >= n_settle {
            let tt = t + dt;
            acc += (s.gauge_force_g(&p) - load_g) * Complex64::new(0.0, -w * tt).exp();
        }
    }
    // The drive sin(ωt) has phasor −j; the gauge's phasor is 2·acc/N.
    (2.0 * acc / n_measure as f64) / (amplitude_g * Complex64::new(0.0, -1.0))
}

/// Net encirclements of −1 by the A1 loop at load `load_g` (feedback scaled as A1 does at that
/// command), from 0.05 Hz to 500 Hz; and the largest |L| where the loop crosses the negative real
/// axis. The loop is the law's PD on the error, the discretized filter, the plant, and the
/// 1.5 ms of delay the rig has (gauge average half a tick old, one tick of computation and
/// the DAC's half-tick hold).
pub fn loop_encirclements(
    law: &ForceLawConfig,
    filter: &LowpassNotch,
    p: &ApplicatorParams,
    spring: &SpringLaw,
    load_g: f64,
) -> (i32, f64) {
    let dt = f64::from(law.dt_s);
    let scale = f64::from(law.gain_scale(load_g as f32));
    let mut count = 0;
    let mut worst: f64 = 0.0;
    let mut prev: Option<Complex64> = None;
    let n = 40_000;
    for i in 1..=n {
        let hz = 0.05 * (500.0f64 / 0.05).powf(i as f64 / n as f64);
        let w = 2.0 * core::f64::consts::PI * hz;
        let z_inv = Complex64::new(0.0, -w * dt).exp();
        let pd = scale * (f64::from(law.kp) + f64::from(law.kd_s) * (1.0 - z_inv) / dt);
        let delay = Complex64::new(0.0, -w * 1.5 * dt).exp();
        let l = pd * filter.response(w, dt) * applicator_response(p, spring, load_g, w) * delay;
        if let Some(q) = prev {
            if (q.im < 0.0) != (l.im < 0.0) {
                let x = 0.5 * (q.re + l.re);
                if x < 0.0 {
                    worst = worst.max(-x);
                }
                if x < -1.0 {
                    count += if l.im > q.im { 1 } else { -1 };
                }
            }
        }
        prev = Some(l);
    }
    (count, worst)
}

/// Frequencies (Hz) of the local maxima of |response| between `lo_hz` and `hi_hz`.
pub fn peaks(lo_hz: f64, hi_hz: f64, step_hz: f64, response: impl Fn(f64) -> f64) -> Vec<f64> {
    let freqs: Vec<f64> = (0..)
        .map(|i| lo_hz + i as f64 * step_hz)
        .take_while(|f| *f <= hi_hz)
        .collect();
    let mags: Vec<f64> = freqs.iter().map(|f| response(*f)).collect();
    (1..mags.len().saturating_sub(1))
        .filter(|&i| mags[i] > mags[i - 1] && mags[i] >= mags[i + 1])
        .map(|i| freqs[i])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rig::RigConfig;
    use tactile_core::control::GainSchedule;
    use tactile_core::viscoelastic::NonlinearMk;

    #[test]
    fn open_loop_resonances_are_the_memos_50_and_190_hz() {
        let p = ApplicatorParams::MEMO;
        let law = NonlinearMk::ELEMENT_4_2.g1;
        let two_pi = 2.0 * core::f64::consts::PI;
        let analytic = peaks(10.0, 300.0, 0.5, |hz| {
            applicator_response(&p, &law, 50.0, two_pi * hz).norm()
        });
        assert_eq!(analytic.len(), 2, "{analytic:?}");
        // Measured from the simulated plant by sine excitation, about the analytic peaks.
        let measured = peaks(30.0, 240.0, 2.0, |hz| {
            if (hz - analytic[0]).abs() < 16.0 || (hz - analytic[1]).abs() < 16.0 {
                measured_response(&p, &law, 50.0, 1.0, hz).norm()
            } else {
                0.0
            }
        });
        assert_eq!(measured.len(), 2, "{measured:?}");
        assert!(
            (measured[0] - 50.0).abs() <= 5.0,
            "inertia–finger mode at {} Hz",
            measured[0]
        );
        assert!(
            (measured[1] - 190.0).abs() <= 19.0,
            "beam mode at {} Hz",
            measured[1]
        );
        // The simulation and the linearization agree where both are defined.
        for hz in [5.0, 20.0, 80.0] {
            let a = applicator_response(&p, &law, 50.0, two_pi * hz);
            let m = measured_response(&p, &law, 50.0, 1.0, hz);
            assert!((a - m).norm() < 0.03 * a.norm(), "{hz} Hz: {a} vs {m}");
        }
    }

    #[test]
    fn the_memo_gains_are_unstable_on_this_plant_and_the_sim_gain_is_not() {
        let c = RigConfig::default();
        let filter = c.firmware.filter.discretize().unwrap();
        let spring = NonlinearMk::ELEMENT_4_2.g1;
        let memo = ForceLawConfig::MEMO;
        // Memo gains at 100 g: one net encirclement of −1.
        let (n, _) = loop_encirclements(&memo, &filter, &c.applicator, &spring, 100.0);
        assert_eq!(n, 1);
        // The simulator's K_e: stable from 2 g to 120 g with gain margin above 1.3.
        for load in [2.0, 5.0, 10.0, 30.0, 50.0, 80.0, 120.0] {
            let (n, worst) =
                loop_encirclements(&c.firmware.law, &filter, &c.applicator, &spring, load);
            assert_eq!(n, 0, "{load} g");
            assert!(worst < 1.0 / 1.3, "{load} g: |L| = {worst} at −180°");
        }
        for load in [2.0, 5.0, 10.0, 20.0, 50.0, 100.0] {
            let (_, worst) = loop_encirclements(
                &ForceLawConfig {
                    ke: 1.0,
                    ..c.firmware.law
                },
                &filter,
                &c.applicator,
                &spring,
                load,
            );
            eprintln!(
                "{load} g: largest stable overall gain {:.3}",
                1.0 / worst * load / 100.0
            );
        }
        // Fixed gains at their 100 g value are unstable below about 20 g: the schedule's job.
        let fixed = ForceLawConfig {
            schedule: GainSchedule::Fixed { command_g: 100.0 },
            ..c.firmware.law
        };
        for load in [2.0, 5.0, 10.0] {
            assert_eq!(
                loop_encirclements(&fixed, &filter, &c.applicator, &spring, load).0,
                1,
                "{load} g"
            );
        }
    }
}
