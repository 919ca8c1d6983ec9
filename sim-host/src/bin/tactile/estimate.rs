//! `tactile estimate`: run the chip's estimators (the firmware's own code) over a record's strain with a
//! calibration table; write the force estimates as a record; with a reference force, print
//! each estimator's error.

use crate::common::taxel_arg;
use clap::Args;
use sim_host::Error;
use std::path::PathBuf;
use tactile_core::tactile::TaxelId;

#[derive(Args)]
pub struct EstimateArgs {
    pub file: PathBuf,
    /// The calibration table (`tactile calibrate` or `tactile diagnose --table`).
    #[arg(long)]
    pub table: PathBuf,
    /// The taxel of the table the record is of, ROW,COL from zero.
    #[arg(long, default_value = "3,2", value_parser = taxel_arg)]
    pub taxel: TaxelId,
    /// Only this estimator (default: all five).
    #[arg(long, value_enum)]
    pub estimator: Option<sim_host::record_estimates::Estimator>,
    /// Where to write the estimates (default: FILE with `_estimate.csv`).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

pub fn run(args: EstimateArgs) -> Result<(), Error> {
    let text = sim_host::record_estimates::run(
        &args.file,
        &args.table,
        args.taxel,
        args.estimator,
        args.out.as_deref(),
    )?;
    out!("{text}");
    Ok(())
}
