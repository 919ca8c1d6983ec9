//! A gain that sags beside a zero that settles and swings, on records of 8–10 min: both are
//! named, and a sag alone gets no drift beside it. The generator's zero swings with a period of
//! 60–200 s, so on a long record's 48–60 s blocks it turns inside a held-out block; the gain's
//! basis, accepted first, takes the zero's settling wherever the load holds.

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

/// (seed, rate Hz, length s) of records where the gain is found first.
const RECORDS: [(u64, f64, f64); 5] = [
    (23, 40.0, 600.0),
    (42, 40.0, 600.0),
    (92, 40.0, 600.0),
    (32, 40.0, 480.0),
    (23, 100.0, 600.0),
];

#[test]
fn a_gain_drift_beside_a_zero_drift_is_named_both() {
    for (seed, rate, length) in RECORDS {
        let d = diag(
            seed,
            rate,
            length,
            &[SynthEffect::SensitivityDrift(0.1), SynthEffect::Drift(0.03)],
        );
        let mut named = d.effects.clone();
        named.sort_by_key(|e| e.name());
        assert_eq!(
            named,
            [Effect::BaselineDrift, Effect::SensitivityDrift],
            "seed {seed}, {rate} Hz, {length} s: {}",
            d.summary
        );
        assert!(
            d.after.held_out_rms_pct < d.before.held_out_rms_pct,
            "{}",
            d.summary
        );
    }
}

#[test]
fn a_sagging_gain_alone_gets_no_drift_beside_it() {
    for (seed, rate, length) in RECORDS {
        let d = diag(seed, rate, length, &[SynthEffect::SensitivityDrift(0.1)]);
        assert_eq!(
            d.effects,
            [Effect::SensitivityDrift],
            "seed {seed}, {rate} Hz, {length} s: {}",
            d.summary
        );
    }
}
