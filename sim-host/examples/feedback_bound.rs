//! What feedback could do at a light load's inertia–finger mode: on the simulator's
//! friction-free linearization (the plant the margins are checked on), with each of six
//! mechanical parameters 20 % off, at 2–120 g, every feedback of the designed form — PI
//! (`kp`, `ki`) on the error through one biquad: none, or a lead (a zero, then a double pole to
//! roll it off before the beam) — that keeps gain margin ≥ 2 and phase margin ≥ 45°
//! everywhere; printed, the ones whose sensitivity |S| at 10 g peaks least over 15–40 Hz,
//! where the light loads' sines miss (docs/design.md, "Not yet").
//!
//! cargo run --release -p sim-host --example feedback_bound -- applicators/F.toml
//!
//! `DELAY_TICKS=D`: the ticks the loop waits for the reading (1, the firmware's), to see what
//! a faster read-out would buy.
use num_complex::Complex64;
use sim_host::{analysis, design};
use std::f64::consts::PI;
use tactile_core::CONTROL_PERIOD_S;

/// A zero at `zero_hz` and a double pole at `pole_hz`, unit gain at DC, by the bilinear
/// transform: (b₀, b₁, b₂, a₁, a₂) as `design::ErrorFilter::biquad` gives them.
fn lead(zero_hz: f64, pole_hz: f64) -> [f64; 5] {
    let k = 2.0 / CONTROL_PERIOD_S;
    let (z, p) = (k / (2.0 * PI * zero_hz), k / (2.0 * PI * pole_hz));
    let (p0, p1) = (1.0 + p, 1.0 - p);
    let n = p0 * p0;
    [
        (1.0 + z) / n,
        2.0 / n,
        (1.0 - z) / n,
        2.0 * p0 * p1 / n,
        p1 * p1 / n,
    ]
}

/// (kp + ki·T/(1 − z⁻¹))·F(z)·z^−delay at `hz`.
fn feedback(kp: f64, ki: f64, [b0, b1, b2, a1, a2]: [f64; 5], delay: f64, hz: f64) -> Complex64 {
    let z = Complex64::from_polar(1.0, -2.0 * PI * hz * CONTROL_PERIOD_S);
    let f = (b0 + z * (b1 + z * b2)) / (1.0 + z * (a1 + z * a2));
    (kp + ki * CONTROL_PERIOD_S / (1.0 - z))
        * f
        * Complex64::from_polar(1.0, -2.0 * PI * hz * CONTROL_PERIOD_S * delay)
}

fn main() {
    let file = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "applicators/memo.toml".into());
    let nominal = sim_host::error::read_applicator(std::path::Path::new(&file))
        .unwrap_or_else(|e| panic!("{file}: {e}"));
    let delay: f64 = std::env::var("DELAY_TICKS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1.0);
    let law = tactile_core::viscoelastic::NonlinearMk::ELEMENT_4_2.g1;
    let grid = design::loop_grid_hz();
    let mut rigs = vec![nominal];
    for (_, field) in analysis::MECHANICAL_PARAMETERS {
        for f in [0.8, 1.2] {
            let mut p = nominal;
            *field(&mut p) *= f;
            rigs.push(p);
        }
    }
    // The plant as the loop sees it, on the loop's grid: gauge grams per drive gram.
    let on_grid = |p, load_g| -> Vec<Complex64> {
        grid.iter()
            .map(|&hz| analysis::held_response(p, &law, load_g, hz))
            .collect()
    };
    let loads = [2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 120.0];
    let plants: Vec<Vec<Complex64>> = rigs
        .iter()
        .flat_map(|p| loads.iter().map(move |&l| (p, l)))
        .map(|(p, l)| on_grid(p, l))
        .collect();
    let at_10g = on_grid(&nominal, 10.0);
    let band: Vec<usize> = (0..grid.len())
        .filter(|&i| (15.0..=40.0).contains(&grid[i]))
        .collect();
    let mut filters = vec![("none".to_string(), [1.0, 0.0, 0.0, 0.0, 0.0])];
    for (zero_hz, pole_hz) in [
        (5.0, 40.0),
        (10.0, 40.0),
        (20.0, 40.0),
        (10.0, 60.0),
        (30.0, 60.0),
        (10.0, 80.0),
        (20.0, 80.0),
        (40.0, 80.0),
        (20.0, 100.0),
        (50.0, 100.0),
        (15.0, 120.0),
        (30.0, 120.0),
        (10.0, 150.0),
        (40.0, 150.0),
        (60.0, 150.0),
    ] {
        filters.push((
            format!("lead {zero_hz}/{pole_hz} Hz"),
            lead(zero_hz, pole_hz),
        ));
    }
    let mut found: Vec<(f64, f64, String)> = vec![];
    let mut tried = 0;
    for (name, biquad) in &filters {
        for kp in [0.0, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.5, 0.8] {
            for ki in [0.0, 5.0, 10.0, 20.0, 40.0, 80.0] {
                if kp == 0.0 && ki == 0.0 {
                    continue;
                }
                tried += 1;
                let c: Vec<Complex64> = grid
                    .iter()
                    .map(|&hz| feedback(kp, ki, *biquad, delay, hz))
                    .collect();
                let keeps = plants.iter().all(|p| {
                    let l: Vec<Complex64> = p.iter().zip(&c).map(|(p, c)| p * c).collect();
                    let m = design::margins(&l);
                    m.gain >= 2.0 && m.phase_deg >= 45.0
                });
                if !keeps {
                    continue;
                }
                let s_db = |i: &usize| -20.0 * (1.0 + at_10g[*i] * c[*i]).norm().log10();
                let most = band.iter().map(s_db).fold(f64::MIN, f64::max);
                let least = band.iter().map(s_db).fold(f64::MAX, f64::min);
                found.push((most, least, format!("{name}, kp {kp}, ki {ki}/s")));
            }
        }
    }
    found.sort_by(|a, b| a.0.total_cmp(&b.0));
    println!(
        "{file}: {} of {tried} feedbacks keep the margins (loop delay {delay} tick); least peak of |S| at 10 g, 15–40 Hz:",
        found.len()
    );
    for (most, least, name) in found.iter().take(5) {
        println!("  {most:+.2} dB (least {least:+.2} dB): {name}");
    }
}
