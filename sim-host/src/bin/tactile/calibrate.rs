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
    /// The array's calibration instead: frames records of presses at known positions
    /// (`t_s,r0c0,…,r7c7,x_mm,y_mm,force_g`), fitted for the array's spatial response.
    #[arg(long, num_args = 1.., value_name = "FRAMES.csv")]
    pub array: Vec<PathBuf>,
    /// With --array: the taxels' calibration table (`tactile calibrate`), so the presses are
    /// read through each taxel's calibrated estimator as the board reads them.
    #[arg(long, requires = "array")]
    pub calibration: Option<PathBuf>,
    /// The table (binary, what the firmware's calibration sector holds; default
    /// out/calibration/table.bin, with --array out/calibration/array.bin).
    #[arg(long)]
    pub out: Option<PathBuf>,
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
        array,
        calibration,
        out,
        seed,
        finger,
    } = args;
    if !array.is_empty() {
        if !records.is_empty() {
            return Err(Error::Usage(
                "--array calibrates the array from frames records; the taxels' records are a \
                 calibration of their own: one or the other"
                    .into(),
            ));
        }
        let out = out.unwrap_or_else(|| PathBuf::from("out/calibration/array.bin"));
        outln!(
            "{}",
            sim_host::array_calibration::calibrate_command(&array, calibration.as_deref(), &out)?
        );
        return Ok(());
    }
    let out = out.unwrap_or_else(|| PathBuf::from("out/calibration/table.bin"));
    outln!("{}", cli::calibrate(&records, &out, seed, finger)?);
    Ok(())
}
