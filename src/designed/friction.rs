//! The friction compensation's adaptation at the reference's reversals.

use super::{
    DesignedConfig, ADAPT_GAIN, ADAPT_MOTION_SHARE, ADAPT_RANGE, ADAPT_STEP_SHARE,
    ADAPT_SWING_SHARE,
};

/// The friction compensation's size, learned at the reference's reversals.
///
/// A force sine of a few grams about a light load moves the motor against a stiction of about
/// a gram, and what the loop's force does there rests on the compensation alone (the feedback
/// the margins allow is slow): 10 % short of the heavy rig's stiction left a 2 g sine 8 dB
/// short at 25 Hz, 20 % over rang the memo rig's +3.7 dB. No identification reads the
/// stiction that closely, so the loop measures it: after a reversal the compensation steps by
/// twice its size, and if that is short of the friction's own step the motor sticks and the
/// force falls behind the reference in the new direction; if over, it runs ahead. Over the
/// first half period of the lightest mode, where the plant's response to a step of drive is
/// one-signed, the error's change in the new direction, weighted by that response (a
/// smoothstep, the shape of 1 − cos), estimates the shortfall in grams of force (the
/// least-squares fit of the weighted step to the error); the compensation moves by
/// [`ADAPT_GAIN`] of it, by at most [`ADAPT_STEP_SHARE`] of the identified stiction per
/// reversal, within [`ADAPT_RANGE`]. It learns only from a sine slower than that mode (the
/// last half cycle at least the window): above the mode the last reversal's response turns
/// sign within the window, and learning there drove two of eight unseen rigs 6–9 dB off at
/// 40 Hz. Steps, holds and swings of many stictions (the feed-forward's and the feedback's
/// work, where the compensation's size hardly shows) leave it alone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct FrictionAdapt {
    /// The compensated friction, g.
    pub(super) friction_g: f32,
    /// The window after the last reversal: its length and the ticks into it (none: `length`
    /// 0), the new direction, and the sums of weight × error and weight².
    pub(super) length: u8,
    pub(super) tick: u8,
    pub(super) direction: f32,
    /// The reference at the last reversal, g, and the ticks since.
    pub(super) last_reversal_g: f32,
    pub(super) since_reversal: u16,
    /// The error and the reference at the reversal, g: what the window weighs is their
    /// change from it.
    pub(super) start_error_g: f32,
    pub(super) start_reference_g: f32,
    pub(super) weighted_error: f32,
    pub(super) weighted_motion: f32,
    pub(super) weights: f32,
}

impl FrictionAdapt {
    pub(super) fn new(friction_g: f32) -> Self {
        Self {
            friction_g,
            length: 0,
            tick: 0,
            direction: 0.0,
            last_reversal_g: f32::NAN,
            since_reversal: 0,
            start_error_g: 0.0,
            start_reference_g: 0.0,
            weighted_error: 0.0,
            weighted_motion: 0.0,
            weights: 0.0,
        }
    }

    /// A reversal into `direction` at `reference_g`; the window is half the period of the
    /// mode of the inverse `c` (c₀ + c₂s² ≈ 0), in ticks, and opens where the last half cycle
    /// was as long and its swing within [`ADAPT_SWING_SHARE`] stictions.
    pub(super) fn reversal(
        &mut self,
        direction: f32,
        reference_g: f32,
        c: &[f32; 4],
        config: &DesignedConfig,
    ) {
        let [c0, _, c2, _] = *c;
        let half_period_s = if c0 > 0.0 && c2 > 0.0 {
            core::f32::consts::PI * crate::trig::sqrtf(c2 / c0)
        } else {
            0.0
        };
        let swing_g = libm::fabsf(reference_g - self.last_reversal_g);
        let small = swing_g <= ADAPT_SWING_SHARE * config.friction_g;
        let mode_ticks = half_period_s / config.dt_s;
        *self = Self {
            length: if small && f32::from(self.since_reversal) >= mode_ticks {
                crate::limit(mode_ticks, 0.0, 40.0) as u8
            } else {
                0
            },
            direction,
            last_reversal_g: reference_g,
            ..Self::new(self.friction_g)
        };
    }

    /// The window's next error (reference less reading, g) and reference (the one the
    /// reading is compared with); at its end the compensation moves.
    pub(super) fn observe(
        &mut self,
        error_g: f32,
        reference_g: f32,
        config: &DesignedConfig,
        c0: f32,
    ) {
        self.since_reversal = self.since_reversal.saturating_add(1);
        if self.tick >= self.length {
            return;
        }
        if self.tick == 0 {
            self.start_error_g = error_g;
            self.start_reference_g = reference_g;
        }
        self.tick += 1;
        let u = f32::from(self.tick) / f32::from(self.length);
        let weight = u * u * (3.0 - 2.0 * u);
        self.weighted_error += weight * (error_g - self.start_error_g) * self.direction;
        self.weighted_motion += weight * (reference_g - self.start_reference_g) * self.direction;
        self.weights += weight * weight;
        if self.tick == self.length {
            self.finish(config, c0);
        }
    }

    /// The window's estimate taken: where the reference moved by at least
    /// [`ADAPT_MOTION_SHARE`] of the stiction over it (the weighted mean); a slow sine's
    /// reversal is the integral's.
    pub(super) fn finish(&mut self, config: &DesignedConfig, c0: f32) {
        let moved = self.weighted_motion >= ADAPT_MOTION_SHARE * config.friction_g * self.weights;
        if self.weights > 0.0 && moved {
            let most = ADAPT_STEP_SHARE * config.friction_g;
            let step = crate::limit(
                ADAPT_GAIN * c0 * self.weighted_error / self.weights,
                -most,
                most,
            );
            self.friction_g = crate::limit(
                self.friction_g + step,
                ADAPT_RANGE.0 * config.friction_g,
                ADAPT_RANGE.1 * config.friction_g,
            );
        }
        self.cancel();
    }

    /// No window open (a restart: what follows is not a reversal's response).
    pub(super) fn cancel(&mut self) {
        self.length = 0;
        self.tick = 0;
        self.weights = 0.0;
    }
}
