//! The firmware's task bodies, written once for every board and for the simulator's rig.
//!
//! A board owns the peripherals behind [`crate::io`]'s traits and runs these bodies from its
//! tasks; the simulator's rig (`tactile-plant`) runs the same bodies on its simulated board, so
//! a simulated run and the firmware in the loop agree by construction:
//!
//! - [`config`]: what they run with ([`FirmwareConfig`]).
//! - [`control`]: the 1 kHz control tick (gauge → slew → A1 → filter → DAC) with the probed
//!   element's estimator; [`Controller`] adds a protocol's command source.
//! - [`scan`]: the 8×8 scan, strain per taxel, the per-taxel estimator, total force and
//!   centroid.

pub mod config;
pub mod control;
pub mod scan;
pub mod unlocated;

pub use config::{ConfigError, FirmwareConfig};
pub use control::{ControlLoop, Controller, Reading};
pub use scan::{
    ArrayEstimate, CalibrationStatus, ScanReport, Scanner, UnlocatedFrame, CONTACT_THRESHOLD_G,
};
