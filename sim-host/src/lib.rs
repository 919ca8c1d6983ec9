//! sim-host: the force applicator, the Maxwell–Kelvin finger and the 8×8 array simulated and
//! closed around the core library's control and estimation code, with the memo's experiments.
//!
//! The plant modules (`applicator`, `finger`, `noise`) use only `core` and `libm`, so the
//! firmware-in-the-loop build can run the same physics without `std`.

pub mod analysis;
pub mod applicator;
pub mod cli;
pub mod finger;
pub mod metrics;
pub mod noise;
pub mod plot;
pub mod record;
pub mod rig;
pub mod scenario;
