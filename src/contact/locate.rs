//! One point contact fitted to a frame of per-taxel forces: Levenberg–Marquardt on (x, y, F)
//! over the peak's neighbourhood, started at the neighbourhood's centroid, and a verdict on
//! whether the frame is one point at all (nothing, two peaks, or a load the point's spread
//! leaves unexplained, as a line or a wide contact does).

use super::response::{Shares, SpatialResponse};
use crate::tactile::{TaxelId, COLS, ROWS, TAXELS};

/// The locator's settings beside the spatial response.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocatorConfig {
    pub response: SpatialResponse,
    /// Total force below which the frame holds no contact, grams.
    pub min_force_g: f32,
    /// Half-width of the fitted neighbourhood, taxels (1: a 3 × 3 window about the peak; the
    /// 5 × 5 window located no better on the simulator's frames, at 2.8 times the work).
    pub window: usize,
    /// Levenberg–Marquardt iterations at most (each one a pass over the window).
    pub max_iterations: u8,
    /// Share of the array's load (sum of squares) the fitted point may leave unexplained: above
    /// it the frame is not one point. Noise and a ±2 % gain spread leave about 0.02 %.
    pub max_residual_share: f32,
    /// A second local maximum at least two taxels from the peak carrying this share of the
    /// peak's force (and above the noise) makes the frame two contacts.
    pub second_peak_share: f32,
}

impl LocatorConfig {
    pub const MEMO: LocatorConfig = LocatorConfig {
        response: SpatialResponse::MEMO,
        min_force_g: 2.0,
        window: 1,
        max_iterations: 12,
        max_residual_share: 0.01,
        second_peak_share: 0.05,
    };
}

/// What the frame holds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ContactKind {
    /// Total force below the threshold, or no finite taxel.
    #[default]
    Nothing,
    /// One point contact: the location and force are the fit's.
    Point,
    /// A second peak away from the first: two contacts (the location is the larger one's).
    TwoPeaks,
    /// One region the point's spread does not explain (a line, a wide or flat contact): the
    /// location is its best point's, the force the fitted point's.
    Spread,
}

impl ContactKind {
    /// The kind's name in records and reports.
    pub const fn name(self) -> &'static str {
        match self {
            ContactKind::Nothing => "nothing",
            ContactKind::Point => "point",
            ContactKind::TwoPeaks => "two_peaks",
            ContactKind::Spread => "spread",
        }
    }
}

/// The locator's answer for one frame. Location and force are always finite.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ContactEstimate {
    pub kind: ContactKind,
    /// Contact location, mm (0 for [`ContactKind::Nothing`]).
    pub x_mm: f32,
    pub y_mm: f32,
    /// The fitted point's force (the sum of the finite taxels for `Nothing`), grams.
    pub force_g: f32,
    /// Share of the array's sum of squares the fitted point leaves unexplained (a second
    /// contact outside the fitted window counts).
    pub residual_share: f32,
    /// Force-weighted centroid of the whole array, mm, beside the fit (0 for `Nothing`).
    pub centroid_x_mm: f32,
    pub centroid_y_mm: f32,
}

/// The locator: its configuration (no state carries between frames).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Locator {
    pub config: LocatorConfig,
}

/// The fitted neighbourhood: its row and column ranges (inclusive).
#[derive(Clone, Copy, Debug)]
struct Window {
    rows: (usize, usize),
    cols: (usize, usize),
}

impl Window {
    /// The taxels within `radius` rows and columns of `t`, clipped to the array.
    fn about(t: TaxelId, radius: usize) -> Window {
        Window {
            rows: (
                t.row().saturating_sub(radius),
                (t.row() + radius).min(ROWS - 1),
            ),
            cols: (
                t.col().saturating_sub(radius),
                (t.col() + radius).min(COLS - 1),
            ),
        }
    }

    fn taxels(self) -> impl Iterator<Item = TaxelId> {
        // One flat count rather than nested iterators: the locator runs on the F407, whose
        // flash the nested form's code took a share of.
        // A width that cannot be zero: its division carries no panic path (nor core's
        // formatting behind it) onto the firmware.
        let width =
            core::num::NonZeroUsize::MIN.saturating_add(self.cols.1.saturating_sub(self.cols.0));
        let n = (self.rows.1.saturating_sub(self.rows.0) + 1) * width.get();
        (0..n).map(move |k| {
            TaxelId::from_index((self.rows.0 + k / width) * COLS + self.cols.0 + k % width)
        })
    }
}

fn value(forces_g: &[f32; TAXELS], taxel: TaxelId) -> Option<f32> {
    forces_g
        .get(taxel.index())
        .copied()
        .filter(|f| f.is_finite())
}

impl Locator {
    pub const fn new(config: LocatorConfig) -> Self {
        Self { config }
    }

    /// The contact in one frame of per-taxel forces (grams, by taxel index). Non-finite taxels
    /// are left out (a dead taxel), never propagated.
    pub fn locate(&self, forces_g: &[f32; TAXELS]) -> ContactEstimate {
        let cfg = &self.config;
        let mut nothing = ContactEstimate {
            kind: ContactKind::Nothing,
            x_mm: 0.0,
            y_mm: 0.0,
            force_g: 0.0,
            residual_share: 0.0,
            centroid_x_mm: 0.0,
            centroid_y_mm: 0.0,
        };
        let (mut total, mut positive, mut sx, mut sy) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
        let mut peak = None;
        for i in 0..TAXELS {
            let t = TaxelId::from_index(i);
            let Some(f) = value(forces_g, t) else {
                continue;
            };
            total += f;
            let (x, y) = cfg.response.centre_mm(t);
            let w = f.max(0.0);
            positive += w;
            sx += w * x;
            sy += w * y;
            if peak.is_none_or(|(_, p)| f > p) {
                peak = Some((t, f));
            }
        }
        nothing.force_g = if total.is_finite() { total } else { 0.0 };
        let Some((peak, peak_g)) = peak else {
            return nothing;
        };
        if !(total >= cfg.min_force_g && positive > 0.0 && peak_g > 0.0) {
            return nothing;
        }
        let (centroid_x_mm, centroid_y_mm) = (sx / positive, sy / positive);
        let window = self.window_about(peak);
        let Some(shares) = cfg.response.shares() else {
            return nothing;
        };
        let Some(mut fit) = self.fit(forces_g, window, &shares) else {
            return nothing;
        };
        fit.residual_share = self.residual_share(forces_g, &fit, &shares);
        fit.centroid_x_mm = centroid_x_mm;
        fit.centroid_y_mm = centroid_y_mm;
        if fit.residual_share > cfg.max_residual_share {
            fit.kind = ContactKind::Spread;
        }
        if self.second_peak(forces_g, peak, peak_g) {
            fit.kind = ContactKind::TwoPeaks;
        }
        fit
    }

    /// The fitted point's unexplained share of the whole array's sum of squares.
    fn residual_share(
        &self,
        forces_g: &[f32; TAXELS],
        fit: &ContactEstimate,
        shares: &Shares,
    ) -> f32 {
        let r = &self.config.response;
        let (mut cost, mut load) = (0.0f32, 0.0f32);
        for i in 0..TAXELS {
            let t = TaxelId::from_index(i);
            let Some(f) = value(forces_g, t) else {
                continue;
            };
            let (cx, cy) = r.centre_mm(t);
            let gain = r.gain.get(i).copied().unwrap_or(1.0);
            let resid = f - gain * fit.force_g * shares.weight(cx - fit.x_mm, cy - fit.y_mm);
            cost += resid * resid;
            load += f * f;
        }
        let share = if load > 0.0 { cost / load } else { 0.0 };
        if share.is_finite() {
            share
        } else {
            1.0
        }
    }

    fn window_about(&self, peak: TaxelId) -> Window {
        Window::about(peak, self.config.window)
    }

    /// A local maximum (no neighbour larger) at least two taxels from the peak, above the
    /// threshold and a share of the peak.
    fn second_peak(&self, forces_g: &[f32; TAXELS], peak: TaxelId, peak_g: f32) -> bool {
        let floor = (self.config.second_peak_share * peak_g).max(self.config.min_force_g * 0.25);
        (0..TAXELS).map(TaxelId::from_index).any(|t| {
            let far = t
                .row()
                .abs_diff(peak.row())
                .max(t.col().abs_diff(peak.col()))
                >= 2;
            let Some(f) = value(forces_g, t) else {
                return false;
            };
            far && f >= floor && {
                let around = Window::about(t, 1);
                around
                    .taxels()
                    .filter(|&n| n != t)
                    .all(|n| value(forces_g, n).is_none_or(|g| g <= f))
            }
        })
    }
}

/// Normal equations of the point model over a window at one (x, y, F).
#[derive(Clone, Copy, Debug, Default)]
struct Normal {
    /// JᵀJ's upper triangle: xx, xy, xF, yy, yF, FF.
    jtj: [f32; 6],
    /// Jᵀr for x, y, F.
    jtr: [f32; 3],
    /// Sum of squared residuals, and of squared readings.
    cost: f32,
    load: f32,
    taxels: usize,
}

impl Locator {
    /// The model's residuals and normal equations at (x, y, F) over `window`.
    fn normal(
        &self,
        forces_g: &[f32; TAXELS],
        window: Window,
        shares: &Shares,
        p: [f32; 3],
    ) -> Normal {
        let [x, y, force] = p;
        let r = &self.config.response;
        let mut n = Normal::default();
        for t in window.taxels() {
            let Some(f) = value(forces_g, t) else {
                continue;
            };
            let (cx, cy) = r.centre_mm(t);
            let gain = r.gain.get(t.index()).copied().unwrap_or(1.0);
            let s = shares.at(cx - x, cy - y);
            let resid = f - gain * force * s.weight;
            // Derivatives of the model (the residual's, negated).
            let j = [
                gain * force * s.d_dx,
                gain * force * s.d_dy,
                gain * s.weight,
            ];
            let [a, b, c] = j;
            n.jtj[0] += a * a;
            n.jtj[1] += a * b;
            n.jtj[2] += a * c;
            n.jtj[3] += b * b;
            n.jtj[4] += b * c;
            n.jtj[5] += c * c;
            n.jtr[0] += a * resid;
            n.jtr[1] += b * resid;
            n.jtr[2] += c * resid;
            n.cost += resid * resid;
            n.load += f * f;
            n.taxels += 1;
        }
        n
    }

    /// Levenberg–Marquardt from the window's centroid; `None` with too few finite taxels or
    /// no load in the window.
    fn fit(
        &self,
        forces_g: &[f32; TAXELS],
        window: Window,
        shares: &Shares,
    ) -> Option<ContactEstimate> {
        let cfg = &self.config;
        let (mut w, mut sx, mut sy) = (0.0f32, 0.0f32, 0.0f32);
        for t in window.taxels() {
            let f = value(forces_g, t).unwrap_or(0.0).max(0.0);
            let (cx, cy) = cfg.response.centre_mm(t);
            w += f;
            sx += f * cx;
            sy += f * cy;
        }
        if w.is_nan() || w <= 0.0 {
            return None;
        }
        let (x0, y0) = (sx / w, sy / w);
        // The force that best explains the window with the point at the centroid.
        let at = self.normal(forces_g, window, shares, [x0, y0, 1.0]);
        let f0 = if at.jtj[5] > 0.0 {
            at.jtr[2] / at.jtj[5] + 1.0
        } else {
            w
        };
        let mut p = [x0, y0, f0];
        let mut n = self.normal(forces_g, window, shares, p);
        if n.taxels < 4 {
            return None;
        }
        let (xmax, ymax) = cfg.response.extent_mm();
        let half = 0.5 * cfg.response.pitch_mm;
        let mut lambda = 1e-3f32;
        for _ in 0..cfg.max_iterations {
            let Some(step) = solve_damped(&n, lambda) else {
                break;
            };
            let [dx, dy, df] = step;
            let trial = [
                crate::limit(p[0] + dx, -half, xmax + half),
                crate::limit(p[1] + dy, -half, ymax + half),
                (p[2] + df).max(0.0),
            ];
            // A step this short moves the point by nothing the location's error could show
            // (a thousandth of a pitch), taken or not: the fit has converged. Without it a fit
            // at its f32 floor spends every remaining iteration refusing steps.
            let small = dx.abs() + dy.abs() < 1e-3 * cfg.response.pitch_mm;
            let m = self.normal(forces_g, window, shares, trial);
            if m.cost.is_finite() && m.cost <= n.cost {
                p = trial;
                n = m;
                lambda = (lambda * 0.1).max(1e-7);
                if small {
                    break;
                }
            } else if small {
                break;
            } else {
                lambda *= 10.0;
                if lambda > 1e6 {
                    break;
                }
            }
        }
        let share = if n.load > 0.0 { n.cost / n.load } else { 0.0 };
        let [x_mm, y_mm, force_g] = p;
        if !(x_mm.is_finite() && y_mm.is_finite() && force_g.is_finite()) {
            return None;
        }
        Some(ContactEstimate {
            kind: ContactKind::Point,
            x_mm,
            y_mm,
            force_g,
            residual_share: if share.is_finite() { share } else { 1.0 },
            centroid_x_mm: 0.0,
            centroid_y_mm: 0.0,
        })
    }
}

/// (JᵀJ + λ diag JᵀJ) δ = Jᵀr by Cramer's rule; `None` when singular.
fn solve_damped(n: &Normal, lambda: f32) -> Option<[f32; 3]> {
    let [xx, xy, xf, yy, yf, ff] = n.jtj;
    let (a, d, f) = (
        xx * (1.0 + lambda),
        yy * (1.0 + lambda),
        ff * (1.0 + lambda),
    );
    let (b, c, e) = (xy, xf, yf);
    let [r0, r1, r2] = n.jtr;
    // | a b c |
    // | b d e |
    // | c e f |
    let det = a * (d * f - e * e) - b * (b * f - e * c) + c * (b * e - d * c);
    if !det.is_finite() || det.abs() <= f32::MIN_POSITIVE {
        return None;
    }
    let dx = (r0 * (d * f - e * e) - b * (r1 * f - e * r2) + c * (r1 * e - d * r2)) / det;
    let dy = (a * (r1 * f - e * r2) - r0 * (b * f - e * c) + c * (b * r2 - r1 * c)) / det;
    let df = (a * (d * r2 - r1 * e) - b * (b * r2 - r1 * c) + r0 * (b * e - d * c)) / det;
    let step = [dx, dy, df];
    step.iter().all(|s| s.is_finite()).then_some(step)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(points: &[(f32, f32, f32)]) -> [f32; TAXELS] {
        let r = SpatialResponse::MEMO;
        core::array::from_fn(|i| {
            let (cx, cy) = r.centre_mm(TaxelId::from_index(i));
            points
                .iter()
                .map(|&(x, y, f)| f * r.share(cx - x, cy - y).weight)
                .sum()
        })
    }

    const LOCATOR: Locator = Locator::new(LocatorConfig::MEMO);

    #[test]
    fn a_clean_point_is_found_where_it_is() {
        for (x, y, f) in [(10.3, 13.9, 40.0), (4.0, 4.0, 10.0), (21.7, 6.2, 100.0)] {
            let e = LOCATOR.locate(&frame(&[(x, y, f)]));
            assert_eq!(e.kind, ContactKind::Point, "{e:?}");
            // The model is the frame's own: what is left is f32 rounding.
            assert!(
                (e.x_mm - x).abs() < 0.01 && (e.y_mm - y).abs() < 0.01,
                "{e:?}"
            );
            assert!((e.force_g - f).abs() < 0.01 * f, "{e:?}");
            assert!(e.residual_share < 1e-4, "{e:?}");
        }
    }

    #[test]
    fn nothing_bad_or_dead_taxels_give_a_clear_finite_answer() {
        let zero = LOCATOR.locate(&[0.0; TAXELS]);
        assert_eq!(zero.kind, ContactKind::Nothing);
        let nan = LOCATOR.locate(&[f32::NAN; TAXELS]);
        assert_eq!(nan.kind, ContactKind::Nothing);
        let inf = LOCATOR.locate(&[f32::INFINITY; TAXELS]);
        assert_eq!(inf.kind, ContactKind::Nothing);
        for e in [zero, nan, inf] {
            assert!(
                e.x_mm.is_finite() && e.y_mm.is_finite() && e.force_g.is_finite(),
                "{e:?}"
            );
        }
        let negative = LOCATOR.locate(&[-3.0; TAXELS]);
        assert_eq!(negative.kind, ContactKind::Nothing);
        // A dead taxel beside the contact is left out, not propagated.
        let mut f = frame(&[(12.5, 11.0, 50.0)]);
        f[2 * COLS + 3] = f32::NAN;
        let e = LOCATOR.locate(&f);
        assert_eq!(e.kind, ContactKind::Point, "{e:?}");
        assert!(
            (e.x_mm - 12.5).abs() < 0.05 && (e.y_mm - 11.0).abs() < 0.05,
            "{e:?}"
        );
    }

    #[test]
    fn two_contacts_and_a_line_are_not_a_point() {
        let two = LOCATOR.locate(&frame(&[(8.0, 12.0, 40.0), (18.0, 12.0, 40.0)]));
        assert_eq!(two.kind, ContactKind::TwoPeaks, "{two:?}");
        let line: Vec<(f32, f32, f32)> = (0..13)
            .map(|k| (8.0 + k as f32, 14.0, 60.0 / 13.0))
            .collect();
        let e = LOCATOR.locate(&frame(&line));
        assert_ne!(e.kind, ContactKind::Point, "{e:?}");
    }
}
