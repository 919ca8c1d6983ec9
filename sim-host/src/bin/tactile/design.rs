//! `tactile design`: design the force controller for the simulated rig: the excitation at six
//! preloads, a model at each, the static gain and stiction from the holds, then the
//! feed-forward's schedule and the feedback's gains from the margins. A1 stays the
//! default loop; `cargo run --release -p sim-host --example design_controller` measures
//! the design against it.

use clap::Args;
use sim_host::output::Output;
use sim_host::Error;
use std::path::{Path, PathBuf};

#[derive(Args)]
pub struct DesignArgs {
    /// The rig's applicator, a TOML file (default: the memo's).
    #[arg(long)]
    pub applicator: Option<PathBuf>,
    /// Design from these records of the excitation at several preloads instead of
    /// simulating it (a board's, or the QEMU firmware's identification session:
    /// `boards/qemu-netduinoplus2/run.sh OUT session=excitation`).
    #[arg(long, num_args = 1.., conflicts_with = "applicator")]
    pub records: Vec<PathBuf>,
    /// Write the models, the gains and the margins as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the controller's table here (the bytes the firmware checks at start-up;
    /// `boards/controller/table.bin` is the QEMU build's).
    #[arg(long)]
    pub table: Option<PathBuf>,
}

pub fn run(args: DesignArgs) -> Result<(), Error> {
    let (applicator, records) = (args.applicator, args.records);
    let inputs: Vec<&Path> = records
        .iter()
        .map(PathBuf::as_path)
        .chain(applicator.as_deref())
        .collect();
    let json = Output::claim_some(args.json.as_deref(), &inputs)?;
    let table = Output::claim_some(args.table.as_deref(), &inputs)?;
    let mut config = sim_host::rig::RigConfig {
        scan_array: false,
        ..Default::default()
    };
    if let Some(path) = &applicator {
        config.set_applicator(sim_host::error::read_applicator(path)?);
    }
    let r = if records.is_empty() {
        sim_host::design::design_for_rig(&config)
    } else {
        let (mut excited, mut left_out) = (Vec::new(), Vec::new());
        for file in &records {
            let rec = tactile_record::read_record(file)?;
            match sim_host::design::excited_of_record(&rec).map_err(sim_host::design::left_out_of) {
                Ok(e) => excited.push(e),
                Err(Ok(mut left)) => {
                    left.why = format!("{}: {}", file.display(), left.why);
                    left_out.push(left);
                }
                Err(Err(e)) => return Err(Error::Failed(format!("{}: {e}", file.display()))),
            }
        }
        sim_host::design::identified_from(&excited, left_out)
            .and_then(|id| sim_host::design::design_identified(id, &config))
    }
    .map_err(|e| Error::Failed(format!("design: {e}")))?;
    let id = &r.identified;
    outln!(
        "static line of the holds: gain {:.3}, stiction {:.2} g; gauge noise {:.2} g",
        id.static_gain,
        id.stiction_g,
        id.gauge_noise_g
    );
    for left in &id.left_out {
        outln!("left out {left}");
    }
    let d = &r.design;
    for ((m, p), mg) in d.models.iter().zip(&d.config.schedule).zip(&d.margins) {
        let source = if id.models.iter().any(|i| i.load_g == m.load_g) {
            "identified"
        } else {
            "extrapolated"
        };
        outln!("{:5} g ({source}): {}", m.load_g, m.model);
        outln!(
            "        feedback share {:.2}: least margins with the model 20 % off: gain {:.2}, phase {:.0}°",
            p.feedback,
            mg.gain,
            mg.phase_deg
        );
    }
    outln!(
        "feedback kp {:.3}, ki {:.1}/s through {}; stiction compensated {:.2} g moving (through the amplifier's τ {:.2} ms), {:.2} g held; reference model {} Hz",
        d.feedback.kp,
        d.feedback.ki_per_s,
        d.feedback.filter,
        d.config.friction_g,
        1e3 * d.config.amplifier_tau_s,
        d.config.held_friction_g,
        d.config.reference_hz
    );
    outln!(
        "touch-down: pulses of {} ms on {:.2} g of stiction, pushing to +{:.2} g and braking to {:.2} g; on the finger at {:.2} g, then the command ramps at {} g/s plus the force over {} s",
        tactile_core::designed::APPROACH_TICKS,
        d.config.approach_hold_g,
        d.config.approach_push_g,
        d.config.approach_brake_g,
        d.config.contact_g,
        tactile_core::designed::TOUCH_RATE_G_PER_S,
        tactile_core::designed::TOUCH_TAU_S
    );
    if let Some(json) = json {
        let path = json.write_json(&r)?;
        outln!("wrote {}", path.display());
    }
    if let Some(table) = table {
        let bytes = d
            .config
            .encode()
            .map_err(|e| Error::Failed(format!("the designed controller: {e}")))?;
        let path = table.write(bytes)?;
        outln!("wrote {} ({} bytes)", path.display(), bytes.len());
    }
    Ok(())
}
