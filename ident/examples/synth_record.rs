//! Writes a record of the second generator in the project's record format.
//!
//! cargo run --release -p tactile-ident --example synth_record -- OUT.csv SEED RATE_HZ DURATION_S [EFFECT=VALUE[@X]]...
//! Effects as `SynthEffect`'s `FromStr` reads them (stiffening=S, drift=A, interference=A@HZ, …).
use std::io::Write;

use tactile_ident::synth::{generate, Spec, SynthEffect};

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
            .map(|a| a.parse::<SynthEffect>())
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
