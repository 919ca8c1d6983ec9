//! The identification the design reads: the excitation run at each preload (on the simulated
//! rig, or read from records), the static line of the holds and the chirps' means, the models
//! fitted there, and the preloads left out and why.

use serde::Serialize;
use tactile_core::profile::Protocol;
use tactile_ident::stats;

use super::models::upper_median;
use super::*;
use crate::applicator_model::{ApplicatorModel, IdentifyError};
use crate::rig::RigConfig;
use crate::scenario::run_protocol;

/// What the excitation at several preloads identified.
#[derive(Clone, Debug, Serialize)]
pub struct Identified {
    /// The plausible models, in increasing load.
    pub models: Vec<LoadModel>,
    /// The static line ([`crate::applicator_model::static_line`]): gain and stiction (g at the
    /// probe).
    pub static_gain: f64,
    pub stiction_g: f64,
    /// The gauge's noise, RMS of one reading: the median of the holds'.
    pub gauge_noise_g: f64,
    /// The preloads whose excitation gave no model the design could use, and why: the design
    /// extrapolates past them or interpolates across them.
    pub left_out: Vec<LeftOut>,
}

impl Identified {
    /// The stiction in the drive's grams (the firmware's): the drive that overcomes it.
    pub fn stiction_drive_g(&self) -> f64 {
        self.stiction_g / self.static_gain
    }
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
pub(super) fn left_out_list(left_out: &[LeftOut]) -> String {
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
    pub means: crate::applicator_model::PeriodMeans,
    pub hold: crate::applicator_model::Hold,
}

/// Runs the excitation at each of [`DESIGN_LOADS_G`] the loop takes as a command (within
/// `supervisor::GAUGE_COMMAND_SHARE` of the gauge's top reading: a gauge twice as sensitive as
/// the memo's reads up to 67.5 g, and the 75 g preload's hold put it at its rail before the
/// chirp began, which refused the design; the loads above are extrapolated from the heaviest
/// identified) on a rig built from `config` and identifies the applicator from them
/// ([`identified_from`]); a preload whose excitation cannot be identified, even with its chirp
/// halved, is left out. The drive is read in the firmware's grams of `config` whatever scale
/// the identification ran at ([`identification_config`]).
pub fn identify_loads(config: &RigConfig) -> Result<Identified, DesignError> {
    let top_g = tactile_core::supervisor::GAUGE_COMMAND_SHARE * config.firmware.gauge.force_max_g;
    let identifying = identification_config(config, held_share(config)?);
    let actuator = config.firmware.actuator;
    let runs: Vec<Result<Excited, DesignError>> = std::thread::scope(|scope| {
        let handles: Vec<_> = DESIGN_LOADS_G
            .iter()
            .filter(|&&load_g| load_g <= top_g)
            .map(|&load_g| {
                let config = RigConfig {
                    scan_array: false,
                    ..identifying.clone()
                };
                scope.spawn(move || excite(config, &actuator, load_g))
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

/// The rig the excitation runs on: `config`'s, its firmware's drive scale moved to the
/// `held_share` it measured (`None`: left). A1 has no integral action and its feedback is a
/// hundredth of the command at 10 g, so it drives the command itself: a drive at 0.38 of the
/// firmware's scale held 3.8 g for 10 g, and the supervisor took that for a contact lost
/// (the reading under half the command) at every preload. With the scale moved, the holds
/// land near the preloads and the commands' secant steps ([`HOLD_TRIES`]) do the rest.
pub fn identification_config(config: &RigConfig, held_share: Option<f64>) -> RigConfig {
    let mut identifying = config.clone();
    if let Some(share) = held_share {
        identifying.firmware.actuator.grams_per_volt *= share as f32;
    }
    identifying
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
    let load_g = crate::applicator_model::preload_of_record(rec).ok_or(not_excitation)?;
    let means = crate::applicator_model::period_means_of_record(rec)
        .map_err(|source| DesignError::Identify { load_g, source })?;
    let hold = crate::applicator_model::hold_means_of_record(rec)
        .ok_or(IdentifyError::NoHold)
        .and_then(|h| h.at_preload(load_g))
        .map_err(|source| DesignError::Identify { load_g, source })?;
    Ok(Excited {
        load_g,
        means,
        hold,
    })
}

/// The models fitted at each preload, with the static line's gain and stiction; loads
/// whose fit does not converge, is not [`plausible`] or puts the amplifier elsewhere than the
/// others' ([`one_amplifier`]) are left out, after those the caller left out (`left_out`); at
/// least two must remain.
///
/// A preload whose chirp gives no applicator's model is no reading of the static line either:
/// on a drive 0.55× the memo's the 100 g chirp reached the drive's rail, and its mean read the
/// gain 2 % low and the stiction 40 % low. Where one is left out of a line the chirps gave, the
/// line is taken again without it and the models fitted again with its stiction.
pub fn identified_from(
    excited: &[Excited],
    left_out: Vec<LeftOut>,
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
    let gauge_noise_g =
        upper_median(excited.iter().map(|e| e.hold.noise_g).collect()).unwrap_or(0.0);
    let all: Vec<&Excited> = excited.iter().collect();
    let (mut line, mut fitted) = fitted_on_line(excited, &all, left_out.clone())?;
    let kept: Vec<&Excited> = excited
        .iter()
        .filter(|e| fitted.0.iter().any(|m| m.load_g == e.load_g))
        .collect();
    if line.1 && (2..excited.len()).contains(&kept.len()) {
        (line, fitted) = fitted_on_line(excited, &kept, left_out)?;
    }
    let (((static_gain, stiction_g), _), (models, left_out)) = (line, fitted);
    if models.len() < 2 {
        return Err(DesignError::TooFewModels {
            have: models.len(),
            left_out,
        });
    }
    Ok(Identified {
        models,
        static_gain,
        stiction_g,
        gauge_noise_g,
        left_out,
    })
}

/// Models and what is left out, sorted by load.
type Fitted = (Vec<LoadModel>, Vec<LeftOut>);

/// The static line of the preloads `on` ([`crate::applicator_model::static_line`]: the line,
/// and whether the chirps gave its gain), and the models of every preload of `excited` fitted with its stiction ([`fit_models`]).
fn fitted_on_line(
    excited: &[Excited],
    on: &[&Excited],
    left_out: Vec<LeftOut>,
) -> Result<(crate::applicator_model::StaticLine, Fitted), DesignError> {
    let points: Vec<crate::applicator_model::StaticPoint> = on
        .iter()
        .map(|e| crate::applicator_model::StaticPoint {
            hold: (e.hold.drive_g, e.hold.gauge_g),
            chirp: (stats::mean(&e.means.drive_g), stats::mean(&e.means.gauge_g)),
        })
        .collect();
    let line = crate::applicator_model::static_line(&points).ok_or(DesignError::NoStaticLine)?;
    Ok((line, fit_models(excited, line.0, left_out)))
}

/// The model of each preload fitted with the static line's (gain, stiction), the implausible
/// and the amplifiers off the others' left out after `left_out`.
fn fit_models(
    excited: &[Excited],
    (static_gain, stiction_g): (f64, f64),
    mut left_out: Vec<LeftOut>,
) -> Fitted {
    // The friction acts on the drive: its grams are the probe's over the drive's gain.
    let stiction_drive_g = stiction_g / static_gain;
    // One fit per preload, side by side (each is a few hundred milliseconds).
    let fits: Vec<Option<ApplicatorModel>> = std::thread::scope(|scope| {
        let handles: Vec<_> = excited
            .iter()
            .map(|e| {
                scope.spawn(move || {
                    // The linear fit starts the one with the friction simulated (seconds).
                    let fit = |pole_hz: Option<f64>| {
                        let linear = e.means.fit_less_friction(stiction_drive_g, pole_hz)?;
                        let refined = crate::stick_slip::fit_with_friction_and_pole(
                            &e.means,
                            stiction_drive_g,
                            &linear,
                            pole_hz,
                        );
                        Some(refined.unwrap_or(linear))
                    };
                    let free = fit(None)?;
                    if free.pole_hz > POLE_RANGE_HZ.1 {
                        return fit(Some(POLE_RANGE_HZ.1)).or(Some(free));
                    }
                    Some(free)
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
    (kept, left_out)
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
    excited_at(ticks, protocol, actuator, preload_g)
}

/// [`excited_of_run`] for a run whose command was chosen to hold `load_g` (a drive stronger
/// or weaker than the firmware's scale holds another force at the preload commanded).
fn excited_at(
    ticks: &[crate::rig::TickRecord],
    protocol: Protocol,
    actuator: &tactile_core::control::ActuatorConfig,
    load_g: f32,
) -> Result<Excited, DesignError> {
    let failed = |source| DesignError::Identify { load_g, source };
    let means = crate::applicator_model::period_means(ticks, protocol, actuator).map_err(failed)?;
    let hold = crate::applicator_model::hold_means(ticks, actuator)
        .ok_or(IdentifyError::NoHold)
        .and_then(|h| h.at_preload(load_g))
        .map_err(failed)?;
    Ok(Excited {
        load_g,
        means,
        hold,
    })
}

/// Runs of the excitation a preload gets to find the command that holds it.
pub const HOLD_TRIES: usize = 4;

/// The force held per gram commanded at the lightest preload, with the supervisor's contact
/// rule off (a drive under half the firmware's scale reads under half the command), where that
/// is off 1 (`None` where it is not, or the hold says nothing).
fn held_share(config: &RigConfig) -> Result<Option<f64>, DesignError> {
    let load_g = DESIGN_LOADS_G[0];
    let mut protocol = Protocol::design_excitation(load_g);
    if let Protocol::Excitation { periods, .. } = &mut protocol {
        *periods = 1;
    }
    let mut free = config.clone();
    free.firmware.supervisor.contact_command_g = f32::INFINITY;
    let run = run_protocol("excitation", protocol, free, false, |_| {})?;
    let hold = crate::applicator_model::hold_means(&run.ticks, &config.firmware.actuator);
    Ok(hold
        .map(|h| h.gauge_g / f64::from(load_g))
        .filter(|share| share.is_finite() && *share > 0.1 && (share - 1.0).abs() > HELD_SHARE_OFF))
}

/// How far off 1 the force held per gram commanded must be for the drive's scale to be moved:
/// A1's steady error on the memo's drive is under a gram at 10 g; a drive 1.5× as strong holds
/// 14 g.
pub const HELD_SHARE_OFF: f64 = 0.25;

/// The excitation at one preload on the simulated rig ([`Protocol::design_excitation`]), its
/// chirp halved while the probe leaves the finger or the gauge leaves its range, the drive
/// read in `actuator`'s grams (the firmware's own, whatever scale `config` runs at).
///
/// A1 has no integral action: a hold off the preload is read as the rig's static gain, and
/// the command moved until the gauge holds the preload (secant steps through the holds'
/// forces), the chirp scaled by the same ratio, so that it is the same force at the probe.
fn excite(
    config: RigConfig,
    actuator: &tactile_core::control::ActuatorConfig,
    load_g: f32,
) -> Result<Excited, DesignError> {
    let top_g = tactile_core::supervisor::GAUGE_COMMAND_SHARE * config.firmware.gauge.force_max_g;
    let mut protocol = Protocol::design_excitation(load_g);
    let chirp_g = match protocol {
        Protocol::Excitation { amplitude_g, .. } => amplitude_g,
        _ => 0.0,
    };
    let command = |c: f64| (c as f32).clamp(0.25 * load_g, top_g.max(load_g));
    let mut tried: Vec<(f64, f64)> = Vec::new();
    loop {
        let run = run_protocol("excitation", protocol, config.clone(), false, |_| {})?;
        let Protocol::Excitation {
            preload_g: command_g,
            amplitude_g,
            ..
        } = &mut protocol
        else {
            return Err(DesignError::Record(IdentifyError::NotTheExcitation));
        };
        let hold = crate::applicator_model::hold_means(&run.ticks, actuator);
        if let Some(h) = hold.filter(|h| h.gauge_g > 0.1 * f64::from(load_g)) {
            let off = matches!(
                h.at_preload(load_g),
                Err(IdentifyError::HoldOffPreload { .. })
            );
            if off && tried.len() + 1 < HOLD_TRIES {
                tried.push((f64::from(*command_g), h.gauge_g));
                *command_g = command(command_for(&tried, f64::from(load_g)));
                *amplitude_g = chirp_g * *command_g / load_g;
                continue;
            }
        }
        match excited_at(&run.ticks, protocol, actuator, load_g) {
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

/// The command whose hold reads `load_g`, from the (command, held force) runs so far: through
/// the origin from one, the secant of the last two after.
fn command_for(tried: &[(f64, f64)], load_g: f64) -> f64 {
    match tried {
        [.., (c0, h0), (c1, h1)] if (h1 - h0).abs() > 1e-3 => {
            c1 + (load_g - h1) * (c1 - c0) / (h1 - h0)
        }
        [.., (c, h)] => c * load_g / h,
        [] => load_g,
    }
}
