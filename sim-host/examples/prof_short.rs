fn main() {
    let o = sim_host::scenario::ScenarioOptions {
        duration_s: 5.0,
        ..Default::default()
    };
    let r = sim_host::scenario::run_named(
        "pseudo-random",
        &o,
        sim_host::rig::RigConfig::default(),
        |_| {},
    )
    .unwrap();
    println!("{}", r.ticks.len());
}
