//! `tactile board`: drive a board from the host: commands down, its defmt stream up, decoded as it arrives
//! into records (`OUT/NAME.csv`), with a progress bar and a live line (force, error,
//! faults, frames lost). The board is the QEMU firmware (`cargo fw-qemu` builds it), or
//! with --probe an STM32F407G-DISC1 over SWD (`cargo fw-f407` builds its firmware).

use crate::common::taxel_arg;
use clap::{Args, Subcommand};
use sim_host::Error;
use std::path::PathBuf;
use tactile_core::tactile::TaxelId;

#[derive(Args)]
pub struct BoardArgs {
    /// The firmware ELF: its defmt table, what QEMU runs, what --flash writes
    /// [default: the QEMU build's, or the F407 build's with --probe].
    #[arg(long)]
    pub elf: Option<PathBuf>,
    /// Decode a saved log of the firmware instead of running it.
    #[arg(long, conflicts_with = "probe")]
    pub replay: Option<PathBuf>,
    /// A board through the first debug probe found: its RTT channels carry the commands
    /// and the stream.
    #[arg(long)]
    pub probe: bool,
    /// With --probe: the chip, as probe-rs names it.
    #[arg(long, requires = "probe", default_value = sim_host::probe::F407)]
    pub chip: String,
    /// With --probe: write the ELF to the chip and reset it first.
    #[arg(long, requires = "probe")]
    pub flash: bool,
    #[arg(long, default_value = "out/board")]
    pub out: PathBuf,
    #[command(subcommand)]
    pub action: BoardCommand,
}

/// What `tactile board` asks of the board.
#[derive(Subcommand)]
pub enum BoardCommand {
    /// Run a protocol and record it.
    Run {
        #[arg(value_enum)]
        protocol: sim_host::board_link::BoardProtocol,
        /// Length of pseudo-random, s.
        #[arg(long, default_value_t = 10.0)]
        duration: f32,
        /// The excitation's preload, g.
        #[arg(long, default_value_t = 50.0)]
        load: f32,
        /// The calibration's taxel under the probe, ROW,COL.
        #[arg(long, default_value = "3,2", value_parser = taxel_arg)]
        taxel: TaxelId,
        /// Under the designed force controller (the build's table) instead of A1.
        #[arg(long)]
        designed: bool,
    },
    /// Hold a force, then stop.
    Hold {
        force_g: f32,
        #[arg(long, default_value_t = 5.0)]
        seconds: f32,
    },
    /// Calibrate taxels: the calibration protocol over each (ROW,COL) in turn, the table fitted
    /// to their records (OUT/calibration-table.bin), loaded into the board and run.
    Calibrate {
        #[arg(required = true, value_parser = taxel_arg)]
        taxels: Vec<TaxelId>,
    },
    /// Decode what the board streams (a saved log with --replay LOG, a board with --probe).
    Stream {
        /// How long to follow a live board, s.
        #[arg(long, default_value_t = 10.0)]
        seconds: f32,
    },
}

pub fn run(args: BoardArgs) -> Result<(), Error> {
    let BoardArgs {
        elf,
        replay,
        probe,
        chip,
        flash,
        out,
        action,
    } = args;
    let action = match action {
        BoardCommand::Run {
            protocol,
            duration,
            load,
            taxel,
            designed,
        } => sim_host::board_link::Action::Run {
            protocol,
            duration_s: duration,
            load_g: load,
            taxel,
            designed,
        },
        BoardCommand::Hold { force_g, seconds } => {
            sim_host::board_link::Action::Hold { force_g, seconds }
        }
        BoardCommand::Stream { seconds } => sim_host::board_link::Action::Stream { seconds },
        BoardCommand::Calibrate { taxels } => sim_host::board_link::Action::Calibrate { taxels },
    };
    let target = match (&replay, probe) {
        (Some(log), _) => sim_host::board_link::Target::Replay(log),
        (None, true) => sim_host::board_link::Target::Probe { chip: &chip, flash },
        (None, false) => sim_host::board_link::Target::Qemu,
    };
    let elf = elf.unwrap_or_else(|| {
        PathBuf::from(if probe {
            "target/thumbv7em-none-eabihf/release/tactile-f407"
        } else {
            "target/thumbv7em-none-eabihf/release/tactile-qemu"
        })
    });
    let text = sim_host::board_link::run(&elf, target, &action, &out)?;
    out!("{text}");
    Ok(())
}
