//! Rate-independent hysteresis as Prandtl–Ishlinskii play operators on the force, and its
//! compensation in front of a force estimator.
//!
//! A loop adds to the strain `Σ wᵢ (Pᵣᵢ(σ) − σ)`: each play `Pᵣ` follows the force once it has
//! moved `r` away, so each term stays within `±wᵢ rᵢ` (the stop form: the part of a play that
//! is proportional to the force belongs to the elastic spring). The diagnosis fits the plays'
//! weights (`tactile diagnose`); the simulated finger's hysteresis is of this form too.
//!
//! On the chip the loop is undone causally by taking its strain off before the estimator, with
//! the plays driven by the force that estimator gave last: one update late, and bounded by
//! `Σ |wᵢ| rᵢ` whatever the estimate does, so it cannot run away.
//!
//! ```
//! use tactile_core::hysteresis::{LoopCompensator, Plays};
//!
//! // A spring of 4 g/% with one play of 2 g radius weighing 0.05 %/g.
//! let plays = Plays::new(&[(2.0, 0.05)]).unwrap();
//! let elastic = |strain_pct: f32| 4.0 * strain_pct;
//! let mut comp = LoopCompensator::new(plays);
//! // Loaded to 10 g, the play trails the force by its radius: the strain is 10/4 − 0.05·2.
//! let strain = 10.0 / 4.0 - 0.05 * 2.0;
//! let mut force = 0.0;
//! for _ in 0..20 {
//!     force = comp.force_g(elastic, strain);
//! }
//! assert!((force - 10.0).abs() < 0.05, "{force}");
//! ```

use crate::lti::Real;

/// Plays a calibration can carry (the diagnosis's basis).
pub const PLAYS: usize = 5;

/// One play operator's step: the output `out` follows `input` only once the input has moved
/// `radius` away from it.
#[inline]
pub fn play<T: Real>(out: T, input: T, radius: T) -> T {
    let (lo, hi) = (input - radius, input + radius);
    if out < lo {
        lo
    } else if out > hi {
        hi
    } else {
        out
    }
}

/// Why a set of plays was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PlaysError {
    #[error("more than {PLAYS} plays")]
    TooMany,
    /// A radius that is negative or not finite, or a weight that is not finite.
    #[error("play {index}: a radius below zero or a value that is not finite")]
    BadPlay { index: u8 },
}

/// Weighted plays in stop form (weight 0: an unused slot).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Plays {
    pub radius_g: [f32; PLAYS],
    pub weight_pct_per_g: [f32; PLAYS],
}

impl Plays {
    /// From (radius g, weight %/g) pairs.
    pub fn new(plays: &[(f32, f32)]) -> Result<Self, PlaysError> {
        if plays.len() > PLAYS {
            return Err(PlaysError::TooMany);
        }
        let mut p = Plays::default();
        for ((r, w), &pair) in p
            .radius_g
            .iter_mut()
            .zip(p.weight_pct_per_g.iter_mut())
            .zip(plays)
        {
            (*r, *w) = pair;
        }
        p.check().map(|()| p)
    }

    /// Checks stored plays (a table's): finite, radii not negative.
    pub fn check(&self) -> Result<(), PlaysError> {
        for (k, (r, w)) in self.radius_g.iter().zip(&self.weight_pct_per_g).enumerate() {
            if !(r.is_finite() && *r >= 0.0 && w.is_finite()) {
                return Err(PlaysError::BadPlay { index: k as u8 });
            }
        }
        Ok(())
    }

    /// No loop.
    pub fn is_empty(&self) -> bool {
        self.weight_pct_per_g.iter().all(|w| *w == 0.0)
    }

    /// The loop's largest strain, % (`Σ |wᵢ| rᵢ`).
    pub fn bound_pct(&self) -> f32 {
        self.radius_g
            .iter()
            .zip(&self.weight_pct_per_g)
            .map(|(r, w)| r * w.abs())
            .sum()
    }

    /// The loop's strain after the force has moved to `force_g`, %; advances the plays' outputs
    /// `out_g`.
    #[inline]
    pub fn loop_pct(&self, out_g: &mut [f32; PLAYS], force_g: f32) -> f32 {
        let mut e = 0.0;
        for ((y, r), w) in out_g
            .iter_mut()
            .zip(&self.radius_g)
            .zip(&self.weight_pct_per_g)
        {
            *y = play(*y, force_g, *r);
            e += w * (*y - force_g);
        }
        e
    }
}

/// A loop's strain taken off an estimator's input, the plays driven by that estimator's last
/// force (the estimator passed in: this loop wraps any of them).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoopCompensator {
    plays: Plays,
    out_g: [f32; PLAYS],
    loop_pct: f32,
}

impl LoopCompensator {
    pub fn new(plays: Plays) -> Self {
        Self {
            plays,
            ..Default::default()
        }
    }

    /// Force from the latest strain through `estimate` (an estimator's update: strain in,
    /// force out), the loop's strain taken off first.
    #[inline]
    pub fn force_g(&mut self, estimate: impl FnOnce(f32) -> f32, strain_pct: f32) -> f32 {
        if self.plays.is_empty() {
            return estimate(strain_pct);
        }
        let force = estimate(strain_pct - self.loop_pct);
        // A force that is not a number leaves the plays where they were.
        if force.is_finite() {
            self.loop_pct = self.plays.loop_pct(&mut self.out_g, force);
        }
        force
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimator::TaxelEstimator;

    #[test]
    fn a_play_follows_by_hand() {
        // Input 0, 1, 3, 2.5, 1, 0 through a play of radius 1 starting at 0.
        let mut y = 0.0f64;
        let out: Vec<f64> = [0.0, 1.0, 3.0, 2.5, 1.0, 0.0]
            .iter()
            .map(|&x| {
                y = play(y, x, 1.0);
                y
            })
            .collect();
        assert_eq!(out, [0.0, 0.0, 2.0, 2.0, 2.0, 1.0]);
    }

    #[test]
    fn bad_plays_are_refused() {
        assert_eq!(
            Plays::new(&[(1.0, 0.1), (-1.0, 0.1)]),
            Err(PlaysError::BadPlay { index: 1 })
        );
        assert_eq!(
            Plays::new(&[(1.0, f32::NAN)]),
            Err(PlaysError::BadPlay { index: 0 })
        );
        assert_eq!(Plays::new(&[(1.0, 0.1); 6]), Err(PlaysError::TooMany));
        assert!(Plays::default().is_empty());
        let p = Plays::new(&[(2.0, 0.1), (10.0, -0.02)]).unwrap();
        assert!((p.bound_pct() - 0.4).abs() < 1e-6);
        assert!(p.check().is_ok());
    }

    /// An elastic finger with a loop of three plays (the simulator's form), loaded up and down
    /// in ramps: the compensated estimate follows the force within the one update it lags;
    /// the elastic estimate alone misses by the loop's half-width.
    #[test]
    fn the_loop_is_taken_off_an_elastic_estimate() {
        let g = 4.0f32;
        let plays = Plays::new(&[(2.0, 0.02), (5.0, 0.02), (10.0, 0.02)]).unwrap();
        let force: Vec<f32> = (0..4000)
            .map(|i| {
                let t = (i % 1000) as f32 / 1000.0;
                // 0 → 60 g → 0 in 1000 updates.
                60.0 * (1.0 - (2.0 * t - 1.0).abs())
            })
            .collect();
        let mut out = [0.0; PLAYS];
        let strain: Vec<f32> = force
            .iter()
            .map(|&f| f / g + plays.loop_pct(&mut out, f))
            .collect();
        let rms = |comp: Option<LoopCompensator>| {
            let mut est = TaxelEstimator::Elastic { g_per_pct: g };
            let mut comp = comp;
            let sum: f32 = strain
                .iter()
                .zip(&force)
                .map(|(&e, &f)| {
                    let x = match &mut comp {
                        Some(c) => c.force_g(|s| est.force_g(s), e),
                        None => est.force_g(e),
                    };
                    (x - f).powi(2)
                })
                .sum();
            (sum / force.len() as f32).sqrt()
        };
        let (with, without) = (rms(Some(LoopCompensator::new(plays))), rms(None));
        // The loop's half-width through the spring: 4·(0.02·(2 + 5 + 10)) = 1.36 g while the
        // plays trail; the compensated error is what one update's move of 0.12 g leaves.
        assert!(without > 1.0, "{without}");
        assert!(with < 0.1, "{with}");
    }
}
