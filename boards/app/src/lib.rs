//! What every board's firmware shares around the core's task bodies.
//!
//! The RTIC applications under `boards/` are thin: they own the peripherals, run the core's
//! task bodies ([`tactile_core::tasks`]: control, scan) from their tasks and move frames to
//! defmt. Everything here is `no_std`, allocation-free and panic-free:
//!
//! - [`table`]: the calibration table a build carries and a real board's configuration
//!   ([`BOARD`]).
//! - [`safety`]: watchdog check-ins, the reset cause, the crash handlers' report.
//! - [`telemetry`]: bounded outboxes that number frames and count drops, never blocking.
//! - `sim` (feature `sim`): the sessions the QEMU build runs on the simulated board of
//!   `tactile-plant`.
#![cfg_attr(not(test), no_std)]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic
    )
)]

pub mod commands;
pub mod safety;
pub mod table;
pub mod telemetry;

#[cfg(any(test, feature = "sim"))]
pub mod sim;
#[cfg(any(test, feature = "sim"))]
pub use sim::{
    applicator_from_cmdline, cmdline_words as words_of_cmdline, only_run_from_cmdline,
    runs_from_cmdline, script_from_cmdline, session_from_cmdline, DeliberateCrash, FilRun, Session,
    CALIBRATION_SESSION, EXCITATION_SESSION, FIL_SESSION,
};

pub use commands::{
    hold, Action, CommandPort, EstimatorChoice, Reply, HOLD_S, LOADED_TABLE_BYTES, QUIET_TICKS,
};

pub use safety::{CheckIns, ResetCause, SafeStop};
pub use table::{BOARD, CALIBRATION_TABLE, CONTROLLER_TABLE};
pub use tactile_core::io::{ControlIo, ScanIo};
pub use tactile_core::tasks::{
    ArrayEstimate, CalibrationStatus, ConfigError, Controller, FirmwareConfig, ScanReport, Scanner,
    UnlocatedFrame,
};
pub use tactile_core::CONTROL_PERIOD_S;
pub use telemetry::{drain, Message, Numbered, Outbox, RunEnd, RunStart};
