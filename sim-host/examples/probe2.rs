use sim_host::rig::*;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let ke: f32 = a[1].parse().unwrap();
    let level: f32 = a[2].parse().unwrap();
    let damping: f64 = a[3].parse().unwrap();
    let verbose = a.len() > 4;
    let mut cfg = RigConfig::default();
    cfg.law.ke = ke;
    cfg.applicator.contact_damping_n_s_per_m = damping;
    cfg.scan_array = false;
    let mut rig = Rig::new(cfg).unwrap();
    let mut worst: f32 = 0.0; let mut lost = 0;
    for k in 0..3000 {
        // Ramp to the level over 0.5 s, hold, then a 10 g step at 2 s.
        let t = k as f32 * 1e-3;
        let c = if t < 0.5 { level * t / 0.5 } else if t < 2.0 { level } else { level + 10.0 };
        let r = rig.tick(c, |_, _| {});
        if t > 1.5 && t < 2.0 || t > 2.1 { worst = worst.max((r.true_force_g - c).abs()); if !r.in_contact { lost += 1; } }
        if verbose && k % 5 == 0 && k > 1950 && k < 2200 { println!("{:.3} c={:.1} s={:.2} a={:.2} f={:.2}", r.t_s, c, r.sensed_g, r.adjusted_g, r.true_force_g); }
    }
    println!("ke {ke} level {level} damping {damping}: worst |f-c| {worst:.2} g, ticks out of contact {lost}");
}
