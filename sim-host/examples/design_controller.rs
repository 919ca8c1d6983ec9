//! Identify the applicator, design the force controller, and measure it against A1 on the rig:
//! closed-loop magnitude about 10, 50 and 100 g, the force steps (settling into ±1 g and
//! overshoot per step) and the touch-downs of `low-force`.
//!
//! `cargo run --release -p sim-host --example design_controller [APPLICATOR.toml]`
//!
//! `ANALYTIC=1`: design on the simulator's own plant linearized at each load instead of the
//! identified models (what the design would do with a perfect identification).
//! `SEED=N`: the rig's seed (1). `FF_ONLY=1`: the feed-forward alone (no feedback). `ONLY=1`: skip A1. `FRICTION=G`: G grams
//! of stiction compensated instead of `design::FRICTION_SHARE` of the identified.
//! `TAU_MS=T`: the compensation through (1 + sT) instead of the amplifier's identified τ
//! (`design::amplifier_tau_s`). `HELD=S`: S times the stiction compensated held once the
//! reference stops instead of `design::HELD_FRICTION_SHARE`. `SINES=L:A,…`: sines of A g
//! about L g instead of 2 about 10, 10 about 50 and 10 about 100. `NO_GAUGE_S2=1`: the
//! feedback compares the reading without the tip's inertia (`InverseSeries::gauge_s2` zero).
//! `TRUE_FRICTION=1`: the file's stiction compensated (an oracle: what the identified one costs).
//! `RUN_OFF=NAME:F`: the design run on the rig with one of `analysis::MECHANICAL_PARAMETERS`
//! (`"motor inertia"`, …) F times the file's: what a model that far off costs (with
//! `ANALYTIC=1`, a perfect model of the file's rig). `TRACE=FILE`: the designed loop's
//! force-steps tick by tick to FILE (CSV: time, command, reading, true force, drive).
use sim_host::design;
use sim_host::metrics;
use sim_host::rig::RigConfig;
use sim_host::scenario::{run_named, ScenarioOptions};

fn main() {
    let config = rig_config();
    let run_off = run_off_from_env();
    let t0 = std::time::Instant::now();
    let mut d = if std::env::var("ANALYTIC").is_ok() {
        analytic_design(&config)
    } else {
        identified_design(&config)
    };
    override_from_env(&mut d, &config);
    print_design(&d);
    let fw = &config.firmware;
    println!(
        "commands up to {:.1} g (the gauge's range ends at {:.1} g)",
        fw.supervisor
            .command_max_g
            .min(tactile_core::supervisor::GAUGE_COMMAND_SHARE * fw.gauge.force_max_g),
        fw.gauge.force_max_g
    );
    // On stderr: a wall-clock time is no figure for docs/results.md.
    eprintln!(
        "identified and designed in {:.1} s",
        t0.elapsed().as_secs_f64()
    );
    let mut designed = config.clone();
    let mut tc = d.config;
    if std::env::var("FF_ONLY").is_ok() {
        tc.kp = 0.0;
        tc.ki_per_s = 0.0;
    }
    designed.firmware.designed = Some(tc);
    if let Some((name, field, factor)) = run_off {
        let mut off = designed.applicator;
        *field(&mut off) *= factor;
        println!("run on the rig with its {name} {factor} times the file's");
        designed.set_applicator(off);
    }
    let mut runs = vec![("designed", &designed)];
    if std::env::var("ONLY").is_err() {
        runs.insert(0, ("A1", &config));
    }
    for (name, cfg) in runs {
        measure(name, cfg);
    }
}

/// The rig of the file named on the command line (the memo's without), at `SEED`.
fn rig_config() -> RigConfig {
    let mut config = RigConfig {
        scan_array: false,
        seed: std::env::var("SEED")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(1),
        ..Default::default()
    };
    if let Some(path) = std::env::args().nth(1) {
        config.set_applicator(
            sim_host::error::read_applicator(std::path::Path::new(&path))
                .unwrap_or_else(|e| refuse(&e)),
        );
    }
    config
}

/// A mechanical parameter's name, its field and the factor the rig runs it at.
type RunOff = (
    String,
    fn(&mut sim_host::applicator::ApplicatorParams) -> &mut f64,
    f64,
);

/// `RUN_OFF=NAME:F`: the design runs on the rig with one mechanical parameter F times the
/// file's (what a model that far off costs; names as `analysis::MECHANICAL_PARAMETERS`).
fn run_off_from_env() -> Option<RunOff> {
    let run_off = std::env::var("RUN_OFF").ok().map(|v| {
        let (name, factor) = v
            .split_once(':')
            .and_then(|(n, f)| Some((n.to_string(), f.parse::<f64>().ok()?)))
            .unwrap_or_else(|| refuse(&format!("RUN_OFF={v}: want NAME:FACTOR")));
        let (_, field) = sim_host::analysis::MECHANICAL_PARAMETERS
            .iter()
            .find(|(n, _)| *n == name)
            .unwrap_or_else(|| refuse(&format!("RUN_OFF: no mechanical parameter named {name:?}")));
        (name, *field, factor)
    });
    run_off
}

/// `ANALYTIC=1`: the design on the simulator's own plant linearized at each load.
fn analytic_design(config: &RigConfig) -> design::Design {
    let law = tactile_core::viscoelastic::NonlinearMk::ELEMENT_4_2.g1;
    let scale = drive_scale(config);
    let models: Vec<design::LoadModel> = design::DESIGN_LOADS_G
        .iter()
        .map(|&load_g| {
            let response: Vec<sim_host::applicator_model::ResponsePoint> = (2..300)
                .map(|hz| {
                    let w = 2.0 * std::f64::consts::PI * f64::from(hz);
                    let g = scale
                        * sim_host::analysis::applicator_response(
                            &config.applicator,
                            &law,
                            f64::from(load_g),
                            w,
                        );
                    sim_host::applicator_model::ResponsePoint {
                        hz: f64::from(hz),
                        re: g.re,
                        im: g.im,
                    }
                })
                .collect();
            let model = sim_host::applicator_model::fit_model(&response).expect("fit");
            design::LoadModel {
                load_g,
                model,
                static_gain: model.gain,
            }
        })
        .collect();
    let stiction_g = file_stiction_g(config);
    let law = config.firmware.law;
    design::design(
        &models,
        stiction_g as f32,
        (law.adjusted_min_g, law.adjusted_max_g),
        config.firmware.gauge,
        config.applicator.gauge_noise_g as f32,
    )
    .unwrap_or_else(|e| refuse(&e))
}

/// The design from the rig's identification, with what it identified printed.
fn identified_design(config: &RigConfig) -> design::Design {
    let r = design::design_for_rig(config).unwrap_or_else(|e| refuse(&e));
    println!(
        "static gain {:.3}, stiction {:.2} g, gauge noise {:.2} g (identified from the holds)",
        r.identified.static_gain, r.identified.stiction_g, r.identified.gauge_noise_g
    );
    for left in &r.identified.left_out {
        println!("left out {left}");
    }
    r.design
}

/// The environment's overrides of the design (`FRICTION`, `TRUE_FRICTION`, `TAU_MS`,
/// `NO_GAUGE_S2`, `HELD`).
fn override_from_env(d: &mut design::Design, config: &RigConfig) {
    // `FRICTION=G`: the same models, G grams of stiction compensated.
    if let Some(friction_g) = std::env::var("FRICTION")
        .ok()
        .and_then(|v| v.parse::<f32>().ok())
    {
        d.config.friction_g = friction_g;
    }
    if std::env::var("TRUE_FRICTION").is_ok() {
        let true_g = file_stiction_g(config);
        println!(
            "stiction identified {:.3} g, the file's {true_g:.3} g",
            d.config.friction_g
        );
        d.config.friction_g = true_g as f32;
    }
    // `TAU_MS=T`: the friction compensation through (1 + sT) instead of the design's τ.
    if let Some(tau_ms) = std::env::var("TAU_MS")
        .ok()
        .and_then(|v| v.parse::<f32>().ok())
    {
        d.config.amplifier_tau_s = 1e-3 * tau_ms;
    }
    // `NO_GAUGE_S2=1`: the feedback compares the reading without the tip's inertia.
    if std::env::var("NO_GAUGE_S2").is_ok() {
        d.config.schedule.iter_mut().for_each(|p| p.gauge_s2 = 0.0);
    }
    // `HELD=S`: S times the identified stiction held once the reference stops.
    if let Some(share) = std::env::var("HELD")
        .ok()
        .and_then(|v| v.parse::<f32>().ok())
    {
        d.config.held_friction_g = share * d.config.friction_g;
    }
}

fn print_design(d: &design::Design) {
    for (m, p) in d.models.iter().zip(&d.config.schedule) {
        println!(
            "{:5} g: {} | static gain {:.3}, series {:?}, feedback share {:.2}",
            m.load_g, m.model, m.static_gain, p.c, p.feedback
        );
    }
    println!(
        "kp {:.3}, ki {:.1}/s, {}, friction {:.2} g through the amplifier's τ {:.2} ms",
        d.feedback.kp,
        d.feedback.ki_per_s,
        d.feedback.filter,
        d.config.friction_g,
        1e3 * d.config.amplifier_tau_s,
    );
}

/// The closed-loop magnitude, the force steps and the touch-downs of one loop.
fn measure(name: &str, cfg: &RigConfig) {
    println!("== {name}");
    for (load, amp) in sines() {
        let g: Vec<String> = [0.5, 5.0, 10.0, 20.0, 25.0, 30.0, 40.0]
            .iter()
            .map(
                |hz| match metrics::closed_loop_gain(cfg.clone(), load, amp, *hz) {
                    Ok(g) => format!("{hz} Hz {:+.2} dB", 20.0 * g.log10()),
                    Err(e) => format!("{hz} Hz: {e}"),
                },
            )
            .collect();
        println!("  {amp} g about {load} g: {}", g.join(", "));
    }
    let o = ScenarioOptions::default();
    let steps = run_named("force-steps", &o, cfg.clone(), |_| {})
        .unwrap()
        .ticks;
    let settle: Vec<String> = metrics::step_settling_s(&steps)
        .iter()
        .map(|(level, t)| format!("{level}:{:.0}", 1e3 * t.unwrap_or(f64::NAN)))
        .collect();
    println!(
        "  force-steps, settling into ±1 g (ms): {}",
        settle.join(" ")
    );
    let over: Vec<String> = metrics::step_overshoots_g(&steps)
        .iter()
        .map(|(l, o)| format!("{l}:{o:.2}"))
        .collect();
    println!("  force-steps, overshoot (g): {}", over.join(" "));
    if let (Ok(path), "designed") = (std::env::var("TRACE"), name) {
        write_trace(&path, cfg, &steps);
    }
    let low = run_named("low-force", &o, cfg.clone(), |_| {})
        .unwrap()
        .ticks;
    let over: Vec<String> = metrics::step_overshoots_g(&low)
        .iter()
        .filter(|(l, _)| *l > 0.0)
        .map(|(l, o)| format!("{l}:{o:.2}"))
        .collect();
    println!("  low-force touch-downs, overshoot (g): {}", over.join(" "));
    for (level, lost, worst) in metrics::hold_quality(&low, 0.3) {
        println!(
            "    {level:>4} g: out of contact {:5.1} %, worst error {worst:6.2} g",
            lost * 100.0
        );
    }
}

/// The ticks to `path` as CSV, the drive in firmware grams from the DAC's code.
fn write_trace(path: &str, cfg: &RigConfig, ticks: &[tactile_core::telemetry::TickRecord]) {
    let a = &cfg.firmware.actuator;
    let mut out = String::from("t_s,command_g,sensed_g,true_g,drive_g\n");
    for r in ticks {
        out += &format!(
            "{:.3},{},{},{},{}\n",
            r.t_s,
            r.command_g,
            r.sensed_g,
            r.true_force_g,
            a.force_g(tactile_core::gauge::AdcCode(r.dac_code))
        );
    }
    std::fs::write(path, out).unwrap_or_else(|e| refuse(&format!("{path}: {e}")));
}

/// A drive gram's force at the probe, in the rig's own grams: the drive's grams are the
/// firmware's (its volts per gram), and on a rig whose amplifier, motor or arm differ from the
/// memo's a drive gram moves the probe by this many.
fn drive_scale(config: &RigConfig) -> f64 {
    config.applicator.drive_g_per_v() / f64::from(config.firmware.actuator.grams_per_volt)
}

/// The applicator file's stiction in drive grams.
fn file_stiction_g(config: &RigConfig) -> f64 {
    let p = &config.applicator;
    p.static_friction_nm / p.arm_m / sim_host::applicator::NEWTONS_PER_GRAM / drive_scale(config)
}

/// The closed loop's sines, (load, amplitude) in g: `SINES=L:A,…` or the three.
fn sines() -> Vec<(f64, f64)> {
    std::env::var("SINES")
        .ok()
        .map(|v| {
            v.split(',')
                .filter_map(|p| {
                    let (l, a) = p.split_once(':')?;
                    Some((l.trim().parse().ok()?, a.trim().parse().ok()?))
                })
                .collect()
        })
        .unwrap_or_else(|| vec![(10.0, 2.0), (50.0, 10.0), (100.0, 10.0)])
}

/// A rig the design refuses, a bad file or knob: the reason on stderr and exit status 1, as
/// `tactile design` (`scripts/controller-sweep.sh` logs it and goes on to the next rig).
fn refuse(e: &dyn std::fmt::Display) -> ! {
    eprintln!("error: {e}");
    std::process::exit(1)
}
