//! The firmware's task bodies, written once for every board (issue 5).
//!
//! The RTIC applications under `boards/` are thin: they own the peripherals, run these bodies
//! from their tasks and move frames to defmt. Everything here is `no_std`, allocation-free and
//! panic-free, and reuses the core library for the law, filter, gauge path, scan, models,
//! profiles and frames:
//!
//! - [`board`]: the hardware layer a board implements ([`ControlIo`], [`ScanIo`]).
//! - [`config`]: what a build runs with ([`FirmwareConfig`]).
//! - [`control`]: the 1 kHz control tick (gauge → slew → A1 → filter → DAC) with the probed
//!   element's estimator and the command source.
//! - [`scan`]: the 8×8 scan, strain per taxel, the per-taxel inverse model, total force and
//!   centroid.
//! - [`safety`]: watchdog check-ins, the reset cause, the crash handlers' report.
//! - [`telemetry`]: bounded outboxes that number frames and count drops, never blocking.
//! - `sim` (feature `sim`): the simulated board of `tactile-plant` behind the same traits.
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

pub mod board;
pub mod config;
pub mod control;
pub mod safety;
pub mod scan;
pub mod telemetry;

#[cfg(any(test, feature = "sim"))]
pub mod sim;
#[cfg(any(test, feature = "sim"))]
pub use sim::{
    session_from_cmdline, DeliberateCrash, FilRun, Session, CALIBRATION_SESSION, FIL_SESSION,
};

pub use board::{ControlIo, ScanIo};
pub use config::{ConfigError, FirmwareConfig, CONTROL_PERIOD_S};
pub use control::Controller;
pub use safety::{CheckIns, ResetCause, SafeStop};
pub use scan::{ArrayEstimate, CalibrationStatus, ScanReport, Scanner};
pub use telemetry::{Message, Numbered, Outbox, RunEnd, RunStart};
