//! The chip's contact locator on frames from the simulator's half-space finger at rest: the
//! fit's location and force errors beside the centroid's on the same frames, and how often two
//! contacts or a line are said not to be one point. Run with `--nocapture` for the figures.
//!
//! A frame is each taxel's force estimate at rest: its share of the load (the finger's
//! `Finger::load_share`) times the force, times a per-taxel static error of a calibrated
//! estimator (uniform ±2 %) plus 0.05 g RMS of noise (the finger's 0.022 g through an
//! estimator's gain on a 16 ms frame, rounded up).

use tactile_core::contact::{ContactKind, Locator, LocatorConfig, SpatialResponse};
use tactile_core::gauge::AdcScale;
use tactile_core::tactile::{ScanConfig, TAXELS};
use tactile_plant::finger::{Effects, Finger, ReadoutParams, NOMINAL_TAXEL};
use tactile_plant::noise::Noise;
use tactile_plant::spatial::SpatialLaw;

const FRAMES: usize = 400;
const PITCH_MM: f64 = SpatialResponse::MEMO.pitch_mm as f64;

struct Bench {
    finger: Finger,
    noise: Noise,
    gain_error: [f64; TAXELS],
    law: SpatialLaw,
}

impl Bench {
    fn new(seed: u64, law: SpatialLaw, gain_spread: f64) -> Self {
        let mut noise = Noise::new(seed);
        let gain_error = core::array::from_fn(|_| gain_spread * (2.0 * noise.uniform() - 1.0));
        let finger = Finger::new(
            seed,
            NOMINAL_TAXEL,
            Effects::MEMO,
            ReadoutParams::default(),
            AdcScale::BIPOLAR_10V_12BIT,
            ScanConfig::DESIGN,
        );
        Self {
            finger,
            noise,
            gain_error,
            law,
        }
    }

    /// Somewhere at least half a pitch inside the array's outer centres.
    fn position(&mut self) -> (f64, f64) {
        let span = 6.0 * PITCH_MM;
        let lo = 0.5 * PITCH_MM;
        (
            lo + span * self.noise.uniform(),
            lo + span * self.noise.uniform(),
        )
    }

    fn force(&mut self) -> f64 {
        10.0 + 90.0 * self.noise.uniform()
    }

    /// Per-taxel estimates for point contacts `(x_mm, y_mm, force_g)`.
    fn frame(&mut self, points: &[(f64, f64, f64)]) -> [f32; TAXELS] {
        let mut load = [0.0f64; TAXELS];
        for &(x, y, f) in points {
            self.finger.press_at(self.law, x, y);
            for (i, l) in load.iter_mut().enumerate() {
                *l += f * self.finger.load_share(i);
            }
        }
        core::array::from_fn(|i| {
            let e = load[i] * (1.0 + self.gain_error[i]) + 0.05 * self.noise.gaussian();
            e as f32
        })
    }
}

#[derive(Debug, Default)]
struct Errors {
    fit_mm: f64,
    centroid_mm: f64,
    /// Worst force error as a share of the 3 % + 0.5 g allowance.
    fit_force_worst: f64,
    sum_force_worst: f64,
    fit_force_rms_pct: f64,
    not_point: usize,
    n: usize,
}

fn single_points(law: SpatialLaw, gain_spread: f64, seed: u64) -> Errors {
    let mut b = Bench::new(seed, law, gain_spread);
    let locator = Locator::new(LocatorConfig::MEMO);
    let mut e = Errors::default();
    for _ in 0..FRAMES {
        let (x, y) = b.position();
        let f = b.force();
        let frame = b.frame(&[(x, y, f)]);
        let est = locator.locate(&frame);
        let sq = |ex: f32, ey: f32| (f64::from(ex) - x).powi(2) + (f64::from(ey) - y).powi(2);
        e.fit_mm += sq(est.x_mm, est.y_mm);
        e.centroid_mm += sq(est.centroid_x_mm, est.centroid_y_mm);
        let allowance = 0.03 * f + 0.5;
        let fit_err = (f64::from(est.force_g) - f).abs();
        e.fit_force_worst = e.fit_force_worst.max(fit_err / allowance);
        e.fit_force_rms_pct += (100.0 * fit_err / f).powi(2);
        let total: f32 = frame.iter().sum();
        e.sum_force_worst = e
            .sum_force_worst
            .max((f64::from(total) - f).abs() / allowance);
        e.not_point += usize::from(est.kind != ContactKind::Point);
        e.n += 1;
    }
    let n = e.n as f64;
    e.fit_mm = (e.fit_mm / n).sqrt();
    e.centroid_mm = (e.centroid_mm / n).sqrt();
    e.fit_force_rms_pct = (e.fit_force_rms_pct / n).sqrt();
    eprintln!(
        "{law:?}, gain spread ±{:.0} %: location RMS {:.3} mm (centroid {:.3} mm); force \
         error worst {:.2} of 3 % + 0.5 g, RMS {:.2} % (array sum: worst {:.1} of it); \
         not a point {} of {}",
        100.0 * gain_spread,
        e.fit_mm,
        e.centroid_mm,
        e.fit_force_worst,
        e.fit_force_rms_pct,
        e.sum_force_worst,
        e.not_point,
        e.n
    );
    e
}

#[test]
fn a_point_anywhere_is_located_to_a_fraction_of_the_pitch() {
    let clean = single_points(SpatialLaw::MEMO_HALF_SPACE, 0.0, 11);
    let spread = single_points(SpatialLaw::MEMO_HALF_SPACE, 0.02, 12);
    // The targets: 0.3 mm RMS, force within 3 % + 0.5 g; the centroid, pulled toward the
    // middle by the spread clipped at the edges and quantized by the taxels, well worse.
    for e in [&clean, &spread] {
        assert!(e.fit_mm < 0.3, "{e:?}");
        assert!(e.fit_force_worst < 1.0, "{e:?}");
        assert!(e.centroid_mm > 2.0 * e.fit_mm, "{e:?}");
        // A point is said to be one in nearly every frame.
        assert!(e.not_point * 100 <= e.n, "{e:?}");
    }
    // The array's sum counts the spread load about twice.
    assert!(spread.sum_force_worst > 10.0, "{spread:?}");
}

/// A strain field the locator's model does not hold (a rubber a quarter thinner or thicker):
/// said with the figures, asserted only loosely.
#[test]
fn another_layer_depth_is_located_within_a_millimetre() {
    for depth_mm in [3.0, 5.0] {
        let e = single_points(SpatialLaw::half_space(depth_mm), 0.02, 13);
        assert!(e.fit_mm < 1.0, "{depth_mm} mm: {e:?}");
    }
}

#[test]
fn two_contacts_and_a_line_are_not_one_point() {
    let mut b = Bench::new(21, SpatialLaw::MEMO_HALF_SPACE, 0.02);
    let locator = Locator::new(LocatorConfig::MEMO);
    let (mut two, mut line) = (0, 0);
    let inside = |v: f64| (0.5 * PITCH_MM..=6.5 * PITCH_MM).contains(&v);
    for _ in 0..FRAMES {
        // Two contacts 10 mm apart, any direction, each 10–100 g, both on the array.
        let ((x, y), (x2, y2)) = loop {
            let (x, y) = b.position();
            let angle = 2.0 * core::f64::consts::PI * b.noise.uniform();
            let (x2, y2) = (x + 10.0 * angle.cos(), y + 10.0 * angle.sin());
            if inside(x2) && inside(y2) {
                break ((x, y), (x2, y2));
            }
        };
        let angle = 2.0 * core::f64::consts::PI * b.noise.uniform();
        let (f1, f2) = (b.force(), b.force());
        let frame = b.frame(&[(x, y, f1), (x2, y2, f2)]);
        two += usize::from(locator.locate(&frame).kind != ContactKind::Point);
        // A line 12 mm long (three pitches), any direction, 10–100 g spread along it.
        let (x, y) = b.position();
        let total = b.force();
        let points: Vec<(f64, f64, f64)> = (0..25)
            .map(|k| {
                let s = -6.0 + 12.0 * f64::from(k) / 24.0;
                (x + s * angle.cos(), y + s * angle.sin(), total / 25.0)
            })
            .collect();
        line += usize::from(locator.locate(&b.frame(&points)).kind != ContactKind::Point);
    }
    eprintln!(
        "not one point: two contacts 10 mm apart {two} of {FRAMES}, a 12 mm line {line} of \
         {FRAMES}"
    );
    assert!(two * 100 >= 95 * FRAMES, "{two}");
    assert!(line * 100 >= 95 * FRAMES, "{line}");
}
