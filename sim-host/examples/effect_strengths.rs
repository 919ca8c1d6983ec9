//! Which effect strengths double the baseline's held-out error on a bench record, and what the
//! diagnosis says about them (a calibration aid, not a test).
//!
//! cargo run --release -p sim-host --example effect_strengths -- [EFFECT=VALUE ...]
use sim_host::cli::apply_effect;
use sim_host::diagnose::diagnose;
use sim_host::fit::{fit, Base, ModelSpec, Series};
use sim_host::record::{parse_record, write_record};
use sim_host::rig::RigConfig;
use sim_host::scenario::{run_named, ScenarioOptions};

fn record(specs: &[&str], seed: u64) -> Series {
    let mut config = RigConfig {
        seed,
        scan_array: false,
        ..Default::default()
    };
    apply_effect(&mut config.effects, "stiffening=0").expect("valid");
    for s in specs {
        apply_effect(&mut config.effects, s).expect("valid effect");
    }
    let options = ScenarioOptions {
        protocol_seed: seed + 100,
        ..Default::default()
    };
    let run = run_named("bench-record", &options, config, |_| {}).expect("rig builds");
    let path = std::env::temp_dir().join(format!("effect_strengths_{seed}.csv"));
    write_record(&path, &[], &run.ticks, 5).expect("write");
    let text = std::fs::read_to_string(&path).expect("read");
    Series::from_record(&parse_record(text.as_bytes(), &path).expect("parse"))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let specs: Vec<&str> = args.iter().map(String::as_str).collect();
    let base = fit(&ModelSpec::new(Base::MkAlpha), &record(&[], 1), &[]).expect("fit");
    let data = record(&specs, 1);
    let f = fit(&ModelSpec::new(Base::MkAlpha), &data, &[]).expect("fit");
    println!(
        "{:?}: held-out {:.3} g vs {:.3} g without ({:.2}x)",
        specs,
        f.held_out_rms_g,
        base.held_out_rms_g,
        f.held_out_rms_g / base.held_out_rms_g
    );
    if let Some(d) = diagnose(&data) {
        println!(
            "  verdict {} {:?}; held out {:.3} -> {:.3} g",
            d.effect, d.effects, d.before.held_out_rms_g, d.after.held_out_rms_g
        );
    }
}
