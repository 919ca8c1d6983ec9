//! The feedback and its margins: the loop's frequency grid, the filter on the error, the
//! feedback's response, the model's variants the margins must hold on, and the search's
//! bisection.

use num_complex::Complex64;
use serde::Serialize;
use tactile_core::designed::DesignedConfig;
use tactile_core::CONTROL_PERIOD_S;

use super::*;
use crate::applicator_model::ApplicatorModel;

/// Gain and phase margins of a loop given by its response on a frequency grid (first to last
/// point): the smallest 1/|L| where the phase crosses −180° (∞ where it never does) and the
/// smallest distance of the phase from −180° where |L| crosses 1 (180 where it never does).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Margins {
    pub gain: f64,
    pub phase_deg: f64,
    /// The sensitivity's peak up to [`BAND_HZ`], dB: how much the feedback amplifies what the
    /// feed-forward leaves there (a phase margin of 50° alone let the loop lift 40 Hz by 3.7 dB).
    pub band_sensitivity_db: f64,
}

/// The band the closed loop must be flat in, Hz.
pub const BAND_HZ: f64 = 40.0;

/// The margins of the loop `l` given on [`loop_grid_hz`].
pub fn margins(l: &[Complex64]) -> Margins {
    margins_on(&loop_grid_hz(), l)
}

/// The margins of the loop `l` given at the increasing frequencies `hz`. Each crossing is
/// placed between its two points (where the line between them crosses the negative real axis,
/// or where its magnitude, interpolated, is 1): a lightly damped mode's circle turns its phase
/// by tens of degrees from one point to the next, and the phase read at the point past the
/// crossing moved the phase margin by a degree as the mode moved by a fraction of a step.
pub fn margins_on(hz: &[f64], l: &[Complex64]) -> Margins {
    let band_sensitivity_db = l
        .iter()
        .zip(hz)
        .take_while(|(_, hz)| **hz <= BAND_HZ)
        .map(|(l, _)| -20.0 * (1.0 + l).norm().log10())
        .fold(f64::NEG_INFINITY, f64::max);
    let mut gain = f64::INFINITY;
    let mut phase_deg: f64 = 180.0;
    for w in l.windows(2) {
        let (a, b) = (w[0], w[1]);
        // The phase crossing −180°: the imaginary part changes sign with a negative real part.
        if a.im.signum() != b.im.signum() && (a.re < 0.0 || b.re < 0.0) {
            let t = a.im / (a.im - b.im);
            let re = a.re + t * (b.re - a.re);
            if re < 0.0 {
                gain = gain.min(1.0 / -re);
            }
        }
        let (ma, mb) = (a.norm(), b.norm());
        if (ma - 1.0).signum() != (mb - 1.0).signum() {
            let t = (1.0 - ma) / (mb - ma);
            let at = a + t * (b - a);
            let p = (180.0 + at.arg().to_degrees()).rem_euclid(360.0);
            phase_deg = phase_deg.min(p.min(360.0 - p));
        }
    }
    Margins {
        gain,
        phase_deg,
        band_sensitivity_db,
    }
}

/// The loop's frequencies: [`GRID_POINTS`] from 0.1 Hz to just under the Nyquist rate,
/// log-spaced.
pub fn loop_grid_hz() -> Vec<f64> {
    (0..GRID_POINTS).map(grid_hz).collect()
}

const GRID_POINTS: usize = 2000;

/// [`loop_grid_hz`] with points added about each mode of `models` as lightly damped as their
/// [`variants`] make it (`extrapolated`: whether each is outside the identified loads), sorted.
/// The grid's steps are 0.43 % apart, and a mode damped to ζ 0.007 (a tenth of an identified
/// 0.07 at an extrapolated load) is 1.5 % wide: its peak fell between points or on one as its
/// frequency moved by less than a step, and the feedback it allowed with it (the memo rig's 1 g
/// share 0.247 or 0.257 from the firmware's ticks or their CSV, fits 0.02 % apart; its 5 g
/// share read 0.75, on 12 000 points 0.61, on this grid 0.60). About each such
/// mode, [`MODE_POINTS`] a sixth of its damping apart, over five dampings either side.
pub fn loop_grid_about(models: &[(ApplicatorModel, bool)]) -> Vec<f64> {
    let mut hz = loop_grid_hz();
    let top = *hz.last().unwrap_or(&0.0);
    for (m, extrapolated) in models {
        let floor = if *extrapolated {
            0.5 * DAMPING_FLOOR
        } else {
            DAMPING_FLOOR
        };
        for mode in m.modes {
            let zeta = floor * mode.damping_ratio;
            if !(zeta.is_finite() && zeta > 0.0 && mode.hz.is_finite()) {
                continue;
            }
            let half = (MODE_POINTS / 2) as f64;
            hz.extend(
                (0..MODE_POINTS)
                    .map(|k| mode.hz * (1.0 + (k as f64 - half) * zeta / 6.0))
                    .filter(|f| *f > 0.0 && *f < top),
            );
        }
    }
    hz.sort_by(f64::total_cmp);
    hz.dedup();
    hz
}

/// The points [`loop_grid_about`] adds about each mode.
const MODE_POINTS: usize = 61;

fn grid_hz(i: usize) -> f64 {
    let (lo, hi) = (0.1f64, 0.49 / CONTROL_PERIOD_S);
    lo * (hi / lo).powf(i as f64 / (GRID_POINTS - 1) as f64)
}

/// The filter the error passes before the feedback's gains.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum ErrorFilter {
    /// None.
    Pass,
    /// A notch at `hz` (zeros on the unit circle there) with poles damped `damping`: the wider
    /// it is, the more of the mode's uncertain frequency it covers and the more phase it costs
    /// below.
    Notch { hz: f64, damping: f64 },
    /// A double real pole at `hz`.
    Lowpass { hz: f64 },
}

impl ErrorFilter {
    /// (b₀, b₁, b₂, a₁, a₂) of the discrete biquad (the notch by the bilinear transform,
    /// prewarped to its frequency; the poles matched, e^(−ωT)).
    pub fn biquad(&self) -> [f64; 5] {
        match *self {
            ErrorFilter::Pass => tactile_core::designed::FEEDBACK_PASS.map(f64::from),
            ErrorFilter::Notch { hz, damping } => {
                let w = 2.0 * std::f64::consts::PI * hz;
                let k = w / (w * CONTROL_PERIOD_S / 2.0).tan();
                let a0 = k * k + 2.0 * damping * w * k + w * w;
                let (n0, n1) = (k * k + w * w, 2.0 * (w * w - k * k));
                [
                    n0 / a0,
                    n1 / a0,
                    n0 / a0,
                    n1 / a0,
                    (k * k - 2.0 * damping * w * k + w * w) / a0,
                ]
            }
            ErrorFilter::Lowpass { hz } => {
                let a = (-2.0 * std::f64::consts::PI * hz * CONTROL_PERIOD_S).exp();
                [(1.0 - a) * (1.0 - a), 0.0, 0.0, -2.0 * a, a * a]
            }
        }
    }
}

impl std::fmt::Display for ErrorFilter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ErrorFilter::Pass => write!(f, "no filter"),
            ErrorFilter::Notch { hz, damping } => {
                write!(f, "a notch at {hz:.0} Hz (poles damped {damping})")
            }
            ErrorFilter::Lowpass { hz } => write!(f, "a double pole at {hz:.0} Hz"),
        }
    }
}

/// (b₀ + b₁z⁻¹ + b₂z⁻²)/(1 + a₁z⁻¹ + a₂z⁻²) at `z_inv`.
pub(super) fn biquad_at([b0, b1, b2, a1, a2]: [f64; 5], z_inv: Complex64) -> Complex64 {
    (b0 + z_inv * (b1 + z_inv * b2)) / (1.0 + z_inv * (a1 + z_inv * a2))
}

/// The feedback's response at `hz`: (kp + ki·T/(1 − z⁻¹))·F(z)·z⁻¹, F the biquad on the
/// error and z⁻¹ the tick the loop waits for the reading; as `tactile_core::designed` runs it.
fn feedback_at(kp: f64, ki_per_s: f64, biquad: [f64; 5], hz: f64) -> Complex64 {
    let z_inv = Complex64::from_polar(1.0, -2.0 * std::f64::consts::PI * hz * CONTROL_PERIOD_S);
    (kp + ki_per_s * CONTROL_PERIOD_S / (1.0 - z_inv)) * biquad_at(biquad, z_inv) * z_inv
}

/// The feedback a controller table runs at `load_g` (its share there), as [`Feedback::response`]
/// computes a design's: to check a table on a plant it was not designed on.
pub fn table_feedback(c: &DesignedConfig, load_g: f32) -> impl Fn(f64) -> Complex64 {
    let share = f64::from(c.series_at(load_g).1);
    let (kp, ki) = (share * f64::from(c.kp), share * f64::from(c.ki_per_s));
    let biquad = c.feedback_filter.map(f64::from);
    move |hz| feedback_at(kp, ki, biquad, hz)
}

/// The controller's feedback: what the margins are computed for.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Feedback {
    pub kp: f64,
    pub ki_per_s: f64,
    pub filter: ErrorFilter,
}

impl Feedback {
    /// The gains times `share` (a load's feedback share), the filter unchanged.
    pub fn scaled(self, share: f64) -> Feedback {
        Feedback {
            kp: share * self.kp,
            ki_per_s: share * self.ki_per_s,
            ..self
        }
    }

    /// The response at `hz` ([`feedback_at`]).
    pub fn response(&self, hz: f64) -> Complex64 {
        feedback_at(self.kp, self.ki_per_s, self.filter.biquad(), hz)
    }
}

/// The margins of `feedback` on `plant` (gauge g per drive g at each hertz).
pub fn loop_margins(feedback: Feedback, plant: impl Fn(f64) -> Complex64) -> Margins {
    let l: Vec<Complex64> = loop_grid_hz()
        .into_iter()
        .map(|hz| feedback.response(hz) * plant(hz))
        .collect();
    margins(&l)
}

/// `m` (first) and its variants: the modes' damping at [`DAMPING_FLOOR`] of the identified
/// (half that at an `extrapolated` load), the contact mode's, both, the beam's, and the beam's
/// with a tick more delay; each parameter moved by ±[`PLANT_TOLERANCE`] in turn (the gain,
/// each mode's frequency and damping, the amplifier's pole).
pub fn variants(m: &ApplicatorModel, extrapolated: bool) -> Vec<ApplicatorModel> {
    let mut out = vec![*m];
    let floor = if extrapolated {
        0.5 * DAMPING_FLOOR
    } else {
        DAMPING_FLOOR
    };
    let mut v = *m;
    v.modes[0].damping_ratio *= floor;
    out.push(v);
    v.modes[1].damping_ratio *= floor;
    out.push(v);
    v = *m;
    v.modes[1].damping_ratio *= floor;
    out.push(v);
    // A tick more delay, with the beam's damping at the floor as well: the fitted delay runs
    // negative (a lead of 0.6–0.8 ms where the hold alone delays half a tick) and the fitted
    // phase at the beam's mode leads the friction-free plant's by 40–100°.
    v.delay_s += CONTROL_PERIOD_S;
    out.push(v);
    for f in [1.0 - PLANT_TOLERANCE, 1.0 + PLANT_TOLERANCE] {
        let mut v = *m;
        v.gain *= f;
        out.push(v);
        v = *m;
        v.pole_hz *= f;
        out.push(v);
        for k in 0..2 {
            v = *m;
            v.modes[k].hz *= f;
            out.push(v);
            v = *m;
            v.modes[k].damping_ratio *= f;
            out.push(v);
        }
    }
    out
}

/// The least margins of a feedback (its response on [`loop_grid_hz`]) over plants given by
/// theirs.
pub(super) fn worst_margins(
    hz: &[f64],
    plants: &[Vec<Complex64>],
    feedback_on_grid: &[Complex64],
) -> Margins {
    plants.iter().fold(
        Margins {
            gain: f64::INFINITY,
            phase_deg: 180.0,
            band_sensitivity_db: f64::NEG_INFINITY,
        },
        |w, p| {
            let l: Vec<Complex64> = feedback_on_grid.iter().zip(p).map(|(c, p)| c * p).collect();
            let m = margins_on(hz, &l);
            Margins {
                gain: w.gain.min(m.gain),
                phase_deg: w.phase_deg.min(m.phase_deg),
                band_sensitivity_db: w.band_sensitivity_db.max(m.band_sensitivity_db),
            }
        },
    )
}

/// The largest x in [0, `hi`] that `passes` (which holds at 0 and fails past some point), by
/// bisection to 2⁻²⁴ of `hi`.
pub(super) fn largest_passing(hi: f64, passes: impl Fn(f64) -> bool) -> f64 {
    let (mut lo, mut hi) = (0.0f64, hi);
    for _ in 0..24 {
        let mid = 0.5 * (lo + hi);
        if passes(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::applicator_model::Resonance;

    #[test]
    fn the_margins_about_a_lightly_damped_mode_are_a_dense_grids_as_it_moves() {
        // A memo-like load below the identified ones: the contact mode at 30 Hz (ζ 0.073, a
        // tenth of that in the variant the margins must hold on), moved by steps of 0.06 % over
        // more than one of the plain grid's 0.43 % steps. The margins on the grid refined about
        // it are those on 200 000 points, each time.
        let r = |hz, damping_ratio| Resonance { hz, damping_ratio };
        let base = ApplicatorModel {
            gain: 1.0,
            anti_resonance: r(50.0, 0.15),
            modes: [r(30.0, 0.073), r(182.0, 0.046)],
            pole_hz: 167.0,
            delay_s: -0.14e-3,
            rms_log_error: 0.0,
        };
        let fb = Feedback {
            kp: 0.1,
            ki_per_s: 43.0,
            filter: ErrorFilter::Lowpass { hz: 15.0 },
        }
        .scaled(0.6);
        let (lo, hi) = (0.1f64, 0.49 / CONTROL_PERIOD_S);
        let dense: Vec<f64> = (0..200_000)
            .map(|i| lo * (hi / lo).powf(f64::from(i) / 199_999.0))
            .collect();
        for k in 0..10 {
            let mut m = base;
            m.modes[0].hz *= 1.0 + 6e-4 * f64::from(k);
            let lightest = variants(&m, true)[1];
            let on = |hz: &[f64]| {
                let l: Vec<Complex64> = hz
                    .iter()
                    .map(|f| fb.response(*f) * lightest.response(*f))
                    .collect();
                margins_on(hz, &l)
            };
            let (refined, exact) = (on(&loop_grid_about(&[(m, true)])), on(&dense));
            assert!(
                exact.gain.is_finite() && (refined.gain / exact.gain - 1.0).abs() < 0.01,
                "{k}: {refined:?} vs {exact:?}"
            );
            assert!(
                (refined.phase_deg - exact.phase_deg).abs() < 0.5,
                "{k}: {refined:?} vs {exact:?}"
            );
        }
    }
}
