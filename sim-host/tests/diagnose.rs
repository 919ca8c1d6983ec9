//! The diagnosis names the effect a record contains (issue: "Done means").
//!
//! Records are simulated bench records (80 s of the memo's sinusoids, 80 s of pseudo-random
//! steps, 20 s rest) of a finger that is linear Maxwell–Kelvin with α unless an effect is
//! switched on; each effect at a strength that roughly doubles the baseline's held-out error,
//! with seeds and strengths varied so the tests exercise the method, not one record.

use std::path::Path;

use sim_host::cli::apply_effect;
use sim_host::diagnose::{diagnose, Diagnosis};
use sim_host::fit::Series;
use sim_host::record::{parse_record, read_record, write_record};
use sim_host::rig::RigConfig;
use sim_host::scenario::{run_named, ScenarioOptions};

fn bench_record(effects: &[&str], seed: u64) -> Series {
    bench_record_of(
        tactile_plant::finger::NOMINAL_TAXEL,
        &[&["stiffening=0"], effects].concat(),
        seed,
    )
}

/// A bench record of the probe over `taxel` (its own parameters away from element 4,2's) with
/// `effects` applied over the memo's physics.
fn bench_record_of(taxel: tactile_core::tactile::TaxelId, effects: &[&str], seed: u64) -> Series {
    let mut config = RigConfig {
        seed,
        probe: taxel,
        scan_array: false,
        ..Default::default()
    };
    for e in effects {
        apply_effect(&mut config.effects, e).unwrap();
    }
    let options = ScenarioOptions {
        protocol_seed: seed * 7 + 3,
        ..Default::default()
    };
    let run = run_named("bench-record", &options, config, |_| {}).unwrap();
    // Through the record format, as a user's file would come.
    let path = std::env::temp_dir().join(format!(
        "diagnose_test_{seed}_{}_{}.csv",
        taxel.index(),
        effects.join("_").replace(['=', '@', '.'], "-")
    ));
    write_record(
        &path,
        &[("sample_rate_hz".into(), "200".into())],
        &run.ticks,
        5,
    )
    .unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let _ = std::fs::remove_file(&path);
    Series::from_record(&parse_record(text.as_bytes(), &path).unwrap())
}

fn check(d: &Diagnosis, expected: &str) {
    assert_eq!(d.effect, expected, "{}", d.summary);
    if expected != "none" {
        assert!(
            d.after.held_out_rms_g < d.before.held_out_rms_g,
            "{}",
            d.summary
        );
        assert!(d
            .candidates
            .iter()
            .any(|c| c.accepted && c.effect == expected));
    } else {
        assert!(d.effects.is_empty(), "{}", d.summary);
    }
}

/// Other taxels of other fingers (their springs and dashpots 0.7–1.4× element 4,2's, each
/// its own way): a linear one gets `none`; the memo's stiffening gets that effect alone, with the
/// residual left at the read-out's noise — no second effect made up from a stiffening model of
/// the wrong shape.
#[test]
fn other_taxels_get_their_verdicts_and_nothing_more() {
    use tactile_core::tactile::TaxelId;
    let linear = diagnose(&bench_record_of(
        TaxelId::new(1, 5).unwrap(),
        &["stiffening=0"],
        7,
    ))
    .unwrap();
    check(&linear, "none");
    let stiff = diagnose(&bench_record_of(TaxelId::new(6, 6).unwrap(), &[], 3)).unwrap();
    check(&stiff, "load_dependent_stiffness");
    assert_eq!(
        stiff.effects,
        ["load_dependent_stiffness"],
        "{}",
        stiff.summary
    );
    assert!(stiff.after.held_out_rms_g < 0.25, "{}", stiff.summary);
}

/// The memo's step loads on a linear finger drive the strain onto its converter's rail at
/// 50 and 80 g (25 % strain is beyond the ±10 V converter): those samples are left out and the
/// verdict is `none`, not an effect made up to explain a clipped signal.
#[test]
fn a_clipped_record_is_judged_on_what_it_saw() {
    let mut config = RigConfig {
        seed: 5,
        scan_array: false,
        ..Default::default()
    };
    apply_effect(&mut config.effects, "stiffening=0").unwrap();
    let run = run_named("step-loads", &ScenarioOptions::default(), config, |_| {}).unwrap();
    let path = std::env::temp_dir().join("diagnose_test_clipped_step_loads.csv");
    write_record(
        &path,
        &[("sample_rate_hz".into(), "200".into())],
        &run.ticks,
        5,
    )
    .unwrap();
    let series = Series::from_record(&read_record(&path).unwrap());
    let _ = std::fs::remove_file(&path);
    let railed = series.excluded.iter().filter(|x| **x).count();
    assert!(
        railed > series.excluded.len() / 20,
        "{railed} samples at the rail"
    );
    let d = diagnose(&series).unwrap();
    check(&d, "none");
    assert!(d.summary.contains("rail"), "{}", d.summary);
    assert!(d.before.held_out_rms_g < 0.3, "{}", d.summary);
}

#[test]
fn a_linear_finger_gets_none() {
    for seed in [11, 12] {
        check(&diagnose(&bench_record(&[], seed)).unwrap(), "none");
    }
}

#[test]
fn load_dependent_stiffness_is_found() {
    for (strength, seed) in [("stiffening=0.1", 21), ("stiffening=0.15", 22)] {
        check(
            &diagnose(&bench_record(&[strength], seed)).unwrap(),
            "load_dependent_stiffness",
        );
    }
}

#[test]
fn hysteresis_is_found() {
    for (strength, seed) in [("hysteresis=0.2", 31), ("hysteresis=0.25", 32)] {
        check(
            &diagnose(&bench_record(&[strength], seed)).unwrap(),
            "hysteresis",
        );
    }
}

#[test]
fn baseline_drift_is_found() {
    for (strength, seed) in [("drift=0.015", 41), ("drift=0.02", 42)] {
        check(
            &diagnose(&bench_record(&[strength], seed)).unwrap(),
            "baseline_drift",
        );
    }
}

#[test]
fn periodic_interference_is_found_at_its_frequency() {
    for (strength, seed, hz) in [
        ("interference=0.11@7.3", 51, 7.3),
        ("interference=0.1@3.1", 52, 3.1),
    ] {
        let d = diagnose(&bench_record(&[strength], seed)).unwrap();
        check(&d, "periodic_interference");
        let notch = d.force_estimate.estimator_config["notch_hz"]
            .as_f64()
            .unwrap();
        assert!((notch - hz).abs() < 0.05, "notch at {notch} Hz for {hz} Hz");
        // On the chip: the exported table's notch takes the tone off the strain before the
        // estimators; the same table without it leaves the tone in the force.
        let model =
            sim_host::diagnose::taxel_model(&d, tactile_core::tactile::TaxelId::default()).unwrap();
        assert!((model.notch_hz - hz).abs() < 0.05, "{}", model.notch_hz);
        let series = bench_record(&[strength], seed);
        let without = tactile_core::calibration::TaxelModel {
            notch_hz: 0.0,
            ..model.clone()
        };
        let score = |m: &tactile_core::calibration::TaxelModel| {
            let mut est = tactile_core::estimator::TaxelEstimators::new(m, series.dt_s).unwrap();
            let sum: f64 = series
                .strain
                .iter()
                .zip(&series.force)
                .map(|(e, f)| (f64::from(est.update(*e as f32)[1]) - f).powi(2))
                .sum();
            (sum / series.force.len() as f64).sqrt()
        };
        let (with, without) = (score(&model), score(&without));
        eprintln!("{strength}: on-chip inverse {with:.3} g with the notch, {without:.3} g without");
        assert!(with < 0.75 * without, "{with} vs {without}");
    }
}

#[test]
fn time_delay_is_found_and_measured() {
    for (strength, seed, delay) in [
        ("delay=0.005", 61, 0.005),
        ("delay=0.008", 62, 0.008),
        ("delay=0.02", 63, 0.02),
    ] {
        let d = diagnose(&bench_record(&[strength], seed)).unwrap();
        check(&d, "time_delay");
        let fitted = d.force_estimate.estimator_config["delay_s"]
            .as_f64()
            .unwrap();
        assert!(
            (fitted - delay).abs() < 0.0015,
            "fitted {fitted} s for {delay} s"
        );
    }
}

#[test]
fn the_shared_examples_get_their_labels() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    let labels: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("labels.json")).unwrap()).unwrap();
    for entry in labels.as_array().unwrap() {
        let file = entry["file"].as_str().unwrap();
        let expected = entry["effect"].as_str().unwrap();
        let record = read_record(&dir.join(file)).unwrap();
        let d = diagnose(&Series::from_record(&record)).unwrap();
        check(&d, expected);
    }
}

/// The accepted stiffening travels to the chip (issue 4, step 6): the diagnosis of the shared
/// stiffening example, exported as the firmware's calibration table, gives the core's scheduled
/// inverse a schedule over load that estimates the record's force better than the same model
/// without it.
#[test]
fn the_diagnosed_stiffening_reaches_the_on_chip_estimator() {
    use tactile_core::calibration::{CalibrationTable, TaxelModel};
    use tactile_core::estimator::TaxelEstimators;
    use tactile_core::tactile::TaxelId;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/example_stiffening.csv");
    let record = sim_host::record::read_record(&path).unwrap();
    let series = sim_host::fit::Series::from_record(&record);
    let d = sim_host::diagnose::diagnose(&series).unwrap();
    assert_eq!(d.effect, "load_dependent_stiffness");
    let taxel = TaxelId::new(3, 2).unwrap();
    let model = sim_host::diagnose::taxel_model(&d, taxel).unwrap();
    assert_eq!(model.schedule.len(), 4);
    // Through the firmware's own bytes.
    let mut table = CalibrationTable::default();
    table.taxels.push(model.clone()).unwrap();
    let mut bytes = vec![0u8; table.encoded_len()];
    let n = table.encode(&mut bytes).unwrap();
    let back = CalibrationTable::decode(&bytes[..n]).unwrap();
    let model = back.get(taxel).unwrap().clone();
    // Without the effect: the baseline model the diagnosis started from, as the chip would
    // have run it.
    let baseline = d.baseline_fit.as_ref().unwrap();
    let base = baseline.model.base;
    let baseline_so = base.second_order(&baseline.physical).unwrap();
    let unscheduled = TaxelModel {
        schedule: [(25.0, baseline_so)].into_iter().collect(),
        second_order: baseline_so,
        strain_offset_pct: baseline.physical[base.parameter_count()],
        ..model.clone()
    };
    // RMS against the record's force of estimator `k` (2: scheduled inverse, 3: observer).
    let score = |m: &TaxelModel, k: usize| {
        let mut est = TaxelEstimators::new(m, series.dt_s).unwrap();
        let sum: f64 = series
            .strain
            .iter()
            .zip(&series.force)
            .map(|(e, f)| (f64::from(est.update(*e as f32)[k]) - f).powi(2))
            .sum();
        (sum / series.force.len() as f64).sqrt()
    };
    let (with, without) = (score(&model, 2), score(&unscheduled, 2));
    let observer = score(&model, 3);
    eprintln!("observer with the diagnosed springs: {observer:.3} g");
    assert!(observer < 0.3, "{observer}");
    eprintln!("scheduled inverse on the stiffening example: {with:.3} g with the diagnosed schedule, {without:.3} g with the baseline model (diagnosis: {:.3} → {:.3} g)", d.force_estimate.before_rms_g, d.force_estimate.after_rms_g);
    assert!(with < 0.5 && with < 0.2 * without, "{with} vs {without}");
}
