//! The calibration table a build carries, and a real board's configuration.

use tactile_core::tasks::FirmwareConfig;

/// The calibration table this build carries: `tactile calibrate --out
/// boards/calibration/table.bin` writes it (from a board's calibration records, or the
/// simulated finger's); the committed one is the simulated finger's four taxels. A board keeps
/// it in flash at a fixed place ([`CALIBRATION_TABLE`] is linked there on the F407).
pub static CALIBRATION_TABLE: [u8; include_bytes!("../../calibration/table.bin").len()] =
    *include_bytes!("../../calibration/table.bin");

/// The designed force controller's table the QEMU build runs its `force-steps-designed` with:
/// `tactile design --table boards/controller/table.bin` writes it (the memo's rig identified
/// on the simulator); checked at start-up like the calibration table.
pub static CONTROLLER_TABLE: [u8; include_bytes!("../../controller/table.bin").len()] =
    *include_bytes!("../../controller/table.bin");

/// A real board: the memo's law as built (K_e = 1; see docs/design.md for why
/// the simulator runs K_e = 0.07), filter, gauge and actuator paths, element 4,2 under the
/// probe, the second-order fit of Table IV as the estimator, and the table this build carries.
pub const BOARD: FirmwareConfig = FirmwareConfig {
    calibration: &CALIBRATION_TABLE,
    ..FirmwareConfig::MEMO
};
