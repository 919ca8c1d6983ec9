use sim_host::{metrics::*, rig::RigConfig, scenario::*};
fn main() {
    for hz in [1.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 40.0, 50.0] {
        println!("{hz} Hz: {:.3} ({:.2} dB)", closed_loop_gain(RigConfig::default(), 40.0, 5.0, hz).unwrap(), 20.0*closed_loop_gain(RigConfig::default(), 40.0, 5.0, hz).unwrap().log10());
    }
    let o = ScenarioOptions::default();
    let r = run_named("static-linearity", &o, RigConfig { scan_array: false, ..Default::default() }, |_| {}).unwrap();
    println!("{:?}", static_linearity(&r.ticks, 500.0));
    let r = run_named("permanent-deformation", &o, RigConfig { scan_array: false, ..Default::default() }, |_| {}).unwrap();
    println!("{:?}", residual_deformation(&r.ticks));
    let r = run_named("force-steps", &o, RigConfig::default(), |_| {}).unwrap();
    println!("settle {:?}", worst_step_settling_s(&r.ticks));
    for fixed in [false, true] {
        let r = run_named("low-force", &ScenarioOptions { fixed_gains: fixed, ..o }, RigConfig::default(), |_| {}).unwrap();
        println!("low-force fixed={fixed}: {:?}", hold_quality(&r.ticks, 0.3));
    }
}
