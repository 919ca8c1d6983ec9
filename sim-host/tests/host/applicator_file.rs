//! `--applicator FILE`: the memo's rig as a file, and files that describe
//! no rig refused with the line and column or the parameter at fault.

use crate::common;

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
    assert_eq!(a.len(), 14);
    for (k, v) in b {
        let (x, y) = (a[k].as_float().unwrap(), v.as_float().unwrap());
        assert!((x - y).abs() <= 1e-12 * y.abs(), "{k}: {x} vs {y}");
    }
    // Appendix A's 19.2 g per volt into the amplifier.
    assert!(
        (p.drive_g_per_v() - 19.2).abs() < 0.05,
        "{}",
        p.drive_g_per_v()
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
    let dir = crate::common::scratch("applicator");
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
    // A unit slipped: finite, positive, and no gauge's (a file with it ran and recorded −inf).
    let e = refused(&memo.replace("gauge_g_per_v = 14.0", "gauge_g_per_v = 1e300"));
    assert!(e.contains("gauge_g_per_v = 1e300: outside 1e-2…1e4"), "{e}");
    let e = refused(&memo.replace("arm_m = 0.09", "arm_m = 9.0"));
    assert!(e.contains("arm_m = 9e0: outside"), "{e}");
    // A tip 130 times lighter: the beam rings at √(2000 N/m / 20 mg)/2π = 1592 Hz.
    let e = refused(&memo.replace("tip_mass_kg = 0.00261", "tip_mass_kg = 0.00002"));
    assert!(e.contains("rings at 1592 Hz, over 1000 Hz"), "{e}");
}

#[test]
fn tactile_applicator_writes_the_firmwares_form_or_refuses_with_the_reason() {
    let dir = crate::common::scratch("applicator-cli");
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

/// The gauge's scale and noise are the file's ("half the gauge
/// sensitivity"): on the memo's gauge (14 g/V, 0.14 g) and on the light rig's, half as
/// sensitive (28 g/V, 0.28 g), the firmware's reading of a probe pressed by a steady drive is
/// the contact force, and with the probe still off the finger its spread is the file's noise.
#[test]
fn the_gauge_reads_at_the_files_scale_with_the_files_noise() {
    use sim_host::rig::RigConfig;
    use tactile_plant::hardware::SimHardware;
    for (file, g_per_v, noise_g) in [
        ("memo.toml", 14.0, 0.14),
        ("light-motor-stiff-beam.toml", 28.0, 0.28),
    ] {
        let p = read_applicator(&folder().join(file)).unwrap();
        assert_eq!((p.gauge_g_per_v, p.gauge_noise_g), (g_per_v, noise_g));
        let mut config = RigConfig {
            scan_array: false,
            ..Default::default()
        };
        config.set_applicator(p);
        let gauge = config.firmware.gauge;
        let mut hw = SimHardware::new(&config);
        let reading_g = |hw: &mut SimHardware| {
            hw.advance_period();
            gauge.average_force(&hw.gauge_codes()).unwrap()
        };
        // Off the finger, the drive at zero and the motor held by its stiction: the reading is
        // the noise alone (0.28 g against the 0.14 g the converter's step is, at 28 g/V: the
        // rounding adds (0.14²/12)/8 to the variance, 0.1 % of it).
        let n = 4000;
        let still: Vec<f32> = (0..n).map(|_| reading_g(&mut hw)).collect();
        let mean = still.iter().sum::<f32>() / n as f32;
        let rms = (still.iter().map(|r| (r - mean).powi(2)).sum::<f32>() / n as f32).sqrt();
        // The sample RMS of 4 000 draws is within 1.1 % (one deviation) of the true one.
        assert!(
            (rms / noise_g as f32 - 1.0).abs() < 0.05,
            "{file}: RMS {rms} g"
        );
        assert!(mean.abs() < 0.05, "{file}: mean {mean} g");
        // Pressed by 30 g of drive: after two seconds the reading's mean is the contact force's.
        hw.write_dac(config.firmware.actuator.code(30.0));
        for _ in 0..2000 {
            reading_g(&mut hw);
        }
        let (mut read, mut truth) = (0.0f32, 0.0f32);
        for _ in 0..n {
            read += reading_g(&mut hw) / n as f32;
            truth += hw.true_force_g() as f32 / n as f32;
        }
        assert!(truth > 20.0, "{file}: {truth} g pressed");
        assert!(
            (read - truth).abs() < 0.05,
            "{file}: read {read} g, {truth} g"
        );
    }
    // An applicator set without the firmware's gauge would read half the force: refused.
    let config = RigConfig {
        applicator: read_applicator(&folder().join("light-motor-stiff-beam.toml")).unwrap(),
        ..Default::default()
    };
    let e = sim_host::rig::Rig::new(config).err().unwrap().to_string();
    assert!(e.contains("at 14 g/V") && e.contains("28 g/V"), "{e}");
}

/// An experiment whose supervisor latched says so beside its figures (a gauge stuck from 1 s is
/// taken for one once the command moves while it reads the same, at the step's 2 s); a clean
/// run says nothing of it.
#[test]
fn an_experiment_whose_supervisor_stopped_the_drive_says_so() {
    let dir = crate::common::scratch("latched");
    let run = |extra: &[&str]| {
        let args = [
            "experiment",
            "step",
            "--no-plot",
            "--out",
            dir.to_str().unwrap(),
        ];
        let (code, stdout, stderr) = common::tactile(args.iter().chain(extra));
        assert_eq!(code, Some(0), "{stdout}{stderr}");
        stdout
    };
    let stuck = run(&["--fault", "gauge-stuck@1"]);
    assert!(
        stuck.contains("the supervisor stopped the drive at 2.0") && stuck.contains("GAUGE_STUCK"),
        "{stuck}"
    );
    let clean = run(&[]);
    assert!(!clean.contains("supervisor"), "{clean}");
}
