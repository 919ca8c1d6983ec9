//! Development aid (not a test): diagnose a CSV record or a generated one and print the summary.
//!
//! cargo run --release -p tactile-ident --example try -- FILE.csv
//! cargo run --release -p tactile-ident --example try -- synth SEED RATE_HZ DURATION_S [EFFECT=VALUE]...
use tactile_ident::synth::{generate, Spec, SynthEffect};
use tactile_ident::{diagnose, Series};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (dt, f, e) = if args[0] == "synth" {
        let effects = args[4..]
            .iter()
            .map(|a| a.parse::<SynthEffect>().unwrap())
            .collect();
        let g = generate(&Spec {
            seed: args[1].parse().unwrap(),
            rate_hz: args[2].parse().unwrap(),
            duration_s: args[3].parse().unwrap(),
            effects,
        });
        (g.dt_s, g.force_g, g.strain_pct)
    } else {
        let text = std::fs::read_to_string(&args[0]).unwrap();
        let mut t = Vec::new();
        let (mut f, mut e) = (Vec::new(), Vec::new());
        for line in text.lines().filter(|l| !l.starts_with('#')).skip(1) {
            let v: Vec<f64> = line
                .split(',')
                .take(3)
                .map(|x| x.trim().parse().unwrap())
                .collect();
            t.push(v[0]);
            f.push(v[1]);
            e.push(v[2]);
        }
        ((t[t.len() - 1] - t[0]) / (t.len() - 1) as f64, f, e)
    };
    let start = std::time::Instant::now();
    match Series::new(dt, f, e, vec![]) {
        Ok(s) => {
            let d = diagnose(&s);
            print!("{}", d.summary);
            println!("({:.2} s)", start.elapsed().as_secs_f64());
        }
        Err(r) => println!("refused: {r}"),
    }
}
