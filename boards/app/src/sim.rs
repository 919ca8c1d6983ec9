//! The simulated board of `tactile-plant` behind the firmware's hardware traits, for the
//! firmware-in-the-loop build (QEMU) and the host check that the task bodies reproduce the
//! simulator's rig.

use tactile_core::command::Run;
use tactile_core::profile::{Protocol, DESIGN_PRELOADS_G};
use tactile_core::tactile::TaxelId;
use tactile_core::tasks::FirmwareConfig;
use tactile_core::viscoelastic::NonlinearMk;
use tactile_plant::finger::{
    Effects, CALIBRATION_FINGER_SEED, CALIBRATION_TAXELS, LINEAR_SATURATING_ELEMENT,
};
use tactile_plant::rig::{FaultInjection, InjectedFault, RigConfig};

use crate::commands::CommandPort;
use crate::table::{CALIBRATION_TABLE, CONTROLLER_TABLE};
use tactile_core::designed::DesignedConfig;
use tactile_core::estimator::EstimatorKind;

/// One run of the firmware-in-the-loop session: a protocol on a fresh simulated board, with
/// the fault that board injects. The QEMU firmware runs [`FIL_SESSION`] in order; the QEMU
/// test runs the same table on the host simulator and compares.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilRun {
    /// The simulator's scenario name for the fault-free runs; `fault-…` for the others.
    pub name: &'static str,
    pub protocol: Protocol,
    pub fault: Option<FaultInjection>,
    /// The probe over another taxel of another finger (taxel, finger seed); the simulator's
    /// default rig otherwise.
    pub finger: Option<(TaxelId, u64)>,
    /// The element the finger's taxels vary about, for a finger unlike the memo's.
    pub element: Option<NonlinearMk>,
    /// Run the designed force controller of [`CONTROLLER_TABLE`] instead of A1 (A1 if the
    /// table is refused: the QEMU test checks it is not).
    pub designed: bool,
    /// The estimator every taxel of the array runs (a command's choice); `None`: each taxel's
    /// own.
    pub estimator: Option<EstimatorKind>,
    /// The calibration table in place of [`CALIBRATION_TABLE`] (one loaded by command).
    pub calibration: Option<&'static [u8]>,
}

impl FilRun {
    /// The rig this run's board is built from (the simulator's own rig with the table this
    /// build carries, plus the fault and the probe's place).
    pub fn rig(&self) -> RigConfig {
        let defaults = RigConfig::default();
        let firmware = FirmwareConfig {
            calibration: self.calibration.unwrap_or(&CALIBRATION_TABLE),
            array_estimator: self.estimator.or(defaults.firmware.array_estimator),
            designed: if self.designed {
                DesignedConfig::decode(&CONTROLLER_TABLE).ok()
            } else {
                None
            },
            ..defaults.firmware
        };
        let base = RigConfig {
            firmware,
            fault: self.fault,
            effects: Effects {
                element: self.element,
                ..defaults.effects
            },
            ..defaults
        };
        match self.finger {
            Some((probe, seed)) => RigConfig {
                firmware: FirmwareConfig { probe, ..firmware },
                seed,
                ..base
            },
            None => base,
        }
    }
}

const fn calibration_run(name: &'static str, taxel: TaxelId) -> FilRun {
    FilRun {
        name,
        protocol: Protocol::CALIBRATION,
        fault: None,
        finger: Some((taxel, CALIBRATION_FINGER_SEED)),
        element: None,
        designed: false,
        estimator: None,
        calibration: None,
    }
}

/// The QEMU calibration session (`-append "session=calibration"`): the calibration protocol
/// with the probe over the first two calibration taxels of the simulated finger in turn, then
/// over the first of them on a finger whose springs stiffen by other laws
/// ([`LINEAR_SATURATING_ELEMENT`]), recorded over defmt for `tactile calibrate`. (Two of the
/// four: each run simulates the protocol's 122 s, about 170 s of QEMU's time.)
pub const CALIBRATION_SESSION: [FilRun; 3] = {
    let [a, b, ..] = CALIBRATION_TAXELS;
    [
        calibration_run("calibrate-3-2", a),
        calibration_run("calibrate-1-5", b),
        FilRun {
            element: Some(LINEAR_SATURATING_ELEMENT),
            ..calibration_run("calibrate-3-2-linear-saturating", a)
        },
    ]
};

const fn excitation_run(name: &'static str, preload_g: f32) -> FilRun {
    FilRun {
        name,
        protocol: Protocol::design_excitation(preload_g),
        fault: None,
        finger: None,
        element: None,
        designed: false,
        estimator: None,
        calibration: None,
    }
}

/// The QEMU identification session (`-append "session=excitation"`): the applicator's
/// excitation at each of the design's preloads ([`DESIGN_PRELOADS_G`]) under A1, recorded over
/// defmt for `tactile design --records` (9.5 s each).
pub const EXCITATION_SESSION: [FilRun; 6] = {
    let [a, b, c, d, e, f] = DESIGN_PRELOADS_G;
    [
        excitation_run("excitation-10g", a),
        excitation_run("excitation-20g", b),
        excitation_run("excitation-35g", c),
        excitation_run("excitation-50g", d),
        excitation_run("excitation-75g", e),
        excitation_run("excitation-100g", f),
    ]
};

/// The words of a semihosting command line (the ELF's path, then `-append`'s words), up to its
/// NUL; none if it is not UTF-8.
pub fn cmdline_words(cmdline: &[u8]) -> impl Iterator<Item = &str> {
    let end = cmdline
        .iter()
        .position(|&b| b == 0)
        .unwrap_or(cmdline.len());
    cmdline
        .get(..end)
        .and_then(|b| core::str::from_utf8(b).ok())
        .unwrap_or("")
        .split_ascii_whitespace()
}

/// The sessions the QEMU firmware can run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Session {
    /// [`FIL_SESSION`] (the default).
    FirmwareInTheLoop,
    /// [`CALIBRATION_SESSION`] (`session=calibration`).
    Calibration,
    /// [`EXCITATION_SESSION`] (`session=excitation`).
    Excitation,
    /// Driven by commands (`session=commands script=PATH`): no runs of its own; each run is
    /// one a command asked for ([`FilRun::commanded`]).
    Commands,
}

impl Session {
    pub fn runs(self) -> &'static [FilRun] {
        match self {
            Session::FirmwareInTheLoop => &FIL_SESSION,
            Session::Calibration => &CALIBRATION_SESSION,
            Session::Excitation => &EXCITATION_SESSION,
            Session::Commands => &[],
        }
    }

    /// The session's runs, or only run `only` of them.
    pub fn runs_of(self, only: Option<usize>) -> &'static [FilRun] {
        let all = self.runs();
        only.and_then(|n| all.get(n..=n)).unwrap_or(all)
    }
}

/// Which session the QEMU firmware runs, from its semihosting command line.
pub fn session_from_cmdline(cmdline: &[u8]) -> Session {
    cmdline_words(cmdline)
        .find_map(|w| match w {
            "session=calibration" => Some(Session::Calibration),
            "session=excitation" => Some(Session::Excitation),
            "session=commands" => Some(Session::Commands),
            _ => None,
        })
        .unwrap_or(Session::FirmwareInTheLoop)
}

/// The command script's path (`script=PATH`) on a semihosting command line.
pub fn script_from_cmdline(cmdline: &[u8]) -> Option<&str> {
    cmdline_words(cmdline).find_map(|w| w.strip_prefix("script="))
}

/// The applicator file's path (`applicator=PATH`, the form `tactile applicator` writes) on a
/// semihosting command line.
pub fn applicator_from_cmdline(cmdline: &[u8]) -> Option<&str> {
    cmdline_words(cmdline).find_map(|w| w.strip_prefix("applicator="))
}

impl FilRun {
    /// A commanded hold of `force_g` on the simulated board (the build's board, as a command
    /// session starts it).
    pub fn hold(force_g: f32) -> FilRun {
        FilRun {
            name: "hold",
            protocol: crate::commands::hold(force_g),
            fault: None,
            finger: None,
            element: None,
            designed: false,
            estimator: None,
            calibration: None,
        }
    }

    /// The run a command asks for, on the simulated board: the calibration with the probe over
    /// its taxel of the same finger.
    pub fn commanded(run: Run) -> FilRun {
        FilRun {
            name: run.name(),
            protocol: run.protocol(),
            finger: match run {
                Run::Calibration { taxel } => Some((taxel, RigConfig::default().seed)),
                _ => None,
            },
            ..FilRun::hold(0.0)
        }
    }

    /// This commanded run as the board runs it after the commands `port` took: the force law
    /// and the array's estimator they chose, and the calibration table they loaded in place of
    /// the build's (the board's scan task rebuilds its estimators from the same table). A
    /// controller table loaded by command is not carried: `designed` runs the build's.
    pub fn after_commands<const CAL: usize>(self, port: &'static CommandPort<CAL>) -> FilRun {
        let chosen = port.firmware(FirmwareConfig::MEMO, &CONTROLLER_TABLE);
        FilRun {
            designed: chosen.designed.is_some(),
            estimator: chosen.array_estimator,
            calibration: port.calibration_table(),
            ..self
        }
    }
}

/// The one run of the session that `run=N` (0-based) names, so that a test can run a long
/// session's runs in QEMUs side by side; none (the whole session) without it, or when it is
/// malformed or out of range.
pub fn only_run_from_cmdline(cmdline: &[u8]) -> Option<usize> {
    let n = cmdline_words(cmdline).find_map(|w| w.strip_prefix("run=")?.parse::<usize>().ok())?;
    (n < session_from_cmdline(cmdline).runs().len()).then_some(n)
}

/// The runs the QEMU firmware runs for its command line: the session's, or the one `run=N`
/// names.
pub fn runs_from_cmdline(cmdline: &[u8]) -> &'static [FilRun] {
    session_from_cmdline(cmdline).runs_of(only_run_from_cmdline(cmdline))
}

/// Length of the pseudo-random run, s (at least 10 s per protocol).
pub const FIL_PSEUDO_RANDOM_S: f32 = 10.0;

/// The fault runs hold 30 g (reached by 0.3 s at the step slew) and inject at this time.
pub const FIL_FAULT_AT_S: f64 = 1.5;

/// A 30 g hold for the fault runs: 0.2 s lead, 2.5 s on, 0.3 s off (3 s in all).
pub const FIL_FAULT_HOLD: Protocol = Protocol::Step {
    load_g: 30.0,
    lead_s: 0.2,
    on_s: 2.5,
    off_s: 0.3,
};

const fn fault_run(name: &'static str, fault: InjectedFault) -> FilRun {
    FilRun {
        name,
        protocol: FIL_FAULT_HOLD,
        fault: Some(FaultInjection {
            fault,
            at_s: FIL_FAULT_AT_S,
        }),
        finger: None,
        element: None,
        designed: false,
        estimator: None,
        calibration: None,
    }
}

/// The QEMU session, in order: the memo's force steps (10.5 s), the memo's pseudo-random
/// protocol (seed 1989) cut to [`FIL_PSEUDO_RANDOM_S`] (as `tactile experiment pseudo-random`
/// runs it with that duration), then three injected faults: a sensor fault (the gauge's wire
/// breaks), an implausible reading (an 80 g spike) and a timing fault (the control task really
/// misses a deadline on the Cortex-M4F).
pub const FIL_SESSION: [FilRun; 6] = [
    FilRun {
        name: "force-steps",
        protocol: Protocol::FORCE_STEPS_MEMO,
        fault: None,
        finger: None,
        element: None,
        designed: false,
        estimator: None,
        calibration: None,
    },
    FilRun {
        name: "pseudo-random",
        protocol: pseudo_random(FIL_PSEUDO_RANDOM_S),
        fault: None,
        finger: None,
        element: None,
        designed: false,
        estimator: None,
        calibration: None,
    },
    FilRun {
        name: "force-steps-designed",
        protocol: Protocol::FORCE_STEPS_MEMO,
        fault: None,
        finger: None,
        element: None,
        designed: true,
        estimator: None,
        calibration: None,
    },
    fault_run("fault-gauge-disconnected", InjectedFault::GaugeDisconnected),
    fault_run("fault-force-spike", InjectedFault::ForceSpike { g: 80.0 }),
    fault_run("fault-deadline-overrun", InjectedFault::DeadlineOverrun),
];

const fn pseudo_random(duration_s: f32) -> Protocol {
    Protocol::pseudo_random_memo(1989, duration_s)
}

/// A deliberate crash the QEMU firmware can be asked for (semihosting command line, QEMU's
/// `-append`), to show its panic and HardFault handlers zero the actuator before anything else.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DeliberateCrash {
    /// `panic-at-tick=N`: the control task panics at board tick N.
    Panic { tick: u32 },
    /// `hardfault-at-tick=N`: the control task executes a permanently undefined instruction.
    HardFault { tick: u32 },
}

impl DeliberateCrash {
    /// The board tick the crash happens at.
    pub fn tick(self) -> u32 {
        match self {
            DeliberateCrash::Panic { tick } | DeliberateCrash::HardFault { tick } => tick,
        }
    }

    /// Reads the request from a semihosting command line (the ELF's path, then `-append`'s
    /// words, NUL-terminated). Unknown words are ignored; a malformed number is no request.
    pub fn from_cmdline(cmdline: &[u8]) -> Option<DeliberateCrash> {
        cmdline_words(cmdline).find_map(|word| {
            let (key, value) = word.split_once('=')?;
            let tick = value.parse().ok()?;
            match key {
                "panic-at-tick" => Some(DeliberateCrash::Panic { tick }),
                "hardfault-at-tick" => Some(DeliberateCrash::HardFault { tick }),
                _ => None,
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Controller, Scanner};
    use tactile_core::telemetry::FaultFlags;
    use tactile_core::telemetry::TaxelFrame;
    use tactile_plant::hardware::SimHardware;
    use tactile_plant::rig::Rig;

    /// The task bodies on the simulated board, in the order the QEMU build runs them (control,
    /// one period of physics, four scan steps), against the simulator's rig: the same numbers
    /// to the bit, one tick apart where the rig reports after the physics. With a fault, the
    /// board injects it and the harness plays the firmware-side ones as the QEMU build does (a
    /// missed deadline is seen at the end of the tick before the one it hits).
    fn replay(protocol: Protocol, seconds: f64, fault: Option<FaultInjection>) {
        let config = RigConfig {
            command_slew_g_per_s: protocol.slew_limit_g_per_s(),
            fault,
            ..RigConfig::default()
        };
        let fw = config.firmware;
        let mut rig = Rig::new(config.clone()).unwrap();
        let mut hw = SimHardware::new(&config);
        let calibration = *hw.calibration();
        let mut controller = Controller::new(&fw, protocol, calibration[fw.probe.index()]).unwrap();
        let mut scanner = Scanner::new(&fw, calibration).unwrap();
        scanner.start(&mut hw);
        let mut source = tactile_core::profile::CommandSource::new(protocol);
        let (mut rig_frames, mut fw_frames) = (Vec::new(), Vec::new());
        let mut previous = None;
        let ticks = (seconds * 1000.0).round() as u32;
        for k in 0..ticks {
            let frame = controller.tick(&mut hw, k);
            hw.advance_period();
            if hw.fault_starting() == Some(InjectedFault::DeadlineOverrun) {
                controller.record_overrun();
            }
            for _ in 0..4 {
                if let Some(r) = scanner.step(&mut hw, k) {
                    fw_frames.push(r.frame);
                }
            }
            let command = source.command_g(rig.time_s() as f32);
            let rec = rig.tick(command, |_, grid| rig_frames.push(*grid));
            assert_eq!(frame.command_g, rec.command_g, "tick {k}");
            assert_eq!(frame.adjusted_g, rec.adjusted_g, "tick {k}");
            assert_eq!(hw.dac().0, rec.dac_code, "tick {k}");
            // The rig also flags a railed taxel per tick; the firmware marks it in the frame.
            assert_eq!(
                frame.faults.bits(),
                (rec.faults - FaultFlags::TAXEL_AT_RAIL).bits(),
                "tick {k}"
            );
            if let Some(prev) = previous.replace(rec) {
                let prev: tactile_plant::rig::TickRecord = prev;
                assert_eq!(
                    frame.sensed_g.to_bits(),
                    prev.sensed_g.to_bits(),
                    "tick {k}"
                );
                assert_eq!(frame.strain_pct, prev.strain_pct, "tick {k}");
                assert_eq!(frame.estimate_g, prev.estimate_g, "tick {k}");
            }
            assert_eq!(hw.true_force_g() as f32, rec.true_force_g, "tick {k}");
        }
        assert_eq!(fw_frames.len(), rig_frames.len());
        assert!(fw_frames.len() as f64 >= (seconds * 62.0).floor());
        for (f, g) in fw_frames.iter().zip(&rig_frames) {
            for (r, (cells, row)) in f.strain_centi_pct.iter().zip(g).enumerate() {
                for (c, (&cell, &strain)) in cells.iter().zip(row).enumerate() {
                    // A taxel at a rail: the rig writes NaN, the firmware sets its bad bit.
                    if f.bad_taxels & (1u64 << (r * 8 + c)) != 0 {
                        assert!(strain.is_nan(), "{fault:?}: taxel {r},{c}");
                    } else {
                        assert_eq!(cell, TaxelFrame::quantize(strain), "{fault:?}");
                    }
                }
            }
        }
        let expected_overruns = u32::from(matches!(
            fault,
            Some(FaultInjection {
                fault: InjectedFault::DeadlineOverrun,
                ..
            })
        ));
        assert_eq!(controller.overruns(), expected_overruns);
        // Not vacuous: the latching faults did latch.
        if let Some(f) = fault {
            let latches = !matches!(
                f.fault,
                InjectedFault::TaxelOpen { .. } | InjectedFault::ContactLost { .. }
            );
            assert_eq!(controller.latched() != FaultFlags::NONE, latches, "{f:?}");
        }
    }

    #[test]
    fn a_crash_request_is_read_from_the_command_line() {
        let crash = |s: &str| DeliberateCrash::from_cmdline(s.as_bytes());
        assert_eq!(
            crash("target/tactile-qemu panic-at-tick=1200\0junk"),
            Some(DeliberateCrash::Panic { tick: 1200 })
        );
        assert_eq!(
            crash("fw hardfault-at-tick=7"),
            Some(DeliberateCrash::HardFault { tick: 7 })
        );
        assert_eq!(crash("fw"), None);
        assert_eq!(crash("fw panic-at-tick=12x"), None);
        assert_eq!(crash("fw panic-at-tick="), None);
        assert_eq!(crash(""), None);
        assert_eq!(DeliberateCrash::from_cmdline(&[0xff, 0xfe]), None);
    }

    #[test]
    fn the_session_is_chosen_on_the_command_line() {
        assert_eq!(session_from_cmdline(b"fw\0"), Session::FirmwareInTheLoop);
        assert_eq!(
            session_from_cmdline(b"fw session=calibration\0junk"),
            Session::Calibration
        );
        assert_eq!(
            session_from_cmdline(b"fw session=calib"),
            Session::FirmwareInTheLoop
        );
        assert_eq!(Session::Calibration.runs(), &CALIBRATION_SESSION[..]);
        assert_eq!(
            runs_from_cmdline(b"fw session=calibration run=2\0"),
            &CALIBRATION_SESSION[2..]
        );
        assert_eq!(runs_from_cmdline(b"fw run=1"), &FIL_SESSION[1..2]);
        assert_eq!(
            session_from_cmdline(b"fw session=excitation\0"),
            Session::Excitation
        );
        assert_eq!(
            runs_from_cmdline(b"fw session=excitation run=5"),
            &EXCITATION_SESSION[5..]
        );
        // The identification session runs the design's excitations, named by their preloads.
        for (r, load_g) in EXCITATION_SESSION.iter().zip(DESIGN_PRELOADS_G) {
            assert_eq!(r.protocol, Protocol::design_excitation(load_g));
            assert_eq!(r.name, format!("excitation-{load_g}g"));
            assert!(r.fault.is_none() && r.finger.is_none() && !r.designed);
        }
        for whole in [
            "fw session=calibration run=3",
            "fw session=calibration run=x",
        ] {
            assert_eq!(
                runs_from_cmdline(whole.as_bytes()),
                &CALIBRATION_SESSION[..]
            );
        }
        // Each calibration run puts the probe over its own taxel of the calibration finger;
        // the last over the first again, on a finger with other spring laws.
        let probes: Vec<_> = CALIBRATION_SESSION
            .iter()
            .map(|r| r.rig().firmware.probe)
            .collect();
        assert_eq!(probes[..2], CALIBRATION_TAXELS[..2]);
        assert_eq!(probes[2], CALIBRATION_TAXELS[0]);
        for r in &CALIBRATION_SESSION {
            let (row, col) = (r.rig().firmware.probe.row(), r.rig().firmware.probe.col());
            let other = r.element.map_or("", |_| "-linear-saturating");
            assert_eq!(r.name, format!("calibrate-{row}-{col}{other}"));
            assert_eq!(r.rig().seed, CALIBRATION_FINGER_SEED);
            assert_eq!(r.rig().effects.element, r.element);
        }
    }

    #[test]
    fn the_task_bodies_on_the_simulated_board_are_the_simulators_rig() {
        replay(Protocol::FORCE_STEPS_MEMO, 11.0, None);
        replay(Protocol::PSEUDO_RANDOM_MEMO, 10.0, None);
    }

    /// Every fault the board can inject, on a 30 g hold: the firmware reacts as the rig does,
    /// to the bit (the QEMU test runs three of them on the Cortex-M4F).
    #[test]
    fn injected_faults_on_the_simulated_board_are_the_rigs() {
        let hold = Protocol::Step {
            load_g: 30.0,
            lead_s: 0.2,
            on_s: 2.0,
            off_s: 0.3,
        };
        for fault in [
            InjectedFault::GaugeDisconnected,
            InjectedFault::GaugeSaturated,
            InjectedFault::GaugeStuck,
            InjectedFault::ForceSpike { g: 80.0 },
            InjectedFault::ContactLost {
                strain_pct: f64::INFINITY,
            },
            InjectedFault::DeadlineOverrun,
            InjectedFault::TaxelOpen { index: 27 },
        ] {
            replay(hold, 2.5, Some(FaultInjection { fault, at_s: 1.5 }));
        }
        // And the QEMU session's own fault runs, whole.
        for run in FIL_SESSION.iter().filter(|r| r.fault.is_some()) {
            replay(
                run.protocol,
                f64::from(run.protocol.duration_s()),
                run.fault,
            );
        }
    }
}
