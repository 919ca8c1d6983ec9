//! sim-host: the force applicator, the Maxwell–Kelvin finger and the 8×8 array simulated and
//! closed around the core library's control and estimation code, with the memo's experiments.
//!
//! The plant and the rig live in `tactile-plant` (`plant/`, no `std`), re-exported here,
//! so the firmware-in-the-loop build runs the same physics.

pub mod analysis;
pub mod applicator_model;
pub mod array_bench;
pub mod array_calibration;
pub mod board_link;
pub mod chip_diagnosis;
pub mod cli;
pub mod demo;
pub mod design;
pub mod dynamic_calibration;
pub mod error;
pub mod estimator_comparison;
pub mod fingers;
pub mod fit;
pub mod fuzz;
pub mod least_squares;
pub mod metrics;
pub mod output;
pub mod plot;
pub mod probe;
pub mod record_estimates;
pub mod report;
pub mod scenario;
pub mod stick_slip;
pub mod tables;

pub use error::Error;
pub use tactile_plant::{applicator, finger, noise, rig};
/// The record format lives in its own crate (`record/`), shared with the decoder.
pub use tactile_record as record;
