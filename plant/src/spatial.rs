//! How the probe's load spreads over the array: the fixed kernel of the memo's experiments
//! (the probe over a taxel's centre), or an elastic half-space under a contact anywhere.

use tactile_core::contact::SpatialResponse;
use tactile_core::tactile::{TaxelId, TAXELS};

use crate::finger::crosstalk_weight;

/// The spread of the probe's load to the taxels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpatialLaw {
    /// The fixed kernel about the probe taxel's centre (1, 0.25, 0.10, 0.04, 0.02): the
    /// experiments and committed tables of the single element; the position is ignored.
    Kernel,
    /// Boussinesq's half-space: each taxel reads σ_zz under a point contact averaged over its
    /// plate at `depth_mm` (the core's [`SpatialResponse`], so the simulator and the chip share
    /// one copy of the formula), relative to a contact over its centre, on a square array of
    /// `pitch_mm` (plates the memo's 3.57 mm squares); the memo geometry, 4.0 mm deep on a
    /// 4.0 mm pitch, reproduces the kernel at taxel-centre presses within 0.015.
    HalfSpace { depth_mm: f64, pitch_mm: f64 },
    /// The same half-space read as strain rather than stress: the compression −ε_zz under a
    /// point, ∝ z(3z² − 2νR²)/R⁵ (Boussinesq's displacement differentiated, Poisson's ratio
    /// `poisson`), averaged over each plate numerically, relative to a centred contact. It
    /// narrows faster than σ_zz and turns to extension beyond r = z·√(3/(2ν) − 1) (1.41
    /// depths for rubber's ν = 0.5), read as no load: a field the locator's model does not
    /// hold.
    Strain {
        depth_mm: f64,
        pitch_mm: f64,
        poisson: f64,
    },
}

impl SpatialLaw {
    /// The half-space at the memo geometry's depth.
    pub const MEMO_HALF_SPACE: SpatialLaw = SpatialLaw::HalfSpace {
        depth_mm: SpatialResponse::MEMO.depth_mm as f64,
        pitch_mm: SpatialResponse::MEMO.pitch_mm as f64,
    };

    /// The half-space `depth_mm` deep on the memo geometry's pitch.
    pub const fn half_space(depth_mm: f64) -> SpatialLaw {
        SpatialLaw::HalfSpace {
            depth_mm,
            pitch_mm: SpatialResponse::MEMO.pitch_mm as f64,
        }
    }

    /// The spatial response this law is (the kernel: the memo geometry, which reproduces it).
    pub fn response(self) -> SpatialResponse {
        match self {
            SpatialLaw::Kernel => SpatialResponse::MEMO,
            SpatialLaw::HalfSpace { depth_mm, pitch_mm }
            | SpatialLaw::Strain {
                depth_mm, pitch_mm, ..
            } => SpatialResponse {
                depth_mm: depth_mm as f32,
                pitch_mm: pitch_mm as f32,
                ..SpatialResponse::MEMO
            },
        }
    }

    /// Every taxel's share of the load with the contact at (`x_mm`, `y_mm`) (the kernel: about
    /// `probe`'s centre).
    pub fn shares(self, probe: TaxelId, x_mm: f64, y_mm: f64) -> [f64; TAXELS] {
        core::array::from_fn(|i| {
            let t = TaxelId::from_index(i);
            match self {
                SpatialLaw::Kernel => crosstalk_weight(
                    t.row() as i32 - probe.row() as i32,
                    t.col() as i32 - probe.col() as i32,
                ),
                SpatialLaw::HalfSpace { .. } => {
                    let r = self.response();
                    let (cx, cy) = r.centre_mm(t);
                    let w = r.share(cx - x_mm as f32, cy - y_mm as f32).weight;
                    unloaded_below_a_millionth(f64::from(w))
                }
                SpatialLaw::Strain {
                    depth_mm, poisson, ..
                } => {
                    let r = self.response();
                    let (cx, cy) = r.centre_mm(t);
                    let h = 0.5 * f64::from(r.plate_mm);
                    let at = |u: f64, v: f64| plate_strain(u, v, h, depth_mm, poisson);
                    let w = at(f64::from(cx) - x_mm, f64::from(cy) - y_mm) / at(0.0, 0.0);
                    unloaded_below_a_millionth(w)
                }
            }
        })
    }
}

/// Below a millionth the share is nothing a taxel can read: left unloaded so its state is not
/// stepped each scan (and a taxel in extension reads no load).
fn unloaded_below_a_millionth(w: f64) -> f64 {
    if w > 1e-6 && w.is_finite() {
        w
    } else {
        0.0
    }
}

/// Gauss–Legendre nodes and weights on [−1, 1], six points (exact to degree 11).
const GAUSS_6: [(f64, f64); 6] = [
    (-0.932_469_514_203_152, 0.171_324_492_379_170),
    (-0.661_209_386_466_265, 0.360_761_573_048_139),
    (-0.238_619_186_083_197, 0.467_913_934_572_691),
    (0.238_619_186_083_197, 0.467_913_934_572_691),
    (0.661_209_386_466_265, 0.360_761_573_048_139),
    (0.932_469_514_203_152, 0.171_324_492_379_170),
];

/// The compressive strain z(3z² − 2νR²)/R⁵ of a point load integrated over the plate
/// [−h, h]² centred (`u_mm`, `v_mm`) from the load, at depth `z_mm` (6 × 6 Gauss points: the
/// depth keeps the integrand smooth over a plate of about its size).
fn plate_strain(u_mm: f64, v_mm: f64, h_mm: f64, z_mm: f64, poisson: f64) -> f64 {
    let mut sum = 0.0;
    for (a, wa) in GAUSS_6 {
        for (b, wb) in GAUSS_6 {
            let (x, y) = (u_mm + h_mm * a, v_mm + h_mm * b);
            let r2 = x * x + y * y + z_mm * z_mm;
            let r5 = r2 * r2 * libm::sqrt(r2);
            sum += wa * wb * z_mm * (3.0 * z_mm * z_mm - 2.0 * poisson * r2) / r5;
        }
    }
    sum * h_mm * h_mm
}

/// The taxels other than `probe` with a share, for the finger's per-tick accumulation.
pub(crate) fn loaded_of(
    shares: &[f64; TAXELS],
    probe: TaxelId,
) -> heapless::Vec<(usize, f64), TAXELS> {
    let mut loaded = heapless::Vec::new();
    for (i, &w) in shares.iter().enumerate() {
        if w > 0.0 && i != probe.index() {
            // At most 64 entries: the push cannot fail.
            let _ = loaded.push((i, w));
        }
    }
    loaded
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::finger::{Effects, Finger, ReadoutParams};
    use tactile_core::gauge::AdcScale;
    use tactile_core::tactile::{ScanConfig, COLS};

    fn finger() -> Finger {
        Finger::new(
            3,
            crate::finger::NOMINAL_TAXEL,
            Effects::MEMO,
            ReadoutParams::default(),
            AdcScale::BIPOLAR_10V_12BIT,
            ScanConfig::DESIGN,
        )
    }

    #[test]
    fn the_default_finger_keeps_the_fixed_kernel() {
        let f = finger();
        assert_eq!(f.law(), SpatialLaw::Kernel);
        let p = f.probe;
        for i in 0..TAXELS {
            let t = TaxelId::from_index(i);
            let k = crosstalk_weight(
                t.row() as i32 - p.row() as i32,
                t.col() as i32 - p.col() as i32,
            );
            assert_eq!(f.load_share(i).to_bits(), k.to_bits());
        }
    }

    /// Boussinesq's σ_zz ∝ (1 + r²/z²)^(−5/2) at the taxels' centres gives the fixed kernel
    /// with z = 1.16 pitches; averaged over the plates, with z = 1.0 pitch.
    #[test]
    fn the_kernel_is_the_half_space_sampled_at_a_depth_of_a_pitch() {
        let z = 1.0 / (0.25f64.powf(-0.4) - 1.0).sqrt();
        assert!((z - 1.16).abs() < 0.005, "{z}");
        let point = |r2: f64| (1.0 + r2 / (z * z)).powf(-2.5);
        for (r2, k) in [(2.0, 0.10), (4.0, 0.04), (5.0, 0.02)] {
            assert!(
                (point(r2) - k).abs() < 0.01,
                "r² = {r2}: {} vs {k}",
                point(r2)
            );
        }
        let mut f = finger();
        let probe = f.probe;
        let pitch = f64::from(SpatialResponse::MEMO.pitch_mm);
        let (x, y) = (probe.col() as f64 * pitch, probe.row() as f64 * pitch);
        f.press_at(SpatialLaw::MEMO_HALF_SPACE, x, y);
        for i in 0..TAXELS {
            let t = TaxelId::from_index(i);
            let (dr, dc) = (
                t.row() as i32 - probe.row() as i32,
                t.col() as i32 - probe.col() as i32,
            );
            let d = (f.load_share(i) - crosstalk_weight(dr, dc)).abs();
            assert!(d < 0.015, "({dr},{dc}): {}", f.load_share(i));
        }
    }

    /// The strain field follows the contact: halfway between two taxels they read alike, and
    /// as the contact moves toward one its share grows while the other's falls.
    #[test]
    fn the_strain_field_follows_the_contact() {
        let mut f = finger();
        let (a, b) = (3 * COLS + 2, 3 * COLS + 3);
        let pitch = f64::from(SpatialResponse::MEMO.pitch_mm);
        let y = 3.0 * pitch;
        let mut last = (f64::INFINITY, 0.0);
        for k in 0..=8 {
            let x = 2.0 * pitch + pitch * k as f64 / 8.0;
            f.press_at(SpatialLaw::MEMO_HALF_SPACE, x, y);
            let (sa, sb) = (f.load_share(a), f.load_share(b));
            assert!(sa < last.0 && sb > last.1, "{x} mm: {sa} {sb}");
            if k == 4 {
                assert!((sa - sb).abs() < 1e-6, "{sa} {sb}");
                // Halfway, each reads well under the centred 1 and well over the kernel's 0.25.
                assert!(sa > 0.5 && sa < 0.8, "{sa}");
            }
            last = (sa, sb);
        }
        // And the taxel strains through the finger's dynamics follow: the nearer taxel the more
        // (by less than the shares' ratio of about 1.9: the springs stiffen with load).
        f.press_at(SpatialLaw::MEMO_HALF_SPACE, 2.25 * pitch, y);
        for _ in 0..2000 {
            f.tick(40.0, 1e-3);
        }
        f.readout.noise_pct = 0.0;
        let cal = f.rest_calibration(1);
        let strain = |f: &mut Finger, i: usize, prev: usize| {
            let code = f.sample_scan(TaxelId::from_index(i), TaxelId::from_index(prev), 40.0, 2.0);
            crate::finger::code_to_strain_pct(&f.adc, &cal[i], code)
        };
        let (ea, eb) = (strain(&mut f, a, a - 1), strain(&mut f, b, a));
        assert!(ea > 1.2 * eb && eb > 0.5, "{ea} {eb}");
    }

    /// Read as strain: with ν = 0 the compression is σ_zz's shape (3z³/R⁵), so the numerical
    /// plate average gives the half-space's closed form; with rubber's ν = 0.5 a neighbour a
    /// pitch away reads 0.614 of what σ_zz gives it (point-sampled, (1/2^2.5)/2 against 2^−2.5:
    /// a half; over the plate, a 400 × 400 midpoint sum gives 0.6143), and a taxel two pitches
    /// away, all of its plate beyond r = √2 z, none.
    #[test]
    fn read_as_strain_the_field_narrows_and_turns_to_extension() {
        let pitch = f64::from(SpatialResponse::MEMO.pitch_mm);
        let depth = f64::from(SpatialResponse::MEMO.depth_mm);
        let probe = NOMINAL_PROBE;
        let (x, y) = (probe.col() as f64 * pitch, probe.row() as f64 * pitch);
        let strain = |poisson| SpatialLaw::Strain {
            depth_mm: depth,
            pitch_mm: pitch,
            poisson,
        };
        let stress = SpatialLaw::MEMO_HALF_SPACE.shares(probe, x + 1.3, y - 0.7);
        let like = strain(0.0).shares(probe, x + 1.3, y - 0.7);
        for (a, b) in stress.iter().zip(like) {
            assert!((a - b).abs() < 1e-4, "{a} {b}");
        }
        let rubber = strain(0.5).shares(probe, x, y);
        let near = |dr: usize, dc: usize| probe.index() + dr * COLS + dc;
        assert!((rubber[probe.index()] - 1.0).abs() < 1e-9);
        let ratio = rubber[near(0, 1)] / stress_at(near(0, 1), x, y);
        assert!((ratio - 0.6143).abs() < 0.002, "{ratio}");
        assert_eq!(rubber[near(0, 2)], 0.0);
        assert_eq!(rubber[near(2, 0)], 0.0);
    }

    const NOMINAL_PROBE: TaxelId = crate::finger::NOMINAL_TAXEL;

    fn stress_at(index: usize, x: f64, y: f64) -> f64 {
        SpatialLaw::MEMO_HALF_SPACE.shares(NOMINAL_PROBE, x, y)[index]
    }
}
