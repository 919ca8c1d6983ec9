//! `tactile locate`: the chip's scan over a frames record (each taxel's estimator, then the
//! contact locator on the array table's response); the location and force errors where the
//! record carries the truth, the centroid's beside them.

use clap::Args;
use sim_host::Error;
use std::path::PathBuf;

#[derive(Args)]
pub struct LocateArgs {
    /// A frames record: `t_s,r0c0,…,r7c7` (strain %), with `x_mm,y_mm,force_g` where the
    /// truth is known.
    pub file: PathBuf,
    /// The array table (`tactile calibrate --array`).
    #[arg(long)]
    pub table: PathBuf,
    /// The taxels' calibration table (`tactile calibrate`): each taxel's calibrated estimator,
    /// as the board runs it; without it, the nominal models.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Where to write each frame's contact (kind, x, y, force, centroid).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

pub fn run(args: LocateArgs) -> Result<(), Error> {
    let text = sim_host::array_calibration::locate_command(
        &args.file,
        &args.table,
        args.calibration.as_deref(),
        args.out.as_deref(),
    )?;
    out!("{text}");
    Ok(())
}
