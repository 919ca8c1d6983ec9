//! The models the design is built on: one per preload, whether a fit is one an applicator
//! gives, the loads that share one amplifier, and the models extrapolated past the identified
//! loads.

use serde::Serialize;

use crate::applicator_model::ApplicatorModel;

/// The identified model at one preload.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct LoadModel {
    pub load_g: f32,
    pub model: ApplicatorModel,
    /// Gauge grams per drive gram of the still holds before the chirps, or of the chirps' means
    /// ([`crate::applicator_model::static_line`]): the feed-forward's static gain.
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
    let (lo, hi) = crate::applicator_model::STATIC_GAIN_RANGE;
    if !(lo..hi).contains(&m.gain) {
        Some("its gain is not within 0.2–5")
    } else if !above(0.7, a.damping_ratio) {
        Some("its inertia–finger mode is damped past ζ 0.7")
    } else if !above(a.damping_ratio, LEAST_FINGER_DAMPING) {
        Some("its inertia–finger mode is undamped (the friction simulated took all its damping)")
    } else if !above(a.hz, 5.0) {
        Some("its inertia–finger mode is under 5 Hz")
    } else if !(above(b.hz, a.hz) && above(m.anti_resonance.hz, a.hz)) {
        Some("its anti-resonance or beam mode is under the inertia–finger mode")
    } else if !(POLE_RANGE_HZ.0..=POLE_RANGE_HZ.1).contains(&m.pole_hz) {
        Some("its amplifier's pole is not within 20–500 Hz")
    } else if !above(3e-3, m.delay_s.abs()) {
        Some("its delay is over 3 ms either way")
    } else {
        None
    }
}

/// The least damping ratio of the inertia–finger mode a fit may read: the rubber under the
/// probe is lossy and the motor has viscous friction (a rig of loss factor 0.24 and 2.6 times
/// the memo's viscous friction, linearized: ζ 0.03 at every load). Where the stiction is as
/// large as the chirp (1.5–4 g), the fit with the friction simulated read one load's ζ 0.00
/// between loads of 0.01–0.07, and the margins on that mode allowed an integral gain of 0.6/s
/// (or none: the design refused); that load left out, 38/s.
pub const LEAST_FINGER_DAMPING: f64 = 0.005;

/// Where an applicator's amplifier has its pole, Hz. A fit that puts it above is refitted with
/// it held at the top ([`super::identified_from`]): the chirp ends at 301 Hz, and past the
/// loop's band a pole shows as a little phase the record cannot place.
pub const POLE_RANGE_HZ: (f64, f64) = (20.0, 500.0);

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
pub(super) fn upper_median(mut values: Vec<f64>) -> Option<f64> {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied()
}

/// The median: the middle value, the mean of the two for an even count (`None` for none).
pub(super) fn median(mut values: Vec<f64>) -> Option<f64> {
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
