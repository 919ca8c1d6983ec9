//! The diagnosis on the second record generator (`tactile_ident::synth`), different in form
//! from the simulator it was first built on: Prony fingers of 3–5 modes, effects written in
//! other forms, 20 Hz–1 kHz. Seeds and strengths vary.

use tactile_ident::synth::{generate, Spec, SynthEffect};
use tactile_ident::{diagnose, Diagnosis, Effect, Series};

fn diag(seed: u64, rate_hz: f64, duration_s: f64, effects: &[SynthEffect]) -> Diagnosis {
    let g = generate(&Spec {
        seed,
        rate_hz,
        duration_s,
        effects: effects.to_vec(),
    });
    diagnose(&Series::new(g.dt_s, g.force_g, g.strain_pct, vec![]).unwrap())
}

fn check(d: &Diagnosis, expected: &str) {
    assert_eq!(d.effect, expected, "{}", d.summary);
    assert!(d.before.held_out_rms_pct.is_finite() && d.after.held_out_rms_pct.is_finite());
    assert_eq!(d.folds.len(), d.before.fold_rms_pct.len());
    assert!(d.folds.len() >= 4);
    if expected == "none" {
        assert!(d.effects.is_empty(), "{}", d.summary);
    } else {
        assert!(
            d.after.held_out_rms_pct < d.before.held_out_rms_pct,
            "{}",
            d.summary
        );
    }
}

fn size(d: &Diagnosis, key: &str) -> f64 {
    d.sizes
        .iter()
        .flat_map(|s| s.values.iter())
        .find(|v| v.0 == key)
        .map(|v| v.1)
        .unwrap_or(f64::NAN)
}

#[test]
fn clean_fingers_get_none_at_any_rate_and_length() {
    for (seed, rate, length) in [
        (1, 200.0, 240.0),
        (2, 100.0, 120.0),
        (3, 100.0, 120.0),
        (4, 20.0, 300.0),
        (5, 1000.0, 120.0),
        (6, 1000.0, 60.0),
        // Eight seconds, one loading: plays started settled once stood in for a slow mode here.
        (13, 100.0, 8.0),
        // Read `unexplained` while the models saw the force's noise (held out 2.1–2.2× the
        // floor, in mean square); every model now sees the same Wiener-smoothed force.
        (51, 1000.0, 180.0),
        // Named `baseline_drift` by the short-time filter until the force's noise (and the
        // floor with it) was no longer estimated a fifth low.
        (65, 200.0, 180.0),
        // Named `baseline_drift` at 1 kHz while a gain of a tenth of the floor (in mean
        // square) was enough where the baseline already held out at the floor: 8 half-cosines
        // took 7 % off a residual that was the force's noise through the model.
        (24, 1000.0, 180.0),
        (46, 1000.0, 180.0),
    ] {
        check(&diag(seed, rate, length, &[]), "none");
    }
}

/// A record without noise: strain an exact spring of a slow sine of force. Nothing is
/// missing, so `none`; the fit's single-precision arithmetic (1.6·10⁻⁵ of the strain, held out)
/// read `unexplained`.
#[test]
fn a_noise_free_linear_record_gets_none() {
    let dt = 0.005;
    let force: Vec<f64> = (0..20_000)
        .map(|i| 20.0 + 10.0 * (i as f64 * dt).sin())
        .collect();
    let strain: Vec<f64> = force.iter().map(|f| 0.3 * f).collect();
    let d = diagnose(&Series::new(dt, force, strain, vec![]).unwrap());
    assert_eq!(d.effect, "none", "{}", d.summary);
    assert!(d.after.held_out_rms_pct < 1e-3, "{}", d.summary);
}

#[test]
fn an_eight_second_record_is_diagnosed_not_refused() {
    let d = diag(6, 100.0, 8.0, &[]);
    assert!(d.folds.len() >= 4);
    assert!(d.before.held_out_rms_g.is_finite());
}

#[test]
fn stiffening_by_other_laws_is_found() {
    for (seed, s) in [(5, 0.6), (7, 0.4)] {
        check(
            &diag(seed, 200.0, 240.0, &[SynthEffect::Stiffening(s)]),
            "load_dependent_stiffness",
        );
    }
}

#[test]
fn a_wandering_drift_is_found() {
    for (seed, a) in [(7, 0.05), (9, 0.03), (11, 0.03)] {
        check(
            &diag(seed, 200.0, 240.0, &[SynthEffect::Drift(a)]),
            "baseline_drift",
        );
    }
}

/// A drift that wanders (it settles and swings with a period of 60–200 s) so that no basis
/// fitted on the other blocks carries it into a 36–60 s held-out block: on seeds 76 and 85
/// every candidate lost held out and the records were left `unexplained`, though a slow
/// function of time held 76–91 % of the residual. Judged on each block less its own offset
/// and slope when nothing else explains the record. The third is a drift of another form than
/// the generator's (a smoothed random walk added to a clean finger), named before and after.
#[test]
fn a_drift_that_no_basis_carries_across_a_block_is_named() {
    for (seed, rate, length, a) in [(76, 200.0, 180.0, 0.02), (85, 50.0, 300.0, 0.06)] {
        let d = diag(seed, rate, length, &[SynthEffect::Drift(a)]);
        check(&d, "baseline_drift");
        assert_eq!(d.effects, [Effect::BaselineDrift], "{}", d.summary);
        // Its held-out error after is the blocks' less their own lines, and the JSON says so.
        assert!(d.after_per_block_line, "{}", d.summary);
    }
    let g = generate(&Spec {
        seed: 31,
        rate_hz: 100.0,
        duration_s: 240.0,
        effects: vec![],
    });
    let swing = g.strain_pct.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // A random walk (a fixed xorshift, steps ±1 every 0.5 s), smoothed over 10 s: a
    // wandering zero of 3–6 % of the strain's swing with no low-order shape.
    let (mut state, mut walk, mut level) = (0x9e37_79b9_u32, Vec::new(), 0.0);
    for i in 0..g.strain_pct.len() {
        if i % 50 == 0 {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            level += if state & 1 == 0 { 1.0 } else { -1.0 };
        }
        walk.push(level);
    }
    let mut smooth = 0.0;
    let strain: Vec<f64> = g
        .strain_pct
        .iter()
        .zip(&walk)
        .map(|(e, w)| {
            smooth += (w - smooth) * (g.dt_s / 10.0);
            e + 0.006 * swing * smooth
        })
        .collect();
    let d = diagnose(&Series::new(g.dt_s, g.force_g, strain, vec![]).unwrap());
    check(&d, "baseline_drift");
    assert_eq!(d.effects, [Effect::BaselineDrift], "{}", d.summary);
}

/// A drift that turns inside a held-out block: the drift basis cannot interpolate it from the
/// blocks around it, and a force-driven term that follows the force's slow course won there
/// (seeds 66, 80, 87: drift then hysteresis or a sagging gain; seed 46: then stiffening), until
/// later effects were judged on each block less its own offset and slope.
#[test]
fn a_drift_that_turns_inside_a_block_is_named_alone() {
    for (seed, rate, length, a) in [
        (66, 50.0, 300.0, 0.06),
        (80, 50.0, 300.0, 0.06),
        (87, 50.0, 300.0, 0.06),
        (46, 200.0, 180.0, 0.02),
    ] {
        let d = diag(seed, rate, length, &[SynthEffect::Drift(a)]);
        check(&d, "baseline_drift");
        assert_eq!(d.effects, [Effect::BaselineDrift], "{}", d.summary);
    }
}

/// A zero that swings every 1–3 min on a record of 10–25 min: held-out blocks of a tenth of the
/// record (60–150 s) hold a whole turn of it, which no drift basis interpolates from the blocks
/// around, and the records were left `unexplained`. Judged again on blocks of at most 45 s.
#[test]
fn a_zero_that_swings_every_few_minutes_on_a_long_record_is_named() {
    for (seed, rate, length, a) in [
        (24, 25.0, 900.0, 0.05),
        (41, 50.0, 900.0, 0.05),
        (42, 25.0, 900.0, 0.05),
        (92, 100.0, 1200.0, 0.05),
        (21, 40.0, 600.0, 0.05),
        (22, 25.0, 1500.0, 0.03),
    ] {
        let d = diag(seed, rate, length, &[SynthEffect::Drift(a)]);
        check(&d, "baseline_drift");
        assert_eq!(d.effects, [Effect::BaselineDrift], "{}", d.summary);
        assert!(
            length / d.folds.len() as f64 <= 45.0 * 1.01,
            "{} folds: {}",
            d.folds.len(),
            d.summary
        );
        // And the report says why the folds are short, and how many the first pass had.
        assert!(
            d.first_folds.is_some_and(|k| k < d.folds.len())
                && d.summary.contains("judged again on blocks of at most 45 s"),
            "{:?}: {}",
            d.first_folds,
            d.summary
        );
    }
    // A clean long record is still `none` on its usual blocks, and a 60 s mode on a 900 s
    // record still `slow_relaxation`: short blocks are tried only where nothing is named.
    let d = diag(21, 25.0, 900.0, &[]);
    check(&d, "none");
    assert_eq!(d.folds.len(), 10);
    assert_eq!(d.first_folds, None);
    let d = diag(
        22,
        25.0,
        900.0,
        &[SynthEffect::SlowRelaxation {
            share: 0.3,
            tau_s: 60.0,
        }],
    );
    check(&d, "slow_relaxation");
}

#[test]
fn interference_off_the_mains_is_found_at_its_frequency() {
    for (seed, hz) in [(8, 13.7), (9, 37.0)] {
        let d = diag(
            seed,
            200.0,
            240.0,
            &[SynthEffect::Interference {
                amplitude: 0.01,
                hz,
            }],
        );
        check(&d, "periodic_interference");
        assert!((size(&d, "hz") - hz).abs() < 0.02, "{}", d.summary);
    }
}

/// Delays of two to five samples. Two samples at 200 Hz (10 ms) is what a baseline's 10 ms
/// branch nearly absorbs: only the ramps' corners tell them apart, and the force estimate must
/// keep them (a short-time Wiener filter). Seeds 41 and 45 were missed with one filter for the
/// whole record; 52 and 74 while the folds were compared on their raw errors: the delayed model
/// passes more of the force's noise than a baseline that smooths, and lost the quiet folds by it
/// (p 0.053–0.12 with 38–66 % of the excess removed).
#[test]
fn delays_of_whole_samples_are_found() {
    for (seed, rate, samples, length) in [
        (9, 200.0, 4, 120.0),
        (13, 50.0, 2, 120.0),
        (24, 20.0, 2, 120.0),
        (23, 200.0, 5, 120.0),
        (21, 200.0, 2, 120.0),
        (41, 200.0, 2, 180.0),
        (45, 200.0, 2, 180.0),
        (52, 200.0, 2, 180.0),
        (74, 200.0, 2, 180.0),
        (30, 500.0, 7, 120.0),
    ] {
        let d = diag(seed, rate, length, &[SynthEffect::Delay(samples)]);
        check(&d, "time_delay");
        // What a delay named right leaves is the force's noise through the model: not reported.
        assert_eq!(verdict(&d), "verdict: found time_delay", "{}", d.summary);
        assert!(d.unexplained.is_none());
        let ms = size(&d, "delay_ms");
        let true_ms = samples as f64 * 1e3 / rate;
        // Within a tenth: refined to a twenty-fourth of an octave and the nearest whole sample
        // (a sixth of an octave named 15 ms 14.1 and left more of it).
        assert!(
            ms > 0.9 * true_ms && ms < 1.1 * true_ms,
            "{ms} ms for {true_ms} ms"
        );
    }
}

/// A slow sensor's lag: 0.2–0.9 s at 20–500 Hz, searched to 1 s. The size within a sample:
/// the doubling search is refined to whole samples, and the delayed model has the grid's
/// fast branches that the undelayed fit's support left out (without them, 500 ms at 200 Hz
/// was named 516 ms and left 38 noise floors).
#[test]
fn delays_of_tenths_of_a_second_are_found_within_a_sample() {
    for (seed, rate, samples, length) in [
        (21, 100.0, 20, 180.0),
        (22, 50.0, 25, 180.0),
        (23, 20.0, 18, 180.0),
        (24, 200.0, 100, 120.0),
        (25, 100.0, 90, 240.0),
        (26, 500.0, 250, 120.0),
    ] {
        let d = diag(seed, rate, length, &[SynthEffect::Delay(samples)]);
        check(&d, "time_delay");
        let ms = size(&d, "delay_ms");
        let true_ms = samples as f64 * 1e3 / rate;
        assert!(
            (ms - true_ms).abs() <= 1e3 / rate,
            "seed {seed}: {ms} ms for {true_ms} ms: {}",
            d.summary
        );
    }
}

#[test]
fn a_slow_relaxation_is_found_with_its_time_constant() {
    let d = diag(
        10,
        200.0,
        240.0,
        &[SynthEffect::SlowRelaxation {
            share: 0.3,
            tau_s: 40.0,
        }],
    );
    check(&d, "slow_relaxation");
    let tau = size(&d, "tau_s");
    assert!((20.0..80.0).contains(&tau), "{tau}");
}

/// The memo's own finger (eq. 14: the creep levels off with N₁/α of 300–3 000 s) on records
/// to 30 min: the baseline's, not an effect (eq. 11's permanent creep alone left it to the slow
/// relaxation or the drift on records of 10 min and more). Where the record spans N₁/α, the
/// baseline reports it within a fifth.
#[test]
fn the_memos_levelling_creep_is_the_baselines_at_any_length() {
    // (seed, rate Hz, length s, N₁/α s, creep rate × the elastic compliance per s: the memo's
    // element 4,2 has 1/N₁ ÷ 1/G₁ ≈ 6·10⁻⁴)
    for (seed, rate, length, tau, rate_per_s) in [
        (1, 100.0, 600.0, 400.0, 6.7e-4),
        (2, 25.0, 900.0, 800.0, 6.7e-4),
        (3, 100.0, 1200.0, 1340.0, 6.7e-4),
        (12, 50.0, 1800.0, 600.0, 1e-3),
        (13, 40.0, 1800.0, 3000.0, 4e-4),
        (14, 100.0, 300.0, 300.0, 6.7e-4),
    ] {
        let d = diag(
            seed,
            rate,
            length,
            &[SynthEffect::Eq14Creep {
                tau_s: tau,
                rate_per_s,
            }],
        );
        check(&d, "none");
        if length >= tau {
            let (found, _) = d.baseline.alpha_branch.expect("eq. 14's branch");
            assert!((found / tau - 1.0).abs() < 0.2, "{found} s for {tau} s");
        }
    }
}

/// Beside the memo's levelling creep, a genuine extra relaxation (a Kelvin mode of 20–120 s with
/// a tenth of the elastic compliance or more) is still named, and a wandering zero still a drift.
#[test]
fn beside_the_memos_creep_a_slow_mode_and_a_drift_are_still_named() {
    let creep = SynthEffect::Eq14Creep {
        tau_s: 800.0,
        rate_per_s: 6.7e-4,
    };
    for (seed, share, tau_s) in [(21, 0.15, 60.0), (22, 0.3, 120.0), (23, 0.1, 30.0)] {
        let d = diag(
            seed,
            100.0,
            600.0,
            &[creep, SynthEffect::SlowRelaxation { share, tau_s }],
        );
        check(&d, "slow_relaxation");
    }
    for (seed, rate, a) in [(24, 100.0, 0.05), (26, 100.0, 0.05), (27, 50.0, 0.03)] {
        let d = diag(seed, rate, 600.0, &[creep, SynthEffect::Drift(a)]);
        check(&d, "baseline_drift");
    }
}

/// The verdict line of a diagnosis.
fn verdict(d: &Diagnosis) -> &str {
    d.summary
        .lines()
        .find(|l| l.starts_with("verdict:"))
        .unwrap_or("")
}

#[test]
fn hysteresis_and_a_sagging_sensitivity_are_found() {
    // The generator's Duhem loop is fitted to the floor's order by the Duhem operators (1.6
    // floors on this seed), and nothing is said to be left.
    let d = diag(6, 200.0, 240.0, &[SynthEffect::Hysteresis(0.05)]);
    check(&d, "hysteresis");
    let floors = d.after.held_out_rms_pct / d.noise_floor_pct;
    assert!(
        floors < 3.0 && d.unexplained.is_none(),
        "{floors:.1}\n{}",
        d.summary
    );
    // A loop that the force's jumps throw across (an Euler step of the same loop, one per
    // sample: b·|dσ| near 1 where a burst ends mid-swing), outside the vocabulary: named
    // hysteresis, and what it leaves (5.4 floors, far from white, at the slow end) is said
    // beside the name, not hidden behind it.
    let g = generate(&Spec {
        seed: 6,
        rate_hz: 200.0,
        duration_s: 240.0,
        effects: vec![],
    });
    let peak_pct = g.strain_pct.iter().fold(0.0f64, |a, b| a.max(*b));
    let b = 1.0 / 15.0;
    let a = 0.05 * peak_pct * b / 2.0;
    let (mut z, mut prev) = (0.0, 0.0);
    let e: Vec<f64> = g
        .strain_pct
        .iter()
        .zip(&g.true_force_g)
        .map(|(e, f)| {
            let df = f - prev;
            prev = *f;
            z += -a * df - b * df.abs() * z;
            e + z
        })
        .collect();
    let d = diagnose(&Series::new(g.dt_s, g.force_g, e, vec![]).unwrap());
    check(&d, "hysteresis");
    let line = verdict(&d);
    assert!(
        line.starts_with(
            "verdict: found hysteresis; after hysteresis, the residual is still far from white"
        ) && line.ends_with("× the noise floor)")
            && d.unexplained.is_some(),
        "{}",
        d.summary
    );
    let d = diag(11, 200.0, 240.0, &[SynthEffect::SensitivityDrift(0.1)]);
    check(&d, "sensitivity_drift");
    assert!(
        (5.0..15.0).contains(&size(&d, "gain_change_pct")),
        "{}",
        d.summary
    );
}

/// Records that an earlier version named wrong, found by running the sweep on seeds it had not
/// seen (`SEEDS="41 42 43 44 45 46" scripts/sweep-synth.sh`): a play wider than half the range
/// (a step only the first fold sees), a gain that sags on a finger whose slowest mode the first
/// fit left out, a slow relaxation the drift basis ties with, and a drift that wanders faster than
/// eight half-cosines follow.
#[test]
fn effects_on_seeds_the_design_was_not_tuned_on() {
    let d = diag(41, 200.0, 180.0, &[SynthEffect::Hysteresis(0.03)]);
    check(&d, "hysteresis");
    // No fold extrapolates the plays (the first, with the first loading, was 5× worse).
    let pairs = || d.after.fold_rms_pct.iter().zip(&d.before.fold_rms_pct);
    assert!(pairs().all(|(a, b)| *a < 1.2 * b), "{}", d.summary);
    assert!(pairs().filter(|(a, b)| a < b).count() >= 8, "{}", d.summary);
    for seed in [45, 46] {
        let d = diag(seed, 100.0, 240.0, &[SynthEffect::SensitivityDrift(0.15)]);
        check(&d, "sensitivity_drift");
        assert_eq!(d.effects.len(), 1, "{}", d.summary);
    }
    // The drift basis holds out a hair better on every fold (p < 0.05), not by an effect's
    // margin: the simpler slow relaxation is named.
    let d = diag(
        54,
        200.0,
        300.0,
        &[SynthEffect::SlowRelaxation {
            share: 0.2,
            tau_s: 60.0,
        }],
    );
    check(&d, "slow_relaxation");
    check(
        &diag(44, 50.0, 300.0, &[SynthEffect::Drift(0.06)]),
        "baseline_drift",
    );
}

/// A slow mode pulls the baseline's eq. 14 branch toward itself (N₁/α at the range's 300 s); the
/// slow relaxation's try refits that branch beside the mode, and the baseline's goes to zero. An
/// effect's size is what it adds to the model's columns in use, net: counted by its own columns
/// alone, the branch moved made the mode look bigger than a drift of two half-cosines, and the
/// drift was named (seed 24). On seed 53 the drift basis fails one fold of six by 6× and ties
/// the others: Student's t over the folds, widened by that fold, did not let the slow
/// relaxation beat it head to head.
#[test]
fn a_slow_mode_that_moves_the_creep_is_not_named_a_drift() {
    for seed in [24, 21, 41, 43, 53] {
        let d = diag(
            seed,
            100.0,
            240.0,
            &[SynthEffect::SlowRelaxation {
                share: 0.4,
                tau_s: 30.0,
            }],
        );
        check(&d, "slow_relaxation");
    }
}

/// Two effects in one record: both are named, whichever comes first (the pairs the sweep's
/// `PAIRS=1` runs name right on these seeds; it lists the pairs that are not yet).
#[test]
fn two_effects_at_once_are_both_named() {
    let interference = |amplitude, hz| SynthEffect::Interference { amplitude, hz };
    let slow_mode = SynthEffect::SlowRelaxation {
        share: 0.3,
        tau_s: 60.0,
    };
    // (seeds, rate Hz, length s, the effects, their names)
    type Case = (
        &'static [u64],
        f64,
        f64,
        [SynthEffect; 2],
        [&'static str; 2],
    );
    let cases: [Case; 14] = [
        // The stiffening found first leaves its basis's misfit beside the delay's part; the
        // delay is tried with the stiffening rebuilt through the delayed fit's branches (the
        // undelayed fit had put its weight on branches of about the lag).
        (
            &[31, 32, 33],
            100.0,
            180.0,
            [SynthEffect::Delay(3), SynthEffect::Stiffening(0.5)],
            ["time_delay", "load_dependent_stiffness"],
        ),
        (
            &[33, 34],
            200.0,
            180.0,
            [SynthEffect::Delay(3), SynthEffect::Hysteresis(0.05)],
            ["time_delay", "hysteresis"],
        ),
        // A temperature cycle: the gain ±3 % and the zero ±½ % of the peak strain with a 10 min
        // period, over 19 min at 40 Hz.
        (
            &[31, 32, 33],
            40.0,
            1140.0,
            [
                SynthEffect::GainCycle {
                    amplitude: 0.03,
                    period_s: 600.0,
                },
                SynthEffect::ZeroCycle {
                    amplitude: 0.005,
                    period_s: 600.0,
                },
            ],
            ["sensitivity_drift", "baseline_drift"],
        ),
        // A gain that sags beside a zero that settles and swings (every 60–200 s): on 8–10 min
        // the zero turns inside a held-out block, and the gain's basis, accepted first, takes
        // its settling wherever the load holds. After a gain alone the drift is judged by
        // block, against each block's own gain line too.
        (
            &[23, 42, 92],
            40.0,
            600.0,
            [SynthEffect::SensitivityDrift(0.1), SynthEffect::Drift(0.03)],
            ["sensitivity_drift", "baseline_drift"],
        ),
        (
            &[32],
            40.0,
            480.0,
            [SynthEffect::SensitivityDrift(0.1), SynthEffect::Drift(0.03)],
            ["sensitivity_drift", "baseline_drift"],
        ),
        (
            &[23],
            100.0,
            600.0,
            [SynthEffect::SensitivityDrift(0.1), SynthEffect::Drift(0.03)],
            ["sensitivity_drift", "baseline_drift"],
        ),
        // A delay under a loop: the delayed model passes twice the force's noise of the
        // undelayed one, and its error was judged above the undelayed one's floor (the delay
        // took 43 % of an excess half of which was that noise).
        (
            &[21, 93],
            200.0,
            180.0,
            [SynthEffect::Delay(3), SynthEffect::Hysteresis(0.05)],
            ["time_delay", "hysteresis"],
        ),
        // Seed 105: a gain's quartic in time held out 14 % better than the drift's half-cosines
        // and was named; a gain must now beat the drift as an effect beats the model without it.
        (
            &[105, 21],
            200.0,
            180.0,
            [SynthEffect::Hysteresis(0.05), SynthEffect::Drift(0.04)],
            ["hysteresis", "baseline_drift"],
        ),
        // Seed 92 (never run while the design was made): the drift was named, the plays
        // accepted with it as each block's nuisance, then the drift dropped by a removal check
        // that judged it without one.
        (
            &[92, 23],
            100.0,
            240.0,
            [SynthEffect::Hysteresis(0.08), SynthEffect::Drift(0.06)],
            ["hysteresis", "baseline_drift"],
        ),
        (
            &[22],
            200.0,
            180.0,
            [SynthEffect::Stiffening(0.5), SynthEffect::Drift(0.04)],
            ["load_dependent_stiffness", "baseline_drift"],
        ),
        (
            &[24],
            1000.0,
            120.0,
            [interference(0.01, 123.0), SynthEffect::Stiffening(0.5)],
            ["periodic_interference", "load_dependent_stiffness"],
        ),
        (
            &[21],
            100.0,
            240.0,
            [SynthEffect::SensitivityDrift(0.1), interference(0.01, 17.3)],
            ["sensitivity_drift", "periodic_interference"],
        ),
        // Seeds 42 and 91: the plays left so much of the generator's Duhem loop (which forgets
        // under small reversals) that the slow mode beside it was not seen; Duhem operators
        // leave a quarter of it. Seed 92: the mode was named a drift of two half-cosines, the
        // "simpler" effect, while its refitted eq. 14 branch counted as a column of its own.
        (
            &[24, 42, 91, 92],
            200.0,
            300.0,
            [slow_mode, SynthEffect::Hysteresis(0.05)],
            ["slow_relaxation", "hysteresis"],
        ),
        // The delay replaces the slow branches found first with their delayed copies: they
        // stay the slow relaxation's (were dropped as "explained by the later effects" when
        // the effect still held the undelayed ones).
        (
            &[21],
            200.0,
            300.0,
            [SynthEffect::Delay(3), slow_mode],
            ["time_delay", "slow_relaxation"],
        ),
    ];
    for (seeds, rate, length, effects, names) in cases {
        for &seed in seeds {
            let d = diag(seed, rate, length, &effects);
            let mut named: Vec<String> = d.effects.iter().map(|e| e.name().to_string()).collect();
            named.sort();
            let mut expected = names.map(String::from).to_vec();
            expected.sort();
            assert_eq!(named, expected, "seed {seed}: {}", d.summary);
            assert!(
                d.after.held_out_rms_pct < d.before.held_out_rms_pct,
                "{}",
                d.summary
            );
        }
    }
}

/// The same sagging gain with no zero beside it: no drift is named beside the gain, though the
/// drift is judged by block against each block's own gain line after it.
#[test]
fn a_sagging_gain_alone_gets_no_drift_beside_it() {
    for (seed, rate, length) in [
        (23, 40.0, 600.0),
        (42, 40.0, 600.0),
        (92, 40.0, 600.0),
        (32, 40.0, 480.0),
        (23, 100.0, 600.0),
    ] {
        let d = diag(seed, rate, length, &[SynthEffect::SensitivityDrift(0.1)]);
        assert_eq!(
            d.effects,
            [Effect::SensitivityDrift],
            "seed {seed}, {rate} Hz, {length} s: {}",
            d.summary
        );
    }
}

/// What a stiffening's basis leaves of each mode's own law is no second effect: rebuilt
/// through other branches, undelayed, it held out as well as delayed by a sample, and a delay
/// is judged against that basis.
#[test]
fn a_stiffening_alone_gets_no_delay_beside_it() {
    for (seed, rate, length, strength) in [
        (22, 100.0, 240.0, 0.8),
        (41, 100.0, 240.0, 0.8),
        (45, 200.0, 180.0, 0.3),
        (88, 200.0, 180.0, 0.3),
    ] {
        let d = diag(seed, rate, length, &[SynthEffect::Stiffening(strength)]);
        assert_eq!(
            d.effects,
            [Effect::LoadDependentStiffness],
            "seed {seed}: {}",
            d.summary
        );
    }
}

/// A gain that swings with the temperature over minutes is named with its size, and a sag
/// over the record still by a polynomial.
#[test]
fn a_gain_that_cycles_is_named_with_its_swing() {
    for seed in [51, 52] {
        let d = diag(
            seed,
            40.0,
            900.0,
            &[SynthEffect::GainCycle {
                amplitude: 0.04,
                period_s: 400.0,
            }],
        );
        assert_eq!(d.effects, [Effect::SensitivityDrift], "{}", d.summary);
        // ±4 %: a swing of 8 % peak to peak, read from the fitted gain within a fifth.
        let swing = size(&d, "gain_change_pct");
        assert!((swing - 8.0).abs() < 1.6, "seed {seed}: {swing} %");
    }
}

/// Another unit for either column does not move the verdict or the strain errors.
#[test]
fn scaling_a_column_keeps_the_verdict() {
    let g = generate(&Spec {
        seed: 6,
        rate_hz: 200.0,
        duration_s: 240.0,
        effects: vec![SynthEffect::Hysteresis(0.05)],
    });
    let base =
        diagnose(&Series::new(g.dt_s, g.force_g.clone(), g.strain_pct.clone(), vec![]).unwrap());
    for (kf, ke) in [(10.0, 0.1), (0.1, 1.0), (1.0, 30.0)] {
        let f: Vec<f64> = g.force_g.iter().map(|v| v * kf).collect();
        let e: Vec<f64> = g.strain_pct.iter().map(|v| v * ke).collect();
        let d = diagnose(&Series::new(g.dt_s, f, e, vec![]).unwrap());
        assert_eq!(d.effects, base.effects, "×{kf}, ×{ke}: {}", d.summary);
        let ratio = d.after.held_out_rms_pct / base.after.held_out_rms_pct;
        assert!((ratio / ke - 1.0).abs() < 0.02, "×{kf}, ×{ke}: {ratio}");
    }
}

/// A load cell not tared: the force read 300 g high on a record that swings about 80 g. From
/// zero, the load basis over so narrow a band far from it is nearly linear in the load: seeds 23
/// and 24 (and 25) of a strong stiffening at 100 Hz were read `none`, and an outside finger's
/// Hertzian contact was named hysteresis. Measured from the record's lowest load, 15 of 16 of
/// seeds 21–28 at two strengths are named alone (seed 25 with a drift). A strain offset is the
/// baseline's own offset term.
#[test]
fn an_untared_force_keeps_the_verdict() {
    for (seed, strength, rate, length) in [
        (21, 0.3, 200.0, 180.0),
        (23, 0.8, 100.0, 240.0),
        (24, 0.8, 100.0, 240.0),
    ] {
        let g = generate(&Spec {
            seed,
            rate_hz: rate,
            duration_s: length,
            effects: vec![SynthEffect::Stiffening(strength)],
        });
        let f: Vec<f64> = g.force_g.iter().map(|v| v + 300.0).collect();
        let e: Vec<f64> = g.strain_pct.iter().map(|v| v - 40.0).collect();
        let d = diagnose(&Series::new(g.dt_s, f, e, vec![]).unwrap());
        check(&d, "load_dependent_stiffness");
        assert_eq!(d.effects.len(), 1, "{}", d.summary);
        assert!(d.model.force_origin_g > 250.0, "{}", d.model.force_origin_g);
        // On a tared record the basis is measured from zero, as before.
        let tared = diagnose(&Series::new(g.dt_s, g.force_g, g.strain_pct, vec![]).unwrap());
        assert_eq!(tared.model.force_origin_g, 0.0);
        check(&tared, "load_dependent_stiffness");
    }
}

#[test]
fn a_sensitivity_that_settles_is_named_alone() {
    // A gain that sags by 10 % toward a settled value, τ a third of the record (95 % of the sag
    // by the end: 9.5 % over the record), not the generator's line: a line and a parabola left
    // a bend the drift basis then took ("sensitivity_drift, then baseline_drift").
    for seed in [1, 5, 11, 17] {
        let g = generate(&Spec {
            seed,
            rate_hz: 200.0,
            duration_s: 240.0,
            effects: vec![],
        });
        let t_end = g.dt_s * g.strain_pct.len() as f64;
        let e: Vec<f64> = g
            .strain_pct
            .iter()
            .enumerate()
            .map(|(i, e)| e * (1.0 - 0.1 * (1.0 - (-(i as f64 * g.dt_s) / (t_end / 3.0)).exp())))
            .collect();
        let d = diagnose(&Series::new(g.dt_s, g.force_g, e, vec![]).unwrap());
        check(&d, "sensitivity_drift");
        assert_eq!(d.effects.len(), 1, "seed {seed}: {}", d.summary);
        assert!(
            (8.0..11.5).contains(&size(&d, "gain_change_pct")),
            "seed {seed}: {}",
            d.summary
        );
    }
}

#[test]
fn a_loop_that_forgets_is_fitted_by_duhem_operators_and_undone_by_plays() {
    // The generator's loop is Duhem's (dz = a·dσ − b·|dσ|·z): every movement draws it toward
    // its side, so small reversals wear it down, which no set of plays does. The plays left
    // 12.6 noise floors of it on seed 6; Duhem operators on the force seen through a deadband
    // of its noise leave under 3 on every seed (1.4–2.1). The chip still undoes the loop with
    // plays: its model has plays where the named one has Duhem operators.
    for (seed, rate, length) in [
        (6, 200.0, 240.0),
        (11, 200.0, 240.0),
        (21, 100.0, 240.0),
        (31, 500.0, 120.0),
    ] {
        let d = diag(seed, rate, length, &[SynthEffect::Hysteresis(0.05)]);
        check(&d, "hysteresis");
        let accepted = d.candidates.iter().find(|c| c.accepted).unwrap();
        assert!(
            accepted.variant.starts_with("Duhem operators"),
            "{}",
            d.summary
        );
        let floors = d.after.held_out_rms_pct / d.noise_floor_pct;
        assert!(
            floors < 3.0,
            "seed {seed}: {floors:.1} floors\n{}",
            d.summary
        );
        let has = |terms: &[(tactile_ident::diagnose::Term, f64)], name: &str| {
            terms.iter().any(|t| format!("{:?}", t.0).starts_with(name))
        };
        assert!(has(&d.model.terms, "Duhem"));
        assert!(has(&d.model.chip_terms, "Play"), "{:?}", d.model.chip_terms);
        assert!(!has(&d.model.chip_terms, "Duhem"));
        assert_eq!(d.model.chip_fold_terms.len(), d.folds.len());
        assert!(size(&d, "play_width_g") > 0.0, "{}", d.summary);
    }
}
