//! `tactile tables`: reproduce the memo's Tables I–IV on the simulator, beside the memo's numbers.

use crate::common::{claim_report, print_and_write};
use clap::Args;
use sim_host::Error;
use std::path::PathBuf;

#[derive(Args)]
pub struct TablesArgs {
    #[arg(long, default_value = "out/tables")]
    pub out: PathBuf,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

pub fn run(args: TablesArgs) -> Result<(), Error> {
    let TablesArgs { out, seed } = args;
    let files = claim_report(&out, "tables")?;
    let t = sim_host::tables::reproduce(seed)?;
    print_and_write(files, &sim_host::tables::render(&t), &t)?;
    Ok(())
}
