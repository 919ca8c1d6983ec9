//! `--applicator FILE` (issue 13, item 4): the memo's rig as a file, and files that describe
//! no rig refused with the line and column or the parameter at fault.

use sim_host::applicator::ApplicatorParams;
use sim_host::error::read_applicator;

fn folder() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../applicators")
}

#[test]
fn the_memo_file_is_the_memo_applicator() {
    let p = read_applicator(&folder().join("memo.toml")).unwrap();
    let (a, b) = (
        toml::Value::try_from(p).unwrap(),
        toml::Value::try_from(ApplicatorParams::MEMO).unwrap(),
    );
    let (a, b) = (a.as_table().unwrap(), b.as_table().unwrap());
    assert_eq!(a.len(), 12);
    for (k, v) in b {
        let (x, y) = (a[k].as_float().unwrap(), v.as_float().unwrap());
        assert!((x - y).abs() <= 1e-12 * y.abs(), "{k}: {x} vs {y}");
    }
    // Appendix A's 19.2 g per volt into the amplifier.
    assert!(
        (p.grams_per_volt() - 19.2).abs() < 0.05,
        "{}",
        p.grams_per_volt()
    );
}

#[test]
fn every_file_in_the_folder_is_a_rig() {
    for entry in std::fs::read_dir(folder()).unwrap() {
        let path = entry.unwrap().path();
        read_applicator(&path).unwrap_or_else(|e| panic!("{e}"));
    }
}

fn refused(text: &str) -> String {
    let dir = std::env::temp_dir().join(format!("applicator-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("rig.toml");
    std::fs::write(&path, text).unwrap();
    let e = read_applicator(&path).unwrap_err().to_string();
    assert!(e.contains("rig.toml"), "{e}");
    e
}

#[test]
fn a_bad_file_is_refused_with_where_and_why() {
    let memo = std::fs::read_to_string(folder().join("memo.toml")).unwrap();
    // A typo: the line and column, and the fields there are.
    let e = refused(&memo.replace("\narm_m =", "\narm_mm ="));
    assert!(
        e.contains("line 12, column 1") && e.contains("unknown field `arm_mm`"),
        "{e}"
    );
    // A missing field.
    let without: String = memo
        .lines()
        .filter(|l| !l.starts_with("tip_mass_kg"))
        .map(|l| format!("{l}\n"))
        .collect();
    assert!(refused(&without).contains("missing field `tip_mass_kg`"));
    // Not a number.
    let e = refused(&memo.replace("arm_m = 0.09", "arm_m = \"9 cm\""));
    assert!(
        e.contains("line 12, column 9") && e.contains("expected f64"),
        "{e}"
    );
    // A rig that cannot exist.
    let e = refused(&memo.replace("arm_m = 0.09", "arm_m = -0.09"));
    assert!(
        e.contains("arm_m = -0.09: must be a finite number above zero"),
        "{e}"
    );
    let e = refused(&memo.replace("beam_damping_ratio = 0.01", "beam_damping_ratio = -1.0"));
    assert!(e.contains("beam_damping_ratio = -1"), "{e}");
    let e = refused(&memo.replace("tip_mass_kg = 0.00261", "tip_mass_kg = nan"));
    assert!(e.contains("tip_mass_kg = NaN"), "{e}");
}

#[test]
fn tactile_applicator_writes_the_firmwares_form_or_refuses_with_the_reason() {
    let dir = std::env::temp_dir().join(format!("applicator-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let tactile = env!("CARGO_BIN_EXE_tactile");
    let out = dir.join("memo.bin");
    let status = std::process::Command::new(tactile)
        .args([
            "applicator",
            folder().join("memo.toml").to_str().unwrap(),
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(status.status.success(), "{status:?}");
    let back = ApplicatorParams::decode(&std::fs::read(&out).unwrap()).unwrap();
    assert_eq!(back, read_applicator(&folder().join("memo.toml")).unwrap());
    // A rig that cannot exist: exit 1, the file and the field named, nothing written.
    let bad = dir.join("bad.toml");
    let memo = std::fs::read_to_string(folder().join("memo.toml")).unwrap();
    std::fs::write(
        &bad,
        memo.replace("tip_mass_kg = 0.00261", "tip_mass_kg = -1.0"),
    )
    .unwrap();
    let none = dir.join("bad.bin");
    let refused = std::process::Command::new(tactile)
        .args(["applicator", bad.to_str().unwrap(), "--out"])
        .arg(&none)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("bad.toml") && stderr.contains("tip_mass_kg"),
        "{stderr}"
    );
    assert!(!none.exists());
}
