//! `tactile estimate`: the chip's estimators, the firmware's own code, run over a record's strain
//! with a calibration table, for the user who has a table and a new record.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use tactile_core::calibration::CalibrationTable;
use tactile_core::estimator::{EstimatorKind, TaxelEstimators};
use tactile_core::tactile::TaxelId;

use crate::output::Output;
use crate::Error;

/// The estimators by the names a user types.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Estimator {
    Elastic,
    SecondOrder,
    Scheduled,
    Observer,
    Bank,
}

impl Estimator {
    fn kind(self) -> EstimatorKind {
        match self {
            Estimator::Elastic => EstimatorKind::Elastic,
            Estimator::SecondOrder => EstimatorKind::SecondOrderInverse,
            Estimator::Scheduled => EstimatorKind::ScheduledInverse,
            Estimator::Observer => EstimatorKind::Observer,
            Estimator::Bank => EstimatorKind::Bank,
        }
    }
    fn column(self) -> &'static str {
        match self {
            Estimator::Elastic => "elastic_g",
            Estimator::SecondOrder => "second_order_g",
            Estimator::Scheduled => "scheduled_g",
            Estimator::Observer => "observer_g",
            Estimator::Bank => "bank_g",
        }
    }
}

const ALL: [Estimator; EstimatorKind::COUNT] = [
    Estimator::Elastic,
    Estimator::SecondOrder,
    Estimator::Scheduled,
    Estimator::Observer,
    Estimator::Bank,
];

/// Runs the estimators; writes `t_s,force_g,strain_pct,<estimates>` to `out` (default: beside
/// the record); returns the text to print (each estimator's RMS against the record's force).
pub fn run(
    file: &Path,
    table: &Path,
    taxel: TaxelId,
    only: Option<Estimator>,
    out: Option<&Path>,
) -> Result<String, Error> {
    let record = crate::record::read_record(file)?;
    // The plausibility `tactile diagnose` checks first: a strain of 10²⁰⁰ % is a unit error,
    // not a load to estimate.
    tactile_ident::series::check_scale(&record.force_g, &record.strain_pct).map_err(|reason| {
        Error::Failed(format!("{}: cannot be estimated: {reason}", file.display()))
    })?;
    let dt = record.sample_period_s().ok_or_else(|| {
        Error::Failed(format!(
            "{}: too few samples to know the sample period",
            file.display()
        ))
    })?;
    tactile_ident::series::check_period(dt).map_err(|reason| {
        Error::Failed(format!("{}: cannot be estimated: {reason}", file.display()))
    })?;
    let bytes = std::fs::read(table).map_err(Error::io(table))?;
    let decoded = CalibrationTable::decode(&bytes).map_err(|source| Error::Table {
        path: table.to_path_buf(),
        source,
    })?;
    let model = decoded.get(taxel).cloned().ok_or_else(|| {
        Error::Usage(format!(
            "{}: no entry for taxel ({}, {})",
            table.display(),
            taxel.row(),
            taxel.col()
        ))
    })?;
    let mut est = TaxelEstimators::new(&model, dt).map_err(|e| {
        Error::Failed(format!(
            "{}: the taxel's model cannot run: {e}",
            table.display()
        ))
    })?;
    let chosen: Vec<Estimator> = only.map_or(ALL.to_vec(), |e| vec![e]);
    let index = |e: Estimator| e.kind().index();
    let runs = ALL
        .into_iter()
        .find(|e| e.kind() == model.estimator)
        .unwrap_or(Estimator::Elastic);
    let out_path: PathBuf = out.map(Path::to_path_buf).unwrap_or_else(|| {
        let stem = file
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("record");
        file.with_file_name(format!("{stem}_estimate.csv"))
    });
    // NOTE: the estimates written over the record would replace it, its other columns lost.
    let f = Output::claim(&out_path, &[file, table])?.into_file()?;
    let mut w = std::io::BufWriter::new(f);
    let io = |e: std::io::Error| Error::Io {
        path: out_path.clone(),
        source: e,
    };
    writeln!(
        w,
        "# estimates of {} with {}",
        file.display(),
        table.display()
    )
    .map_err(io)?;
    writeln!(w, "# sample_rate_hz={}", 1.0 / dt).map_err(io)?;
    writeln!(w, "# chip_runs={}", runs.column()).map_err(io)?;
    let names: Vec<&str> = chosen.iter().map(|e| e.column()).collect();
    writeln!(w, "t_s,force_g,strain_pct,{}", names.join(",")).map_err(io)?;
    let mut sums = vec![0.0f64; chosen.len()];
    for i in 0..record.len() {
        let all = est.update(record.strain_pct[i] as f32);
        let mut line = format!(
            "{:.6},{:.4},{:.6}",
            record.t_s[i], record.force_g[i], record.strain_pct[i]
        );
        for (k, e) in chosen.iter().enumerate() {
            let v = f64::from(all[index(*e)]);
            sums[k] += (v - record.force_g[i]).powi(2);
            let _ = write!(line, ",{v:.4}");
        }
        writeln!(w, "{line}").map_err(io)?;
    }
    w.flush().map_err(io)?;
    let mut text = format!(
        "{} samples at {:.0} Hz, taxel ({}, {}) of {}\n",
        record.len(),
        1.0 / dt,
        taxel.row(),
        taxel.col(),
        table.display()
    );
    text.push_str(&crate::chip_diagnosis::chip_choice(&model));
    for (k, e) in chosen.iter().enumerate() {
        let rms = (sums[k] / record.len().max(1) as f64).sqrt();
        let _ = if rms.is_finite() {
            writeln!(
                text,
                "  {:<22} RMS against the record's force {rms:.3} g{}",
                e.kind().name(),
                if *e == runs { " (the chip's)" } else { "" }
            )
        } else {
            writeln!(
                text,
                "  {:<22} RMS against the record's force: none (an estimate is not finite)",
                e.kind().name()
            )
        };
    }
    let _ = writeln!(text, "  estimates: {}", out_path.display());
    Ok(text)
}
