//! What the task bodies run with: one configuration for a board, QEMU's simulated board and
//! the simulator's rig.

use crate::contact::LocatorConfig;
use crate::control::{ActuatorConfig, ForceLawConfig};
use crate::designed::DesignedConfig;
use crate::estimator::EstimatorKind;
use crate::filter::LowpassNotchConfig;
use crate::gauge::{AdcScale, GaugeConfig};
use crate::supervisor::{LoopError, SupervisorConfig};
use crate::tactile::{ScanConfig, TaxelId, PROBED_TAXEL};
use crate::viscoelastic::{ModelError, SecondOrder};

/// Everything the task bodies are built from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirmwareConfig {
    pub law: ForceLawConfig,
    pub filter: LowpassNotchConfig,
    /// The designed force controller in place of A1 and the filter (`None`: A1).
    pub designed: Option<DesignedConfig>,
    pub gauge: GaugeConfig,
    pub actuator: ActuatorConfig,
    /// Converter of the taxel channels (offset/gain stage output, memo's ±10 V).
    pub taxel_adc: AdcScale,
    pub scan: ScanConfig,
    /// The element under the probe, read on its own channel every control tick.
    pub probe: TaxelId,
    /// Model inverted on the chip to estimate force from the probed element's strain.
    pub estimator: SecondOrder,
    /// The force loop's fault thresholds.
    pub supervisor: SupervisorConfig,
    /// The per-taxel calibration table, checked at start-up; a refused (or empty) table leaves
    /// every taxel on the nominal models and the scanner reports why.
    pub calibration: &'static [u8],
    /// The estimator every taxel of the array runs; `None`: each taxel runs the one its
    /// calibration chose (the one that held out best; the observer for a taxel without a
    /// calibration). The probed taxel also runs all four side by side, for the comparison
    /// stream.
    pub array_estimator: Option<EstimatorKind>,
    /// Where a contact is, from each frame's per-taxel estimates: the spatial response and the
    /// locator's thresholds.
    pub locator: LocatorConfig,
    /// The array's spatial calibration (`tactile calibrate --array`), checked at start-up: its
    /// response replaces `locator`'s; empty, `locator`'s stands; refused, it stands and the
    /// scanner says why.
    pub array_table: &'static [u8],
}

impl FirmwareConfig {
    /// The memo's rig as built: A1 with its gains (K_e = 1; the simulator runs K_e = 0.07, see
    /// docs/design.md), the lowpass-notch filter, gauge and actuator paths,
    /// element 4,2 under the probe, the second-order fit of Table IV as the estimator, no
    /// calibration table.
    pub const MEMO: FirmwareConfig = FirmwareConfig {
        law: ForceLawConfig::MEMO,
        filter: LowpassNotchConfig::MEMO,
        designed: None,
        gauge: GaugeConfig::MEMO,
        actuator: ActuatorConfig::MEMO,
        taxel_adc: AdcScale::BIPOLAR_10V_12BIT,
        scan: ScanConfig::DESIGN,
        probe: PROBED_TAXEL,
        estimator: SecondOrder::MEMO_FIT,
        supervisor: SupervisorConfig::DESIGN,
        calibration: &[],
        array_estimator: None,
        locator: LocatorConfig::MEMO,
        array_table: &[],
    };
}

/// Why the task bodies could not be built from a configuration.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum ConfigError {
    #[error(transparent)]
    Loop(#[from] LoopError),
    #[error(transparent)]
    Estimator(#[from] ModelError),
    #[error("the controller table was designed through a gauge of {table_g_per_v} g/V reading to {table_max_g} g; this firmware reads {firmware_g_per_v} g/V to {firmware_max_g} g")]
    DesignedGauge {
        table_g_per_v: f32,
        table_max_g: f32,
        firmware_g_per_v: f32,
        firmware_max_g: f32,
    },
}
