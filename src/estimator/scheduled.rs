//! The scheduled inverse: eq. 17 written as an instantaneous spring and two Kelvin branches,
//! its parameters interpolated over the last estimated load from a table of load levels.

use crate::viscoelastic::{ModelError, ModelParameter, SecondOrder};

use super::SCHEDULE_POINTS;

/// One load level of a schedule, discretized for the update period: the instantaneous spring
/// and two Kelvin branches, each advancing `x ← φ x + c σ` with the stress held over a period.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ChainStep {
    /// Load the entry was fitted at, grams.
    pub load_g: f32,
    /// Instantaneous spring b₀, g/%.
    pub g0: f32,
    /// Per-period decay of each branch's strain.
    pub phi: [f32; 2],
    /// Branch strain gained per gram held over one period, %/g.
    pub gain: [f32; 2],
}

impl ChainStep {
    /// Eq. 17 as an instantaneous spring and two Kelvin branches: the compliance
    /// (s² + a₁s + a₂)/(b₀s² + b₁s + b₂) = 1/b₀ + r₁/(s + p₁) + r₂/(s + p₂), discretized
    /// exactly for stress held over `dt_s`. The forward poles (roots of b₀s² + b₁s + b₂) must
    /// be real and negative, as for any spring–dashpot network, and the inverse's (the zeros)
    /// in the left half-plane: the estimator runs the chain backwards.
    pub fn from_second_order(
        load_g: f32,
        so: &SecondOrder,
        dt_s: f64,
    ) -> Result<ChainStep, ModelError> {
        let c = [so.a1, so.a2, so.b0, so.b1, so.b2];
        if c.iter().any(|v| !v.is_finite()) || !dt_s.is_finite() || dt_s <= 0.0 {
            return Err(ModelError::InvalidParameter {
                name: ModelParameter::ScheduleEntry,
            });
        }
        if !so.inverse_is_stable() {
            return Err(ModelError::Unstable);
        }
        if so.b0 <= 0.0 {
            return Err(ModelError::NotBiproper);
        }
        let (e1, e0) = (so.b1 / so.b0, so.b2 / so.b0);
        let disc = e1 * e1 - 4.0 * e0;
        if e1 <= 0.0 || e0 <= 0.0 || disc <= 0.0 {
            // Complex, repeated or unstable forward poles: not a chain of Kelvin branches.
            return Err(ModelError::Unstable);
        }
        let root = crate::trig::sqrt(disc);
        let p = [(e1 - root) / 2.0, (e1 + root) / 2.0];
        // Strictly proper remainder (n₁s + n₀)/(b₀(s + p₁)(s + p₂)).
        let (n1, n0) = (so.a1 - e1, so.a2 - e0);
        let [p1, p2] = p;
        let residue = |pi: f64, pj: f64| (n1 * -pi + n0) / (so.b0 * (pj - pi));
        let branch = |pi: f64, pj: f64| {
            let decay = libm::exp(-pi * dt_s);
            (decay as f32, (residue(pi, pj) * (1.0 - decay) / pi) as f32)
        };
        let ((phi1, gain1), (phi2, gain2)) = (branch(p1, p2), branch(p2, p1));
        let (phi, gain) = ([phi1, phi2], [gain1, gain2]);
        Ok(ChainStep {
            load_g,
            g0: so.b0 as f32,
            phi,
            gain,
        })
    }

    fn lerp(&self, other: &ChainStep, w: f32) -> ChainStep {
        let l = |a: f32, b: f32| a + (b - a) * w;
        ChainStep {
            load_g: l(self.load_g, other.load_g),
            g0: l(self.g0, other.g0),
            phi: [l(self.phi[0], other.phi[0]), l(self.phi[1], other.phi[1])],
            gain: [
                l(self.gain[0], other.gain[0]),
                l(self.gain[1], other.gain[1]),
            ],
        }
    }
}

/// Parameters over load: up to [`SCHEDULE_POINTS`] entries in increasing load, linearly
/// interpolated between them and held beyond the ends.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Schedule {
    points: [ChainStep; SCHEDULE_POINTS],
    len: usize,
}

impl Schedule {
    /// A schedule from models fitted at the given loads (any order; sorted here).
    pub fn new(fits: &[(f32, SecondOrder)], dt_s: f64) -> Result<Schedule, ModelError> {
        if fits.is_empty() || fits.len() > SCHEDULE_POINTS {
            return Err(ModelError::InvalidParameter {
                name: ModelParameter::ScheduleLength,
            });
        }
        let mut s = Schedule::default();
        for (slot, (load, so)) in s.points.iter_mut().zip(fits) {
            if !load.is_finite() || *load < 0.0 {
                return Err(ModelError::InvalidParameter {
                    name: ModelParameter::ScheduleLoad,
                });
            }
            *slot = ChainStep::from_second_order(*load, so, dt_s)?;
        }
        s.len = fits.len();
        // Sorted by load (NaN was refused above, so the order is total); by insertion: at most
        // four entries, and no sort's code in the firmware's flash.
        if let Some(used) = s.points.get_mut(..fits.len()) {
            for k in 1..used.len() {
                let mut j = k;
                while j > 0 && used.get(j - 1).map(|p| p.load_g) > used.get(j).map(|p| p.load_g) {
                    used.swap(j - 1, j);
                    j -= 1;
                }
            }
        }
        Ok(s)
    }

    pub fn points(&self) -> &[ChainStep] {
        self.points.get(..self.len).unwrap_or(&[])
    }

    /// The parameters at `load_g`.
    #[inline]
    pub fn at(&self, load_g: f32) -> ChainStep {
        match crate::bracket(self.points(), |p| p.load_g, load_g) {
            // At an end, the point itself (no interpolation to round).
            Some((a, _, 0.0)) => *a,
            Some((a, b, w)) => a.lerp(b, w),
            None => ChainStep::default(),
        }
    }
}

/// The inverted second-order model with its parameters scheduled over the estimated load (the
/// last estimate), clamped at zero.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ScheduledInverse {
    pub schedule: Schedule,
    branch_pct: [f32; 2],
    force_g: f32,
}

impl ScheduledInverse {
    pub fn new(schedule: Schedule) -> Self {
        Self {
            schedule,
            branch_pct: [0.0; 2],
            force_g: 0.0,
        }
    }

    /// Force from the latest strain sample: the strain beyond the branches' is the
    /// instantaneous spring's; the stress it implies then advances the branches.
    #[inline]
    pub fn force_g(&mut self, strain_pct: f32) -> f32 {
        if !strain_pct.is_finite() {
            return 0.0;
        }
        let p = self.schedule.at(self.force_g);
        let [x0, x1] = self.branch_pct;
        let stress = p.g0 * (strain_pct - x0 - x1);
        // The branches only ever carry a compressive stress.
        let held = stress.max(0.0);
        self.branch_pct = [
            p.phi[0] * x0 + p.gain[0] * held,
            p.phi[1] * x1 + p.gain[1] * held,
        ];
        if !(self.branch_pct[0].is_finite() && self.branch_pct[1].is_finite()) {
            self.branch_pct = [0.0; 2];
        }
        self.force_g = held;
        held
    }
}
