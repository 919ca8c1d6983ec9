//! One preload's excitation on the simulated rig: the model fitted to the response less the
//! friction, the same refined with the friction in the simulation ([`sim_host::stick_slip`]),
//! and the plant's own linearization, every 5 Hz.
//!
//! `cargo run --release -p sim-host --example stick_slip_detail [APPLICATOR.toml] [PRELOAD_G]
//! [STICTION_G]` (defaults: the memo's rig, 10 g, 1 g).
use sim_host::design;
use sim_host::rig::RigConfig;
use sim_host::scenario::run_protocol;
use tactile_core::profile::Protocol;

fn main() {
    let mut config = RigConfig {
        scan_array: false,
        ..Default::default()
    };
    let arg = |i: usize| std::env::args().nth(i);
    if let Some(path) = arg(1) {
        config.set_applicator(
            sim_host::error::read_applicator(std::path::Path::new(&path)).expect("applicator"),
        );
    }
    let load_g: f32 = arg(2).and_then(|v| v.parse().ok()).unwrap_or(10.0);
    let stiction_g: f64 = arg(3).and_then(|v| v.parse().ok()).unwrap_or(1.0);
    let protocol = Protocol::design_excitation(load_g);
    let run = run_protocol("excitation", protocol, config.clone(), false, |_| {}).expect("run");
    let e = design::excited_of_run(&run.ticks, protocol, &config.firmware.actuator)
        .expect("an excitation record");
    let less = e
        .means
        .less_friction(stiction_g)
        .response()
        .expect("response");
    let fit = sim_host::identify::fit_model(&less).expect("a fit");
    println!("less friction: {fit}");
    let t0 = std::time::Instant::now();
    let refined = sim_host::stick_slip::fit_with_friction(&e.means, stiction_g, &fit);
    eprintln!("refined in {:.2} s", t0.elapsed().as_secs_f64());
    match &refined {
        Some(m) => println!("with friction: {m}"),
        None => println!("with friction: no better fit"),
    }
    let sim = sim_host::stick_slip::simulated_response(&fit, &e.means).expect("simulated");
    let law = tactile_core::viscoelastic::NonlinearMk::ELEMENT_4_2.g1;
    let db = |c: num_complex::Complex64| 20.0 * c.norm().log10();
    let deg = |c: num_complex::Complex64| c.arg().to_degrees();
    for p in sim.iter().filter(|p| (p.hz as usize).is_multiple_of(5)) {
        let w = 2.0 * std::f64::consts::PI * p.hz;
        let lin =
            sim_host::analysis::applicator_response(&config.applicator, &law, f64::from(load_g), w);
        let m = fit.response(p.hz);
        let r = refined.map_or(m, |r| r.response(p.hz));
        println!(
            "{:5.0} Hz fit {:+6.2} dB {:+7.1}° | fit simulated {:+6.2} dB {:+7.1}° | refined {:+6.2} dB {:+7.1}° | plant {:+6.2} dB {:+7.1}°",
            p.hz,
            db(m),
            deg(m),
            db(p.value()),
            deg(p.value()),
            db(r),
            deg(r),
            db(lin),
            deg(lin),
        );
    }
}
