//! The closed loop: the core's A1 law, lowpass-notch filter, gauge path, scan sequencer, strain
//! conversion and inverse model, run at their firmware rates around the simulated applicator
//! and finger. The plant is integrated at 10 kHz (ten RK4 steps per 1 ms control tick; the
//! applicator tests check the step size).

use tactile_core::control::{ActuatorConfig, ForceLawConfig};
use tactile_core::filter::LowpassNotchConfig;
use tactile_core::gauge::{GaugeConfig, GaugeFault};
use tactile_core::supervisor::{ForceLoop, ForceLoopConfig, SupervisorConfig};
use tactile_core::tactile::{ScanSequencer, TaxelId, TAXELS};
use tactile_core::telemetry::FaultFlags;
use tactile_core::viscoelastic::{InverseEstimator, ModelError, SecondOrder};

use crate::applicator::ApplicatorParams;
use crate::finger::{code_to_strain_pct, Effects, ReadoutParams, StrainGrid};
use crate::hardware::SimHardware;

/// Plant steps per control tick.
pub const SUBSTEPS: usize = 10;
/// Control period (memo: Δt = 1 ms).
pub const TICK_S: f64 = 1e-3;

/// Everything a run is made of; `Default` is the memo's rig.
#[derive(Clone, Debug)]
pub struct RigConfig {
    pub seed: u64,
    pub law: ForceLawConfig,
    /// Command slew limit ahead of the law, g/s (scenarios take it from their protocol).
    pub command_slew_g_per_s: f32,
    pub filter: LowpassNotchConfig,
    pub gauge: GaugeConfig,
    pub actuator: ActuatorConfig,
    pub applicator: ApplicatorParams,
    /// Gauge noise per converter sample, grams RMS: 0.14 g after 8× averaging (misprint 2)
    /// is 0.14·√8 = 0.40 g per sample.
    pub gauge_noise_g: f64,
    pub effects: Effects,
    pub readout: ReadoutParams,
    pub probe: TaxelId,
    /// Model inverted on the chip to estimate force from the probed element's strain.
    pub estimator: SecondOrder,
    /// Run the 8×8 scan (off for speed when only the probed element matters).
    pub scan_array: bool,
    /// The force loop's fault thresholds.
    pub supervisor: SupervisorConfig,
    /// A fault to inject, and when.
    pub fault: Option<FaultInjection>,
}

/// Faults the simulator can inject into the rig.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InjectedFault {
    /// The gauge's converter reads its lower rail (a broken wire).
    GaugeDisconnected,
    /// The gauge's converter reads its upper rail.
    GaugeSaturated,
    /// The gauge's converter repeats the codes it had.
    GaugeStuck,
    /// One tick of a spike of this many grams on the gauge.
    ForceSpike { g: f32 },
    /// The finger surface drops away by this much strain (infinite: the finger is removed).
    ContactLost { strain_pct: f64 },
    /// One tick of a NaN command.
    CommandNan,
    /// The control task misses one deadline.
    DeadlineOverrun,
    /// A taxel reads its converter's rail from then on.
    TaxelOpen { index: usize },
}

impl InjectedFault {
    /// The names `tactile experiment --fault` takes.
    pub const NAMES: [&'static str; 8] = [
        "gauge-disconnected",
        "gauge-saturated",
        "gauge-stuck",
        "force-spike",
        "contact-lost",
        "command-nan",
        "deadline-overrun",
        "taxel-open",
    ];

    pub fn parse(name: &str) -> Option<InjectedFault> {
        Some(match name {
            "gauge-disconnected" => InjectedFault::GaugeDisconnected,
            "gauge-saturated" => InjectedFault::GaugeSaturated,
            "gauge-stuck" => InjectedFault::GaugeStuck,
            "force-spike" => InjectedFault::ForceSpike { g: 80.0 },
            "contact-lost" => InjectedFault::ContactLost {
                strain_pct: f64::INFINITY,
            },
            "command-nan" => InjectedFault::CommandNan,
            "deadline-overrun" => InjectedFault::DeadlineOverrun,
            "taxel-open" => InjectedFault::TaxelOpen { index: 3 * 8 + 3 },
            _ => return None,
        })
    }
}

/// A fault and the time it starts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultInjection {
    pub fault: InjectedFault,
    pub at_s: f64,
}

/// The error gain K_e the simulated rig runs with.
///
/// With the memo's filter (its Q = 2.8 section peaks near 27 Hz and reaches −180° near 31 Hz)
/// and K_p = 2, K_d = 0.03 s, the A1 loop is linearly unstable at 100 g on any plant whose gain
/// near 30 Hz is about one, which a 50 Hz inertia–finger resonance forces: the Nyquist plot of
/// the loop encircles −1 (see `loop_analysis` in the tests, and the README). Stability at every
/// load needs the overall feedback gain below about 0.17 at 100 g and 0.06 at 5 g for this plant;
/// K_e is the memo's own knob for that overall gain, so the simulator keeps A1's structure,
/// K_p, K_d and the filter, and sets K_e = 0.07 (gain margin 2.4 at 100 g; at 0.1 a 100 g step rings
/// at the edge of the ±1 g band for 0.13 s).
pub const SIM_ERROR_GAIN: f32 = 0.07;

impl Default for RigConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            law: ForceLawConfig {
                ke: SIM_ERROR_GAIN,
                ..ForceLawConfig::MEMO
            },
            command_slew_g_per_s: tactile_core::profile::STEP_SLEW_G_PER_S,
            filter: LowpassNotchConfig::MEMO,
            gauge: GaugeConfig::MEMO,
            actuator: ActuatorConfig::MEMO,
            applicator: ApplicatorParams::MEMO,
            gauge_noise_g: 0.14 * libm::sqrt(8.0),
            effects: Effects::MEMO,
            readout: ReadoutParams::default(),
            probe: crate::finger::NOMINAL_TAXEL,
            estimator: SecondOrder::MEMO_FIT,
            scan_array: true,
            supervisor: SupervisorConfig::DESIGN,
            fault: None,
        }
    }
}

/// What one control tick produced.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TickRecord {
    pub t_s: f64,
    pub command_g: f32,
    /// Force from the gauge path (the value the law uses next tick); on a gauge fault, the raw
    /// reading, with the fault flagged.
    pub sensed_g: f32,
    pub adjusted_g: f32,
    pub strain_pct: f32,
    pub estimate_g: f32,
    /// Simulator truth: the contact force at the end of the tick.
    pub true_force_g: f32,
    pub in_contact: bool,
    pub faults: FaultFlags,
    /// The code written to the actuator's DAC.
    pub dac_code: u16,
}

/// Why a rig could not be built.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RigError {
    Filter(tactile_core::filter::FilterError),
    /// A taxel index outside the array.
    Taxel(usize),
    Estimator(ModelError),
}

impl core::fmt::Display for RigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            RigError::Filter(e) => write!(f, "lowpass-notch filter configuration refused: {e:?}"),
            RigError::Taxel(i) => write!(f, "taxel {i} is outside the 8×8 array"),
            RigError::Estimator(e) => write!(f, "estimator model refused: {e:?}"),
        }
    }
}

impl core::error::Error for RigError {}

/// The closed-loop rig.
pub struct Rig {
    pub config: RigConfig,
    force_loop: ForceLoop,
    /// The simulated board: applicator, finger, converters (the firmware-in-the-loop build
    /// runs the same one).
    pub hardware: SimHardware,
    estimator: InverseEstimator,
    scan: ScanSequencer,
    frame: StrainGrid,
    last_gauge: Result<f32, GaugeFault>,
    tick: u64,
    /// Scan steps per control tick (dwell 250 µs → 4).
    scan_steps_per_tick: usize,
}

impl Rig {
    pub fn new(config: RigConfig) -> Result<Self, RigError> {
        let force_loop = ForceLoop::new(ForceLoopConfig {
            law: config.law,
            filter: config.filter,
            actuator: config.actuator,
            supervisor: config.supervisor,
            slew_g_per_s: config.command_slew_g_per_s,
        })
        .map_err(RigError::Filter)?;
        if let Some(FaultInjection {
            fault: InjectedFault::TaxelOpen { index },
            ..
        }) = config.fault
        {
            if index >= TAXELS {
                return Err(RigError::Taxel(index));
            }
        }
        let estimator = InverseEstimator::new(
            config
                .estimator
                .inverse(TICK_S)
                .map_err(RigError::Estimator)?,
        );
        let scan_steps_per_tick =
            libm::round(TICK_S / f64::from(config.readout.scan.dwell_s)).max(1.0) as usize;
        Ok(Self {
            force_loop,
            hardware: SimHardware::new(&config),
            estimator,
            scan: ScanSequencer::new(),
            frame: [[0.0; 8]; 8],
            last_gauge: Ok(0.0),
            tick: 0,
            scan_steps_per_tick,
            config,
        })
    }

    pub fn time_s(&self) -> f64 {
        self.tick as f64 * TICK_S
    }

    /// One control tick with command `command_g`; `on_frame` receives each completed 8×8 scan.
    pub fn tick(
        &mut self,
        command_g: f32,
        mut on_frame: impl FnMut(f64, &StrainGrid),
    ) -> TickRecord {
        let t_s = self.time_s();
        let fault_now = self
            .config
            .fault
            .filter(|f| f.active_in(t_s))
            .map(|f| f.fault);
        let first_fault_tick = self.config.fault.is_some_and(|f| f.starts_in(t_s));
        let command_in = if fault_now == Some(InjectedFault::CommandNan) && first_fault_tick {
            f32::NAN
        } else {
            command_g
        };
        let overrun = fault_now == Some(InjectedFault::DeadlineOverrun) && first_fault_tick;
        // Control: the core's force loop on the gauge reading of the last tick.
        let out = self.force_loop.tick(command_in, self.last_gauge, overrun);
        let mut faults = out.faults;
        let adjusted = out.adjusted_g;
        // The board: the DAC holds the code for the period, the plant runs, the converters
        // sample.
        self.hardware.write_dac(out.dac_code);
        self.hardware.advance_period();
        self.last_gauge = self
            .config
            .gauge
            .average_force(&self.hardware.gauge_codes());
        let t_end = t_s + TICK_S;
        let true_force = self.hardware.true_force_g();

        // The probed element's own channel, converted and inverted as on the chip.
        let probe = self.config.probe.index();
        let code = self.hardware.probe_code();
        let adc = self.config.readout.adc;
        let calibration = self.hardware.calibration();
        let strain = calibration
            .get(probe)
            .map_or(f32::NAN, |cal| code_to_strain_pct(&adc, cal, code));
        let estimate = self.estimator.force_g(strain);

        if self.config.scan_array {
            for _ in 0..self.scan_steps_per_tick {
                let sampled = self.scan.selected();
                let step = self.scan.advance();
                self.hardware.select_taxel(sampled);
                let code = self.hardware.sample_selected_taxel();
                // A taxel at a rail is open or shorted: marked bad (NaN) in the frame.
                let strain = if adc.at_rail(code) {
                    faults.insert(FaultFlags::TAXEL_AT_RAIL);
                    f32::NAN
                } else {
                    self.hardware
                        .calibration()
                        .get(sampled.index())
                        .map_or(f32::NAN, |c| code_to_strain_pct(&adc, c, code))
                };
                if let Some(cell) = self
                    .frame
                    .get_mut(sampled.row())
                    .and_then(|r| r.get_mut(sampled.col()))
                {
                    *cell = strain;
                }
                if step.frame_complete {
                    on_frame(t_end, &self.frame);
                }
            }
        }

        self.tick += 1;
        TickRecord {
            t_s: t_end,
            command_g,
            sensed_g: match self.last_gauge {
                Ok(f) | Err(GaugeFault::OutOfRange { force_g: f }) => f,
                Err(GaugeFault::AtRail { code }) => {
                    self.config.gauge.force_g(self.config.gauge.adc.volts(code))
                }
            },
            adjusted_g: adjusted,
            strain_pct: strain,
            estimate_g: estimate,
            true_force_g: true_force as f32,
            in_contact: true_force > 0.0,
            faults,
            dac_code: out.dac_code.0,
        }
    }
}
