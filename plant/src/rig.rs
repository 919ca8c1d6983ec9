//! The closed loop: the firmware's own control and scan tasks ([`tactile_core::tasks`]) on the
//! simulated board ([`SimHardware`]), one control period per [`Rig::tick`]. The plant is
//! integrated at 10 kHz (ten RK4 steps per 1 ms control tick; the applicator tests check the
//! step size).
//!
//! A tick is what a board does in one period (act on the last reading, the hardware runs,
//! sense, scan), with the scenario's command in place of a protocol's and the two faults that
//! live in the firmware (a NaN command, a missed deadline) played as the firmware would see
//! them.

use tactile_core::tactile::TAXELS;
use tactile_core::tasks::{ArrayEstimate, ConfigError, ControlLoop, Scanner};
use tactile_core::telemetry::FaultFlags;
use tactile_core::CONTROL_PERIOD_S;

pub use crate::config::{RigConfig, SIM_ERROR_GAIN};
pub use crate::fault::{FaultInjection, InjectedFault};
use crate::finger::StrainGrid;
use crate::hardware::SimHardware;
pub use tactile_core::telemetry::TickRecord;

/// Why a rig could not be built.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum RigError {
    /// The firmware refused its configuration.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A taxel index outside the array.
    #[error("taxel {0} is outside the 8×8 array")]
    Taxel(usize),
    /// The firmware would read the gauge at another scale than the applicator's gauge has
    /// (`applicator` set without [`RigConfig::set_applicator`]).
    #[error(
        "the firmware reads the gauge at {firmware_g_per_v} g/V, the applicator's gauge gives \
         {gauge_g_per_v} g/V (set the applicator with RigConfig::set_applicator)"
    )]
    GaugeScale {
        firmware_g_per_v: f32,
        gauge_g_per_v: f64,
    },
}

/// The closed-loop rig.
pub struct Rig {
    pub config: RigConfig,
    /// The simulated board: applicator, finger, converters (the firmware-in-the-loop build
    /// runs the same one).
    pub hardware: SimHardware,
    control: ControlLoop,
    /// The scan task, when the run scans the array.
    scanner: Option<Scanner>,
    tick: u64,
    /// Scan steps per control tick (dwell 250 µs → 4).
    scan_steps_per_tick: usize,
    /// The scan's estimate of its latest frame (what a board streams beside the frame).
    last_estimate: ArrayEstimate,
}

impl Rig {
    pub fn new(config: RigConfig) -> Result<Self, RigError> {
        let (firmware_g_per_v, gauge_g_per_v) = (
            config.firmware.gauge.grams_per_volt,
            config.applicator.gauge_g_per_v,
        );
        if firmware_g_per_v != gauge_g_per_v as f32 {
            return Err(RigError::GaugeScale {
                firmware_g_per_v,
                gauge_g_per_v,
            });
        }
        if let Some(FaultInjection {
            fault: InjectedFault::TaxelOpen { index },
            ..
        }) = config.fault
        {
            if index >= TAXELS {
                return Err(RigError::Taxel(index));
            }
        }
        let mut hardware = SimHardware::new(&config);
        let fw = &config.firmware;
        let calibration = *hardware.calibration();
        let probe_calibration = calibration
            .get(fw.probe.index())
            .copied()
            .ok_or(RigError::Taxel(fw.probe.index()))?;
        let control = ControlLoop::new(fw, config.command_slew_g_per_s, probe_calibration)
            .map_err(RigError::Config)?;
        let scanner = if config.scan_array {
            let mut scanner = Scanner::new(fw, calibration).map_err(RigError::Config)?;
            scanner.start(&mut hardware);
            Some(scanner)
        } else {
            None
        };
        let scan_steps_per_tick =
            libm::round(CONTROL_PERIOD_S / f64::from(fw.scan.dwell_s)).max(1.0) as usize;
        Ok(Self {
            hardware,
            control,
            scanner,
            tick: 0,
            scan_steps_per_tick,
            last_estimate: ArrayEstimate::default(),
            config,
        })
    }

    /// The array estimate of the latest completed frame (the default before the first).
    pub fn last_array_estimate(&self) -> ArrayEstimate {
        self.last_estimate
    }

    pub fn time_s(&self) -> f64 {
        self.tick as f64 * CONTROL_PERIOD_S
    }

    /// The excitation protocol's chirp, added to the drive after the loop's filter from the
    /// next tick on (A1's feedback off meanwhile; see `ForceLoop::set_drive_excitation`).
    pub fn set_drive_excitation(&mut self, chirp: Option<tactile_core::profile::ChirpSample>) {
        self.control.set_drive_excitation(chirp);
    }

    /// One control tick with command `command_g`; `on_frame` receives each completed 8×8 scan
    /// (a taxel at a converter rail reads NaN).
    pub fn tick(
        &mut self,
        command_g: f32,
        mut on_frame: impl FnMut(f64, &StrainGrid),
    ) -> TickRecord {
        let t_s = self.time_s();
        let starting = self.hardware.fault_starting();
        let command_in = if starting == Some(InjectedFault::CommandNan) {
            f32::NAN
        } else {
            command_g
        };
        if starting == Some(InjectedFault::DeadlineOverrun) {
            self.control.record_overrun();
        }
        let out = self
            .control
            .act(&mut self.hardware, command_in, self.tick as u32);
        self.hardware.advance_period();
        let reading = self.control.sense(&mut self.hardware);
        let t_end = t_s + CONTROL_PERIOD_S;
        let true_force = self.hardware.true_force_g();
        let mut faults = out.faults;
        if let Some(scanner) = &mut self.scanner {
            for _ in 0..self.scan_steps_per_tick {
                if let Some(report) = scanner.step(&mut self.hardware, self.tick as u32) {
                    self.last_estimate = report.estimate;
                    let mut grid = *scanner.strain_pct();
                    for (i, cell) in grid.iter_mut().flatten().enumerate() {
                        if scanner.bad_taxels() & (1 << i) != 0 {
                            *cell = f32::NAN;
                        }
                    }
                    on_frame(t_end, &grid);
                }
            }
            if scanner.bad_taxels() != 0 {
                faults.insert(FaultFlags::TAXEL_AT_RAIL);
            }
        }
        self.tick += 1;
        TickRecord {
            t_s: t_end,
            command_g,
            sensed_g: reading.sensed_g(&self.config.firmware.gauge),
            adjusted_g: out.adjusted_g,
            strain_pct: reading.strain_pct,
            estimate_g: reading.estimate_g,
            true_force_g: true_force as f32,
            in_contact: true_force > 0.0,
            faults,
            dac_code: self.hardware.dac().0,
        }
    }
}
