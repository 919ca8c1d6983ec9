//! `tactile-decode --elf ELF --log LOG --out DIR`: a defmt log of the firmware (from a board
//! or from QEMU) → one record per protocol run (`DIR/NAME.csv`, the format `tactile diagnose`
//! reads), its 8×8 frames and the array estimates; a summary on stdout.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Turns the firmware's defmt log (board or QEMU) into the project's records.
#[derive(clap::Parser, Debug)]
#[command(name = "tactile-decode", version)]
struct Args {
    /// The firmware ELF the log was produced by (its defmt table).
    #[arg(long, value_name = "FIRMWARE.elf")]
    elf: PathBuf,
    /// The raw defmt bytes (RTT up-channel 0, or QEMU's semihosting output).
    #[arg(long, value_name = "DEFMT.log")]
    log: PathBuf,
    /// Where the records go (one CSV per protocol run).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
}

/// Bad usage exits 2 (clap), a failed run 1.
fn main() -> ExitCode {
    let args = <Args as clap::Parser>::parse();
    match run(&args.elf, &args.log, &args.out) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("tactile-decode: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(elf: &Path, log: &Path, out: &Path) -> Result<(), String> {
    let read =
        |p: &Path| std::fs::read(p).map_err(|e| format!("{}: cannot read: {e}", p.display()));
    let session =
        tactile_decode::decode(&read(elf)?, elf, &read(log)?, log).map_err(|e| e.to_string())?;
    for e in &session.errors {
        eprintln!("firmware error: {e}");
    }
    for n in &session.notes {
        println!("{n}");
    }
    if session.runs.is_empty() {
        return Err(format!("{}: no protocol run in the log", log.display()));
    }
    let meta = vec![
        (
            "source".to_string(),
            format!("firmware defmt log {}", log.display()),
        ),
        ("elf".to_string(), elf.display().to_string()),
    ];
    for run in &session.runs {
        let files = tactile_decode::write_run(out, run, &meta)
            .map_err(|e| format!("{}: cannot write: {e}", out.display()))?;
        println!(
            "{}: {} control frames, {} taxel frames{} -> {}",
            run.name,
            run.ticks.len(),
            run.frames.len(),
            run.end
                .map_or(String::from(" (no RunEnd: log cut short?)"), |e| format!(
                    ", dropped {} control / {} taxel, {} overruns",
                    e.control_frames_dropped, e.taxel_frames_dropped, e.overruns
                )),
            files
                .first()
                .map_or(String::new(), |f| f.display().to_string())
        );
    }
    if let Some(figures) = session.estimator_figures() {
        let path = out.join("estimators.json");
        let json = serde_json::to_string_pretty(&figures)
            .map_err(|e| format!("estimator figures: cannot encode: {e}"))?;
        std::fs::write(&path, json)
            .map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
        print!("{}", figures.render());
        println!("-> {}", path.display());
    }
    println!(
        "sequence: {} control frames received, {} missing; {} taxel frames received, {} missing; {} trailing bytes",
        session.control_seq.received(),
        session.control_seq.missing(),
        session.taxel_seq.received(),
        session.taxel_seq.missing(),
        session.trailing_bytes
    );
    if !session.errors.is_empty() {
        return Err("the firmware reported errors (above)".into());
    }
    Ok(())
}
