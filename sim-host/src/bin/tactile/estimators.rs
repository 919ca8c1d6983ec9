//! `tactile estimators`: compare the force estimators on the simulator's protocols, nominal and calibrated.

use crate::common::{claim_report, print_and_write, read_firmware_figures};
use clap::Args;
use sim_host::fingers::FingerKind;
use sim_host::Error;
use std::path::PathBuf;

#[derive(Args)]
pub struct EstimatorsArgs {
    #[arg(long, default_value = "out/estimators")]
    pub out: PathBuf,
    /// Seed of the simulated finger whose four taxels are calibrated and scored.
    #[arg(long, default_value_t = sim_host::dynamic_calibration::FINGER_SEED)]
    pub seed: u64,
    /// The kind of finger: the memo's, or one whose springs stiffen by other laws.
    #[arg(long, value_enum, default_value_t = FingerKind::Memo)]
    pub finger: FingerKind,
    /// Also the firmware's row: a folder `tactile-decode` wrote from a QEMU session
    /// (`boards/qemu-netduinoplus2/run.sh DIR`), with its `estimators.json`.
    #[arg(long)]
    pub qemu: Option<PathBuf>,
}

pub fn run(args: EstimatorsArgs) -> Result<(), Error> {
    let firmware = args
        .qemu
        .as_deref()
        .map(read_firmware_figures)
        .transpose()?;
    let files = claim_report(&args.out, "estimators")?;
    let t = sim_host::estimator_comparison::compare(args.seed, args.finger)?;
    let mut text = sim_host::estimator_comparison::render(&t);
    if let Some(f) = &firmware {
        text.push('\n');
        text.push_str(&f.render());
    }
    let data = serde_json::json!({ "simulator": t, "firmware": firmware });
    print_and_write(files, &text, &data)?;
    Ok(())
}
