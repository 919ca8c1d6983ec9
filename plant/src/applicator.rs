//! The motor–beam force applicator of memo Appendix A, with the finger contact.
//!
//! Lumped model, in SI units inside (N, m, kg, s), grams at the boundary:
//!
//! ```text
//!  amplifier input V ─► current amplifier (0.19 A/V, pole 160 Hz) ─► i
//!  motor (inertia J reflected to the 9 cm tip as M = J/r²) ── beam spring k_b ── tip mass m_b ── finger
//!      static friction 10 g·cm (Karnopp stick/slip), tiny viscous damping (misprint 1)
//! ```
//!
//! The strain gauge reads the beam's bending, k_b (x_motor − y_tip), in grams. The finger
//! touches the tip unilaterally: the contact force is the G₁ spring of the probed element
//! compressed by the tip's indentation beyond the finger's current rest surface; when the tip
//! lifts off the force is zero and the gauge sees only the beam's own dynamics.
//!
//! Parameters are chosen (not fitted) so that, probe on the finger at 50 g, the two modes are
//! the memo's 50 Hz (motor inertia on the finger spring) and 190 Hz (beam): with k_b = 2000 N/m
//! the modal equations give m_b = 2.61 g and a finger contact stiffness of 845 N/m at 50 g, which
//! the element's tangent G₁ (7.74 g/% at 50 g) gives for an indentation scale of 9 mm per 100 %
//! strain. `open_loop_resonances` in the tests measures both peaks from the simulation.

use tactile_core::viscoelastic::SpringLaw;

/// Standard gravity: newtons per gram-force × 1000.
pub const NEWTONS_PER_GRAM: f64 = 9.806_65e-3;

/// A rig's applicator: what a user writes in an `--applicator` file (TOML, every field, in the
/// units its name carries; `applicators/memo.toml` is [`ApplicatorParams::MEMO`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct ApplicatorParams {
    pub amplifier_a_per_v: f64,
    pub amplifier_pole_hz: f64,
    pub torque_constant_nm_per_a: f64,
    pub motor_inertia_kg_m2: f64,
    pub arm_m: f64,
    pub static_friction_nm: f64,
    pub viscous_nm_s_per_rad: f64,
    pub beam_stiffness_n_per_m: f64,
    pub tip_mass_kg: f64,
    pub beam_damping_ratio: f64,
    /// Probe indentation (mm) per 100 % strain of the element under it.
    pub indentation_mm_per_100pct: f64,
    /// Rubber's high-frequency loss under the probe: a dashpot in parallel with G₁ whose
    /// coefficient is the loss factor times the spring's secant stiffness over ω at 50 Hz
    /// (structural damping, so it grows with the load as the spring does). The memo's
    /// Maxwell–Kelvin model is fitted at 10 Hz and has no such term; elastomers have loss
    /// factors of 0.1–0.5 at tens of hertz. Its time constant with G₁ is below a millisecond,
    /// invisible in the strain records.
    pub contact_loss_factor: f64,
    /// The strain gauge's scale: grams at the probe per volt at the converter (memo: 14). The
    /// firmware reads the gauge with it (a user's gauge is calibrated with weights), so the
    /// force range the converter spans is ±10 V times it.
    pub gauge_g_per_v: f64,
    /// The gauge's noise, grams RMS of one control tick's reading (the mean of its eight
    /// converter samples) with the probe still: the memo's measured 0.14 g (misprint 2).
    pub gauge_noise_g: f64,
}

/// A field's name, value, sign, plausible range and what the range is of.
type FieldRange = (&'static str, f64, Sign, f64, f64, &'static str);

impl ApplicatorParams {
    /// FACTS.md values; beam and indentation scale chosen for the 50 Hz and 190 Hz modes.
    pub const MEMO: ApplicatorParams = ApplicatorParams {
        amplifier_a_per_v: 0.19,
        amplifier_pole_hz: 160.0,
        torque_constant_nm_per_a: 910.0 * NEWTONS_PER_GRAM * 0.01,
        motor_inertia_kg_m2: 0.38 * NEWTONS_PER_GRAM * 0.01,
        arm_m: 0.09,
        static_friction_nm: 10.0 * NEWTONS_PER_GRAM * 0.01,
        // Misprint 1: 0.1 oz·in/krpm ≈ 0.068 g·cm·s/rad.
        viscous_nm_s_per_rad: 0.068 * NEWTONS_PER_GRAM * 0.01,
        beam_stiffness_n_per_m: 2000.0,
        tip_mass_kg: 2.61e-3,
        beam_damping_ratio: 0.01,
        indentation_mm_per_100pct: 9.0,
        contact_loss_factor: 0.36,
        gauge_g_per_v: 14.0,
        gauge_noise_g: 0.14,
    };

    /// Each field: its sign (a rig cannot exist otherwise), then a range wide enough for any
    /// bench applicator (out of it, a unit is wrong), and what the range is of.
    fn field_ranges(&self) -> [FieldRange; 14] {
        use Sign::{NotNegative, Positive};
        [
            (
                "amplifier_a_per_v",
                self.amplifier_a_per_v,
                Positive,
                1e-3,
                1e2,
                "current amplifiers, A/V",
            ),
            (
                "amplifier_pole_hz",
                self.amplifier_pole_hz,
                Positive,
                1.0,
                1e5,
                "amplifier bandwidths, Hz",
            ),
            (
                "torque_constant_nm_per_a",
                self.torque_constant_nm_per_a,
                Positive,
                1e-4,
                10.0,
                "motors' torque constants, N·m/A",
            ),
            (
                "motor_inertia_kg_m2",
                self.motor_inertia_kg_m2,
                Positive,
                1e-9,
                1e-2,
                "rotors' inertias, kg·m²",
            ),
            (
                "arm_m",
                self.arm_m,
                Positive,
                1e-3,
                1.0,
                "arms from shaft to probe, m",
            ),
            (
                "static_friction_nm",
                self.static_friction_nm,
                NotNegative,
                0.0,
                1.0,
                "a small motor's stiction, N·m",
            ),
            (
                "viscous_nm_s_per_rad",
                self.viscous_nm_s_per_rad,
                NotNegative,
                0.0,
                1.0,
                "a small motor's viscous friction, N·m·s/rad",
            ),
            (
                "beam_stiffness_n_per_m",
                self.beam_stiffness_n_per_m,
                Positive,
                1.0,
                1e7,
                "gauge beams' stiffnesses, N/m",
            ),
            (
                "tip_mass_kg",
                self.tip_mass_kg,
                Positive,
                1e-5,
                1.0,
                "tips and probes, kg",
            ),
            (
                "beam_damping_ratio",
                self.beam_damping_ratio,
                NotNegative,
                0.0,
                1.0,
                "a beam's damping ratio",
            ),
            (
                "indentation_mm_per_100pct",
                self.indentation_mm_per_100pct,
                Positive,
                0.1,
                100.0,
                "a skin's thickness, mm",
            ),
            (
                "contact_loss_factor",
                self.contact_loss_factor,
                NotNegative,
                0.0,
                2.0,
                "rubbers' loss factors",
            ),
            (
                "gauge_g_per_v",
                self.gauge_g_per_v,
                Positive,
                0.01,
                1e4,
                "strain-gauge scales, g/V",
            ),
            (
                "gauge_noise_g",
                self.gauge_noise_g,
                NotNegative,
                0.01,
                10.0,
                "a gauge's noise, g RMS (a converter's code at least; a reading that never \
                 moves is what the supervisor takes for a stuck gauge)",
            ),
        ]
    }

    /// Checks that the rig can exist: every value finite, masses, stiffnesses, gains and the
    /// arm positive, losses and friction not negative, each within a range any bench
    /// applicator is in (out of it, a unit slipped: a file with a gauge of 1e300 g/V ran, and its
    /// record read −inf), and the beam's mode under [`MAX_BEAM_HZ`].
    pub fn validate(&self) -> Result<(), ApplicatorError> {
        use Sign::{NotNegative, Positive};
        let fields = self.field_ranges();
        // The positive fields first, then the others (the order a file's errors are named in).
        for (name, value, ..) in fields.iter().filter(|f| f.2 == Positive) {
            if !(value.is_finite() && *value > 0.0) {
                return Err(ApplicatorError::NotPositive {
                    name,
                    value: *value,
                });
            }
        }
        for (name, value, ..) in fields.iter().filter(|f| f.2 == NotNegative) {
            if !(value.is_finite() && *value >= 0.0) {
                return Err(ApplicatorError::Negative {
                    name,
                    value: *value,
                });
            }
        }
        for (name, value, _, lo, hi, what) in fields {
            if !(lo..=hi).contains(&value) {
                return Err(ApplicatorError::Implausible {
                    name,
                    value,
                    lo,
                    hi,
                    what,
                });
            }
        }
        // NOTE: the simulator integrates at 10 kHz (RK4, within 0.01 g to 1 kHz): a lighter tip
        // or a stiffer beam rings past what it resolves, and past anything a 1 kHz loop sees.
        let beam_hz =
            libm::sqrt(self.beam_stiffness_n_per_m / self.tip_mass_kg) / core::f64::consts::TAU;
        if beam_hz > MAX_BEAM_HZ {
            return Err(ApplicatorError::BeamTooFast { hz: beam_hz });
        }
        Ok(())
    }

    /// Grams at the probe per volt into the amplifier (memo: 19.2).
    pub fn drive_g_per_v(&self) -> f64 {
        self.amplifier_a_per_v * self.torque_constant_nm_per_a / self.arm_m / NEWTONS_PER_GRAM
    }

    /// Contact dashpot (N·s/m) for a contact carrying `spring_g` at `compression_pct`.
    pub fn contact_damping_n_s_per_m(&self, spring_g: f64, compression_pct: f64) -> f64 {
        let c = Contact::new(self, SpringLaw::constant(1.0), 0.0);
        spring_g / compression_pct * c.damping_s_pct_per_m * NEWTONS_PER_GRAM
    }

    fn motor_mass_kg(&self) -> f64 {
        self.motor_inertia_kg_m2 / (self.arm_m * self.arm_m)
    }

    /// The fields in the file's order.
    fn fields(&self) -> [f64; APPLICATOR_FIELDS] {
        [
            self.amplifier_a_per_v,
            self.amplifier_pole_hz,
            self.torque_constant_nm_per_a,
            self.motor_inertia_kg_m2,
            self.arm_m,
            self.static_friction_nm,
            self.viscous_nm_s_per_rad,
            self.beam_stiffness_n_per_m,
            self.tip_mass_kg,
            self.beam_damping_ratio,
            self.indentation_mm_per_100pct,
            self.contact_loss_factor,
            self.gauge_g_per_v,
            self.gauge_noise_g,
        ]
    }

    /// The applicator in the form the firmware-in-the-loop build reads at start-up
    /// (`boards/qemu-netduinoplus2/run.sh OUT applicator=FILE.toml` writes it with `tactile
    /// applicator`): [`APPLICATOR_MAGIC`], [`APPLICATOR_VERSION`] (u16), two zero bytes, the
    /// fields as f64 in the file's order, then the CRC-32 (IEEE) of everything before it; all
    /// little-endian.
    pub fn encode(&self) -> [u8; APPLICATOR_BYTES] {
        let mut out = [0u8; APPLICATOR_BYTES];
        for (k, v) in self.fields().iter().enumerate() {
            out[8 + 8 * k..16 + 8 * k].copy_from_slice(&v.to_le_bytes());
        }
        tactile_core::seal::seal(&mut out, APPLICATOR_MAGIC, APPLICATOR_VERSION);
        out
    }

    /// Reads [`Self::encode`]'s bytes, checked as a table is: length, magic, version, CRC,
    /// then [`Self::validate`].
    pub fn decode(bytes: &[u8]) -> Result<ApplicatorParams, ApplicatorError> {
        use tactile_core::seal::{bytes_at, check_crc, check_head};
        let all = bytes
            .get(..APPLICATOR_BYTES)
            .ok_or(ApplicatorError::TooShort {
                bytes: bytes.len(),
                needed: APPLICATOR_BYTES,
            })?;
        check_head(all, APPLICATOR_MAGIC, APPLICATOR_VERSION)?;
        check_crc(all, APPLICATOR_BYTES)?;
        let f = |k: usize| f64::from_le_bytes(bytes_at(all, 8 + 8 * k));
        let params = ApplicatorParams {
            amplifier_a_per_v: f(0),
            amplifier_pole_hz: f(1),
            torque_constant_nm_per_a: f(2),
            motor_inertia_kg_m2: f(3),
            arm_m: f(4),
            static_friction_nm: f(5),
            viscous_nm_s_per_rad: f(6),
            beam_stiffness_n_per_m: f(7),
            tip_mass_kg: f(8),
            beam_damping_ratio: f(9),
            indentation_mm_per_100pct: f(10),
            contact_loss_factor: f(11),
            gauge_g_per_v: f(12),
            gauge_noise_g: f(13),
        };
        params.validate()?;
        Ok(params)
    }
}

/// The sign a field must have.
#[derive(Clone, Copy, PartialEq)]
enum Sign {
    Positive,
    NotNegative,
}

/// Fields of an applicator.
const APPLICATOR_FIELDS: usize = 14;
/// The highest beam mode (tip alone on the beam) the simulator takes, Hz.
pub const MAX_BEAM_HZ: f64 = 1000.0;
/// The first bytes of [`ApplicatorParams::encode`]'s form.
pub const APPLICATOR_MAGIC: [u8; 4] = *b"TAPP";
/// Version 2 added the gauge's scale and noise.
pub const APPLICATOR_VERSION: u16 = 2;
/// Bytes of [`ApplicatorParams::encode`]'s form.
pub const APPLICATOR_BYTES: usize = 8 + 8 * APPLICATOR_FIELDS + 4;

impl From<tactile_core::seal::SealError> for ApplicatorError {
    fn from(e: tactile_core::seal::SealError) -> Self {
        use tactile_core::seal::SealError;
        match e {
            SealError::TooShort { bytes, needed } => ApplicatorError::TooShort { bytes, needed },
            SealError::BadMagic => ApplicatorError::BadMagic,
            SealError::UnsupportedVersion { found } => {
                ApplicatorError::UnsupportedVersion { found }
            }
            SealError::Checksum { stored, computed } => {
                ApplicatorError::Checksum { stored, computed }
            }
        }
    }
}

/// Why an applicator's parameters describe no rig.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum ApplicatorError {
    #[error("{name} = {value:e}: outside {lo:e}…{hi:e}, the range of {what}")]
    Implausible {
        name: &'static str,
        value: f64,
        lo: f64,
        hi: f64,
        what: &'static str,
    },
    #[error("the beam with the tip alone rings at {hz:.0} Hz, over {MAX_BEAM_HZ} Hz: the simulator (10 kHz steps) does not resolve it; a stiffer beam wants a heavier tip")]
    BeamTooFast { hz: f64 },
    #[error("{name} = {value}: must be a finite number above zero")]
    NotPositive { name: &'static str, value: f64 },
    #[error("{name} = {value}: must be a finite number, zero or more")]
    Negative { name: &'static str, value: f64 },
    #[error("{bytes} bytes: an applicator's form has {needed}")]
    TooShort { bytes: usize, needed: usize },
    #[error("not an applicator (its first bytes are not \"TAPP\")")]
    BadMagic,
    #[error("applicator form version {found}; this build reads version {APPLICATOR_VERSION}")]
    UnsupportedVersion { found: u16 },
    #[error("damaged: CRC {stored:#010x} stored, {computed:#010x} computed")]
    Checksum { stored: u32, computed: u32 },
}

/// The applicator's state (tip-referred motor coordinates).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ApplicatorState {
    pub current_a: f64,
    /// Motor side of the beam, rθ, in metres (positive toward the finger).
    pub motor_m: f64,
    pub motor_m_per_s: f64,
    /// Probe tip, metres from the finger's undeformed surface (positive = indenting).
    pub tip_m: f64,
    pub tip_m_per_s: f64,
    /// Static friction holds the motor.
    pub stuck: bool,
}

/// What the finger presents to the probe during a plant step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// G₁ spring law of the element under the probe.
    pub spring: SpringLaw,
    /// The finger surface's rest strain (viscoelastic states), percent.
    pub rest_strain_pct: f64,
    /// Probe strain per metre of tip travel.
    strain_pct_per_m: f64,
    /// Dashpot per unit secant stiffness: grams per (g/%) per (m/s).
    damping_s_pct_per_m: f64,
}

impl Contact {
    pub fn new(p: &ApplicatorParams, spring: SpringLaw, rest_strain_pct: f64) -> Self {
        let strain_pct_per_m = 100.0 / (p.indentation_mm_per_100pct * 1e-3);
        let omega = 2.0 * core::f64::consts::PI * 50.0;
        Self {
            spring,
            rest_strain_pct,
            strain_pct_per_m,
            damping_s_pct_per_m: p.contact_loss_factor * strain_pct_per_m / omega,
        }
    }
}

impl ApplicatorState {
    /// Beam force read by the strain gauge, grams.
    pub fn gauge_force_g(&self, p: &ApplicatorParams) -> f64 {
        p.beam_stiffness_n_per_m * (self.motor_m - self.tip_m) / NEWTONS_PER_GRAM
    }
}

impl Contact {
    /// Contact force (grams) with the tip at `tip_m` moving at `tip_m_per_s`; zero when lifted
    /// off (the dashpot cannot pull).
    #[inline]
    pub fn force_g(&self, tip_m: f64, tip_m_per_s: f64) -> f64 {
        let compression = tip_m * self.strain_pct_per_m - self.rest_strain_pct;
        if compression <= 0.0 {
            0.0
        } else {
            let spring_g = self.spring.stress_g(compression);
            let damping_g = spring_g / compression * self.damping_s_pct_per_m * tip_m_per_s;
            (spring_g + damping_g).max(0.0)
        }
    }
}

/// Tip-referred constants of the applicator for a fixed step, computed once per run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lumped {
    params: ApplicatorParams,
    dt_s: f64,
    inv_m_motor: f64,
    inv_m_tip: f64,
    motor_n_per_a: f64,
    friction_n: f64,
    viscous_n_s_per_m: f64,
    beam_damping: f64,
    /// The amplifier is linear and driven only by its input: its current is advanced exactly,
    /// with these decays over a half and a whole step.
    amp_decay_half: f64,
    amp_decay_full: f64,
}

impl Lumped {
    pub fn new(p: &ApplicatorParams, dt_s: f64) -> Self {
        let amp_rate = 2.0 * core::f64::consts::PI * p.amplifier_pole_hz;
        Self {
            params: *p,
            dt_s,
            inv_m_motor: 1.0 / p.motor_mass_kg(),
            inv_m_tip: 1.0 / p.tip_mass_kg,
            motor_n_per_a: p.torque_constant_nm_per_a / p.arm_m,
            friction_n: p.static_friction_nm / p.arm_m,
            viscous_n_s_per_m: p.viscous_nm_s_per_rad / (p.arm_m * p.arm_m),
            beam_damping: 2.0
                * p.beam_damping_ratio
                * libm::sqrt(p.beam_stiffness_n_per_m * p.tip_mass_kg),
            amp_decay_half: libm::exp(-amp_rate * dt_s / 2.0),
            amp_decay_full: libm::exp(-amp_rate * dt_s),
        }
    }

    /// The step this was built for.
    pub fn dt_s(&self) -> f64 {
        self.dt_s
    }
}

/// One integration step of `dt_s` with amplifier input `drive_v` held.
pub fn step(
    p: &ApplicatorParams,
    s: &mut ApplicatorState,
    contact: &Contact,
    drive_v: f64,
    dt_s: f64,
) {
    step_lumped(&Lumped::new(p, dt_s), s, contact, drive_v);
}

/// One step of `l.dt_s()`: the amplifier current advanced exactly, the mechanics by fourth-order
/// Runge–Kutta, with Karnopp stick/slip decided at the step boundaries.
#[inline]
pub fn step_lumped(l: &Lumped, s: &mut ApplicatorState, contact: &Contact, drive_v: f64) {
    let p = &l.params;
    let dt_s = l.dt_s;
    let kb = p.beam_stiffness_n_per_m;
    let beam_n = |x: &[f64; 4]| kb * (x[0] - x[2]) + l.beam_damping * (x[1] - x[3]);
    let x0 = [s.motor_m, s.motor_m_per_s, s.tip_m, s.tip_m_per_s];

    // Current at the start, middle and end of the step (exact first-order response).
    let i_ss = p.amplifier_a_per_v * drive_v;
    let currents = [
        s.current_a,
        i_ss + (s.current_a - i_ss) * l.amp_decay_half,
        i_ss + (s.current_a - i_ss) * l.amp_decay_full,
    ];

    // Stick/slip decision at the start of the step.
    let drive0 = l.motor_n_per_a * s.current_a - beam_n(&x0);
    if l.friction_n <= 0.0 || drive0.abs() > l.friction_n {
        s.stuck = false;
    }
    let stuck = s.stuck;
    let slip_direction = if s.motor_m_per_s != 0.0 {
        s.motor_m_per_s.signum()
    } else {
        drive0.signum()
    };
    let friction = l.friction_n * slip_direction;

    let deriv = |x: &[f64; 4], current_a: f64| -> [f64; 4] {
        let fb = beam_n(x);
        let (dxm, dvm) = if stuck {
            (0.0, 0.0)
        } else {
            (
                x[1],
                (l.motor_n_per_a * current_a - fb - friction - l.viscous_n_s_per_m * x[1])
                    * l.inv_m_motor,
            )
        };
        let fc = contact.force_g(x[2], x[3]) * NEWTONS_PER_GRAM;
        [dxm, dvm, x[3], (fb - fc) * l.inv_m_tip]
    };
    let add = |a: &[f64; 4], k: &[f64; 4], h: f64| -> [f64; 4] {
        [
            a[0] + h * k[0],
            a[1] + h * k[1],
            a[2] + h * k[2],
            a[3] + h * k[3],
        ]
    };
    let [i_start, i_mid, i_end] = currents;
    let k1 = deriv(&x0, i_start);
    let k2 = deriv(&add(&x0, &k1, dt_s / 2.0), i_mid);
    let k3 = deriv(&add(&x0, &k2, dt_s / 2.0), i_mid);
    let k4 = deriv(&add(&x0, &k3, dt_s), i_end);
    let mut x = x0;
    for (i, xi) in x.iter_mut().enumerate() {
        *xi += dt_s / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    // Kinetic friction may not reverse the motion: when the velocity changes sign and the drive
    // cannot overcome static friction, the motor sticks.
    if l.friction_n > 0.0 && !stuck && x[1] * slip_direction <= 0.0 {
        let drive = l.motor_n_per_a * i_end - beam_n(&x);
        if drive.abs() <= l.friction_n {
            x[1] = 0.0;
            s.stuck = true;
        }
    }
    s.current_a = i_end;
    [s.motor_m, s.motor_m_per_s, s.tip_m, s.tip_m_per_s] = x;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_applicators_form_reads_back_and_refuses_damage() {
        let heavy = ApplicatorParams {
            motor_inertia_kg_m2: 2.0 * ApplicatorParams::MEMO.motor_inertia_kg_m2,
            beam_stiffness_n_per_m: 1234.5,
            ..ApplicatorParams::MEMO
        };
        for p in [ApplicatorParams::MEMO, heavy] {
            assert_eq!(ApplicatorParams::decode(&p.encode()), Ok(p));
        }
        let bytes = heavy.encode();
        let mut flipped = bytes;
        flipped[8 + 8 * 7] ^= 0x01;
        assert!(matches!(
            ApplicatorParams::decode(&flipped),
            Err(ApplicatorError::Checksum { .. })
        ));
        assert_eq!(
            ApplicatorParams::decode(&bytes[..50]),
            Err(ApplicatorError::TooShort {
                bytes: 50,
                needed: APPLICATOR_BYTES
            })
        );
        let mut foreign = bytes;
        foreign[..4].copy_from_slice(b"TCAL");
        assert_eq!(
            ApplicatorParams::decode(&foreign),
            Err(ApplicatorError::BadMagic)
        );
        // A rig that cannot exist, its CRC right: refused by the same check as the file.
        let impossible = ApplicatorParams {
            tip_mass_kg: -1.0,
            ..ApplicatorParams::MEMO
        };
        assert_eq!(
            ApplicatorParams::decode(&impossible.encode()),
            Err(ApplicatorError::NotPositive {
                name: "tip_mass_kg",
                value: -1.0
            })
        );
    }

    #[test]
    fn memo_force_per_volt_is_19_2_g() {
        assert!((ApplicatorParams::MEMO.drive_g_per_v() - 19.21).abs() < 0.01);
    }

    fn linear_contact(g1: f64) -> Contact {
        Contact::new(&ApplicatorParams::MEMO, SpringLaw::constant(g1), 0.0)
    }

    /// Settles at the force the amplifier commands: a step of 2.6 V is 50 g at the probe, once
    /// friction lets go (the static error is within the ±1.1 g friction band).
    #[test]
    fn static_force_equals_commanded_torque_within_friction() {
        let p = ApplicatorParams::MEMO;
        let contact = linear_contact(4.0);
        let mut s = ApplicatorState {
            stuck: true,
            ..Default::default()
        };
        let volts = 50.0 / p.drive_g_per_v();
        for _ in 0..50_000 {
            step(&p, &mut s, &contact, volts, 1e-4);
        }
        let f = s.gauge_force_g(&p);
        assert!((f - 50.0).abs() <= 1.15, "{f}");
        let fc = contact.force_g(s.tip_m, 0.0);
        assert!((fc - f).abs() < 0.01, "contact {fc} vs gauge {f}");
    }

    /// RK4 at 10 kHz against the same run at 80 kHz: the step response of the lightly damped
    /// applicator agrees within 0.01 g over half a second without friction. Stick/slip events
    /// are resolved to the step, a first-order error: within 0.2 g with the memo's friction
    /// (below the gauge's 0.4 g per-sample noise).
    #[test]
    fn integration_error_at_10_khz_is_below_0_01_g() {
        for friction in [0.0, ApplicatorParams::MEMO.static_friction_nm] {
            integration_error_with_friction(friction);
        }
    }

    fn integration_error_with_friction(static_friction_nm: f64) {
        let p = ApplicatorParams {
            static_friction_nm,
            ..ApplicatorParams::MEMO
        };
        let contact = Contact::new(
            &p,
            tactile_core::viscoelastic::NonlinearMk::ELEMENT_4_2.g1,
            0.0,
        );
        let volts = 30.0 / p.drive_g_per_v();
        let run = |substeps: usize| {
            let mut s = ApplicatorState::default();
            let dt = 1e-4 / substeps as f64;
            (0..5000)
                .map(|_| {
                    for _ in 0..substeps {
                        step(&p, &mut s, &contact, volts, dt);
                    }
                    s.gauge_force_g(&p)
                })
                .collect::<Vec<_>>()
        };
        let coarse = run(1);
        let fine = run(8);
        let worst = coarse
            .iter()
            .zip(&fine)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let bound = if static_friction_nm > 0.0 { 0.2 } else { 0.01 };
        assert!(
            worst < bound,
            "worst {worst} g with friction {static_friction_nm} N·m"
        );
        // And the run is a real oscillation, not a trivial one: it overshoots 30 g.
        assert!(fine.iter().cloned().fold(0.0, f64::max) > 35.0);
    }

    #[test]
    fn lifted_probe_has_no_contact_force() {
        let contact = linear_contact(4.0);
        assert_eq!(contact.force_g(-0.001, 0.0), 0.0);
        // 0.9 mm indentation is 10 % strain: 40 g on a 4 g/% spring.
        assert!((contact.force_g(0.9e-3, 0.0) - 40.0).abs() < 1e-9);
    }
}
