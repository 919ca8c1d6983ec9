//! `tactile demo`: the main job without a board: the memo's experiment set, plots and a report.

use clap::Args;
use sim_host::Error;
use std::path::PathBuf;

#[derive(Args)]
pub struct DemoArgs {
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

pub fn run(args: DemoArgs) -> Result<(), Error> {
    let DemoArgs { out, seed } = args;
    let path = sim_host::demo::demo(&out, seed)?;
    outln!("report: {}", path.display());
    Ok(())
}
