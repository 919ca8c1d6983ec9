//! Benchmark (not a test): how many times faster than real time a 100 s closed-loop run goes
//! on one core, with all 64 taxels scanned.
//!
//! cargo run --release -p sim-host --example bench_realtime

use std::time::Instant;

use sim_host::rig::RigConfig;
use sim_host::scenario::{run_named, ScenarioOptions};

fn main() {
    let options = ScenarioOptions {
        duration_s: 100.0,
        ..Default::default()
    };
    let mut best = f64::MAX;
    let mut frames = 0;
    for _ in 0..3 {
        let start = Instant::now();
        let run = run_named("pseudo-random", &options, RigConfig::default(), |_| {})
            .expect("memo rig builds");
        best = best.min(start.elapsed().as_secs_f64());
        frames = run.frames.len();
    }
    let no_scan = {
        let start = Instant::now();
        run_named(
            "pseudo-random",
            &options,
            RigConfig {
                scan_array: false,
                ..Default::default()
            },
            |_| {},
        )
        .expect("memo rig builds");
        start.elapsed().as_secs_f64()
    };
    println!("100 s pseudo-random, 1 kHz control, 10 kHz plant, 64 taxels at 62.5 frames/s ({frames} frames)");
    println!(
        "  best of 3: {:.3} s wall = {:.0}x real time",
        best,
        100.0 / best
    );
    println!(
        "  without the array scan: {:.3} s wall = {:.0}x real time",
        no_scan,
        100.0 / no_scan
    );
}
