//! The simulator's integration tests, one module per file, in one binary: one link for them
//! all instead of ten, and the long tests (the estimators' and the controller's) run beside
//! the others. `cargo test --release -p sim-host --test host controller::` runs one module.

mod common;

mod applicator_file;
mod controller;
mod diagnose;
mod estimators;
mod faults;
mod fuzz;
mod identify;
mod logger;
mod memo_experiments;
mod refusals;
mod tables;
