//! Identify the applicator, design the controller, and measure it against A1 on the rig.
//! `cargo run --release -p sim-host --example design_controller [APPLICATOR.toml]`
use sim_host::design;
use sim_host::metrics;
use sim_host::rig::RigConfig;
use sim_host::scenario::{run_named, ScenarioOptions};

fn main() {
    let mut config = RigConfig {
        scan_array: false,
        ..Default::default()
    };
    if let Some(path) = std::env::args().nth(1) {
        config.applicator =
            sim_host::error::read_applicator(std::path::Path::new(&path)).expect("applicator");
    }
    let t0 = std::time::Instant::now();
    let models = if std::env::var("ANALYTIC").is_ok() {
        let law = tactile_core::viscoelastic::NonlinearMk::ELEMENT_4_2.g1;
        design::DESIGN_LOADS_G
            .iter()
            .map(|&load_g| {
                let response: Vec<sim_host::identify::ResponsePoint> = (2..300)
                    .map(|hz| {
                        let g = sim_host::analysis::applicator_response(
                            &config.applicator,
                            &law,
                            f64::from(load_g),
                            2.0 * std::f64::consts::PI * hz as f64,
                        );
                        sim_host::identify::ResponsePoint {
                            hz: hz as f64,
                            re: g.re,
                            im: g.im,
                        }
                    })
                    .collect();
                let model = sim_host::identify::fit_model(&response).unwrap();
                design::LoadModel { load_g, model }
            })
            .collect()
    } else {
        design::identify_loads(&config).expect("identify")
    };
    for m in &models {
        println!(
            "{:5} g: {} | series {:?}",
            m.load_g,
            m.model,
            design::inverse_series(&m.model)
        );
    }
    let law = config.firmware.law;
    let friction_g = std::env::var("FRICTION")
        .map(|v| v.parse().unwrap())
        .unwrap_or(0.0);
    let d = design::design(
        &models,
        friction_g,
        (law.adjusted_min_g, law.adjusted_max_g),
    )
    .expect("design");
    println!(
        "kp {:.3} ki {:.1}/s; margins {:?} ({:.1} s)",
        d.kp,
        d.ki_per_s,
        d.margins,
        t0.elapsed().as_secs_f64()
    );
    let mut designed = config.clone();
    let mut tc = d.config;
    if std::env::var("FF_ONLY").is_ok() {
        tc.kp = 0.0;
        tc.ki_per_s = 0.0;
    }
    designed.firmware.tracking = Some(tc);
    if std::env::var("DEBUG").is_ok() {
        debug_sine(designed.clone(), 10.0, 2.0, 25.0);
        return;
    }
    let runs: Vec<(&str, &RigConfig)> = if std::env::var("ONLY").is_ok() {
        vec![("designed", &designed)]
    } else {
        vec![("A1", &config), ("designed", &designed)]
    };
    for (name, cfg) in runs {
        println!("== {name}");
        for (load, amp) in [(10.0, 2.0), (50.0, 10.0), (100.0, 10.0)] {
            let g: Vec<String> = [0.5, 5.0, 10.0, 20.0, 25.0, 30.0, 40.0]
                .iter()
                .map(|hz| {
                    let g = metrics::closed_loop_gain(cfg.clone(), load, amp, *hz).unwrap();
                    format!("{hz} Hz {:+.2} dB", 20.0 * g.log10())
                })
                .collect();
            println!("  about {load} g: {}", g.join(", "));
        }
        let o = ScenarioOptions::default();
        let steps = run_named("force-steps", &o, cfg.clone(), |_| {})
            .unwrap()
            .ticks;
        let over: Vec<String> = metrics::step_overshoots_g(&steps)
            .iter()
            .map(|(l, o)| format!("{l}:{o:.2}"))
            .collect();
        let segs = metrics::segments(&steps);
        let st: Vec<String> = segs
            .iter()
            .filter(|s| s.command_g > 0.0)
            .map(|s| {
                format!(
                    "{}:{:.0}",
                    s.command_g,
                    1e3 * metrics::settling_time_s(&steps, s, 1.0).unwrap_or(f64::NAN)
                )
            })
            .collect();
        println!("  settling ms {}", st.join(" "));
        println!(
            "  force-steps: worst settling {:?} s; overshoot {}",
            metrics::worst_step_settling_s(&steps),
            over.join(" ")
        );
        let low = run_named("low-force", &o, cfg.clone(), |_| {})
            .unwrap()
            .ticks;
        let over: Vec<String> = metrics::step_overshoots_g(&low)
            .iter()
            .map(|(l, o)| format!("{l}:{o:.2}"))
            .collect();
        println!("  low-force overshoot {}", over.join(" "));
        for (level, lost, worst) in metrics::hold_quality(&low, 0.3) {
            println!(
                "    {level:>4} g: out of contact {:5.1} %, worst error {worst:6.2} g",
                lost * 100.0
            );
        }
    }
}

#[allow(dead_code)]
pub fn debug_sine(cfg: RigConfig, offset: f64, amp: f64, hz: f64) {
    let mut rig = sim_host::rig::Rig::new(RigConfig {
        command_slew_g_per_s: f32::INFINITY,
        ..cfg
    })
    .unwrap();
    let w = 2.0 * std::f64::consts::PI * hz;
    for k in 0..1000 {
        rig.tick((offset * k as f64 / 1000.0) as f32, |_, _| {});
    }
    for k in 0..400 {
        let t = rig.time_s();
        let r = rig.tick((offset + amp * (w * t).sin()) as f32, |_, _| {});
        if k % 10 == 0 {
            println!(
                "{:.3} cmd {:.2} sensed {:.2} true {:.2} adj {:.2} faults {:?}",
                r.t_s, r.command_g, r.sensed_g, r.true_force_g, r.adjusted_g, r.faults
            );
        }
    }
}
