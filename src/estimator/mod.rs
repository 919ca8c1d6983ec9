//! Force estimators that run per taxel at the scan rate, and the per-taxel
//! calibration table the firmware reads at start-up.
//!
//! - [`InverseEstimator`]: the memo's inverted second-order model, clamped at zero (the
//!   baseline); [`StructuralInverse`], eq. 14 run backwards (host-side reference).
//! - [`ScheduledInverse`]: the same model, its parameters interpolated over load from a table
//!   fitted at several load levels. Each table entry is written as a chain of springs and
//!   Kelvin branches (eq. 17 in partial fractions), so the state — the strain of each branch —
//!   means the same thing at every load and the schedule can move under it without a jolt.
//! - [`MkObserver`]: an extended Kalman filter on the modified Maxwell–Kelvin element with
//!   load-dependent springs (eq. 10 with α), estimating the stress, the Kelvin strain and the
//!   Maxwell (permanent) strain from the measured strain.
//! - [`ForceBank`]: the strain's own terms (hinges, lowpasses, plays) weighted to give the force,
//!   fitted for force rather than inverted, with a zero that re-settles at rest.
//!
//! Everything on the update path is `f32`, allocation-free and panic-free; construction (once,
//! at start-up) may use `f64`.

use crate::filter::{Biquad, BiquadState};
use crate::hysteresis::LoopCompensator;
use crate::viscoelastic::{ModelError, ModelParameter};

mod bank;
mod inverse;
mod model;
mod observer;
mod scheduled;

pub use bank::{
    BankModel, ForceBank, Rezero, BANK_FEATURES, BANK_FILTERS, BANK_KNOTS, BANK_PLAYS, HINGE_TERMS,
    LOWPASS_TERMS, PLAY_TERMS, QUIET_TAU_S,
};
pub use inverse::{InverseEstimator, StructuralInverse};
pub use observer::{MkObserver, ObserverTuning};
pub use scheduled::{ChainStep, Schedule, ScheduledInverse};

pub use model::{
    secant_schedule, CalibrationFlags, EstimatorKind, TaxelModel, LARGE_OFFSET_PCT, POOR_FIT_G,
    SCHEDULE_POINTS,
};

/// One taxel's estimator, of one kind, built from its calibration for an update period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TaxelEstimator {
    Elastic { g_per_pct: f32 },
    SecondOrderInverse(InverseEstimator),
    ScheduledInverse(ScheduledInverse),
    Observer(MkObserver),
    Bank(ForceBank),
}

impl TaxelEstimator {
    pub fn new(kind: EstimatorKind, model: &TaxelModel, dt_s: f64) -> Result<Self, ModelError> {
        Ok(match kind {
            EstimatorKind::Elastic => {
                let g = model.elastic_g_per_pct;
                if !(g.is_finite() && g > 0.0) {
                    return Err(ModelError::InvalidParameter {
                        name: ModelParameter::Elastic,
                    });
                }
                TaxelEstimator::Elastic {
                    g_per_pct: g as f32,
                }
            }
            EstimatorKind::SecondOrderInverse => TaxelEstimator::SecondOrderInverse(
                InverseEstimator::new(model.second_order.inverse(dt_s)?),
            ),
            EstimatorKind::ScheduledInverse => {
                let schedule = Schedule::new(&model.schedule, dt_s)?;
                TaxelEstimator::ScheduledInverse(ScheduledInverse::new(schedule))
            }
            EstimatorKind::Observer => TaxelEstimator::Observer(MkObserver::new(
                &model.element,
                dt_s,
                ObserverTuning::DESIGN,
            )?),
            EstimatorKind::Bank => TaxelEstimator::Bank(ForceBank::new(&model.bank, dt_s)?),
        })
    }

    /// Force from the latest strain of the taxel (its calibration's offset already removed).
    #[inline]
    pub fn force_g(&mut self, strain_pct: f32) -> f32 {
        match self {
            TaxelEstimator::Elastic { g_per_pct } => {
                let f = *g_per_pct * strain_pct;
                if f.is_finite() {
                    f.max(0.0)
                } else {
                    0.0
                }
            }
            TaxelEstimator::SecondOrderInverse(e) => e.force_g(strain_pct),
            TaxelEstimator::ScheduledInverse(e) => e.force_g(strain_pct),
            TaxelEstimator::Observer(e) => e.force_g(strain_pct),
            TaxelEstimator::Bank(e) => e.force_g(strain_pct),
        }
    }
}

/// Quality factor of the interference notch: narrow (−3 dB at f0 ± f0/60), so the steps of a
/// load barely ring through it (measured on the diagnosis tests: Q = 1 made the on-chip
/// inverse 5× worse than no notch, Q = 30 takes 30–40 % off its error).
pub const NOTCH_Q: f64 = 30.0;

/// What a taxel's strain goes through before its estimators: the calibration's offset removed
/// and, when the calibration found a periodic interference, that tone notched.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StrainConditioner {
    offset_pct: f32,
    notch: Option<(Biquad, BiquadState)>,
}

impl StrainConditioner {
    /// For `model` sampled every `dt_s` (no notch where the tone aliases onto DC).
    pub fn new(model: &TaxelModel, dt_s: f64) -> Self {
        let notch = (model.notch_hz > 0.0)
            .then(|| Biquad::notch(model.notch_hz, NOTCH_Q, dt_s))
            .flatten()
            .map(|b| (b, BiquadState::default()));
        Self {
            offset_pct: model.strain_offset_pct as f32,
            notch,
        }
    }

    /// The offset alone (no state), for comparisons.
    #[inline]
    pub fn offset_removed(&self, strain_pct: f32) -> f32 {
        strain_pct - self.offset_pct
    }

    /// The conditioned strain of the latest sample.
    #[inline]
    pub fn update(&mut self, strain_pct: f32) -> f32 {
        let e = strain_pct - self.offset_pct;
        match &mut self.notch {
            Some((b, state)) if e.is_finite() => {
                let y = b.update(state, e);
                if y.is_finite() {
                    y
                } else {
                    *state = BiquadState::default();
                    e
                }
            }
            _ => e,
        }
    }
}

/// Every estimator side by side on one taxel (the probed one, for the comparison stream).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaxelEstimators {
    conditioner: StrainConditioner,
    estimators: [TaxelEstimator; EstimatorKind::COUNT],
    /// The calibration's loop taken off each estimator's input (from its own last force); none
    /// before the bank, which was fitted with its own plays.
    loops: [LoopCompensator; EstimatorKind::COUNT],
}

impl TaxelEstimators {
    pub fn new(model: &TaxelModel, dt_s: f64) -> Result<Self, ModelError> {
        let e = |k| TaxelEstimator::new(k, model, dt_s);
        Ok(Self {
            conditioner: StrainConditioner::new(model, dt_s),
            estimators: [
                e(EstimatorKind::Elastic)?,
                e(EstimatorKind::SecondOrderInverse)?,
                e(EstimatorKind::ScheduledInverse)?,
                e(EstimatorKind::Observer)?,
                e(EstimatorKind::Bank)?,
            ],
            loops: EstimatorKind::ALL.map(|k| LoopCompensator::new(k.loop_taken_off(model))),
        })
    }

    /// The read-out's strain less the calibration's offset (no notch: stateless).
    #[inline]
    pub fn corrected(&self, strain_pct: f32) -> f32 {
        self.conditioner.offset_removed(strain_pct)
    }

    /// Each estimator's force, in [`EstimatorKind::ALL`]'s order, from the conditioned strain.
    pub fn update(&mut self, strain_pct: f32) -> [f32; EstimatorKind::COUNT] {
        self.update_kinds(strain_pct, EstimatorKind::ALL)
    }

    /// The forces of `kinds` alone, each as [`update`](Self::update) gives it (the others
    /// are not run: a host that compares two of them pays for two).
    #[inline]
    pub fn update_kinds<const K: usize>(
        &mut self,
        strain_pct: f32,
        kinds: [EstimatorKind; K],
    ) -> [f32; K] {
        let e = self.conditioner.update(strain_pct);
        kinds.map(|k| {
            let (est, comp) = self.pair_mut(k);
            comp.force_g(|s| est.force_g(s), e)
        })
    }

    /// One estimator and the loop taken off its input.
    fn pair_mut(&mut self, kind: EstimatorKind) -> (&mut TaxelEstimator, &mut LoopCompensator) {
        let ([a, b, c, d, e], [la, lb, lc, ld, le]) = (&mut self.estimators, &mut self.loops);
        match kind {
            EstimatorKind::Elastic => (a, la),
            EstimatorKind::SecondOrderInverse => (b, lb),
            EstimatorKind::ScheduledInverse => (c, lc),
            EstimatorKind::Observer => (d, ld),
            EstimatorKind::Bank => (e, le),
        }
    }

    /// One estimator, by kind (for timing them one at a time).
    #[inline]
    pub fn estimator_mut(&mut self, kind: EstimatorKind) -> &mut TaxelEstimator {
        self.pair_mut(kind).0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::viscoelastic::{MaxwellKelvin, NonlinearMkState};
    use crate::viscoelastic::{NonlinearMk, SecondOrder};

    const FRAME_S: f64 = 0.016;

    /// Steps in 20–40 g every 2–8 s, sampled every `dt`.
    fn pseudo_random_stress(n: usize, dt: f64) -> Vec<f64> {
        crate::test_support::pseudo_random_steps(n, dt, 0x2545_F491_4F6C_DD1D, 2.0, 6.0)
    }

    /// The element's strain under `stress` held over each frame (the form it is exact for).
    fn strain_of(model: &NonlinearMk, stress: &[f64], dt: f64) -> Vec<f32> {
        let mut st = NonlinearMkState::default();
        stress
            .iter()
            .map(|&s| {
                let e = model.strain_pct(&st, s);
                model.step(&mut st, s, dt);
                e as f32
            })
            .collect()
    }

    #[test]
    fn the_memo_fit_is_a_spring_and_two_kelvin_branches() {
        // By hand: b₀s² + b₁s + b₂ = 5.81 (s + 0.21015)(s + 2.07212); the remainder
        // (0.72773 s + 0.34854)/(5.81 (s + p₁)(s + p₂)) has residues 0.018082 and 0.107172.
        let dt = 1.0;
        let c = ChainStep::from_second_order(25.0, &SecondOrder::MEMO_FIT, dt).unwrap();
        assert!((c.g0 - 5.81).abs() < 1e-6);
        let p1 = -f64::from(c.phi[0]).ln();
        let p2 = -f64::from(c.phi[1]).ln();
        assert!(
            (p1 - 0.21015).abs() < 2e-5 && (p2 - 2.07212).abs() < 2e-5,
            "{p1} {p2}"
        );
        let r1 = f64::from(c.gain[0]) * p1 / (1.0 - f64::from(c.phi[0]));
        let r2 = f64::from(c.gain[1]) * p2 / (1.0 - f64::from(c.phi[1]));
        assert!(
            (r1 - 0.018082).abs() < 2e-5 && (r2 - 0.107172).abs() < 2e-5,
            "{r1} {r2}"
        );
        // DC compliance 1/b₀ + r₁/p₁ + r₂/p₂ = a₂/b₂.
        let so = SecondOrder::MEMO_FIT;
        let dc = 1.0 / so.b0 + r1 / p1 + r2 / p2;
        assert!((dc - so.a2 / so.b2).abs() < 1e-3, "{dc}");
        // Complex forward poles are not a chain.
        let ringing = SecondOrder {
            b1: 0.1,
            ..SecondOrder::MEMO_FIT
        };
        assert_eq!(
            ChainStep::from_second_order(25.0, &ringing, dt),
            Err(ModelError::Unstable)
        );
        // Nor a chain whose inverse runs away (a zero in the right half-plane).
        let runaway = SecondOrder {
            a1: -5.0,
            ..SecondOrder::MEMO_FIT
        };
        assert_eq!(
            ChainStep::from_second_order(25.0, &runaway, dt),
            Err(ModelError::Unstable)
        );
    }

    #[test]
    fn one_entry_schedule_matches_the_tustin_inverse_of_the_same_model() {
        // Two discretizations of the memo's inverse at the scan rate: the chain (stress held
        // over a frame) and the bilinear one (the baseline estimator) agree on a pseudo-random
        // load to within the change a held frame makes.
        let so = SecondOrder::MEMO_FIT;
        let stress = pseudo_random_stress(10_000, FRAME_S);
        let fwd = so.forward::<f64>(FRAME_S).unwrap();
        let mut st = crate::viscoelastic::Discrete2State::default();
        let strain: Vec<f32> = stress
            .iter()
            .map(|&s| fwd.update(&mut st, s) as f32)
            .collect();
        let mut chain = ScheduledInverse::new(Schedule::new(&[(25.0, so)], FRAME_S).unwrap());
        let mut tustin = InverseEstimator::new(so.inverse(FRAME_S).unwrap());
        let mut sum = 0.0;
        for e in &strain {
            let d = chain.force_g(*e) - tustin.force_g(*e);
            sum += f64::from(d * d);
        }
        let rms = (sum / strain.len() as f64).sqrt();
        assert!(rms < 0.3, "{rms}");
    }

    #[test]
    fn schedule_interpolates_between_loads_and_holds_beyond() {
        let at = |load: f64| NonlinearMk::ELEMENT_4_2.linearized(load).second_order();
        let mk = |load: f64| MaxwellKelvin {
            alpha: 5.0,
            ..NonlinearMk::ELEMENT_4_2.linearized(load)
        };
        assert_eq!(mk(30.0).second_order(), at(30.0));
        let s = Schedule::new(&[(50.0, at(50.0)), (10.0, at(10.0))], FRAME_S).unwrap();
        let (lo, hi) = (s.at(10.0), s.at(50.0));
        assert_eq!(s.at(0.0), lo);
        assert_eq!(s.at(80.0), hi);
        let mid = s.at(30.0);
        assert!((mid.g0 - 0.5 * (lo.g0 + hi.g0)).abs() < 1e-5);
        assert!((mid.load_g - 30.0).abs() < 1e-5);
        assert_eq!(s.at(f32::NAN), lo);
        assert!(Schedule::new(&[], FRAME_S).is_err());
    }

    #[test]
    fn a_schedule_from_the_element_tracks_it_better_than_one_load() {
        // Element 4,2's secant models at four loads, scheduled, against the single 30 g one.
        let element = NonlinearMk::ELEMENT_4_2;
        let stress: Vec<f64> = pseudo_random_stress(12_000, FRAME_S)
            .iter()
            .map(|s| s * 1.5)
            .collect();
        let strain = strain_of(&element, &stress, FRAME_S);
        let fits: Vec<(f32, SecondOrder)> = [10.0, 30.0, 50.0, 70.0]
            .iter()
            .map(|&l| (l as f32, element.linearized(l).second_order()))
            .collect();
        let rms = |mut est: ScheduledInverse| {
            let sum: f64 = strain
                .iter()
                .zip(&stress)
                .map(|(e, s)| (f64::from(est.force_g(*e)) - s).powi(2))
                .sum();
            (sum / stress.len() as f64).sqrt()
        };
        let scheduled = rms(ScheduledInverse::new(
            Schedule::new(&fits, FRAME_S).unwrap(),
        ));
        let single = rms(ScheduledInverse::new(
            Schedule::new(&fits[1..2], FRAME_S).unwrap(),
        ));
        assert!(
            scheduled < 0.5 && scheduled < 0.25 * single,
            "{scheduled} vs {single}"
        );
    }

    #[test]
    fn the_observer_recovers_stress_and_the_permanent_deformation() {
        let element = NonlinearMk::ELEMENT_4_2;
        // 60 s of pseudo-random load, then 30 s unloaded.
        let mut stress = pseudo_random_stress(3750, FRAME_S);
        stress.extend(std::iter::repeat_n(0.0, 1875));
        let strain = strain_of(&element, &stress, FRAME_S);
        let mut obs = MkObserver::new(&element, FRAME_S, ObserverTuning::DESIGN).unwrap();
        let mut sum = 0.0;
        for (e, s) in strain.iter().zip(&stress) {
            sum += (f64::from(obs.force_g(*e)) - s).powi(2);
        }
        let rms = (sum / stress.len() as f64).sqrt();
        // The strain was made by the observer's own model, whose springs the observer runs
        // tabulated (within 0.01 % strain of the laws above 6 g).
        assert!(rms < 0.03, "{rms}");
        // After the loads: no phantom force, and the permanent strain is the element's.
        let mut st = NonlinearMkState::default();
        for &s in &stress {
            element.step(&mut st, s, FRAME_S);
        }
        let [spring, _, permanent] = obs.state();
        assert!(spring.abs() < 0.02, "{spring}");
        assert!(
            (f64::from(permanent) - st.maxwell_pct).abs() < 0.02 * st.maxwell_pct,
            "{permanent} vs {}",
            st.maxwell_pct
        );
        assert!(st.maxwell_pct > 0.1, "{}", st.maxwell_pct);
    }

    #[test]
    fn bad_samples_do_not_poison_the_estimators() {
        let mut obs =
            MkObserver::new(&NonlinearMk::ELEMENT_4_2, FRAME_S, ObserverTuning::DESIGN).unwrap();
        let mut inv = ScheduledInverse::new(
            Schedule::new(&[(25.0, SecondOrder::MEMO_FIT)], FRAME_S).unwrap(),
        );
        for _ in 0..10 {
            obs.force_g(8.0);
            inv.force_g(8.0);
        }
        let (a, b) = (obs.force_g(f32::NAN), inv.force_g(f32::INFINITY));
        assert!(a.is_finite() && b == 0.0);
        assert!(obs.force_g(8.0).is_finite() && inv.force_g(8.0) > 10.0);
        // A bad model is refused, not run.
        let broken = NonlinearMk {
            n2: -1.0,
            ..NonlinearMk::ELEMENT_4_2
        };
        assert!(MkObserver::new(&broken, FRAME_S, ObserverTuning::DESIGN).is_err());
    }
}
