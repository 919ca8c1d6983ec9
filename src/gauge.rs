//! The strain-gauge path: eight ADC samples per control tick, averaged and converted to grams
//! at the probe, with a range check that reports a saturated or disconnected gauge instead of
//! returning a number.
//!
//! The memo's gauge signal is ±10 V at its converter (bridge 10 V, amplifier gain 2100,
//! 14 g/V). On a board the signal is level-shifted into the microcontroller's converter; the
//! [`AdcScale`] maps codes back to the memo's volts so the rest of the code is board-free.

/// A raw converter code (right-aligned, `bits` wide).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub struct AdcCode(pub u16);

/// Volts at the signal's own scale (before level shifting), of a converter code.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdcScale {
    /// Highest code (4095 for 12 bits).
    pub full_scale_code: u16,
    /// Signal voltage at code 0.
    pub min_v: f32,
    /// Signal voltage at the full-scale code.
    pub max_v: f32,
}

impl AdcScale {
    /// A 12-bit converter spanning the memo's ±10 V.
    pub const BIPOLAR_10V_12BIT: AdcScale = AdcScale {
        full_scale_code: 4095,
        min_v: -10.0,
        max_v: 10.0,
    };

    /// Volts per code.
    #[inline]
    pub fn lsb_v(&self) -> f32 {
        (self.max_v - self.min_v) / f32::from(self.full_scale_code)
    }

    #[inline]
    pub fn volts(&self, code: AdcCode) -> f32 {
        self.min_v + f32::from(code.0.min(self.full_scale_code)) * self.lsb_v()
    }

    /// The code a converter returns for `volts` (rounded, clamped to the rails; NaN reads 0).
    #[inline]
    pub fn code(&self, volts: f32) -> AdcCode {
        let x = (volts - self.min_v) / self.lsb_v() + 0.5;
        // `as` saturates and maps NaN to 0, which is what a converter at its rail does.
        AdcCode((x as u32).min(u32::from(self.full_scale_code)) as u16)
    }

    /// True when the code sits at either rail.
    #[inline]
    pub fn at_rail(&self, code: AdcCode) -> bool {
        code.0 == 0 || code.0 >= self.full_scale_code
    }
}

/// Why the gauge gave no force.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GaugeFault {
    /// A sample sat at a converter rail: the gauge is saturated or disconnected.
    AtRail { code: AdcCode },
    /// The average is outside the physically possible range of the applicator.
    OutOfRange { force_g: f32 },
}

/// Number of converter samples averaged per control tick (memo: 8).
pub const SAMPLES_PER_TICK: usize = 8;

/// Conversion from gauge volts to grams at the probe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaugeConfig {
    pub adc: AdcScale,
    /// Grams at the probe per volt at the converter (memo: 14 g/V).
    pub grams_per_volt: f32,
    /// Gauge output with the probe unloaded (bridge offset), in volts.
    pub zero_v: f32,
    /// Physical range of the gauge; an average outside it is a fault (the memo's −30 to 135 g
    /// is −2.1 to 9.6 V: the converter's span less a margin at the top).
    pub force_min_g: f32,
    pub force_max_g: f32,
}

impl GaugeConfig {
    pub const MEMO: GaugeConfig = GaugeConfig {
        adc: AdcScale::BIPOLAR_10V_12BIT,
        grams_per_volt: 14.0,
        zero_v: 0.0,
        force_min_g: -30.0,
        force_max_g: 135.0,
    };

    /// The memo's converter and range in volts, with a gauge of `grams_per_volt` (a gauge half
    /// as sensitive reads twice the force over the same volts).
    ///
    /// ```
    /// use tactile_core::gauge::GaugeConfig;
    /// // A const: a board's configuration is one (`tactile_firmware::BOARD`).
    /// const G: GaugeConfig = GaugeConfig::with_scale(28.0);
    /// let g = G;
    /// assert_eq!((g.force_min_g, g.force_max_g), (-60.0, 270.0));
    /// assert_eq!(g.force_g(1.0), 28.0);
    /// ```
    pub const fn with_scale(grams_per_volt: f32) -> GaugeConfig {
        let k = grams_per_volt / Self::MEMO.grams_per_volt;
        GaugeConfig {
            grams_per_volt,
            force_min_g: Self::MEMO.force_min_g * k,
            force_max_g: Self::MEMO.force_max_g * k,
            ..Self::MEMO
        }
    }

    /// Grams for a gauge voltage.
    #[inline]
    pub fn force_g(&self, volts: f32) -> f32 {
        (volts - self.zero_v) * self.grams_per_volt
    }

    /// Gauge voltage for a force (the simulator's gauge uses this).
    #[inline]
    pub fn volts(&self, force_g: f32) -> f32 {
        force_g / self.grams_per_volt + self.zero_v
    }

    /// Averages one tick's samples into grams, or reports why it cannot.
    #[inline]
    pub fn average_force(&self, samples: &[AdcCode; SAMPLES_PER_TICK]) -> Result<f32, GaugeFault> {
        let mut sum: u32 = 0;
        for &code in samples {
            if self.adc.at_rail(code) {
                return Err(GaugeFault::AtRail { code });
            }
            sum += u32::from(code.0);
        }
        let mean_code = sum as f32 / SAMPLES_PER_TICK as f32;
        let volts = self.adc.min_v + mean_code * self.adc.lsb_v();
        let force_g = self.force_g(volts);
        if (self.force_min_g..=self.force_max_g).contains(&force_g) {
            Ok(force_g)
        } else {
            Err(GaugeFault::OutOfRange { force_g })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_checked_conversion() {
        let g = GaugeConfig::MEMO;
        // Code 2048 is −10 + 2048·20/4095 = 0.002442 V → 0.0342 g.
        let f = g.average_force(&[AdcCode(2048); 8]).unwrap();
        assert!((f - 0.034_188).abs() < 1e-4, "{f}");
        // 50 g is 50/14 = 3.5714 V → code (13.5714/20)·4095 = 2778.75, rounds to 2779.
        assert_eq!(g.adc.code(g.volts(50.0)), AdcCode(2779));
        // Averaging: four at 2779 and four at 2780 → mean 2779.5 → 50.034 g.
        let s = [2779, 2780, 2779, 2780, 2779, 2780, 2779, 2780].map(AdcCode);
        let f = g.average_force(&s).unwrap();
        let expected = (-10.0 + 2779.5 * 20.0 / 4095.0) * 14.0;
        assert!((f - expected).abs() < 1e-3, "{f} vs {expected}");
    }

    #[test]
    fn a_rail_sample_is_a_fault_not_a_number() {
        let g = GaugeConfig::MEMO;
        let mut s = [AdcCode(2100); 8];
        s[3] = AdcCode(4095);
        assert_eq!(
            g.average_force(&s),
            Err(GaugeFault::AtRail {
                code: AdcCode(4095)
            })
        );
        s[3] = AdcCode(0);
        assert_eq!(
            g.average_force(&s),
            Err(GaugeFault::AtRail { code: AdcCode(0) })
        );
    }

    #[test]
    fn out_of_physical_range_is_a_fault() {
        let g = GaugeConfig::MEMO;
        // 9.5 V is 133 g: inside. 9.8 V is 137.2 g: outside.
        assert!(g.average_force(&[g.adc.code(9.5); 8]).is_ok());
        match g.average_force(&[g.adc.code(9.8); 8]) {
            Err(GaugeFault::OutOfRange { force_g }) => assert!((force_g - 137.2).abs() < 0.1),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn code_clamps_at_the_rails() {
        let adc = AdcScale::BIPOLAR_10V_12BIT;
        assert_eq!(adc.code(-50.0), AdcCode(0));
        assert_eq!(adc.code(50.0), AdcCode(4095));
        assert_eq!(adc.code(f32::NAN), AdcCode(0));
        for code in [1u16, 100, 2047, 4094] {
            assert_eq!(adc.code(adc.volts(AdcCode(code))), AdcCode(code));
        }
    }
}
