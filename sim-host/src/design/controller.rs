//! The design itself: the loads the schedule covers, the feedback the margins allow there, the
//! feed-forward's schedule and the touch-down's pulses, gathered in the core's
//! [`DesignedConfig`]; and the design of a rig from its identification.

use num_complex::Complex64;
use serde::Serialize;
use tactile_core::designed::{DesignedConfig, InverseSeries, DESIGNED_POINTS};
use tactile_core::CONTROL_PERIOD_S;

use super::feedback::{largest_passing, worst_margins};
use super::models::upper_median;
use super::*;
use crate::applicator_model::ApplicatorModel;
use crate::rig::RigConfig;

/// The designed controller and what it was designed on.
#[derive(Clone, Debug, Serialize)]
pub struct Design {
    #[serde(skip)]
    pub config: DesignedConfig,
    pub models: Vec<LoadModel>,
    pub feedback: Feedback,
    /// The least margins at each model's load over its [`variants`].
    pub margins: Vec<Margins>,
}
/// The controller for the identified `models` (in increasing load), the stiction the drive
/// must overcome `stiction_g` and the actuator's range `drive_range_g` (the drive's grams, the
/// firmware's: the models' static gain turns them into the probe's), through `gauge` (its
/// noise `gauge_noise_g`).
pub fn design(
    models: &[LoadModel],
    stiction_g: f32,
    drive_range_g: (f32, f32),
    gauge: tactile_core::gauge::GaugeConfig,
    gauge_noise_g: f32,
) -> Result<Design, DesignError> {
    let friction_g = (FRICTION_SHARE * f64::from(stiction_g)) as f32;
    let (grid, loads) = LoopGrid::new(models);
    // The gains from the identified loads; each extrapolated light load gets the share of them
    // its margins allow.
    let feedback = search_feedback(&grid, models, &loads)?;
    let families: Vec<Vec<Vec<Complex64>>> = loads.iter().map(|m| grid.family(m)).collect();
    let schedule = schedule(&grid, feedback, &loads, &families);
    let (push_g, contact_g) = touch_down(&loads, stiction_g, gauge_noise_g)?;
    let config = DesignedConfig {
        dt_s: CONTROL_PERIOD_S as f32,
        reference_hz: REFERENCE_HZ,
        schedule,
        points: loads.len().min(DESIGNED_POINTS) as u8,
        friction_g,
        amplifier_tau_s: amplifier_tau_s(models) as f32,
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
        gauge_g_per_v: gauge.grams_per_volt,
        gauge_max_g: gauge.force_max_g,
    };
    let margins = families
        .iter()
        .zip(&schedule)
        .map(|(plants, p)| grid.worst(feedback.scaled(f64::from(p.feedback)), plants))
        .collect();
    Ok(Design {
        config,
        models: loads,
        feedback,
        margins,
    })
}

/// The loop's frequencies ([`loop_grid_about`] the designed loads' modes) and the span of the
/// identified loads: what a load's plants and a feedback's margins on them are computed on.
struct LoopGrid {
    hz: Vec<f64>,
    lightest: f32,
    heaviest: f32,
}

impl LoopGrid {
    /// The grid for the identified `models`, and the loads designed for ([`designed_loads`]).
    fn new(models: &[LoadModel]) -> (LoopGrid, Vec<LoadModel>) {
        let lightest = models
            .iter()
            .map(|m| m.load_g)
            .fold(f32::INFINITY, f32::min);
        let heaviest = models.iter().map(|m| m.load_g).fold(0.0, f32::max);
        let loads = designed_loads(models, lightest, heaviest);
        let outside = |m: &LoadModel| m.load_g < lightest || m.load_g > heaviest;
        let modes: Vec<(ApplicatorModel, bool)> =
            loads.iter().map(|m| (m.model, outside(m))).collect();
        let grid = LoopGrid {
            hz: loop_grid_about(&modes),
            lightest,
            heaviest,
        };
        (grid, loads)
    }

    /// The responses of `m`'s [`variants`] (an extrapolated load's outside the identified).
    fn family(&self, m: &LoadModel) -> Vec<Vec<Complex64>> {
        variants(
            &m.model,
            m.load_g < self.lightest || m.load_g > self.heaviest,
        )
        .iter()
        .map(|v| self.hz.iter().map(|hz| v.response(*hz)).collect())
        .collect()
    }

    /// The response of `m`'s model itself.
    fn nominal(&self, m: &LoadModel) -> Vec<Complex64> {
        self.hz.iter().map(|hz| m.model.response(*hz)).collect()
    }

    fn on_grid(&self, fb: Feedback) -> Vec<Complex64> {
        self.hz.iter().map(|hz| fb.response(*hz)).collect()
    }

    /// The least margins of `fb` over `plants`.
    fn worst(&self, fb: Feedback, plants: &[Vec<Complex64>]) -> Margins {
        worst_margins(&self.hz, plants, &self.on_grid(fb))
    }

    /// Whether `fb` has the margins on every one of `plants`. Stops at the first plant that
    /// fails (the search's inner loop).
    fn passes(&self, fb: Feedback, plants: &[Vec<Complex64>]) -> bool {
        let c = self.on_grid(fb);
        plants.iter().all(|p| {
            let m = worst_margins(&self.hz, std::slice::from_ref(p), &c);
            m.gain >= GAIN_MARGIN && m.phase_deg >= PHASE_MARGIN_DEG
        })
    }
}

/// The identified models and, outside them (under `lightest`, over `heaviest`), the
/// extrapolated ones, in increasing load, at most [`DESIGNED_POINTS`].
fn designed_loads(models: &[LoadModel], lightest: f32, heaviest: f32) -> Vec<LoadModel> {
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
    all.truncate(DESIGNED_POINTS);
    all
}

/// The feedback: its gains as large as the margins allow on the `identified` models' plants,
/// its sensitivity judged on the designed `loads`' models.
fn search_feedback(
    grid: &LoopGrid,
    identified: &[LoadModel],
    loads: &[LoadModel],
) -> Result<Feedback, DesignError> {
    let plants: Vec<Vec<Complex64>> = identified.iter().flat_map(|m| grid.family(m)).collect();
    // For each filter and proportional gain on a grid, the largest integral gain the margins
    // allow; of those with integral action enough for the stiction, the one whose sensitivity
    // peaks least in the band (the feedback's job there is what the feed-forward leaves).
    let nominal: Vec<Vec<Complex64>> = loads.iter().map(|m| grid.nominal(m)).collect();
    let mut best: Option<(Feedback, f64)> = None;
    // Where no candidate reaches the integral gain wanted, the one with the most.
    let mut most: Option<Feedback> = None;
    for filter in error_filters(identified) {
        for kp in [0.0, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4] {
            let at = |ki_per_s| Feedback {
                kp,
                ki_per_s,
                filter,
            };
            if !grid.passes(at(0.0), &plants) {
                continue;
            }
            let fb = at(largest_passing(2000.0, |ki| grid.passes(at(ki), &plants)));
            let peak = grid.worst(fb, &nominal).band_sensitivity_db;
            if most.is_none_or(|m| fb.ki_per_s > m.ki_per_s) {
                most = Some(fb);
            }
            if fb.ki_per_s >= MIN_KI_PER_S && best.is_none_or(|b| peak < b.1) {
                best = Some((fb, peak));
            }
        }
    }
    let best = best.map(|b| b.0).or(most);
    best.filter(|b| b.ki_per_s > 0.0)
        .ok_or_else(|| no_margin(grid, loads))
}

/// The filters the search tries on the error: none, notches at the beam's mode, double poles.
fn error_filters(identified: &[LoadModel]) -> Vec<ErrorFilter> {
    // The notches sit at the beam's mode (the models' highest), its median over the loads.
    let beam_hz =
        upper_median(identified.iter().map(|m| m.model.modes[1].hz).collect()).unwrap_or(f64::NAN);
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
    filters
}

/// Why no feedback has the margins: the load whose gain margin is least under an integral
/// gain of 1/s alone.
fn no_margin(grid: &LoopGrid, loads: &[LoadModel]) -> DesignError {
    let probe = Feedback {
        kp: 0.0,
        ki_per_s: 1.0,
        filter: ErrorFilter::Pass,
    };
    let worst = loads
        .iter()
        .map(|m| (m.load_g, grid.worst(probe, &grid.family(m)).gain))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((f32::NAN, f64::NAN));
    DesignError::NoMargin {
        load_g: worst.0,
        margin: worst.1,
    }
}

/// The feed-forward's schedule: at each of `loads` its series ([`inverse_series`]), the share
/// of `feedback` its plants (`families`) allow, and the tip's inertia on the gauge.
fn schedule(
    grid: &LoopGrid,
    feedback: Feedback,
    loads: &[LoadModel],
    families: &[Vec<Vec<Complex64>>],
) -> [InverseSeries; DESIGNED_POINTS] {
    let share_at = |plants: &[Vec<Complex64>]| {
        if grid.passes(feedback, plants) {
            1.0
        } else {
            largest_passing(1.0, |share| grid.passes(feedback.scaled(share), plants))
        }
    };
    let mut schedule = [InverseSeries {
        load_g: 0.0,
        c: [1.0, 0.0, 0.0, 0.0],
        feedback: 0.0,
        gauge_s2: 0.0,
    }; DESIGNED_POINTS];
    for ((slot, m), plants) in schedule.iter_mut().zip(loads).zip(families) {
        let w_z = 2.0 * std::f64::consts::PI * m.model.anti_resonance.hz;
        *slot = InverseSeries {
            load_g: m.load_g,
            c: inverse_series(m).map(|v| v as f32),
            feedback: share_at(plants) as f32,
            gauge_s2: (1.0 / (w_z * w_z)) as f32,
        };
    }
    schedule
}

/// The touch-down's push (drive grams) and the contact reading (the gauge's), g, for the
/// designed `loads`, `stiction_g` in drive grams; refused where the stiction is too little to
/// stop the probe between the pushes.
fn touch_down(
    loads: &[LoadModel],
    stiction_g: f32,
    gauge_noise_g: f32,
) -> Result<(f32, f32), DesignError> {
    // The touch-down's pulses: the momentum a push gives the probe beyond the friction is what
    // it strikes the finger with at most, and a mass with momentum p landing on a spring that
    // rings at ω overshoots by about p·ω: at the lightest load's inertia–finger mode, a
    // momentum worth TOUCH_OVERSHOOT_G. A pulse's shape has a mean of one half, so its peak
    // is twice the push.
    let w_light = 2.0 * std::f64::consts::PI * loads.first().map_or(50.0, |m| m.model.modes[0].hz);
    let pulse_s = f64::from(tactile_core::designed::APPROACH_TICKS) * CONTROL_PERIOD_S;
    // The momentum is the probe's, and a drive gram pushes it by the static gain's grams.
    let gain = loads.first().map_or(1.0, |m| m.static_gain) as f32;
    let push_g = (2.0 * TOUCH_OVERSHOOT_G / w_light / pulse_s) as f32 / gain;
    // And enough to press the finger to the contact test's force against a stiction 15 % above
    // the identified (the identification reads it 4–9 % low on the three rigs).
    let contact_g = CONTACT_G.max(CONTACT_DEVIATIONS * gauge_noise_g);
    let push_g = push_g.max((contact_g + 0.2) / gain + 0.15 * stiction_g);
    let least_g = LEAST_STICTION_SHARE * push_g;
    if stiction_g < least_g {
        return Err(DesignError::TooLittleFriction {
            stiction_g,
            push_g,
            least_g,
        });
    }
    // And the contact test must pass on the finger: six readings of eight at `contact_g`, a
    // noise deviation over it, through the push's middle six ticks (its shape ≥ ½), the
    // stiction holding the rest. A noisy gauge's contact reading can need a push whose
    // momentum the friction cannot take back: refused, with why.
    let pressing_g = 2.0 * ((contact_g + gauge_noise_g) / gain - stiction_g);
    let least_g = LEAST_STICTION_SHARE * pressing_g;
    if stiction_g < least_g {
        return Err(DesignError::NoisyContact {
            noise_g: gauge_noise_g,
            contact_g,
            push_g: pressing_g,
            stiction_g,
            least_g,
        });
    }
    Ok((push_g.max(pressing_g), contact_g))
}

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
/// The reading that tells the probe is on the finger (`tactile_core::designed::CONTACT_COUNT`
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
    // The heaviest force step the loop takes: the design's top preload, within the gauge's.
    let fw = &config.firmware;
    let top_g = DESIGN_LOADS_G
        .last()
        .copied()
        .unwrap_or(100.0)
        .min(fw.supervisor.command_max_g)
        .min(tactile_core::supervisor::GAUGE_COMMAND_SHARE * fw.gauge.force_max_g);
    let top_g = f64::from(top_g);
    let reach_g =
        identified.static_gain * (f64::from(law.adjusted_max_g) - identified.stiction_drive_g());
    if reach_g < top_g {
        return Err(DesignError::OutOfReach {
            reach_g,
            top_g,
            static_gain: identified.static_gain,
        });
    }
    let design = design(
        &identified.models,
        identified.stiction_drive_g() as f32,
        (law.adjusted_min_g, law.adjusted_max_g),
        config.firmware.gauge,
        identified.gauge_noise_g as f32,
    )?;
    Ok(RigDesign { identified, design })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::applicator_model::{ApplicatorModel, Resonance};

    /// A lightest load whose inertia–finger mode rings at 16 Hz, the drive's gain 1.117 (the
    /// gauge reads 1.117 g per drive gram).
    fn light_load() -> LoadModel {
        let mode = |hz| Resonance {
            hz,
            damping_ratio: 0.07,
        };
        LoadModel {
            load_g: 1.0,
            model: ApplicatorModel {
                gain: 1.117,
                anti_resonance: mode(30.0),
                modes: [mode(16.0), mode(122.0)],
                pole_hz: 243.0,
                delay_s: 0.0,
                rms_log_error: 0.0,
            },
            static_gain: 1.117,
        }
    }

    #[test]
    fn a_gauge_too_noisy_for_the_touch_downs_contact_test_is_refused_with_the_numbers() {
        // 0.493 g of noise a reading: contact at 2.8 deviations, 1.380 g. Pressing the finger
        // to it and a deviation more through the push's middle six ticks (shape ≥ ½) with
        // 0.197 g of stiction holding: 2·((1.380 + 0.493)/1.117 − 0.197) = 2.960 g, whose
        // momentum needs 0.07 × 2.960 = 0.207 g of stiction. The old push, 1.46 g, never
        // pressed six readings of eight to 1.38 g: the probe pulsed on the finger for 2 s.
        match touch_down(&[light_load()], 0.197, 0.493) {
            Err(
                e @ DesignError::NoisyContact {
                    push_g, least_g, ..
                },
            ) => {
                assert!((push_g - 2.960).abs() < 2e-3, "{e}");
                assert!((least_g - 0.2072).abs() < 2e-4, "{e}");
                assert!(e.to_string().contains("1.38 g"), "{e}");
            }
            other => panic!("{other:?}"),
        }
        // A gauge half as noisy: contact at 0.70 g, the push 2·((0.70 + 0.25)/1.117 − 0.197)
        // = 1.307 g, which the stiction stops.
        let (push_g, contact_g) = touch_down(&[light_load()], 0.197, 0.25).unwrap();
        assert!((contact_g - 0.70).abs() < 1e-6 && (push_g - 1.307).abs() < 2e-3);
        // The memo's gauge and stiction: the push the momentum sets, as before,
        // 2 × 0.5 g/(2π·16 Hz·10 ms)/1.117 = 0.890 g.
        let (push_g, _) = touch_down(&[light_load()], 0.9, 0.14).unwrap();
        let momentum_g = 1.0 / (2.0 * std::f64::consts::PI * 16.0 * 0.01) / 1.117;
        assert!((f64::from(push_g) - momentum_g).abs() < 1e-4, "{push_g}");
    }
}
