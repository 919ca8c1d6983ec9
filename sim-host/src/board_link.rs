//! `tactile board`: drives a board from the host through a
//! [`Transport`](tactile_decode::transport::Transport) — commands down, the defmt stream up,
//! decoded as it arrives into the project's records, with a progress bar and a live summary
//! line (force, error, faults, frames lost). The board is the QEMU firmware (`cargo fw-qemu`
//! builds it; its down-channel is the script it reads at start), a board over a debug probe
//! ([`crate::probe`]: the commands sent when their time comes), or a saved log replayed.

use std::path::{Path, PathBuf};

use tactile_core::command::{Command, ControllerChoice, Run};
use tactile_core::tactile::TaxelId;
use tactile_decode::transport::{Qemu, Replay, Transport};

use crate::Error;

/// The protocols `tactile board run` asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum BoardProtocol {
    ForceSteps,
    PseudoRandom,
    Sines,
    StepLoads,
    LowForce,
    Calibration,
    Excitation,
}

/// What the board is asked to do.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Run a protocol (`duration_s` for pseudo-random, `load_g` the excitation's preload,
    /// `taxel` the calibration's), under the designed controller if asked.
    Run {
        protocol: BoardProtocol,
        duration_s: f32,
        load_g: f32,
        taxel: TaxelId,
        designed: bool,
    },
    /// Hold a force for `seconds`, then stop.
    Hold { force_g: f32, seconds: f32 },
    /// Only decode what the board streams (a live board's for `seconds`).
    Stream { seconds: f32 },
    /// The calibration protocol over each taxel in turn, then the table fitted to their
    /// records (`tactile calibrate`'s code) loaded into the board, and a short pseudo-random
    /// run on it.
    Calibrate { taxels: Vec<TaxelId> },
}

/// The calibration protocol's length, s.
fn calibration_s() -> f32 {
    Run::Calibration {
        taxel: TaxelId::default(),
    }
    .protocol()
    .duration_s()
}

/// The pseudo-random run on the loaded table, s.
const CHECK_RUN_S: f32 = 2.0;

/// Where the board is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target<'a> {
    /// The QEMU firmware (the ELF given), started for the session.
    Qemu,
    /// A saved log of the firmware, replayed.
    Replay(&'a Path),
    /// A chip through the first debug probe found (`chip` as probe-rs names it), flashed with
    /// the ELF and reset first if `flash`.
    Probe { chip: &'a str, flash: bool },
}

impl Action {
    /// The run a `Run` action asks for.
    fn run(&self) -> Option<Run> {
        let Action::Run {
            protocol,
            duration_s,
            load_g,
            taxel,
            ..
        } = *self
        else {
            return None;
        };
        Some(match protocol {
            BoardProtocol::ForceSteps => Run::ForceSteps,
            BoardProtocol::PseudoRandom => Run::PseudoRandom {
                seed: 1989,
                duration_s,
            },
            BoardProtocol::Sines => Run::Sines,
            BoardProtocol::StepLoads => Run::StepLoads,
            BoardProtocol::LowForce => Run::LowForce,
            BoardProtocol::Calibration => Run::Calibration { taxel },
            BoardProtocol::Excitation => Run::Excitation { preload_g: load_g },
        })
    }
}

/// When a live board's session for `action` is over (see [`tactile_decode::Until`]): what it
/// asked for has had its time, and a little more.
fn until(action: &Action) -> tactile_decode::Until {
    let s = |x: f32| std::time::Duration::from_secs_f32(x.max(0.0));
    match *action {
        Action::Run { .. } => after_run(action.run().map_or(0.0, |r| r.protocol().duration_s())),
        Action::Hold { .. } => tactile_decode::Until {
            settle: s(0.5),
            timeout: s(10.0),
        },
        Action::Stream { seconds } => tactile_decode::Until {
            settle: s(seconds),
            timeout: s(seconds),
        },
        // After the last calibration's command.
        Action::Calibrate { .. } => after_run(calibration_s()),
    }
}

/// A session whose last command starts a run of `length_s`: over half a second after the
/// run's end; a board still silent 15 s after it has stopped answering.
fn after_run(length_s: f32) -> tactile_decode::Until {
    let s = |x: f32| std::time::Duration::from_secs_f32(x.max(0.0));
    tactile_decode::Until {
        settle: s(length_s + 0.5),
        timeout: s(length_s + 15.0),
    }
}

/// The commands that load `table` (a calibration table) and run a short pseudo-random
/// protocol on it, numbered from `seq`.
fn load_and_check(table: &[u8], seq: u16) -> Vec<(u32, Vec<u8>)> {
    use tactile_core::command::TableKind;
    let mut commands: Vec<Command> = Command::table_chunks(TableKind::Calibration, table).collect();
    commands.push(Command::LoadTable {
        table: TableKind::Calibration,
        len: u16::try_from(table.len()).unwrap_or(u16::MAX),
    });
    commands.push(Command::Run(Run::PseudoRandom {
        seed: 1989,
        duration_s: CHECK_RUN_S,
    }));
    let bytes = commands
        .into_iter()
        .zip(seq..)
        .flat_map(|(c, n)| c.frame(n).as_bytes().to_vec())
        .collect();
    vec![(0, bytes)]
}

/// The commands for `action`, each with the board tick it is sent at.
pub fn script(action: &Action) -> Vec<(u32, Vec<u8>)> {
    let frame = |seq: u16, c: Command| c.frame(seq).as_bytes().to_vec();
    match *action {
        Action::Run { designed, .. } => {
            let Some(run) = action.run() else {
                return Vec::new();
            };
            let law = if designed {
                ControllerChoice::Designed
            } else {
                ControllerChoice::A1
            };
            vec![(
                0,
                [
                    frame(1, Command::Controller(law)),
                    frame(2, Command::Run(run)),
                ]
                .concat(),
            )]
        }
        Action::Hold { force_g, seconds } => vec![
            (0, frame(1, Command::Hold { force_g })),
            ((seconds.max(0.0) * 1000.0) as u32, frame(2, Command::Stop)),
        ],
        Action::Stream { .. } => Vec::new(),
        Action::Calibrate { ref taxels } => taxels
            .iter()
            .zip(1u16..)
            .map(|(&taxel, seq)| {
                // One after the other, half a second apart.
                let period_ms = (calibration_s() * 1000.0) as u32 + 500;
                (
                    u32::from(seq - 1) * period_ms,
                    frame(seq, Command::Run(Run::Calibration { taxel })),
                )
            })
            .collect(),
    }
}

/// Runs `action` on the board `target` whose firmware is `elf` (the ELF's defmt table decodes
/// its stream), writes the records into `out`, and returns the report.
pub fn run(elf: &Path, target: Target, action: &Action, out: &Path) -> Result<String, Error> {
    let Action::Calibrate { taxels } = action else {
        return session(elf, target, &script(action), until(action), out, |_| None);
    };
    if taxels.is_empty() {
        return Err(Error::Usage(
            "calibrate: name at least one taxel, ROW,COL".into(),
        ));
    }
    if let Target::Replay(_) = target {
        return Err(Error::Usage(
            "calibrate needs a board, not a replayed log".into(),
        ));
    }
    // The calibration runs (a board just flashed also ran its build's protocol first), each
    // record named after its taxel, in the order asked; then fitted into the table.
    let calibration = Run::Calibration {
        taxel: TaxelId::default(),
    }
    .name();
    let mut records: Vec<(TaxelId, PathBuf)> = Vec::new();
    let mut report = session(elf, target, &script(action), until(action), out, |run| {
        if run.name != calibration {
            return None;
        }
        let t = taxels.get(records.len())?;
        let name = format!("calibration-{}-{}", t.row(), t.col());
        records.push((*t, out.join(format!("{name}.csv"))));
        Some(name)
    })?;
    if records.len() < taxels.len() {
        return Err(Error::Failed(format!(
            "{report}the board ran {} of {} calibrations",
            records.len(),
            taxels.len()
        )));
    }
    let table_path = out.join("calibration-table.bin");
    report.push_str(&crate::cli::calibrate(
        &records,
        &table_path,
        crate::dynamic_calibration::FINGER_SEED,
        crate::fingers::FingerKind::Memo,
    )?);
    report.push('\n');
    // The table into the board (checked there as at start-up), and a run on it. QEMU's board
    // is a new one (its runs are sessions of their own); a probe's is the same board.
    let table = std::fs::read(&table_path).map_err(|source| Error::Io {
        path: table_path.clone(),
        source,
    })?;
    let seq = u16::try_from(taxels.len() + 1).unwrap_or(u16::MAX);
    let target = match target {
        Target::Probe { chip, .. } => Target::Probe { chip, flash: false },
        other => other,
    };
    let check = after_run(CHECK_RUN_S);
    match session(
        elf,
        target,
        &load_and_check(&table, seq),
        check,
        out,
        |_| None,
    ) {
        Ok(r) => report.push_str(&r),
        Err(Error::Failed(r)) if r.contains("Unsupported") => {
            report.push_str(&format!(
                "{r}\nthis board has no room for this calibration table loaded by command \
                 (eight taxels fit): build it in (cp {} boards/calibration/table.bin, then \
                 cargo flash-f407)\n",
                table_path.display()
            ));
        }
        Err(e) => return Err(e),
    }
    Ok(report)
}

/// One session on the board: `script` sent (QEMU: read at start; a probe: each entry when
/// due), the stream decoded live until it ends (`until` for a live board), its runs written
/// into `out` (`name` may give a run's records another name), and the report.
fn session(
    elf: &Path,
    target: Target,
    script: &[(u32, Vec<u8>)],
    until: tactile_decode::Until,
    out: &Path,
    mut name: impl FnMut(&tactile_decode::Run) -> Option<String>,
) -> Result<String, Error> {
    let read = |p: &Path| {
        std::fs::read(p).map_err(|source| Error::Io {
            path: p.to_path_buf(),
            source,
        })
    };
    let elf_bytes = read(elf)?;
    let table = tactile_decode::table(&elf_bytes, elf).map_err(|e| Error::Failed(e.to_string()))?;
    std::fs::create_dir_all(out).map_err(|source| Error::Io {
        path: out.to_path_buf(),
        source,
    })?;
    let (mut transport, source): (Box<dyn Transport>, PathBuf) = match target {
        Target::Replay(log) => (Box::new(Replay::new(read(log)?, 4096)), log.to_path_buf()),
        Target::Qemu if script.is_empty() => {
            return Err(Error::Usage(
                "stream needs a board that runs on its own: --replay LOG or --probe".into(),
            ))
        }
        Target::Qemu => {
            let path = out.join("commands.bin");
            let qemu = Qemu::start(elf, script, &path)
                .map_err(|e| Error::Failed(format!("cannot start qemu-system-arm: {e}")))?;
            (Box::new(qemu), PathBuf::from("qemu"))
        }
        Target::Probe { chip, flash } => {
            let probe =
                crate::probe::Probe::attach(chip, flash.then_some(elf)).map_err(Error::Failed)?;
            (Box::new(probe), PathBuf::from(format!("probe ({chip})")))
        }
    };
    // A board attached while it runs: what belongs to a run begun before is left out.
    let live = match target {
        Target::Probe { flash: false, .. } => tactile_decode::Live::joined(&table, &source),
        _ => tactile_decode::Live::new(&table, &source),
    };
    let bar = indicatif::ProgressBar::new(1000);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{prefix:>14} [{bar:30}] {percent:>3}%  {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let show = |l: &tactile_decode::Live| {
        if let Some((name, done)) = l.progress() {
            bar.set_prefix(name.to_string());
            bar.set_position((done * 1000.0) as u64);
        }
        bar.set_message(l.summary());
    };
    let session = match target {
        // A live board: each command sent when its time comes, until the action is over.
        Target::Probe { .. } => tactile_decode::drive(&mut *transport, script, live, until, show),
        // QEMU reads its commands at start and ends the stream; a log ends.
        _ => tactile_decode::follow(&mut *transport, live, show),
    }
    .map_err(Error::Failed)?;
    bar.finish_and_clear();
    let mut report = String::new();
    for (seq, reply) in &session.replies {
        match reply {
            None => report.push_str(&format!("command {seq}: taken\n")),
            Some(reason) => report.push_str(&format!("command {seq}: refused: {reason}\n")),
        }
    }
    for e in &session.errors {
        report.push_str(&format!("firmware error: {e}\n"));
    }
    let meta = vec![(
        "source".to_string(),
        format!("tactile board, {}", source.display()),
    )];
    for run in &session.runs {
        let renamed;
        let run = match name(run) {
            Some(n) => {
                renamed = tactile_decode::Run {
                    name: n,
                    ..run.clone()
                };
                &renamed
            }
            None => run,
        };
        let files = tactile_decode::write_run(out, run, &meta).map_err(|e| Error::Io {
            path: out.to_path_buf(),
            source: e,
        })?;
        report.push_str(&format!(
            "{}: {} control frames, {} taxel frames -> {}\n",
            run.name,
            run.ticks.len(),
            run.frames.len(),
            files[0].display()
        ));
    }
    report.push_str(&format!(
        "control frames: {} received, {} missing; {} flagged dropped on the board\n",
        session.control_seq.received(),
        session.control_seq.missing(),
        session.flagged_drops
    ));
    if session.before_first_run > 0 {
        report.push_str(&format!(
            "{} frames of a run begun before the probe attached left out\n",
            session.before_first_run
        ));
    }
    // A command of ours the board refused fails the session (a replayed log's are its own).
    let ours = !matches!(target, Target::Replay(_));
    if ours && session.replies.iter().any(|r| r.1.is_some()) {
        return Err(Error::Failed(report.trim_end().to_string()));
    }
    Ok(report)
}
