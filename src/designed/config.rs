//! The designed controller's configuration: the schedule of the plant's inverse, the
//! feedback, the touch-down, and the table the firmware checks at start-up (`TCTL`).

use super::DESIGNED_POINTS;

/// The controller at one load: the plant's inverse as a series in s, drive grams per gram of
/// force and of its first three derivatives (c₀ in g/g, c₁ in s, c₂ in s², c₃ in s³), and the
/// share of the feedback gains the margins allow there (the lighter the load, the sharper the
/// inertia–finger mode: the memo's reason for A1's schedule).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InverseSeries {
    pub load_g: f32,
    pub c: [f32; 4],
    pub feedback: f32,
    /// The gauge's reading over the contact force, its s² term, s²: it sits on the beam and
    /// reads the tip's inertia besides the force, reading = force + `gauge_s2`·force''
    /// (1/ω_z² of the identified anti-resonance; about 50 g at 40 Hz, −1.2 dB on the light
    /// motor's fast-amplifier rig, −1.9 dB on the slow amplifier's).
    pub gauge_s2: f32,
}

/// Everything the designed controller is configured by (what its table carries).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DesignedConfig {
    pub dt_s: f32,
    /// The reference model's triple pole, Hz.
    pub reference_hz: f32,
    /// The inverse at increasing loads (`points` of them used); linear in between, the end
    /// values beyond.
    pub schedule: [InverseSeries; DESIGNED_POINTS],
    pub points: u8,
    /// The motor's Coulomb friction at the probe, g: added in the direction the force is
    /// moving (the motor moves with it), reached at [`FRICTION_RATE_G_PER_S`].
    pub friction_g: f32,
    /// The current amplifier's time constant, s (1/2πf_p of the identified pole): the friction
    /// compensation is added after the series, so where its sign turns (a reversal on the move)
    /// it passes (1 + τs) itself, a backward difference: τ/dt times the turn on that tick.
    /// Turned only a time ahead instead, its step reached the motor over a few τ while the
    /// motor stuck: the slow amplifier's 2 g sine about 10 g lost 11.6 dB at 40 Hz. Starts and
    /// stops get none (there the motor sticks anyway, and the held share carries the friction:
    /// with it an unseen rig's 100 → 90 g step went 1.37 g over).
    pub amplifier_tau_s: f32,
    /// Friction held once the reference stops, g, in the direction it last moved: a motor
    /// that stuck short of a step's end sits anywhere within its stiction band, and the
    /// integral alone, which still carries the last hold's friction (of the other sign after
    /// a reversal), took 30–60 ms to free it. Faded in as the reference's rate falls below
    /// half of [`FRICTION_RATE_G_PER_S`], so a sine, which never rests, gets none.
    pub held_friction_g: f32,
    /// Proportional gain, drive g per g of error.
    pub kp: f32,
    /// Integral gain, drive g per g·s of error.
    pub ki_per_s: f32,
    /// The biquad the error passes before the feedback's gains: (b₀, b₁, b₂, a₁, a₂) of
    /// (b₀ + b₁z⁻¹ + b₂z⁻²)/(1 + a₁z⁻¹ + a₂z⁻²), designed on the host.
    pub feedback_filter: [f32; 5],
    /// The integral's bound, drive g (what stiction and the model's gain error can need).
    pub integral_limit_g: f32,
    /// Touch-down: the drive held through a push (the identified stiction), g; what the push
    /// adds at its peak (what bounds the probe's momentum), g; the brake's peak, g (≤ 0).
    pub approach_hold_g: f32,
    pub approach_push_g: f32,
    pub approach_brake_g: f32,
    /// The reading that means the probe is on the finger ([`CONTACT_COUNT`] of the last
    /// [`CONTACT_TICKS`] at it), g; zero: no touch-down (a plant always in contact).
    pub contact_g: f32,
    /// Actuator range for the drive, g at the probe.
    pub drive_min_g: f32,
    pub drive_max_g: f32,
    /// The gauge the rig was identified through: its scale, g/V, and the top of its range, g.
    /// The table's grams (the contact reading, the schedule's loads) are that gauge's, so a
    /// firmware that reads another is refused (`tasks::ConfigError::DesignedGauge`).
    pub gauge_g_per_v: f32,
    pub gauge_max_g: f32,
}

impl From<crate::seal::SealError> for DesignedError {
    fn from(e: crate::seal::SealError) -> Self {
        use crate::seal::SealError;
        match e {
            SealError::TooShort { bytes, needed } => DesignedError::TooShort { bytes, needed },
            SealError::BadMagic => DesignedError::BadMagic,
            SealError::UnsupportedVersion { found } => DesignedError::UnsupportedVersion { found },
            SealError::Checksum { stored, computed } => {
                DesignedError::Checksum { stored, computed }
            }
        }
    }
}

/// Why a configuration is refused, naming the parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DesignedError {
    #[error("the designed controller's parameter {0} is not finite, or out of its range")]
    Invalid(&'static str),
    #[error("the schedule's loads must increase")]
    ScheduleOrder,
    /// Not a controller table (an erased flash sector reads `0xFF…`).
    #[error("not a controller table (no TCTL header)")]
    BadMagic,
    #[error("controller table version {found}; this build reads version {TABLE_VERSION}")]
    UnsupportedVersion { found: u16 },
    #[error("controller table too short: {bytes} bytes, need {needed}")]
    TooShort { bytes: usize, needed: usize },
    #[error(
        "controller table checksum {stored:#010x} does not match its contents ({computed:#010x})"
    )]
    Checksum { stored: u32, computed: u32 },
}

impl DesignedConfig {
    /// A plant with unit gain and no dynamics (for tests and the doc example).
    pub const UNIT_PLANT: DesignedConfig = DesignedConfig {
        dt_s: crate::CONTROL_PERIOD_S as f32,
        reference_hz: 200.0,
        schedule: [InverseSeries {
            load_g: 0.0,
            c: [1.0, 0.0, 0.0, 0.0],
            feedback: 1.0,
            gauge_s2: 0.0,
        }; DESIGNED_POINTS],
        points: 1,
        friction_g: 0.0,
        amplifier_tau_s: 0.0,
        held_friction_g: 0.0,
        kp: 0.0,
        ki_per_s: 20.0,
        feedback_filter: FEEDBACK_PASS,
        integral_limit_g: 10.0,
        approach_hold_g: 0.0,
        approach_push_g: 0.5,
        approach_brake_g: -0.5,
        contact_g: 0.0,
        drive_min_g: -192.0,
        drive_max_g: 192.0,
        gauge_g_per_v: 14.0,
        gauge_max_g: 135.0,
    };

    pub(super) fn check(&self) -> Result<(), DesignedError> {
        let positive = |v: f32, name| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(DesignedError::Invalid(name))
            }
        };
        let non_negative = |v: f32, name| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(DesignedError::Invalid(name))
            }
        };
        positive(self.dt_s, "dt_s")?;
        positive(self.reference_hz, "reference_hz")?;
        non_negative(self.kp, "kp")?;
        non_negative(self.ki_per_s, "ki_per_s")?;
        non_negative(self.integral_limit_g, "integral_limit_g")?;
        non_negative(self.friction_g, "friction_g")?;
        non_negative(self.held_friction_g, "held_friction_g")?;
        non_negative(self.amplifier_tau_s, "amplifier_tau_s")?;
        non_negative(self.approach_hold_g, "approach_hold_g")?;
        positive(self.approach_push_g, "approach_push_g")?;
        non_negative(-self.approach_brake_g, "approach_brake_g")?;
        non_negative(self.contact_g, "contact_g")?;
        positive(self.gauge_g_per_v, "gauge_g_per_v")?;
        positive(self.gauge_max_g, "gauge_max_g")?;
        // Stable: both poles inside the unit circle (the triangle a₂ < 1, |a₁| < 1 + a₂).
        let [b0, b1, b2, a1, a2] = self.feedback_filter;
        if ![b0, b1, b2, a1, a2].iter().all(|v| v.is_finite()) || a2 >= 1.0 || a1.abs() >= 1.0 + a2
        {
            return Err(DesignedError::Invalid("feedback_filter"));
        }
        if !(self.drive_min_g.is_finite()
            && self.drive_max_g.is_finite()
            && self.drive_min_g < self.drive_max_g)
        {
            return Err(DesignedError::Invalid("drive range"));
        }
        let n = usize::from(self.points);
        let used = self
            .schedule
            .get(..n)
            .filter(|s| !s.is_empty())
            .ok_or(DesignedError::Invalid("points"))?;
        for p in used {
            if !(p.load_g.is_finite()
                && p.c.iter().all(|c| c.is_finite())
                && p.c[0] > 0.0
                && (0.0..=1.0).contains(&p.feedback)
                && p.gauge_s2.is_finite())
            {
                return Err(DesignedError::Invalid("schedule"));
            }
        }
        if used
            .windows(2)
            .any(|w| matches!(w, [a, b] if a.load_g >= b.load_g))
        {
            return Err(DesignedError::ScheduleOrder);
        }
        Ok(())
    }

    /// The schedule at `load_g`: linear between its loads, the heaviest's beyond it; below the
    /// lightest the lightest's, with the feedback's share falling in proportion to the load
    /// (zero at no load, where the contact has no stiffness to speak of).
    #[inline]
    pub fn point_at(&self, load_g: f32) -> InverseSeries {
        let n = usize::from(self.points).clamp(1, DESIGNED_POINTS);
        let used = self.schedule.get(..n).unwrap_or(&[]);
        let Some((a, b, t)) = crate::bracket(used, |p| p.load_g, load_g) else {
            return InverseSeries {
                load_g,
                c: [1.0, 0.0, 0.0, 0.0],
                feedback: 0.0,
                gauge_s2: 0.0,
            };
        };
        if load_g <= a.load_g {
            // At or below the lightest point (`a` is it): the feedback fades out.
            let share = if a.load_g > 0.0 {
                crate::limit(load_g / a.load_g, 0.0, 1.0)
            } else {
                1.0
            };
            return InverseSeries {
                load_g,
                feedback: a.feedback * share,
                ..*a
            };
        }
        let mut c = a.c;
        for (ci, bi) in c.iter_mut().zip(b.c) {
            *ci += t * (bi - *ci);
        }
        InverseSeries {
            load_g,
            c,
            feedback: a.feedback + t * (b.feedback - a.feedback),
            gauge_s2: a.gauge_s2 + t * (b.gauge_s2 - a.gauge_s2),
        }
    }

    /// The inverse's series and the feedback's share at `load_g` ([`Self::point_at`]).
    #[inline]
    pub fn series_at(&self, load_g: f32) -> ([f32; 4], f32) {
        let p = self.point_at(load_g);
        (p.c, p.feedback)
    }

    /// How c₂ changes with the load at `load_g`, s²/g: the difference of [`Self::series_at`]
    /// a quarter of the load either side (the schedule's lines kink at its loads, and a sine
    /// about one of them would see a slope that jumps as it crosses: a pull at its own
    /// frequency); 0 where the series is held (below the lightest point, beyond the heaviest).
    #[inline]
    pub fn c2_slope_at(&self, load_g: f32) -> f32 {
        let h = SLOPE_SPAN * load_g;
        if h <= 0.0 {
            return 0.0;
        }
        let (above, _) = self.series_at(load_g + h);
        let (below, _) = self.series_at(load_g - h);
        (above[2] - below[2]) / (2.0 * h)
    }
}

/// The controller table's header (what the firmware checks at start-up, as it checks the
/// calibration table): `TCTL`, version, a byte reserved (zero) and the schedule's length.
pub const TABLE_MAGIC: [u8; 4] = *b"TCTL";
pub const TABLE_VERSION: u16 = 7;
const TABLE_HEADER_BYTES: usize = 8;
/// dt, reference, kp, ki, friction, integral bound, drive range, the feedback's biquad, the
/// touch-down's hold, push, brake and contact, the held friction, the amplifier's τ, the
/// gauge's scale and top; then per point load, c₀…c₃, feedback share, the gauge's s² term.
const TABLE_SCALARS: usize = 21;
/// The biquad that passes the error unchanged.
pub const FEEDBACK_PASS: [f32; 5] = [1.0, 0.0, 0.0, 0.0, 0.0];
const POINT_FLOATS: usize = 7;
/// The encoded table's length, bytes (the whole schedule, used points or not, and a CRC-32).
pub const TABLE_BYTES: usize =
    TABLE_HEADER_BYTES + 4 * (TABLE_SCALARS + DESIGNED_POINTS * POINT_FLOATS) + 4;

impl DesignedConfig {
    /// The table's bytes, little-endian, checksummed; `check`ed first.
    pub fn encode(&self) -> Result<[u8; TABLE_BYTES], DesignedError> {
        self.check()?;
        let mut out = [0u8; TABLE_BYTES];
        let scalars = [
            self.dt_s,
            self.reference_hz,
            self.kp,
            self.ki_per_s,
            self.friction_g,
            self.integral_limit_g,
            self.drive_min_g,
            self.drive_max_g,
            self.feedback_filter[0],
            self.feedback_filter[1],
            self.feedback_filter[2],
            self.feedback_filter[3],
            self.feedback_filter[4],
            self.approach_hold_g,
            self.approach_push_g,
            self.approach_brake_g,
            self.contact_g,
            self.held_friction_g,
            self.amplifier_tau_s,
            self.gauge_g_per_v,
            self.gauge_max_g,
        ];
        let points = self.schedule.iter().flat_map(|p| {
            [
                p.load_g, p.c[0], p.c[1], p.c[2], p.c[3], p.feedback, p.gauge_s2,
            ]
        });
        let floats = scalars.into_iter().chain(points);
        let (header, rest) = out.split_at_mut(TABLE_HEADER_BYTES);
        if let Some(slot) = header.get_mut(6..8) {
            slot.copy_from_slice(&[0, self.points]);
        }
        for (slot, v) in rest.chunks_exact_mut(4).zip(floats) {
            slot.copy_from_slice(&v.to_le_bytes());
        }
        crate::seal::seal(&mut out, TABLE_MAGIC, TABLE_VERSION);
        Ok(out)
    }

    /// Reads a table, checking the header, the length, the checksum and every parameter
    /// before trusting any of it. Bytes after the table are ignored.
    pub fn decode(bytes: &[u8]) -> Result<DesignedConfig, DesignedError> {
        let all = bytes.get(..TABLE_BYTES).ok_or(DesignedError::TooShort {
            bytes: bytes.len(),
            needed: TABLE_BYTES,
        })?;
        crate::seal::check_head(all, TABLE_MAGIC, TABLE_VERSION)?;
        crate::seal::check_crc(all, TABLE_BYTES)?;
        let f =
            |i: usize| f32::from_le_bytes(crate::seal::bytes_at(all, TABLE_HEADER_BYTES + 4 * i));
        let point = |k: usize| {
            let at = TABLE_SCALARS + k * POINT_FLOATS;
            InverseSeries {
                load_g: f(at),
                c: [f(at + 1), f(at + 2), f(at + 3), f(at + 4)],
                feedback: f(at + 5),
                gauge_s2: f(at + 6),
            }
        };
        let config = DesignedConfig {
            dt_s: f(0),
            reference_hz: f(1),
            kp: f(2),
            ki_per_s: f(3),
            friction_g: f(4),
            integral_limit_g: f(5),
            drive_min_g: f(6),
            drive_max_g: f(7),
            feedback_filter: [f(8), f(9), f(10), f(11), f(12)],
            approach_hold_g: f(13),
            approach_push_g: f(14),
            approach_brake_g: f(15),
            contact_g: f(16),
            held_friction_g: f(17),
            amplifier_tau_s: f(18),
            gauge_g_per_v: f(19),
            gauge_max_g: f(20),
            schedule: core::array::from_fn(point),
            points: all.get(7).copied().unwrap_or(0),
        };
        config.check()?;
        Ok(config)
    }
}

/// The span of [`DesignedConfig::c2_slope_at`]'s difference either side, a share of the load.
pub const SLOPE_SPAN: f32 = 0.25;
