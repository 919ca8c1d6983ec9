//! The gain-scheduled PD force law of memo eq. A1.
//!
//! ```text
//! e(k+1)   = f_c(k+1) − f_s(k)
//! f_a(k+1) = f_c(k+1) + (K_e f_c(k+1) / 100) (K_p e(k+1) + K_d (e(k+1) − e(k)) / Δt)
//! ```
//!
//! The feedback gains scale with the command (zero at 0 g, nominal at 100 g): a fixed-gain PD
//! loop lost contact with the finger and went unstable for commands below about 10 g, and the
//! schedule is how the memo fixed it. [`GainSchedule::Fixed`] keeps the failing law available for
//! the simulator's `low-force` experiment.

/// How the feedback gain follows the command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GainSchedule {
    /// Memo eq. A1: gains multiplied by `K_e f_c / reference_g` (reference 100 g).
    Proportional { reference_g: f32 },
    /// The gains frozen at their value for `command_g` (the fixed-gain PD loop that failed).
    Fixed { command_g: f32 },
}

/// Gains, sample period and actuator range of the law (memo values by default).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceLawConfig {
    pub kp: f32,
    /// Derivative gain in seconds (error difference divided by Δt).
    pub kd_s: f32,
    pub ke: f32,
    pub dt_s: f32,
    pub schedule: GainSchedule,
    /// Actuator range for the adjusted command f_a, in grams at the probe. The memo's
    /// amplifier gives 19.2 g per volt, so a ±10 V drive is ±192 g.
    pub adjusted_min_g: f32,
    pub adjusted_max_g: f32,
}

impl ForceLawConfig {
    pub const MEMO: ForceLawConfig = ForceLawConfig {
        kp: 2.0,
        kd_s: 0.03,
        ke: 1.0,
        dt_s: crate::CONTROL_PERIOD_S as f32,
        schedule: GainSchedule::Proportional { reference_g: 100.0 },
        adjusted_min_g: -192.0,
        adjusted_max_g: 192.0,
    };

    /// The feedback multiplier `K_e f_c / 100` (or its frozen value).
    #[inline]
    pub fn gain_scale(&self, command_g: f32) -> f32 {
        match self.schedule {
            GainSchedule::Proportional { reference_g } => self.ke * command_g / reference_g,
            GainSchedule::Fixed { command_g: frozen } => self.ke * frozen / 100.0,
        }
    }
}

/// Output of one tick of the law.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adjusted {
    /// f_a, saturated to the actuator's range.
    pub force_g: f32,
    /// The unsaturated value was outside the actuator's range.
    pub saturated: bool,
    /// An input was NaN or infinite; the output is the safe value 0 g.
    pub invalid_input: bool,
}

/// State of the law: the previous error e(k).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceLaw {
    pub config: ForceLawConfig,
    previous_error_g: f32,
}

impl ForceLaw {
    pub fn new(config: ForceLawConfig) -> Self {
        Self {
            config,
            previous_error_g: 0.0,
        }
    }

    /// The error e(k) kept from the previous tick (0 after a reset, as in the memo's recursion).
    pub fn previous_error_g(&self) -> f32 {
        self.previous_error_g
    }

    pub fn reset(&mut self) {
        self.previous_error_g = 0.0;
    }

    /// One tick: `command_g` is f_c(k+1), `sensed_g` the gauge force f_s(k) of the last tick.
    #[inline]
    pub fn update(&mut self, command_g: f32, sensed_g: f32, feedback: bool) -> Adjusted {
        if !command_g.is_finite() || !sensed_g.is_finite() {
            return Adjusted {
                force_g: 0.0,
                saturated: false,
                invalid_input: true,
            };
        }
        let c = &self.config;
        let error_g = command_g - sensed_g;
        let derivative = c.kd_s * (error_g - self.previous_error_g) / c.dt_s;
        self.previous_error_g = error_g;
        // Off, the error is still followed (no derivative kick when it comes back on).
        let gain = if feedback {
            c.gain_scale(command_g)
        } else {
            0.0
        };
        let raw = command_g + gain * (c.kp * error_g + derivative);
        let force_g = crate::limit(raw, c.adjusted_min_g, c.adjusted_max_g);
        Adjusted {
            force_g,
            saturated: force_g != raw,
            invalid_input: false,
        }
    }
}

/// Limits how fast the command fed to the law may change.
///
/// A step of the command releases or stores the finger's elastic energy faster than the
/// lightly damped probe can follow: on unloading the probe rebounds off the finger and on the
/// next load it strikes it. Slewing the command at a rate the mechanics can track (a 30 g step
/// over 60 ms at 500 g/s, two periods of the 50 Hz mode) keeps the probe on the finger; it also
/// keeps A1's derivative term from kicking on every step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlewLimiter {
    pub max_rate_g_per_s: f32,
    pub dt_s: f32,
    last_g: f32,
}

impl SlewLimiter {
    pub const fn new(max_rate_g_per_s: f32, dt_s: f32) -> Self {
        Self {
            max_rate_g_per_s,
            dt_s,
            last_g: 0.0,
        }
    }

    /// Restarts the ramp from `value_g` (where the force actually is); returns it.
    pub fn update_from(&mut self, value_g: f32) -> f32 {
        if value_g.is_finite() {
            self.last_g = value_g;
        }
        self.last_g
    }

    /// The next command, moved toward `target_g` by at most one step of the rate; a
    /// non-finite target holds the last command.
    #[inline]
    pub fn update(&mut self, target_g: f32) -> f32 {
        if target_g.is_finite() {
            let step = self.max_rate_g_per_s * self.dt_s;
            self.last_g += crate::limit(target_g - self.last_g, -step, step);
        }
        self.last_g
    }
}

/// The actuator path: grams at the probe → volts into the current amplifier → DAC code.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ActuatorConfig {
    /// Grams at the probe per volt into the amplifier (memo: 0.19 A/V × 910 g·cm/A / 9 cm = 19.2).
    pub grams_per_volt: f32,
    /// The converter driving the amplifier, in the amplifier's volts (level shifting included).
    pub dac: crate::gauge::AdcScale,
}

impl ActuatorConfig {
    pub const MEMO: ActuatorConfig = ActuatorConfig {
        grams_per_volt: 19.2,
        dac: crate::gauge::AdcScale::BIPOLAR_10V_12BIT,
    };

    /// DAC code for a force; clamps at the converter's range.
    #[inline]
    pub fn code(&self, force_g: f32) -> crate::gauge::AdcCode {
        self.dac.code(force_g / self.grams_per_volt)
    }

    /// The force a DAC code commands, g (what the amplifier is driven with).
    #[inline]
    pub fn force_g(&self, code: crate::gauge::AdcCode) -> f32 {
        self.dac.volts(code) * self.grams_per_volt
    }

    /// The code that puts zero volts into the amplifier (the safe output).
    pub fn zero_code(&self) -> crate::gauge::AdcCode {
        self.dac.code(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_a_hand_computed_sequence() {
        let mut law = ForceLaw::new(ForceLawConfig::MEMO);
        // Tick 1: f_c = 50, f_s = 40 → e = 10, e_prev = 0.
        // f_a = 50 + 0.5 (2·10 + 0.03·(10 − 0)/0.001) = 50 + 0.5 (20 + 300) = 210 → saturated at 192.
        let a = law.update(50.0, 40.0, true);
        assert_eq!(a.force_g, 192.0);
        assert!(a.saturated);
        // Tick 2: f_c = 50, f_s = 48 → e = 2, e_prev = 10.
        // f_a = 50 + 0.5 (4 + 30·(2 − 10)) = 50 + 0.5 (4 − 240) = −68.
        let a = law.update(50.0, 48.0, true);
        assert!((a.force_g - (-68.0)).abs() < 1e-4, "{}", a.force_g);
        assert!(!a.saturated);
        // Tick 3: f_c = 20, f_s = 19.5 → e = 0.5, e_prev = 2.
        // f_a = 20 + 0.2 (1 + 30·(0.5 − 2)) = 20 + 0.2 (1 − 45) = 11.2.
        let a = law.update(20.0, 19.5, true);
        assert!((a.force_g - 11.2).abs() < 1e-4, "{}", a.force_g);
        assert_eq!(law.previous_error_g(), 0.5);
        // Feedback off (an excitation on the drive): the command alone, the error followed.
        let a = law.update(20.0, 17.0, false);
        assert_eq!(a.force_g, 20.0);
        assert_eq!(law.previous_error_g(), 3.0);
        // On again, the derivative from the last error (3 → 2.5), not from before the pause:
        // f_a = 20 + 0.2 (5 + 30·(2.5 − 3)) = 20 + 0.2 (5 − 15) = 18.
        let a = law.update(20.0, 17.5, true);
        assert!((a.force_g - 18.0).abs() < 1e-4, "{}", a.force_g);
    }

    #[test]
    fn zero_command_has_exactly_zero_feedback() {
        let mut law = ForceLaw::new(ForceLawConfig::MEMO);
        for sensed in [-1e6f32, -3.0, 0.0, 0.25, 17.0, 1e6] {
            let a = law.update(0.0, sensed, true);
            assert_eq!(a.force_g, 0.0, "sensed {sensed}");
        }
    }

    #[test]
    fn fixed_schedule_keeps_full_gain_at_small_commands() {
        let mut fixed = ForceLaw::new(ForceLawConfig {
            schedule: GainSchedule::Fixed { command_g: 100.0 },
            ..ForceLawConfig::MEMO
        });
        // First tick from reset: f_a = 5 + 1·(2·1 + 30·1) = 37.
        let a = fixed.update(5.0, 4.0, true);
        assert!((a.force_g - 37.0).abs() < 1e-4);
        let mut scheduled = ForceLaw::new(ForceLawConfig::MEMO);
        // Same inputs with A1: f_a = 5 + 0.05·32 = 6.6.
        let a = scheduled.update(5.0, 4.0, true);
        assert!((a.force_g - 6.6).abs() < 1e-4);
    }

    #[test]
    fn non_finite_input_gives_the_safe_output_and_a_flag() {
        let mut law = ForceLaw::new(ForceLawConfig::MEMO);
        for (c, s) in [
            (f32::NAN, 1.0),
            (10.0, f32::INFINITY),
            (f32::NEG_INFINITY, 0.0),
        ] {
            let a = law.update(c, s, true);
            assert_eq!(a.force_g, 0.0);
            assert!(a.invalid_input);
        }
        // The bad tick left the derivative memory untouched.
        assert_eq!(law.previous_error_g(), 0.0);
    }

    #[test]
    fn slew_limiter_ramps_at_its_rate() {
        let mut s = SlewLimiter::new(500.0, 0.001);
        let out: Vec<f32> = (0..5).map(|_| s.update(30.0)).collect();
        assert_eq!(out, vec![0.5, 1.0, 1.5, 2.0, 2.5]);
        for _ in 0..100 {
            s.update(30.0);
        }
        assert_eq!(s.update(30.0), 30.0);
        assert_eq!(s.update(f32::NAN), 30.0);
        assert_eq!(s.update(29.8), 29.8);
    }

    #[test]
    fn actuator_codes_by_hand() {
        let a = ActuatorConfig::MEMO;
        // 96 g is 5 V: code (15/20)·4095 = 3071.25 → 3071.
        assert_eq!(a.code(96.0).0, 3071);
        assert_eq!(a.code(1e4).0, 4095);
        // 0 V falls between codes 2047 and 2048 (±2.4 mV, 0.05 g): the converter has no exact
        // zero, and the safe output is within half a code of it.
        let zero = a.zero_code();
        assert!((2047..=2048).contains(&zero.0));
        assert!(a.dac.volts(zero).abs() <= a.dac.lsb_v() / 2.0 + 1e-6);
    }

    proptest::proptest! {
        #[test]
        fn output_is_finite_and_within_the_actuator_range(
            commands in proptest::collection::vec(-1e4f32..1e4, 1..50),
            sensed in proptest::collection::vec(-1e4f32..1e4, 50),
        ) {
            let mut law = ForceLaw::new(ForceLawConfig::MEMO);
            for (c, s) in commands.iter().zip(sensed.iter()) {
                let a = law.update(*c, *s, true);
                proptest::prop_assert!(a.force_g.is_finite());
                proptest::prop_assert!((-192.0..=192.0).contains(&a.force_g));
            }
        }
    }
}
