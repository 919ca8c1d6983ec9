//! A force estimator fitted for force: a fixed bank of the strain's own terms — a spring
//! curve as hinges, relaxation as first-order lowpasses over a log-spaced grid, a loop as
//! plays — weighted to give the force, with a zero that re-settles wherever the sensor rests.
//!
//! The models of the other estimators are fitted to predict strain from force and then
//! inverted; on a measured skin (noise, a lag nobody modelled, a static curve far from the
//! memo's) the inverse of a good forward model is not a good force estimate. This one is fitted
//! in the direction it is used (`tactile_ident::force_fit`), on the same terms the diagnosis
//! names, and outside the loads it saw it continues by its last slope (hinges, not powers).
//!
//! ```
//! use tactile_core::estimator::{BankModel, ForceBank};
//!
//! // A 4 g/% spring: the bank's elastic form.
//! let mut bank = ForceBank::new(&BankModel::elastic(4.0), 0.01).unwrap();
//! assert!((bank.force_g(2.5) - 10.0).abs() < 1e-5);
//! ```
//!
//! The update costs a fixed [`BANK_FEATURES`] multiply-adds, [`BANK_FILTERS`] lowpasses and
//! [`BANK_PLAYS`] plays per sample: no allocation, no panic.

use core::ops::Range;

use crate::hysteresis::play;
use crate::lti::{ModelError, ModelParameter};

/// Lowpasses of the strain (relaxation) a bank holds.
pub const BANK_FILTERS: usize = 8;
/// Hinges of the static curve.
pub const BANK_KNOTS: usize = 3;
/// Plays of the strain (a loop).
pub const BANK_PLAYS: usize = 3;
/// Weights: the bias, the strain, the hinges, the lowpasses, the plays.
pub const BANK_FEATURES: usize = 2 + BANK_KNOTS + BANK_FILTERS + BANK_PLAYS;
/// Where each kind of term sits among the weights (the bias at 0, the strain at 1).
pub const HINGE_TERMS: Range<usize> = 2..2 + BANK_KNOTS;
pub const LOWPASS_TERMS: Range<usize> = HINGE_TERMS.end..HINGE_TERMS.end + BANK_FILTERS;
pub const PLAY_TERMS: Range<usize> = LOWPASS_TERMS.end..BANK_FEATURES;
/// The start-up zero's band, in re-zero bounds: a bank whose first estimate is within this many
/// bounds of zero takes it as its zero (a scale's initial zero-setting, up to a fifth of its
/// range, beside a zero tracking within a twentieth).
pub const STARTUP_ZERO_BOUNDS: f32 = 4.0;
/// Time constant of the strain's short average the re-zero calls quiet against, s.
pub const QUIET_TAU_S: f32 = 0.1;

/// Where the sensor is taken to rest, and how fast its zero follows there.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rezero {
    /// The estimate below which the sensor may be unloaded, g (0: no re-zero).
    pub below_g: f32,
    /// How far the strain may stray from its short average and still be at rest, in the
    /// bank's strain units.
    pub quiet: f32,
    /// Time constant of the zero's move while at rest, s.
    pub tau_s: f32,
}

impl Rezero {
    pub const OFF: Rezero = Rezero {
        below_g: 0.0,
        quiet: 0.0,
        tau_s: 1.0,
    };

    pub fn is_on(&self) -> bool {
        self.below_g > 0.0
    }
}

/// A bank's configuration, as the calibration table stores it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BankModel {
    /// The strain that is one unit of the bank's input, % (about the calibration's range).
    pub strain_scale_pct: f32,
    /// The lowpasses' time constants, s.
    pub tau_s: [f32; BANK_FILTERS],
    /// The hinges' corners, in strain units.
    pub knots: [f32; BANK_KNOTS],
    /// The plays' radii, in strain units.
    pub play_radius: [f32; BANK_PLAYS],
    /// Force per term, g, in [`ForceBank::step`]'s order.
    pub weights_g: [f32; BANK_FEATURES],
    pub rezero: Rezero,
}

impl BankModel {
    /// σ = G ε: a spring of `g_per_pct` and nothing else (a taxel with no bank fitted).
    pub fn elastic(g_per_pct: f64) -> BankModel {
        let mut weights_g = [0.0; BANK_FEATURES];
        if let Some(w) = weights_g.get_mut(1) {
            *w = g_per_pct as f32;
        }
        BankModel {
            strain_scale_pct: 1.0,
            tau_s: [1.0; BANK_FILTERS],
            knots: [1.0; BANK_KNOTS],
            play_radius: [0.0; BANK_PLAYS],
            weights_g,
            rezero: Rezero::OFF,
        }
    }

    /// Every value in range: finite, scale and time constants positive, radii not negative.
    pub fn check(&self) -> Result<(), ModelError> {
        let r = &self.rezero;
        let finite = [self.strain_scale_pct]
            .iter()
            .chain(&self.tau_s)
            .chain(&self.knots)
            .chain(&self.play_radius)
            .chain(&self.weights_g)
            .chain([&r.below_g, &r.quiet, &r.tau_s])
            .all(|v| v.is_finite());
        let positive = self.strain_scale_pct > 0.0
            && self.tau_s.iter().all(|t| *t > 0.0)
            && self.play_radius.iter().all(|p| *p >= 0.0)
            && r.below_g >= 0.0
            && r.quiet >= 0.0
            && r.tau_s > 0.0;
        if finite && positive {
            Ok(())
        } else {
            Err(ModelError::InvalidParameter {
                name: ModelParameter::Bank,
            })
        }
    }

    /// Whether any of the terms in `terms` (one of [`HINGE_TERMS`], [`LOWPASS_TERMS`],
    /// [`PLAY_TERMS`]) weighs anything.
    pub fn uses(&self, terms: Range<usize>) -> bool {
        self.weights_g
            .get(terms)
            .is_some_and(|w| w.iter().any(|w| *w != 0.0))
    }
}

/// A bank running at one sample period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceBank {
    model: BankModel,
    phi: [f32; BANK_FILTERS],
    quiet_phi: f32,
    /// The share of the estimate at rest the zero takes per sample (0: no re-zero).
    rezero_share: f32,
    lowpass: [f32; BANK_FILTERS],
    plays: [f32; BANK_PLAYS],
    average: f32,
    /// The estimate's zero, g: taken off the weighed terms, so that it moves outside the
    /// bank's dynamics (a step of the zero is a step of the estimate, whatever the weights).
    zero_g: f32,
    started: bool,
}

impl ForceBank {
    pub fn new(model: &BankModel, dt_s: f64) -> Result<Self, ModelError> {
        model.check()?;
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(ModelError::InvalidParameter {
                name: ModelParameter::Bank,
            });
        }
        let decay = |tau_s: f32| libm::exp(-dt_s / f64::from(tau_s)) as f32;
        let rezero_share = if model.rezero.is_on() {
            1.0 - decay(model.rezero.tau_s)
        } else {
            0.0
        };
        Ok(Self {
            model: *model,
            phi: model.tau_s.map(decay),
            quiet_phi: decay(QUIET_TAU_S),
            rezero_share,
            lowpass: [0.0; BANK_FILTERS],
            plays: [0.0; BANK_PLAYS],
            average: 0.0,
            zero_g: 0.0,
            started: false,
        })
    }

    /// The terms of the latest strain, in the weights' order (advances the lowpasses and
    /// plays; the first sample starts them settled there).
    #[inline]
    fn advance(&mut self, strain_pct: f32) -> [f32; BANK_FEATURES] {
        let u = strain_pct / self.model.strain_scale_pct;
        if !self.started {
            self.lowpass = [u; BANK_FILTERS];
            self.plays = [u; BANK_PLAYS];
            self.average = u;
            self.started = true;
        }
        let mut f = [0.0; BANK_FEATURES];
        let (head, rest) = f.split_at_mut(HINGE_TERMS.start);
        let (hinges, rest) = rest.split_at_mut(BANK_KNOTS);
        let (lowpasses, plays) = rest.split_at_mut(BANK_FILTERS);
        // The constant and the input (no `copy_from_slice`: its length check is a panic path).
        if let [one, input] = head {
            (*one, *input) = (1.0, u);
        }
        for (h, k) in hinges.iter_mut().zip(&self.model.knots) {
            *h = (u - k).max(0.0);
        }
        for ((out, x), phi) in lowpasses.iter_mut().zip(&mut self.lowpass).zip(&self.phi) {
            *x = phi * *x + (1.0 - phi) * u;
            *out = *x;
        }
        for ((out, y), r) in plays
            .iter_mut()
            .zip(&mut self.plays)
            .zip(&self.model.play_radius)
        {
            *y = play(*y, u, *r);
            *out = *y;
        }
        self.average = self.quiet_phi * self.average + (1.0 - self.quiet_phi) * u;
        f
    }

    /// The weighted sum of `features`, g (not clamped).
    #[inline]
    fn weigh(&self, features: &[f32; BANK_FEATURES]) -> f32 {
        features
            .iter()
            .zip(&self.model.weights_g)
            .map(|(f, w)| f * w)
            .sum()
    }

    /// Moves the zero by the estimate `force_g` of a sample at rest: the estimate is below the
    /// re-zero's bound and the strain within its quiet band of its short average.
    #[inline]
    fn settle_zero(&mut self, force_g: f32, features: &[f32; BANK_FEATURES]) {
        let r = &self.model.rezero;
        let u = features.get(1).copied().unwrap_or(f32::NAN);
        if self.rezero_share > 0.0 && force_g < r.below_g && (u - self.average).abs() <= r.quiet {
            self.zero_g += self.rezero_share * force_g;
        }
    }

    /// One sample of strain (the calibration's offset already removed): its terms in the
    /// weights' order and the force they weigh, not clamped; the zero settled after it. A
    /// force that is not finite starts the bank over (the fit computes its terms this way too).
    #[inline]
    pub fn step(&mut self, strain_pct: f32) -> ([f32; BANK_FEATURES], f32) {
        let starting = !self.started;
        let features = self.advance(strain_pct);
        let mut force = self.weigh(&features) - self.zero_g;
        if starting
            && self.rezero_share > 0.0
            && force.abs() < STARTUP_ZERO_BOUNDS * self.model.rezero.below_g
        {
            // A first sample within the start-up band is the zero.
            self.zero_g += force;
            force = 0.0;
        }
        if force.is_finite() {
            self.settle_zero(force, &features);
        } else {
            *self = Self {
                started: false,
                zero_g: 0.0,
                ..*self
            };
        }
        (features, force)
    }

    /// Force from the latest strain (the calibration's offset already removed), clamped at
    /// zero; a strain that is not finite leaves the state where it was and gives none.
    #[inline]
    pub fn force_g(&mut self, strain_pct: f32) -> f32 {
        if !strain_pct.is_finite() {
            return 0.0;
        }
        let (_, force) = self.step(strain_pct);
        if force.is_finite() {
            force.max(0.0)
        } else {
            0.0
        }
    }

    /// The zero the re-zero has found, g (0 without re-zero): the estimate is the weighed
    /// terms less it.
    pub fn zero_g(&self) -> f32 {
        self.zero_g
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A spring of 10 g/% that re-zeroes below 8 g, its zero following with `tau_s`.
    fn rezeroing_spring(tau_s: f32) -> BankModel {
        let mut m = BankModel::elastic(10.0);
        m.rezero = Rezero {
            below_g: 8.0,
            quiet: 0.05,
            tau_s,
        };
        m
    }

    #[test]
    fn a_lowpass_term_follows_a_step_by_its_time_constant() {
        // One lowpass of τ = 1 s at 10 ms, weight 10 g: after a unit step at rest, the term
        // is 1 − e^(−t/τ) by hand; at t = 1 s, 6.32 g.
        let mut m = BankModel::elastic(0.0);
        m.weights_g[LOWPASS_TERMS.start] = 10.0;
        let mut bank = ForceBank::new(&m, 0.01).unwrap();
        assert_eq!(bank.force_g(0.0), 0.0);
        let mut f = 0.0;
        for _ in 0..100 {
            f = bank.force_g(1.0);
        }
        assert!((f - 6.321).abs() < 0.01, "{f}");
    }

    #[test]
    fn hinges_continue_by_their_slope_and_plays_hold_by_their_radius() {
        let mut m = BankModel::elastic(2.0);
        m.knots = [1.0, 5.0, 5.0];
        m.weights_g[HINGE_TERMS.start] = 3.0;
        let mut bank = ForceBank::new(&m, 0.01).unwrap();
        // 2·3 + 3·(3 − 1) = 12 g; far beyond: linear, 2·10 + 3·9 = 47 g.
        assert!((bank.force_g(3.0) - 12.0).abs() < 1e-5);
        assert!((bank.force_g(10.0) - 47.0).abs() < 1e-4);
        let mut p = BankModel::elastic(0.0);
        p.play_radius[0] = 0.5;
        p.weights_g[PLAY_TERMS.start] = 1.0;
        let mut bank = ForceBank::new(&p, 0.01).unwrap();
        // 0 → 2 → 1.8: the play trails by 0.5 on the way up and holds on the way down.
        let out: Vec<f32> = [0.0, 2.0, 1.8].iter().map(|e| bank.force_g(*e)).collect();
        assert_eq!(out, [0.0, 1.5, 1.5]);
    }

    #[test]
    fn the_zero_settles_at_rest_and_not_under_load() {
        // A spring of 10 g/% whose zero has moved by +0.5 %: at rest the estimate reads 5 g
        // until the re-zero has taken it off (τ = 0.5 s: e^(−10) left after 5 s); a load of
        // 50 g is read above the bound and leaves the zero alone.
        let m = rezeroing_spring(0.5);
        let mut bank = ForceBank::new(&m, 0.01).unwrap();
        assert_eq!(bank.force_g(0.0), 0.0);
        let first = bank.force_g(0.5);
        assert!((first - 5.0).abs() < 1e-5);
        for _ in 0..500 {
            bank.force_g(0.5);
        }
        assert!(bank.force_g(0.5) < 0.01);
        assert!((bank.zero_g() - 5.0).abs() < 1e-2, "{}", bank.zero_g());
        for _ in 0..200 {
            bank.force_g(5.5);
        }
        assert!((bank.force_g(5.5) - 50.0).abs() < 0.01);
        assert!((bank.zero_g() - 5.0).abs() < 1e-2);
        // Without the re-zero the offset stays in the estimate.
        let mut plain = ForceBank::new(&BankModel::elastic(10.0), 0.01).unwrap();
        for _ in 0..500 {
            plain.force_g(0.5);
        }
        assert!((plain.force_g(0.5) - 5.0).abs() < 1e-4);
    }

    #[test]
    fn a_zero_within_the_start_up_band_is_taken_at_the_first_sample() {
        // The same spring and bound (8 g: a band of 32 g at start-up). Started at a strain of
        // 2 % (20 g), the bank takes it as its zero and reads a later 50 g press as 50 g;
        // started under 4 % (40 g) it reads 40 g. Without a re-zero there is no start-up zero.
        let m = rezeroing_spring(1.0);
        let mut drifted = ForceBank::new(&m, 0.01).unwrap();
        assert!(drifted.force_g(2.0).abs() < 1e-5);
        assert!((drifted.zero_g() - 20.0).abs() < 1e-5);
        assert!((drifted.force_g(7.0) - 50.0).abs() < 1e-4);
        let mut loaded = ForceBank::new(&m, 0.01).unwrap();
        assert!((loaded.force_g(4.0) - 40.0).abs() < 1e-4);
        assert_eq!(loaded.zero_g(), 0.0);
        let mut plain = ForceBank::new(&BankModel::elastic(10.0), 0.01).unwrap();
        assert!((plain.force_g(2.0) - 20.0).abs() < 1e-5);
    }

    #[test]
    fn bad_models_and_samples_are_refused_not_run() {
        let mut m = BankModel::elastic(4.0);
        m.tau_s[3] = 0.0;
        assert!(ForceBank::new(&m, 0.01).is_err());
        let mut m = BankModel::elastic(4.0);
        m.weights_g[4] = f32::NAN;
        assert_eq!(
            m.check(),
            Err(ModelError::InvalidParameter {
                name: ModelParameter::Bank
            })
        );
        assert!(ForceBank::new(&BankModel::elastic(4.0), f64::NAN).is_err());
        let mut bank = ForceBank::new(&BankModel::elastic(4.0), 0.01).unwrap();
        assert_eq!(bank.force_g(f32::NAN), 0.0);
        assert!((bank.force_g(1.0) - 4.0).abs() < 1e-6);
        assert_eq!(bank.force_g(f32::INFINITY), 0.0);
        assert_eq!(bank.force_g(-1.0), 0.0);
    }
}
