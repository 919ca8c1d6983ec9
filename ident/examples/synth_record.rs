//! Writes a record of the second generator in the project's record format.
//!
//! cargo run --release -p tactile-ident --example synth_record -- OUT.csv SEED RATE_HZ DURATION_S [EFFECT=VALUE[@X]]...
//! Effects: stiffening=S, hysteresis=W, drift=A, interference=A@HZ, delay=SAMPLES,
//! slow=SHARE@TAU_S, sag=FRACTION (see `tactile_ident::synth::SynthEffect`).
use std::io::Write;

use tactile_ident::synth::{generate, Spec, SynthEffect};

fn effect(arg: &str) -> Result<SynthEffect, String> {
    let (name, value) = arg
        .split_once('=')
        .ok_or(format!("{arg}: expected NAME=VALUE"))?;
    let (v, at) = match value.split_once('@') {
        Some((v, at)) => (v, Some(at)),
        None => (value, None),
    };
    let num = |s: &str| s.parse::<f64>().map_err(|e| format!("{arg}: {e}"));
    let at = || at.ok_or(format!("{arg}: expected VALUE@X")).and_then(num);
    Ok(match name {
        "stiffening" => SynthEffect::Stiffening(num(v)?),
        "hysteresis" => SynthEffect::Hysteresis(num(v)?),
        "drift" => SynthEffect::Drift(num(v)?),
        "interference" => SynthEffect::Interference {
            amplitude: num(v)?,
            hz: at()?,
        },
        "delay" => SynthEffect::Delay(num(v)? as usize),
        "slow" => SynthEffect::SlowRelaxation {
            share: num(v)?,
            tau_s: at()?,
        },
        "sag" => SynthEffect::SensitivityDrift(num(v)?),
        _ => return Err(format!("{arg}: unknown effect")),
    })
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 4 {
        return Err("usage: OUT.csv SEED RATE_HZ DURATION_S [EFFECT=VALUE]...".into());
    }
    let parse = |s: &str| s.parse::<f64>().map_err(|e| format!("{s}: {e}"));
    let spec = Spec {
        seed: parse(&args[1])? as u64,
        rate_hz: parse(&args[2])?,
        duration_s: parse(&args[3])?,
        effects: args[4..]
            .iter()
            .map(|a| effect(a))
            .collect::<Result<_, _>>()?,
    };
    let g = generate(&spec);
    let file = std::fs::File::create(&args[0]).map_err(|e| e.to_string())?;
    let mut w = std::io::BufWriter::new(file);
    let io = |e: std::io::Error| e.to_string();
    writeln!(
        w,
        "# tactile_ident::synth seed={} effects={:?}",
        spec.seed, spec.effects
    )
    .map_err(io)?;
    writeln!(w, "# sample_rate_hz={}", spec.rate_hz).map_err(io)?;
    writeln!(w, "t_s,force_g,strain_pct,true_force_g").map_err(io)?;
    for i in 0..g.force_g.len() {
        writeln!(
            w,
            "{:.6},{:.4},{:.6},{:.4}",
            i as f64 * g.dt_s,
            g.force_g[i],
            g.strain_pct[i],
            g.true_force_g[i]
        )
        .map_err(io)?;
    }
    w.flush().map_err(io)
}
