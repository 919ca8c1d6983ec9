//! Benchmark (not a test): a mk-alpha fit of a 240 s record at 200 Hz, and a diagnosis of it.
//!
//! cargo run --release -p sim-host --example bench_fit
use std::time::Instant;

use sim_host::fit::{fit, Base, ModelSpec, Split};
use sim_host::rig::RigConfig;
use sim_host::scenario::{run_named, ScenarioOptions};

fn main() {
    let options = ScenarioOptions {
        duration_s: 240.0,
        ..Default::default()
    };
    let run = run_named(
        "sines",
        &options,
        RigConfig {
            scan_array: false,
            ..Default::default()
        },
        |_| {},
    )
    .expect("rig builds");
    let (force, strain): (Vec<f64>, Vec<f64>) = run
        .ticks
        .iter()
        .skip(4)
        .step_by(5)
        .map(|t| (f64::from(t.sensed_g), f64::from(t.strain_pct)))
        .unzip();
    let n = force.len();
    let mut data = Split::whole(0.005, force, strain);
    // The usual split: every fourth 10 s block held out.
    data.in_fit = (0..n).map(|i| (i / 2000) % 4 != 3).collect();
    let spec = ModelSpec::new(Base::MkAlpha);
    let mut best = f64::MAX;
    let mut evaluations = 0;
    for _ in 0..3 {
        let start = Instant::now();
        let f = fit(&spec, &data, &[]).expect("fit converges");
        best = best.min(start.elapsed().as_secs_f64());
        evaluations = f.evaluations;
    }
    println!("mk-alpha fit of a 240 s record at 200 Hz ({n} samples): best of 3 {best:.3} s ({evaluations} evaluations)");
    let series = tactile_ident::Series::new(
        0.005,
        data.series.force_g.clone(),
        data.series.strain_pct.clone(),
        vec![],
    )
    .expect("a usable record");
    let start = Instant::now();
    let d = tactile_ident::diagnose(&series);
    println!(
        "diagnosis of the same record: {:.2} s, verdict {}",
        start.elapsed().as_secs_f64(),
        d.effect
    );
}
