//! `tactile board` (issue 14): drives a board from the host through a
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
}

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

/// The run `protocol` names, with its arguments.
fn run_of(protocol: BoardProtocol, duration_s: f32, load_g: f32, taxel: TaxelId) -> Run {
    match protocol {
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
    }
}

/// When a live board's session for `action` is over (see [`tactile_decode::Until`]): what it
/// asked for has had its time, and a little more.
fn until(action: &Action) -> tactile_decode::Until {
    use std::time::Duration;
    let s = |x: f32| Duration::from_secs_f32(x.max(0.0));
    match *action {
        Action::Run {
            protocol,
            duration_s,
            load_g,
            taxel,
            ..
        } => {
            let length = run_of(protocol, duration_s, load_g, taxel)
                .protocol()
                .duration_s();
            tactile_decode::Until {
                settle: s(length + 0.5),
                timeout: s(length + 15.0),
            }
        }
        Action::Hold { .. } => tactile_decode::Until {
            settle: s(0.5),
            timeout: s(10.0),
        },
        Action::Stream { seconds } => tactile_decode::Until {
            settle: s(seconds),
            timeout: s(seconds),
        },
    }
}

/// The commands for `action`, each with the board tick it is sent at.
pub fn script(action: &Action) -> Vec<(u32, Vec<u8>)> {
    let frame = |seq: u16, c: Command| c.frame(seq).as_bytes().to_vec();
    match *action {
        Action::Run {
            protocol,
            duration_s,
            load_g,
            taxel,
            designed,
        } => {
            let run = run_of(protocol, duration_s, load_g, taxel);
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
    }
}

/// Runs `action` on the board `target` whose firmware is `elf` (the ELF's defmt table decodes
/// its stream), writes the records into `out`, and returns the report.
pub fn run(elf: &Path, target: Target, action: &Action, out: &Path) -> Result<String, Error> {
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
    let (mut transport, source): (Box<dyn Transport>, PathBuf) = match (target, action) {
        (Target::Replay(log), _) => (Box::new(Replay::new(read(log)?, 4096)), log.to_path_buf()),
        (Target::Qemu, Action::Stream { .. }) => {
            return Err(Error::Usage(
                "stream needs a board that runs on its own: --replay LOG or --probe".into(),
            ))
        }
        (Target::Qemu, action) => {
            let path = out.join("commands.bin");
            let qemu = Qemu::start(elf, &script(action), &path)
                .map_err(|e| Error::Failed(format!("cannot start qemu-system-arm: {e}")))?;
            (Box::new(qemu), PathBuf::from("qemu"))
        }
        (Target::Probe { chip, flash }, _) => {
            let probe =
                crate::probe::Probe::attach(chip, flash.then_some(elf)).map_err(Error::Failed)?;
            (Box::new(probe), PathBuf::from(format!("probe ({chip})")))
        }
    };
    let live = tactile_decode::Live::new(&table, &source);
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
        Target::Probe { .. } => {
            tactile_decode::drive(&mut *transport, &script(action), live, until(action), show)
        }
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
    // A command of ours the board refused fails the session (a replayed log's are its own).
    let ours = !matches!(action, Action::Stream { .. }) && !matches!(target, Target::Replay(_));
    if ours && session.replies.iter().any(|r| r.1.is_some()) {
        return Err(Error::Failed(report.trim_end().to_string()));
    }
    Ok(report)
}
