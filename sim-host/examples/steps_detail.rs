//! Per-step settling of the force-steps scenario for several seeds (a diagnostic, not a test).
//!
//! cargo run --release -p sim-host --example steps_detail
use sim_host::metrics::{segments, settling_time_s};
use sim_host::rig::RigConfig;
use sim_host::scenario::{run_named, ScenarioOptions};

fn main() {
    for seed in 1..=6 {
        let mut config = RigConfig {
            seed,
            scan_array: false,
            ..Default::default()
        };
        if let Some(ke) = std::env::var("KE").ok().and_then(|v| v.parse().ok()) {
            config.firmware.law.ke = ke;
        }
        let run = run_named("force-steps", &ScenarioOptions::default(), config, |_| {})
            .expect("rig builds");
        let times: Vec<String> = segments(&run.ticks)
            .iter()
            .filter(|s| s.command_g > 0.0)
            .map(|s| {
                settling_time_s(&run.ticks, s, 1.0)
                    .map_or("never".into(), |t| format!("{:.0}", t * 1e3))
            })
            .collect();
        println!("seed {seed}: settling (ms) {}", times.join(" "));
    }
}
