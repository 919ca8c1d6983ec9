//! `tactile diagnose`: find what a linear Maxwell–Kelvin model misses in a record, add it, report before/after.

use crate::common::taxel_arg;
use clap::Args;
use sim_host::output::Output;
use sim_host::Error;
use std::path::PathBuf;
use tactile_core::tactile::TaxelId;

#[derive(Args)]
pub struct DiagnoseArgs {
    pub file: PathBuf,
    /// Write the diagnosis as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write plots and a report into this folder.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write the accepted model as a calibration table for the firmware (one taxel); where
    /// there is nothing the chip can run, no file is written and the exit code is 1.
    #[arg(long)]
    pub table: Option<PathBuf>,
    /// The taxel the record is of, ROW,COL from zero (for --table).
    #[arg(long, default_value = "3,2", value_parser = taxel_arg)]
    pub taxel: TaxelId,
}

pub fn run(args: DiagnoseArgs) -> Result<(), Error> {
    let DiagnoseArgs {
        file,
        json,
        report,
        table,
        taxel,
    } = args;
    let json = Output::claim_some(json.as_deref(), &[&file])?;
    let table = Output::claim_some(table.as_deref(), &[&file])?;
    if let Some(dir) = &report {
        std::fs::create_dir_all(dir).map_err(Error::io(dir))?;
    }
    let record = sim_host::record::read_record(&file)?;
    let series = sim_host::chip_diagnosis::into_series(record).map_err(|reason| {
        Error::Failed(format!("{}: cannot be diagnosed: {reason}", file.display()))
    })?;
    let start = std::time::Instant::now();
    let d = sim_host::chip_diagnosis::diagnose(&series, taxel);
    out!("{}", d.diagnosis.summary);
    outln!("  ({:.2} s)", start.elapsed().as_secs_f64());
    if let Some(json) = json {
        json.write_json(&d)?;
    }
    // The report before the table: a table that cannot be written still leaves it.
    if let Some(dir) = report {
        let p = sim_host::report::diagnosis_report(&dir, &file, &series, &d)
            .map_err(|e| Error::Failed(format!("report {}: {e}", dir.display())))?;
        outln!("  report: {}", p.display());
    }
    if let Some(table) = table {
        let path = table.path().to_path_buf();
        // A script that asks for a table learns from the exit code that none was written.
        let model = d.table_model.clone().ok_or_else(|| {
            // NOTE: a file already at the path is left, and named: it is not this
            // record's calibration.
            let older = if table.existed() {
                "; the file already there is not this record's calibration"
            } else {
                ""
            };
            Error::Failed(format!(
                "{}: not written: the diagnosed model has no form the chip can run \
                 (see above), so there is no calibration to export{older}",
                path.display()
            ))
        })?;
        let mut t = tactile_core::calibration::CalibrationTable::default();
        let _ = t.taxels.push(model);
        table.write(sim_host::dynamic_calibration::encode_table(&path, &t)?)?;
        outln!(
            "  calibration table for taxel ({}, {}): {} (the firmware's format; {})",
            taxel.row(),
            taxel.col(),
            path.display(),
            if d.force_estimate.exported {
                "the accepted model"
            } else {
                "the baseline's model"
            }
        );
    }
    Ok(())
}
