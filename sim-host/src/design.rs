//! The force controller designed from the identified applicator (issue 13, item 2): the
//! excitation protocol run at several preloads, a low-order model fitted at each
//! ([`crate::identify::fit_model`] to the drive less the friction, then refined with the
//! motor's friction simulated, [`crate::stick_slip::fit_with_friction`]), and from those
//! models the core's [`TrackingConfig`]:
//!
//! - the feed-forward's schedule: at each preload, the inverse of the model's path to the
//!   contact force as a series in s up to s³ (the delay left out: no controller can undo it),
//!   over the static gain of the holds before the chirps ([`crate::identify::static_line`],
//!   which also gives the stiction compensated); below the lightest identified load (and above
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

use num_complex::Complex64;
use serde::Serialize;
use tactile_core::tracking::{InverseSeries, TrackingConfig, TRACKING_POINTS};

use tactile_core::profile::Protocol;

use crate::identify::{ApplicatorModel, IdentifyError};
use crate::rig::RigConfig;
use crate::scenario::{run_protocol, ScenarioError};
use tactile_core::CONTROL_PERIOD_S;

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
    #[error("no integral gain gives the margins at every load (the model at {load_g} g has a gain margin of {margin:.2} with none)")]
    NoMargin { load_g: f32, margin: f64 },
    #[error("the holds read {stiction_g:.3} g of stiction, under the {least_g:.3} g the touch-down needs to stop the probe between its pushes of {push_g:.2} g: the probe would strike the finger after a rest (a rig this free needs a sensor of the motor's position)")]
    TooLittleFriction {
        stiction_g: f32,
        push_g: f32,
        least_g: f32,
    },
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

/// Whether a fitted model is one the design can use: the inertia–finger mode under the chirp's
/// band and less than critically damped, the anti-resonance (the tip alone on the finger, far
/// lighter than the motor) and the beam mode above it, the amplifier's pole and the delay where
/// an amplifier and a 1 kHz loop put them. On the heavy rig the 100 g fit ran to ζ 5.4 and a
/// pole at 879 Hz (122 % RMS), and the loop built on it lost the finger; on a light motor with
/// 2.8 g of stiction the 100 g fit put the anti-resonance at 52 Hz under a mode at 69 Hz and the
/// pole at 30 Hz (the other loads: 167–230 Hz), and the loop peaked +3.1 dB at 40 Hz there.
pub fn plausible(m: &ApplicatorModel) -> bool {
    implausible(m).is_none()
}

/// Why a fitted model is not [`plausible`] (`None` if it is).
pub fn implausible(m: &ApplicatorModel) -> Option<&'static str> {
    use std::cmp::Ordering::Greater;
    let [a, b] = m.modes;
    // NaN compares as nothing: each test asks for the ordering that makes the model usable.
    let above = |x: f64, y: f64| x.partial_cmp(&y) == Some(Greater);
    let (lo, hi) = crate::identify::STATIC_GAIN_RANGE;
    if !(lo..hi).contains(&m.gain) {
        Some("its gain is not within 0.5–2")
    } else if !above(0.7, a.damping_ratio) {
        Some("its inertia–finger mode is damped past ζ 0.7")
    } else if !above(a.hz, 5.0) {
        Some("its inertia–finger mode is under 5 Hz")
    } else if !(above(b.hz, a.hz) && above(m.anti_resonance.hz, a.hz)) {
        Some("its anti-resonance or beam mode is under the inertia–finger mode")
    } else if !(20.0..500.0).contains(&m.pole_hz) {
        Some("its amplifier's pole is not within 20–500 Hz")
    } else if !above(3e-3, m.delay_s.abs()) {
        Some("its delay is over 3 ms either way")
    } else {
        None
    }
}

/// The amplifier is one whatever the load: of the plausible models, those whose pole is within
/// a factor [`POLE_SPREAD`] of their median pole.
pub fn one_amplifier(models: &[LoadModel]) -> Vec<LoadModel> {
    let Some(median) = upper_median(models.iter().map(|m| m.model.pole_hz).collect()) else {
        return Vec::new();
    };
    models
        .iter()
        .filter(|m| (m.model.pole_hz / median).ln().abs() <= POLE_SPREAD.ln())
        .copied()
        .collect()
}

/// The middle value, the upper of the two for an even count (`None` for none).
fn upper_median(mut values: Vec<f64>) -> Option<f64> {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied()
}

/// The median: the middle value, the mean of the two for an even count (`None` for none).
fn median(mut values: Vec<f64>) -> Option<f64> {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    let upper = *values.get(n / 2)?;
    // An even count that has a value at n/2 has one below it.
    Some(if n.is_multiple_of(2) {
        0.5 * (values[n / 2 - 1] + upper)
    } else {
        upper
    })
}

/// How far a load's fitted amplifier pole may be from the others' median, as a factor (the
/// four rigs' fits spread 126–309 Hz about medians of 130–160 Hz).
pub const POLE_SPREAD: f64 = 2.5;

/// What the excitation at several preloads identified.
#[derive(Clone, Debug, Serialize)]
pub struct Identified {
    /// The plausible models, in increasing load.
    pub models: Vec<LoadModel>,
    /// The static line of the holds: gain and stiction (g at the probe).
    pub static_gain: f64,
    pub stiction_g: f64,
    /// The gauge's noise, RMS of one reading: the median of the holds'.
    pub gauge_noise_g: f64,
    /// The preloads whose excitation gave no model the design could use, and why: the design
    /// extrapolates past them or interpolates across them.
    pub left_out: Vec<LeftOut>,
}

/// A preload the design left out, and why.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LeftOut {
    pub load_g: f32,
    pub why: String,
}

impl std::fmt::Display for LeftOut {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} g: {}", self.load_g, self.why)
    }
}

/// "; left out: A; B" for an error's message ("" for none).
fn left_out_list(left_out: &[LeftOut]) -> String {
    if left_out.is_empty() {
        return String::new();
    }
    let each: Vec<String> = left_out.iter().map(ToString::to_string).collect();
    format!("; left out: {}", each.join("; "))
}

/// One preload's excitation as the design reads it: the measured response and the still
/// hold before the chirps.
#[derive(Clone, Debug)]
pub struct Excited {
    pub load_g: f32,
    /// The drive and gauge over the chirp's periods (the response is their ratio).
    pub means: crate::identify::PeriodMeans,
    pub hold: crate::identify::Hold,
}

/// Runs the excitation at each of [`DESIGN_LOADS_G`] the loop takes as a command (within
/// `supervisor::GAUGE_COMMAND_SHARE` of the gauge's top reading: a gauge twice as sensitive as
/// the memo's reads up to 67.5 g, and the 75 g preload's hold put it at its rail before the
/// chirp began, which refused the design; the loads above are extrapolated from the heaviest
/// identified) on a rig built from `config` (the loop that holds the preload is the one
/// `config` has) and identifies the applicator from them ([`identified_from`]); a preload
/// whose excitation cannot be identified, even with its chirp halved, is left out.
pub fn identify_loads(config: &RigConfig) -> Result<Identified, DesignError> {
    let top_g = tactile_core::supervisor::GAUGE_COMMAND_SHARE * config.firmware.gauge.force_max_g;
    let runs: Vec<Result<Excited, DesignError>> = std::thread::scope(|scope| {
        let handles: Vec<_> = DESIGN_LOADS_G
            .iter()
            .filter(|&&load_g| load_g <= top_g)
            .map(|&load_g| {
                let config = RigConfig {
                    scan_array: false,
                    ..config.clone()
                };
                scope.spawn(move || excite(config, load_g))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
            })
            .collect()
    });
    let (mut excited, mut left_out) = (Vec::new(), Vec::new());
    for run in runs {
        match run {
            Ok(e) => excited.push(e),
            Err(e) => left_out.push(left_out_of(e)?),
        }
    }
    identified_from(&excited, left_out)
}

/// What a preload's failed excitation says for the design: a [`LeftOut`] where the excitation
/// ran and gave nothing to identify (the probe left the finger, the supervisor stopped it, the
/// drive did not move, the hold was not at the preload), the error itself where the record is
/// not one of the excitation (no drive column, cut short, another rate or protocol).
pub fn left_out_of(e: DesignError) -> Result<LeftOut, DesignError> {
    match e {
        DesignError::Identify { load_g, source }
            if matches!(
                source,
                IdentifyError::LostContact { .. }
                    | IdentifyError::Faulted { .. }
                    | IdentifyError::NoDrive { .. }
                    | IdentifyError::HoldOffPreload { .. }
                    | IdentifyError::HoldDrive { .. }
            ) =>
        {
            Ok(LeftOut {
                load_g,
                why: source.to_string(),
            })
        }
        other => Err(other),
    }
}

/// The design's reading of one record of the excitation (a board's, or the QEMU firmware's
/// identification session, `tactile experiment excitation`): its preload is its command during
/// the hold.
pub fn excited_of_record(rec: &tactile_record::Record) -> Result<Excited, DesignError> {
    let not_excitation = DesignError::NotExcitation {
        settle_s: tactile_core::profile::EXCITATION_SETTLE_S,
    };
    if rec.column("drive_g").is_none() {
        return Err(DesignError::Record(IdentifyError::NoDriveColumn));
    }
    let load_g = crate::identify::preload_of_record(rec).ok_or(not_excitation)?;
    let means = crate::identify::period_means_of_record(rec)
        .map_err(|source| DesignError::Identify { load_g, source })?;
    let hold = crate::identify::hold_means_of_record(rec)
        .ok_or(IdentifyError::NoHold)
        .and_then(|h| h.at_preload(load_g))
        .map_err(|source| DesignError::Identify { load_g, source })?;
    Ok(Excited {
        load_g,
        means,
        hold,
    })
}

/// The models fitted at each preload, with the static gain and stiction of the holds; loads
/// whose fit does not converge, is not [`plausible`] or puts the amplifier elsewhere than the
/// others' ([`one_amplifier`]) are left out, after those the caller left out (`left_out`); at
/// least two must remain.
pub fn identified_from(
    excited: &[Excited],
    mut left_out: Vec<LeftOut>,
) -> Result<Identified, DesignError> {
    let mut preloads: Vec<f32> = excited.iter().map(|e| e.load_g).collect();
    preloads.sort_by(f32::total_cmp);
    preloads.dedup();
    if preloads.len() < 2 {
        return Err(DesignError::TooFewPreloads {
            have: preloads.len(),
            left_out,
        });
    }
    let holds: Vec<(f64, f64)> = excited
        .iter()
        .map(|e| (e.hold.drive_g, e.hold.gauge_g))
        .collect();
    let gauge_noise_g =
        upper_median(excited.iter().map(|e| e.hold.noise_g).collect()).unwrap_or(0.0);
    let (static_gain, stiction_g) =
        crate::identify::static_line(&holds).ok_or(DesignError::NoStaticLine)?;
    // One fit per preload, side by side (each is a few hundred milliseconds).
    let fits: Vec<Option<ApplicatorModel>> = std::thread::scope(|scope| {
        let handles: Vec<_> = excited
            .iter()
            .map(|e| {
                scope.spawn(move || {
                    // The linear fit starts the one with the friction simulated (seconds).
                    let linear = e.means.fit_less_friction(stiction_g)?;
                    Some(
                        crate::stick_slip::fit_with_friction(&e.means, stiction_g, &linear)
                            .unwrap_or(linear),
                    )
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().ok().flatten())
            .collect()
    });
    let mut models = Vec::with_capacity(excited.len());
    for (e, model) in excited.iter().zip(fits) {
        match model {
            Some(model) => match implausible(&model) {
                None => models.push(LoadModel {
                    load_g: e.load_g,
                    model,
                    static_gain,
                }),
                Some(why) => left_out.push(LeftOut {
                    load_g: e.load_g,
                    why: format!("the fitted model is not an applicator's, {why} ({model})"),
                }),
            },
            None => left_out.push(LeftOut {
                load_g: e.load_g,
                why: "no model converged on its response".into(),
            }),
        }
    }
    models.sort_by(|a, b| a.load_g.total_cmp(&b.load_g));
    let kept = one_amplifier(&models);
    for m in models
        .iter()
        .filter(|m| !kept.iter().any(|k| k.load_g == m.load_g))
    {
        left_out.push(LeftOut {
            load_g: m.load_g,
            why: format!(
                "its amplifier's pole at {:.0} Hz is over {POLE_SPREAD}× off the other loads'",
                m.model.pole_hz
            ),
        });
    }
    left_out.sort_by(|a, b| a.load_g.total_cmp(&b.load_g));
    if kept.len() < 2 {
        return Err(DesignError::TooFewModels {
            have: kept.len(),
            left_out,
        });
    }
    Ok(Identified {
        models: kept,
        static_gain,
        stiction_g,
        gauge_noise_g,
        left_out,
    })
}

/// The design's reading of a run of [`Protocol::design_excitation`] (the simulator's, or the
/// firmware's decoded log) at 1 kHz.
pub fn excited_of_run(
    ticks: &[crate::rig::TickRecord],
    protocol: Protocol,
    actuator: &tactile_core::control::ActuatorConfig,
) -> Result<Excited, DesignError> {
    let Protocol::Excitation { preload_g, .. } = protocol else {
        return Err(DesignError::Record(IdentifyError::NotTheExcitation));
    };
    let means = crate::identify::period_means(ticks, protocol, actuator).map_err(|source| {
        DesignError::Identify {
            load_g: preload_g,
            source,
        }
    })?;
    let hold = crate::identify::hold_means(ticks, actuator)
        .ok_or(IdentifyError::NoHold)
        .and_then(|h| h.at_preload(preload_g))
        .map_err(|source| DesignError::Identify {
            load_g: preload_g,
            source,
        })?;
    Ok(Excited {
        load_g: preload_g,
        means,
        hold,
    })
}

/// The excitation at one preload on the simulated rig ([`Protocol::design_excitation`]), its
/// chirp halved while the probe leaves the finger or the gauge leaves its range.
fn excite(config: RigConfig, load_g: f32) -> Result<Excited, DesignError> {
    let mut protocol = Protocol::design_excitation(load_g);
    loop {
        let run = run_protocol("excitation", protocol, config.clone(), false, |_| {})?;
        match excited_of_run(&run.ticks, protocol, &config.firmware.actuator) {
            Err(DesignError::Identify {
                source: IdentifyError::LostContact { .. } | IdentifyError::Faulted { .. },
                ..
            }) if matches!(protocol, Protocol::Excitation { amplitude_g, .. } if amplitude_g > 0.3) => {
                if let Protocol::Excitation { amplitude_g, .. } = &mut protocol {
                    *amplitude_g *= 0.5;
                }
            }
            other => return other,
        }
    }
}

/// The model at `load_g`, outside the identified loads: the inertia–finger mode and the
/// anti-resonance (the tip on the finger) move with the contact's stiffness, which a soft
/// finger's spring makes a power of the load; the power is fitted to the identified loads
/// (ln f against ln load, least squares), the rest is the nearest identified model's. On the
/// memo's finger the analytic modes follow it to 1 %: 25.8 and 30.9 Hz at 2 and 5 g from
/// 35.7–57.5 Hz at 10–100 g.
pub fn extrapolate(models: &[LoadModel], load_g: f32) -> Option<LoadModel> {
    let distance = |m: &LoadModel| (f64::from(m.load_g).ln() - f64::from(load_g).ln()).abs();
    let nearest = models
        .iter()
        .min_by(|a, b| distance(a).total_cmp(&distance(b)))?;
    let slope = |hz: &dyn Fn(&ApplicatorModel) -> f64| -> Option<f64> {
        let (ln_load, ln_hz): (Vec<f64>, Vec<f64>) = models
            .iter()
            .map(|m| (f64::from(m.load_g).ln(), hz(&m.model).ln()))
            .unzip();
        Some(tactile_ident::stats::line(&ln_load, &ln_hz)?.1)
    };
    let ratio = f64::from(load_g) / f64::from(nearest.load_g);
    let mut model = nearest.model;
    let b_mode = slope(&|m| m.modes[0].hz)?;
    let b_anti = slope(&|m| m.anti_resonance.hz)?;
    model.modes[0].hz *= ratio.powf(b_mode);
    model.anti_resonance.hz *= ratio.powf(b_anti);
    Some(LoadModel {
        load_g,
        model,
        static_gain: nearest.static_gain,
    })
}

/// 1 + (2ζ/ω)s + s²/ω² as coefficients in s.
fn quadratic(r: crate::identify::Resonance) -> [f64; 3] {
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
        let q = |r: crate::identify::Resonance| -> Complex64 {
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

/// Gain and phase margins of a loop given by its response on a frequency grid (first to last
/// point): the smallest 1/|L| where the phase crosses −180° (∞ where it never does) and the
/// smallest distance of the phase from −180° where |L| crosses 1 (180 where it never does).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Margins {
    pub gain: f64,
    pub phase_deg: f64,
    /// The sensitivity's peak up to [`BAND_HZ`], dB: how much the feedback amplifies what the
    /// feed-forward leaves there (a phase margin of 50° alone let the loop lift 40 Hz by 3.7 dB).
    pub band_sensitivity_db: f64,
}

/// The band the closed loop must be flat in, Hz.
pub const BAND_HZ: f64 = 40.0;

/// The margins of the loop `l` given on [`loop_grid_hz`].
pub fn margins(l: &[Complex64]) -> Margins {
    let band_sensitivity_db = l
        .iter()
        .enumerate()
        .take_while(|(i, _)| grid_hz(*i) <= BAND_HZ)
        .map(|(_, l)| -20.0 * (1.0 + l).norm().log10())
        .fold(f64::NEG_INFINITY, f64::max);
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
    Margins {
        gain,
        phase_deg,
        band_sensitivity_db,
    }
}

/// The loop's frequencies: [`GRID_POINTS`] from 0.1 Hz to just under the Nyquist rate,
/// log-spaced.
pub fn loop_grid_hz() -> Vec<f64> {
    (0..GRID_POINTS).map(grid_hz).collect()
}

const GRID_POINTS: usize = 2000;

fn grid_hz(i: usize) -> f64 {
    let (lo, hi) = (0.1f64, 0.49 / CONTROL_PERIOD_S);
    lo * (hi / lo).powf(i as f64 / (GRID_POINTS - 1) as f64)
}

/// The filter the error passes before the feedback's gains.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum ErrorFilter {
    /// None.
    Pass,
    /// A notch at `hz` (zeros on the unit circle there) with poles damped `damping`: the wider
    /// it is, the more of the mode's uncertain frequency it covers and the more phase it costs
    /// below.
    Notch { hz: f64, damping: f64 },
    /// A double real pole at `hz`.
    Lowpass { hz: f64 },
}

impl ErrorFilter {
    /// (b₀, b₁, b₂, a₁, a₂) of the discrete biquad (the notch by the bilinear transform,
    /// prewarped to its frequency; the poles matched, e^(−ωT)).
    pub fn biquad(&self) -> [f64; 5] {
        match *self {
            ErrorFilter::Pass => tactile_core::tracking::FEEDBACK_PASS.map(f64::from),
            ErrorFilter::Notch { hz, damping } => {
                let w = 2.0 * std::f64::consts::PI * hz;
                let k = w / (w * CONTROL_PERIOD_S / 2.0).tan();
                let a0 = k * k + 2.0 * damping * w * k + w * w;
                let (n0, n1) = (k * k + w * w, 2.0 * (w * w - k * k));
                [
                    n0 / a0,
                    n1 / a0,
                    n0 / a0,
                    n1 / a0,
                    (k * k - 2.0 * damping * w * k + w * w) / a0,
                ]
            }
            ErrorFilter::Lowpass { hz } => {
                let a = (-2.0 * std::f64::consts::PI * hz * CONTROL_PERIOD_S).exp();
                [(1.0 - a) * (1.0 - a), 0.0, 0.0, -2.0 * a, a * a]
            }
        }
    }
}

impl std::fmt::Display for ErrorFilter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ErrorFilter::Pass => write!(f, "no filter"),
            ErrorFilter::Notch { hz, damping } => {
                write!(f, "a notch at {hz:.0} Hz (poles damped {damping})")
            }
            ErrorFilter::Lowpass { hz } => write!(f, "a double pole at {hz:.0} Hz"),
        }
    }
}

/// (b₀ + b₁z⁻¹ + b₂z⁻²)/(1 + a₁z⁻¹ + a₂z⁻²) at `z_inv`.
fn biquad_at([b0, b1, b2, a1, a2]: [f64; 5], z_inv: Complex64) -> Complex64 {
    (b0 + z_inv * (b1 + z_inv * b2)) / (1.0 + z_inv * (a1 + z_inv * a2))
}

/// The feedback's response at `hz`: (kp + ki·T/(1 − z⁻¹))·F(z)·z⁻¹, F the biquad on the
/// error and z⁻¹ the tick the loop waits for the reading; as `tactile_core::tracking` runs it.
fn feedback_at(kp: f64, ki_per_s: f64, biquad: [f64; 5], hz: f64) -> Complex64 {
    let z_inv = Complex64::from_polar(1.0, -2.0 * std::f64::consts::PI * hz * CONTROL_PERIOD_S);
    (kp + ki_per_s * CONTROL_PERIOD_S / (1.0 - z_inv)) * biquad_at(biquad, z_inv) * z_inv
}

/// The feedback a controller table runs at `load_g` (its share there), as [`Feedback::response`]
/// computes a design's: to check a table on a plant it was not designed on.
pub fn table_feedback(c: &TrackingConfig, load_g: f32) -> impl Fn(f64) -> Complex64 {
    let share = f64::from(c.series_at(load_g).1);
    let (kp, ki) = (share * f64::from(c.kp), share * f64::from(c.ki_per_s));
    let biquad = c.feedback_filter.map(f64::from);
    move |hz| feedback_at(kp, ki, biquad, hz)
}

/// The controller's feedback: what the margins are computed for.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Feedback {
    pub kp: f64,
    pub ki_per_s: f64,
    pub filter: ErrorFilter,
}

impl Feedback {
    /// The gains times `share` (a load's feedback share), the filter unchanged.
    pub fn scaled(self, share: f64) -> Feedback {
        Feedback {
            kp: share * self.kp,
            ki_per_s: share * self.ki_per_s,
            ..self
        }
    }

    /// The response at `hz` ([`feedback_at`]).
    pub fn response(&self, hz: f64) -> Complex64 {
        feedback_at(self.kp, self.ki_per_s, self.filter.biquad(), hz)
    }
}

/// The margins of `feedback` on `plant` (gauge g per drive g at each hertz).
pub fn loop_margins(feedback: Feedback, plant: impl Fn(f64) -> Complex64) -> Margins {
    let l: Vec<Complex64> = loop_grid_hz()
        .into_iter()
        .map(|hz| feedback.response(hz) * plant(hz))
        .collect();
    margins(&l)
}

/// `m` (first) and its variants: the modes' damping at [`DAMPING_FLOOR`] of the identified
/// (half that at an `extrapolated` load), the contact mode's, both, the beam's, and the beam's
/// with a tick more delay; each parameter moved by ±[`PLANT_TOLERANCE`] in turn (the gain,
/// each mode's frequency and damping, the amplifier's pole).
pub fn variants(m: &ApplicatorModel, extrapolated: bool) -> Vec<ApplicatorModel> {
    let mut out = vec![*m];
    let floor = if extrapolated {
        0.5 * DAMPING_FLOOR
    } else {
        DAMPING_FLOOR
    };
    let mut v = *m;
    v.modes[0].damping_ratio *= floor;
    out.push(v);
    v.modes[1].damping_ratio *= floor;
    out.push(v);
    v = *m;
    v.modes[1].damping_ratio *= floor;
    out.push(v);
    // A tick more delay, with the beam's damping at the floor as well: the fitted delay runs
    // negative (a lead of 0.6–0.8 ms where the hold alone delays half a tick) and the fitted
    // phase at the beam's mode leads the friction-free plant's by 40–100°.
    v.delay_s += CONTROL_PERIOD_S;
    out.push(v);
    for f in [1.0 - PLANT_TOLERANCE, 1.0 + PLANT_TOLERANCE] {
        let mut v = *m;
        v.gain *= f;
        out.push(v);
        v = *m;
        v.pole_hz *= f;
        out.push(v);
        for k in 0..2 {
            v = *m;
            v.modes[k].hz *= f;
            out.push(v);
            v = *m;
            v.modes[k].damping_ratio *= f;
            out.push(v);
        }
    }
    out
}

/// The least margins of a feedback (its response on [`loop_grid_hz`]) over plants given by
/// theirs.
fn worst_margins(plants: &[Vec<Complex64>], feedback_on_grid: &[Complex64]) -> Margins {
    plants.iter().fold(
        Margins {
            gain: f64::INFINITY,
            phase_deg: 180.0,
            band_sensitivity_db: f64::NEG_INFINITY,
        },
        |w, p| {
            let l: Vec<Complex64> = feedback_on_grid.iter().zip(p).map(|(c, p)| c * p).collect();
            let m = margins(&l);
            Margins {
                gain: w.gain.min(m.gain),
                phase_deg: w.phase_deg.min(m.phase_deg),
                band_sensitivity_db: w.band_sensitivity_db.max(m.band_sensitivity_db),
            }
        },
    )
}

/// The largest x in [0, `hi`] that `passes` (which holds at 0 and fails past some point), by
/// bisection to 2⁻²⁴ of `hi`.
fn largest_passing(hi: f64, passes: impl Fn(f64) -> bool) -> f64 {
    let (mut lo, mut hi) = (0.0f64, hi);
    for _ in 0..24 {
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
    pub feedback: Feedback,
    /// The least margins at each model's load over its [`variants`].
    pub margins: Vec<Margins>,
}

/// The controller for the identified `models` (in increasing load), the actuator's range
/// `drive_range_g`.
pub fn design(
    models: &[LoadModel],
    stiction_g: f32,
    drive_range_g: (f32, f32),
    gauge_noise_g: f32,
) -> Result<Design, DesignError> {
    let friction_g = (FRICTION_SHARE * f64::from(stiction_g)) as f32;
    // The identified models and, outside them, the extrapolated ones.
    let lightest = models
        .iter()
        .map(|m| m.load_g)
        .fold(f32::INFINITY, f32::min);
    let heaviest = models.iter().map(|m| m.load_g).fold(0.0, f32::max);
    // Above the heaviest, the design's loads whose excitation gave no model (the heavy rig's
    // 100 g chirp leaves the gauge's range: the 75 g model ran to 110 g, and a 10 g sine
    // about 100 g peaked +4.4 dB at 40 Hz, at that load's own mode).
    let mut all: Vec<LoadModel> = EXTRAPOLATED_LOADS_G
        .iter()
        .filter(|l| **l < lightest)
        .chain(DESIGN_LOADS_G.iter().filter(|l| **l > heaviest))
        .filter_map(|l| extrapolate(models, *l))
        .chain(models.iter().copied())
        .collect();
    all.sort_by(|a, b| a.load_g.total_cmp(&b.load_g));
    all.truncate(TRACKING_POINTS);
    // The gains from the identified loads; each extrapolated light load gets the share of them
    // its margins allow.
    let grid = loop_grid_hz();
    let family = |m: &LoadModel| -> Vec<Vec<Complex64>> {
        variants(&m.model, m.load_g < lightest || m.load_g > heaviest)
            .iter()
            .map(|v| grid.iter().map(|hz| v.response(*hz)).collect())
            .collect()
    };
    let identified_models = models;
    let identified: Vec<Vec<Complex64>> = models.iter().flat_map(family).collect();
    let models = &all[..];
    let on_grid =
        |fb: Feedback| -> Vec<Complex64> { grid.iter().map(|hz| fb.response(*hz)).collect() };
    let worst = |fb: Feedback, plants: &[Vec<Complex64>]| worst_margins(plants, &on_grid(fb));
    // Stops at the first plant that fails (the search's inner loop).
    let passes = |fb: Feedback, plants: &[Vec<Complex64>]| {
        let c = on_grid(fb);
        plants.iter().all(|p| {
            let m = worst_margins(std::slice::from_ref(p), &c);
            m.gain >= GAIN_MARGIN && m.phase_deg >= PHASE_MARGIN_DEG
        })
    };
    // For each filter and proportional gain on a grid, the largest integral gain the margins
    // allow; of those with integral action enough for the stiction, the one whose sensitivity
    // peaks least in the band (the feedback's job there is what the feed-forward leaves).
    let nominal: Vec<Vec<Complex64>> = models
        .iter()
        .map(|m| grid.iter().map(|hz| m.model.response(*hz)).collect())
        .collect();
    // The notches sit at the beam's mode (the models' highest), its median over the loads.
    let beam_hz = upper_median(
        identified_models
            .iter()
            .map(|m| m.model.modes[1].hz)
            .collect(),
    )
    .unwrap_or(f64::NAN);
    let mut filters = vec![ErrorFilter::Pass];
    if beam_hz.is_finite() && beam_hz < 0.45 / CONTROL_PERIOD_S {
        filters.extend(NOTCH_DAMPINGS.iter().map(|&damping| ErrorFilter::Notch {
            hz: beam_hz,
            damping,
        }));
    }
    filters.extend(
        FEEDBACK_POLES_HZ
            .iter()
            .map(|&hz| ErrorFilter::Lowpass { hz }),
    );
    let mut best: Option<(Feedback, f64)> = None;
    // Where no candidate reaches the integral gain wanted, the one with the most.
    let mut most: Option<Feedback> = None;
    for filter in filters {
        for kp in [0.0, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4] {
            let at = |ki_per_s| Feedback {
                kp,
                ki_per_s,
                filter,
            };
            if !passes(at(0.0), &identified) {
                continue;
            }
            let fb = at(largest_passing(2000.0, |ki| passes(at(ki), &identified)));
            let peak = worst(fb, &nominal).band_sensitivity_db;
            if most.is_none_or(|m| fb.ki_per_s > m.ki_per_s) {
                most = Some(fb);
            }
            if fb.ki_per_s >= MIN_KI_PER_S && best.is_none_or(|b| peak < b.1) {
                best = Some((fb, peak));
            }
        }
    }
    let best = best.map(|b| b.0).or(most);
    let Some(feedback) = best.filter(|b| b.ki_per_s > 0.0) else {
        let probe = Feedback {
            kp: 0.0,
            ki_per_s: 1.0,
            filter: ErrorFilter::Pass,
        };
        let worst = models
            .iter()
            .map(|m| (m.load_g, worst(probe, &family(m)).gain))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((f32::NAN, f64::NAN));
        return Err(DesignError::NoMargin {
            load_g: worst.0,
            margin: worst.1,
        });
    };
    let families: Vec<Vec<Vec<Complex64>>> = models.iter().map(family).collect();
    let share_at = |plants: &[Vec<Complex64>]| {
        if passes(feedback, plants) {
            1.0
        } else {
            largest_passing(1.0, |share| passes(feedback.scaled(share), plants))
        }
    };
    let mut schedule = [InverseSeries {
        load_g: 0.0,
        c: [1.0, 0.0, 0.0, 0.0],
        feedback: 0.0,
        gauge_s2: 0.0,
    }; TRACKING_POINTS];
    for ((slot, m), plants) in schedule.iter_mut().zip(models).zip(&families) {
        let w_z = 2.0 * std::f64::consts::PI * m.model.anti_resonance.hz;
        *slot = InverseSeries {
            load_g: m.load_g,
            c: inverse_series(m).map(|v| v as f32),
            feedback: share_at(plants) as f32,
            gauge_s2: (1.0 / (w_z * w_z)) as f32,
        };
    }
    // The touch-down's pulses: the momentum a push gives the probe beyond the friction is what
    // it strikes the finger with at most, and a mass with momentum p landing on a spring that
    // rings at ω overshoots by about p·ω: at the lightest load's inertia–finger mode, a
    // momentum worth TOUCH_OVERSHOOT_G. A pulse's shape has a mean of one half, so its peak
    // is twice the push.
    let w_light = 2.0 * std::f64::consts::PI * models.first().map_or(50.0, |m| m.model.modes[0].hz);
    let pulse_s = f64::from(tactile_core::tracking::APPROACH_TICKS) * CONTROL_PERIOD_S;
    let push_g = (2.0 * TOUCH_OVERSHOOT_G / w_light / pulse_s) as f32;
    // And enough to press the finger to the contact test's force against a stiction 15 % above
    // the identified (the identification reads it 4–9 % low on the three rigs).
    let contact_g = CONTACT_G.max(CONTACT_DEVIATIONS * gauge_noise_g);
    let push_g = push_g.max(contact_g + 0.15 * stiction_g + 0.2);
    let least_g = LEAST_STICTION_SHARE * push_g;
    if stiction_g < least_g {
        return Err(DesignError::TooLittleFriction {
            stiction_g,
            push_g,
            least_g,
        });
    }
    let config = TrackingConfig {
        dt_s: CONTROL_PERIOD_S as f32,
        reference_hz: REFERENCE_HZ,
        schedule,
        points: models.len().min(TRACKING_POINTS) as u8,
        friction_g,
        amplifier_tau_s: amplifier_tau_s(identified_models) as f32,
        held_friction_g: (HELD_FRICTION_SHARE * f64::from(stiction_g)) as f32,
        kp: feedback.kp as f32,
        ki_per_s: feedback.ki_per_s as f32,
        feedback_filter: feedback.filter.biquad().map(|v| v as f32),
        // What the model's static gain can be off by: the light rig's small chirps read its
        // gain 0.65–0.81 through twice the stiction, and the feed-forward overdrove 70 g by 21 g
        // (a 20 g bound left 1.2 g of error standing).
        integral_limit_g: 0.5 * drive_range_g.1.max(-drive_range_g.0),
        approach_hold_g: stiction_g,
        approach_push_g: push_g,
        // Half the push back: on a rig without friction a brake as strong as the push would
        // leave any drift the probe had (an offset of the drive's zero, a push from the finger)
        // uncorrected, and the probe would never arrive; half leaves a net push of a quarter
        // of a pulse's, which the friction of any other rig takes.
        approach_brake_g: -0.5 * push_g,
        contact_g,
        drive_min_g: drive_range_g.0,
        drive_max_g: drive_range_g.1,
    };
    let margins = families
        .iter()
        .zip(&schedule)
        .map(|(plants, p)| worst(feedback.scaled(f64::from(p.feedback)), plants))
        .collect();
    Ok(Design {
        config,
        models: models.to_vec(),
        feedback,
        margins,
    })
}

/// The share of the identified stiction the feed-forward pushes against, in the direction the
/// reference moves (through the amplifier's inverse where it turns, [`amplifier_tau_s`]): all
/// of it, now that the models are fitted to the drive less the friction
/// ([`crate::identify::PeriodMeans::less_friction`]) and refined with it simulated
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

/// The current amplifier's time constant, s (`TrackingConfig::amplifier_tau_s`): 1/(2πf_p) of
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
/// last moved (`TrackingConfig::held_friction_g`): the rest of the stiction is a dead band
/// about the target, where a motor that stops short stays until the integral pushes it on.
/// Measured (`HELD=S ONLY=1 cargo run --release -p sim-host --example design_controller
/// applicators/FILE.toml`), every step after the first into ±1 g, worst, memo / heavy / light
/// rig: none 53 / 78 / 82 ms (with the flat chirp's models), a half 25 / 23 / 62 ms (the light
/// rig's 2.1 g of stiction left its 60 g step stopped 1.1 g short: it did so on the analytic
/// models too), three quarters 25 / 23 / 20 ms, a whole 37 / – / 33 ms; the closed loop's
/// magnitude the same to 0.03 dB.
pub const HELD_FRICTION_SHARE: f64 = 0.75;

/// The least stiction the design takes, as a share of the touch-down's push: the pulses' brake
/// is half the push, and the friction takes the rest of each cycle's momentum; with less the
/// probe gathers speed over an approach and strikes the finger. Measured on the memo's rig with
/// its stiction scaled (`ONLY=1 cargo run --release -p sim-host --example design_controller
/// FILE`; the push 0.76 g): a tenth (0.08 g identified) landed every `low-force` touch-down
/// within 0.15 g; a twentieth (0.03 g) 1.53 g over, a fiftieth 15.7 g, none 33.9 g. A brake as
/// strong as the push instead left the frictionless probe drifting off, never landing.
pub const LEAST_STICTION_SHARE: f32 = 0.07;

/// The overshoot a touch-down's momentum is sized for, g (the bound is 1 g).
pub const TOUCH_OVERSHOOT_G: f64 = 0.5;
/// The reading that tells the probe is on the finger (`tactile_core::tracking::CONTACT_COUNT`
/// of the last `CONTACT_TICKS` at it), g: above the tip's inertia under a push (a third of the
/// push's net force on the memo rig), and over [`CONTACT_DEVIATIONS`] of the gauge's noise.
pub const CONTACT_G: f32 = 0.4;
/// The contact reading in deviations of a tick's gauge noise, at least: six readings of eight
/// do not pass 2.8 deviations by chance (0.39 g at the memo's 0.14 g, 0.78 g at a gauge half
/// as sensitive).
pub const CONTACT_DEVIATIONS: f32 = 2.8;

/// What [`design_for_rig`] identified and designed.
#[derive(Clone, Debug, Serialize)]
pub struct RigDesign {
    pub identified: Identified,
    pub design: Design,
}

/// Identifies the rig `config` describes and designs its controller, the drive's range A1's.
pub fn design_for_rig(config: &RigConfig) -> Result<RigDesign, DesignError> {
    design_identified(identify_loads(config)?, config)
}

/// Designs the controller from an identification (the simulator's, or records'), the drive's
/// range that of `config`'s A1.
pub fn design_identified(
    identified: Identified,
    config: &RigConfig,
) -> Result<RigDesign, DesignError> {
    let law = config.firmware.law;
    let design = design(
        &identified.models,
        identified.stiction_g as f32,
        (law.adjusted_min_g, law.adjusted_max_g),
        identified.gauge_noise_g as f32,
    )?;
    Ok(RigDesign { identified, design })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::Resonance;

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
        // A drive that was one spike: the fit's gain 0.00 and its pole at 6.5e30 Hz (the gain
        // is the first reason named).
        let mut spike = kept.model;
        spike.gain = 0.003;
        spike.pole_hz = 6.5e30;
        assert_eq!(implausible(&spike), Some("its gain is not within 0.5–2"));
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
