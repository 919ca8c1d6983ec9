use sim_host::{metrics::*, rig::RigConfig, scenario::*};
fn main() {
    let slew: f32 = std::env::args().nth(1).unwrap().parse().unwrap();
    let cfg = || RigConfig { command_slew_g_per_s: slew, scan_array: false, ..Default::default() };
    for hz in [1.0, 10.0, 15.0, 20.0, 25.0, 40.0] {
        let g = closed_loop_gain(cfg(), 50.0, 10.0, hz).unwrap();
        print!("{hz}Hz {:.2}dB  ", 20.0*g.log10());
    }
    println!();
    let o = ScenarioOptions::default();
    let r = run_named("static-linearity", &o, cfg(), |_| {}).unwrap();
    println!("{:?}", static_linearity(&r.ticks, 500.0).iter().map(|(a,b)| format!("{a}:{b:.2}")).collect::<Vec<_>>());
    let r = run_named("force-steps", &o, cfg(), |_| {}).unwrap();
    println!("settle {:?}", worst_step_settling_s(&r.ticks));
    for sg in segments(&r.ticks) { print!("{}:{:?} ", sg.command_g, settling_time_s(&r.ticks, &sg, 1.0)); }
    println!();
    for fixed in [false, true] {
        let r = run_named("low-force", &ScenarioOptions { fixed_gains: fixed, ..o }, cfg(), |_| {}).unwrap();
        println!("low-force fixed={fixed}: {:?}", hold_quality(&r.ticks, 0.3).iter().map(|(a,b,c)| format!("{a}:{b:.2}/{c:.2}")).collect::<Vec<_>>());
    }
    let r = run_named("step-loads", &o, cfg(), |_| {}).unwrap();
    println!("step-loads lost contact ticks {}", r.ticks.iter().filter(|t| t.command_g > 0.0 && !t.in_contact).count());
}
#[allow(dead_code)]
fn per_step() {}
