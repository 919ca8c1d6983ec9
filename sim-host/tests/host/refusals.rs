//! The `tactile` command on records and tables it cannot use: each refused with its reason
//! (the same reason `tactile diagnose` gives), never a panic, never a NaN or an infinity
//! printed as a result, and nothing written that a later command would refuse.

use std::path::{Path, PathBuf};

use tactile_core::calibration::CalibrationTable;
use tactile_core::estimator::TaxelModel;
use tactile_core::tactile::TaxelId;

/// A fresh path for the refusals' files (tests run in parallel).
fn temp(name: &str) -> PathBuf {
    crate::common::scratch(&format!("refusals_{name}"))
}

/// A record `t_s,force_g,strain_pct` of `n` samples every `dt_s`, from `f(t)` = (force, strain).
fn record(name: &str, n: usize, dt_s: f64, f: impl Fn(f64) -> (f64, f64)) -> PathBuf {
    let mut text = String::from("t_s,force_g,strain_pct\n");
    for i in 0..n {
        let t = i as f64 * dt_s;
        let (force, strain) = f(t);
        text.push_str(&format!("{t},{force:e},{strain:e}\n"));
    }
    let path = temp(name);
    std::fs::write(&path, text).unwrap();
    path
}

use crate::common::tactile;

/// No number printed as NaN or an infinity.
fn all_finite(text: &str) -> bool {
    !(text.contains("NaN")
        || text.contains("inf ")
        || text.contains("inf\n")
        || text.contains("±inf"))
}

/// 20 s at 100 Hz of a linear spring (0.5 % per gram) under a force about zero, half of it a
/// pull.
fn about_zero(name: &str) -> PathBuf {
    record(name, 2000, 0.01, |t| {
        let f = -10.0 * (10.0 * t).sin();
        (f, 0.5 * f)
    })
}

fn arg(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn fit_refuses_a_record_diagnose_refuses_with_the_same_reason() {
    let constant = record("constant.csv", 2000, 0.01, |_| (5.0, 2.0));
    let zeros = record("zeros.csv", 2000, 0.01, |_| (0.0, 0.0));
    let huge = record("huge.csv", 2000, 0.01, |t| (1e30 * t.sin(), 1e30));
    for (path, why) in [
        (&constant, "the force does not vary"),
        (&zeros, "the force does not vary"),
        (&huge, "beyond any plausible value (|force_g| ≤ 1e7)"),
    ] {
        let (_, _, diagnosed) = tactile(["diagnose", arg(path)]);
        let reason = diagnosed
            .split("cannot be diagnosed: ")
            .nth(1)
            .unwrap_or_else(|| panic!("{diagnosed}"));
        assert!(reason.contains(why), "{diagnosed}");
        for model in ["mk-alpha", "elastic"] {
            let (code, stdout, stderr) = tactile(["fit", arg(path), "--model", model]);
            // 1, a run refused: not 101, a panic.
            assert_eq!(
                code,
                Some(1),
                "{model} {}: {stdout}{stderr}",
                path.display()
            );
            assert_eq!(
                stderr,
                format!("tactile: {}: cannot be fitted: {reason}", path.display()),
                "{model}"
            );
        }
    }
}

#[test]
fn fit_says_in_words_what_it_cannot_determine_or_hold_out() {
    // 20 s of a linear spring, the force about zero: eq. 14's dashpots run to their bounds,
    // and the record is too short for the fourth 10 s block, the first held out.
    let path = about_zero("short.csv");
    let json = temp("short-fit.json");
    let (code, stdout, stderr) = tactile(["fit", arg(&path), "--json", arg(&json)]);
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    assert!(all_finite(&stdout), "{stdout}");
    assert!(
        stdout
            .contains("RMS_n held out: none: the record (20.0 s) is too short to hold a block out")
            && stdout.contains("a whole one needs 40 s"),
        "{stdout}"
    );
    assert!(
        stdout.contains("± not determined (at the bound of its range, 1e7)"),
        "{stdout}"
    );
    let fit: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert!(fit["held_out_rms_g"].is_null(), "{fit}");
    assert!(
        fit["held_out"].as_str().unwrap().contains("too short"),
        "{fit}"
    );
    // N1 at its bound: no error; G1 determined.
    let se = fit["standard_error"].as_array().unwrap();
    assert!(se[1].is_null() && se[0].is_number(), "{fit}");
}

/// A table of the nominal model for the default taxel (3, 2), as bytes.
fn nominal_table() -> Vec<u8> {
    let mut t = CalibrationTable::default();
    t.taxels
        .push(TaxelModel::nominal(TaxelId::new(3, 2).unwrap()))
        .unwrap();
    let mut bytes = vec![0u8; t.encoded_len()];
    let n = t.encode(&mut bytes).unwrap();
    bytes.truncate(n);
    bytes
}

#[test]
fn estimate_refuses_an_absurd_record_and_a_table_that_would_run_away() {
    let table = temp("nominal.bin");
    std::fs::write(&table, nominal_table()).unwrap();
    let good = record("good.csv", 1000, 0.01, |t| {
        let f = 20.0 + 10.0 * (t).sin();
        (f, f / 3.0)
    });
    let out = temp("estimate.csv");
    let (code, stdout, stderr) = tactile([
        "estimate",
        arg(&good),
        "--table",
        arg(&table),
        "--out",
        arg(&out),
    ]);
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    assert!(all_finite(&stdout), "{stdout}");
    // Not over the record it reads (its columns past the estimates would be lost): a usage
    // error, the record untouched.
    let before = std::fs::read(&good).unwrap();
    let (code, _, stderr) = tactile([
        "estimate",
        arg(&good),
        "--table",
        arg(&table),
        "--out",
        arg(&good),
    ]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("which this command reads"), "{stderr}");
    assert_eq!(std::fs::read(&good).unwrap(), before);
    // Finite but absurd (a strain of 10²⁰⁰ %): diagnose's plausibility check.
    let huge = record("huge2.csv", 2000, 0.01, |t| (1e200 * t.sin(), 1e200));
    let absurd_out = temp("absurd-estimate.csv");
    let (code, stdout, stderr) = tactile([
        "estimate",
        arg(&huge),
        "--table",
        arg(&table),
        "--out",
        arg(&absurd_out),
    ]);
    assert_eq!(code, Some(1), "{stdout}{stderr}");
    assert!(
        stderr.contains(&format!("{}: cannot be estimated: ", huge.display()))
            && stderr.contains("beyond any plausible value (|force_g| ≤ 1e7)"),
        "{stderr}"
    );
    assert!(!absurd_out.exists());
    // The schedule's last entry's a₁ made −5 (the f32 at byte 120), the checksum mended:
    // the scheduled inverse would print an infinite error. The table's check names it.
    let mut bad = nominal_table();
    bad[120..124].copy_from_slice(&(-5.0f32).to_le_bytes());
    let n = bad.len();
    let crc = tactile_core::seal::crc32(&bad[..n - 4]);
    bad[n - 4..].copy_from_slice(&crc.to_le_bytes());
    let bad_table = temp("bad-schedule.bin");
    std::fs::write(&bad_table, bad).unwrap();
    let (code, stdout, stderr) = tactile([
        "estimate",
        arg(&good),
        "--table",
        arg(&bad_table),
        "--out",
        arg(&out),
    ]);
    assert_eq!(code, Some(1), "{stdout}{stderr}");
    assert!(
        stderr.contains("record 0: the schedule entry a1, a2, b0, b1, b2 cannot run"),
        "{stderr}"
    );
}

#[test]
fn diagnose_writes_no_table_when_there_is_nothing_to_export() {
    // A force about zero (half of it a pull): no model the chip's estimators can run.
    let path = about_zero("about-zero.csv");
    let table = temp("about-zero.bin");
    let (code, stdout, stderr) = tactile(["diagnose", arg(&path), "--table", arg(&table)]);
    assert!(stdout.contains("no calibration is exported"), "{stdout}");
    // A script that asked for a table learns from the exit code that there is none.
    assert_eq!(code, Some(1), "{stdout}{stderr}");
    assert!(
        stderr.contains(&format!("{}: not written", table.display())),
        "{stderr}"
    );
    assert!(!table.exists());
    // A table already at the path (an earlier record's) is left, and the refusal says it is
    // not this record's.
    std::fs::write(&table, b"an earlier table").unwrap();
    let (code, _, stderr) = tactile(["diagnose", arg(&path), "--table", arg(&table)]);
    assert_eq!(code, Some(1));
    assert!(
        stderr.contains("the file already there is not this record's"),
        "{stderr}"
    );
    assert_eq!(std::fs::read(&table).unwrap(), b"an earlier table");
}

/// `tactile experiment NAME --no-plot ARGS…` refused as a usage error (exit 2) before it wrote
/// anything: its stderr.
fn experiment_refused(name: &str, args: &[&str]) -> String {
    let out = temp(&format!("refused-{name}"));
    let head = ["experiment", name, "--no-plot", "--out", arg(&out)];
    let (code, stdout, stderr) = tactile(head.iter().chain(args));
    assert_eq!(code, Some(2), "{stdout}{stderr}");
    assert!(!out.exists(), "{}", out.display());
    stderr
}

#[test]
fn a_fault_after_the_run_ends_is_a_usage_error() {
    // `step` runs 77 s (2 s lead, 50 s on, 25 s off): a fault at 100 s would never happen.
    let stderr = experiment_refused("step", &["--fault", "gauge-stuck@100"]);
    assert!(stderr.contains("`step` ends at 77 s"), "{stderr}");
}

#[test]
fn calibrate_refuses_a_dead_strain_channel_as_diagnose_does() {
    // The force moves, the strain reads zero throughout: before, only flagged `poor`, and the
    // table written from it estimated thousands of grams off.
    let dead = record("dead-strain.csv", 2000, 0.01, |t| {
        (20.0 + 10.0 * t.sin(), 0.0)
    });
    let table = temp("dead-strain.bin");
    let (code, stdout, stderr) = tactile([
        "calibrate",
        &format!("3,2={}", arg(&dead)),
        "--out",
        arg(&table),
    ]);
    assert_eq!(code, Some(1), "{stdout}{stderr}");
    assert!(
        stderr.contains(&format!(
            "{}: cannot be calibrated: the strain does not vary",
            dead.display()
        )),
        "{stderr}"
    );
    assert!(!table.exists());
}

#[test]
fn an_experiment_refuses_a_record_rate_the_loop_cannot_keep_and_a_run_too_short() {
    // 1000/143 = 6.993 Hz and 1000/142 = 7.042 Hz: 7 Hz is neither.
    let stderr = experiment_refused("step", &["--record-hz", "7"]);
    assert!(
        stderr.contains("7.042 Hz (k = 142) or 6.993 Hz (k = 143)"),
        "{stderr}"
    );
    let stderr = experiment_refused("pseudo-random", &["--duration", "0.001"]);
    assert!(
        stderr.contains("--duration 0.001: must be in [1, 3600] s"),
        "{stderr}"
    );
}

/// Every command that writes a file claims it before its work: a path it cannot write is said
/// at once (nothing of the work printed), missing folders are made, and the file it claimed is
/// not left behind when the run stops.
#[test]
fn a_path_that_cannot_be_written_is_refused_before_the_work() {
    let rec = record("claims.csv", 2000, 0.01, |t| {
        let f = 20.0 + 10.0 * (t).sin();
        (f, f / 3.0)
    });
    let table = temp("claims-table.bin");
    std::fs::write(&table, nominal_table()).unwrap();
    // A file where a folder would have to be: nothing can be written under it.
    let blocker = temp("claims-blocker");
    std::fs::write(&blocker, b"a file, not a folder").unwrap();
    let bad = blocker.join("out.bin");
    let memo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../applicators/memo.toml");
    let commands: Vec<Vec<&str>> = vec![
        vec!["fit", arg(&rec), "--json", arg(&bad)],
        vec!["diagnose", arg(&rec), "--json", arg(&bad)],
        vec!["diagnose", arg(&rec), "--table", arg(&bad)],
        vec!["diagnose", arg(&rec), "--report", arg(&bad)],
        vec!["identify", arg(&rec), "--json", arg(&bad)],
        vec![
            "estimate",
            arg(&rec),
            "--table",
            arg(&table),
            "--out",
            arg(&bad),
        ],
        vec!["applicator", arg(&memo), "--out", arg(&bad)],
        // The long ones: an identification and design, four taxels calibrated, the memo's
        // tables and the estimators' comparison (minutes), had they not stopped first.
        vec!["design", "--table", arg(&bad)],
        vec!["calibrate", "--out", arg(&bad)],
        vec!["tables", "--out", arg(&bad)],
        vec!["estimators", "--out", arg(&bad)],
    ];
    for args in &commands {
        let (code, stdout, stderr) = tactile(args);
        assert_eq!(code, Some(1), "{args:?}: {stdout}{stderr}");
        assert!(stdout.is_empty(), "{args:?} worked first: {stdout}");
        assert!(
            stderr.contains(&blocker.display().to_string()),
            "{args:?}: {stderr}"
        );
    }
    // Missing folders are made (fit's --json was written only where its folder was).
    let deep = temp("claims-new").join("a/b/fit.json");
    let (code, stdout, stderr) = tactile(["fit", arg(&rec), "--json", arg(&deep)]);
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    assert!(std::fs::read_to_string(&deep)
        .unwrap()
        .contains("\"theta\""));
    // A run that stops after its claim leaves no file where there was none: the record is
    // refused (the force does not vary) after the JSON's path was claimed.
    let flat = record("claims-flat.csv", 2000, 0.01, |_| (5.0, 2.0));
    let json = temp("claims-flat.json");
    let (code, _, stderr) = tactile(["diagnose", arg(&flat), "--json", arg(&json)]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(!json.exists());
    // A usage error is named before the outputs are: a taxel given twice with an output that
    // cannot be written is the usage (exit 2), as it is with a good one.
    let twice = format!("3,2={}", arg(&rec));
    let (code, _, stderr) = tactile(["calibrate", &twice, &twice, "--out", arg(&bad)]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("taxel (3, 2) given twice"), "{stderr}");
    assert!(!stderr.contains(&blocker.display().to_string()), "{stderr}");
}

/// A time column in milliseconds (a 100 Hz record read as one sample every 10 s) is refused by
/// `estimate` as by `diagnose`, with the reason, instead of estimated at 0.1 Hz.
#[test]
fn a_time_column_not_in_seconds_is_refused() {
    let table = temp("ms-table.bin");
    std::fs::write(&table, nominal_table()).unwrap();
    let ms = record("ms.csv", 2000, 10.0, |t| {
        let f = 20.0 + 10.0 * (t / 1000.0).sin();
        (f, f / 3.0)
    });
    let out = temp("ms-estimate.csv");
    let why = "the sample period is 10 s: a tactile record is sampled between 1 Hz and 1 MHz";
    let (code, stdout, stderr) = tactile([
        "estimate",
        arg(&ms),
        "--table",
        arg(&table),
        "--out",
        arg(&out),
    ]);
    assert_eq!(code, Some(1), "{stdout}{stderr}");
    assert!(stderr.contains(why), "{stderr}");
    assert!(!out.exists());
    let (code, _, stderr) = tactile(["diagnose", arg(&ms)]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains(why), "{stderr}");
}
