//! The force controller designed from the identified applicator (issue 13, item 2): the
//! excitation protocol run at several preloads, a low-order model fitted at each
//! ([`crate::identify::fit_model`]), and from those models the core's [`TrackingConfig`]:
//!
//! - the feed-forward's schedule: at each preload, the inverse of the model's path to the
//!   contact force as a series in s up to s³ (the delay left out: no controller can undo it),
//!   over the static gain of the holds before the chirps ([`crate::identify::static_line`],
//!   which also gives the stiction compensated); below the lightest identified load, models
//!   extrapolated by the modes' power law in load ([`extrapolate`]);
//! - the feedback: integral action (and a proportional term) as large as the margins allow at
//!   every identified load: gain margin ≥ [`GAIN_MARGIN`] and phase margin ≥ [`PHASE_MARGIN_DEG`]
//!   with the loop's extra tick of delay, so that the plant's gain may be 20 % off and still
//!   leave a margin of 2.
//!
//! The design method is loop shaping on the identified frequency responses; the reference
//! model's bandwidth puts the closed loop's −0.5 dB point past 40 Hz.

use num_complex::Complex64;
use serde::Serialize;
use tactile_core::tracking::{InverseSeries, TrackingConfig, TRACKING_POINTS};

use crate::identify::{ApplicatorModel, IdentifyError};
use crate::rig::{RigConfig, TICK_S};
use crate::scenario::{run_protocol, ScenarioError};

/// The preloads the applicator is identified at, g. Not lighter: a chirp small enough to keep
/// the probe on the finger at 2–5 g hardly moves the motor through its stiction (the fits came
/// out with gains of 0.05–0.12 and errors of 130 %).
pub const DESIGN_LOADS_G: [f32; 6] = [10.0, 20.0, 35.0, 50.0, 75.0, 100.0];
/// Loads below the identified ones the design extrapolates to ([`extrapolate`]), g. Reaching
/// down to 0.5 g took the memo rig's first step from rest from 1.5 g of overshoot to 0.03–0.24 g
/// (seeds 1–4) but slowed the heavy rig's 20 g step to 44 ms (1.6 g over) and the light rig's
/// to 41 ms: not kept.
pub const EXTRAPOLATED_LOADS_G: [f32; 3] = [1.0, 2.0, 5.0];
/// Least gain margin of the designed loop on every identified model (2 with the plant 20 %
/// stronger).
pub const GAIN_MARGIN: f64 = 2.4;
/// Least phase margin, degrees.
pub const PHASE_MARGIN_DEG: f64 = 50.0;
/// The reference model's triple pole, Hz: 0.45 dB down at 40 Hz.
pub const REFERENCE_HZ: f32 = 200.0;

/// Why a controller could not be designed.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    #[error(transparent)]
    Run(#[from] ScenarioError),
    #[error("identification at {load_g} g: {source}")]
    Identify {
        load_g: f32,
        #[source]
        source: IdentifyError,
    },
    #[error("no model converged on the response measured at {load_g} g")]
    NoModel { load_g: f32 },
    #[error("no integral gain gives the margins at every load (the model at {load_g} g has a gain margin of {margin:.2} with none)")]
    NoMargin { load_g: f32, margin: f64 },
}

/// The identified model at one preload.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct LoadModel {
    pub load_g: f32,
    pub model: ApplicatorModel,
    /// Gauge grams per drive gram of the still holds before the chirps
    /// ([`crate::identify::static_line`]): the feed-forward's static gain.
    pub static_gain: f64,
}

/// The chirp's amplitude at a preload: 0.4 of it, at most the memo protocol's 5 g (at a fifth,
/// the 10 g fit had a gain of 0.60: the stiction); halved while the probe leaves the finger or
/// the gauge leaves its range.
fn excitation_amplitude_g(load_g: f32) -> f32 {
    (0.4 * load_g).clamp(0.25, 5.0)
}

/// Whether a fitted model is one the design can use: the inertia–finger mode under the chirp's
/// band and less than critically damped, the beam mode above it, the amplifier's pole and the
/// delay where an amplifier and a 1 kHz loop put them. On the heavy rig the 100 g fit ran to
/// ζ 5.4 and a pole at 879 Hz (122 % RMS), and the loop built on it lost the finger.
pub fn plausible(m: &ApplicatorModel) -> bool {
    let [a, b] = m.modes;
    m.gain.is_finite()
        && (0.5..2.0).contains(&m.gain)
        && a.damping_ratio < 0.7
        && a.hz > 5.0
        && b.hz > a.hz
        && (20.0..500.0).contains(&m.pole_hz)
        && m.delay_s.abs() < 3e-3
}

/// What the excitation at several preloads identified.
#[derive(Clone, Debug, Serialize)]
pub struct Identified {
    /// The plausible models, in increasing load.
    pub models: Vec<LoadModel>,
    /// The static line of the holds: gain and stiction (g at the probe).
    pub static_gain: f64,
    pub stiction_g: f64,
}

/// Runs the excitation at each of [`DESIGN_LOADS_G`] on a rig built from `config` (the loop
/// that holds the preload is the one `config` has) and fits the model at each; loads whose
/// fit is not [`plausible`] are left out (at least two must remain). The holds before the
/// chirps give the static gain and the stiction.
pub fn identify_loads(config: &RigConfig) -> Result<Identified, DesignError> {
    let runs: Vec<Result<AtLoad, DesignError>> = std::thread::scope(|scope| {
        let handles: Vec<_> = DESIGN_LOADS_G
            .iter()
            .map(|&load_g| {
                let config = RigConfig {
                    scan_array: false,
                    ..config.clone()
                };
                scope.spawn(move || identify_at(config, load_g))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or(Err(DesignError::NoModel { load_g: f32::NAN }))
            })
            .collect()
    });
    let runs: Vec<AtLoad> = runs.into_iter().collect::<Result<_, _>>()?;
    let holds: Vec<(f64, f64)> = runs.iter().map(|r| r.1).collect();
    let (static_gain, stiction_g) =
        crate::identify::static_line(&holds).ok_or(DesignError::NoModel { load_g: f32::NAN })?;
    let models: Vec<LoadModel> = runs
        .into_iter()
        .map(|(m, _)| LoadModel { static_gain, ..m })
        .collect();
    let kept: Vec<LoadModel> = models
        .iter()
        .filter(|m| plausible(&m.model))
        .copied()
        .collect();
    if kept.len() < 2 {
        let load_g = models
            .iter()
            .find(|m| !plausible(&m.model))
            .map_or(f32::NAN, |m| m.load_g);
        return Err(DesignError::NoModel { load_g });
    }
    Ok(Identified {
        models: kept,
        static_gain,
        stiction_g,
    })
}

/// The model at one preload (its static gain still 1) and the hold's mean drive and gauge, g.
type AtLoad = (LoadModel, (f64, f64));

fn identify_at(config: RigConfig, load_g: f32) -> Result<AtLoad, DesignError> {
    let mut amplitude_g = excitation_amplitude_g(load_g);
    loop {
        let protocol = tactile_core::profile::Protocol::Excitation {
            preload_g: load_g,
            amplitude_g,
            periods: 8,
        };
        let actuator = config.firmware.actuator;
        let run = run_protocol("excitation", protocol, config.clone(), false, |_| {})?;
        match crate::identify::frequency_response(&run.ticks, protocol, &actuator) {
            Ok(response) => {
                let model =
                    crate::identify::fit_model(&response).ok_or(DesignError::NoModel { load_g })?;
                let hold = crate::identify::hold_means(&run.ticks, &actuator)
                    .ok_or(DesignError::NoModel { load_g })?;
                let model = LoadModel {
                    load_g,
                    model,
                    static_gain: 1.0,
                };
                return Ok((model, hold));
            }
            // Too strong a chirp: the probe left the finger, or the beam's mode drove the
            // gauge out of its range.
            Err(IdentifyError::LostContact { .. } | IdentifyError::Faulted { .. })
                if amplitude_g > 0.3 =>
            {
                amplitude_g *= 0.5
            }
            Err(source) => return Err(DesignError::Identify { load_g, source }),
        }
    }
}

/// The model at `load_g`, below the identified loads: the inertia–finger mode and the
/// anti-resonance (the tip on the finger) move with the contact's stiffness, which a soft
/// finger's spring makes a power of the load; the power is fitted to the identified loads
/// (ln f against ln load, least squares), the rest is the lightest identified model's. On the
/// memo's finger the analytic modes follow it to 1 %: 25.8 and 30.9 Hz at 2 and 5 g from
/// 35.7–57.5 Hz at 10–100 g.
pub fn extrapolate(models: &[LoadModel], load_g: f32) -> Option<LoadModel> {
    let lightest = models.iter().min_by(|a, b| a.load_g.total_cmp(&b.load_g))?;
    let slope = |hz: &dyn Fn(&ApplicatorModel) -> f64| -> Option<f64> {
        let (ln_load, ln_hz): (Vec<f64>, Vec<f64>) = models
            .iter()
            .map(|m| (f64::from(m.load_g).ln(), hz(&m.model).ln()))
            .unzip();
        Some(tactile_ident::stats::line(&ln_load, &ln_hz)?.1)
    };
    let ratio = f64::from(load_g) / f64::from(lightest.load_g);
    let mut model = lightest.model;
    let b_mode = slope(&|m| m.modes[0].hz)?;
    let b_anti = slope(&|m| m.anti_resonance.hz)?;
    model.modes[0].hz *= ratio.powf(b_mode);
    model.anti_resonance.hz *= ratio.powf(b_anti);
    Some(LoadModel {
        load_g,
        model,
        static_gain: lightest.static_gain,
    })
}

/// 1 + (2ζ/ω)s + s²/ω² as coefficients in s.
fn quadratic(r: crate::identify::Resonance) -> [f64; 3] {
    let w = 2.0 * std::f64::consts::PI * r.hz;
    [1.0, 2.0 * r.damping_ratio / w, 1.0 / (w * w)]
}

fn times(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

/// The feed-forward's series c₀ + c₁s + c₂s² + c₃s³ for one load: the inverse of the model's
/// path from drive to contact force, delay left out (no controller can take it back). The
/// gauge reads the contact force plus the tip's inertia, gauge = contact·(1 + s²/ω_z²), the
/// anti-resonance ω_z being the tip on the finger alone; the contact force, which the user
/// asks for, is the model without that factor, and its inverse is a polynomial: the modes'
/// quadratics times the amplifier's pole over the static gain (the hold's, not the chirp's:
/// measured, the chirp's gain overdrove the memo's rig by 0.7 dB across the band), truncated
/// after s³.
///
/// Tried and dropped: matching the series to the measured response by least squares over
/// 1–50 Hz (the stiction lowers the small chirp's gain to 0.92 at every frequency, and the
/// feed-forward then drove 1.3 dB too hard across the band).
pub fn inverse_series(load: &LoadModel) -> [f64; 4] {
    let m = &load.model;
    let pole = [1.0, 1.0 / (2.0 * std::f64::consts::PI * m.pole_hz)];
    let n = times(
        &times(&quadratic(m.modes[0]), &quadratic(m.modes[1])),
        &pole,
    );
    core::array::from_fn(|k| n.get(k).copied().unwrap_or(0.0) / load.static_gain)
}

/// Gain and phase margins of a loop given by its response on a frequency grid (first to last
/// point): the smallest 1/|L| where the phase crosses −180° (∞ where it never does) and the
/// smallest distance of the phase from −180° where |L| crosses 1 (180 where it never does).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Margins {
    pub gain: f64,
    pub phase_deg: f64,
}

pub fn margins(l: &[Complex64]) -> Margins {
    let mut gain = f64::INFINITY;
    let mut phase_deg: f64 = 180.0;
    for w in l.windows(2) {
        let (a, b) = (w[0], w[1]);
        // The phase crossing −180°: the imaginary part changes sign with a negative real part.
        if a.im.signum() != b.im.signum() && (a.re < 0.0 || b.re < 0.0) {
            let t = a.im / (a.im - b.im);
            let re = a.re + t * (b.re - a.re);
            if re < 0.0 {
                gain = gain.min(1.0 / -re);
            }
        }
        if (a.norm() - 1.0).signum() != (b.norm() - 1.0).signum() {
            let p = (180.0 + b.arg().to_degrees()).rem_euclid(360.0);
            phase_deg = phase_deg.min(p.min(360.0 - p));
        }
    }
    Margins { gain, phase_deg }
}

/// The loop's frequencies: 0.1 Hz to just under the Nyquist rate, log-spaced.
pub fn loop_grid_hz() -> Vec<f64> {
    let (lo, hi) = (0.1f64, 0.49 / TICK_S);
    let n = 2000;
    (0..n)
        .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
        .collect()
}

/// The feedback's response at `hz`: kp + ki·T/(1 − z⁻¹), with the tick it waits for the
/// reading (z⁻¹).
pub fn feedback(kp: f64, ki_per_s: f64, hz: f64) -> Complex64 {
    let z_inv = Complex64::from_polar(1.0, -2.0 * std::f64::consts::PI * hz * TICK_S);
    (kp + ki_per_s * TICK_S / (1.0 - z_inv)) * z_inv
}

/// The margins of the designed feedback on `plant` (gauge g per drive g at each hertz).
pub fn loop_margins(kp: f64, ki_per_s: f64, plant: impl Fn(f64) -> Complex64) -> Margins {
    let l: Vec<Complex64> = loop_grid_hz()
        .into_iter()
        .map(|hz| feedback(kp, ki_per_s, hz) * plant(hz))
        .collect();
    margins(&l)
}

/// The largest x in [0, `hi`] that `passes` (which holds at 0 and fails past some point), by
/// bisection to 2⁻⁴⁰ of `hi`.
fn largest_passing(hi: f64, passes: impl Fn(f64) -> bool) -> f64 {
    let (mut lo, mut hi) = (0.0f64, hi);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if passes(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// The designed controller and what it was designed on.
#[derive(Clone, Debug, Serialize)]
pub struct Design {
    #[serde(skip)]
    pub config: TrackingConfig,
    pub models: Vec<LoadModel>,
    pub kp: f64,
    pub ki_per_s: f64,
    /// Margins on each identified model.
    pub margins: Vec<Margins>,
}

/// The controller for the identified `models` (in increasing load), the actuator's range
/// `drive_range_g`.
pub fn design(
    models: &[LoadModel],
    friction_g: f32,
    drive_range_g: (f32, f32),
) -> Result<Design, DesignError> {
    // The identified models and, below the lightest, the extrapolated ones.
    let lightest = models
        .iter()
        .map(|m| m.load_g)
        .fold(f32::INFINITY, f32::min);
    let mut all: Vec<LoadModel> = EXTRAPOLATED_LOADS_G
        .iter()
        .filter(|l| **l < lightest)
        .filter_map(|l| extrapolate(models, *l))
        .chain(models.iter().copied())
        .collect();
    all.sort_by(|a, b| a.load_g.total_cmp(&b.load_g));
    all.truncate(TRACKING_POINTS);
    // The gains from the identified loads; each extrapolated light load gets the share of them
    // its margins allow.
    let identified = models;
    let models = &all[..];
    let passes = |m: &LoadModel, kp: f64, ki: f64| {
        let mg = loop_margins(kp, ki, |hz| m.model.response(hz));
        mg.gain >= GAIN_MARGIN && mg.phase_deg >= PHASE_MARGIN_DEG
    };
    let ok = |kp: f64, ki: f64| identified.iter().all(|m| passes(m, kp, ki));
    // The largest integral gain for each proportional gain on a grid; the pair with the most
    // integral action (what the steady state and the stiction need).
    let mut best: Option<(f64, f64)> = None;
    for kp in [0.0, 0.05, 0.1, 0.2, 0.3] {
        if !ok(kp, 0.0) {
            continue;
        }
        let lo = largest_passing(2000.0, |ki| ok(kp, ki));
        if best.is_none_or(|b| lo > b.1) {
            best = Some((kp, lo));
        }
    }
    let Some((kp, ki)) = best.filter(|b| b.1 > 0.0) else {
        let worst = models
            .iter()
            .map(|m| {
                (
                    m.load_g,
                    loop_margins(0.0, 1.0, |hz| m.model.response(hz)).gain,
                )
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((f32::NAN, f64::NAN));
        return Err(DesignError::NoMargin {
            load_g: worst.0,
            margin: worst.1,
        });
    };
    let holds = |m: &LoadModel, share: f64| passes(m, share * kp, share * ki);
    let share_at = |m: &LoadModel| {
        if holds(m, 1.0) {
            1.0
        } else {
            largest_passing(1.0, |share| holds(m, share))
        }
    };
    let mut schedule = [InverseSeries {
        load_g: 0.0,
        c: [1.0, 0.0, 0.0, 0.0],
        feedback: 0.0,
    }; TRACKING_POINTS];
    for (slot, m) in schedule.iter_mut().zip(models) {
        *slot = InverseSeries {
            load_g: m.load_g,
            c: inverse_series(m).map(|v| v as f32),
            feedback: share_at(m) as f32,
        };
    }
    let config = TrackingConfig {
        dt_s: TICK_S as f32,
        reference_hz: REFERENCE_HZ,
        schedule,
        points: models.len().min(TRACKING_POINTS) as u8,
        friction_g,
        kp: kp as f32,
        ki_per_s: ki as f32,
        delay_ticks: 2,
        // What the model's static gain can be off by: the light rig's small chirps read its
        // gain 0.65–0.81 through twice the stiction, and the feed-forward overdrove 70 g by 21 g
        // (a 20 g bound left 1.2 g of error standing).
        integral_limit_g: 0.5 * drive_range_g.1.max(-drive_range_g.0),
        drive_min_g: drive_range_g.0,
        drive_max_g: drive_range_g.1,
    };
    let margins = models
        .iter()
        .zip(&schedule)
        .map(|(m, p)| {
            let share = f64::from(p.feedback);
            loop_margins(share * kp, share * ki, |hz| m.model.response(hz))
        })
        .collect();
    Ok(Design {
        config,
        models: models.to_vec(),
        kp,
        ki_per_s: ki,
        margins,
    })
}

/// The share of the identified stiction the feed-forward pushes against, in the direction the
/// reference moves. Measured on the memo's rig (`FRICTION=G cargo run --release -p sim-host
/// --example design_controller`, of its 1.11 g): none leaves a 2 g sine about 10 g stuck from
/// 30 Hz (−57 dB) but overshoots the touch-downs least (0.7–1.7 g); a quarter keeps it to 30 Hz;
/// a half overshoots the 2 g touch-down by 3.4 g.
pub const FRICTION_SHARE: f64 = 0.25;

/// What [`design_for_rig`] identified and designed.
#[derive(Clone, Debug, Serialize)]
pub struct RigDesign {
    pub identified: Identified,
    pub design: Design,
}

/// Identifies the rig `config` describes and designs its controller: the stiction compensated
/// is [`FRICTION_SHARE`] of the identified, the drive's range A1's.
pub fn design_for_rig(config: &RigConfig) -> Result<RigDesign, DesignError> {
    let identified = identify_loads(config)?;
    let law = config.firmware.law;
    let design = design(
        &identified.models,
        (FRICTION_SHARE * identified.stiction_g) as f32,
        (law.adjusted_min_g, law.adjusted_max_g),
    )?;
    Ok(RigDesign { identified, design })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::Resonance;

    #[test]
    fn the_series_of_a_single_mode_is_its_quadratic() {
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
}
