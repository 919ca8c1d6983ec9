//! The holds of `metrics::steady_errors_g` traced: `cargo run --release -p sim-host --example
//! hold_trace -- FILE FROM_S TO_S EVERY_MS` prints time, command, true force, gauge and drive.
use sim_host::design;
use sim_host::rig::{Rig, RigConfig};

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let mut config = RigConfig {
        scan_array: false,
        ..Default::default()
    };
    config.set_applicator(
        sim_host::error::read_applicator(std::path::Path::new(&a[0])).expect("applicator"),
    );
    config.firmware.designed = Some(
        design::design_for_rig(&config)
            .expect("design")
            .design
            .config,
    );
    let (from, to, every): (f64, f64, usize) = (
        a[1].parse().unwrap(),
        a[2].parse().unwrap(),
        a[3].parse().unwrap(),
    );
    let mut rig = Rig::new(config).unwrap();
    let n = (sim_host::metrics::STEADY_HOLD_S / tactile_core::CONTROL_PERIOD_S).round() as usize;
    for (i, level) in sim_host::metrics::STEADY_LEVELS_G.iter().enumerate() {
        for k in 0..n {
            let t = rig.tick(*level, |_, _| {});
            let ts = (i * n + k) as f64 * 1e-3;
            if ts >= from && ts <= to && k % every == 0 {
                println!(
                    "{ts:7.3} s  cmd {:6.2}  true {:7.3}  gauge {:7.3}  drive {:7.3}",
                    level, t.true_force_g, t.sensed_g, t.adjusted_g
                );
            }
        }
    }
}
