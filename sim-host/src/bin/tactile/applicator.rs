//! `tactile applicator`: check an applicator file and write the form the QEMU firmware reads at start-up
//! (`boards/qemu-netduinoplus2/run.sh OUT applicator=FILE.toml` does this for you).

use clap::Args;
use sim_host::output::Output;
use sim_host::Error;
use std::path::PathBuf;

#[derive(Args)]
pub struct ApplicatorArgs {
    /// The applicator, a TOML file (`applicators/*.toml`).
    pub file: PathBuf,
    /// Write its checked binary form here.
    #[arg(long)]
    pub out: PathBuf,
}

pub fn run(args: ApplicatorArgs) -> Result<(), Error> {
    let ApplicatorArgs { file, out } = args;
    let params = sim_host::error::read_applicator(&file)?;
    let bytes = params.encode();
    Output::claim(&out, &[&file])?.write(bytes)?;
    outln!(
        "{}: checked; wrote {} ({} bytes)",
        file.display(),
        out.display(),
        bytes.len()
    );
    Ok(())
}
