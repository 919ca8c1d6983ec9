use sim_host::rig::RigConfig;
use sim_host::scenario::*;
fn main() {
    let name = std::env::args().nth(1).unwrap_or("force-steps".into());
    let fixed = std::env::args().any(|a| a == "--fixed");
    let o = ScenarioOptions { fixed_gains: fixed, ..Default::default() };
    let t0 = std::time::Instant::now();
    let run = run_named(&name, &o, RigConfig::default(), |_| {}).unwrap();
    eprintln!("wall {:?}", t0.elapsed());
    let step = std::env::args().nth(2).and_then(|s| s.parse().ok()).unwrap_or(20usize);
    for r in run.ticks.iter().step_by(step) {
        println!("{:.3} c={:.2} s={:.2} a={:.2} f={:.2} e={:.3} est={:.2} contact={}", r.t_s, r.command_g, r.sensed_g, r.adjusted_g, r.true_force_g, r.strain_pct, r.estimate_g, r.in_contact as u8);
    }
}
