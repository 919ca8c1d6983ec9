//! `tactile diagnose` on a record straight from a logger: time stamps that jitter, rows stamped
//! alike, values held when a read was missed. Each mended or left out, and said in the text and
//! the JSON; the verdict the same as on the record as the sensor gave it.

use sim_host::chip_diagnosis::{diagnose, series_of, Report};
use sim_host::record::{parse_record, read_record, Record};
use tactile_core::tactile::TaxelId;

fn run(r: &Record) -> Report {
    diagnose(&series_of(r).unwrap(), TaxelId::default())
}

/// A reproducible uniform draw in [0, 1) (SplitMix64).
fn uniform(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

/// `r` as a PC's logger writes it: each row read up to `late` of a step late (its values the
/// record's, interpolated, at that time), every 500th row written twice, and about once a
/// second the last values repeated for 5 to 50 rows.
fn logged(r: &Record, seed: u64, late: f64) -> (String, usize) {
    let (mut s, h) = (seed, r.sample_period_s().unwrap());
    let mut text = String::from("t_s,force_g,strain_pct\n");
    let (mut held, mut hold, mut last) = (0, 0, (0.0, 0.0));
    let every = (1.0 / h) as usize;
    for k in 0..r.len() - 1 {
        let u = late * uniform(&mut s);
        let at = |v: &[f64]| v[k] + u * (v[k + 1] - v[k]);
        let mut values = (at(&r.force_g), at(&r.strain_pct));
        if k > 0 && k % every == every / 2 {
            hold = 5 + (uniform(&mut s) * 46.0) as usize;
        }
        if hold > 0 {
            values = last;
            hold -= 1;
            held += 1;
        }
        last = values;
        let row = format!("{:.7},{:.4},{:.6}\n", r.t_s[k] + u * h, values.0, values.1);
        text.push_str(&row);
        if k % 500 == 250 {
            text.push_str(&row);
        }
    }
    (text, held)
}

#[test]
fn a_logged_record_is_mended_said_and_diagnosed_as_the_clean_one() {
    let dir = crate::common::shared_data();
    for (file, seed) in [("example_clean.csv", 3), ("example_stiffening.csv", 4)] {
        let clean = read_record(&dir.join(file)).unwrap();
        let (text, held) = logged(&clean, seed, 0.8);
        let r = parse_record(text.as_bytes(), std::path::Path::new(file)).unwrap();
        let d = run(&r);
        let (c, g) = (run(&clean).diagnosis, &d.diagnosis);
        assert_eq!(g.effect, c.effect, "{file}:\n{}", g.summary);
        let i = &g.intake;
        let rs = i.resampling.clone().unwrap();
        assert!((0.7..0.82).contains(&rs.jitter_share), "{rs:?}");
        assert_eq!(rs.merged_duplicates, (clean.len() - 1 + 249) / 500);
        // Resampling moves a row by up to a step: the held runs' edges by one sample each.
        assert!(
            i.held_samples.abs_diff(held) <= 2 * i.held_runs + held / 50,
            "{i:?} {held}"
        );
        for said in [
            format!(
                "the time stamps jitter by {:.0} % of the step",
                100.0 * rs.jitter_share
            ),
            format!(
                "{} rows stamped with the time of the row before",
                rs.merged_duplicates
            ),
            format!(
                "the logger repeated a value instead of reading for {}",
                i.held_samples
            ),
        ] {
            assert!(g.summary.contains(&said), "{said}\n{}", g.summary);
        }
        let json = serde_json::to_value(&d).unwrap();
        let share = json["intake"]["resampling"]["jitter_share"]
            .as_f64()
            .unwrap();
        assert_eq!(share, rs.jitter_share);
        assert_eq!(
            json["intake"]["held_samples"].as_u64(),
            Some(i.held_samples as u64)
        );
        eprintln!(
            "{file}: jitter {:.3}, {} merged, held {} of {held} in {} runs; {} ({} clean); \
             held out {:.3} g ({:.3} clean)",
            rs.jitter_share,
            rs.merged_duplicates,
            i.held_samples,
            i.held_runs,
            g.effect,
            c.effect,
            g.after.held_out_rms_g,
            c.after.held_out_rms_g
        );
    }
}

#[test]
fn the_shared_records_are_taken_in_as_written() {
    let dir = crate::common::shared_data();
    for file in [
        "example_clean.csv",
        "example_stiffening.csv",
        "real/fsi_skin_air.csv",
        "real/fsi_skin_oil.csv",
        "real/fsi_skin_water.csv",
    ] {
        let s = series_of(&read_record(&dir.join(file)).unwrap()).unwrap();
        assert_eq!(s.intake.resampling, None, "{file}");
        assert_eq!(
            (s.intake.held_samples, s.intake.held_runs),
            (0, 0),
            "{file}"
        );
    }
}
