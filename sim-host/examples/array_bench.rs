//! The array's benchmark through the chip's path (`sim_host::array_bench`): a finger whose
//! taxels each have their own dynamics, calibrated taxel by taxel and then as an array, and
//! steps of one contact, two contacts and a line located every frame by the firmware's scanner.
//!
//! cargo run --release -p sim-host --example array_bench -- [--fitted] [--depth MM] [--strain]
//!     [SEED…]
//!
//! `--fitted`: each taxel's calibration fitted from its record of the calibration protocol
//! (`tactile calibrate`'s fit, about 6 s a taxel); without it, each taxel's own element given
//! whole. `--depth MM`: the finger's rubber this deep over its plates (the memo's 4 mm
//! otherwise); the array's calibration learns it. `--strain`: each taxel reads the rubber's
//! compressive strain (ν = 0.5) rather than σ_zz, a field the locator's model does not hold.

use sim_host::array_bench::{bench_table, TaxelCalibration};
use tactile_plant::spatial::SpatialLaw;

fn main() {
    let mut how = TaxelCalibration::Exact;
    let mut depth_mm = f64::from(tactile_core::contact::SpatialResponse::MEMO.depth_mm);
    let mut strain = false;
    let mut seeds = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--fitted" => how = TaxelCalibration::Fitted,
            "--strain" => strain = true,
            "--depth" => match args.next().and_then(|d| d.parse().ok()) {
                Some(d) => depth_mm = d,
                None => usage(),
            },
            seed => match seed.parse::<u64>() {
                Ok(s) => seeds.push(s),
                Err(_) => usage(),
            },
        }
    }
    let pitch_mm = f64::from(tactile_core::contact::SpatialResponse::MEMO.pitch_mm);
    let law = if strain {
        SpatialLaw::Strain {
            depth_mm,
            pitch_mm,
            poisson: 0.5,
        }
    } else {
        SpatialLaw::HalfSpace { depth_mm, pitch_mm }
    };
    if seeds.is_empty() {
        seeds.push(3);
    }
    for seed in seeds {
        match bench_table(seed, law, how, 60) {
            Ok(text) => println!("{text}"),
            Err(e) => {
                eprintln!("array_bench: {e}");
                std::process::exit(1);
            }
        }
    }
}

fn usage() -> ! {
    eprintln!("usage: array_bench [--fitted] [--depth MM] [--strain] [SEED…]");
    std::process::exit(2);
}
