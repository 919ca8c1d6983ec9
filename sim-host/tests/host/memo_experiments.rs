//! The simulator against what the memo saw (issue: "Must reproduce").

use sim_host::metrics::{
    closed_loop_gain, hold_quality, residual_deformation, static_linearity, worst_step_settling_s,
};
use sim_host::rig::RigConfig;
use sim_host::scenario::{run_named, ScenarioOptions};
use tactile_core::profile::STEP_SLEW_G_PER_S;

fn quiet() -> RigConfig {
    RigConfig {
        scan_array: false,
        ..Default::default()
    }
}

/// The experiment `name` with its default options on the quiet rig.
fn run_default(name: &str) -> sim_host::scenario::Run {
    run_named(name, &ScenarioOptions::default(), quiet(), |_| {}).unwrap()
}

#[test]
fn force_steps_settle_within_one_gram_in_a_tenth_of_a_second() {
    let run = run_default("force-steps");
    let worst = worst_step_settling_s(&run.ticks).expect("every step settles");
    // Memo Appendix A: about 0.08 s.
    assert!(worst <= 0.1, "worst settling {worst} s");
    assert!(
        worst > 0.03,
        "settling {worst} s is too quick to be the slewed 10 g step"
    );
}

#[test]
fn low_force_fails_with_fixed_gains_and_holds_with_the_a1_schedule() {
    let scheduled = run_default("low-force");
    for (level, lost, worst) in hold_quality(&scheduled.ticks, 0.3) {
        assert_eq!(lost, 0.0, "A1 lost contact at {level} g");
        assert!(worst <= 1.0, "A1 at {level} g: error {worst} g");
    }
    let fixed = ScenarioOptions {
        fixed_gains: true,
        ..Default::default()
    };
    let failing = run_named("low-force", &fixed, quiet(), |_| {}).unwrap();
    let quality = hold_quality(&failing.ticks, 0.3);
    let bouncing: Vec<_> = quality
        .iter()
        .filter(|(_, lost, worst)| *lost > 0.2 && *worst > 5.0)
        .collect();
    // The probe bounces off the finger: at least the two largest sub-10 g commands.
    assert!(bouncing.len() >= 2, "{quality:?}");
    assert!(bouncing.iter().all(|(level, _, _)| *level < 10.0));
}

#[test]
fn closed_loop_magnitude_is_flat_to_15_hz_and_the_filter_bump_shows_at_20() {
    let db = |hz: f64| 20.0 * closed_loop_gain(quiet(), 50.0, 10.0, hz).unwrap().log10();
    for hz in [1.0, 5.0, 10.0, 15.0] {
        let g = db(hz);
        assert!(g.abs() <= 3.0, "{hz} Hz: {g:.2} dB");
    }
    // At 20 Hz the memo's filter alone has +3.3 dB (its Q = 2.8 section peaks at 27 Hz); the
    // loop cannot flatten it with the gain that keeps it stable. Measured: +3.5 dB.
    let g20 = db(20.0);
    assert!((2.5..=4.5).contains(&g20), "20 Hz: {g20:.2} dB");
}

#[test]
fn static_linearity_bends_like_graph_1() {
    let run = run_default("static-linearity");
    let points = static_linearity(&run.ticks, STEP_SLEW_G_PER_S);
    assert_eq!(points.len(), 10, "{points:?}");
    let strains: Vec<f64> = points.iter().map(|p| p.1).collect();
    let increments: Vec<f64> = std::iter::once(strains[0])
        .chain(strains.windows(2).map(|w| w[1] - w[0]))
        .collect();
    // Saturating: each 10 g adds less than the one before (within 0.15 % of noise), and the last
    // 10 g adds under a third of the first.
    for w in increments.windows(2) {
        assert!(w[1] <= w[0] + 0.15, "{increments:?}");
    }
    assert!(increments[9] < increments[0] / 3.0, "{increments:?}");
    // Locally linear (memo: "in ±10 g about any point ... a straight line"): the midpoint of
    // each 20 g span is within 0.5 % of the chord.
    for w in strains.windows(3) {
        assert!((w[1] - 0.5 * (w[0] + w[2])).abs() < 0.5, "{strains:?}");
    }
}

#[test]
fn permanent_deformation_is_about_0_2_and_0_4_percent() {
    let run = run_default("permanent-deformation");
    let residual = residual_deformation(&run.ticks);
    assert_eq!(residual.len(), 2, "{residual:?}");
    let (r50, r100) = (residual[0].1, residual[1].1);
    assert!((0.15..=0.3).contains(&r50), "50 g: {r50} %");
    assert!((0.3..=0.5).contains(&r100), "100 g: {r100} %");
}

#[test]
fn same_seed_same_output_bit_for_bit() {
    let options = ScenarioOptions {
        duration_s: 3.0,
        ..Default::default()
    };
    let run = |seed| {
        let config = RigConfig {
            seed,
            ..Default::default()
        };
        run_named("pseudo-random", &options, config, |_| {}).unwrap()
    };
    let (a, b, c) = (run(7), run(7), run(8));
    let bits = |r: &sim_host::scenario::Run| {
        r.ticks
            .iter()
            .flat_map(|t| {
                [
                    t.sensed_g.to_bits(),
                    t.strain_pct.to_bits(),
                    t.adjusted_g.to_bits(),
                ]
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(a.frames.len(), b.frames.len());
    assert!(a
        .frames
        .iter()
        .zip(&b.frames)
        .all(|(x, y)| x.0 == y.0 && x.1 == y.1));
    assert_ne!(bits(&a), bits(&c));
    // 3 s at 62.5 frames/s.
    assert!((186..=188).contains(&a.frames.len()), "{}", a.frames.len());
}
