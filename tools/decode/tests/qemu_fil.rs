//! Firmware-in-the-loop: builds the QEMU firmware (release, thumbv7em-none-eabihf), runs it on
//! QEMU's netduinoplus2 with deterministic instruction counting, decodes its defmt stream and
//! checks it against the memo's tracking bound and the host simulator.
//!
//! Ignored in plain `cargo test` (it builds a second target and runs an emulator);
//! `scripts/test-all.sh` runs it with `--ignored`. Without `qemu-system-arm` it says so loudly
//! and passes; the test script installs QEMU first, so in CI it always runs.

mod common;
use common::{build_firmware, workspace};

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use sim_host::metrics::{rms, worst_step_settling_s};
use sim_host::rig::InjectedFault;
use sim_host::rig::{RigConfig, TickRecord};
use sim_host::scenario::{run_named, run_protocol, ScenarioOptions};
use tactile_core::control::ActuatorConfig;
use tactile_core::telemetry::{FaultFlags, TaxelFrame};
use tactile_firmware::{FilRun, FIL_SESSION};

const QEMU: &str = "qemu-system-arm";
/// A guard against a firmware that never exits, not a timing test: the main session took 45 s
/// alone and over 150 s beside the calibration runs on two cores.
const QEMU_TIMEOUT: Duration = Duration::from_secs(600);
/// A calibration run simulates 122 s (one QEMU per run; the three of the session took 456 s
/// of wall time one after another on CI).
const CALIBRATION_TIMEOUT: Duration = Duration::from_secs(900);

fn qemu_present() -> bool {
    Command::new(QEMU)
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Runs the firmware to its semihosting exit with `append` as its command line, writing the
/// defmt bytes to `log`; returns whether it exited with success.
fn run_qemu(elf: &Path, log: &Path, append: &str) -> bool {
    run_qemu_for(elf, log, append, QEMU_TIMEOUT)
}

fn run_qemu_for(elf: &Path, log: &Path, append: &str, timeout: Duration) -> bool {
    let out = std::fs::File::create(log).expect("log file");
    let mut command = tactile_decode::transport::qemu_command(elf);
    if !append.is_empty() {
        command.args(["-append", append]);
    }
    let mut child = command
        .stdout(out)
        .stderr(Stdio::inherit())
        .spawn()
        .expect("qemu starts");
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().expect("qemu status") {
            eprintln!(
                "QEMU ran the session{} in {:.1} s wall ({status})",
                if append.is_empty() {
                    String::new()
                } else {
                    format!(" with `{append}`")
                },
                start.elapsed().as_secs_f64()
            );
            return status.success();
        }
        if start.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            panic!("QEMU still running after {timeout:?}: the firmware did not finish its session");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The firmware built and an output folder, or `None` (said loudly) without QEMU.
fn firmware_for(what: &str) -> Option<(std::path::PathBuf, std::path::PathBuf)> {
    if !qemu_present() {
        eprintln!(
            "\n!!!!!!!! SKIPPED: {QEMU} is not installed, the {what} did NOT run \
             (apt-get install -y qemu-system-arm; scripts/test-all.sh does this) !!!!!!!!\n"
        );
        return None;
    }
    let elf = build_firmware("fw-qemu", "release", "tactile-qemu");
    let dir = workspace().join("target/qemu-fil");
    std::fs::create_dir_all(&dir).expect("output directory");
    Some((elf, dir))
}

/// Each of a session's `runs` runs in its own QEMU (`session=NAME run=N`), side by side (the
/// emulator uses one core, and each run starts from a fresh board, as within one session),
/// decoded.
fn each_run(
    elf: &Path,
    dir: &Path,
    session: &str,
    runs: impl IntoIterator<Item = usize>,
    timeout: Duration,
) -> Vec<tactile_decode::Session> {
    std::thread::scope(|scope| {
        let handles: Vec<_> = runs
            .into_iter()
            .map(|k| {
                scope.spawn(move || {
                    let log = dir.join(format!("{session}-{k}.defmt"));
                    let append = format!("session={session} run={k}");
                    assert!(
                        run_qemu_for(elf, &log, &append, timeout),
                        "the firmware exited with a failure (`{append}`)"
                    );
                    decode_log(elf, &log)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("a QEMU run"))
            .collect()
    })
}

fn decode_log(elf: &Path, log: &Path) -> tactile_decode::Session {
    tactile_decode::decode(
        &std::fs::read(elf).expect("elf"),
        elf,
        &std::fs::read(log).expect("log"),
        log,
    )
    .unwrap_or_else(|e| panic!("{e}"))
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

fn is_fault(spec: &FilRun, fault: InjectedFault) -> bool {
    spec.fault.is_some_and(|f| f.fault == fault)
}

/// A fault run of the QEMU session, from its decoded defmt stream: the DAC at the zero code
/// within 2 ticks of the injection (in the same tick for a missed deadline) and held there,
/// LATCHED and the fault's bit in the frames, the probe's true force released, and every
/// control value, DAC code and fault bit equal to the host rig's run of the same fault.
fn fault_run_is_safe_and_is_the_rigs(run: &tactile_decode::Run, spec: &FilRun) {
    let name = spec.name;
    let injection = spec.fault.expect("a fault run");
    // (fault bit, safe within this many ticks, latched by this many ticks after): the host
    // simulator's fault tests, the same table.
    let (bit, within, latch) = match injection.fault {
        InjectedFault::GaugeDisconnected | InjectedFault::GaugeSaturated => {
            (FaultFlags::GAUGE_AT_RAIL, 2, 2)
        }
        InjectedFault::ForceSpike { .. } => (FaultFlags::FORCE_SLEW, 2, 1),
        InjectedFault::DeadlineOverrun => (FaultFlags::DEADLINE_OVERRUN, 1, 0),
        other => panic!("{name}: no expectations written for {other:?}"),
    };
    let zero = ActuatorConfig::MEMO.zero_code().0;
    let ticks = &run.ticks;
    // Tick k starts at k ms: the first tick at or after the injection time.
    let k0 = ticks
        .iter()
        .position(|t| run.tick_time_s(t.frame.tick) >= injection.at_s - 1e-9)
        .expect("the injection falls inside the run");
    let dac = |t: &tactile_decode::Tick| t.frame.dac_code;
    assert!(
        ticks[..k0].iter().rev().take(100).all(|t| dac(t) != zero),
        "{name}: the actuator was not driving before the fault"
    );
    let last_driving = ticks[k0..].iter().rposition(|t| dac(t) != zero);
    let safe_after = last_driving.map_or(0, |i| i + 1);
    assert!(
        safe_after < within,
        "{name}: DAC not at the zero code {zero} until {safe_after} ticks after the injection"
    );
    let flags = |k: usize| ticks[k].frame.faults;
    let latched_at = (k0..=k0 + latch)
        .find(|&k| flags(k).contains(bit | FaultFlags::LATCHED))
        .unwrap_or_else(|| {
            panic!(
                "{name}: {:?} not latched within {latch} ticks: {:?}",
                bit.names().collect::<Vec<_>>(),
                flags(k0 + latch).names().collect::<Vec<_>>()
            )
        });
    assert!(
        ticks[latched_at..]
            .iter()
            .all(|t| t.frame.faults.contains(FaultFlags::LATCHED)),
        "{name}: the latch let go"
    );
    // The probe retracts: true force below 0.5 g within 150 ms, below 0.1 g at the end.
    let records = run.tick_records();
    let released = records[k0..]
        .iter()
        .position(|r| r.true_force_g < 0.5)
        .unwrap_or_else(|| panic!("{name}: the probe force never falls"));
    assert!(
        released < 150,
        "{name}: force above 0.5 g for {released} ms"
    );
    let end_force = records.last().expect("records").true_force_g;
    assert!(end_force < 0.1, "{name}: {end_force} g at the end");
    eprintln!(
        "{name}: injected at tick {k0}; DAC at the zero code {safe_after} tick(s) later; \
         {:?} latched {} tick(s) later; true force < 0.5 g after {released} ms, {end_force:.3} g \
         at the end",
        flags(latched_at).names().collect::<Vec<_>>(),
        latched_at - k0
    );

    is_the_rigs_to_the_bit(run, spec);
}

/// The host rig, same protocol, fault, controller and seed: every command, control output,
/// DAC code and fault bit identical to the bit, and the same forces.
fn is_the_rigs_to_the_bit(run: &tactile_decode::Run, spec: &FilRun) {
    is_this_rigs_to_the_bit(run, spec, spec.rig());
}

/// [`is_the_rigs_to_the_bit`] against the host rig built from `rig`.
fn is_this_rigs_to_the_bit(run: &tactile_decode::Run, spec: &FilRun, rig: RigConfig) {
    let name = spec.name;
    let ticks = &run.ticks;
    let records = run.tick_records();
    let dac = |t: &tactile_decode::Tick| t.frame.dac_code;
    let host = run_protocol(name, spec.protocol, rig, false, |_| {}).expect("host rig");
    assert_eq!(ticks.len(), host.ticks.len(), "{name}");
    for (k, (fw, rig)) in ticks.iter().zip(&host.ticks).enumerate() {
        let f = &fw.frame;
        assert_eq!(
            (
                f.command_g.to_bits(),
                f.adjusted_g.to_bits(),
                dac(fw),
                f.faults.bits()
            ),
            (
                rig.command_g.to_bits(),
                rig.adjusted_g.to_bits(),
                rig.dac_code,
                // The rig flags a railed taxel per tick; the firmware marks it in its frames.
                (rig.faults - FaultFlags::TAXEL_AT_RAIL).bits()
            ),
            "{name}: tick {k} differs from the host rig"
        );
    }
    let truth = rms_between(&records, &host.ticks, |r| f64::from(r.true_force_g));
    let sensed = rms_between(&records, &host.ticks, |r| f64::from(r.sensed_g));
    // An injected overrun delays the firmware's scan against the plant (the rig counts it
    // without delaying anything): its frames are the rig's up to the injection.
    let before_tick = match spec.fault {
        Some(f) if f.fault == InjectedFault::DeadlineOverrun => {
            (f.at_s / tactile_core::CONTROL_PERIOD_S) as u32
        }
        _ => u32::MAX,
    };
    let contacts = estimates_are_the_rigs(run, &host.estimates, name, before_tick);
    eprintln!(
        "{name}: firmware vs host rig over {} ticks: command, control output, DAC code and \
         fault bits identical; {} frames' contact (kind, x, y, force) and centroid identical \
         ({contacts} found a point); RMS true force {truth:.2e} g, gauge force {sensed:.2e} g",
        ticks.len(),
        host.estimates.len()
    );
    assert!(truth == 0.0 && sensed == 0.0, "{name}: traces differ");
}

/// Every frame's array estimate of the firmware completed before the run's tick `before_tick`
/// is the host rig's to the bit (the locator's contact, its force and the centroid); the
/// frames where the contact was one point.
fn estimates_are_the_rigs(
    run: &tactile_decode::Run,
    host: &[tactile_firmware::ArrayEstimate],
    name: &str,
    before_tick: u32,
) -> usize {
    assert_eq!(run.frames.len(), host.len(), "{name}: frames");
    let bits = |e: &tactile_firmware::ArrayEstimate| {
        (
            e.contact,
            e.contact_x_mm.to_bits(),
            e.contact_y_mm.to_bits(),
            e.total_force_g.to_bits(),
            e.centroid_row.to_bits(),
            e.centroid_col.to_bits(),
        )
    };
    let compared = run
        .frames
        .iter()
        .zip(host)
        .take_while(|(_, rig)| rig.tick < before_tick);
    for (k, ((_, fw), rig)) in compared.enumerate() {
        let fw = fw.unwrap_or_else(|| panic!("{name}: frame {k} without its estimate"));
        assert_eq!(bits(&fw), bits(rig), "{name}: frame {k}: {fw:?} vs {rig:?}");
    }
    host.iter()
        .take_while(|e| e.tick < before_tick)
        .filter(|e| e.contact == tactile_core::contact::ContactKind::Point)
        .count()
}

/// The plant of an applicator file, read by the QEMU firmware as by the simulator
///: the light rig's force steps under A1 (`run=0 applicator=FILE`), its gauge half as
/// sensitive as the memo's and the firmware reading it at its scale, are the host rig's with
/// the same file to the bit (sensed force included), and not the memo rig's; a damaged file is refused with the
/// reason and the firmware exits with a failure before it runs anything.
#[test]
#[ignore = "builds the firmware and runs QEMU: scripts/test-all.sh runs it with --ignored"]
fn the_firmware_runs_the_plant_of_an_applicator_file() {
    let Some((elf, dir)) = firmware_for("applicator-file test") else {
        return;
    };
    let file = workspace().join("applicators/light-motor-stiff-beam.toml");
    let light = sim_host::error::read_applicator(&file).unwrap_or_else(|e| panic!("{e}"));
    let bin = dir.join("light-motor-stiff-beam.bin");
    std::fs::write(&bin, light.encode()).expect("applicator written");
    let log = dir.join("applicator.defmt");
    let append = format!("run=0 applicator={}", bin.display());
    assert!(run_qemu(&elf, &log, &append), "`{append}` failed");
    let session = decode_log(&elf, &log);
    assert!(session.errors.is_empty(), "{:?}", session.errors);
    let (run, spec) = (&session.runs[0], &FIL_SESSION[0]);
    assert_eq!(light.gauge_g_per_v, 28.0);
    let mut config = spec.rig();
    config.set_applicator(light);
    is_this_rigs_to_the_bit(run, spec, config);
    let memo = run_protocol(spec.name, spec.protocol, spec.rig(), false, |_| {}).expect("memo");
    let differ = run
        .ticks
        .iter()
        .zip(&memo.ticks)
        .filter(|(f, m)| f.frame.dac_code != m.dac_code)
        .count();
    eprintln!(
        "light rig: {differ} of {} DAC codes differ from the memo rig's",
        run.ticks.len()
    );
    // (Measured: 5 086 of 10 500.)
    assert!(differ > run.ticks.len() / 4);

    let mut damaged = light.encode();
    damaged[8 + 8 * 3] ^= 0x10;
    let bad = dir.join("damaged.bin");
    std::fs::write(&bad, damaged).expect("damaged written");
    let log = dir.join("applicator-damaged.defmt");
    let append = format!("run=0 applicator={}", bad.display());
    assert!(!run_qemu(&elf, &log, &append), "`{append}` ran");
    let session = decode_log(&elf, &log);
    assert!(
        session.runs.is_empty(),
        "a run started on a damaged applicator"
    );
    assert!(
        session
            .errors
            .iter()
            .any(|e| e.contains("refused") && e.contains("CRC")),
        "{:?}",
        session.errors
    );
}

#[test]
#[ignore = "builds the firmware and runs QEMU: scripts/test-all.sh runs it with --ignored"]
fn firmware_in_the_loop_tracks_like_the_simulator() {
    let Some((elf, dir)) = firmware_for("firmware-in-the-loop test") else {
        return;
    };
    let log = dir.join("session.defmt");
    assert!(
        run_qemu(&elf, &log, ""),
        "the firmware exited with a failure (a panic or HardFault: see the log)"
    );

    let session = decode_log(&elf, &log);
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
    let expected: Vec<&str> = FIL_SESSION.iter().map(|r| r.name).collect();
    assert_eq!(names, expected);
    for (run, spec) in session.runs.iter().zip(&FIL_SESSION) {
        let end = run.end.unwrap_or_else(|| panic!("{}: no RunEnd", run.name));
        // The one overrun is the injected one.
        let overruns = u32::from(is_fault(spec, InjectedFault::DeadlineOverrun));
        assert_eq!(
            (
                end.control_frames_dropped,
                end.taxel_frames_dropped,
                end.overruns
            ),
            (0, 0, overruns),
            "{}",
            run.name
        );
        let expected_ticks =
            (f64::from(run.duration_s) / tactile_core::CONTROL_PERIOD_S).round() as usize;
        assert_eq!(run.ticks.len(), expected_ticks, "{}", run.name);
        assert_eq!(run.duration_s, spec.protocol.duration_s(), "{}", run.name);
        // Every tick of the run, in order (the sequence numbers are checked session-wide).
        assert!(
            run.ticks
                .windows(2)
                .all(|w| w[1].frame.tick == w[0].frame.tick.wrapping_add(1)),
            "{}: ticks missing",
            run.name
        );
        let files = tactile_decode::write_run(&dir, run, &[]).expect("records written");
        // The record reads back with the simulator's strict reader.
        let back = sim_host::record::read_record(&files[0]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(back.len(), run.ticks.len() - 1);
    }
    for spec in FIL_SESSION.iter().filter(|r| r.fault.is_none()) {
        let run = session.run(spec.name).expect("run decoded");
        assert!(run.duration_s >= 10.0, "{}: {} s", run.name, run.duration_s);
    }
    for spec in FIL_SESSION.iter().filter(|r| r.fault.is_some()) {
        let run = session.run(spec.name).expect("run decoded");
        fault_run_is_safe_and_is_the_rigs(run, spec);
    }
    // The designed force controller from the table the build carries: the host
    // rig's to the bit, and every force step after the first from rest into ±1 g within 40 ms
    // (A1: 58–69 ms), as `sim-host/tests/host/controller.rs` finds on the host.
    let spec = FIL_SESSION
        .iter()
        .find(|r| r.designed)
        .expect("a designed run");
    assert!(
        spec.rig().firmware.designed.is_some(),
        "the controller table was refused: {:?}",
        tactile_core::designed::DesignedConfig::decode(&tactile_firmware::CONTROLLER_TABLE)
    );
    let run = session.run(spec.name).expect("run decoded");
    is_the_rigs_to_the_bit(run, spec);
    let records = run.tick_records();
    let settling = sim_host::metrics::settling_after_first_s(&records);
    eprintln!(
        "{}: settling into ±1 g after the first step (ms): {:?}",
        spec.name,
        settling
            .iter()
            .map(|t| (t * 1e3).round())
            .collect::<Vec<_>>()
    );
    // As on the host (sim-host/tests/host/controller.rs): all but one within 30 ms (measured
    // 15–22 ms), the 100 → 90 g step within 70 ms (61 ms).
    let n = settling.len();
    assert!(
        n > 1 && settling[n - 2] <= 0.030 && settling[n - 1] <= 0.070,
        "{}: {settling:?}",
        spec.name
    );
    // The control tick, the designed controller's runs included: within the 2 000
    // instructions (measured at most 1 553 over the session; A1's alone were 505–1 190).
    let control_tick_max: u32 = session
        .notes
        .iter()
        .flat_map(|n| tactile_decode::text::parse_structs(n))
        .find(|s| s.name == "InstructionCounts")
        .and_then(|c| {
            let f = c.fields();
            let span = tactile_decode::text::parse_structs(f.text("control_tick").ok()?);
            span.first()?.fields().num("max").ok()
        })
        .expect("the firmware reported its instruction counts");
    eprintln!("control tick: at most {control_tick_max} instructions");
    assert!(control_tick_max <= 2000, "{control_tick_max}");
    // The scan step that completes a frame leaves the contact's fit to the locate task: on the
    // F407 it runs in TIM2's interrupt and must end within its 250 µs dwell (42 000 cycles at
    // 168 MHz); the fit, once a 16 ms frame, well within the frame: at most its 12
    // Levenberg–Marquardt iterations of about 7 500 instructions (105 148 measured on a frame
    // that used them all), 4 % of the frame's 2.7 million cycles.
    let span_of = |name: &str| {
        session
            .notes
            .iter()
            .flat_map(|n| tactile_decode::text::parse_structs(n))
            .find(|s| s.name == "InstructionCounts")
            .and_then(|c| {
                let f = c.fields();
                let span = tactile_decode::text::parse_structs(f.text(name).ok()?);
                let f = span.first()?.fields();
                Some((f.num::<u32>("min").ok()?, f.num::<u32>("max").ok()?))
            })
            .expect("the firmware reported its scan's instructions")
    };
    let frame_step = span_of("scan_frame_step");
    eprintln!(
        "scan step completing a frame: {}–{} instructions",
        frame_step.0, frame_step.1
    );
    assert!(frame_step.1 < 42_000, "{frame_step:?}");
    let locate = span_of("locate_frame");
    eprintln!(
        "contact located (the locate task, per frame): {}–{} instructions",
        locate.0, locate.1
    );
    assert!(locate.1 < 110_000, "{locate:?}");

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
        // The session's own rig (the build's calibration table) to the bit, the array's
        // estimates with it.
        let spec = FIL_SESSION
            .iter()
            .find(|r| r.name == name)
            .expect("a session run");
        is_the_rigs_to_the_bit(run, spec);
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

    // The estimators on the chip: the probed taxel (element 4,2, calibrated in the
    // build's table) by every estimator at the scan rate, against the simulator's true force at
    // the instant the scan sampled it (the truth that rides with the next control tick).
    let (rms, n) = session
        .run("pseudo-random")
        .expect("pseudo-random")
        .probe_estimator_rms(1.0);
    eprintln!(
        "pseudo-random on the firmware, probed taxel, calibrated, {n} frames: RMS elastic {:.3} g, \
         second-order inverse {:.3} g, scheduled inverse {:.3} g, observer {:.3} g, force bank \
         {:.3} g",
        rms[0], rms[1], rms[2], rms[3], rms[4]
    );
    assert!(n > 500, "{n} frames with estimates");
    assert!(
        rms[3] <= 0.5 && rms[3] < rms[1] && rms[1] < rms[0],
        "{rms:?}"
    );
    let figures = session.estimator_figures().expect("estimator figures");
    assert_eq!(figures.rms_g, rms);
    eprint!("{}", figures.render());
    // Instructions per taxel update: elastic < inverse < scheduled < observer, the observer
    // and the force bank each under 1 000 (the budget: 8 400 a millisecond for control and
    // four taxel updates).
    let worst: Vec<u32> = figures.instructions.iter().map(|(_, hi)| *hi).collect();
    assert!(
        worst[..4].windows(2).all(|w| w[0] < w[1]) && worst[3] < 1000 && worst[4] < 1000,
        "{worst:?}"
    );
    assert!(
        session
            .notes
            .iter()
            .any(|n| n.contains("calibrated_taxels: 4")),
        "the firmware did not report its calibration table: {:?}",
        session.notes
    );

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

/// The crash handlers: a deliberate panic, then a deliberate HardFault (an undefined
/// instruction) at a tick where the actuator is driving 10 g; each handler must put the safe
/// code into the simulated DAC before it reports, and QEMU must stop with a failure code.
#[test]
#[ignore = "builds the firmware and runs QEMU: scripts/test-all.sh runs it with --ignored"]
fn a_panic_and_a_hardfault_zero_the_actuator_before_reporting() {
    let Some((elf, dir)) = firmware_for("crash test") else {
        return;
    };
    let zero = ActuatorConfig::MEMO.zero_code().0;
    // 1.2 s into force-steps: the first 10 g step is on.
    const CRASH_TICK: u32 = 1200;
    for (request, cause) in [
        ("panic-at-tick", "panic"),
        ("hardfault-at-tick", "hardfault"),
    ] {
        let log = dir.join(format!("{cause}.defmt"));
        let append = format!("{request}={CRASH_TICK}");
        assert!(
            !run_qemu(&elf, &log, &append),
            "{cause}: QEMU exited with success after a crash"
        );
        let session = decode_log(&elf, &log);
        // The last frame out before the crash: the actuator was driving.
        let last = session
            .runs
            .last()
            .and_then(|r| r.ticks.last())
            .expect("frames before the crash");
        assert_eq!(last.frame.tick, CRASH_TICK - 1, "{cause}");
        let driving = last.frame.dac_code;
        assert_ne!(driving, zero, "{cause}: the actuator was not driving");
        // The crash report: the handler's SafeStop, with the DAC read back at the zero code.
        assert_eq!(session.errors.len(), 1, "{cause}: {:?}", session.errors);
        let report = &session.errors[0];
        let stop = tactile_decode::text::parse_structs(report)
            .into_iter()
            .find(|s| s.name == "SafeStop")
            .unwrap_or_else(|| panic!("{cause}: no SafeStop in {report:?}"));
        let f = stop.fields();
        assert_eq!(f.text("cause").expect("cause"), cause);
        assert!(f.flag("board").expect("board"));
        let dac: u16 = f.num("dac_code").expect("dac_code");
        let safe: u16 = f.num("safe_code").expect("safe_code");
        assert_eq!((dac, safe), (zero, zero), "{cause}: {report}");
        eprintln!("{cause} at tick {CRASH_TICK}: DAC {driving} → {dac} (zero code) before the report: {report}");
    }
}

/// |a − b| / |b|.
fn relative_error(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// A taxel's calibration from the firmware's record is the host simulator's of the same taxel
/// to within what a tick of shift and the record's rounding change: G₁ at 30 g within 1 %, G₂
/// within 5 %.
fn the_hosts_calibration(
    firmware: &tactile_core::viscoelastic::NonlinearMk,
    host: &tactile_core::viscoelastic::NonlinearMk,
) -> bool {
    relative_error(firmware.g1.stiffness(30.0), host.g1.stiffness(30.0)) < 0.01
        && relative_error(firmware.g2.stiffness(30.0), host.g2.stiffness(30.0)) < 0.05
}

/// Dynamic calibration end to end: the firmware runs the calibration protocol with the
/// probe over a taxel of the simulated finger (parameters unlike the nominal models'), streams
/// it over defmt; the host decodes the record, fits the taxel (`tactile calibrate`'s code) and
/// writes the table; that table must match the host simulator's calibration of the same taxel
/// (what the firmware build carries) and bring the observer under 0.2 g, where the nominal
/// models err by several grams (another taxel of another finger, by command:
/// `the_board_calibrates_a_taxel_by_command`). A second
/// run calibrates a taxel of a finger whose springs stiffen by other laws: its
/// calibration must be the host's and meet the 0.3 g there too.
#[test]
#[ignore = "builds the firmware and runs QEMU: scripts/test-all.sh runs it with --ignored"]
fn calibration_on_the_firmware_end_to_end() {
    use sim_host::dynamic_calibration::{
        calibrate_simulated, fit_taxel, CALIBRATION_TAXELS, FINGER_SEED,
    };
    use tactile_core::calibration::CalibrationTable;
    use tactile_core::profile::Protocol;
    use tactile_firmware::CALIBRATION_SESSION;
    let Some((elf, dir)) = firmware_for("calibration test") else {
        return;
    };
    // NOTE: the session's first taxel, (3, 2), is left out: its parameters are the nominal
    // models' (element 4,2), so it shows no calibration at work, and the calibration by command
    // checks another taxel of another finger against the host (a fourth QEMU run of the
    // protocol's 122 s was two minutes of the test command).
    let chosen = [1, 2];
    let sessions = each_run(&elf, &dir, "calibration", chosen, CALIBRATION_TIMEOUT);
    for session in &sessions {
        assert!(session.errors.is_empty(), "{:?}", session.errors);
        assert_eq!(session.control_seq.missing(), 0);
        assert_eq!(session.flagged_drops, 0);
        assert_eq!(session.runs.len(), 1);
    }
    let mut table = CalibrationTable::default();
    let mut other = CalibrationTable::default();
    let runs = sessions.iter().flat_map(|s| &s.runs);
    assert_eq!(runs.clone().count(), chosen.len());
    for (run, spec) in runs.zip(chosen.map(|k| &CALIBRATION_SESSION[k])) {
        assert_eq!(run.name, spec.name);
        let end = run.end.expect("RunEnd");
        assert_eq!(
            (end.control_frames_dropped, end.overruns),
            (0, 0),
            "{}",
            run.name
        );
        let taxel = spec.rig().firmware.probe;
        let records = run.tick_records();
        assert!(
            records.len() >= 121_000,
            "{}: {} records",
            run.name,
            records.len()
        );
        let (force, strain): (Vec<f64>, Vec<f64>) = records
            .iter()
            .map(|r| (f64::from(r.sensed_g), f64::from(r.strain_pct)))
            .unzip();
        let (model, report) = fit_taxel(taxel, Protocol::CALIBRATION, 1e-3, &force, &strain)
            .unwrap_or_else(|e| panic!("{}: {e}", run.name));
        eprintln!(
            "{}: G1(30 g) {:.3} g/%, G2(30 g) {:.1} g/%, N1 {:.0}, N2 {:.0}, strain offset {:.3} %, held out {:?} g, runs {}",
            run.name,
            model.element.g1.stiffness(30.0),
            model.element.g2.stiffness(30.0),
            model.element.n1,
            model.element.n2,
            model.strain_offset_pct,
            report.held_out_g,
            report.estimator,
        );
        let into = if spec.element.is_some() {
            &mut other
        } else {
            &mut table
        };
        into.taxels.push(model).expect("a taxel");
    }
    assert_eq!(table.taxels.len(), 1);
    let mut bytes = vec![0u8; table.encoded_len()];
    let n = table.encode(&mut bytes).expect("encoded");
    std::fs::write(dir.join("calibration-table.bin"), &bytes[..n]).expect("table written");

    // The firmware's calibration is the host simulator's (the build's table) to within what
    // one tick of shift and the record's rounding change.
    let memo = sim_host::fingers::FingerKind::Memo.effects();
    let (host, _) =
        calibrate_simulated(&CALIBRATION_TAXELS[1..2], FINGER_SEED, memo).expect("host");
    let unlike = sim_host::fingers::FingerKind::LinearSaturating;
    let (host_other, _) =
        calibrate_simulated(&CALIBRATION_TAXELS[..1], FINGER_SEED, unlike.effects()).expect("host");
    assert_eq!(other.taxels.len(), 1);
    for (fw, h) in table.taxels.iter().zip(&host.taxels) {
        let (e, g) = (&fw.element, &h.element);
        assert!(
            the_hosts_calibration(e, g),
            "{:?}: {e:?} vs {g:?}",
            fw.taxel
        );
    }
    // On the other finger the record pins G₁ more tightly than how the slow branches share
    // the creep (G₂, α and N₁ may land apart from records a tick apart): G₁ alone is
    // compared, the rest is judged by the estimates below.
    for (fw, h) in other.taxels.iter().zip(&host_other.taxels) {
        let (e, g) = (&fw.element, &h.element);
        assert!(
            relative_error(e.g1.stiffness(30.0), g.g1.stiffness(30.0)) < 0.02,
            "{:?}: {e:?} vs {g:?}",
            fw.taxel
        );
    }
    // And it does what calibration is for: the observer, calibrated, on the memo's protocols.
    let scores =
        sim_host::estimator_comparison::compare_with(&table, Vec::new(), FINGER_SEED, memo)
            .expect("estimators");
    eprintln!("{}", sim_host::estimator_comparison::render(&scores));
    for row in &scores.pseudo_random_per_taxel_g {
        assert!(row[3] <= 0.2, "{row:?}");
    }
    assert!(
        scores.calibrated_g[0][3] < 0.2 * scores.nominal_g[0][3],
        "{:?} vs {:?}",
        scores.calibrated_g[0],
        scores.nominal_g[0]
    );
    // On the finger unlike the memo's: the observer calibrated on the firmware's record
    // within the 0.3 g target on pseudo-random (the nominal models: about 3.5 g).
    let scores = sim_host::estimator_comparison::compare_with(
        &other,
        Vec::new(),
        FINGER_SEED,
        unlike.effects(),
    )
    .expect("estimators");
    eprintln!("{}", sim_host::estimator_comparison::render(&scores));
    assert!(
        scores.calibrated_g[0][3] < 0.3 && scores.calibrated_g[0][3] < 0.2 * scores.nominal_g[0][3],
        "{:?} vs {:?}",
        scores.calibrated_g[0],
        scores.nominal_g[0]
    );
}

/// Issue 13's identification end to end on the firmware: the QEMU firmware runs the
/// applicator's excitation at the design's six preloads (`session=excitation`), the host
/// decodes the log and designs the controller from it as `tactile design --records` does. The
/// table is the one the firmware build carries (`boards/controller/table.bin`, designed on the
/// host simulator): to the byte from the decoded ticks, and within 1 % from the CSV records
/// (their rounding: 1 mg of gauge, 0.1 mg of drive).
#[test]
#[ignore = "builds the firmware and runs QEMU: scripts/test-all.sh runs it with --ignored"]
fn the_controller_is_designed_from_the_firmwares_excitation() {
    use sim_host::design::{
        design_identified, excited_of_record, excited_of_run, identified_from, Excited,
    };
    use tactile_core::designed::DesignedConfig;
    use tactile_firmware::EXCITATION_SESSION;
    let Some((elf, dir)) = firmware_for("identification test") else {
        return;
    };
    let sessions = each_run(
        &elf,
        &dir,
        "excitation",
        0..EXCITATION_SESSION.len(),
        QEMU_TIMEOUT,
    );
    let rig = RigConfig {
        scan_array: false,
        ..Default::default()
    };
    let out = dir.join("excitation");
    let (mut from_ticks, mut from_csv) = (Vec::new(), Vec::new());
    let runs = sessions.iter().flat_map(|s| &s.runs);
    assert_eq!(runs.clone().count(), EXCITATION_SESSION.len());
    for (run, spec) in runs.zip(&EXCITATION_SESSION) {
        assert_eq!(run.name, spec.name);
        let end = run.end.expect("RunEnd");
        assert_eq!((end.control_frames_dropped, end.overruns), (0, 0));
        let ticks = run.tick_records();
        from_ticks.push(
            excited_of_run(&ticks, spec.protocol, &rig.firmware.actuator)
                .unwrap_or_else(|e| panic!("{}: {e}", run.name)),
        );
        let written = tactile_decode::write_run(&out, run, &[]).expect("records written");
        let rec = tactile_record::read_record(&written[0]).expect("record read back");
        from_csv.push(excited_of_record(&rec).unwrap_or_else(|e| panic!("{}: {e}", run.name)));
    }
    let design = |e: &[Excited]| {
        design_identified(identified_from(e, Vec::new()).expect("identified"), &rig)
            .expect("designed")
            .design
            .config
    };
    let committed = std::fs::read(workspace().join("boards/controller/table.bin")).expect("table");
    let exact = design(&from_ticks);
    assert_eq!(
        exact.encode().expect("encoded").to_vec(),
        committed,
        "the table from the firmware's records is not the build's"
    );
    let (csv, build) = (
        design(&from_csv),
        DesignedConfig::decode(&committed).expect("the build's table"),
    );
    let fields = |c: &DesignedConfig| -> Vec<f32> {
        let mut v = vec![c.kp, c.ki_per_s, c.friction_g, c.reference_hz];
        v.extend([c.approach_hold_g, c.approach_push_g, c.approach_brake_g]);
        v.extend(c.feedback_filter);
        for p in &c.schedule[..usize::from(c.points)] {
            v.extend([p.load_g, p.feedback, p.gauge_s2]);
            v.extend(p.c);
        }
        v
    };
    assert_eq!(csv.points, build.points);
    let worst = fields(&csv)
        .iter()
        .zip(fields(&build))
        .map(|(a, b)| (a - b).abs() / a.abs().max(b.abs()).max(1e-6))
        .fold(0.0f32, f32::max);
    eprintln!("the design from the CSV records: worst relative difference {worst:.2e}");
    assert!(worst < 0.01, "{csv:?}\nvs\n{build:?}");
}

/// Issue 14 under QEMU: the firmware driven by commands from a script (what a board's RTT
/// down-channel carries), each answered with its sequence number: taken, or refused with the
/// reason and nothing changed; a corrupt frame between them dropped without an answer; a
/// hold under the designed controller chosen by command, stopped by command; a run asked for
/// by command recorded as the host rig runs it, to the bit.
#[test]
#[ignore = "builds the firmware and runs QEMU: scripts/test-all.sh runs it with --ignored"]
fn a_session_driven_by_commands() {
    use tactile_core::command::{Command, ControllerChoice, Run, TableKind};
    use tactile_core::estimator::EstimatorKind;
    let Some((elf, dir)) = firmware_for("command session test") else {
        return;
    };
    let frame = |seq: u16, c: Command| c.frame(seq).as_bytes().to_vec();
    let pseudo_random = Run::PseudoRandom {
        seed: 1989,
        duration_s: 2.0,
    };
    let mut corrupt = frame(99, Command::Stop);
    corrupt[3] ^= 0x10;
    // An opcode no board knows, framed correctly.
    let unknown = {
        let mut f = frame(11, Command::Stop);
        f[4] = 42;
        let crc = crc_16(&f[1..5]);
        f[5..7].copy_from_slice(&crc.to_le_bytes());
        f
    };
    let mut script: Vec<(u32, Vec<u8>)> = vec![
        (
            5,
            [
                frame(1, Command::Controller(ControllerChoice::Designed)),
                frame(2, Command::Estimator(EstimatorKind::Elastic)),
            ]
            .concat(),
        ),
        (10, frame(3, Command::Hold { force_g: 30.0 })),
        (1500, frame(4, Command::Hold { force_g: 500.0 })),
        (
            1600,
            [vec![1, 2, 0xA5, 3], corrupt, frame(5, Command::ClearFaults)].concat(),
        ),
        (2000, frame(6, Command::Stop)),
        (
            2100,
            frame(
                7,
                Command::LoadTable {
                    table: TableKind::Calibration,
                    len: 100,
                },
            ),
        ),
        (
            2200,
            [
                frame(8, Command::Controller(ControllerChoice::A1)),
                frame(9, Command::Run(pseudo_random)),
            ]
            .concat(),
        ),
        (
            5000,
            frame(10, Command::Run(Run::Excitation { preload_g: 500.0 })),
        ),
        (5100, unknown),
    ];
    // A calibration table of the build's first two taxels only, loaded in chunks one tick
    // apart before the run: the run's other taxels fall back to the nominal models, so its
    // frames tell this table from the build's.
    let loaded = first_taxels_of_the_builds_table(2);
    let chunks = Command::table_chunks(TableKind::Calibration, &loaded);
    let mut loading: Vec<(u32, Vec<u8>)> = chunks
        .enumerate()
        .map(|(k, c)| (2110 + k as u32, frame(20 + k as u16, c)))
        .collect();
    let load_seq = 20 + loading.len() as u16;
    let load = Command::LoadTable {
        table: TableKind::Calibration,
        len: loaded.len() as u16,
    };
    loading.push((2110 + u32::from(load_seq - 20), frame(load_seq, load)));
    assert!(loading.last().is_some_and(|(tick, _)| *tick < 2200));
    let at = script
        .iter()
        .position(|(tick, _)| *tick == 2200)
        .expect("the run");
    script.splice(at..at, loading);
    let path = dir.join("commands.bin");
    let bytes = tactile_decode::transport::script_bytes(&script).expect("a script");
    std::fs::write(&path, &bytes).expect("script written");
    let log = dir.join("commands.defmt");
    let append = format!("session=commands script={}", path.display());
    assert!(
        run_qemu(&elf, &log, &append),
        "the firmware failed (`{append}`)"
    );
    let session = decode_log(&elf, &log);
    assert!(session.errors.is_empty(), "{:?}", session.errors);
    let refused = |s: &str| Some(s.to_string());
    assert_eq!(
        session.replies,
        [
            (1, None),
            (2, None),
            (3, None),
            (4, refused("OutOfRange { param: ForceG }")),
            (5, None),
            (6, None),
            (7, refused("TableRefused")),
        ]
        .into_iter()
        .chain((20..=load_seq).map(|seq| (seq, None)))
        .chain([
            (8, None),
            (9, None),
            (10, refused("OutOfRange { param: PreloadG }")),
            (11, refused("UnknownCommand { op: 42 }")),
        ])
        .collect::<Vec<_>>()
    );
    let names: Vec<&str> = session.runs.iter().map(|r| r.name.as_str()).collect();
    assert_eq!(names, ["hold", "pseudo-random"]);
    // The hold: 30 g under the designed controller, through the refused 500 g, until stopped.
    let hold = &session.runs[0];
    let end = hold.end.expect("the hold ended");
    assert_eq!((hold.start_tick, end.end_tick), (10, 2000));
    let records = hold.tick_records();
    let last: Vec<f64> = records[records.len() - 500..]
        .iter()
        .map(|r| f64::from(r.true_force_g))
        .collect();
    let mean = last.iter().sum::<f64>() / last.len() as f64;
    assert!((mean - 30.0).abs() < 0.5, "the hold at {mean:.2} g");
    // The run asked for by command is the host rig's, to the bit, frames included: the host
    // takes the script's commands up to the run into a port of its own and builds the run
    // with the estimator and the calibration table they set.
    let port = commands_up_to(&script, 2200);
    assert_eq!(port.calibration_table(), Some(loaded.as_slice()));
    let spec = tactile_firmware::FilRun::commanded(pseudo_random).after_commands(port);
    assert_eq!(spec.estimator, Some(EstimatorKind::Elastic));
    is_the_rigs_to_the_bit(&session.runs[1], &spec);
}

/// The build's calibration table cut to its first `n` taxels.
fn first_taxels_of_the_builds_table(n: usize) -> Vec<u8> {
    use tactile_core::calibration::{CalibrationTable, TableView};
    let view = TableView::check(&tactile_firmware::CALIBRATION_TABLE).expect("the build's table");
    let mut table = CalibrationTable::default();
    for m in view.models().take(n) {
        table.taxels.push(m).expect("room");
    }
    let mut bytes = vec![0; table.encoded_len()];
    let len = table.encode(&mut bytes).expect("encoded");
    bytes.truncate(len);
    bytes
}

/// A port on the host that took the script's commands due up to `tick` (inclusive), as the
/// QEMU board's did; kept for the rest of the test process (a run's table borrows it).
fn commands_up_to(
    script: &[(u32, Vec<u8>)],
    tick: u32,
) -> &'static tactile_firmware::CommandPort<{ tactile_firmware::LOADED_TABLE_BYTES }> {
    let max_force_g = tactile_core::tasks::FirmwareConfig::MEMO
        .supervisor
        .command_max_g;
    let mut port = tactile_firmware::CommandPort::new(max_force_g, tactile_firmware::HOLD_S);
    for (_, bytes) in script.iter().filter(|(t, _)| *t <= tick) {
        port.poll(bytes, &tactile_firmware::CONTROLLER_TABLE, |_, _| {});
    }
    Box::leak(Box::new(port))
}

/// CRC-16/IBM-3740 (the command frames'), to build a frame the encoder would not.
fn crc_16(bytes: &[u8]) -> u16 {
    let mut crc = 0xFFFFu16;
    for b in bytes {
        crc ^= u16::from(*b) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x1021
            } else {
                crc << 1
            };
        }
    }
    crc
}

/// `tactile board`'s path: the QEMU firmware through the transport, its stream
/// decoded live in the pieces it arrives in, is the session a batch decode of the same bytes
/// gives, and so is a replay of those bytes in 7-byte pieces; the commands `tactile board run`
/// sends are taken, and the run they asked for is the host rig's to the bit.
#[test]
#[ignore = "builds the firmware and runs QEMU: scripts/test-all.sh runs it with --ignored"]
fn the_board_session_decodes_live_as_in_batch() {
    use sim_host::board_link::{script, Action, BoardProtocol};
    use tactile_decode::transport::{Qemu, Replay, Transport};
    use tactile_decode::{follow, Live};
    let Some((elf, dir)) = firmware_for("board session test") else {
        return;
    };
    /// A transport that keeps what it passes on.
    struct Tee<T> {
        inner: T,
        bytes: Vec<u8>,
    }
    impl<T: Transport> Transport for Tee<T> {
        fn receive(&mut self) -> std::io::Result<Option<Vec<u8>>> {
            let got = self.inner.receive()?;
            if let Some(b) = &got {
                self.bytes.extend(b);
            }
            Ok(got)
        }
        fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
            self.inner.send(bytes)
        }
    }
    let action = Action::Run {
        protocol: BoardProtocol::PseudoRandom,
        duration_s: 2.0,
        load_g: 50.0,
        taxel: tactile_core::tactile::TaxelId::new(3, 2).expect("a taxel"),
        designed: false,
    };
    let elf_bytes = std::fs::read(&elf).expect("elf");
    let table = tactile_decode::table(&elf_bytes, &elf).expect("defmt table");
    let qemu = Qemu::start(&elf, &script(&action), &dir.join("board.bin")).expect("qemu starts");
    let mut tee = Tee {
        inner: qemu,
        bytes: Vec::new(),
    };
    let mut pieces = 0;
    let live = follow(&mut tee, Live::new(&table, Path::new("qemu")), |_| {
        pieces += 1
    })
    .expect("a session");
    let log = Path::new("board.defmt");
    let batch = tactile_decode::decode(&elf_bytes, &elf, &tee.bytes, log).expect("decoded");
    let same = |a: &tactile_decode::Session, b: &tactile_decode::Session| {
        assert_eq!(a.runs.len(), b.runs.len());
        for (x, y) in a.runs.iter().zip(&b.runs) {
            assert_eq!(x.name, y.name);
            assert!(x.ticks == y.ticks, "{}: the control ticks differ", x.name);
            // By their text: an estimate may be NaN (no calibration), never equal to itself.
            assert!(
                format!("{:?}", x.frames) == format!("{:?}", y.frames),
                "{}: the taxel frames differ",
                x.name
            );
            assert_eq!(x.end, y.end);
        }
        assert_eq!(
            (&a.replies, &a.notes, &a.errors, a.trailing_bytes),
            (&b.replies, &b.notes, &b.errors, b.trailing_bytes)
        );
        assert_eq!((a.control_seq, a.taxel_seq), (b.control_seq, b.taxel_seq));
    };
    same(&live, &batch);
    let replayed = follow(
        &mut Replay::new(tee.bytes.clone(), 7),
        Live::new(&table, log),
        |_| {},
    )
    .expect("replayed");
    same(&replayed, &batch);
    // A live board's path (`tactile board --probe`): the same bytes from a board that never
    // ends its stream; `drive` sends the script's commands when due and ends the session on
    // its own, once every command is answered, no run is in progress and the run's time is up.
    struct Board {
        bytes: Vec<u8>,
        at: usize,
        sent: Vec<u8>,
    }
    impl Transport for Board {
        fn receive(&mut self) -> std::io::Result<Option<Vec<u8>>> {
            let end = (self.at + 512).min(self.bytes.len());
            let piece = self.bytes[self.at..end].to_vec();
            self.at = end;
            // Once its bytes are out, silence (not an end), as a board between runs. Until
            // then no wait: the session ends only once nothing has arrived for a while (the
            // scan's frames after the run's end belong to the run; on a loaded machine their
            // decoding came after the settling time).
            if piece.is_empty() {
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
            Ok(Some(piece))
        }
        fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
            self.sent.extend(bytes);
            Ok(())
        }
    }
    let mut board = Board {
        bytes: tee.bytes.clone(),
        at: 0,
        sent: Vec::new(),
    };
    let until = tactile_decode::Until {
        settle: std::time::Duration::from_millis(300),
        timeout: std::time::Duration::from_secs(20),
    };
    let t0 = std::time::Instant::now();
    let driven = tactile_decode::drive(
        &mut board,
        &script(&action),
        Live::new(&table, log),
        until,
        |_| {},
    )
    .expect("driven");
    same(&driven, &batch);
    assert_eq!(
        board.sent,
        script(&action)
            .into_iter()
            .flat_map(|(_, b)| b)
            .collect::<Vec<u8>>()
    );
    assert!(t0.elapsed() < std::time::Duration::from_secs(10));
    // A probe attached mid-run: the stream from the middle, at the first frame boundary;
    // what belongs to the run begun before is left out, not an error.
    let middle = sim_host::probe::after_first_delimiter(&tee.bytes[tee.bytes.len() / 2..])
        .expect("a delimiter");
    let mut joined = Live::joined(&table, log);
    joined.push(middle).expect("a joined stream decodes");
    let joined = joined.finish();
    assert!(joined.runs.is_empty() && joined.before_first_run > 500);
    // A board that answers nothing: an error once the timeout is up, not a hang.
    let mut mute = Board {
        bytes: Vec::new(),
        at: 0,
        sent: Vec::new(),
    };
    let quick = tactile_decode::Until {
        settle: std::time::Duration::from_millis(10),
        timeout: std::time::Duration::from_millis(200),
    };
    let e = tactile_decode::drive(
        &mut mute,
        &script(&action),
        Live::new(&table, log),
        quick,
        |_| {},
    )
    .expect_err("no answer");
    assert!(e.contains("answered 0 of 2 commands"), "{e}");
    eprintln!(
        "board session: {} bytes in {pieces} pieces decoded live",
        tee.bytes.len()
    );
    assert_eq!(batch.replies, [(1, None), (2, None)]);
    assert_eq!(batch.runs.len(), 1);
    let spec = tactile_firmware::FilRun::commanded(tactile_core::command::Run::PseudoRandom {
        seed: 1989,
        duration_s: 2.0,
    });
    is_the_rigs_to_the_bit(&batch.runs[0], &spec);
}

/// Issue 14's calibration table loaded at run time: a board with a blank calibration sector
/// (`calibration=none`) runs on the nominal models; the build's table sent in chunks and loaded
/// by command, the next run's array estimates are those of a board that carries the table, to
/// the bit, and grams away from the nominal ones.
#[test]
#[ignore = "builds the firmware and runs QEMU: scripts/test-all.sh runs it with --ignored"]
fn a_calibration_table_loaded_by_command_estimates_as_the_built_in_one() {
    use tactile_core::command::{Command, Run, TableKind};
    let Some((elf, dir)) = firmware_for("calibration load test") else {
        return;
    };
    let frame = |seq: u16, c: Command| c.frame(seq).as_bytes().to_vec();
    let run = Command::Run(Run::PseudoRandom {
        seed: 1989,
        duration_s: 2.0,
    });
    let table = tactile_firmware::CALIBRATION_TABLE;
    let mut script: Vec<(u32, Vec<u8>)> = vec![(0, frame(1, run))];
    for (i, c) in Command::table_chunks(TableKind::Calibration, &table).enumerate() {
        script.push((2100 + i as u32, frame(10 + i as u16, c)));
    }
    let load = Command::LoadTable {
        table: TableKind::Calibration,
        len: table.len() as u16,
    };
    script.push((2200, frame(100, load)));
    script.push((2300, frame(101, run)));
    let session = |name: &str, words: &str, script: &[(u32, Vec<u8>)]| {
        let path = dir.join(format!("{name}.bin"));
        let bytes = tactile_decode::transport::script_bytes(script).expect("a script");
        std::fs::write(&path, &bytes).expect("script written");
        let log = dir.join(format!("{name}.defmt"));
        let append = format!("session=commands script={} {words}", path.display());
        assert!(
            run_qemu(&elf, &log, &append),
            "the firmware failed (`{append}`)"
        );
        decode_log(&elf, &log)
    };
    let blank = session("calibration-load", "calibration=none", &script);
    let built_in = session("calibration-built-in", "", &script[..1]);
    assert!(blank.errors.is_empty() && built_in.errors.is_empty());
    assert!(
        blank.replies.iter().all(|r| r.1.is_none()),
        "{:?}",
        blank.replies
    );
    assert_eq!(blank.runs.len(), 2);
    let estimates = |run: &tactile_decode::Run| -> Vec<f32> {
        run.frames
            .iter()
            .map(|(_, e)| e.expect("an array estimate").total_force_g)
            .collect()
    };
    let (nominal, loaded, reference) = (
        estimates(&blank.runs[0]),
        estimates(&blank.runs[1]),
        estimates(&built_in.runs[0]),
    );
    assert_eq!(format!("{loaded:?}"), format!("{reference:?}"));
    let gaps: Vec<f64> = nominal
        .iter()
        .zip(&reference)
        .map(|(a, b)| f64::from((a - b).abs()))
        .collect();
    let worst = gaps.iter().copied().fold(0.0, f64::max);
    eprintln!(
        "total force of the array, nominal models vs the loaded table: {:.2} g apart on average, {worst:.2} g at most, over {} frames",
        gaps.iter().sum::<f64>() / gaps.len() as f64,
        gaps.len()
    );
    // The calibrated taxels are off the probe's: the table moves the located contact's force
    // (0.38 g at most), by far more than it moved the probe's own estimate (0.01 g: no record
    // for it in the table).
    assert!(
        worst > 0.3,
        "the table changed the estimates by {worst} g at most"
    );
}

/// `tactile board calibrate` on the QEMU firmware: the calibration protocol run by
/// command over a taxel, its record fitted into a table on the host (`tactile calibrate`'s
/// code), the table loaded into a board by command and a run made on it; every command taken.
#[test]
#[ignore = "builds the firmware and runs QEMU: scripts/test-all.sh runs it with --ignored"]
fn the_board_calibrates_a_taxel_by_command() {
    use sim_host::board_link::{run, Action, Target};
    use tactile_core::tactile::TaxelId;
    let Some((elf, dir)) = firmware_for("board calibration test") else {
        return;
    };
    let out = dir.join("board-calibrate");
    let taxel = TaxelId::new(4, 2).expect("a taxel");
    let action = Action::Calibrate {
        taxels: vec![taxel],
    };
    let report = run(&elf, Target::Qemu, &action, &out).unwrap_or_else(|e| panic!("{e}"));
    eprintln!("{report}");
    assert!(report.contains("command 1: taken"), "{report}");
    assert!(!report.contains("refused"), "{report}");
    // The record of the run, named after its taxel, and the table fitted to it: one taxel.
    let record = tactile_record::read_record(&out.join("calibration-4-2.csv")).expect("record");
    assert!(record.force_g.len() >= 121_000, "{}", record.force_g.len());
    let table = std::fs::read(out.join("calibration-table.bin")).expect("table");
    let view = tactile_core::calibration::TableView::check(&table).expect("a valid table");
    assert_eq!(view.len(), 1);
    // The host simulator's calibration of the same taxel of the commanded run's finger (the
    // board's own, seed 1; the calibration session's is seed 7): as close as the session's.
    let fw = tactile_core::calibration::CalibrationTable::decode(&table).expect("decoded");
    let seed = sim_host::rig::RigConfig::default().seed;
    let memo = sim_host::fingers::FingerKind::Memo.effects();
    let (host, _) = sim_host::dynamic_calibration::calibrate_simulated(&[taxel], seed, memo)
        .expect("host calibration");
    let (e, g) = (&fw.taxels[0].element, &host.taxels[0].element);
    assert!(the_hosts_calibration(e, g), "{e:?} vs {g:?}");
    // Loaded by the chunks and the load command (numbered on from the run's), then the run.
    let chunks = table.len().div_ceil(tactile_core::command::CHUNK_BYTES);
    let last = 1 + chunks + 2;
    assert!(
        report.contains(&format!("command {last}: taken")),
        "{report}"
    );
    // Two seconds at 1 kHz (the record starts at the second tick: the first senses nothing).
    let check = tactile_record::read_record(&out.join("pseudo-random.csv")).expect("run");
    assert!(
        (1990..=2000).contains(&check.force_g.len()),
        "{}",
        check.force_g.len()
    );
}
