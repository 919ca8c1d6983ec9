//! `tactile`: the memo's experiments on the simulator.
//!
//! ```text
//! tactile list
//! tactile experiment NAME [--out DIR] [--seed N] [--load G] [--fixed-gains] [--duration S]
//!                         [--record-hz HZ] [--effect NAME=VALUE]... [--no-plot]
//! tactile calibrate [ROW,COL=FILE]... [--out TABLE.bin] [--seed N]
//! tactile fit FILE [--model NAME] [--json OUT]
//! tactile diagnose FILE [--json OUT] [--report DIR] [--table OUT.bin] [--taxel R,C]
//! tactile estimate FILE --table TABLE.bin [--taxel R,C] [--estimator NAME] [--out OUT.csv]
//! tactile tables [--out DIR]
//! tactile estimators [--out DIR] [--seed N]
//! tactile demo [--out DIR] [--seed N]
//! ```
//! Exit codes: 0 done, 1 failed while running, 2 bad usage (unknown scenario, effect, option).

use sim_host::fingers::FingerKind;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use sim_host::cli;
use sim_host::fit::Base;
use sim_host::output::Output;
use sim_host::rig::RigConfig;
use sim_host::scenario::{Scenario, ScenarioOptions};
use sim_host::Error;
use tactile_core::tactile::TaxelId;

#[derive(Parser)]
#[command(
    name = "tactile",
    version,
    about = "Force applicator and tactile finger after UCB/ERL M89/138, on the simulator"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// What `tactile board` asks of the board.
#[derive(Subcommand)]
enum BoardCommand {
    /// Run a protocol and record it.
    Run {
        #[arg(value_enum)]
        protocol: sim_host::board::BoardProtocol,
        /// Length of pseudo-random, s.
        #[arg(long, default_value_t = 10.0)]
        duration: f32,
        /// The excitation's preload, g.
        #[arg(long, default_value_t = 50.0)]
        load: f32,
        /// The calibration's taxel under the probe, ROW,COL.
        #[arg(long, default_value = "3,2", value_parser = taxel_arg)]
        taxel: TaxelId,
        /// Under the designed force controller (the build's table) instead of A1.
        #[arg(long)]
        designed: bool,
    },
    /// Hold a force, then stop.
    Hold {
        force_g: f32,
        #[arg(long, default_value_t = 5.0)]
        seconds: f32,
    },
    /// Calibrate taxels: the calibration protocol over each (ROW,COL) in turn, the table fitted
    /// to their records (OUT/calibration-table.bin), loaded into the board and run.
    Calibrate {
        #[arg(required = true, value_parser = taxel_arg)]
        taxels: Vec<TaxelId>,
    },
    /// Decode what the board streams (a saved log with --replay LOG, a board with --probe).
    Stream {
        /// How long to follow a live board, s.
        #[arg(long, default_value_t = 10.0)]
        seconds: f32,
    },
}

#[derive(Subcommand)]
enum Command {
    /// List the scenarios and the effects that can be switched on.
    List,
    /// Run one of the memo's experiments, write its record, frames and plot.
    Experiment {
        /// The experiment (see `tactile list`).
        #[arg(value_enum)]
        scenario: Scenario,
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Seed of the simulated noise and finger variation.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Load for `step`, and the preload of `excitation`, grams.
        #[arg(long, default_value_t = 50.0)]
        load: f32,
        /// The chirp's amplitude in `excitation`, grams.
        #[arg(long, default_value_t = ScenarioOptions::default().excitation_amplitude_g)]
        amplitude: f32,
        /// Replace the A1 gain schedule by its 100 g value (the law that failed).
        #[arg(long)]
        fixed_gains: bool,
        /// Duration of `pseudo-random` and `sines`, seconds.
        #[arg(long, default_value_t = 100.0)]
        duration: f32,
        /// Seed of the pseudo-random and sines protocols.
        #[arg(long, default_value_t = 1989)]
        protocol_seed: u64,
        /// Record sample rate, Hz (the control loop runs at 1000).
        #[arg(long, default_value_t = 200.0)]
        record_hz: f64,
        /// Switch on an effect, NAME=VALUE (repeatable; see `tactile list`).
        #[arg(long = "effect", value_parser = cli::parse_effect)]
        effects: Vec<cli::EffectSetting>,
        /// Skip the PNG.
        #[arg(long)]
        no_plot: bool,
        /// Inject a fault, NAME@SECONDS (see `tactile list`).
        #[arg(long, value_parser = cli::parse_fault)]
        fault: Option<sim_host::rig::FaultInjection>,
        /// The rig's applicator, a TOML file (`applicators/memo.toml`, the default, shows
        /// every field).
        #[arg(long)]
        applicator: Option<PathBuf>,
    },
    /// Fit one of the memo's models to a record (t_s,force_g,strain_pct).
    Fit {
        file: PathBuf,
        /// The model to fit.
        #[arg(long, value_enum, default_value_t = Base::MkAlpha)]
        model: Base,
        /// Write the fit as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Find what a linear Maxwell–Kelvin model misses in a record, add it, report before/after.
    Diagnose {
        file: PathBuf,
        /// Write the diagnosis as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Write plots and a report into this folder.
        #[arg(long)]
        report: Option<PathBuf>,
        /// Write the accepted model as a calibration table for the firmware (one taxel); where
        /// there is nothing the chip can run, no file is written and the exit code is 1.
        #[arg(long)]
        table: Option<PathBuf>,
        /// The taxel the record is of, ROW,COL from zero (for --table).
        #[arg(long, default_value = "3,2", value_parser = taxel_arg)]
        taxel: TaxelId,
    },
    /// Run the chip's estimators (the firmware's own code) over a record's strain with a
    /// calibration table; write the force estimates as a record; with a reference force, print
    /// each estimator's error.
    Estimate {
        file: PathBuf,
        /// The calibration table (`tactile calibrate` or `tactile diagnose --table`).
        #[arg(long)]
        table: PathBuf,
        /// The taxel of the table the record is of, ROW,COL from zero.
        #[arg(long, default_value = "3,2", value_parser = taxel_arg)]
        taxel: TaxelId,
        /// Only this estimator (default: all four).
        #[arg(long, value_enum)]
        estimator: Option<sim_host::estimate::Estimator>,
        /// Where to write the estimates (default: FILE with `_estimate.csv`).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Identify the applicator from a record of the excitation (`tactile experiment excitation
    /// --record-hz 1000`, with its drive): the measured response and a low-order model.
    Identify {
        file: PathBuf,
        /// Write the response and the model as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Check an applicator file and write the form the QEMU firmware reads at start-up
    /// (`boards/qemu-netduinoplus2/run.sh OUT applicator=FILE.toml` does this for you).
    Applicator {
        /// The applicator, a TOML file (`applicators/*.toml`).
        file: PathBuf,
        /// Write its checked binary form here.
        #[arg(long)]
        out: PathBuf,
    },
    /// Design the force controller for the simulated rig (issue 13): the excitation at six
    /// preloads, a model at each, the static gain and stiction from the holds, then the
    /// feed-forward's schedule and the feedback's gains from the margins. A1 stays the
    /// default loop; `cargo run --release -p sim-host --example design_controller` measures
    /// the design against it.
    Design {
        /// The rig's applicator, a TOML file (default: the memo's).
        #[arg(long)]
        applicator: Option<PathBuf>,
        /// Design from these records of the excitation at several preloads instead of
        /// simulating it (a board's, or the QEMU firmware's identification session:
        /// `boards/qemu-netduinoplus2/run.sh OUT session=excitation`).
        #[arg(long, num_args = 1.., conflicts_with = "applicator")]
        records: Vec<PathBuf>,
        /// Write the models, the gains and the margins as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Write the controller's table here (the bytes the firmware checks at start-up;
        /// `boards/controller/table.bin` is the QEMU build's).
        #[arg(long)]
        table: Option<PathBuf>,
    },
    /// Drive a board from the host: commands down, its defmt stream up, decoded as it arrives
    /// into records (`OUT/NAME.csv`), with a progress bar and a live line (force, error,
    /// faults, frames lost). The board is the QEMU firmware (`cargo fw-qemu` builds it), or
    /// with --probe an STM32F407G-DISC1 over SWD (`cargo fw-f407` builds its firmware).
    Board {
        /// The firmware ELF: its defmt table, what QEMU runs, what --flash writes
        /// [default: the QEMU build's, or the F407 build's with --probe].
        #[arg(long)]
        elf: Option<PathBuf>,
        /// Decode a saved log of the firmware instead of running it.
        #[arg(long, conflicts_with = "probe")]
        replay: Option<PathBuf>,
        /// A board through the first debug probe found: its RTT channels carry the commands
        /// and the stream.
        #[arg(long)]
        probe: bool,
        /// With --probe: the chip, as probe-rs names it.
        #[arg(long, requires = "probe", default_value = sim_host::probe::F407)]
        chip: String,
        /// With --probe: write the ELF to the chip and reset it first.
        #[arg(long, requires = "probe")]
        flash: bool,
        #[arg(long, default_value = "out/board")]
        out: PathBuf,
        #[command(subcommand)]
        action: BoardCommand,
    },
    /// Reproduce the memo's Tables I–IV on the simulator, beside the memo's numbers.
    Tables {
        #[arg(long, default_value = "out/tables")]
        out: PathBuf,
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Compare the force estimators on the simulator's protocols, nominal and calibrated.
    Estimators {
        #[arg(long, default_value = "out/estimators")]
        out: PathBuf,
        /// Seed of the simulated finger whose four taxels are calibrated and scored.
        #[arg(long, default_value_t = sim_host::calibrate::FINGER_SEED)]
        seed: u64,
        /// The kind of finger: the memo's, or one whose springs stiffen by other laws.
        #[arg(long, value_enum, default_value_t = FingerKind::Memo)]
        finger: FingerKind,
        /// Also the firmware's row: a folder `tactile-decode` wrote from a QEMU session
        /// (`boards/qemu-netduinoplus2/run.sh DIR`), with its `estimators.json`.
        #[arg(long)]
        qemu: Option<PathBuf>,
    },
    /// Dynamic calibration: fit each taxel's models to its record of the calibration protocol
    /// and write the table the firmware reads at start-up. Without records, calibrates four
    /// taxels of the simulated finger.
    Calibrate {
        /// ROW,COL=FILE: a taxel (from zero) and its record of the calibration protocol.
        #[arg(value_parser = cli::parse_taxel_record)]
        records: Vec<(TaxelId, PathBuf)>,
        /// The table (binary, what the firmware's calibration sector holds).
        #[arg(long, default_value = "out/calibration/table.bin")]
        out: PathBuf,
        /// Seed of the simulated finger (without records).
        #[arg(long, default_value_t = sim_host::calibrate::FINGER_SEED)]
        seed: u64,
        /// The kind of simulated finger (without records).
        #[arg(long, value_enum, default_value_t = FingerKind::Memo)]
        finger: FingerKind,
    },
    /// The main job without a board: the memo's experiment set, plots and a report.
    Demo {
        #[arg(long, default_value = "out/demo")]
        out: PathBuf,
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
}

/// `println!`/`print!` that ignore a closed pipe (`tactile … | head`) instead of panicking.
macro_rules! outln {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}
macro_rules! out {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout(), $($t)*);
    }};
}

/// The firmware's estimator figures from a decoded QEMU session's folder.
fn read_firmware_figures(dir: &Path) -> Result<sim_host::record::FirmwareFigures, Error> {
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
fn claim_report(out: &Path, name: &str) -> Result<(Output, Output), Error> {
    Ok((
        Output::claim(&out.join(format!("{name}.md")), &[])?,
        Output::claim(&out.join(format!("{name}.json")), &[])?,
    ))
}

/// Prints a Markdown report and writes it, with its data as JSON, to the claimed files.
fn print_and_write(
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
fn read_series(file: &Path) -> Result<sim_host::fit::Series, Error> {
    sim_host::fit::Series::checked(&sim_host::record::read_record(file)?)
        .map_err(|reason| Error::Failed(format!("{}: cannot be fitted: {reason}", file.display())))
}

/// `--taxel ROW,COL` for clap (a bad one is a usage error, exit code 2).
fn taxel_arg(text: &str) -> Result<TaxelId, String> {
    cli::parse_taxel(text).ok_or_else(|| "expected ROW,COL with ROW and COL in 0..8".to_string())
}

/// The one place errors become exit codes: 0 done, 1 the run failed, 2 bad usage (clap exits 2
/// itself for what it refuses).
fn main() -> ExitCode {
    match run(Cli::parse().command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("tactile: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}

fn run(command: Command) -> Result<(), Error> {
    match command {
        Command::List => out!("{}", cli::listing()),
        Command::Experiment {
            scenario,
            out,
            seed,
            load,
            fixed_gains,
            duration,
            amplitude,
            protocol_seed,
            record_hz,
            effects,
            no_plot,
            fault,
            applicator,
        } => {
            if !(record_hz > 0.0 && record_hz <= 1000.0) {
                return Err(Error::Usage(format!(
                    "--record-hz {record_hz}: must be in (0, 1000]"
                )));
            }
            if !(load.is_finite() && (0.0..=120.0).contains(&load)) {
                return Err(Error::Usage(format!(
                    "--load {load}: the applicator's range is 0 to 120 g"
                )));
            }
            // A second at least: shorter, a record holds a few rows and the figures none.
            if !(duration.is_finite() && (1.0..=3600.0).contains(&duration)) {
                return Err(Error::Usage(format!(
                    "--duration {duration}: must be in [1, 3600] s"
                )));
            }
            let mut config = RigConfig {
                seed,
                fault,
                ..Default::default()
            };
            if let Some(path) = &applicator {
                config.set_applicator(sim_host::error::read_applicator(path)?);
            }
            for effect in effects {
                effect.apply(&mut config.effects);
            }
            if !(amplitude.is_finite() && amplitude > 0.0 && amplitude <= 50.0) {
                return Err(Error::Usage(format!(
                    "--amplitude {amplitude}: must be in (0, 50] g"
                )));
            }
            let options = ScenarioOptions {
                load_g: load,
                excitation_amplitude_g: amplitude,
                protocol_seed,
                fixed_gains,
                duration_s: duration,
            };
            let o = cli::experiment(scenario.name(), &options, config, &out, record_hz, !no_plot)?;
            out!("{}", o.summary);
            for f in o.files {
                outln!("  wrote {}", f.display());
            }
        }
        Command::Applicator { file, out } => {
            let params = sim_host::error::read_applicator(&file)?;
            let bytes = params.encode();
            Output::claim(&out, &[&file])?.write(bytes)?;
            outln!(
                "{}: checked; wrote {} ({} bytes)",
                file.display(),
                out.display(),
                bytes.len()
            );
        }
        Command::Identify { file, json } => {
            let json = Output::claim_some(json.as_deref(), &[&file])?;
            let rec = tactile_record::read_record(&file)?;
            let failed = |e: sim_host::identify::IdentifyError| {
                Error::Failed(format!("{}: {e}", file.display()))
            };
            let means = sim_host::identify::period_means_of_record(&rec).map_err(failed)?;
            let response = means.response().map_err(failed)?;
            let plain = sim_host::identify::fit_model(&response).ok_or_else(|| {
                Error::Failed(format!(
                    "{}: no model converged on the measured response",
                    file.display()
                ))
            })?;
            // The motor's friction simulated in the model, its stiction fitted to the chirp from
            // the hold's drive less its gauge (one hold gives no static line).
            let held_g = sim_host::identify::hold_means_of_record(&rec)
                .map_or(0.0, |h| (h.drive_g - h.gauge_g).max(0.0));
            let linear = means.fit_less_friction(held_g).unwrap_or(plain);
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
                    model: &'a sim_host::identify::ApplicatorModel,
                    /// Fitted with the model (`null`: not simulated).
                    stiction_g: Option<f64>,
                    plain_model: &'a sim_host::identify::ApplicatorModel,
                    response: &'a [sim_host::identify::ResponsePoint],
                }
                let path = json.write_json(&Out {
                    model: &model,
                    stiction_g,
                    plain_model: &plain,
                    response: &response,
                })?;
                outln!("  wrote {}", path.display());
            }
        }
        Command::Design {
            applicator,
            records,
            json,
            table,
        } => {
            let inputs: Vec<&Path> = records
                .iter()
                .map(PathBuf::as_path)
                .chain(applicator.as_deref())
                .collect();
            let json = Output::claim_some(json.as_deref(), &inputs)?;
            let table = Output::claim_some(table.as_deref(), &inputs)?;
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
                    match sim_host::design::excited_of_record(&rec)
                        .map_err(sim_host::design::left_out_of)
                    {
                        Ok(e) => excited.push(e),
                        Err(Ok(mut left)) => {
                            left.why = format!("{}: {}", file.display(), left.why);
                            left_out.push(left);
                        }
                        Err(Err(e)) => {
                            return Err(Error::Failed(format!("{}: {e}", file.display())))
                        }
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
                tactile_core::tracking::APPROACH_TICKS,
                d.config.approach_hold_g,
                d.config.approach_push_g,
                d.config.approach_brake_g,
                d.config.contact_g,
                tactile_core::tracking::TOUCH_RATE_G_PER_S,
                tactile_core::tracking::TOUCH_TAU_S
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
        }
        Command::Fit { file, model, json } => {
            let json = Output::claim_some(json.as_deref(), &[&file])?;
            let series = read_series(&file)?;
            let start = std::time::Instant::now();
            let fit = sim_host::fit::fit(&sim_host::fit::ModelSpec::new(model), &series, &[])
                .ok_or_else(|| {
                    Error::Failed(format!(
                        "no start of the {} fit converged on {}",
                        model.name(),
                        file.display()
                    ))
                })?;
            out!("{}", sim_host::fit::describe(&fit));
            outln!(
                "  ({} evaluations, {:.2} s)",
                fit.evaluations,
                start.elapsed().as_secs_f64()
            );
            if let Some(json) = json {
                json.write_json(&fit)?;
            }
        }
        Command::Diagnose {
            file,
            json,
            report,
            table,
            taxel,
        } => {
            let json = Output::claim_some(json.as_deref(), &[&file])?;
            let table = Output::claim_some(table.as_deref(), &[&file])?;
            if let Some(dir) = &report {
                std::fs::create_dir_all(dir).map_err(Error::io(dir))?;
            }
            let record = sim_host::record::read_record(&file)?;
            let jitter = record.jitter();
            if jitter > 0.01 {
                outln!(
                    "time stamps jitter by up to {:.0} % of the step: read as evenly sampled every \
                     {:.6} s",
                    100.0 * jitter,
                    record.sample_period_s().unwrap_or(0.0)
                );
            }
            let series = sim_host::diagnose::into_series(record).map_err(|reason| {
                Error::Failed(format!("{}: cannot be diagnosed: {reason}", file.display()))
            })?;
            let start = std::time::Instant::now();
            let d = sim_host::diagnose::diagnose(&series, taxel);
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
                table.write(sim_host::calibrate::encode_table(&path, &t)?)?;
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
        }
        Command::Estimate {
            file,
            table,
            taxel,
            estimator,
            out,
        } => {
            let text = sim_host::estimate::run(&file, &table, taxel, estimator, out.as_deref())?;
            out!("{text}");
        }
        Command::Board {
            elf,
            replay,
            probe,
            chip,
            flash,
            out,
            action,
        } => {
            let action = match action {
                BoardCommand::Run {
                    protocol,
                    duration,
                    load,
                    taxel,
                    designed,
                } => sim_host::board::Action::Run {
                    protocol,
                    duration_s: duration,
                    load_g: load,
                    taxel,
                    designed,
                },
                BoardCommand::Hold { force_g, seconds } => {
                    sim_host::board::Action::Hold { force_g, seconds }
                }
                BoardCommand::Stream { seconds } => sim_host::board::Action::Stream { seconds },
                BoardCommand::Calibrate { taxels } => sim_host::board::Action::Calibrate { taxels },
            };
            let target = match (&replay, probe) {
                (Some(log), _) => sim_host::board::Target::Replay(log),
                (None, true) => sim_host::board::Target::Probe { chip: &chip, flash },
                (None, false) => sim_host::board::Target::Qemu,
            };
            let elf = elf.unwrap_or_else(|| {
                PathBuf::from(if probe {
                    "target/thumbv7em-none-eabihf/release/tactile-f407"
                } else {
                    "target/thumbv7em-none-eabihf/release/tactile-qemu"
                })
            });
            let text = sim_host::board::run(&elf, target, &action, &out)?;
            out!("{text}");
        }
        Command::Tables { out, seed } => {
            let files = claim_report(&out, "tables")?;
            let t = sim_host::tables::reproduce(seed)?;
            print_and_write(files, &sim_host::tables::render(&t), &t)?;
        }
        Command::Estimators {
            out,
            seed,
            finger,
            qemu,
        } => {
            let firmware = qemu.map(|dir| read_firmware_figures(&dir)).transpose()?;
            let files = claim_report(&out, "estimators")?;
            let t = sim_host::estimators::compare(seed, finger)?;
            let mut text = sim_host::estimators::render(&t);
            if let Some(f) = &firmware {
                text.push('\n');
                text.push_str(&f.render());
            }
            let data = serde_json::json!({ "simulator": t, "firmware": firmware });
            print_and_write(files, &text, &data)?;
        }
        Command::Calibrate {
            records,
            out,
            seed,
            finger,
        } => outln!("{}", cli::calibrate(&records, &out, seed, finger)?),
        Command::Demo { out, seed } => {
            let path = cli::demo(&out, seed)?;
            outln!("report: {}", path.display());
        }
    }
    Ok(())
}
