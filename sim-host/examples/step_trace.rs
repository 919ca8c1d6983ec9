//! throwaway
use sim_host::design;
use sim_host::rig::RigConfig;
use sim_host::scenario::{run_named, ScenarioOptions};
fn main() {
    let mut config = RigConfig {
        scan_array: false,
        seed: std::env::var("SEED")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(1),
        ..Default::default()
    };
    if let Some(path) = std::env::args().nth(1) {
        config
            .set_applicator(sim_host::error::read_applicator(std::path::Path::new(&path)).unwrap());
    }
    let mut d = design::design_for_rig(&config).unwrap().design;
    // `LEAD_MS=T`: the friction compensation turned T ms ahead instead of the design's.
    if let Some(lead_ms) = std::env::var("LEAD_MS")
        .ok()
        .and_then(|v| v.parse::<f32>().ok())
    {
        d.config.friction_lead_s = 1e-3 * lead_ms;
    }
    config.firmware.tracking = Some(d.config);
    let run = run_named("force-steps", &ScenarioOptions::default(), config, |_| {}).unwrap();
    let at: f64 = std::env::args()
        .nth(2)
        .and_then(|v| v.parse().ok())
        .unwrap_or(10.5);
    for t in run
        .ticks
        .iter()
        .filter(|t| t.t_s >= at - 0.004 && t.t_s < at + 0.09)
    {
        if ((t.t_s - at) * 1000.0).round() as i64 % 3 == 0 {
            println!(
                "{:7.3} cmd {:6.2} adj {:6.2} true {:7.2} sensed {:7.2} dac {}",
                t.t_s, t.command_g, t.adjusted_g, t.true_force_g, t.sensed_g, t.dac_code
            );
        }
    }
}
