//! Writers: the simulator's and the decoder's ticks as a record, 8×8 frames as their own CSV.

use std::io::Write;
use std::path::Path;

use tactile_plant::finger::StrainGrid;
use tactile_plant::rig::TickRecord;

/// Writes ticks (decimated to `record_hz`) as a record with the extra columns the simulator
/// knows: command, adjusted command, the on-chip estimate, and the true contact force.
pub fn write_record(
    path: &Path,
    meta: &[(String, String)],
    ticks: &[TickRecord],
    every: usize,
) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    for (k, v) in meta {
        writeln!(w, "# {k}={v}")?;
    }
    writeln!(
        w,
        "t_s,force_g,strain_pct,command_g,adjusted_g,estimate_g,true_force_g,contact,faults"
    )?;
    for r in ticks.iter().skip(every.max(1) - 1).step_by(every.max(1)) {
        writeln!(
            w,
            "{:.4},{:.3},{:.5},{:.3},{:.3},{:.3},{:.3},{},{}",
            r.t_s,
            r.sensed_g,
            r.strain_pct,
            r.command_g,
            r.adjusted_g,
            r.estimate_g,
            r.true_force_g,
            u8::from(r.in_contact),
            r.faults.0
        )?;
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
