//! The memo's Tables I–IV reproduced on the simulator, side by side with the memo's numbers.
//!
//! Procedure as in the memo: records sampled every 0.1 s; Maxwell–Kelvin (eq. 11) and elastic
//! models fitted to each step load (50 s on, 25 s off); the models tuned at each load simulate a
//! pseudo-random record (20–40 g); the second-order model (eq. 17) and the others are fitted to
//! the sum-of-sinusoids excitation and judged on the pseudo-random record, simulating strain and,
//! inverted, estimating force.

use std::fmt::Write as _;

use serde::Serialize;
use tactile_core::viscoelastic::{Discrete2State, MaxwellKelvin};

use crate::fit::{fit, Base, Fit, ModelSpec, Split};
use crate::rig::TickRecord;
use crate::scenario::{probe_run, ScenarioError, ScenarioOptions};

/// The step loads of the memo's tables (Table I's rows).
pub const LOADS_G: [f32; 4] = {
    let t = MaxwellKelvin::TABLE_I;
    [
        t[0].load_g as f32,
        t[1].load_g as f32,
        t[2].load_g as f32,
        t[3].load_g as f32,
    ]
};

/// FACTS.md: Table I (element 4,2) as (G1, N1, N2, G2) per load, from the core's
/// [`MaxwellKelvin::TABLE_I`]; then Table II, Table III, Table IV.
pub fn memo_table_i() -> [[f64; 4]; 4] {
    MaxwellKelvin::TABLE_I.map(|r| [r.element.g1, r.element.n1, r.element.n2, r.element.g2])
}
pub const MEMO_TABLE_II_MK: [f64; 4] = [0.204, 0.455, 0.474, 0.784];
pub const MEMO_TABLE_II_ELASTIC: [f64; 4] = [0.456, 1.32, 1.91, 3.12];
pub const MEMO_TABLE_III: [f64; 4] = [8.07, 2.33, 7.68, 14.44];
/// Elastic, Maxwell–Kelvin, second order simulating strain; elastic and inverted second order
/// estimating force.
pub const MEMO_TABLE_IV: [f64; 5] = [4.54, 3.85, 3.71, 2.76, 2.23];

#[derive(Clone, Debug, Serialize)]
pub struct Tables {
    /// Per load: fitted (G1, N1, N2, G2).
    pub table_i: Vec<[f64; 4]>,
    /// Per load: RMS_n of the Maxwell–Kelvin and the elastic fits.
    pub table_ii_mk: Vec<f64>,
    pub table_ii_elastic: Vec<f64>,
    /// Per load's model: RMS_n simulating the pseudo-random record.
    pub table_iii: Vec<f64>,
    /// As [`MEMO_TABLE_IV`].
    pub table_iv: [f64; 5],
    pub second_order: [f64; 5],
}

/// Samples a run every 0.1 s: (force from the gauge, strain).
fn at_10_hz(ticks: &[TickRecord]) -> (Vec<f64>, Vec<f64>) {
    ticks
        .iter()
        .skip(99)
        .step_by(100)
        .map(|t| (f64::from(t.sensed_g), f64::from(t.strain_pct)))
        .unzip()
}

fn record(name: &str, options: ScenarioOptions, seed: u64) -> Result<Split, ScenarioError> {
    let (force, strain) = at_10_hz(&probe_run(name, options, seed, 1.0)?);
    Ok(Split::whole(0.1, force, strain))
}

fn must(f: Option<Fit>, what: &str) -> Result<Fit, crate::Error> {
    f.ok_or_else(|| crate::Error::Failed(format!("{what}: the fit did not converge")))
}

/// Runs the protocols and fits the models.
pub fn reproduce(seed: u64) -> Result<Tables, crate::Error> {
    let mk = ModelSpec::new(Base::MaxwellKelvin);
    let elastic = ModelSpec::new(Base::Elastic);
    // The memo's 100 s records of pseudo-random steps and of sinusoids.
    let long = |name: &str, seed: u64| {
        let options = ScenarioOptions {
            duration_s: 100.0,
            ..Default::default()
        };
        record(name, options, seed)
    };
    let pseudo = long("pseudo-random", seed + 1)?;
    let mut tables = Tables {
        table_i: vec![],
        table_ii_mk: vec![],
        table_ii_elastic: vec![],
        table_iii: vec![],
        table_iv: [0.0; 5],
        second_order: [0.0; 5],
    };
    for (k, load) in LOADS_G.iter().enumerate() {
        let data = record(
            "step",
            ScenarioOptions {
                load_g: *load,
                ..Default::default()
            },
            seed + 10 + k as u64,
        )?;
        let m = must(fit(&mk, &data, &[]), "Maxwell–Kelvin")?;
        let e = must(fit(&elastic, &data, &[]), "elastic")?;
        tables
            .table_i
            .push([m.physical[0], m.physical[1], m.physical[2], m.physical[3]]);
        tables.table_ii_mk.push(m.fit_rms_g);
        tables.table_ii_elastic.push(e.fit_rms_g);
        tables
            .table_iii
            .push(pseudo.rms_n_g(&m.model, &m.theta, m.g1).unwrap_or(f64::NAN));
    }
    // Table IV: models tuned on the sinusoids, judged on the pseudo-random record.
    let sines = long("sines", seed + 2)?;
    let so_spec = ModelSpec::new(Base::SecondOrder);
    let so = must(fit(&so_spec, &sines, &[]), "second order")?;
    let m = must(fit(&mk, &sines, &[]), "Maxwell–Kelvin on the sinusoids")?;
    let e = must(fit(&elastic, &sines, &[]), "elastic on the sinusoids")?;
    let strain_rms = |f: &Fit| pseudo.rms_n_g(&f.model, &f.theta, f.g1).unwrap_or(f64::NAN);
    // Force from strain: elastic σ = G ε, and the inverted second-order model clamped at zero.
    // Both subtract the fitted strain offset first.
    let rms = |est: &[f64]| {
        (est.iter()
            .zip(&pseudo.series.force_g)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / est.len().max(1) as f64)
            .sqrt()
    };
    let g = e.physical[0];
    let elastic_force: Vec<f64> = pseudo
        .series
        .strain_pct
        .iter()
        .map(|s| (g * (s - e.physical[1])).max(0.0))
        .collect();
    let p = &so.physical;
    let second = Base::SecondOrder
        .second_order(p)
        .ok_or_else(|| ScenarioError::Unknown("second-order fit has too few parameters".into()))?;
    let inverse_force: Vec<f64> = match second.inverse::<f64>(0.1) {
        Ok(inv) => {
            let mut st = Discrete2State::default();
            pseudo
                .series
                .strain_pct
                .iter()
                .map(|s| inv.update(&mut st, s - p[5]).max(0.0))
                .collect()
        }
        Err(_) => vec![f64::NAN; pseudo.series.strain_pct.len()],
    };
    tables.table_iv = [
        strain_rms(&e),
        strain_rms(&m),
        strain_rms(&so),
        rms(&elastic_force),
        rms(&inverse_force),
    ];
    tables.second_order = [p[0], p[1], p[2], p[3], p[4]];
    Ok(tables)
}

/// The tables as Markdown, simulator beside memo.
pub fn render(t: &Tables) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "## Table I — Maxwell–Kelvin parameters by step load (simulator / memo, element 4,2)\n"
    );
    let _ = writeln!(
        s,
        "| | {} |\n|---|---|---|---|---|",
        LOADS_G.map(|l| format!("{l} g")).join(" | ")
    );
    for (i, name) in ["G1", "N1", "N2", "G2"].iter().enumerate() {
        let cells: Vec<String> = t
            .table_i
            .iter()
            .zip(memo_table_i())
            .map(|(sim, memo)| format!("{:.3} / {}", sim[i], memo[i]))
            .collect();
        let _ = writeln!(s, "| {name} | {} |", cells.join(" | "));
    }
    let _ = writeln!(
        s,
        "\n## Table II — normalized RMS error (g), step responses (simulator / memo)\n"
    );
    let _ = writeln!(
        s,
        "| | {} |\n|---|---|---|---|---|",
        LOADS_G.map(|l| format!("{l} g")).join(" | ")
    );
    for (name, sim, memo) in [
        ("Maxwell–Kelvin", &t.table_ii_mk, MEMO_TABLE_II_MK),
        ("elastic", &t.table_ii_elastic, MEMO_TABLE_II_ELASTIC),
    ] {
        let cells: Vec<String> = sim
            .iter()
            .zip(memo)
            .map(|(a, b)| format!("{a:.3} / {b}"))
            .collect();
        let _ = writeln!(s, "| {name} | {} |", cells.join(" | "));
    }
    let _ = writeln!(s, "\n## Table III — pseudo-random record (20–40 g), models tuned at each load (simulator / memo)\n");
    let _ = writeln!(s, "| model | RMS_n (g) |\n|---|---|");
    for ((l, sim), memo) in LOADS_G.iter().zip(&t.table_iii).zip(MEMO_TABLE_III) {
        let _ = writeln!(s, "| {l} g model | {sim:.3} / {memo} |");
    }
    let _ = writeln!(s, "\n## Table IV — pseudo-random record, models tuned on the sum of sinusoids (simulator / memo)\n");
    let _ = writeln!(s, "| | RMS_n (g) |\n|---|---|");
    let names = [
        "elastic, simulating strain",
        "Maxwell–Kelvin, simulating strain",
        "second order, simulating strain",
        "elastic, estimating force",
        "inverted second order, estimating force (≥ 0)",
    ];
    for ((n, sim), memo) in names.iter().zip(t.table_iv).zip(MEMO_TABLE_IV) {
        let _ = writeln!(s, "| {n} | {sim:.3} / {memo} |");
    }
    let so = t.second_order;
    let _ = writeln!(
        s,
        "\nSecond-order fit: a1 = {:.3}, a2 = {:.4}, b0 = {:.3}, b1 = {:.3}, b2 = {:.4} (memo: 3.01, 0.784, 5.81, 13.26, 2.53).",
        so[0], so[1], so[2], so[3], so[4]
    );
    s
}
