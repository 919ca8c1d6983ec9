//! The memo's experiments as named scenarios, each a command profile run on the rig.

use tactile_core::control::GainSchedule;
use tactile_core::profile::{CommandSource, Protocol};

use crate::finger::{Effects, StrainGrid};
use crate::rig::{Rig, RigConfig, RigError, TickRecord};
use tactile_core::tactile::TaxelId;

/// The memo's experiments by the names `tactile experiment` takes, in the order it lists them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Scenario {
    ForceSteps,
    Step,
    StepLoads,
    StaticLinearity,
    PermanentDeformation,
    RepeatedSteps,
    Sweep,
    PseudoRandom,
    Sines,
    LowForce,
    BenchRecord,
    Calibration,
    Excitation,
}

impl Scenario {
    /// Every scenario, in the listed order.
    pub fn all() -> &'static [Scenario] {
        <Scenario as clap::ValueEnum>::value_variants()
    }

    /// The name a user types (`force-steps`, …).
    pub fn name(self) -> &'static str {
        match self {
            Scenario::ForceSteps => "force-steps",
            Scenario::Step => "step",
            Scenario::StepLoads => "step-loads",
            Scenario::StaticLinearity => "static-linearity",
            Scenario::PermanentDeformation => "permanent-deformation",
            Scenario::RepeatedSteps => "repeated-steps",
            Scenario::Sweep => "sweep",
            Scenario::PseudoRandom => "pseudo-random",
            Scenario::Sines => "sines",
            Scenario::LowForce => "low-force",
            Scenario::BenchRecord => "bench-record",
            Scenario::Calibration => "calibration",
            Scenario::Excitation => "excitation",
        }
    }

    /// The scenario called `name`.
    pub fn parse(name: &str) -> Result<Scenario, ScenarioError> {
        Scenario::all()
            .iter()
            .copied()
            .find(|s| s.name() == name)
            .ok_or_else(|| ScenarioError::Unknown(name.to_string()))
    }

    /// The protocol this scenario runs.
    pub fn protocol(self, o: &ScenarioOptions) -> Protocol {
        match self {
            Scenario::ForceSteps => Protocol::FORCE_STEPS_MEMO,
            Scenario::Step => Protocol::Step {
                load_g: o.load_g,
                lead_s: 2.0,
                on_s: 50.0,
                off_s: 25.0,
            },
            Scenario::StepLoads => Protocol::StepLoads,
            Scenario::StaticLinearity => Protocol::StaticLinearity { hold_s: 0.5 },
            Scenario::PermanentDeformation => Protocol::PermanentDeformation,
            Scenario::RepeatedSteps => Protocol::RepeatedSteps {
                load_g: 20.0,
                on_s: 10.0,
                off_s: 5.0,
                count: 6,
            },
            Scenario::Sweep => Protocol::Sweep {
                offset_g: 40.0,
                amplitude_g: 10.0,
                f0_hz: 1.0,
                f1_hz: 54.0,
                duration_s: 30.0,
            },
            Scenario::PseudoRandom => Protocol::pseudo_random_memo(o.protocol_seed, o.duration_s),
            Scenario::Sines => Protocol::Sines {
                seed: o.protocol_seed,
                offset_g: 25.0,
                amplitude_g: 4.0,
                duration_s: o.duration_s,
            },
            Scenario::LowForce => Protocol::LowForce { hold_s: 3.0 },
            Scenario::BenchRecord => Protocol::BenchRecord {
                seed: o.protocol_seed,
            },
            Scenario::Calibration => Protocol::Calibration {
                seed: o.protocol_seed,
                per_offset_s: 15.0,
            },
            Scenario::Excitation => match Protocol::EXCITATION_MEMO {
                Protocol::Excitation { periods, .. } => Protocol::Excitation {
                    preload_g: o.load_g,
                    amplitude_g: o.excitation_amplitude_g,
                    periods,
                },
                other => other,
            },
        }
    }
}

/// Options a scenario takes from the command line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScenarioOptions {
    /// Load for `step` (and `repeated-steps`), and the preload of `excitation`, grams.
    pub load_g: f32,
    /// The chirp's amplitude in `excitation`, grams (several times the tip's stiction force:
    /// a smaller chirp hardly moves the motor).
    pub excitation_amplitude_g: f32,
    /// Seed of the pseudo-random and sines protocols.
    pub protocol_seed: u64,
    /// Replace the A1 schedule by fixed gains at their 100 g value (the law that failed).
    pub fixed_gains: bool,
    /// Duration for the open-ended protocols (pseudo-random, sines), s.
    pub duration_s: f32,
}

impl Default for ScenarioOptions {
    fn default() -> Self {
        Self {
            load_g: 50.0,
            excitation_amplitude_g: 5.0,
            protocol_seed: 1989,
            fixed_gains: false,
            duration_s: 100.0,
        }
    }
}

/// Why a scenario could not start.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ScenarioError {
    #[error("unknown scenario '{0}'; valid scenarios: {valid}", valid = Scenario::all().iter().map(|s| s.name()).collect::<Vec<_>>().join(", "))]
    Unknown(String),
    #[error(transparent)]
    Rig(#[from] RigError),
}

/// The protocol of the scenario called `name`.
pub fn protocol(name: &str, o: &ScenarioOptions) -> Result<Protocol, ScenarioError> {
    Ok(Scenario::parse(name)?.protocol(o))
}

/// A finished run: every control tick and every 8×8 frame.
#[derive(Clone, Debug, Default)]
pub struct Run {
    pub name: String,
    pub ticks: Vec<TickRecord>,
    pub frames: Vec<(f64, StrainGrid)>,
    /// The scan's estimate of each frame (contact, force, centroid), as a board streams it.
    pub estimates: Vec<tactile_core::tasks::ArrayEstimate>,
}

/// Runs `protocol` on a rig built from `config`; `progress` is told the fraction done.
pub fn run_protocol(
    name: &str,
    protocol: Protocol,
    mut config: RigConfig,
    fixed_gains: bool,
    mut progress: impl FnMut(f64),
) -> Result<Run, ScenarioError> {
    if fixed_gains {
        // The memo's failing loop: fixed gains and no contact supervision (the supervisor's
        // bounded re-approach would otherwise hide the failure this demonstrates).
        config.firmware.law.schedule = GainSchedule::Fixed { command_g: 100.0 };
        config.firmware.supervisor.contact_ticks = u16::MAX;
    }
    config.command_slew_g_per_s = protocol.slew_limit_g_per_s();
    let mut rig = Rig::new(config).map_err(ScenarioError::Rig)?;
    let mut source = CommandSource::new(protocol);
    let n = (f64::from(protocol.duration_s()) / tactile_core::CONTROL_PERIOD_S).round() as usize;
    let mut run = Run {
        name: name.to_string(),
        ticks: Vec::with_capacity(n),
        frames: Vec::new(),
        estimates: Vec::new(),
    };
    for k in 0..n {
        let command = source.command_g(rig.time_s() as f32);
        rig.set_drive_excitation(source.chirp(rig.time_s() as f32));
        let frames = &mut run.frames;
        let rec = rig.tick(command, |t, grid| frames.push((t, *grid)));
        if run.frames.len() > run.estimates.len() {
            run.estimates.push(rig.last_array_estimate());
        }
        run.ticks.push(rec);
        if k % 1000 == 0 {
            progress(k as f64 / n as f64);
        }
    }
    progress(1.0);
    Ok(run)
}

/// Runs a named scenario.
pub fn run_named(
    name: &str,
    options: &ScenarioOptions,
    config: RigConfig,
    progress: impl FnMut(f64),
) -> Result<Run, ScenarioError> {
    let p = protocol(name, options)?;
    run_protocol(name, p, config, options.fixed_gains, progress)
}

/// The ticks of a named scenario on the default rig with `seed`, without the array scan (the
/// tables and estimator comparisons need only the probed element), and the finger's springs'
/// load dependence set to `stiffening` (1 = the memo's).
pub fn probe_run(
    name: &str,
    options: ScenarioOptions,
    seed: u64,
    stiffening: f64,
) -> Result<Vec<crate::rig::TickRecord>, ScenarioError> {
    let mut config = RigConfig {
        seed,
        scan_array: false,
        ..Default::default()
    };
    config.effects.stiffening = stiffening;
    Ok(run_named(name, &options, config, |_| {})?.ticks)
}

/// The ticks of `protocol` with the probe over `taxel` of the simulated finger `seed` with
/// `effects`, without the array scan.
pub fn run_on_taxel(
    name: &str,
    protocol: Protocol,
    taxel: TaxelId,
    seed: u64,
    effects: Effects,
) -> Result<Vec<TickRecord>, ScenarioError> {
    let mut config = RigConfig {
        seed,
        scan_array: false,
        effects,
        ..RigConfig::default()
    };
    config.firmware.probe = taxel;
    Ok(run_protocol(name, protocol, config, false, |_| {})?.ticks)
}
