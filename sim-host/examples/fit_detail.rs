//! One preload's excitation on the simulated rig, as the design reads it: the measured response
//! (the drive less the stiction, and the plain ratio) beside the plant's own friction-free
//! linearization, the fitted model and the same refined with the friction simulated
//! (`stick_slip`, the design's), every 5 Hz.
//!
//! `cargo run --release -p sim-host --example fit_detail [APPLICATOR.toml] [PRELOAD_G]
//! [STICTION_G] [AMPLITUDE_G]` (defaults: the memo's rig, 10 g, 1 g, the design's chirp).
//! `KE=K`: A1's error gain K (the simulator's 0.07) for the hold before the chirp, which runs
//! without A1's feedback. Prints the gauge's range over the run.
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
    let mut protocol = Protocol::design_excitation(load_g);
    if let (Some(a), Protocol::Excitation { amplitude_g, .. }) =
        (arg(4).and_then(|v| v.parse::<f32>().ok()), &mut protocol)
    {
        *amplitude_g = a;
    }
    if let Some(ke) = std::env::var("KE").ok().and_then(|v| v.parse::<f32>().ok()) {
        config.firmware.law.ke = ke;
    }
    let run = run_protocol("excitation", protocol, config.clone(), false, |_| {}).expect("run");
    let (lo, hi) = run.ticks.iter().fold((f32::MAX, f32::MIN), |(lo, hi), t| {
        (lo.min(t.sensed_g), hi.max(t.sensed_g))
    });
    let worst = run
        .ticks
        .iter()
        .max_by(|a, b| a.sensed_g.total_cmp(&b.sensed_g));
    println!(
        "gauge {lo:.1}..{hi:.1} g (highest at {:.3} s)",
        worst.map_or(0.0, |t| t.t_s)
    );
    let start = (f64::from(tactile_core::profile::EXCITATION_SETTLE_S)
        / tactile_core::CONTROL_PERIOD_S) as usize;
    let chirp = run.ticks.get(start..).unwrap_or(&[]);
    let zero = chirp.iter().filter(|t| t.true_force_g <= 0.0).count();
    let (clo, chi) = chirp.iter().fold((f32::MAX, f32::MIN), |(lo, hi), t| {
        (lo.min(t.true_force_g), hi.max(t.true_force_g))
    });
    println!(
        "contact force in the chirp {clo:.1}..{chi:.1} g, at zero {zero} of {} ticks",
        chirp.len()
    );
    let e = design::excited_of_run(&run.ticks, protocol, &config.firmware.actuator)
        .expect("an excitation record");
    let less = e
        .means
        .less_friction(stiction_g)
        .response()
        .expect("response");
    let plain = e.means.response().expect("response");
    let fit = sim_host::applicator_model::fit_model(&less).expect("a fit");
    println!("fit: {fit}");
    // The design's model: the same refined with the friction simulated.
    let refined = sim_host::stick_slip::fit_with_friction(&e.means, stiction_g, &fit);
    match &refined {
        Some(m) => println!("with the friction simulated: {m}"),
        None => println!("with the friction simulated: no better fit"),
    }
    if let Some((m, s)) = sim_host::stick_slip::fit_with_stiction(&e.means, stiction_g, &fit) {
        println!("and the stiction fitted too: {s:.3} g, {m}");
    }
    let law = tactile_core::viscoelastic::NonlinearMk::ELEMENT_4_2.g1;
    let db = |c: num_complex::Complex64| 20.0 * c.norm().log10();
    let deg = |c: num_complex::Complex64| c.arg().to_degrees();
    for (p, q) in less
        .iter()
        .zip(&plain)
        .filter(|(p, _)| (p.hz as usize).is_multiple_of(5))
    {
        let w = 2.0 * std::f64::consts::PI * p.hz;
        let lin =
            sim_host::analysis::applicator_response(&config.applicator, &law, f64::from(load_g), w);
        let m = fit.response(p.hz);
        let r = refined.map_or(m, |r| r.response(p.hz));
        println!(
            "{:5.0} Hz less friction {:+6.2} dB {:+7.1}° | plain {:+6.2} dB {:+7.1}° | plant {:+6.2} dB {:+7.1}° | fit {:+6.2} dB {:+7.1}° | refined {:+6.2} dB {:+7.1}°",
            p.hz,
            db(p.value()),
            deg(p.value()),
            db(q.value()),
            deg(q.value()),
            db(lin),
            deg(lin),
            db(m),
            deg(m),
            db(r),
            deg(r)
        );
    }
}
