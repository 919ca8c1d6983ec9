//! What several subcommands share: reports claimed and written, records read for fitting,
//! the `--taxel` argument, the firmware's figures.

use sim_host::cli;
use sim_host::output::Output;
use sim_host::Error;
use std::path::Path;
use tactile_core::tactile::TaxelId;

/// The firmware's estimator figures from a decoded QEMU session's folder.
pub fn read_firmware_figures(dir: &Path) -> Result<sim_host::record::FirmwareFigures, Error> {
    let path = dir.join("estimators.json");
    let text = std::fs::read_to_string(&path).map_err(|e| {
        Error::Usage(format!(
            "{}: {e} (write it with boards/qemu-netduinoplus2/run.sh {})",
            path.display(),
            dir.display()
        ))
    })?;
    serde_json::from_str(&text).map_err(Error::json(&path))
}

/// `out/NAME.md` and `out/NAME.json`, claimed before the work.
pub fn claim_report(out: &Path, name: &str) -> Result<(Output, Output), Error> {
    Ok((
        Output::claim(&out.join(format!("{name}.md")), &[])?,
        Output::claim(&out.join(format!("{name}.json")), &[])?,
    ))
}

/// Prints a Markdown report and writes it, with its data as JSON, to the claimed files.
pub fn print_and_write(
    (md, json): (Output, Output),
    text: &str,
    data: &impl serde::Serialize,
) -> Result<(), Error> {
    out!("{text}");
    let md = md.write(text)?;
    json.write_json(data)?;
    outln!("wrote {}", md.display());
    Ok(())
}

/// A record read strictly, checked as `tactile diagnose` checks it, and split for fitting.
pub fn read_series(file: &Path) -> Result<sim_host::fit::Split, Error> {
    sim_host::fit::Split::checked(&sim_host::record::read_record(file)?)
        .map_err(|reason| Error::Failed(format!("{}: cannot be fitted: {reason}", file.display())))
}

/// `--taxel ROW,COL` for clap (a bad one is a usage error, exit code 2).
pub fn taxel_arg(text: &str) -> Result<TaxelId, String> {
    cli::parse_taxel(text).ok_or_else(|| "expected ROW,COL with ROW and COL in 0..8".to_string())
}
