//! `tactile experiment`: run one of the memo's experiments, write its record, frames and plot.

use clap::Args;
use sim_host::cli;
use sim_host::rig::RigConfig;
use sim_host::scenario::{Scenario, ScenarioOptions};
use sim_host::Error;
use std::path::PathBuf;

#[derive(Args)]
pub struct ExperimentArgs {
    /// The experiment (see `tactile list`).
    #[arg(value_enum)]
    pub scenario: Scenario,
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Seed of the simulated noise and finger variation.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Load for `step`, and the preload of `excitation`, grams.
    #[arg(long, default_value_t = 50.0)]
    pub load: f32,
    /// The chirp's amplitude in `excitation`, grams.
    #[arg(long, default_value_t = ScenarioOptions::default().excitation_amplitude_g)]
    pub amplitude: f32,
    /// Replace the A1 gain schedule by its 100 g value (the law that failed).
    #[arg(long)]
    pub fixed_gains: bool,
    /// Duration of `pseudo-random` and `sines`, seconds.
    #[arg(long, default_value_t = 100.0)]
    pub duration: f32,
    /// Seed of the pseudo-random and sines protocols.
    #[arg(long, default_value_t = 1989)]
    pub protocol_seed: u64,
    /// Record sample rate, Hz (the control loop runs at 1000).
    #[arg(long, default_value_t = 200.0)]
    pub record_hz: f64,
    /// Switch on an effect, NAME=VALUE (repeatable; see `tactile list`).
    #[arg(long = "effect", value_parser = cli::parse_effect)]
    pub effects: Vec<cli::EffectSetting>,
    /// Skip the PNG.
    #[arg(long)]
    pub no_plot: bool,
    /// Inject a fault, NAME@SECONDS (see `tactile list`).
    #[arg(long, value_parser = cli::parse_fault)]
    pub fault: Option<sim_host::rig::FaultInjection>,
    /// The rig's applicator, a TOML file (`applicators/memo.toml`, the default, shows
    /// every field).
    #[arg(long)]
    pub applicator: Option<PathBuf>,
    /// Run the firmware's designed loop with this controller table (`tactile design --table`)
    /// instead of A1.
    #[arg(long, conflicts_with = "fixed_gains")]
    pub controller: Option<PathBuf>,
}

pub fn run(args: ExperimentArgs) -> Result<(), Error> {
    let ExperimentArgs {
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
        controller,
    } = args;
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
    if let Some(path) = &controller {
        config.firmware.designed = Some(sim_host::error::read_controller(path)?);
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
    Ok(())
}
