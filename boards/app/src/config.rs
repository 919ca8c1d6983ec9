//! What a firmware build runs with.

use tactile_core::control::{ActuatorConfig, ForceLawConfig};
use tactile_core::estimator::EstimatorKind;
use tactile_core::filter::{FilterError, LowpassNotchConfig};
use tactile_core::gauge::{AdcScale, GaugeConfig};
use tactile_core::supervisor::SupervisorConfig;
use tactile_core::tactile::{ScanConfig, TaxelId};
use tactile_core::viscoelastic::{ModelError, SecondOrder};

/// Control period, s (memo: Δt = 1 ms). `f64` and spelled as the simulator's rig spells it, so
/// command times match the simulator's to the bit.
pub const CONTROL_PERIOD_S: f64 = 1e-3;

/// Everything the task bodies are built from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirmwareConfig {
    pub law: ForceLawConfig,
    pub filter: LowpassNotchConfig,
    pub gauge: GaugeConfig,
    pub actuator: ActuatorConfig,
    /// Converter of the taxel channels (offset/gain stage output, memo's ±10 V).
    pub taxel_adc: AdcScale,
    pub scan: ScanConfig,
    /// The element under the probe, read on its own channel every control tick.
    pub probe: TaxelId,
    /// Model inverted on the chip to estimate force from strain.
    pub estimator: SecondOrder,
    /// The force loop's fault thresholds.
    pub supervisor: SupervisorConfig,
    /// The per-taxel calibration table, checked at start-up; a refused table leaves every
    /// taxel on the nominal models and the scanner reports why.
    pub calibration: &'static [u8],
    /// The estimator every taxel of the array runs; `None`: each taxel runs the one its
    /// calibration chose (the one that held out best; the observer for a taxel without a
    /// calibration). The probed taxel also runs all four side by side, for the comparison
    /// stream.
    pub array_estimator: Option<EstimatorKind>,
}

/// The calibration table this build carries: `tactile calibrate --out
/// boards/calibration/table.bin` writes it (from a board's calibration records, or the
/// simulated finger's); the committed one is the simulated finger's four taxels. A board keeps
/// it in flash at a fixed place ([`CALIBRATION_TABLE`] is linked there on the F407).
pub static CALIBRATION_TABLE: [u8; include_bytes!("../../calibration/table.bin").len()] =
    *include_bytes!("../../calibration/table.bin");

impl FirmwareConfig {
    /// A real board: the memo's law as built (K_e = 1; see the README's design decisions for
    /// why the simulator runs K_e = 0.07), filter, gauge and actuator paths; element 4,2 under
    /// the probe; the second-order fit of Table IV as the estimator.
    pub const BOARD: FirmwareConfig = FirmwareConfig {
        law: ForceLawConfig::MEMO,
        filter: LowpassNotchConfig::MEMO,
        gauge: GaugeConfig::MEMO,
        actuator: ActuatorConfig::MEMO,
        taxel_adc: AdcScale::BIPOLAR_10V_12BIT,
        scan: ScanConfig::DESIGN,
        probe: TaxelId::from_index(3 * 8 + 2),
        estimator: SecondOrder::MEMO_FIT,
        supervisor: SupervisorConfig::DESIGN,
        calibration: &CALIBRATION_TABLE,
        array_estimator: None,
    };
}

/// Why the task bodies could not be built from a configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConfigError {
    Filter(FilterError),
    Estimator(ModelError),
}
