//! `tactile-ident`: what a model of the sensor gets wrong, from a record of force and strain.
//!
//! The diagnosis ([`diagnose::diagnose`]) fits one model that is linear in its parameters — a
//! generalized Maxwell–Kelvin finger (an elastic compliance and a Prony series of Kelvin
//! branches over a log-spaced grid of time constants, plus the permanent-creep dashpot) — and
//! adds each named effect as a group of regressors: a slower relaxation, a load basis
//! (stiffening), play operators (hysteresis), a smooth drift in time, lines (interference), a
//! fractional delay, a gain that changes with time. Every candidate is scored on the same
//! contiguous folds ([`series::Folds`]); an effect is accepted when its held-out gain is
//! consistent across the folds and it moves the residual toward white (or removes half of what
//! lies above the noise floor: the right model's residual is the force estimate's coloured
//! error). Errors are in strain
//! (what was measured) and in grams through one fixed secant stiffness per record.
//!
//! [`force_fit`] fits the chip's force bank in the direction it is used: force from the
//! strain's history, its terms chosen by the same blocked cross-validation on the force error.
//!
//! [`synth`] is a second record generator, different in form from the project's simulator,
//! for tests and benchmarks.

pub mod diagnose;
pub mod force_fit;
pub mod par;
pub mod residual;
pub mod series;
pub mod solve;
pub mod stats;
pub mod synth;
pub mod terms;

pub use diagnose::{diagnose, Diagnosis, Effect};
pub use series::{Refusal, Series};
