//! `tactile identify`: identify the applicator from a record of the excitation (`tactile experiment excitation
//! --record-hz 1000`, with its drive): the measured response and a low-order model.

use clap::Args;
use sim_host::output::Output;
use sim_host::Error;
use std::path::PathBuf;

#[derive(Args)]
pub struct IdentifyArgs {
    pub file: PathBuf,
    /// Write the response and the model as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

pub fn run(args: IdentifyArgs) -> Result<(), Error> {
    let IdentifyArgs { file, json } = args;
    let json = Output::claim_some(json.as_deref(), &[&file])?;
    let rec = tactile_record::read_record(&file)?;
    let failed = |e: sim_host::applicator_model::IdentifyError| {
        Error::Failed(format!("{}: {e}", file.display()))
    };
    let means = sim_host::applicator_model::period_means_of_record(&rec).map_err(failed)?;
    let response = means.response().map_err(failed)?;
    let plain = sim_host::applicator_model::fit_model(&response).ok_or_else(|| {
        Error::Failed(format!(
            "{}: no model converged on the measured response",
            file.display()
        ))
    })?;
    // The motor's friction simulated in the model, its stiction fitted to the chirp from
    // the hold's drive less its gauge (one hold gives no static line).
    let held_g = sim_host::applicator_model::hold_means_of_record(&rec)
        .map_or(0.0, |h| (h.drive_g - h.gauge_g).max(0.0));
    let linear = means.fit_less_friction(held_g, None).unwrap_or(plain);
    let refined = sim_host::stick_slip::fit_with_stiction(&means, held_g, &linear);
    let (model, stiction_g) = refined.map_or((plain, None), |(m, s)| (m, Some(s)));
    outln!(
        "{}: drive to gauge, {} frequencies",
        file.display(),
        response.len()
    );
    outln!("  model: {model}");
    match stiction_g {
        Some(s) => outln!(
            "  the motor's friction simulated in the model: stiction {s:.2} g fitted to \
             the chirp (the hold's drive less its gauge: {held_g:.2} g)"
        ),
        None => {
            outln!("  (the friction simulated fitted no better: the plain ratio's model)")
        }
    }
    outln!("  the plain ratio's fit, which reads the friction as damping: {plain}");
    if let Some(why) = sim_host::design::implausible(&model) {
        outln!("  not an applicator's model: {why} (the design leaves such a preload out)");
    }
    if let Some(json) = json {
        #[derive(serde::Serialize)]
        struct Out<'a> {
            model: &'a sim_host::applicator_model::ApplicatorModel,
            /// Fitted with the model (`null`: not simulated).
            stiction_g: Option<f64>,
            plain_model: &'a sim_host::applicator_model::ApplicatorModel,
            response: &'a [sim_host::applicator_model::ResponsePoint],
        }
        let path = json.write_json(&Out {
            model: &model,
            stiction_g,
            plain_model: &plain,
            response: &response,
        })?;
        outln!("  wrote {}", path.display());
    }
    Ok(())
}
