//! A logger's record: values held when a read is missed (sample-and-hold dropouts) found, left
//! out, and said; the verdict the same as on the record without them.

use tactile_ident::synth::{generate, Spec, SynthEffect};
use tactile_ident::{diagnose, Series};

/// A reproducible uniform draw in [0, 1) (SplitMix64).
fn uniform(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

/// Holds runs of 5 to 50 repeats about every `every` samples (± a tenth) in the force, the
/// strain or both, by turns; returns the held samples (the repeats) as the truth.
fn drop_out(force: &mut [f64], strain: &mut [f64], seed: u64, every: usize) -> (Vec<bool>, usize) {
    let mut s = seed;
    let mut truth = vec![false; force.len()];
    let (mut a, mut runs) = (every / 2, 0);
    while a + 60 < force.len() {
        let repeats = 5 + (uniform(&mut s) * 46.0) as usize;
        for k in a + 1..=a + repeats {
            if runs % 3 != 1 {
                force[k] = force[a];
            }
            if runs % 3 != 0 {
                strain[k] = strain[a];
            }
            truth[k] = true;
        }
        runs += 1;
        a += every + ((uniform(&mut s) - 0.5) * every as f64 / 5.0) as usize;
    }
    (truth, runs)
}

#[test]
fn held_values_are_found_left_out_and_the_verdict_kept() {
    for (seed, rate_hz, duration_s, effects) in [
        (6, 800.0, 60.0, vec![]),
        (5, 800.0, 90.0, vec![SynthEffect::Stiffening(0.6)]),
        (9, 500.0, 60.0, vec![SynthEffect::Hysteresis(0.1)]),
    ] {
        let g = generate(&Spec {
            seed,
            rate_hz,
            duration_s,
            effects,
        });
        let clean = diagnose(
            &Series::new(g.dt_s, g.force_g.clone(), g.strain_pct.clone(), vec![]).unwrap(),
        );
        let (mut force, mut strain) = (g.force_g.clone(), g.strain_pct.clone());
        // About once a second.
        let (truth, runs) = drop_out(&mut force, &mut strain, seed, rate_hz as usize);
        let held_true = truth.iter().filter(|x| **x).count();
        let series = Series::logged(g.dt_s, force, strain, vec![], None).unwrap();
        let i = &series.intake;
        // Fine codes: every run of repeats is found, but where one lands on a value the
        // channel holds anyway (none here).
        assert!(
            i.held_samples.abs_diff(held_true) * 50 <= held_true,
            "{seed}: {i:?} of {held_true}"
        );
        assert!(
            i.held_runs.abs_diff(runs) <= 1,
            "{seed}: {i:?} of {runs} runs"
        );
        let missed = truth
            .iter()
            .zip(&series.excluded)
            .filter(|(t, x)| **t && !**x)
            .count();
        assert!(missed * 50 <= held_true, "{seed}: {missed} missed");
        let d = diagnose(&series);
        eprintln!(
            "seed {seed}: {held_true} held in {runs} runs, found {} in {}; verdict {} (clean {})",
            i.held_samples, i.held_runs, d.effect, clean.effect
        );
        assert_eq!(
            d.effect, clean.effect,
            "{seed}:\n{}\n{}",
            d.summary, clean.summary
        );
        let said = format!(
            "the logger repeated a value instead of reading for {} samples in {} runs",
            i.held_samples, i.held_runs
        );
        assert!(d.summary.contains(&said), "{}", d.summary);
        assert_eq!(d.intake.held_samples, i.held_samples);
        // Left out, the held values cost the fit little: held out within a tenth of the clean
        // record's (the share of samples lost is about 3 %).
        let ratio = d.after.held_out_rms_pct / clean.after.held_out_rms_pct;
        assert!(
            (0.9..1.1).contains(&ratio),
            "{seed}: {ratio}\n{}",
            d.summary
        );
        assert!(d.before.held_out_rms_pct.is_finite() && !d.summary.contains("NaN"));
    }
}

#[test]
fn a_clean_record_reports_no_held_values() {
    for seed in [1, 2, 3] {
        let g = generate(&Spec {
            seed,
            rate_hz: 800.0,
            duration_s: 30.0,
            effects: vec![],
        });
        // Also quantized, as a 16-bit converter would read it: codes of a thousandth of the
        // strain's range and 0.05 g of force.
        let q = |v: &[f64], step: f64| v.iter().map(|x| (x / step).round() * step).collect();
        let range = g.strain_pct.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for (force, strain) in [
            (g.force_g.clone(), g.strain_pct.clone()),
            (q(&g.force_g, 0.05), q(&g.strain_pct, range / 1000.0)),
        ] {
            let s = Series::logged(g.dt_s, force, strain, vec![], None).unwrap();
            assert_eq!(
                (s.intake.held_samples, s.intake.held_runs),
                (0, 0),
                "{seed}"
            );
            assert!(s.excluded.iter().all(|x| !x));
        }
    }
}
