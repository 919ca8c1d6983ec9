//! Hardware-independent core of the tactile force applicator (after UCB/ERL M89/138).
//!
//! Everything here is `no_std`, allocation-free and `f32` on the hot path, so the firmware,
//! the simulator (`sim-host`) and the host tools all run the same code:
//!
//! - [`filter`]: the memo's analog lowpass-notch filter discretized for the 1 kHz loop.
//! - [`control`]: the gain-scheduled PD force law of memo eq. A1.
//! - [`gauge`]: the strain-gauge path (8× averaged ADC samples to grams, with a range check).
//! - [`tactile`]: the 8×8 scan sequencer, the capacitive element and its read-out amplifier.
//! - [`lti`]: the arithmetic the models run in, second-order transfer functions, their Tustin
//!   discretization.
//! - [`viscoelastic`]: elastic, Maxwell–Kelvin, modified Maxwell–Kelvin and second-order
//!   models, forward (strain from stress) and inverse (stress from strain).
//! - [`calibration`]: the per-taxel calibration table (bytes the firmware checks at start-up).
//! - [`command`]: commands from the host to a running board (framed, numbered, checked).
//! - [`estimator`]: force estimators per taxel at the scan rate (scheduled inverse, observer).
//! - [`hysteresis`]: play operators, and a loop taken off a force estimate.
//! - [`profile`]: the memo's protocols as setpoint generators (firmware and simulator).
//! - [`supervisor`]: the force loop (command check, slew, A1, filter, DAC) and its fault table.
//! - [`designed`]: the designed force controller (reference model, scheduled model-inverse
//!   feed-forward, integral feedback), the alternative to A1.
//! - [`telemetry`]: the frames streamed over defmt, with sequence numbers and drop counts.
//! - [`io`]: what a board puts behind the task bodies (converter codes in, DAC codes out).
//! - [`tasks`]: the firmware's control and scan tasks, run by every board and the simulator.
//!
//! Units: force in grams-force (`_g`), strain in percent deflection (`_pct`), time in seconds
//! (`_s`), voltages in volts (`_v`), raw converter codes as [`gauge::AdcCode`].
#![cfg_attr(not(test), no_std)]
// No panics outside the tests: no unwrap, expect, panicking index or explicit panic.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic
    )
)]

pub mod calibration;
pub mod command;
pub mod contact;
pub mod control;
pub mod designed;
pub mod estimator;
pub mod filter;
pub mod gauge;
pub mod hysteresis;
pub mod io;
pub mod lti;
pub mod profile;
pub mod seal;
pub mod spring;
pub mod supervisor;
pub mod tactile;
pub mod tasks;
pub mod telemetry;
pub mod trig;
pub mod viscoelastic;

/// Control period, s (memo: Δt = 1 ms): the force loop's tick, the filter's and the law's
/// sample period, the simulator's step of record. `f64`, so command times computed from a tick
/// count agree to the bit wherever they are computed.
pub const CONTROL_PERIOD_S: f64 = 1e-3;

/// `x` limited to `[lo, hi]` without a panic path: `f32::clamp` asserts `lo <= hi` and its panic
/// message pulls about 15 KB of float formatting into the firmware. NaN passes through as NaN
/// only if both bounds are NaN; callers give finite bounds.
#[inline]
pub(crate) fn limit(x: f32, lo: f32, hi: f32) -> f32 {
    x.max(lo).min(hi)
}

/// Where `x` falls in a schedule of `points` in increasing load (`load_g` of each): the two
/// points it lies between and its share of the way from the first to the second; the end point
/// twice (share 0) at or beyond an end, the first for NaN. `None` for no points. Shared by the
/// scheduled inverse and the designed controller, so a schedule is read one way on the chip.
#[inline]
pub(crate) fn bracket<P>(
    points: &[P],
    load_g: impl Fn(&P) -> f32,
    x: f32,
) -> Option<(&P, &P, f32)> {
    let (first, last) = (points.first()?, points.last()?);
    if x.is_nan() || x <= load_g(first) {
        return Some((first, first, 0.0));
    }
    if x >= load_g(last) {
        return Some((last, last, 0.0));
    }
    for pair in points.windows(2) {
        if let [a, b] = pair {
            if x < load_g(b) {
                return Some((a, b, (x - load_g(a)) / (load_g(b) - load_g(a))));
            }
        }
    }
    Some((last, last, 0.0))
}

/// Signals the unit tests share.
#[cfg(test)]
pub(crate) mod test_support {
    /// Load steps in 20–40 g (each change uniform in ±20 g, clamped), held `dwell_min_s` plus
    /// up to `dwell_span_s` (xorshift from `seed`), sampled every `dt_s`.
    pub fn pseudo_random_steps(
        n: usize,
        dt_s: f64,
        seed: u64,
        dwell_min_s: f64,
        dwell_span_s: f64,
    ) -> Vec<f64> {
        let mut state = seed;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut level, mut until) = (30.0, 0.0);
        (0..n)
            .map(|k| {
                let t = k as f64 * dt_s;
                if t >= until {
                    level = (level + 40.0 * next() - 20.0).clamp(20.0, 40.0);
                    until = t + dwell_min_s + dwell_span_s * next();
                }
                level
            })
            .collect()
    }
}
