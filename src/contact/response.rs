//! The array's spatial response: the share of a point contact's load each taxel reads.
//!
//! Each element senses the compression of the rubber over its plate, so a taxel reads the
//! vertical stress σ_zz of Boussinesq's half-space under a point force, 3F z³ / (2π R⁵),
//! averaged over its plate at the layer's depth z. The plate average has a closed form (the
//! corner of a rectangle under the point, superposed four times), and so does its gradient: the
//! locator's Gauss–Newton step needs both, with no numerical differentiation on the chip.
//!
//! Geometry: the memo gives the plate (2.5 × 5.1 mm = 12.75 mm²) but neither the pitch nor the
//! rubber's depth. The array is taken square, as the simulator's fixed kernel always was (the
//! same spread along rows and columns): plates of the memo's area as 3.57 mm squares on a
//! 4.0 mm pitch, the smallest round pitch that holds them with a gap. The depth, 4.0 mm, is the
//! one whose plate-averaged stress best reproduces that kernel at taxel-centre presses (within
//! 0.015 of 0.25, 0.10, 0.04, 0.02); a point sample instead of the plate average would put it
//! at 1.16 pitches (4.65 mm). All three are the configuration's, for a finger of other sizes.

use crate::tactile::{TaxelId, COLS, ROWS, TAXELS};

const TWO_PI: f32 = 2.0 * core::f32::consts::PI;

/// The spatial response's parameters, apart from any state: the geometry and each taxel's gain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpatialResponse {
    /// Centre-to-centre spacing of the taxels, along rows and columns, mm.
    pub pitch_mm: f32,
    /// Depth of the plates under the surface (the rubber's thickness over them), mm.
    pub depth_mm: f32,
    /// Side of each (square) plate, mm.
    pub plate_mm: f32,
    /// Each taxel's gain on its share of the load (1: the nominal element), by taxel index.
    pub gain: [f32; TAXELS],
}

impl SpatialResponse {
    /// The memo's element on the geometry the module's doc gives.
    pub const MEMO: SpatialResponse = SpatialResponse {
        pitch_mm: 4.0,
        depth_mm: 4.0,
        plate_mm: 3.570_714,
        gain: [1.0; TAXELS],
    };

    /// Centre of `taxel`'s plate, (x, y) in mm.
    pub fn centre_mm(&self, taxel: TaxelId) -> (f32, f32) {
        (
            taxel.col() as f32 * self.pitch_mm,
            taxel.row() as f32 * self.pitch_mm,
        )
    }

    /// Extent of the array's centres, (x, y) of the last taxel, mm.
    pub fn extent_mm(&self) -> (f32, f32) {
        (
            (COLS - 1) as f32 * self.pitch_mm,
            (ROWS - 1) as f32 * self.pitch_mm,
        )
    }

    /// Share of a point contact's load that a taxel at offset (`dx_mm`, `dy_mm`) from the
    /// contact reads, relative to a contact over its centre (1 there); with its gradient with
    /// respect to the contact's x and y. Zero for a non-positive depth or plate.
    pub fn share(&self, dx_mm: f32, dy_mm: f32) -> Share {
        self.shares()
            .map_or(Share::default(), |s| s.at(dx_mm, dy_mm))
    }

    /// The share's evaluator with the centre's load worked out once (a fit evaluates the
    /// share hundreds of times a frame); `None` for a non-positive depth or plate.
    pub fn shares(&self) -> Option<Shares> {
        let (z, h) = (self.depth_mm, 0.5 * self.plate_mm);
        if !(z > 0.0 && h > 0.0) {
            return None;
        }
        let centre = plate_sum(0.0, 0.0, h, z);
        (centre > 0.0 && centre.is_finite()).then(|| Shares {
            h,
            z,
            inv_centre: 1.0 / centre,
        })
    }
}

/// [`SpatialResponse::share`] for one geometry, its normalization computed once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shares {
    h: f32,
    z: f32,
    inv_centre: f32,
}

impl Shares {
    /// The share and its gradient (see [`SpatialResponse::share`]).
    pub fn at(&self, dx_mm: f32, dy_mm: f32) -> Share {
        let (h, z) = (self.h, self.z);
        // The contact at (u, v) from the plate's centre: the taxel's offset negated.
        let [value, du, dv] = plate_with_gradient(-dx_mm, -dy_mm, h, z);
        Share {
            weight: value * self.inv_centre,
            d_dx: du * self.inv_centre,
            d_dy: dv * self.inv_centre,
        }
    }

    /// The share alone, without its gradient (half the work).
    pub fn weight(&self, dx_mm: f32, dy_mm: f32) -> f32 {
        plate_sum(-dx_mm, -dy_mm, self.h, self.z) * self.inv_centre
    }
}

/// A taxel's share of the load and its gradient with respect to the contact's position.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Share {
    pub weight: f32,
    /// ∂weight/∂x and ∂weight/∂y of the contact, per mm.
    pub d_dx: f32,
    pub d_dy: f32,
}

/// Fraction of a unit point force's σ_zz integrated over the rectangle [0, a] × [0, b] at depth
/// `z` below it (Holl's corner formula; odd in `a` and in `b`, so rectangles anywhere superpose).
fn corner(a: f32, b: f32, z: f32) -> f32 {
    corner_terms(a, b, z).0
}

/// [`corner`] with the reciprocals its gradient reuses: 1/r, 1/(a² + z²), 1/(b² + z²).
fn corner_terms(a: f32, b: f32, z: f32) -> (f32, f32, f32, f32) {
    let (a2z, b2z) = (a * a + z * z, b * b + z * z);
    let inv_r = 1.0 / crate::trig::sqrtf(a2z + b * b);
    let (inv_a2z, inv_b2z) = (1.0 / a2z, 1.0 / b2z);
    let ab_r = a * b * inv_r;
    let value = (crate::trig::atanf(ab_r / z) + ab_r * z * (inv_a2z + inv_b2z)) / TWO_PI;
    (value, inv_r, inv_a2z, inv_b2z)
}

/// [`corner`] and its derivatives in `a` and in `b` (the point force's σ_zz integrated along
/// the side of length `b` at `a`, and along the side of length `a` at `b`), sharing one root.
// Not inlined: four copies in the locator's inner loop cost the F407's flash 1 KB.
#[inline(never)]
fn corner_with_gradient(a: f32, b: f32, z: f32) -> [f32; 3] {
    let (value, inv_r, inv_a2z, inv_b2z) = corner_terms(a, b, z);
    // z³ / (2π r³)
    let k = z * z * z * inv_r * inv_r * inv_r / TWO_PI;
    let (a2z, b2z) = (a * a + z * z, b * b + z * z);
    let d_da = k * b * (2.0 * b * b + 3.0 * a2z) * inv_a2z * inv_a2z;
    let d_db = k * a * (2.0 * a * a + 3.0 * b2z) * inv_b2z * inv_b2z;
    [value, d_da, d_db]
}

/// The plate's four corners with the point at (u, v) from its centre: (a, b, sign).
fn corners(u: f32, v: f32, h: f32) -> [(f32, f32, f32); 4] {
    [
        (h - u, h - v, 1.0),
        (-h - u, h - v, -1.0),
        (h - u, -h - v, -1.0),
        (-h - u, -h - v, 1.0),
    ]
}

/// The plate [−h, h]² integral with the point at (u, v) from its centre.
fn plate_sum(u: f32, v: f32, h: f32, z: f32) -> f32 {
    corners(u, v, h)
        .iter()
        .map(|&(a, b, sign)| sign * corner(a, b, z))
        .sum()
}

/// [`plate_sum`] with its derivatives in u and in v (a corner's a and b fall as u and v rise).
fn plate_with_gradient(u: f32, v: f32, h: f32, z: f32) -> [f32; 3] {
    let (mut value, mut du, mut dv) = (0.0f32, 0.0f32, 0.0f32);
    for (a, b, sign) in corners(u, v, h) {
        let [c, ca, cb] = corner_with_gradient(a, b, z);
        value += sign * c;
        du -= sign * ca;
        dv -= sign * cb;
    }
    [value, du, dv]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// σ_zz of a unit point force at depth z and radius r, integrated numerically over the
    /// plate: the closed form must agree.
    fn numeric_plate(u: f64, v: f64, h: f64, z: f64) -> f64 {
        let n = 400;
        let step = 2.0 * h / n as f64;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let x = -h + (i as f64 + 0.5) * step - u;
                let y = -h + (j as f64 + 0.5) * step - v;
                let r2 = x * x + y * y + z * z;
                sum += 3.0 * z.powi(3) / (2.0 * std::f64::consts::PI * r2.powf(2.5));
            }
        }
        sum * step * step
    }

    #[test]
    fn the_closed_form_integrates_boussinesq_over_the_plate() {
        let (h, z) = (1.8f32, 4.0f32);
        for (u, v) in [(0.0, 0.0), (1.0, 0.5), (4.0, 0.0), (4.0, 8.0), (-6.0, 3.0)] {
            let closed = f64::from(plate_sum(u, v, h, z));
            let numeric = numeric_plate(f64::from(u), f64::from(v), f64::from(h), f64::from(z));
            assert!(
                (closed - numeric).abs() < 1e-4 * numeric.max(1e-3),
                "{u},{v}: {closed} vs {numeric}"
            );
        }
        // A quarter of the load under a corner of an infinite plate.
        assert!((corner(1e4, 1e4, z) - 0.25).abs() < 1e-4);
    }

    #[test]
    fn the_gradient_matches_finite_differences() {
        let s = SpatialResponse::MEMO;
        for (dx, dy) in [(0.3, -0.2), (2.0, 1.0), (-4.0, 3.0), (6.0, -6.5)] {
            let g = s.share(dx, dy);
            let e = 1e-2;
            let fx = (s.share(dx + e, dy).weight - s.share(dx - e, dy).weight) / (2.0 * e);
            let fy = (s.share(dx, dy + e).weight - s.share(dx, dy - e).weight) / (2.0 * e);
            // The gradient is with respect to the contact, the offset is the taxel's: opposite.
            assert!(
                (g.d_dx + fx).abs() < 2e-3,
                "{dx},{dy}: {} vs {}",
                g.d_dx,
                -fx
            );
            assert!(
                (g.d_dy + fy).abs() < 2e-3,
                "{dx},{dy}: {} vs {}",
                g.d_dy,
                -fy
            );
        }
    }

    /// The memo geometry reproduces the simulator's fixed kernel at taxel-centre presses.
    #[test]
    fn the_memo_geometry_reproduces_the_fixed_kernel() {
        let s = SpatialResponse::MEMO;
        let p = s.pitch_mm;
        assert!((s.share(0.0, 0.0).weight - 1.0).abs() < 1e-6);
        for ((dr, dc), kernel) in [
            ((0, 1), 0.25),
            ((1, 1), 0.10),
            ((0, 2), 0.04),
            ((1, 2), 0.02),
        ] {
            let w = s.share(dc as f32 * p, dr as f32 * p).weight;
            assert!((w - kernel).abs() < 0.015, "({dr},{dc}): {w} vs {kernel}");
            // Symmetric in the axes and the signs.
            assert!((s.share(-(dr as f32) * p, -(dc as f32) * p).weight - w).abs() < 1e-5);
        }
    }
}
