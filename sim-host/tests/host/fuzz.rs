//! Bounded fuzzing of the host parsers: no input panics, and every refusal says where.

use std::path::Path;

use sim_host::cli::apply_effect;
use sim_host::finger::Effects;
use sim_host::fit::Base;
use sim_host::fuzz::{load_corpus, run};
use sim_host::record::parse_record;

fn corpus(name: &str) -> Vec<Vec<u8>> {
    load_corpus(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fuzz/corpus")
            .join(name),
    )
    .unwrap()
}

#[test]
fn the_record_reader_never_panics_and_names_the_place() {
    let corpus = corpus("record");
    let mut refused = 0usize;
    let failure = run(0x5eed, &corpus, 20_000, |input| {
        if let Err(e) = parse_record(input, Path::new("fuzz.csv")) {
            refused += 1;
            // A refusal about a cell names its line and column.
            if e.message.contains("is not a number") || e.message.contains("is not finite") {
                assert!(e.line.is_some() && e.column.is_some(), "{e}");
            }
            assert!(e.to_string().starts_with("fuzz.csv"), "{e}");
        }
    });
    assert!(
        failure.is_none(),
        "panicked on {:?}",
        failure.map(|f| String::from_utf8_lossy(&f).into_owned())
    );
    // The mutations do reach the error paths.
    assert!(refused > 5_000, "{refused}");
}

#[test]
fn the_effect_and_model_parsers_never_panic() {
    let corpus = corpus("effect");
    let failure = run(0xeffec7, &corpus, 20_000, |input| {
        let text = String::from_utf8_lossy(input);
        let mut effects = Effects::MEMO;
        if let Err(message) = apply_effect(&mut effects, &text) {
            assert!(!message.is_empty());
        }
        let _ = Base::parse(&text);
        let _ = sim_host::cli::parse_fault(&text);
    });
    assert!(
        failure.is_none(),
        "panicked on {:?}",
        failure.map(|f| String::from_utf8_lossy(&f).into_owned())
    );
}

/// Mutated records through the whole diagnosis: a refusal with its reason or a verdict with
/// finite errors, never a panic and never NaN.
#[test]
fn mutated_records_get_a_reason_or_a_finite_diagnosis() {
    use tactile_core::tactile::TaxelId;
    let corpus = corpus("record");
    let (mut refused, mut diagnosed) = (0usize, 0usize);
    let failure = run(0xd1a9, &corpus, 5_000, |input| {
        let Ok(record) = parse_record(input, Path::new("fuzz.csv")) else {
            return;
        };
        match sim_host::chip_diagnosis::series_of(&record) {
            Err(reason) => {
                refused += 1;
                assert!(!reason.to_string().is_empty());
            }
            Ok(series) => {
                diagnosed += 1;
                let d = sim_host::chip_diagnosis::diagnose(&series, TaxelId::default()).diagnosis;
                assert!(d.before.held_out_rms_g.is_finite(), "{}", d.summary);
                assert!(d.after.held_out_rms_g.is_finite(), "{}", d.summary);
                assert!(!d.summary.contains("NaN"), "{}", d.summary);
            }
        }
    });
    assert!(
        failure.is_none(),
        "panicked on {:?}",
        failure.map(|f| String::from_utf8_lossy(&f).into_owned())
    );
    eprintln!("{refused} refused, {diagnosed} diagnosed");
    assert!(
        refused >= 10 && diagnosed >= 10,
        "{refused} refused, {diagnosed} diagnosed"
    );
}
