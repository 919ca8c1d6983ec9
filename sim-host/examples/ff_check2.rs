//! scratch
use num_complex::Complex64;
use sim_host::design;
fn main() {
    let mut config = sim_host::rig::RigConfig { scan_array: false, ..Default::default() };
    let path = std::env::args().nth(1).unwrap();
    config.applicator = sim_host::error::read_applicator(std::path::Path::new(&path)).unwrap();
    let d = design::design_for_rig(&config).unwrap().design;
    let mut tc = d.config;
    tc.kp = 0.0; tc.ki_per_s = 0.0; tc.friction_g = 0.0; tc.held_friction_g = 0.0;
    config.firmware.tracking = Some(tc);
    config.command_slew_g_per_s = f32::INFINITY;
    let p = config.applicator;
    let law = tactile_core::viscoelastic::NonlinearMk::ELEMENT_4_2.g1;
    let (offset_g, amp): (f64, f64) = (50.0, 1.0);
    let (c, _) = tc.series_at(offset_g as f32);
    for hz in [20.0, 30.0, 40.0] {
        let mut rig = sim_host::rig::Rig::new(config.clone()).unwrap();
        for k in 0..1000 { rig.tick((offset_g * k as f64 / 1000.0) as f32, |_, _| {}); }
        let w = 2.0 * std::f64::consts::PI * hz;
        let n = (20.0 / hz / 1e-3).round() as usize;
        let (mut ac, mut ad, mut af, mut asn) = (Complex64::default(), Complex64::default(), Complex64::default(), Complex64::default());
        for k in 0..(1000 + n) {
            let t = rig.time_s();
            let cmd = offset_g + amp * (w * t).sin();
            let r = rig.tick(cmd as f32, |_, _| {});
            if k >= 1000 {
                let ph = Complex64::new(0.0, -w * t).exp();
                ac += (cmd - offset_g) * ph;
                ad += (f64::from(r.adjusted_g) - offset_g) * ph;
                af += (f64::from(r.true_force_g) - offset_g) * ph;
                asn += (f64::from(r.sensed_g) - offset_g) * ph;
            }
        }
        let s = Complex64::new(0.0, w);
        let ff = f64::from(c[0]) + f64::from(c[1]) * s + f64::from(c[2]) * s * s + f64::from(c[3]) * s * s * s;
        let rr = 1.0 / (1.0 + s / (2.0 * std::f64::consts::PI * 200.0)).powi(3);
        let gauge = sim_host::analysis::applicator_response(&p, &law, offset_g, w);
        let kf = sim_host::analysis::tangent_stiffness(&law, offset_g) * 100.0 / p.indentation_mm_per_100pct * 1e3 * sim_host::applicator::NEWTONS_PER_GRAM;
        let kc = Complex64::new(kf, 0.0) + p.contact_damping_n_s_per_m(offset_g, law.strain_pct(offset_g)) * s;
        let contact = gauge * kc / (p.tip_mass_kg * s * s + kc);
        let db = |z: Complex64| 20.0 * z.norm().log10();
        core_only(tc, hz); terms(hz);
        println!("{hz} Hz: drive/cmd {:+.2} dB {:+.0}° (FF·R {:+.2} dB {:+.0}°), force/drive {:+.2} dB {:+.0}° (analytic {:+.2} dB {:+.0}°), sensed/drive {:+.2} dB (analytic {:+.2}), force/cmd {:+.2} dB",
            db(ad/ac), (ad/ac).arg().to_degrees(), db(ff*rr), (ff*rr).arg().to_degrees(),
            db(af/ad), (af/ad).arg().to_degrees(), db(contact), contact.arg().to_degrees(), db(asn/ad), db(gauge), db(af/ac));
    }
}
#[allow(dead_code)]
pub fn core_only(tc: tactile_core::tracking::TrackingConfig, hz: f64) {
    let mut t = tactile_core::tracking::Tracking::new(tc).unwrap();
    let w = 2.0 * std::f64::consts::PI * hz;
    let mut sensed = 0.0f32;
    for k in 0..1000 { let c = 50.0 * k as f32 / 1000.0; sensed = t.update(c, c, true).force_g; let _ = sensed; }
    let (mut ac, mut ad) = (Complex64::default(), Complex64::default());
    let n = (20.0 / hz / 1e-3).round() as usize;
    for k in 0..(1000 + n) {
        let tt = (1000 + k) as f64 * 1e-3;
        let cmd = 50.0 + (w * tt).sin();
        let d = t.update(cmd as f32, 50.0, false).force_g;
        if k >= 1000 {
            let ph = Complex64::new(0.0, -w * tt).exp();
            ac += (cmd - 50.0) * ph;
            ad += (f64::from(d) - 50.0) * ph;
        }
    }
    println!("core alone {hz} Hz: drive/cmd {:+.2} dB {:+.0}°", 20.0 * (ad / ac).norm().log10(), (ad / ac).arg().to_degrees());
}
#[allow(dead_code)]
pub fn terms(hz: f64) {
    let w = 2.0 * std::f64::consts::PI * hz;
    let s = Complex64::new(0.0, w);
    let rr = 1.0 / (1.0 + s / (2.0 * std::f64::consts::PI * 200.0)).powi(3);
    let scale = [1.0f32, 1e-3, 1e-5, 1e-8];
    let mut g0 = Complex64::default();
    for i in 0..4 {
        let mut cfg = tactile_core::tracking::TrackingConfig::UNIT_PLANT;
        let mut c = [1.0f32, 0.0, 0.0, 0.0];
        if i > 0 { c[i] = scale[i]; }
        for p in cfg.schedule.iter_mut() { p.c = c; }
        cfg.ki_per_s = 0.0; cfg.kp = 0.0;
        let mut t = tactile_core::tracking::Tracking::new(cfg).unwrap();
        let (mut ac, mut ad) = (Complex64::default(), Complex64::default());
        let n = (20.0 / hz / 1e-3).round() as usize;
        for k in 0..(1000 + n) {
            let tt = k as f64 * 1e-3;
            let cmd = 10.0 + (w * tt).sin();
            let d = t.update(cmd as f32, 10.0, false).force_g;
            if k >= 1000 {
                let ph = Complex64::new(0.0, -w * tt).exp();
                ac += (cmd - 10.0) * ph;
                ad += (f64::from(d) - 10.0) * ph;
            }
        }
        let g = ad / ac;
        if i == 0 { g0 = g; }
        let term = if i == 0 { g } else { (g - g0) / f64::from(scale[i]) };
        let ideal = s.powi(i as i32) * rr;
        println!("s^{i} at {hz} Hz: core/ideal {:+.3} dB {:+.1}°", 20.0 * (term / ideal).norm().log10(), (term / ideal).arg().to_degrees());
    }
}
