//! The `tactile` command's experiments and demo, kept in the library so tests drive them.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};

use crate::finger::Effects;
use crate::metrics;
use crate::record::{write_frames, write_record};
use crate::rig::RigConfig;
use crate::scenario::{self, Run, Scenario, ScenarioOptions};
use tactile_core::tactile::TaxelId;
use tactile_core::CONTROL_PERIOD_S;

/// Effects the command line can switch on, with what their strength means.
pub const EFFECTS: [(&str, &str); 6] = [
    (
        "stiffening",
        "load dependence of the springs, 1 = the memo's, 0 = linear",
    ),
    ("hysteresis", "play-operator amplitude, % strain"),
    ("drift", "baseline drift, % strain per second"),
    (
        "interference",
        "periodic interference amplitude, % strain (at 7.3 Hz, or VALUE@HZ)",
    ),
    ("delay", "read-out delay, seconds"),
    (
        "slow-relaxation",
        "extra Kelvin compliance relative to G2 at 30 g (tau 40 s)",
    ),
];

/// One `--effect NAME=VALUE` as typed on the command line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EffectSetting {
    Stiffening(f64),
    Hysteresis { pct: f64 },
    Drift { pct_per_s: f64 },
    Interference { pct: f64, hz: Option<f64> },
    Delay { s: f64 },
    SlowRelaxation { strength: f64, tau_s: Option<f64> },
}

impl EffectSetting {
    /// Switches the effect on in `effects`.
    pub fn apply(self, effects: &mut Effects) {
        match self {
            EffectSetting::Stiffening(v) => effects.stiffening = v,
            EffectSetting::Hysteresis { pct } => effects.hysteresis_pct = pct,
            EffectSetting::Drift { pct_per_s } => effects.drift_pct_per_s = pct_per_s,
            EffectSetting::Interference { pct, hz } => {
                effects.interference_pct = pct;
                if let Some(hz) = hz {
                    effects.interference_hz = hz;
                }
            }
            EffectSetting::Delay { s } => effects.delay_s = s,
            EffectSetting::SlowRelaxation { strength, tau_s } => {
                effects.slow_relaxation = strength;
                if let Some(tau) = tau_s {
                    effects.slow_relaxation_tau_s = tau.max(1.0);
                }
            }
        }
    }
}

/// Parses `NAME=VALUE` (clap's value parser for `--effect`: a bad one is a usage error).
pub fn parse_effect(spec: &str) -> Result<EffectSetting, String> {
    let valid = || {
        EFFECTS
            .iter()
            .map(|(n, _)| *n)
            .collect::<Vec<_>>()
            .join(", ")
    };
    let (name, value) = spec.split_once('=').ok_or_else(|| {
        format!(
            "effect '{spec}' is not NAME=VALUE; valid names: {}",
            valid()
        )
    })?;
    let (value, hz) = match value.split_once('@') {
        Some((v, hz)) => (v, Some(hz)),
        None => (value, None),
    };
    let number = |s: &str| -> Result<f64, String> {
        s.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && *v >= 0.0)
            .ok_or_else(|| format!("effect '{name}': '{s}' is not a non-negative number"))
    };
    let v = number(value)?;
    let extra = hz.map(number).transpose()?;
    Ok(match name {
        "stiffening" => EffectSetting::Stiffening(v),
        "hysteresis" => EffectSetting::Hysteresis { pct: v },
        "drift" => EffectSetting::Drift { pct_per_s: v },
        "interference" => EffectSetting::Interference { pct: v, hz: extra },
        "delay" => {
            if v > 0.5 {
                return Err(format!(
                    "effect 'delay': {v} s is longer than the 0.5 s the read-out buffer holds"
                ));
            }
            EffectSetting::Delay { s: v }
        }
        "slow-relaxation" => EffectSetting::SlowRelaxation {
            strength: v,
            tau_s: extra,
        },
        other => {
            return Err(format!(
                "unknown effect '{other}'; valid effects: {}",
                valid()
            ))
        }
    })
}

/// Parses `NAME=VALUE` into the effects.
pub fn apply_effect(effects: &mut Effects, spec: &str) -> Result<(), String> {
    parse_effect(spec)?.apply(effects);
    Ok(())
}

/// Parses `NAME@SECONDS` into a fault injection.
pub fn parse_fault(spec: &str) -> Result<crate::rig::FaultInjection, String> {
    let valid = || crate::rig::InjectedFault::NAMES.join(", ");
    let (name, at) = spec.split_once('@').ok_or_else(|| {
        format!(
            "fault '{spec}' is not NAME@SECONDS; valid faults: {}",
            valid()
        )
    })?;
    let fault = crate::rig::InjectedFault::parse(name)
        .ok_or_else(|| format!("unknown fault '{name}'; valid faults: {}", valid()))?;
    let at_s = at
        .parse::<f64>()
        .ok()
        .filter(|t| t.is_finite() && *t >= 0.0)
        .ok_or_else(|| format!("fault time '{at}' is not a non-negative number of seconds"))?;
    Ok(crate::rig::FaultInjection { fault, at_s })
}

/// What an experiment run produced.
pub struct ExperimentOutput {
    pub run: Run,
    pub summary: String,
    pub files: Vec<PathBuf>,
    pub wall_s: f64,
}

fn progress_bar(name: &str, simulated_s: f64) -> ProgressBar {
    // Runs that take over a second of wall time get a bar (hidden when not on a terminal).
    let bar = if simulated_s > 20.0 {
        ProgressBar::new(1000)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{msg:>22} [{bar:40}] {percent:>3}%")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(name.to_string());
    bar
}

/// Runs a named scenario, writes its record, frames and plot into `out`.
pub fn experiment(
    name: &str,
    options: &ScenarioOptions,
    config: RigConfig,
    out: &Path,
    record_hz: f64,
    plot: bool,
) -> Result<ExperimentOutput, crate::Error> {
    let protocol = scenario::protocol(name, options)?;
    if let Some(f) = config
        .fault
        .filter(|f| f.at_s > f64::from(protocol.duration_s()))
    {
        return Err(crate::Error::Usage(format!(
            "--fault at {} s: `{name}` ends at {} s, so the fault would never happen",
            f.at_s,
            protocol.duration_s()
        )));
    }
    // NOTE: the record keeps every k-th tick of the loop; another rate would be written as the
    // nearest such, quietly.
    let every = ((1.0 / record_hz) / CONTROL_PERIOD_S).round().max(1.0) as usize;
    if (1.0 / (every as f64 * CONTROL_PERIOD_S) - record_hz).abs() > 1e-6 * record_hz {
        let loop_hz = 1.0 / CONTROL_PERIOD_S;
        let k = (loop_hz / record_hz).floor().max(1.0);
        return Err(crate::Error::Usage(format!(
            "--record-hz {record_hz}: the record keeps every k-th tick of the {loop_hz} Hz loop, so its rate is {loop_hz}/k: {:.3} Hz (k = {k}) or {:.3} Hz (k = {})",
            loop_hz / k,
            loop_hz / (k + 1.0),
            k + 1.0
        )));
    }
    std::fs::create_dir_all(out).map_err(crate::Error::io(out))?;
    let seed = config.seed;
    let effects = config.effects;
    let law = if config.firmware.designed.is_some() {
        "designed"
    } else {
        "A1"
    };
    let bar = progress_bar(name, f64::from(protocol.duration_s()));
    let start = Instant::now();
    let run = scenario::run_protocol(name, protocol, config, options.fixed_gains, |f| {
        bar.set_position((f * 1000.0) as u64)
    })?;
    bar.finish_and_clear();
    let wall_s = start.elapsed().as_secs_f64();
    let meta = vec![
        (
            "source".to_string(),
            "tactile simulator (sim-host)".to_string(),
        ),
        ("scenario".to_string(), name.to_string()),
        ("seed".to_string(), seed.to_string()),
        (
            "sample_rate_hz".to_string(),
            format!("{}", 1.0 / (every as f64 * CONTROL_PERIOD_S)),
        ),
        ("fixed_gains".to_string(), options.fixed_gains.to_string()),
        ("law".to_string(), law.to_string()),
        ("effects".to_string(), format!("{effects:?}")),
    ];
    let record = out.join(format!("{name}.csv"));
    write_record(
        &record,
        &meta,
        &run.ticks,
        every,
        &crate::rig::RigConfig::SIM_FIRMWARE.actuator,
    )
    .map_err(crate::Error::io(&record))?;
    let frames = out.join(format!("{name}_frames.csv"));
    write_frames(&frames, &meta, &run.frames).map_err(crate::Error::io(&frames))?;
    let mut files = vec![record, frames];
    if plot {
        let png = out.join(format!("{name}.png"));
        crate::plot::plot_run(&png, name, &run.ticks)
            .map_err(|e| crate::Error::Failed(format!("plot {}: {e}", png.display())))?;
        files.push(png);
    }
    let summary = summarize(&run, wall_s);
    Ok(ExperimentOutput {
        run,
        summary,
        files,
        wall_s,
    })
}

/// The short summary of a run: speed, and what the scenario is judged by.
pub fn summarize(run: &Run, wall_s: f64) -> String {
    let t = &run.ticks;
    let simulated = t.len() as f64 * CONTROL_PERIOD_S;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}: {simulated:.1} s simulated in {wall_s:.2} s ({:.0}x real time), {} frames",
        run.name,
        simulated / wall_s.max(1e-9),
        run.frames.len()
    );
    match run.name.as_str() {
        "force-steps" => match metrics::worst_step_settling_s(t) {
            Some(w) => {
                let _ = writeln!(
                    s,
                    "  worst settling into ±1 g: {:.0} ms (memo: about 80 ms)",
                    w * 1e3
                );
            }
            None => {
                let _ = writeln!(s, "  a step never settled into ±1 g");
            }
        },
        "low-force" => {
            for (level, lost, worst) in metrics::hold_quality(t, 0.3) {
                let _ = writeln!(s, "  {level:>4} g: out of contact {:5.1} % of the hold, worst error {worst:6.2} g", lost * 100.0);
            }
        }
        "static-linearity" => {
            for (load, strain) in
                metrics::static_linearity(t, tactile_core::profile::STEP_SLEW_G_PER_S)
            {
                let _ = writeln!(s, "  {load:>5} g -> {strain:6.2} %");
            }
        }
        "excitation" => {
            // The scenario's protocol, on the simulator's firmware (the rig `experiment` ran).
            let protocol = Scenario::Excitation.protocol(&ScenarioOptions::default());
            let actuator = crate::rig::RigConfig::SIM_FIRMWARE.actuator;
            match crate::applicator_model::frequency_response(t, protocol, &actuator) {
                Ok(response) => match crate::applicator_model::fit_model(&response) {
                    Some(m) => {
                        let _ = writeln!(s, "  model, drive to gauge: {m}");
                    }
                    None => {
                        let _ = writeln!(s, "  no model converged on the measured response");
                    }
                },
                Err(e) => {
                    let _ = writeln!(s, "  not identified: {e}");
                }
            }
        }
        "permanent-deformation" => {
            for (load, r) in metrics::residual_deformation(t) {
                let _ = writeln!(
                    s,
                    "  residual after {load} g for 20 s and 80 s rest: {r:.2} % (memo: {})",
                    if load < 75.0 { "0.2 %" } else { "0.4 %" }
                );
            }
        }
        _ => {}
    }
    let loaded: Vec<_> = t.iter().filter(|r| r.command_g > 0.0).copied().collect();
    if !loaded.is_empty() {
        let track = metrics::rms(
            &loaded,
            |r| f64::from(r.true_force_g),
            |r| f64::from(r.command_g),
        );
        let est = metrics::rms(
            t,
            |r| f64::from(r.estimate_g),
            |r| f64::from(r.true_force_g),
        );
        let _ = writeln!(s, "  tracking RMS (force − command, loaded): {track:.2} g; on-chip estimate RMS error: {est:.2} g");
    }
    // NOTE: a rig whose supervisor latched ran the rest of the protocol with the drive off;
    // its figures above are of that, and say nothing of why.
    if let Some(r) = t.iter().find(|r| {
        r.faults
            .contains(tactile_core::telemetry::FaultFlags::LATCHED)
    }) {
        let _ = writeln!(
            s,
            "  the supervisor stopped the drive at {:.3} s ({:?}); the figures after it are of a stopped rig",
            r.t_s, r.faults
        );
    }
    s
}

/// Lists the scenarios and effects.
pub fn listing() -> String {
    let mut s = String::from("scenarios:\n");
    for n in Scenario::all() {
        let _ = writeln!(s, "  {}", n.name());
    }
    s.push_str("effects (--effect NAME=VALUE):\n");
    for (n, d) in EFFECTS {
        let _ = writeln!(s, "  {n:<16} {d}");
    }
    let _ = writeln!(
        s,
        "faults (--fault NAME@SECONDS):\n  {}",
        crate::rig::InjectedFault::NAMES.join(", ")
    );
    s
}

/// `ROW,COL=FILE` → the taxel and the file.
pub fn parse_taxel_record(arg: &str) -> Result<(TaxelId, PathBuf), String> {
    let usage =
        || format!("'{arg}': expected ROW,COL=FILE with ROW and COL in 0..8 (e.g. 3,2=taxel.csv)");
    let (pos, file) = arg.split_once('=').ok_or_else(usage)?;
    let taxel = parse_taxel(pos).ok_or_else(usage)?;
    if file.is_empty() {
        return Err(usage());
    }
    Ok((taxel, PathBuf::from(file)))
}

/// `ROW,COL` (from zero) → the taxel, `None` off the array or malformed.
pub fn parse_taxel(pos: &str) -> Option<TaxelId> {
    let (r, c) = pos.split_once(',')?;
    TaxelId::new(r.trim().parse().ok()?, c.trim().parse().ok()?)
}

/// `tactile calibrate`: fits each record (or the simulated finger's four calibration taxels),
/// writes the table, and returns a summary.
pub fn calibrate(
    records: &[(TaxelId, PathBuf)],
    out: &Path,
    seed: u64,
    finger: crate::fingers::FingerKind,
) -> Result<String, crate::Error> {
    use crate::dynamic_calibration::{calibrate_simulated, fit_taxel, CALIBRATION_TAXELS};
    use crate::Error::{Failed, Usage};
    // Bad usage is refused before any output is claimed or record read.
    if let Some((t, _)) = records
        .iter()
        .enumerate()
        .find_map(|(i, (t, _))| records[..i].iter().find(|(u, _)| u == t))
    {
        return Err(Usage(format!(
            "taxel ({}, {}) given twice",
            t.row(),
            t.col()
        )));
    }
    let inputs: Vec<&Path> = records.iter().map(|(_, p)| p.as_path()).collect();
    let table_out = crate::output::Output::claim(out, &inputs)?;
    let json_out = crate::output::Output::claim(&out.with_extension("json"), &inputs)?;
    let (table, reports, source) = if records.is_empty() {
        let (t, r) = calibrate_simulated(&CALIBRATION_TAXELS, seed, finger.effects())?;
        (
            t,
            r,
            format!("the simulated finger (seed {seed}, {})", finger.name()),
        )
    } else {
        let mut table = tactile_core::calibration::CalibrationTable::default();
        let mut reports = Vec::new();
        for (taxel, path) in records {
            let taxel = *taxel;
            let r = crate::record::read_record(path)?;
            // What `tactile diagnose` refuses says nothing of a taxel either (a dead strain
            // channel was only flagged, and its table estimated 5 820 g off).
            crate::chip_diagnosis::series_of(&r).map_err(|reason| {
                Failed(format!(
                    "{}: cannot be calibrated: {reason}",
                    path.display()
                ))
            })?;
            let dt = r.sample_period_s().ok_or_else(|| {
                Failed(format!(
                    "{}: too short to have a sample period",
                    path.display()
                ))
            })?;
            let (model, report) = fit_taxel(
                taxel,
                tactile_core::profile::Protocol::CALIBRATION,
                dt,
                &r.force_g,
                &r.strain_pct,
            )
            .map_err(|e| Failed(format!("{}: {e}", path.display())))?;
            table
                .taxels
                .push(model)
                .map_err(|_| Usage("more taxels than the array has".into()))?;
            reports.push(report);
        }
        (table, reports, format!("{} record(s)", records.len()))
    };
    let bytes = crate::dynamic_calibration::encode_table(out, &table)?;
    let n = bytes.len();
    table_out.write(bytes)?;
    let summary = serde_json::json!({ "taxels": reports, "table_bytes": n });
    let json = json_out.write_json(&summary)?;
    let mut text = format!(
        "calibrated {} taxel(s) from {source}\n\nheld out: RMS force error (g) on the blocks of the record each fold did not fit, elastic / second order / scheduled / observer / force bank; alpha's prior's share: how much of what the fit knows of alpha is its prior's (element 4,2's 5) rather than the record's, above 50 % alpha is the prior's\n\n| taxel | rest offset (%) | G1(30 g) | N1 | alpha (prior's share) | N2 | G2(30 g) | range (g) | element RMS (%) | held out, calibrated | held out, nominal | runs | flags |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        table.taxels.len()
    );
    let four = |v: &[f64; tactile_core::estimator::EstimatorKind::COUNT]| {
        v.map(|x| format!("{x:.2}")).join(" / ")
    };
    for (m, r) in table.taxels.iter().zip(&reports) {
        let e = &m.element;
        let _ = writeln!(
            text,
            "| ({}, {}) | {:.3} | {:.2} | {:.0} | {:.2} ({:.0} %) | {:.0} | {:.1} | {:.0} | {:.4} | {} | {} | {} | {} |",
            m.taxel.row(),
            m.taxel.col(),
            m.strain_offset_pct,
            e.g1.stiffness(30.0),
            e.n1,
            e.alpha,
            100.0 * r.alpha_prior_share,
            e.n2,
            e.g2.stiffness(30.0),
            r.range_g,
            r.element_rms_pct,
            four(&r.held_out_g),
            four(&r.nominal_held_out_g),
            r.estimator,
            if r.flags.is_empty() { "-".to_string() } else { r.flags.join(", ") },
        );
    }
    let _ = write!(
        text,
        "\nwrote {} ({n} bytes) and {}",
        out.display(),
        json.display()
    );
    Ok(text)
}

#[cfg(test)]
mod calibrate_tests {
    use super::*;

    fn taxel_record(arg: &str) -> (TaxelId, PathBuf) {
        parse_taxel_record(arg).unwrap()
    }

    #[test]
    fn taxel_record_arguments_are_checked() {
        let (t, f) = parse_taxel_record("3,2=rec.csv").unwrap();
        assert_eq!((t.row(), t.col(), f), (3, 2, PathBuf::from("rec.csv")));
        for bad in ["3,2", "8,0=a.csv", "3=a.csv", "a,b=c.csv", "3,2="] {
            let e = parse_taxel_record(bad).unwrap_err();
            assert!(e.contains("ROW,COL=FILE"), "{bad}: {e}");
        }
        let memo = crate::fingers::FingerKind::Memo;
        let missing = parse_taxel_record("1,1=/nonexistent/x.csv").unwrap();
        let e = calibrate(&[missing], Path::new("/tmp/t.bin"), 1, memo).unwrap_err();
        assert!(
            matches!(e, crate::Error::Record(_)) && e.to_string().contains("x.csv"),
            "{e:?}"
        );
        assert_eq!(e.exit_code(), 1);
        // The same taxel twice is bad usage (exit 2).
        let twice = [taxel_record("2,2=a.csv"), taxel_record("2,2=b.csv")];
        let e = calibrate(&twice, Path::new("/tmp/t.bin"), 1, memo).unwrap_err();
        assert!(matches!(e, crate::Error::Usage(_)), "{e:?}");
        assert_eq!(e.exit_code(), 2);
    }
}
