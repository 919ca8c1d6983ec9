//! `tactile demo`: the memo's experiment set, the designed controller beside A1, the memo's
//! tables and the force estimators, in one report. The four parts are independent, so they
//! run on threads (the budget is the wall time of the main job).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::cli::experiment;
use crate::metrics;
use crate::rig::RigConfig;
use crate::scenario::ScenarioOptions;
use tactile_core::CONTROL_PERIOD_S;

/// The main job without a board: the memo's experiment set, plots, and a report.
pub fn demo(out: &Path, seed: u64) -> Result<PathBuf, crate::Error> {
    std::fs::create_dir_all(out).map_err(crate::Error::io(out))?;
    let (experiments, controller, tables, estimators) = std::thread::scope(|scope| {
        let controller = scope.spawn(|| controller_comparison(out, seed));
        let tables = scope.spawn(|| crate::tables::reproduce(seed));
        let estimators = scope.spawn(crate::estimator_comparison::compare_firmware_table);
        let experiments = memo_experiments(out, seed);
        (
            experiments,
            joined(controller, "the controller's comparison"),
            joined(tables, "the memo's tables"),
            joined(estimators, "the estimators' comparison"),
        )
    });
    let (mut report, details) = experiments?;
    let (section, plots) = controller??;
    report.push_str(&section);
    report.push_str("\n# The memo's tables on the simulator (`tactile tables`)\n\n");
    report.push_str(&crate::tables::render(&tables??));
    report.push_str("\n# Force estimators (`tactile estimators`)\n\n");
    report.push_str("The calibrated columns use the table the firmware builds carry (`boards/calibration/table.bin`, what `tactile calibrate` writes for this finger).\n\n");
    report.push_str(&crate::estimator_comparison::render(&estimators??));
    report.push_str("\n# Where the contact is: a press that moves\n\n");
    report.push_str(&crate::array_calibration::moving_press_demo(out)?);
    report.push('\n');
    report.push_str(&details);
    report.push_str(&plots);
    let path = out.join("report.md");
    std::fs::write(&path, report).map_err(crate::Error::io(&path))?;
    Ok(path)
}

/// A part's result, or the error that it stopped (a panic in a part is a bug, said so).
fn joined<T>(handle: std::thread::ScopedJoinHandle<'_, T>, part: &str) -> Result<T, crate::Error> {
    handle
        .join()
        .map_err(|_| crate::Error::Failed(format!("{part} stopped on a bug (a panic)")))
}

/// The memo's experiments, each run, written and plotted: the report's head (its table) and
/// the details (each summary and plot).
fn memo_experiments(out: &Path, seed: u64) -> Result<(String, String), crate::Error> {
    let mut report = String::from(
        "# Tactile applicator and finger: the memo's experiments on the simulator\n\n",
    );
    let _ = writeln!(report, "Produced by `tactile demo --out {} --seed {seed}`. Each experiment writes `NAME.csv` (the record at 200 Hz), `NAME_frames.csv` (8×8 frames at 62.5 Hz) and `NAME.png`.\n", out.display());
    report.push_str(
        "| experiment | simulated (s) | speed (× real time) | result |\n|---|---|---|---|\n",
    );
    let mut details = String::new();
    let runs: [(&str, ScenarioOptions); 11] = [
        ("force-steps", ScenarioOptions::default()),
        ("low-force", ScenarioOptions::default()),
        (
            "low-force",
            ScenarioOptions {
                fixed_gains: true,
                ..Default::default()
            },
        ),
        (
            "step",
            ScenarioOptions {
                load_g: 50.0,
                ..Default::default()
            },
        ),
        ("step-loads", ScenarioOptions::default()),
        ("static-linearity", ScenarioOptions::default()),
        ("permanent-deformation", ScenarioOptions::default()),
        ("repeated-steps", ScenarioOptions::default()),
        ("sweep", ScenarioOptions::default()),
        ("pseudo-random", ScenarioOptions::default()),
        ("sines", ScenarioOptions::default()),
    ];
    for (name, options) in runs {
        let dir = if options.fixed_gains {
            out.join("fixed-gains")
        } else {
            out.to_path_buf()
        };
        let config = RigConfig {
            seed,
            ..Default::default()
        };
        let o = experiment(name, &options, config, &dir, 200.0, true)?;
        let label = if options.fixed_gains {
            format!("{name} (fixed gains)")
        } else {
            name.to_string()
        };
        let headline = o.summary.lines().nth(1).unwrap_or("").trim().to_string();
        let simulated = o.run.ticks.len() as f64 * CONTROL_PERIOD_S;
        let _ = writeln!(
            report,
            "| {label} | {simulated:.0} | {:.0} | {headline} |",
            simulated / o.wall_s.max(1e-9)
        );
        let _ = writeln!(details, "## {label}\n\n```text\n{}```\n", o.summary);
        for f in &o.files {
            if f.extension().is_some_and(|e| e == "png") {
                let rel = f.strip_prefix(out).unwrap_or(f);
                let _ = writeln!(details, "![{label}]({})\n", rel.display());
            }
        }
        eprint!("{}", o.summary);
    }
    Ok((report, details))
}

/// The designed force controller beside A1 on the same rig: the design, the
/// closed-loop magnitude, the force steps and the touch-downs, with the designed loop's plots.
fn controller_comparison(out: &Path, seed: u64) -> Result<(String, String), crate::Error> {
    let a1 = RigConfig {
        seed,
        scan_array: false,
        ..Default::default()
    };
    let r = crate::design::design_for_rig(&a1)
        .map_err(|e| crate::Error::Failed(format!("the controller's design: {e}")))?;
    let designed = RigConfig {
        firmware: tactile_core::tasks::FirmwareConfig {
            designed: Some(r.design.config),
            ..a1.firmware
        },
        ..a1.clone()
    };
    let mut s = String::from("\n## The designed force controller beside A1 (`tactile design`)\n\n");
    let _ = writeln!(
        s,
        "Identified at six preloads (static gain {:.3}, stiction {:.2} g from the holds); feedback kp {:.2}, ki {:.1}/s on the error through {}; a triple-pole reference at {} Hz; the model's inverse as a series in s, scheduled on load (docs/design.md). A1 runs with K_e = {} as everywhere else.\n",
        r.identified.static_gain,
        r.identified.stiction_g,
        r.design.feedback.kp,
        r.design.feedback.ki_per_s,
        r.design.feedback.filter,
        r.design.config.reference_hz,
        crate::rig::SIM_ERROR_GAIN
    );
    s.push_str("Closed-loop magnitude (true force over command, stepped sine of 10 g), dB:\n\n| Hz | A1, about 50 g | designed, about 50 g | A1, about 100 g | designed, about 100 g |\n|---|---|---|---|---|\n");
    for hz in [1.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 40.0] {
        let mut row = format!("| {hz} |");
        for offset in [50.0, 100.0] {
            for cfg in [&a1, &designed] {
                match metrics::closed_loop_gain(cfg.clone(), offset, 10.0, hz) {
                    Ok(g) => {
                        let _ = write!(row, " {:+.2} |", 20.0 * g.log10());
                    }
                    Err(metrics::GainError::Stopped { .. }) => row.push_str(" stopped |"),
                    Err(metrics::GainError::Clamped { .. }) => row.push_str(" clamped |"),
                    Err(metrics::GainError::Rig(e)) => {
                        return Err(crate::scenario::ScenarioError::from(e).into())
                    }
                }
            }
        }
        let _ = writeln!(s, "{row}");
    }
    let o = ScenarioOptions::default();
    let mut plots = String::new();
    let mut figures = Vec::new();
    for (label, cfg) in [("A1", &a1), ("designed", &designed)] {
        let dir = out.join(format!("controller-{label}"));
        let steps = experiment("force-steps", &o, cfg.clone(), &dir, 200.0, true)?;
        let low = experiment("low-force", &o, cfg.clone(), &dir, 200.0, true)?;
        let st = &steps.run.ticks;
        let settle = metrics::step_settling_s(st)
            .into_iter()
            .skip(1)
            .map(|(_, t)| t.unwrap_or(f64::INFINITY))
            .fold(0.0f64, f64::max);
        let overshoots = metrics::step_overshoots_g(st);
        let over = overshoots
            .iter()
            .skip(1)
            .map(|(_, o)| *o)
            .fold(0.0f32, f32::max);
        let first = overshoots.first().map_or(f32::NAN, |(_, o)| *o);
        let touch = metrics::step_overshoots_g(&low.run.ticks)
            .into_iter()
            .filter(|(l, _)| *l > 0.0)
            .map(|(_, o)| o)
            .fold(0.0f32, f32::max);
        figures.push((settle, over, first, touch));
        for f in steps.files.iter().chain(&low.files) {
            if f.extension().is_some_and(|e| e == "png") {
                let rel = f.strip_prefix(out).unwrap_or(f);
                let _ = writeln!(plots, "![{label}: {}]({})\n", rel.display(), rel.display());
            }
        }
    }
    s.push_str("\n| figure (contact force) | A1 | designed | target |\n|---|---|---|---|\n");
    let row = |name: &str, unit: &str, a: f64, b: f64, target: &str| {
        let digits = if unit == "ms" { 0 } else { 2 };
        format!("| {name} | {a:.digits$} {unit} | {b:.digits$} {unit} | {target} |\n")
    };
    // Each figure of A1 and of the designed loop, in the row's unit.
    let of = |pick: fn(&(f64, f32, f32, f32)) -> f64| figures.iter().map(pick).collect::<Vec<_>>();
    let rows: [(&str, &str, Vec<f64>, &str); 4] = [
        (
            "worst 10 g step into ±1 g, after the first",
            "ms",
            of(|f| 1e3 * f.0),
            "30 ms",
        ),
        (
            "worst step overshoot, after the first",
            "g",
            of(|f| f64::from(f.1)),
            "1 g",
        ),
        (
            "first step from rest, overshoot",
            "g",
            of(|f| f64::from(f.2)),
            "1 g",
        ),
        (
            "touch-downs of low-force, worst overshoot",
            "g",
            of(|f| f64::from(f.3)),
            "1 g",
        ),
    ];
    for (name, unit, v, target) in rows {
        if let [a, b] = v[..] {
            s.push_str(&row(name, unit, a, b, target));
        }
    }
    Ok((s, plots))
}
