//! Force estimators and dynamic calibration on the simulator.

use std::sync::LazyLock;

use sim_host::dynamic_calibration::{
    calibrate_simulated, TaxelFitReport, CALIBRATION_TAXELS, FINGER_SEED,
};
use sim_host::estimator_comparison::{compare, compare_with, EstimatorTable, PROTOCOLS};
use sim_host::fingers::FingerKind;
use tactile_core::calibration::CalibrationTable;

/// The simulated finger's calibration, made once for the tests that read it.
static MEMO: LazyLock<(CalibrationTable, Vec<TaxelFitReport>)> = LazyLock::new(|| {
    calibrate_simulated(&CALIBRATION_TAXELS, FINGER_SEED, FingerKind::Memo.effects()).unwrap()
});

#[test]
fn calibrated_estimators_beat_the_memos_and_the_best_reaches_half_a_gram() {
    let (table, fits) = &*MEMO;
    let t = compare_with(table, fits.clone(), FINGER_SEED, FingerKind::Memo.effects()).unwrap();
    eprintln!("{}", sim_host::estimator_comparison::render(&t));
    assert_eq!(t.taxels.len(), 4);
    assert_eq!(PROTOCOLS[0], "pseudo-random");
    let (nominal, calibrated) = (&t.nominal_g[0], &t.calibrated_g[0]);
    // Columns: elastic, second-order inverse, scheduled inverse, observer, structural.
    // The best on-chip estimator, calibrated, at or below 0.5 g on the pseudo-random protocol
    // on every taxel (the memo's inverse: 2.23 g).
    let best = |row: &[f64; 5]| row[..4].iter().copied().fold(f64::MAX, f64::min);
    for row in &t.pseudo_random_per_taxel_g {
        assert!(best(row) <= 0.5, "{row:?}");
    }
    // Calibration helps every estimator on average, and the observer most of all.
    for c in 0..4 {
        assert!(
            calibrated[c] < nominal[c],
            "column {c}: {calibrated:?} vs {nominal:?}"
        );
    }
    // Scheduling over load beats one second-order model on the step loads (10–80 g).
    let steps = &t.calibrated_g[1];
    assert!(steps[2] < steps[1], "{steps:?}");
    // The observer, calibrated, is the best on chip: the estimator targets (0.3 g on
    // pseudo-random and the sinusoids, 0.5 g on the step loads to 80 g; 0.05, 0.14 and 0.05 g
    // measured), and the 0.18 g the project's finger had before.
    assert!(
        calibrated[3] <= 0.12 && t.calibrated_g[1][3] <= 0.3 && t.calibrated_g[2][3] <= 0.12,
        "{:?}",
        t.calibrated_g
    );
    // No overshoot beyond 1 g on the memo's 30 g rise, for the scheduled inverse and the
    // observer.
    for c in [2, 3] {
        assert!(
            t.overshoot_30g_rise_g[c] < 1.0,
            "{:?}",
            t.overshoot_30g_rise_g
        );
    }
}

/// The table the firmware build carries is what `tactile calibrate` writes for the simulated
/// finger today (regenerate it with `cargo run --release -p sim-host --bin tactile --
/// calibrate --out boards/calibration/table.bin` when the calibration changes).
#[test]
fn the_committed_calibration_table_is_the_simulators() {
    let committed = std::fs::read(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../boards/calibration/table.bin"),
    )
    .unwrap();
    let (table, _) = &*MEMO;
    let mut fresh = vec![0u8; table.encoded_len()];
    table.encode(&mut fresh).unwrap();
    assert!(
        committed == fresh,
        "boards/calibration/table.bin is stale: regenerate it with `tactile calibrate`"
    );
    let decoded = tactile_core::calibration::CalibrationTable::decode(&committed).unwrap();
    assert_eq!(decoded.taxels.len(), 4);
}

/// The observer's calibrated and nominal RMS (g) on each protocol.
fn observer(t: &EstimatorTable) -> ([f64; 3], [f64; 3]) {
    (
        [0, 1, 2].map(|k| t.calibrated_g[k][3]),
        [0, 1, 2].map(|k| t.nominal_g[k][3]),
    )
}

/// Issue 15: fingers of the memo's physics whose springs stiffen by other laws (linear,
/// saturating, piecewise), with other α and Kelvin times, calibrated from the calibration
/// protocol and scored on pseudo-random, step loads and sinusoids. Calibration must beat the
/// nominal models on every protocol, and every finger meets the targets (0.3, 0.5,
/// 0.3 g) — the piecewise finger, whose stiffness doubles within a few grams, since the
/// knots are spread over the calibrated range (0.62, 0.42, 0.54 g with knots crowded at light
/// loads as the curve's default stresses are).
#[test]
fn calibration_holds_on_fingers_unlike_the_simulators() {
    // (finger, seed, bound on pseudo-random, step loads, sinusoids), g. Seed 37 was first run
    // after the calibration's design was fixed: its fit ran α (the permanent deformation's
    // spring, which a 20 s hold barely shows) to 157 and 0 on two taxels, and the step loads
    // were 2.4 g off until α was held near element 4,2's where the record says little.
    let cases = [
        (FingerKind::Saturating, FINGER_SEED, [0.3, 0.5, 0.3]),
        (FingerKind::LinearSaturating, FINGER_SEED, [0.3, 0.5, 0.3]),
        (FingerKind::Piecewise, FINGER_SEED, [0.3, 0.5, 0.3]),
        (FingerKind::LinearSaturating, 37, [0.3, 0.5, 0.3]),
    ];
    for (finger, seed, bound) in cases {
        let t = compare(seed, finger).unwrap();
        let (calibrated, nominal) = observer(&t);
        eprintln!("{finger:?}: observer calibrated {calibrated:?}, nominal {nominal:?}");
        for k in 0..3 {
            assert!(
                calibrated[k] < 0.5 * nominal[k] && calibrated[k] <= bound[k],
                "{finger:?}, {}: {calibrated:?} vs nominal {nominal:?}",
                PROTOCOLS[k]
            );
        }
        // Every taxel's table runs the estimator that held out best, and a taxel that held
        // out above 1 g is flagged poor.
        for fit in &t.fits {
            let nominal = fit.flags.iter().any(|f| f == "nominal");
            let errors = if nominal {
                fit.nominal_held_out_g
            } else {
                fit.held_out_g
            };
            let best = (0..4)
                .min_by(|a, b| errors[*a].total_cmp(&errors[*b]))
                .unwrap();
            let names = tactile_core::estimator::EstimatorKind::ALL.map(|k| k.name());
            assert_eq!(fit.estimator, names[best], "{finger:?} {:?}", fit.taxel);
            let poor = fit.flags.iter().any(|f| f == "poor");
            assert_eq!(poor, errors[best] > 1.0, "{finger:?} {fit:?}");
        }
    }
}

/// The observer's reading (mean over the last of 3 s) of a load stepped onto a taxel at rest,
/// on the chip's path: the taxel's element given whole, written to a calibration table and
/// read back as the firmware reads it, the element's strain sampled each scan frame.
fn observer_reading_g(element: tactile_core::viscoelastic::NonlinearMk, load_g: f64) -> f64 {
    use tactile_core::estimator::{EstimatorKind, TaxelEstimator, TaxelModel};
    use tactile_core::tactile::TaxelId;
    use tactile_core::viscoelastic::NonlinearMkState;
    let mut table = CalibrationTable::default();
    let mut model = TaxelModel::nominal(TaxelId::default());
    model.element = element;
    table.taxels.push(model).unwrap();
    let mut bytes = vec![0u8; table.encoded_len()];
    table.encode(&mut bytes).unwrap();
    let chip = CalibrationTable::decode(&bytes).unwrap();
    let dt_s = 0.016;
    let mut observer = TaxelEstimator::new(EstimatorKind::Observer, &chip.taxels[0], dt_s).unwrap();
    let mut state = NonlinearMkState::default();
    let frames = (3.0 / dt_s) as usize;
    let last = (1.0 / dt_s) as usize;
    let mut sum = 0.0;
    for k in 0..frames {
        let strain = element.strain_pct(&state, load_g);
        element.step(&mut state, load_g, dt_s);
        let force = f64::from(observer.force_g(strain as f32));
        if k >= frames - last {
            sum += force;
        }
    }
    sum / last as f64
}

/// Under 1 g, below the springs' first knot, the observer reads the load the element carries:
/// within 2 % at 0.1–0.8 g on element 4,2 (whose G₁ = 0.5 + 0.54√σ starts soft: 11–38 % high
/// before the curves carried the stiffness at no load), on a G₁ that starts stiffer and
/// stiffens faster, and on the saturating and piecewise fingers' elements. `--nocapture`
/// prints the figures.
#[test]
fn the_observer_reads_loads_under_a_gram() {
    use tactile_core::spring::SpringLaw;
    use tactile_core::viscoelastic::NonlinearMk;
    let memo = NonlinearMk::ELEMENT_4_2;
    let elements = [
        ("element 4,2", memo),
        (
            "G1 = 1.2 + 1.5√σ + 0.02σ",
            NonlinearMk {
                g1: SpringLaw::power(1.2, 1.5, 0.02),
                ..memo
            },
        ),
        ("saturating finger", FingerKind::Saturating.element()),
        ("piecewise finger", FingerKind::Piecewise.element()),
    ];
    let mut worst: f64 = 0.0;
    for (name, element) in elements {
        let errors: Vec<f64> = [0.1, 0.3, 0.5, 0.8]
            .iter()
            .map(|&load| 100.0 * (observer_reading_g(element, load) / load - 1.0))
            .collect();
        eprintln!("{name}: the observer at 0.1, 0.3, 0.5, 0.8 g reads {errors:+.1?} %");
        worst = errors.iter().fold(worst, |w, e| w.max(e.abs()));
    }
    eprintln!("worst {worst:.1} %");
    assert!(worst < 2.0, "{worst} %");
}
