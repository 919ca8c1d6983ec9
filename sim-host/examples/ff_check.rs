//! scratch
use num_complex::Complex64;
use sim_host::design;
fn main() {
    let mut config = sim_host::rig::RigConfig::default();
    if let Some(path) = std::env::args().nth(1) {
        config.applicator = sim_host::error::read_applicator(std::path::Path::new(&path)).unwrap();
    }
    let p = config.applicator;
    let law = tactile_core::viscoelastic::NonlinearMk::ELEMENT_4_2.g1;
    for load_g in [10.0f32, 50.0, 100.0] {
        let response: Vec<sim_host::identify::ResponsePoint> = (2..300)
            .map(|hz| {
                let w = 2.0 * std::f64::consts::PI * f64::from(hz);
                let g = sim_host::analysis::applicator_response(&p, &law, f64::from(load_g), w);
                sim_host::identify::ResponsePoint { hz: f64::from(hz), re: g.re, im: g.im }
            })
            .collect();
        let model = sim_host::identify::fit_model(&response).unwrap();
        let lm = design::LoadModel { load_g, model, static_gain: model.gain };
        let c = design::inverse_series(&lm);
        println!("{load_g} g: {model} c {c:?}");
        for hz in [10.0, 20.0, 30.0, 40.0, 50.0] {
            let w = 2.0 * std::f64::consts::PI * hz;
            let s = Complex64::new(0.0, w);
            let gauge = sim_host::analysis::applicator_response(&p, &law, f64::from(load_g), w);
            // contact = gauge·kc/(m s² + kc)
            let kf = sim_host::analysis::tangent_stiffness(&law, f64::from(load_g)) * 100.0 / p.indentation_mm_per_100pct * 1e3 * sim_host::applicator::NEWTONS_PER_GRAM;
            let kc = Complex64::new(kf, 0.0) + p.contact_damping_n_s_per_m(f64::from(load_g), law.strain_pct(f64::from(load_g))) * s;
            let contact = gauge * kc / (p.tip_mass_kg * s * s + kc);
            let ff = c[0] + c[1] * s + c[2] * s * s + c[3] * s * s * s;
            let r = 1.0 / (1.0 + s / (2.0 * std::f64::consts::PI * 200.0)).powi(3);
            let mc = model.response(hz) / { let z = model.anti_resonance; let wz = 2.0*std::f64::consts::PI*z.hz; 1.0 + 2.0*z.damping_ratio*s/wz + s*s/(wz*wz) } * (s * model.delay_s).exp();
            // exact model inverse
            let exact = 1.0 / mc;
            let meas = sim_host::analysis::measured_response(&p, &law, f64::from(load_g), 1.0, hz);
            println!("  measured/analytic gauge {:+.2} dB {:+.1}°", 20.0*(meas/gauge).norm().log10(), (meas/gauge).arg().to_degrees());
            println!("  {hz:4} Hz: |contact·FF| {:+.2} dB, |contact·FF·R| {:+.2} dB, |contact/model| {:+.2} dB, |series/exact inverse| {:+.2} dB",
                20.0 * (contact * ff).norm().log10(),
                20.0 * (contact * ff * r).norm().log10(),
                20.0 * (contact / mc).norm().log10(),
                20.0 * (ff / exact).norm().log10());
        }
    }
}
