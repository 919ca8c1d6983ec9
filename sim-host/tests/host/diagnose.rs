//! `tactile diagnose` on the project's simulator, the shared records and bad input.
//!
//! The simulator is the first record generator (the second, different in form, is
//! `tactile_ident::synth`, tested in `ident/tests`).

use std::path::Path;

use sim_host::chip_diagnosis::{diagnose, series_of, Report};
use sim_host::cli::apply_effect;
use sim_host::record::{parse_record, read_record, write_record};
use sim_host::rig::RigConfig;
use sim_host::scenario::{run_named, ScenarioOptions};
use tactile_core::tactile::TaxelId;

/// The rig without its array scan, a linear finger (no stiffening) with `effects` switched on.
fn rig(seed: u64, effects: &[&str]) -> RigConfig {
    let mut config = RigConfig {
        seed,
        scan_array: false,
        ..Default::default()
    };
    for e in [&["stiffening=0"], effects].concat() {
        apply_effect(&mut config.effects, e).unwrap();
    }
    config
}

/// Writes `ticks` as the simulated firmware's record at 200 Hz to `path`.
fn write_sim_record(path: &Path, ticks: &[sim_host::rig::TickRecord]) {
    write_record(
        path,
        &[("sample_rate_hz".into(), "200".into())],
        ticks,
        5,
        &sim_host::rig::RigConfig::SIM_FIRMWARE.actuator,
    )
    .unwrap();
}

fn bench_record(effects: &[&str], seed: u64) -> sim_host::record::Record {
    let config = rig(seed, effects);
    let options = ScenarioOptions {
        protocol_seed: seed * 7 + 3,
        ..Default::default()
    };
    let run = run_named("bench-record", &options, config, |_| {}).unwrap();
    // Unique per call: tests run in parallel and may ask for the same record.
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let path = crate::common::scratch(&format!(
        "diagnose_test_{call}_{seed}_{}.csv",
        effects.join("_").replace(['=', '@', '.'], "-")
    ));
    write_sim_record(&path, &run.ticks);
    let text = std::fs::read_to_string(&path).unwrap();
    let _ = std::fs::remove_file(&path);
    parse_record(text.as_bytes(), &path).unwrap()
}

fn run(r: &sim_host::record::Record) -> Report {
    diagnose(&series_of(r).unwrap(), TaxelId::default())
}

fn check(d: &Report, expected: &str) {
    let d_ = &d.diagnosis;
    assert_eq!(d_.effect, expected, "{}", d_.summary);
    assert!(d_.before.held_out_rms_g.is_finite() && d_.after.held_out_rms_g.is_finite());
    if expected == "none" {
        assert!(d_.effects.is_empty(), "{}", d_.summary);
    } else {
        assert!(
            d_.after.held_out_rms_pct < d_.before.held_out_rms_pct,
            "{}",
            d_.summary
        );
    }
}

/// The value `name` of the first effect's size.
fn first_size(d: &Report, name: &str) -> f64 {
    d.diagnosis.sizes[0]
        .values
        .iter()
        .find(|v| v.0 == name)
        .unwrap()
        .1
}

#[test]
fn a_linear_finger_gets_none_and_the_memo_stiffening_is_found() {
    check(&run(&bench_record(&[], 11)), "none");
    check(
        &run(&bench_record(&["stiffening=0.15"], 22)),
        "load_dependent_stiffness",
    );
}

#[test]
fn simulator_effects_are_named() {
    let d = run(&bench_record(&["interference=0.11@7.3"], 51));
    check(&d, "periodic_interference");
    let hz = first_size(&d, "hz");
    assert!((hz - 7.3).abs() < 0.05, "{hz}");
    check(&run(&bench_record(&["drift=0.02"], 42)), "baseline_drift");
}

#[test]
fn the_shared_examples_get_their_labels() {
    let dir = crate::common::shared_data();
    let labels: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("labels.json")).unwrap()).unwrap();
    for entry in labels.as_array().unwrap() {
        let file = entry["file"].as_str().unwrap();
        let expected = entry["effect"].as_str().unwrap();
        check(&run(&read_record(&dir.join(file)).unwrap()), expected);
    }
}

/// Scaling a column (another unit) does not move the verdict, and the grams follow the force.
#[test]
fn scaling_a_column_does_not_change_the_verdict() {
    let path = crate::common::shared_data().join("example_stiffening.csv");
    let r = read_record(&path).unwrap();
    let base = run(&r);
    let mut scaled = r.clone();
    scaled.force_g.iter_mut().for_each(|f| *f *= 10.0);
    scaled.strain_pct.iter_mut().for_each(|e| *e *= 0.1);
    let d = run(&scaled);
    assert_eq!(d.diagnosis.effect, base.diagnosis.effect);
    assert_eq!(d.diagnosis.effects, base.diagnosis.effects);
    let ratio = d.diagnosis.before.held_out_rms_g / base.diagnosis.before.held_out_rms_g;
    assert!((ratio - 10.0).abs() < 0.05, "{ratio}");
}

/// Real records of a soft skin from another laboratory (`../shared/data/real`): finite
/// results; an accepted effect lowers the held-out error; what `--table` writes never holds
/// out worse on the chip than the baseline.
#[test]
fn real_records_give_finite_results_and_never_a_worse_chip() {
    let dir = crate::common::shared_data().join("real");
    for name in ["fsi_skin_water.csv", "fsi_skin_oil.csv", "fsi_skin_air.csv"] {
        let d = run(&read_record(&dir.join(name)).unwrap());
        let g = &d.diagnosis;
        eprintln!(
            "{name}: {} {:.3} → {:.3} g",
            g.effect, g.before.held_out_rms_g, g.after.held_out_rms_g
        );
        assert!(g.before.held_out_rms_g.is_finite() && g.after.held_out_rms_g.is_finite());
        assert!(g.after.held_out_rms_pct <= g.before.held_out_rms_pct);
        assert!(!g.summary.contains("NaN"), "{}", g.summary);
        let f = &d.force_estimate;
        if let (Some(b), Some(a)) = (f.before_rms_g, f.after_rms_g) {
            if f.exported {
                assert!(
                    a < b,
                    "{name}: exported a model that holds out worse on the chip"
                );
            }
        }
    }
}

/// The oil-filled skin's pressure peaks about 0.23 s after the force, but its slope does not
/// lag (force and pressure slopes correlate best within 10 ms): the lag is the fluid's
/// first-order relaxation, not dead time. Fitted outside the project on this record, a
/// lowpass of 0.3 s beside the force explains 96.7 % of the pressure's variance, the force
/// delayed 0.23 s 91.7 %, and a delay added to lowpasses explains less than they do alone. The
/// baseline holds it in its Kelvin branches, and the delay tried beside them stays short.
#[test]
fn the_oil_skins_lag_is_a_relaxation_the_baseline_holds() {
    let path = crate::common::shared_data().join("real/fsi_skin_oil.csv");
    let g = run(&read_record(&path).unwrap()).diagnosis;
    let b = &g.baseline;
    let total = b.elastic_pct_per_g + b.branches.iter().map(|(_, c)| c).sum::<f64>();
    let lag: f64 = b
        .branches
        .iter()
        .filter(|(tau, _)| (0.1..=1.0).contains(tau))
        .map(|(_, c)| c)
        .sum();
    assert!(lag > 0.8 * total, "{b:?}");
    assert!(g.effects.iter().all(|e| e.to_string() != "time_delay"));
    let delays_ms: Vec<f64> = g
        .candidates
        .iter()
        .filter(|c| c.effect.to_string() == "time_delay")
        .filter_map(|c| {
            c.variant
                .strip_prefix("force delayed ")?
                .strip_suffix(" ms")?
                .parse()
                .ok()
        })
        .collect();
    assert!(
        !delays_ms.is_empty() && delays_ms.iter().all(|d| *d <= 50.0),
        "{delays_ms:?}"
    );
}

#[test]
fn bad_records_are_refused_with_the_reason() {
    let p = Path::new("bad.csv");
    let parse = |text: &str| parse_record(text.as_bytes(), p).unwrap();
    let zeros: String = (0..500)
        .map(|i| format!("{},0,0\n", i as f64 * 0.01))
        .collect();
    let r = parse(&format!("t_s,force_g,strain_pct\n{zeros}"));
    let e = series_of(&r).unwrap_err().to_string();
    assert!(e.contains("force does not vary"), "{e}");
    let r = parse("t_s,force_g,strain_pct\n0,1,2\n0.01,2,3\n");
    assert!(series_of(&r).unwrap_err().to_string().contains("too short"));
    let constant: String = (0..500)
        .map(|i| format!("{},5,{}\n", i as f64 * 0.01, (i % 7) as f64))
        .collect();
    let r = parse(&format!("t_s,force_g,strain_pct\n{constant}"));
    assert!(series_of(&r)
        .unwrap_err()
        .to_string()
        .contains("force does not vary"));
    let huge: String = (0..500)
        .map(|i| format!("{},{},1e30\n", i as f64 * 0.01, i % 9))
        .collect();
    let r = parse(&format!("t_s,force_g,strain_pct\n{huge}"));
    assert!(series_of(&r).unwrap_err().to_string().contains("plausible"));
}

/// The memo's step loads on a linear finger drive the strain onto its converter's rail at 50 and
/// 80 g: those samples are left out and the verdict is `none`, not an effect made up to explain
/// a clipped signal.
#[test]
fn a_clipped_record_is_judged_on_what_it_saw() {
    let run_ = run_named(
        "step-loads",
        &ScenarioOptions::default(),
        rig(5, &[]),
        |_| {},
    )
    .unwrap();
    let path = crate::common::scratch("diagnose_test_clipped_step_loads.csv");
    write_sim_record(&path, &run_.ticks);
    let record = read_record(&path).unwrap();
    let _ = std::fs::remove_file(&path);
    let series = series_of(&record).unwrap();
    let railed = series.excluded.iter().filter(|x| **x).count();
    assert!(railed > series.len() / 20, "{railed} samples at the rail");
    let d = diagnose(&series, TaxelId::default());
    check(&d, "none");
    assert!(
        d.diagnosis.summary.contains("rail"),
        "{}",
        d.diagnosis.summary
    );
}

#[test]
fn simulator_hysteresis_and_delays_are_named() {
    check(&run(&bench_record(&["hysteresis=0.2"], 31)), "hysteresis");
    for (strength, seed, ms) in [("delay=0.008", 62, 8.0), ("delay=0.02", 63, 20.0)] {
        let d = run(&bench_record(&[strength], seed));
        check(&d, "time_delay");
        let fitted = first_size(&d, "delay_ms");
        assert!((fitted - ms).abs() < 0.5 * ms, "{fitted} ms for {ms} ms");
    }
}

/// Hysteresis reaches the chip: the accepted plays, taken off the strain before the on-chip
/// estimators, lower their held-out force error, and `--table` carries them. On both
/// generators: the simulator's plays (stop form, what the chip undoes) and the second
/// generator's Duhem loop (another form), at two strengths and seeds.
#[test]
fn hysteresis_reaches_the_chip_and_lowers_its_error() {
    use tactile_ident::synth::{generate, Spec, SynthEffect};
    let synth = |seed: u64, width: f64, rate_hz: f64, duration_s: f64| {
        let g = generate(&Spec {
            seed,
            rate_hz,
            duration_s,
            effects: vec![SynthEffect::Hysteresis(width)],
        });
        tactile_ident::Series::new(g.dt_s, g.force_g, g.strain_pct, vec![]).unwrap()
    };
    // The simulator's loop is the chip's form: most of the error goes. A Duhem loop, which
    // the chip undoes with plays, is followed less closely (measured 0.74 → 0.24, 0.89 →
    // 0.49, 1.32 → 1.13 and, 120 s at 1 kHz, 1.92 → 0.94 g).
    let cases = [
        (
            "simulator 0.2 %",
            series_of(&bench_record(&["hysteresis=0.2"], 31)).unwrap(),
            0.5,
        ),
        ("synth 15, 0.05", synth(15, 0.05, 200.0, 240.0), 0.8),
        ("synth 6, 0.08", synth(6, 0.08, 200.0, 240.0), 1.0),
        ("synth 1, 0.1, 1 kHz", synth(1, 0.1, 1000.0, 120.0), 0.8),
    ];
    for (name, series, share) in cases {
        let d = diagnose(&series, TaxelId::default());
        check(&d, "hysteresis");
        let f = &d.force_estimate;
        let (before, after) = (f.before_rms_g.unwrap(), f.after_rms_g.unwrap());
        eprintln!("{name}: on the chip {before:.3} → {after:.3} g");
        assert!(f.exported, "{name}: {}", d.diagnosis.summary);
        assert!(after < share * before, "{name}: {before} → {after}");
        let plays = d.table_model.as_ref().unwrap().hysteresis;
        assert!(!plays.is_empty() && plays.bound_pct() > 0.0, "{name}");
    }
}
