//! Command profiles: the memo's protocols as setpoint generators, shared by the firmware's
//! command source and the simulator's scenarios. Stateful (the pseudo-random protocol draws
//! its steps as time advances) but allocation-free; same seed, same sequence on every target.

use rand_xoshiro::rand_core::{RngCore, SeedableRng};
use rand_xoshiro::Xoshiro128PlusPlus;

/// Frequencies of the memo's sum-of-sinusoids excitation (section 4), Hz.
pub const SINES_HZ: [f32; 6] = [0.017, 0.062, 0.23, 0.79, 1.9, 5.0];

/// The protocols. Times in seconds, forces in grams.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Protocol {
    /// Appendix A Fig. a/b: `increment_g` steps up to `top_g` and back down, each held `hold_s`.
    ForceSteps {
        increment_g: f32,
        top_g: f32,
        hold_s: f32,
    },
    /// One step load: `lead_s` at zero, `load_g` for `on_s`, then zero for `off_s`.
    Step {
        load_g: f32,
        lead_s: f32,
        on_s: f32,
        off_s: f32,
    },
    /// Step loads of 10, 30, 50 and 80 g, each 50 s on and 25 s off.
    StepLoads,
    /// Graph 1: loads of 10..=100 g in 10 g increments, each held `hold_s` then 19 s rest.
    StaticLinearity { hold_s: f32 },
    /// Graph 5: 50 g for 20 s then 80 s rest, then 100 g for 20 s then 80 s rest.
    PermanentDeformation,
    /// Graph 6: `count` loads of `load_g`, `on_s` on and `off_s` off.
    RepeatedSteps {
        load_g: f32,
        on_s: f32,
        off_s: f32,
        count: u16,
    },
    /// Graph 3: `offset_g` plus a sine of `amplitude_g` swept exponentially from `f0_hz` to
    /// `f1_hz` over `duration_s`.
    Sweep {
        offset_g: f32,
        amplitude_g: f32,
        f0_hz: f32,
        f1_hz: f32,
        duration_s: f32,
    },
    /// Table III: steps at random times (dwell uniform in `dwell_min_s..dwell_max_s`), each change
    /// uniform in ±`max_change_g`, reflected into `min_g..=max_g`.
    PseudoRandom {
        seed: u64,
        min_g: f32,
        max_g: f32,
        max_change_g: f32,
        dwell_min_s: f32,
        dwell_max_s: f32,
        duration_s: f32,
    },
    /// Section 4: `offset_g` plus six sinusoids of `amplitude_g` at [`SINES_HZ`], random phases.
    Sines {
        seed: u64,
        offset_g: f32,
        amplitude_g: f32,
        duration_s: f32,
    },
    /// A bench record like `../shared/data`'s: 80 s of the memo's sum of sinusoids about
    /// 25 g, 80 s of pseudo-random steps in 40–60 g, 20 s at rest.
    BenchRecord { seed: u64 },
    /// Dynamic calibration of one taxel: [`CALIBRATION_REST_S`] at rest (the strain
    /// there is the taxel's offset), then the memo's sum of sinusoids about each of
    /// [`CALIBRATION_OFFSETS_G`] in turn, `per_offset_s` each, the sinusoids' amplitude
    /// [`CALIBRATION_AMPLITUDE`] of the offset (so the load never leaves the finger), slewed
    /// from one offset to the next; then [`CALIBRATION_HOLD_G`] held [`CALIBRATION_HOLD_S`]
    /// and [`CALIBRATION_RECOVERY_S`] at rest (the hold's creep and the recovery tell the
    /// permanent deformation from the Kelvin branch's: a minute of sinusoids alone left them
    /// interchangeable, and records of minutes at 80 g wrong by grams).
    Calibration { seed: u64, per_offset_s: f32 },
    /// Commands below 10 g (where the memo's fixed-gain loop lost contact): 8, 6, 4 and 2 g,
    /// each applied from rest (1 s at zero) and held `hold_s`.
    LowForce { hold_s: f32 },
    /// Identification of the applicator: the command ramps to `preload_g` and holds
    /// it, the loop keeping the probe on the finger; after [`EXCITATION_SETTLE_S`] the drive
    /// gets `periods` periods of a chirp of `amplitude_g` added after the loop's filter
    /// ([`CommandSource::chirp`]), sweeping linearly from [`EXCITATION_START_HZ`]
    /// to [`EXCITATION_END_HZ`] in [`EXCITATION_PERIOD_S`]: periodic, so each period's
    /// spectrum has every whole hertz of the band and no leakage. Its amplitude rises above
    /// [`EXCITATION_KNEE_HZ`] (the response is a ratio: the shape of the drive drops out).
    Excitation {
        preload_g: f32,
        amplitude_g: f32,
        periods: u16,
    },
}

/// Ramp and hold before the excitation's chirps, s.
pub const EXCITATION_SETTLE_S: f32 = 1.5;
/// Run on after the last period, s: a record that loses its last tick (a firmware log has no
/// readings for it) keeps its last whole period.
pub const EXCITATION_TAIL_S: f32 = 0.01;
/// One chirp, s (the frequency resolution of the response: 1 Hz).
pub const EXCITATION_PERIOD_S: f32 = 1.0;
/// The chirp's start and end, Hz: whole cycles in a period (1 + 150), so it repeats seamlessly;
/// past the beam modes of lighter rigs (near 250 Hz) and under the loop's Nyquist rate.
pub const EXCITATION_START_HZ: f32 = 1.0;
pub const EXCITATION_END_HZ: f32 = 301.0;
/// Above this the chirp's amplitude rises with its frequency, Hz, up to
/// [`EXCITATION_RISE_MAX`] times the protocol's: the amplifier's pole and the motor's stiction
/// take the torque of a flat chirp below what slides the motor at high frequency, and the
/// response read there was the friction's, not the plant's. Measured (`cargo run --release -p
/// sim-host --example design_controller FILE`): on the memo's rig with an 80 Hz amplifier and
/// 1.5× the stiction a flat chirp read the response 20 dB low at random phase from 55 Hz, and
/// the fits put the amplifier's pole at 29 Hz with a 2.4 ms lead (102 % RMS): the loop built
/// on them peaked +6.2 dB at 40 Hz and overshot a 20 g step by 2.4 g. Rising, the pole fits at
/// 67–73 Hz (42–17 % RMS); the memo rig's fits went from 54–23 % to 38–10 % RMS.
pub const EXCITATION_KNEE_HZ: f32 = 60.0;
/// The most the chirp's amplitude rises: more, the light rig's beam mode near 260 Hz moved the
/// gauge by over 40 g in a tick (the supervisor's implausible slew) at 10–35 g.
pub const EXCITATION_RISE_MAX: f32 = 3.0;

/// Preloads the applicator is identified at for the controller's design, g
/// ([`Protocol::design_excitation`]).
pub const DESIGN_PRELOADS_G: [f32; 6] = [10.0, 20.0, 35.0, 50.0, 75.0, 100.0];

/// Load levels the dynamic calibration excites, grams (the scheduled inverse's table).
pub const CALIBRATION_OFFSETS_G: [f32; 4] = [12.0, 25.0, 45.0, 70.0];
/// Rest at the start of the calibration protocol, s: the strain there is the offset.
pub const CALIBRATION_REST_S: f32 = 2.0;
/// Hold after the last level, g (the top of the memo's step loads).
pub const CALIBRATION_HOLD_G: f32 = 80.0;
/// How long the hold lasts, s: creep at a steady load, the permanent deformation's rate.
pub const CALIBRATION_HOLD_S: f32 = 20.0;
/// Rest at the end of the calibration protocol, s: the recovery after the loads (40 s: the
/// Kelvin branch, about 30 s unloaded, mostly recovers; the permanent deformation does not).
pub const CALIBRATION_RECOVERY_S: f32 = 40.0;
/// Each sinusoid's amplitude as a fraction of its offset (the memo: 4 g at 25 g).
pub const CALIBRATION_AMPLITUDE: f32 = 0.12;

const STEP_LOADS_G: [f32; 4] = [10.0, 30.0, 50.0, 80.0];
const LOW_FORCE_G: [f32; 4] = [8.0, 6.0, 4.0, 2.0];

/// Command slew limit for step-like protocols, g/s (see `control::SlewLimiter`).
pub const STEP_SLEW_G_PER_S: f32 = 500.0;

impl Protocol {
    /// The slew limit the command source applies: steps are slewed at
    /// [`STEP_SLEW_G_PER_S`]; the sweep and the sinusoids pass unlimited.
    pub fn slew_limit_g_per_s(&self) -> f32 {
        match self {
            // The chirp reaches 200 Hz (its own ramp to the preload is gentle).
            Protocol::Sweep { .. } | Protocol::Sines { .. } | Protocol::Excitation { .. } => {
                f32::INFINITY
            }
            // The sinusoids pass; the pseudo-random steps are slewed like any step.
            Protocol::BenchRecord { .. } => STEP_SLEW_G_PER_S,
            _ => STEP_SLEW_G_PER_S,
        }
    }

    pub const PSEUDO_RANDOM_MEMO: Protocol = Protocol::pseudo_random_memo(1989, 100.0);
    /// [`Self::PSEUDO_RANDOM_MEMO`] with another seed and length.
    pub const fn pseudo_random_memo(seed: u64, duration_s: f32) -> Protocol {
        Protocol::PseudoRandom {
            seed,
            min_g: 20.0,
            max_g: 40.0,
            max_change_g: 20.0,
            dwell_min_s: 2.0,
            dwell_max_s: 8.0,
            duration_s,
        }
    }
    /// The calibration run of the firmware and the simulator: 15 s about each offset.
    pub const CALIBRATION: Protocol = Protocol::Calibration {
        seed: 17,
        per_offset_s: 15.0,
    };
    pub const SINES_MEMO: Protocol = Protocol::Sines {
        seed: 138,
        offset_g: 25.0,
        amplitude_g: 4.0,
        duration_s: 100.0,
    };
    /// The applicator's identification about 50 g: a 5 g chirp on the drive, 24 periods.
    pub const EXCITATION_MEMO: Protocol = Protocol::Excitation {
        preload_g: 50.0,
        amplitude_g: 5.0,
        periods: 24,
    };
    /// The excitation at one of the design's preloads ([`DESIGN_PRELOADS_G`]): a chirp of 0.4
    /// of the preload, at least 0.25 g and at most the memo protocol's 5 g (at a fifth, the
    /// 10 g fit had a gain of 0.60: the stiction), 8 periods. The firmware's identification
    /// session and the host's design run exactly these.
    pub const fn design_excitation(preload_g: f32) -> Protocol {
        Protocol::Excitation {
            preload_g,
            amplitude_g: (0.4 * preload_g).clamp(0.25, 5.0),
            periods: 8,
        }
    }
    pub const FORCE_STEPS_MEMO: Protocol = Protocol::ForceSteps {
        increment_g: 10.0,
        top_g: 100.0,
        hold_s: 0.5,
    };

    /// Length of the protocol.
    pub fn duration_s(&self) -> f32 {
        match *self {
            Protocol::ForceSteps {
                increment_g,
                top_g,
                hold_s,
            } => (2.0 * steps_to_top(increment_g, top_g) + 1.0) * hold_s,
            Protocol::Step {
                lead_s,
                on_s,
                off_s,
                ..
            } => lead_s + on_s + off_s,
            Protocol::StepLoads => STEP_LOADS_G.len() as f32 * 75.0 + 2.0,
            Protocol::StaticLinearity { hold_s } => 10.0 * (hold_s + 19.0) + 2.0,
            Protocol::PermanentDeformation => 2.0 + 2.0 * 100.0,
            Protocol::RepeatedSteps {
                on_s, off_s, count, ..
            } => 2.0 + f32::from(count) * (on_s + off_s),
            Protocol::Sweep { duration_s, .. } => duration_s + 2.0,
            Protocol::PseudoRandom { duration_s, .. } | Protocol::Sines { duration_s, .. } => {
                duration_s
            }
            Protocol::LowForce { hold_s } => LOW_FORCE_G.len() as f32 * (1.0 + hold_s),
            Protocol::Excitation { periods, .. } => {
                EXCITATION_SETTLE_S + f32::from(periods) * EXCITATION_PERIOD_S + EXCITATION_TAIL_S
            }
            Protocol::BenchRecord { .. } => 180.0,
            Protocol::Calibration { per_offset_s, .. } => {
                CALIBRATION_REST_S
                    + CALIBRATION_OFFSETS_G.len() as f32 * per_offset_s
                    + CALIBRATION_HOLD_S
                    + CALIBRATION_RECOVERY_S
            }
        }
    }

    /// The command of a protocol that is a function of time alone, within its duration (0 for
    /// the others, which [`CommandSource::command_g`] runs).
    fn timed_command_g(self, t_s: f32) -> f32 {
        match self {
            Protocol::ForceSteps {
                increment_g,
                top_g,
                hold_s,
            } => {
                let n = steps_to_top(increment_g, top_g);
                let k = libm::floorf(t_s / hold_s);
                let level = if k <= n { k } else { 2.0 * n - k };
                (level * increment_g).max(0.0)
            }
            Protocol::Step {
                load_g,
                lead_s,
                on_s,
                ..
            } if t_s >= lead_s && t_s < lead_s + on_s => load_g,
            Protocol::StepLoads => {
                let tt = t_s - 2.0;
                let k = libm::floorf(tt / 75.0);
                let within = tt - 75.0 * k;
                match STEP_LOADS_G.get(k as usize) {
                    Some(&g) if tt >= 0.0 && within < 50.0 => g,
                    _ => 0.0,
                }
            }
            Protocol::StaticLinearity { hold_s } => {
                let tt = t_s - 2.0;
                let period = hold_s + 19.0;
                let k = libm::floorf(tt / period);
                if tt >= 0.0 && tt - k * period < hold_s {
                    10.0 * (k + 1.0)
                } else {
                    0.0
                }
            }
            Protocol::PermanentDeformation => {
                let tt = t_s - 2.0;
                if (0.0..20.0).contains(&tt) {
                    50.0
                } else if (100.0..120.0).contains(&tt) {
                    100.0
                } else {
                    0.0
                }
            }
            Protocol::RepeatedSteps {
                load_g,
                on_s,
                off_s,
                ..
            } => {
                let tt = t_s - 2.0;
                let period = on_s + off_s;
                if tt >= 0.0 && tt - libm::floorf(tt / period) * period < on_s {
                    load_g
                } else {
                    0.0
                }
            }
            Protocol::Sweep {
                offset_g,
                amplitude_g,
                f0_hz,
                f1_hz,
                duration_s,
            } => {
                let tt = t_s - 2.0;
                if tt < 0.0 {
                    // Ramp to the offset first, so the sweep starts in contact.
                    return offset_g * t_s / 2.0;
                }
                // Exponential chirp: phase = 2π f0 T/ln(k) (k^(t/T) − 1), k = f1/f0.
                let ln_k = libm::logf(f1_hz / f0_hz);
                let phase = 2.0 * core::f32::consts::PI * f0_hz * duration_s / ln_k
                    * (libm::expf(ln_k * tt / duration_s) - 1.0);
                offset_g + amplitude_g * crate::trig::sinf(phase)
            }
            // Onto the finger in half of the settling time, then still.
            Protocol::Excitation { preload_g, .. } => {
                preload_g * (t_s / (0.5 * EXCITATION_SETTLE_S)).min(1.0)
            }
            Protocol::LowForce { hold_s } => {
                let period = 1.0 + hold_s;
                let k = libm::floorf(t_s / period);
                if t_s - k * period < 1.0 {
                    0.0
                } else {
                    LOW_FORCE_G.get(k as usize).copied().unwrap_or(0.0)
                }
            }
            _ => 0.0,
        }
    }
}

/// Runs a [`Protocol`]: call [`CommandSource::command_g`] with non-decreasing times.
#[derive(Clone, Debug)]
pub struct CommandSource {
    protocol: Protocol,
    rng: Xoshiro128PlusPlus,
    level_g: f32,
    next_change_s: f32,
    phases_rad: [f32; 6],
}

impl CommandSource {
    pub fn new(protocol: Protocol) -> Self {
        let seed = match protocol {
            Protocol::PseudoRandom { seed, .. }
            | Protocol::Sines { seed, .. }
            | Protocol::BenchRecord { seed }
            | Protocol::Calibration { seed, .. } => seed,
            _ => 0,
        };
        let mut rng = Xoshiro128PlusPlus::seed_from_u64(seed);
        let mut phases_rad = [0.0; 6];
        for p in phases_rad.iter_mut() {
            *p = 2.0 * core::f32::consts::PI * unit(&mut rng);
        }
        let level_g = match protocol {
            Protocol::PseudoRandom { min_g, max_g, .. } => 0.5 * (min_g + max_g),
            Protocol::BenchRecord { .. } => 50.0,
            _ => 0.0,
        };
        // The bench record's steps start after its 80 s of sinusoids.
        let next_change_s = if matches!(protocol, Protocol::BenchRecord { .. }) {
            80.0
        } else {
            0.0
        };
        Self {
            protocol,
            rng,
            level_g,
            next_change_s,
            phases_rad,
        }
    }

    pub fn protocol(&self) -> Protocol {
        self.protocol
    }

    /// Commanded force at time `t_s` (0 after the protocol ends).
    pub fn command_g(&mut self, t_s: f32) -> f32 {
        if !(0.0..self.protocol.duration_s()).contains(&t_s) {
            return 0.0;
        }
        match self.protocol {
            Protocol::PseudoRandom {
                min_g,
                max_g,
                max_change_g,
                dwell_min_s,
                dwell_max_s,
                ..
            } => {
                while t_s >= self.next_change_s {
                    let change = (2.0 * unit(&mut self.rng) - 1.0) * max_change_g;
                    self.level_g = reflect(self.level_g + change, min_g, max_g);
                    self.next_change_s +=
                        dwell_min_s + (dwell_max_s - dwell_min_s) * unit(&mut self.rng);
                }
                self.level_g
            }
            Protocol::Sines {
                offset_g,
                amplitude_g,
                ..
            } => self.sines(offset_g, amplitude_g, t_s),
            Protocol::BenchRecord { .. } => self.bench_record_g(t_s),
            Protocol::Calibration { per_offset_s, .. } => self.calibration_g(per_offset_s, t_s),
            timed => timed.timed_command_g(t_s),
        }
    }

    /// The bench record: sines, then pseudo-random steps, then rest.
    fn bench_record_g(&mut self, t_s: f32) -> f32 {
        if t_s < 80.0 {
            // Fade the excitation in over 2 s so the record starts at rest.
            let ramp = (t_s / 2.0).min(1.0);
            ramp * self.sines(25.0, 4.0, t_s)
        } else if t_s < 160.0 {
            while t_s >= self.next_change_s {
                let change = (2.0 * unit(&mut self.rng) - 1.0) * 20.0;
                self.level_g = reflect(self.level_g + change, 40.0, 60.0);
                self.next_change_s += 2.0 + 6.0 * unit(&mut self.rng);
            }
            self.level_g
        } else {
            0.0
        }
    }

    /// The calibration protocol: sines about each offset, then a hold.
    fn calibration_g(&mut self, per_offset_s: f32, t_s: f32) -> f32 {
        let t = t_s - CALIBRATION_REST_S;
        let k = libm::floorf(t / per_offset_s);
        match CALIBRATION_OFFSETS_G.get(k as usize) {
            Some(&offset) if t >= 0.0 => self.sines(offset, CALIBRATION_AMPLITUDE * offset, t_s),
            None if t - CALIBRATION_OFFSETS_G.len() as f32 * per_offset_s < CALIBRATION_HOLD_S => {
                CALIBRATION_HOLD_G
            }
            _ => 0.0,
        }
    }
}

/// One tick of the excitation's chirp: what the protocol adds to the drive is
/// [`Self::drive_g`] of the share of its rise the loop keeps (see
/// `ForceLoop::set_drive_excitation`: a rig whose beam rings harder than the memo's gets less
/// of it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChirpSample {
    /// The protocol's amplitude, g.
    pub amplitude_g: f32,
    /// How many times that the chirp has risen at this frequency (1 below
    /// [`EXCITATION_KNEE_HZ`], up to [`EXCITATION_RISE_MAX`]).
    pub rise: f32,
    /// The sine's value, −1 to 1.
    pub wave: f32,
}

impl ChirpSample {
    /// The drive, g, with `rise_share` of the rise above 1 kept (1: the whole, 0: flat); 0 for
    /// a sample that is not finite.
    pub fn drive_g(self, rise_share: f32) -> f32 {
        let g = self.amplitude_g * (1.0 + (self.rise - 1.0) * rise_share) * self.wave;
        if g.is_finite() {
            g
        } else {
            0.0
        }
    }
}

impl CommandSource {
    /// The excitation's chirp ([`Protocol::Excitation`]) at time `t_s` while it runs, added to
    /// the drive after the loop's filter while the loop's feedback is off (see
    /// `ForceLoop::set_drive_excitation`); `None` before and after it and for every other
    /// protocol.
    pub fn chirp(&self, t_s: f32) -> Option<ChirpSample> {
        let Protocol::Excitation { amplitude_g, .. } = self.protocol else {
            return None;
        };
        let t = t_s - EXCITATION_SETTLE_S;
        if t < 0.0 || t_s >= self.protocol.duration_s() {
            return None;
        }
        let tau = t - libm::floorf(t / EXCITATION_PERIOD_S) * EXCITATION_PERIOD_S;
        let sweep = EXCITATION_END_HZ - EXCITATION_START_HZ;
        let cycles = EXCITATION_START_HZ * tau + sweep * tau * tau / (2.0 * EXCITATION_PERIOD_S);
        // Whole cycles taken off before the sine: its argument stays small in f32.
        let phase = 2.0 * core::f32::consts::PI * (cycles - libm::floorf(cycles));
        let hz = EXCITATION_START_HZ + sweep * tau / EXCITATION_PERIOD_S;
        let rise = (hz / EXCITATION_KNEE_HZ).clamp(1.0, EXCITATION_RISE_MAX);
        Some(ChirpSample {
            amplitude_g,
            rise,
            wave: crate::trig::sinf(phase),
        })
    }

    fn sines(&self, offset_g: f32, amplitude_g: f32, t_s: f32) -> f32 {
        let mut f = offset_g;
        for (hz, phase) in SINES_HZ.iter().zip(self.phases_rad.iter()) {
            f += amplitude_g * crate::trig::sinf(2.0 * core::f32::consts::PI * hz * t_s + phase);
        }
        f.max(0.0)
    }
}

/// Uniform in [0, 1).
fn unit(rng: &mut Xoshiro128PlusPlus) -> f32 {
    (rng.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Folds `x` back into `[lo, hi]` at the edges.
fn reflect(x: f32, lo: f32, hi: f32) -> f32 {
    let r = if x > hi {
        2.0 * hi - x
    } else if x < lo {
        2.0 * lo - x
    } else {
        x
    };
    crate::limit(r, lo, hi)
}

/// The steps of `ForceSteps` from rest to its top (as many come down again).
fn steps_to_top(increment_g: f32, top_g: f32) -> f32 {
    libm::roundf(top_g / increment_g)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The source's command at each time in turn: exactly the force given with it, g.
    fn assert_commands(s: &mut CommandSource, expected: &[(f32, f32)]) {
        for &(t, g) in expected {
            assert_eq!(s.command_g(t), g, "at {t} s");
        }
    }

    #[test]
    fn force_steps_climb_and_descend_in_10_g_increments() {
        let mut s = CommandSource::new(Protocol::FORCE_STEPS_MEMO);
        assert_commands(
            &mut s,
            &[
                (0.1, 0.0),
                (0.6, 10.0),
                (5.2, 100.0),
                (5.6, 90.0),
                (10.4, 0.0),
            ],
        );
        assert!((Protocol::FORCE_STEPS_MEMO.duration_s() - 10.5).abs() < 1e-6);
    }

    #[test]
    fn the_excitation_holds_the_preload_and_chirps_the_drive() {
        let p = Protocol::Excitation {
            preload_g: 50.0,
            amplitude_g: 3.0,
            periods: 4,
        };
        assert!((p.duration_s() - 5.51).abs() < 1e-6);
        assert_eq!(p.slew_limit_g_per_s(), f32::INFINITY);
        let mut s = CommandSource::new(p);
        assert_eq!(s.command_g(0.0), 0.0);
        assert!((s.command_g(0.375) - 25.0).abs() < 1e-4);
        assert_eq!(s.command_g(1.0), 50.0);
        assert_eq!(s.command_g(3.3), 50.0);
        assert_eq!(s.chirp(1.0), None);
        // One period sampled at 1 kHz, twice: the same samples (periodic), within ±3 g below
        // the knee and ±9 g above it, mean 0.
        let period = |s: &CommandSource, start: f32| -> Vec<f32> {
            (0..1000)
                .map(|i| s.chirp(start + i as f32 * 1e-3).unwrap().drive_g(1.0))
                .collect()
        };
        let (a, b) = (period(&s, 2.5), period(&s, 3.5));
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 0.02, "{x} vs {y}");
            assert!(x.abs() <= 9.0 + 1e-3);
        }
        let below_knee = (EXCITATION_KNEE_HZ - EXCITATION_START_HZ) / 300.0;
        for (i, x) in a.iter().enumerate() {
            if (i as f32) < 1000.0 * below_knee {
                assert!(x.abs() <= 3.0 + 1e-4, "{i} ms: {x}");
            }
        }
        assert!(
            a.iter().any(|x| x.abs() > 8.5),
            "the amplitude rises to 9 g"
        );
        let mean = a.iter().sum::<f32>() / 1000.0;
        assert!(mean.abs() < 0.1, "{mean}");
        // By hand: 0.1 s into a period the chirp is at 1 + 300·0.1 = 31 Hz and has turned
        // 1·0.1 + 150·0.01 = 1.6 cycles: 3·sin(2π·0.6).
        let x = s.chirp(1.5 + 0.1).unwrap().drive_g(1.0);
        let expected = 3.0 * (2.0 * core::f32::consts::PI * 0.6).sin();
        assert!((x - expected).abs() < 1e-3, "{x} vs {expected}");
        // 0.3 s in: 91 Hz, 0.3 + 150·0.09 = 13.8 cycles, the amplitude 3·91/60.
        let x = s.chirp(1.5 + 0.3).unwrap().drive_g(1.0);
        let expected = 3.0 * 91.0 / 60.0 * (2.0 * core::f32::consts::PI * 0.8).sin();
        assert!((x - expected).abs() < 2e-3, "{x} vs {expected}");
        // The guard's share of the rise: half of it, 1 + ½(91/60 − 1); none, flat.
        let c = s.chirp(1.5 + 0.3).unwrap();
        let wave = (2.0 * core::f32::consts::PI * 0.8).sin();
        let half = 3.0 * (1.0 + 0.5 * (91.0 / 60.0 - 1.0)) * wave;
        assert!((c.drive_g(0.5) - half).abs() < 2e-3, "{c:?}");
        assert!((c.drive_g(0.0) - 3.0 * wave).abs() < 2e-3, "{c:?}");
        assert_eq!(s.chirp(5.6), None);
        assert_eq!(s.command_g(5.6), 0.0);
        // Every other protocol leaves the drive alone.
        assert_eq!(CommandSource::new(Protocol::CALIBRATION).chirp(10.0), None);
    }

    #[test]
    fn calibration_visits_each_offset_and_stays_on_the_finger() {
        let mut s = CommandSource::new(Protocol::CALIBRATION);
        assert!((Protocol::CALIBRATION.duration_s() - 122.0).abs() < 1e-6);
        // At rest first: the offset is measured there.
        assert_eq!(s.command_g(0.0), 0.0);
        assert_eq!(s.command_g(1.99), 0.0);
        for (k, offset) in CALIBRATION_OFFSETS_G.iter().enumerate() {
            let t0 = 2.0 + 15.0 * k as f32;
            let (mut sum, mut lo, mut hi) = (0.0f32, f32::MAX, f32::MIN);
            for i in 0..15_000 {
                let c = s.command_g(t0 + i as f32 * 1e-3);
                sum += c;
                lo = lo.min(c);
                hi = hi.max(c);
            }
            let mean = sum / 15_000.0;
            // Six sinusoids of 12 % of the offset: the mean near the offset, never off the
            // finger, never above the applicator's 120 g.
            assert!((mean - offset).abs() < 0.25 * offset, "{offset}: {mean}");
            assert!(lo > 0.0 && hi < 120.0, "{offset}: {lo}..{hi}");
            assert!(hi - lo > 0.5 * offset, "{offset}: {lo}..{hi}");
        }
        // The hold after the last level (62–82 s), then the recovery at rest to the end.
        let hold = CALIBRATION_HOLD_G;
        assert_commands(
            &mut s,
            &[
                (62.5, hold),
                (70.0, hold),
                (81.9, hold),
                (82.1, 0.0),
                (100.0, 0.0),
                (121.9, 0.0),
            ],
        );
    }

    #[test]
    fn step_loads_follow_the_memo_timing() {
        let mut s = CommandSource::new(Protocol::StepLoads);
        assert_commands(
            &mut s,
            &[
                (1.0, 0.0),
                (2.5, 10.0),
                (51.9, 10.0),
                (52.1, 0.0),
                (78.0, 30.0),
                (2.0 + 225.0 + 10.0, 80.0),
                (2.0 + 225.0 + 60.0, 0.0),
            ],
        );
    }

    #[test]
    fn pseudo_random_stays_in_band_changes_by_at_most_20_g_and_repeats() {
        let run = || {
            let mut s = CommandSource::new(Protocol::PSEUDO_RANDOM_MEMO);
            (0..100_000)
                .map(|k| s.command_g(k as f32 * 0.001))
                .collect::<Vec<_>>()
        };
        let a = run();
        assert_eq!(a, run());
        let mut changes = 0;
        for w in a.windows(2) {
            assert!((20.0..=40.0).contains(&w[1]));
            let d = (w[1] - w[0]).abs();
            assert!(d <= 20.0 + 1e-4);
            changes += usize::from(d > 0.0);
        }
        // Dwell 2–8 s over 100 s: between 12 and 50 changes.
        assert!((12..=50).contains(&changes), "{changes}");
    }

    #[test]
    fn sines_are_the_memo_excitation() {
        let mut s = CommandSource::new(Protocol::SINES_MEMO);
        let xs: Vec<f32> = (0..100_000)
            .map(|k| s.command_g(k as f32 * 0.001))
            .collect();
        let mean = xs.iter().sum::<f32>() / xs.len() as f32;
        // The slow 0.017 Hz component does not average out over 100 s; the mean is 25 ± 4.
        assert!((mean - 25.0).abs() < 4.0, "{mean}");
        let max = xs.iter().cloned().fold(f32::MIN, f32::max);
        assert!(max <= 25.0 + 24.0 + 1e-3);
    }

    #[test]
    fn reflect_folds_into_the_band() {
        assert_eq!(reflect(45.0, 20.0, 40.0), 35.0);
        assert_eq!(reflect(12.0, 20.0, 40.0), 28.0);
        assert_eq!(reflect(100.0, 20.0, 40.0), 20.0);
    }
}
