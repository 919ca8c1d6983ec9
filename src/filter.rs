//! The memo's lowpass-notch filter (Appendix A), discretized for the 1 kHz loop.
//!
//! ```text
//! H(s) = 1/(s/ω_l + 1) · (ω_o/ω_n)² (s² + ω_n²) / (s² + (ω_o/Q) s + ω_o²)
//! ```
//!
//! Discretized by the bilinear transform, each factor prewarped at its own corner: the notch
//! zeros at ω_n (so the 190 Hz beam resonance is nulled exactly), the resonant pole pair at ω_o
//! and the lowpass pole at ω_l. A single prewarp at the notch would move the Q = 2.8 peak from
//! 26.8 Hz to 23.5 Hz at 1 kHz and miss the analog response by several dB near the peak; the
//! per-factor prewarp keeps the digital response within 0.5 dB of the analog one to 100 Hz. The
//! common (z+1)² of the notch section cancels, so the section stays a plain biquad and DC gain is
//! exactly one.
//!
//! Configuration ([`LowpassNotchConfig`], [`Biquad`] coefficients) is kept apart from state
//! ([`BiquadState`]), as in quartiq/idsp.

use crate::trig::tan;
use num_complex::Complex64;

/// One second-order section, `y = (b0 + b1 z⁻¹ + b2 z⁻²) / (1 + a1 z⁻¹ + a2 z⁻²) x`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Biquad {
    pub b: [f32; 3],
    /// `a1, a2`; `a0` is 1.
    pub a: [f32; 2],
}

/// Transposed direct form II state of a [`Biquad`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BiquadState {
    s: [f32; 2],
}

impl Biquad {
    /// The identity section.
    pub const IDENTITY: Biquad = Biquad {
        b: [1.0, 0.0, 0.0],
        a: [0.0, 0.0],
    };

    /// Runs one sample through the section.
    #[inline]
    pub fn update(&self, state: &mut BiquadState, x: f32) -> f32 {
        let [b0, b1, b2] = self.b;
        let [a1, a2] = self.a;
        let [s1, s2] = state.s;
        let y = b0 * x + s1;
        state.s = [b1 * x - a1 * y + s2, b2 * x - a2 * y];
        y
    }

    /// A notch at `f0_hz` for samples every `dt_s` (RBJ's bilinear notch with the centre
    /// prewarped): unity gain away from it, zero at it, −3 dB at f0 ± f0/(2q). A tone above
    /// Nyquist is notched where it aliases to. `None` when that falls within 2 % of DC or of
    /// Nyquist (a notch there would take the signal), or for non-finite or non-positive
    /// arguments.
    pub fn notch(f0_hz: f64, q: f64, dt_s: f64) -> Option<Biquad> {
        if !(f0_hz.is_finite() && q.is_finite() && dt_s.is_finite())
            || f0_hz <= 0.0
            || q <= 0.0
            || dt_s <= 0.0
        {
            return None;
        }
        let fs = 1.0 / dt_s;
        let alias = (f0_hz - libm::round(f0_hz / fs) * fs).abs();
        if alias < 0.01 * fs || alias > 0.49 * fs {
            return None;
        }
        let w0 = 2.0 * core::f64::consts::PI * alias * dt_s;
        let (sin, cos) = crate::trig::sin_cos(w0);
        let alpha = sin / (2.0 * q);
        let a0 = 1.0 + alpha;
        Some(Biquad {
            b: [1.0 / a0, -2.0 * cos / a0, 1.0 / a0].map(|v| v as f32),
            a: [-2.0 * cos / a0, (1.0 - alpha) / a0].map(|v| v as f32),
        })
    }

    /// True when both poles lie strictly inside the unit circle (the stability triangle).
    pub fn is_stable(&self) -> bool {
        let [a1, a2] = self.a;
        a2.abs() < 1.0 && a1.abs() < 1.0 + a2
    }

    /// Complex frequency response at `omega_t = ω·T` (radians per sample).
    pub fn response(&self, omega_t: f64) -> Complex64 {
        // H(e^{jθ}) = Σ b_k e^{-jkθ} / Σ a_k e^{-jkθ}
        let z1 = Complex64::from_polar(1.0, -omega_t);
        let z2 = z1 * z1;
        let [b0, b1, b2] = self.b.map(f64::from);
        let [a1, a2] = self.a.map(f64::from);
        (z1 * b1 + z2 * b2 + b0) / (z1 * a1 + z2 * a2 + 1.0)
    }
}

/// Why a filter configuration was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FilterError {
    /// A frequency, Q or the sample period is not finite and positive.
    #[error("lowpass-notch filter: {name} must be finite and positive")]
    NonPositiveParameter { name: FilterParameter },
    /// A corner is at or above the Nyquist frequency, where the bilinear prewarp breaks down.
    #[error("lowpass-notch filter: {name} is at or above the Nyquist frequency")]
    AboveNyquist { name: FilterParameter },
}

/// A parameter of [`LowpassNotchConfig`], as an error names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterParameter {
    OmegaL,
    OmegaO,
    Q,
    OmegaN,
    SamplePeriod,
}

impl core::fmt::Display for FilterParameter {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            FilterParameter::OmegaL => "omega_l_rad_s",
            FilterParameter::OmegaO => "omega_o_rad_s",
            FilterParameter::Q => "q",
            FilterParameter::OmegaN => "omega_n_rad_s",
            FilterParameter::SamplePeriod => "sample_period_s",
        })
    }
}

/// The analog filter as built: corners in rad/s, and the loop's sample period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LowpassNotchConfig {
    /// Lowpass pole ω_l (memo: 147 rad/s, 23.4 Hz).
    pub omega_l_rad_s: f64,
    /// Resonant pole pair ω_o (memo: 168 rad/s, 26.8 Hz).
    pub omega_o_rad_s: f64,
    /// Quality factor of the pole pair (memo: 2.8).
    pub q: f64,
    /// Notch ω_n = α ω_o (memo: α ≈ 7, the notch at 190 Hz).
    pub omega_n_rad_s: f64,
    /// Sample period of the loop (memo: 0.001 s).
    pub sample_period_s: f64,
}

impl LowpassNotchConfig {
    /// The memo's component values; the notch placed on the 190 Hz beam resonance.
    pub const MEMO: LowpassNotchConfig = LowpassNotchConfig {
        omega_l_rad_s: 147.0,
        omega_o_rad_s: 168.0,
        q: 2.8,
        omega_n_rad_s: 2.0 * core::f64::consts::PI * 190.0,
        sample_period_s: crate::CONTROL_PERIOD_S,
    };

    /// The analog response H(jω).
    pub fn analog_response(&self, omega_rad_s: f64) -> Complex64 {
        let w = omega_rad_s;
        let lowpass = Complex64::new(1.0, w / self.omega_l_rad_s).inv();
        let ratio = self.omega_o_rad_s / self.omega_n_rad_s;
        let gain = ratio * ratio;
        let num = Complex64::from(gain * (self.omega_n_rad_s * self.omega_n_rad_s - w * w));
        let den = Complex64::new(
            self.omega_o_rad_s * self.omega_o_rad_s - w * w,
            self.omega_o_rad_s / self.q * w,
        );
        lowpass * num / den
    }

    /// Discretizes the filter into two sections (lowpass, then notch).
    pub fn discretize(&self) -> Result<LowpassNotch, FilterError> {
        let t = self.sample_period_s;
        let all = [
            self.omega_l_rad_s,
            self.omega_o_rad_s,
            self.q,
            self.omega_n_rad_s,
            t,
        ];
        use FilterParameter::*;
        const NAMES: [FilterParameter; 5] = [OmegaL, OmegaO, Q, OmegaN, SamplePeriod];
        if let Some((_, name)) = all
            .iter()
            .zip(NAMES)
            .find(|(v, _)| !v.is_finite() || **v <= 0.0)
        {
            return Err(FilterError::NonPositiveParameter { name });
        }
        let nyquist = core::f64::consts::PI / t;
        if let Some((_, name)) = [self.omega_l_rad_s, self.omega_o_rad_s, self.omega_n_rad_s]
            .iter()
            .zip([OmegaL, OmegaO, OmegaN])
            .find(|(w, _)| **w >= 0.999 * nyquist)
        {
            return Err(FilterError::AboveNyquist { name });
        }
        // Bilinear s = K (z-1)/(z+1), with K chosen so that ω maps onto itself.
        let prewarp = |w: f64| w / tan(w * t / 2.0);

        // Lowpass: ω_l (1 + z⁻¹) / ((K+ω_l) + (ω_l−K) z⁻¹)
        let (wl, kl) = (self.omega_l_rad_s, prewarp(self.omega_l_rad_s));
        let lowpass = Biquad {
            b: [(wl / (kl + wl)) as f32, (wl / (kl + wl)) as f32, 0.0],
            a: [((wl - kl) / (kl + wl)) as f32, 0.0],
        };

        // Notch zeros: K_n²(z−1)² + ω_n²(z+1)²; pole pair: K_o²(z−1)² + (ω_o/Q)K_o(z²−1) + ω_o²(z+1)².
        let (wn, kn) = (self.omega_n_rad_s, prewarp(self.omega_n_rad_s));
        let (wo, ko) = (self.omega_o_rad_s, prewarp(self.omega_o_rad_s));
        let num = [
            kn * kn + wn * wn,
            2.0 * (wn * wn - kn * kn),
            kn * kn + wn * wn,
        ];
        let bw = wo / self.q * ko;
        let den = [
            ko * ko + bw + wo * wo,
            2.0 * (wo * wo - ko * ko),
            ko * ko - bw + wo * wo,
        ];
        let gain = (wo / wn) * (wo / wn);
        let notch = Biquad {
            b: num.map(|c| (gain * c / den[0]) as f32),
            a: [(den[1] / den[0]) as f32, (den[2] / den[0]) as f32],
        };
        Ok(LowpassNotch {
            sections: [lowpass, notch],
        })
    }
}

/// The discretized lowpass-notch filter: configuration only, see [`LowpassNotchState`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LowpassNotch {
    pub sections: [Biquad; 2],
}

/// State of a [`LowpassNotch`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LowpassNotchState {
    sections: [BiquadState; 2],
}

impl LowpassNotch {
    /// Runs one sample through both sections.
    #[inline]
    pub fn update(&self, state: &mut LowpassNotchState, x: f32) -> f32 {
        let [lowpass, notch] = &self.sections;
        let [s_lowpass, s_notch] = &mut state.sections;
        notch.update(s_notch, lowpass.update(s_lowpass, x))
    }

    /// Sets the state to the steady state of a constant input `x` (unity DC gain), so a loop
    /// that starts at a non-zero command does not see a filter transient.
    pub fn settle_to(&self, state: &mut LowpassNotchState, x: f32) {
        for (section, s) in self.sections.iter().zip(state.sections.iter_mut()) {
            let [b0, b1, b2] = section.b;
            let [a1, a2] = section.a;
            let dc = (b0 + b1 + b2) / (1.0 + a1 + a2);
            let y = dc * x;
            // From the DF2T equations at steady state.
            s.s = [b1 * x - a1 * y + (b2 * x - a2 * y), b2 * x - a2 * y];
        }
    }

    /// Digital frequency response at ω (rad/s) for sample period `t_s`.
    pub fn response(&self, omega_rad_s: f64, t_s: f64) -> Complex64 {
        let [lowpass, notch] = &self.sections;
        lowpass.response(omega_rad_s * t_s) * notch.response(omega_rad_s * t_s)
    }

    /// True when every section is stable.
    pub fn is_stable(&self) -> bool {
        self.sections.iter().all(Biquad::is_stable)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn db(x: f64) -> f64 {
        20.0 * x.log10()
    }

    #[test]
    fn digital_magnitude_tracks_analog_within_half_a_db_to_100_hz() {
        let config = LowpassNotchConfig::MEMO;
        let filter = config.discretize().unwrap();
        let mut worst: f64 = 0.0;
        // 0.1 Hz to 100 Hz, log spaced.
        for i in 0..=300 {
            let f_hz = 0.1 * 1000f64.powf(i as f64 / 300.0);
            let w = 2.0 * std::f64::consts::PI * f_hz;
            let analog = config.analog_response(w).norm();
            let digital = filter.response(w, config.sample_period_s).norm();
            worst = worst.max((db(digital) - db(analog)).abs());
        }
        assert!(worst < 0.5, "worst deviation {worst:.3} dB");
    }

    #[test]
    fn attenuates_the_190_hz_beam_resonance_by_40_db() {
        let config = LowpassNotchConfig::MEMO;
        let filter = config.discretize().unwrap();
        let w = 2.0 * std::f64::consts::PI * 190.0;
        let gain_db = db(filter.response(w, 0.001).norm());
        assert!(gain_db < -40.0, "{gain_db} dB at 190 Hz");
    }

    #[test]
    fn unity_dc_gain_in_the_time_domain() {
        let filter = LowpassNotchConfig::MEMO.discretize().unwrap();
        let mut state = LowpassNotchState::default();
        let mut y = 0.0;
        for _ in 0..5000 {
            y = filter.update(&mut state, 1.0);
        }
        assert!((y - 1.0).abs() < 1e-4, "DC gain {y}");
    }

    #[test]
    fn the_q_peak_stays_where_the_analog_circuit_put_it() {
        // The analog second-order section peaks near 27 Hz before the lowpass pulls it down
        // (FACTS.md): find the digital peak of the whole filter and compare with the analog one.
        let config = LowpassNotchConfig::MEMO;
        let filter = config.discretize().unwrap();
        let peak = |f: &dyn Fn(f64) -> f64| {
            (1..2000)
                .map(|i| i as f64 * 0.05)
                .map(|hz| (hz, f(2.0 * std::f64::consts::PI * hz)))
                .fold((0.0, 0.0), |best, x| if x.1 > best.1 { x } else { best })
        };
        let (f_a, m_a) = peak(&|w| config.analog_response(w).norm());
        let (f_d, m_d) = peak(&|w| filter.response(w, 0.001).norm());
        assert!(
            (f_a - f_d).abs() < 0.5,
            "analog peak {f_a} Hz, digital {f_d} Hz"
        );
        assert!((db(m_a) - db(m_d)).abs() < 0.2);
        // Hand check: |H| at the analog peak is above 1 (the Q = 2.8 bump survives the lowpass).
        assert!(m_a > 1.0);
    }

    #[test]
    fn settle_to_starts_at_steady_state() {
        let filter = LowpassNotchConfig::MEMO.discretize().unwrap();
        let mut state = LowpassNotchState::default();
        filter.settle_to(&mut state, 42.0);
        for _ in 0..10 {
            let y = filter.update(&mut state, 42.0);
            assert!((y - 42.0).abs() < 1e-3, "{y}");
        }
    }

    #[test]
    fn refuses_bad_configurations() {
        let mut c = LowpassNotchConfig::MEMO;
        c.q = 0.0;
        assert_eq!(
            c.discretize(),
            Err(FilterError::NonPositiveParameter {
                name: FilterParameter::Q
            })
        );
        let mut c = LowpassNotchConfig::MEMO;
        c.omega_n_rad_s = 4000.0;
        let e = c.discretize().unwrap_err();
        assert_eq!(
            e,
            FilterError::AboveNyquist {
                name: FilterParameter::OmegaN
            }
        );
        assert_eq!(
            e.to_string(),
            "lowpass-notch filter: omega_n_rad_s is at or above the Nyquist frequency"
        );
        let mut c = LowpassNotchConfig::MEMO;
        c.sample_period_s = f64::NAN;
        assert_eq!(
            c.discretize(),
            Err(FilterError::NonPositiveParameter {
                name: FilterParameter::SamplePeriod
            })
        );
    }

    proptest::proptest! {
        #[test]
        fn poles_inside_the_unit_circle_for_every_valid_configuration(
            omega_l in 10.0f64..2000.0,
            omega_o in 10.0f64..2000.0,
            q in 0.2f64..20.0,
            omega_n in 10.0f64..3000.0,
        ) {
            let config = LowpassNotchConfig {
                omega_l_rad_s: omega_l, omega_o_rad_s: omega_o, q, omega_n_rad_s: omega_n,
                sample_period_s: 0.001,
            };
            let filter = config.discretize().unwrap();
            proptest::prop_assert!(filter.is_stable(), "{:?}", filter);
        }
    }

    #[test]
    fn notch_takes_its_tone_and_passes_the_rest() {
        let dt = 1.0 / 62.5;
        let n = Biquad::notch(7.3, 2.0, dt).unwrap();
        assert!(n.is_stable());
        let gain = |hz: f64| n.response(2.0 * core::f64::consts::PI * hz * dt).norm();
        assert!(gain(7.3) < 1e-3, "{}", gain(7.3));
        assert!((gain(0.0) - 1.0).abs() < 1e-6);
        assert!((gain(0.5) - 1.0).abs() < 0.01, "{}", gain(0.5));
        // −3 dB at f0 ± f0/(2q), here about ±1.8 Hz.
        assert!((gain(7.3 + 1.9) - 0.707).abs() < 0.1, "{}", gain(9.2));
        // 50 Hz mains sampled at 62.5 Hz lands at 12.5 Hz: notched there.
        let mains = Biquad::notch(50.0, 2.0, dt).unwrap();
        let g = |hz: f64| mains.response(2.0 * core::f64::consts::PI * hz * dt).norm();
        assert!(g(12.5) < 1e-3);
        // A tone on a multiple of the sample rate is DC: refused.
        assert!(Biquad::notch(62.5, 2.0, dt).is_none());
        assert!(Biquad::notch(f64::NAN, 2.0, dt).is_none());
    }
}
