//! Firmware-in-the-loop: builds the QEMU firmware (release, thumbv7em-none-eabihf), runs it on
//! QEMU's netduinoplus2 with deterministic instruction counting, decodes its defmt stream and
//! checks it against the memo's tracking bound and the host simulator.
//!
//! Ignored in plain `cargo test` (it builds a second target and runs an emulator);
//! `scripts/test-all.sh` runs it with `--ignored`. Without `qemu-system-arm` it says so loudly
//! and passes; the test script installs QEMU first, so in CI it always runs.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use sim_host::metrics::{rms, worst_step_settling_s};
use sim_host::rig::{RigConfig, TickRecord};
use sim_host::scenario::{run_named, ScenarioOptions};
use tactile_core::telemetry::TaxelFrame;

const QEMU: &str = "qemu-system-arm";
const QEMU_TIMEOUT: Duration = Duration::from_secs(150);

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn qemu_present() -> bool {
    Command::new(QEMU)
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Builds the firmware into its own target directory (the outer `cargo test` holds its own).
fn build_firmware() -> PathBuf {
    let target_dir = std::env::var_os("TACTILE_FW_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace().join("target/fw"));
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .current_dir(workspace())
        .env("CARGO_TARGET_DIR", &target_dir)
        .arg("fw-qemu")
        .status()
        .expect("cargo runs");
    assert!(status.success(), "the QEMU firmware does not build");
    target_dir.join("thumbv7em-none-eabihf/release/tactile-qemu")
}

/// Runs the firmware to its semihosting exit; returns the defmt bytes it wrote.
fn run_qemu(elf: &Path, log: &Path) {
    let out = std::fs::File::create(log).expect("log file");
    let mut child = Command::new(QEMU)
        .args([
            "-machine",
            "netduinoplus2",
            "-nographic",
            "-monitor",
            "none",
            "-serial",
            "none",
        ])
        .args(["-icount", "shift=0,align=off,sleep=off"])
        .args(["-semihosting-config", "enable=on,target=native"])
        .arg("-kernel")
        .arg(elf)
        .stdout(out)
        .stderr(Stdio::inherit())
        .spawn()
        .expect("qemu starts");
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().expect("qemu status") {
            assert!(
                status.success(),
                "the firmware exited with {status} (a panic or HardFault: see the log)"
            );
            break;
        }
        if start.elapsed() > QEMU_TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("QEMU still running after {QEMU_TIMEOUT:?}: the firmware did not finish its session");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    eprintln!(
        "QEMU ran the session in {:.1} s wall",
        start.elapsed().as_secs_f64()
    );
}

fn host_run(name: &str, duration_s: f32) -> sim_host::scenario::Run {
    let options = ScenarioOptions {
        duration_s,
        ..Default::default()
    };
    run_named(name, &options, RigConfig::default(), |_| {}).expect("host scenario")
}

/// RMS over the common length of two traces.
fn rms_between(a: &[TickRecord], b: &[TickRecord], f: impl Fn(&TickRecord) -> f64) -> f64 {
    let n = a.len().min(b.len());
    let pairs: Vec<TickRecord> = a[..n]
        .iter()
        .zip(&b[..n])
        .map(|(x, y)| TickRecord {
            sensed_g: (f(x) - f(y)) as f32,
            ..*x
        })
        .collect();
    rms(&pairs, |r| f64::from(r.sensed_g), |_| 0.0)
}

#[test]
#[ignore = "builds the firmware and runs QEMU: scripts/test-all.sh runs it with --ignored"]
fn firmware_in_the_loop_tracks_like_the_simulator() {
    if !qemu_present() {
        eprintln!(
            "\n!!!!!!!! SKIPPED: {QEMU} is not installed, the firmware-in-the-loop test did NOT run \
             (apt-get install -y qemu-system-arm; scripts/test-all.sh does this) !!!!!!!!\n"
        );
        return;
    }
    let elf = build_firmware();
    let dir = workspace().join("target/qemu-fil");
    std::fs::create_dir_all(&dir).expect("output directory");
    let log = dir.join("session.defmt");
    run_qemu(&elf, &log);

    let session = tactile_decode::decode(
        &std::fs::read(&elf).expect("elf"),
        &elf,
        &std::fs::read(&log).expect("log"),
        &log,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        session.errors.is_empty(),
        "firmware errors: {:?}",
        session.errors
    );
    for note in &session.notes {
        eprintln!("firmware: {note}");
    }
    // Nothing lost: contiguous sequence numbers, no drop flags, zero drop and overrun counts.
    assert_eq!(session.control_seq.missing(), 0);
    assert_eq!(session.taxel_seq.missing(), 0);
    assert_eq!(session.flagged_drops, 0);
    assert_eq!(session.trailing_bytes, 0);
    let names: Vec<&str> = session.runs.iter().map(|r| r.name.as_str()).collect();
    assert_eq!(names, ["force-steps", "pseudo-random"]);
    for run in &session.runs {
        let end = run.end.unwrap_or_else(|| panic!("{}: no RunEnd", run.name));
        assert_eq!(
            (
                end.control_frames_dropped,
                end.taxel_frames_dropped,
                end.overruns
            ),
            (0, 0, 0),
            "{}",
            run.name
        );
        let expected_ticks = (f64::from(run.duration_s) / tactile_decode::TICK_S).round() as usize;
        assert_eq!(run.ticks.len(), expected_ticks, "{}", run.name);
        assert!(run.duration_s >= 10.0, "{}: {} s", run.name, run.duration_s);
        let files = tactile_decode::write_run(&dir, run, &[]).expect("records written");
        // The record reads back with the simulator's strict reader.
        let back = sim_host::record::read_record(&files[0]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(back.len(), run.ticks.len() - 1);
    }

    for (name, duration_s) in [("force-steps", 10.5f32), ("pseudo-random", 10.0)] {
        let run = session.run(name).expect("run decoded");
        let fw = run.tick_records();
        let host = host_run(name, duration_s);
        assert_eq!(fw.len() + 1, host.ticks.len(), "{name}");
        let sensed = rms_between(&fw, &host.ticks, |r| f64::from(r.sensed_g));
        let truth = rms_between(&fw, &host.ticks, |r| f64::from(r.true_force_g));
        let strain = rms_between(&fw, &host.ticks, |r| f64::from(r.strain_pct));
        let command = rms_between(&fw, &host.ticks, |r| f64::from(r.command_g));
        eprintln!(
            "{name}: firmware vs host simulator, RMS over {} ticks: gauge force {sensed:.2e} g, \
             true force {truth:.2e} g, strain {strain:.2e} %, command {command:.2e} g",
            fw.len()
        );
        assert!(command == 0.0, "{name}: the command sources disagree");
        assert!(sensed <= 0.5 && truth <= 0.5, "{name}: traces disagree");
        // The scan: as many frames as the host's, the same strains to the quantum.
        assert_eq!(run.frames.len(), host.frames.len(), "{name}");
        let worst_cell = run
            .strain_frames()
            .iter()
            .zip(&host.frames)
            .flat_map(|((_, a), (_, b))| {
                a.iter()
                    .flatten()
                    .zip(b.iter().flatten())
                    .map(|(x, y)| (x - TaxelFrame::strain_pct(TaxelFrame::quantize(*y))).abs())
                    .collect::<Vec<_>>()
            })
            .fold(0.0f32, f32::max);
        eprintln!("{name}: worst taxel strain difference {worst_cell:.4} %");
        assert!(
            worst_cell <= 0.011,
            "{name}: taxel frames disagree by {worst_cell} %"
        );
    }

    // Damaged logs give errors that name the frame, or decode what is intact: never a panic.
    let bytes = std::fs::read(&log).expect("log");
    let elf_bytes = std::fs::read(&elf).expect("elf");
    let cut = tactile_decode::decode(&elf_bytes, &elf, &bytes[..bytes.len() / 2 + 7], &log);
    assert!(cut.is_err() || cut.is_ok_and(|s| s.trailing_bytes > 0 || s.runs.len() <= 2));
    let mut flipped = bytes.clone();
    for i in (1000..flipped.len()).step_by(997) {
        flipped[i] ^= 0x5a;
    }
    match tactile_decode::decode(&elf_bytes, &elf, &flipped, &log) {
        Err(e) => {
            eprintln!("a damaged log is refused: {e}");
            assert!(e.frame.is_some() && e.to_string().contains("frame"), "{e}");
        }
        Ok(_) => panic!("a log with flipped bytes decoded without complaint"),
    }

    // The memo's tracking bound, as the simulator's force-steps test checks it: each 10 g step
    // settles into ±1 g within 0.1 s (true contact force).
    let steps = session
        .run("force-steps")
        .expect("force-steps")
        .tick_records();
    let worst = worst_step_settling_s(&steps).expect("every step settles");
    eprintln!(
        "force-steps on the firmware: worst settling into ±1 g {:.0} ms",
        worst * 1e3
    );
    assert!(worst <= 0.1, "worst settling {worst} s");
    assert!(
        worst > 0.03,
        "settling {worst} s is too quick to be the slewed 10 g step"
    );
}
