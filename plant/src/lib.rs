//! The simulated force applicator, tactile finger and closed-loop rig (memo M89/138), without
//! `std`, so the host simulator and the firmware-in-the-loop build run one physics.
//!
//! - [`applicator`]: current amplifier, motor, beam, probe and the unilateral finger contact.
//! - [`finger`]: the 8×8 array of Maxwell–Kelvin elements with their read-out chain and effects.
//! - [`hardware`]: the two seen through the board's converters, behind the core's I/O traits.
//! - [`rig`]: the firmware's own control and scan tasks closed around the simulated board.
//! - [`config`], [`fault`]: what a run is made of, and the faults the board can inject.
//! - [`noise`]: seeded Gaussian noise.
//! - [`spatial`]: how the probe's load spreads: the fixed kernel, or a half-space anywhere.
#![cfg_attr(not(test), no_std)]

pub mod applicator;
pub mod config;
pub mod fault;
pub mod finger;
pub mod hardware;
pub mod noise;
pub mod rig;
pub mod spatial;
