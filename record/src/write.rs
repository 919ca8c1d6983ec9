//! Writers: the simulator's and the decoder's ticks as a record, 8×8 frames as their own CSV.

use std::io::Write;
use std::path::Path;

use tactile_core::control::ActuatorConfig;
use tactile_core::tactile::StrainGrid;
use tactile_core::telemetry::TickRecord;

/// Writes ticks (decimated to every `every`th) as a record with the extra columns the
/// firmware streams: command, adjusted command, the on-chip estimate and the faults, plus the
/// simulator's truth (the contact force and whether the probe touches) from the simulator;
/// the drive in grams through `actuator`, from the code each tick wrote.
pub fn write_record(
    path: &Path,
    meta: &[(String, String)],
    ticks: &[TickRecord],
    every: usize,
    actuator: &ActuatorConfig,
) -> std::io::Result<()> {
    write_ticks(path, meta, ticks, every, true, actuator)
}

/// [`write_record`] with the truth columns only when `truth` (a board knows no true force).
pub fn write_ticks(
    path: &Path,
    meta: &[(String, String)],
    ticks: &[TickRecord],
    every: usize,
    truth: bool,
    actuator: &ActuatorConfig,
) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    for (k, v) in meta {
        writeln!(w, "# {k}={v}")?;
    }
    let truth_header = if truth { ",true_force_g,contact" } else { "" };
    writeln!(
        w,
        "t_s,force_g,strain_pct,command_g,adjusted_g,estimate_g{truth_header},drive_g,faults"
    )?;
    for r in ticks.iter().skip(every.max(1) - 1).step_by(every.max(1)) {
        write!(
            w,
            "{:.4},{:.3},{:.5},{:.3},{:.3},{:.3}",
            r.t_s, r.sensed_g, r.strain_pct, r.command_g, r.adjusted_g, r.estimate_g,
        )?;
        if truth {
            write!(w, ",{:.3},{}", r.true_force_g, u8::from(r.in_contact))?;
        }
        let drive_g = actuator.force_g(tactile_core::gauge::AdcCode(r.dac_code));
        writeln!(w, ",{drive_g:.4},{}", r.faults.bits())?;
    }
    w.flush()
}

/// Writes whole 8×8 frames: `t_s,r0c0,…,r7c7` (strain in percent).
pub fn write_frames(
    path: &Path,
    meta: &[(String, String)],
    frames: &[(f64, StrainGrid)],
) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    for (k, v) in meta {
        writeln!(w, "# {k}={v}")?;
    }
    write!(w, "t_s")?;
    for r in 0..8 {
        for c in 0..8 {
            write!(w, ",r{r}c{c}")?;
        }
    }
    writeln!(w)?;
    for (t, grid) in frames {
        write!(w, "{t:.4}")?;
        for row in grid {
            for v in row {
                write!(w, ",{v:.4}")?;
            }
        }
        writeln!(w)?;
    }
    w.flush()
}
