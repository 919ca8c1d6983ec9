//! `tactile`: the memo's experiments on the simulator.
//!
//! ```text
//! tactile list
//! tactile experiment NAME [--out DIR] [--seed N] [--load G] [--fixed-gains] [--duration S]
//!                         [--record-hz HZ] [--effect NAME=VALUE]... [--no-plot]
//! tactile calibrate [ROW,COL=FILE]... [--out TABLE.bin] [--seed N]
//! tactile fit FILE [--model NAME] [--json OUT]
//! tactile diagnose FILE [--json OUT] [--report DIR] [--table OUT.bin] [--taxel R,C]
//! tactile estimate FILE --table TABLE.bin [--taxel R,C] [--estimator NAME] [--out OUT.csv]
//! tactile tables [--out DIR]
//! tactile estimators [--out DIR] [--seed N]
//! tactile demo [--out DIR] [--seed N]
//! ```
//! Exit codes: 0 done, 1 failed while running, 2 bad usage (unknown scenario, effect, option).

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use sim_host::cli;
use sim_host::Error;

/// `print!`/`println!` that ignore a closed pipe (`tactile … | head`) instead of panicking.
macro_rules! out {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout(), $($t)*);
    }};
}
macro_rules! outln {
    ($($t:tt)*) => {
        out!("{}\n", format_args!($($t)*))
    };
}

mod applicator;
mod board;
mod calibrate;
mod common;
mod demo;
mod design;
mod diagnose;
mod estimate;
mod estimators;
mod experiment;
mod fit;
mod identify;
mod locate;
mod tables;

#[derive(Parser)]
#[command(
    name = "tactile",
    version,
    about = "Force applicator and tactile finger after UCB/ERL M89/138, on the simulator"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List the scenarios and the effects that can be switched on.
    List,
    /// Run one of the memo's experiments, write its record, frames and plot.
    Experiment(experiment::ExperimentArgs),
    /// Fit one of the memo's models to a record (t_s,force_g,strain_pct).
    Fit(fit::FitArgs),
    /// Find what a linear Maxwell–Kelvin model misses in a record, add it, report before/after.
    Diagnose(diagnose::DiagnoseArgs),
    /// Run the chip's estimators (the firmware's own code) over a record's strain with a
    /// calibration table; write the force estimates as a record; with a reference force, print
    /// each estimator's error.
    Estimate(estimate::EstimateArgs),
    /// Run the chip's scan over a frames record (each taxel's estimator, then the contact
    /// locator with an array table): where and how hard, against the truth where the record
    /// has it, the centroid beside it.
    Locate(locate::LocateArgs),
    /// Identify the applicator from a record of the excitation (`tactile experiment excitation
    /// --record-hz 1000`, with its drive): the measured response and a low-order model.
    Identify(identify::IdentifyArgs),
    /// Check an applicator file and write the form the QEMU firmware reads at start-up
    /// (`boards/qemu-netduinoplus2/run.sh OUT applicator=FILE.toml` does this for you).
    Applicator(applicator::ApplicatorArgs),
    /// Design the force controller for the simulated rig: the excitation at six
    /// preloads, a model at each, the static gain and stiction from the holds, then the
    /// feed-forward's schedule and the feedback's gains from the margins. A1 stays the
    /// default loop; `cargo run --release -p sim-host --example design_controller` measures
    /// the design against it.
    Design(design::DesignArgs),
    /// Drive a board from the host: commands down, its defmt stream up, decoded as it arrives
    /// into records (`OUT/NAME.csv`), with a progress bar and a live line (force, error,
    /// faults, frames lost). The board is the QEMU firmware (`cargo fw-qemu` builds it), or
    /// with --probe an STM32F407G-DISC1 over SWD (`cargo fw-f407` builds its firmware).
    Board(board::BoardArgs),
    /// Reproduce the memo's Tables I–IV on the simulator, beside the memo's numbers.
    Tables(tables::TablesArgs),
    /// Compare the force estimators on the simulator's protocols, nominal and calibrated.
    Estimators(estimators::EstimatorsArgs),
    /// Dynamic calibration: fit each taxel's models to its record of the calibration protocol
    /// and write the table the firmware reads at start-up. Without records, calibrates four
    /// taxels of the simulated finger.
    Calibrate(calibrate::CalibrateArgs),
    /// The main job without a board: the memo's experiment set, plots and a report.
    Demo(demo::DemoArgs),
}

/// The one place errors become exit codes: 0 done, 1 the run failed, 2 bad usage (clap exits 2
/// itself for what it refuses).
fn main() -> ExitCode {
    keep_freed_memory();
    match run(Cli::parse().command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("tactile: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}

/// The diagnosis builds and drops columns of a whole record (2.4 MB each at 600 s and 1 kHz)
/// hundreds of times: glibc's malloc maps each afresh and returns it on free, and the page
/// faults of touching it again were a tenth of a long record's CPU. One arena (the threads
/// allocate rarely; more arenas each keep their own peak) whose freed memory stays for reuse.
fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets allocator parameters; called before any thread starts.
    unsafe {
        libc::mallopt(libc::M_ARENA_MAX, 1);
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 128 << 20);
    }
}

fn run(command: Command) -> Result<(), Error> {
    match command {
        Command::List => {
            out!("{}", cli::listing());
            Ok(())
        }
        Command::Experiment(args) => experiment::run(args),
        Command::Fit(args) => fit::run(args),
        Command::Diagnose(args) => diagnose::run(args),
        Command::Estimate(args) => estimate::run(args),
        Command::Locate(args) => locate::run(args),
        Command::Identify(args) => identify::run(args),
        Command::Applicator(args) => applicator::run(args),
        Command::Design(args) => design::run(args),
        Command::Board(args) => board::run(args),
        Command::Tables(args) => tables::run(args),
        Command::Estimators(args) => estimators::run(args),
        Command::Calibrate(args) => calibrate::run(args),
        Command::Demo(args) => demo::run(args),
    }
}
