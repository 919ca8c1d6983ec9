//! The simulated force applicator, tactile finger and closed-loop rig (memo M89/138), without
//! `std`, so the host simulator and the firmware-in-the-loop build run one physics.
//!
//! - [`applicator`]: current amplifier, motor, beam, probe and the unilateral finger contact.
//! - [`finger`]: the 8×8 array of Maxwell–Kelvin elements with their read-out chain and effects.
//! - [`rig`]: the core's control and estimation code closed around the two.
//! - [`noise`]: seeded Gaussian noise.
#![cfg_attr(not(test), no_std)]

pub mod applicator;
pub mod finger;
pub mod hardware;
pub mod noise;
pub mod rig;
