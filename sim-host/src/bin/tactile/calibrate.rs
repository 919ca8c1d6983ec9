//! `tactile calibrate`: dynamic calibration: fit each taxel's models to its record of the calibration protocol
//! and write the table the firmware reads at start-up. Without records, calibrates four
//! taxels of the simulated finger.

use clap::Args;
use sim_host::cli;
use sim_host::fingers::FingerKind;
use sim_host::Error;
use std::path::PathBuf;
use tactile_core::tactile::TaxelId;

#[derive(Args)]
pub struct CalibrateArgs {
    /// ROW,COL=FILE: a taxel (from zero) and its record of the calibration protocol.
    #[arg(value_parser = cli::parse_taxel_record)]
    pub records: Vec<(TaxelId, PathBuf)>,
    /// The table (binary, what the firmware's calibration sector holds).
    #[arg(long, default_value = "out/calibration/table.bin")]
    pub out: PathBuf,
    /// Seed of the simulated finger (without records).
    #[arg(long, default_value_t = sim_host::dynamic_calibration::FINGER_SEED)]
    pub seed: u64,
    /// The kind of simulated finger (without records).
    #[arg(long, value_enum, default_value_t = FingerKind::Memo)]
    pub finger: FingerKind,
}

pub fn run(args: CalibrateArgs) -> Result<(), Error> {
    let CalibrateArgs {
        records,
        out,
        seed,
        finger,
    } = args;
    outln!("{}", cli::calibrate(&records, &out, seed, finger)?);
    Ok(())
}
