//! The numbers each experiment is judged by, computed from a run.

use crate::rig::TickRecord;
use tactile_core::telemetry::FaultFlags;

/// One commanded level of a step protocol.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub start: usize,
    pub end: usize,
    pub command_g: f32,
    /// The loop clamped the command (past its gauge's range): the level is not one it takes.
    pub clamped: bool,
}

/// Splits a run into runs of constant command.
pub fn segments(ticks: &[TickRecord]) -> Vec<Segment> {
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..=ticks.len() {
        if i == ticks.len() || ticks[i].command_g != ticks[start].command_g {
            out.push(Segment {
                start,
                end: i,
                command_g: ticks[start].command_g,
                clamped: ticks[start..i]
                    .iter()
                    .any(|r| r.faults.contains(FaultFlags::COMMAND_CLAMPED)),
            });
            start = i;
        }
    }
    out
}

/// Settling time (s) of a segment: from its start until the true force enters ±`band_g` of
/// the command for good; `None` if it never does.
pub fn settling_time_s(ticks: &[TickRecord], seg: &Segment, band_g: f32) -> Option<f64> {
    let slice = &ticks[seg.start..seg.end];
    let last_out = slice
        .iter()
        .rposition(|r| (r.true_force_g - seg.command_g).abs() > band_g);
    match last_out {
        None => Some(0.0),
        Some(i) if i + 1 < slice.len() => Some((i + 1) as f64 * tactile_core::CONTROL_PERIOD_S),
        Some(_) => None,
    }
}

/// Each non-zero step of a step protocol the loop takes (not one it clamped), in order: its
/// level and its settling time into ±1 g (`None`: it never settled).
pub fn step_settling_s(ticks: &[TickRecord]) -> Vec<(f32, Option<f64>)> {
    segments(ticks)
        .iter()
        .filter(|s| s.command_g > 0.0 && !s.clamped)
        .map(|s| (s.command_g, settling_time_s(ticks, s, 1.0)))
        .collect()
}

/// The settling times of the steps after the first (the first starts from rest: a
/// touch-down), sorted; a step that never settled counts as infinite.
pub fn settling_after_first_s(ticks: &[TickRecord]) -> Vec<f64> {
    let mut settle: Vec<f64> = step_settling_s(ticks)
        .into_iter()
        .skip(1)
        .map(|(_, t)| t.unwrap_or(f64::INFINITY))
        .collect();
    settle.sort_by(f64::total_cmp);
    settle
}

/// Force-steps summary: the worst settling time over the non-zero steps.
pub fn worst_step_settling_s(ticks: &[TickRecord]) -> Option<f64> {
    let mut worst: f64 = 0.0;
    for (_, t) in step_settling_s(ticks) {
        worst = worst.max(t?);
    }
    Some(worst)
}

/// For each step of a step protocol (a segment after another) the loop takes (not one it
/// clamped): its level and how far the true force went past it in the step's direction, g (0
/// if it never did).
pub fn step_overshoots_g(ticks: &[TickRecord]) -> Vec<(f32, f32)> {
    let segs = segments(ticks);
    segs.windows(2)
        .filter(|w| !w[1].clamped)
        .map(|w| {
            let (before, s) = (w[0], w[1]);
            let up = s.command_g >= before.command_g;
            let past = ticks[s.start..s.end]
                .iter()
                .map(|r| {
                    let d = r.true_force_g - s.command_g;
                    if up {
                        d
                    } else {
                        -d
                    }
                })
                .fold(0.0f32, f32::max);
            (s.command_g, past)
        })
        .collect()
}

/// Per commanded level: fraction of the hold out of contact, and the worst |force − command|
/// after `settle_s`.
pub fn hold_quality(ticks: &[TickRecord], settle_s: f64) -> Vec<(f32, f64, f32)> {
    let skip = (settle_s / tactile_core::CONTROL_PERIOD_S) as usize;
    segments(ticks)
        .iter()
        .filter(|s| s.command_g > 0.0 && s.end - s.start > skip)
        .map(|s| {
            let held = &ticks[s.start + skip..s.end];
            let lost = held.iter().filter(|r| !r.in_contact).count() as f64 / held.len() as f64;
            let worst = held
                .iter()
                .map(|r| (r.true_force_g - s.command_g).abs())
                .fold(0.0, f32::max);
            (s.command_g, lost, worst)
        })
        .collect()
}

/// For each loaded segment, `strain_change(previous segment, the load's segment, following
/// segments)` — the strain the load left, measured against the rest before it.
fn per_load(
    ticks: &[TickRecord],
    strain_change: impl Fn(&Segment, &Segment, &[Segment]) -> Option<f64>,
) -> Vec<(f32, f64)> {
    let segs = segments(ticks);
    segs.iter()
        .enumerate()
        .filter(|(_, s)| s.command_g > 0.0)
        .filter_map(|(i, s)| {
            let before = segs.get(i.checked_sub(1)?)?;
            Some((s.command_g, strain_change(before, s, segs.get(i + 1..)?)?))
        })
        .collect()
}

/// The mean strain of the `n` ticks that end segment `s`.
fn strain_at_end(ticks: &[TickRecord], s: &Segment, n: usize) -> Option<f64> {
    Some(mean_strain(ticks.get(s.end.saturating_sub(n)..s.end)?))
}

/// Static linearity (Graph 1 procedure): for each load, the strain 0.1 s after the load was
/// applied (mean of 10 samples 1 ms apart) minus the strain just before it (a new offset).
/// "Applied" is when the slewed command reaches the load (`slew_g_per_s`): the memo's rig
/// stepped, ours ramps at a rate its probe can follow.
pub fn static_linearity(ticks: &[TickRecord], slew_g_per_s: f32) -> Vec<(f32, f64)> {
    per_load(ticks, |before, s, _| {
        let ramp =
            (s.command_g / slew_g_per_s / tactile_core::CONTROL_PERIOD_S as f32).ceil() as usize;
        let at = s.start + ramp + 100;
        Some(mean_strain(ticks.get(at..at + 10)?) - strain_at_end(ticks, before, 10)?)
    })
}

/// Permanent deformation (Graph 5): for each load, the strain at the end of the rest that
/// follows it minus the strain before it was applied.
pub fn residual_deformation(ticks: &[TickRecord]) -> Vec<(f32, f64)> {
    per_load(ticks, |before, _, after| {
        Some(strain_at_end(ticks, after.first()?, 200)? - strain_at_end(ticks, before, 200)?)
    })
}

/// RMS of (a − b) over the ticks where `keep` holds.
pub fn rms(
    ticks: &[TickRecord],
    a: impl Fn(&TickRecord) -> f64,
    b: impl Fn(&TickRecord) -> f64,
) -> f64 {
    let n = ticks.len().max(1) as f64;
    (ticks.iter().map(|r| (a(r) - b(r)).powi(2)).sum::<f64>() / n).sqrt()
}

/// Mean strain of a window of ticks.
fn mean_strain(window: &[TickRecord]) -> f64 {
    mean(window.iter().map(|r| f64::from(r.strain_pct)))
}

pub fn mean(xs: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = xs.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        s / n as f64
    }
}

/// The levels the steady-state error is measured at, g: 2–120 g up from rest and back down
/// (the range), each held [`STEADY_HOLD_S`].
pub const STEADY_LEVELS_G: [f32; 11] = [
    2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 120.0, 60.0, 20.0, 5.0, 2.0,
];
/// Each level's hold, s (`low-force`'s).
pub const STEADY_HOLD_S: f64 = 3.0;

/// The steady-state error at each of `levels_g`, held `hold_s` each in turn from rest: the
/// mean of the contact force less the command over each hold's second half, g (the gauge's
/// noise averages out; a motor the stiction holds off the command does not).
pub fn steady_errors_g(
    config: crate::rig::RigConfig,
    levels_g: &[f32],
    hold_s: f64,
) -> Result<Vec<(f32, f32)>, crate::rig::RigError> {
    let mut rig = crate::rig::Rig::new(config)?;
    let n = (hold_s / tactile_core::CONTROL_PERIOD_S).round() as usize;
    Ok(levels_g
        .iter()
        .map(|&level_g| {
            let sum: f32 = (0..n)
                .map(|k| {
                    let t = rig.tick(level_g, |_, _| {});
                    if k >= n / 2 {
                        t.true_force_g - level_g
                    } else {
                        0.0
                    }
                })
                .sum();
            (level_g, sum / (n - n / 2).max(1) as f32)
        })
        .collect())
}

/// Why a closed-loop magnitude has no value.
#[derive(Debug, thiserror::Error)]
pub enum GainError {
    #[error(transparent)]
    Rig(#[from] crate::rig::RigError),
    /// The supervisor held the drive at zero during the sine (a latched fault, or a reading at
    /// the gauge's rail or past its range: a 110 g peak on a gauge that reads to 67.5 g): what
    /// the lock-in would read is a stopped rig's (it printed −38 dB).
    #[error("the supervisor stopped the drive at {t_s:.3} s ({faults}): no magnitude")]
    Stopped { t_s: f64, faults: String },
    /// The loop clamped the sine's command (past what the gauge reads: a 110 g peak on a gauge
    /// that reads to 67.5 g): the magnitude would be of a clipped sine.
    #[error("the loop clamped the command at {t_s:.3} s (past the gauge's range): no magnitude")]
    Clamped { t_s: f64 },
}

/// Closed-loop magnitude (true force over command) at `hz`: a stepped sine of `amplitude_g`
/// about `offset_g` on the rig, lock-in over whole periods after a settling second.
pub fn closed_loop_gain(
    config: crate::rig::RigConfig,
    offset_g: f64,
    amplitude_g: f64,
    hz: f64,
) -> Result<f64, GainError> {
    let mut rig = crate::rig::Rig::new(crate::rig::RigConfig {
        scan_array: false,
        command_slew_g_per_s: f32::INFINITY,
        ..config
    })?;
    let w = 2.0 * core::f64::consts::PI * hz;
    let ramp = 1000;
    let stopped = |r: &TickRecord| {
        if r.faults.intersects(FaultFlags::DRIVE_HELD_AT_ZERO) {
            Some(GainError::Stopped {
                t_s: r.t_s,
                faults: format!("{:?}", r.faults),
            })
        } else {
            r.faults
                .contains(FaultFlags::COMMAND_CLAMPED)
                .then_some(GainError::Clamped { t_s: r.t_s })
        }
    };
    for k in 0..ramp {
        let r = rig.tick((offset_g * k as f64 / ramp as f64) as f32, |_, _| {});
        if let Some(e) = stopped(&r) {
            return Err(e);
        }
    }
    let periods = (2.0 * hz).ceil().max(4.0);
    let n_settle = 1000;
    let n = (periods / hz / tactile_core::CONTROL_PERIOD_S).round() as usize;
    let (mut acc_f, mut acc_c) = (
        num_complex::Complex64::new(0.0, 0.0),
        num_complex::Complex64::new(0.0, 0.0),
    );
    for k in 0..(n_settle + n) {
        let t = rig.time_s();
        let c = offset_g + amplitude_g * (w * t).sin();
        let r = rig.tick(c as f32, |_, _| {});
        if let Some(e) = stopped(&r) {
            return Err(e);
        }
        if k >= n_settle {
            let ph = num_complex::Complex64::new(0.0, -w * r.t_s).exp();
            acc_f += (f64::from(r.true_force_g) - offset_g) * ph;
            let ph_c = num_complex::Complex64::new(0.0, -w * t).exp();
            acc_c += (c - offset_g) * ph_c;
        }
    }
    Ok(acc_f.norm() / acc_c.norm())
}

/// A touch-down from a gap: when the probe met the finger, s after the command (none: never),
/// the contact force's overshoot over the command, g, and its mean over the run's last 0.2 s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TouchDown {
    pub contact_s: Option<f64>,
    pub overshoot_g: f32,
    pub final_g: f32,
}

/// The probe at rest `gap_m` off the finger, 0.1 s with no command, then `target_g` for
/// `run_s`.
pub fn touch_down(
    config: crate::rig::RigConfig,
    gap_m: f64,
    target_g: f32,
    run_s: f64,
) -> Result<TouchDown, crate::rig::RigError> {
    let mut rig = crate::rig::Rig::new(config)?;
    rig.hardware.lift_probe(gap_m);
    let (rest, run) = (
        100usize,
        (run_s / tactile_core::CONTROL_PERIOD_S).round() as usize,
    );
    let tail = 200usize.min(run);
    let (mut contact_s, mut peak_g, mut sum_g) = (None, 0.0f32, 0.0f32);
    for k in 0..rest + run {
        let command_g = if k < rest { 0.0 } else { target_g };
        let t = rig.tick(command_g, |_, _| {});
        if k >= rest {
            if t.in_contact && contact_s.is_none() {
                contact_s = Some((k - rest) as f64 * tactile_core::CONTROL_PERIOD_S);
            }
            peak_g = peak_g.max(t.true_force_g);
        }
        if k >= rest + run - tail {
            sum_g += t.true_force_g;
        }
    }
    Ok(TouchDown {
        contact_s,
        overshoot_g: peak_g - target_g,
        final_g: sum_g / tail.max(1) as f32,
    })
}
