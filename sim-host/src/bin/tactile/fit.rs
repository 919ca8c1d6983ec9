//! `tactile fit`: fit one of the memo's models to a record (t_s,force_g,strain_pct).

use crate::common::read_series;
use clap::Args;
use sim_host::fit::Base;
use sim_host::output::Output;
use sim_host::Error;
use std::path::PathBuf;

#[derive(Args)]
pub struct FitArgs {
    pub file: PathBuf,
    /// The model to fit.
    #[arg(long, value_enum, default_value_t = Base::MkAlpha)]
    pub model: Base,
    /// Write the fit as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

pub fn run(args: FitArgs) -> Result<(), Error> {
    let FitArgs { file, model, json } = args;
    let json = Output::claim_some(json.as_deref(), &[&file])?;
    let series = read_series(&file)?;
    let start = std::time::Instant::now();
    let fit = sim_host::fit::fit(&sim_host::fit::ModelSpec::new(model), &series, &[]).ok_or_else(
        || {
            Error::Failed(format!(
                "no start of the {} fit converged on {}",
                model.name(),
                file.display()
            ))
        },
    )?;
    out!("{}", sim_host::fit::describe(&fit));
    outln!(
        "  ({} evaluations, {:.2} s)",
        fit.evaluations,
        start.elapsed().as_secs_f64()
    );
    if let Some(json) = json {
        json.write_json(&fit)?;
    }
    Ok(())
}
