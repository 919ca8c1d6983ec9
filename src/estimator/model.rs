//! What a taxel's calibration holds: each estimator's parameters ([`TaxelModel`]), which
//! estimator runs ([`EstimatorKind`]) and what the calibration says of itself
//! ([`CalibrationFlags`]). The calibration table (`crate::calibration`) stores it as bytes.

use heapless::Vec;

use crate::estimator::{BankModel, TaxelEstimator};
use crate::hysteresis::Plays;
use crate::lti::{ModelError, ModelParameter};
use crate::tactile::TaxelId;
use crate::viscoelastic::{MaxwellKelvin, NonlinearMk, SecondOrder};

/// Most load levels a schedule holds (the scheduled inverse's table).
pub const SCHEDULE_POINTS: usize = 4;

/// The estimators a taxel can run, in the order [`TaxelEstimators::update`](crate::estimator::TaxelEstimators::update) reports them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EstimatorKind {
    /// σ = G (ε − ε₀), clamped at zero.
    Elastic,
    /// The memo's inverted second-order model (Table IV, or the taxel's own fit).
    SecondOrderInverse,
    /// [`ScheduledInverse`](crate::estimator::ScheduledInverse).
    ScheduledInverse,
    /// [`MkObserver`](crate::estimator::MkObserver).
    Observer,
    /// [`ForceBank`](crate::estimator::ForceBank).
    Bank,
}

impl EstimatorKind {
    pub const ALL: [EstimatorKind; 5] = [
        EstimatorKind::Elastic,
        EstimatorKind::SecondOrderInverse,
        EstimatorKind::ScheduledInverse,
        EstimatorKind::Observer,
        EstimatorKind::Bank,
    ];
    pub const COUNT: usize = Self::ALL.len();

    /// Index in [`Self::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// The estimator with the least of `held_out_g` (in [`Self::ALL`]'s order; the first of
    /// equals).
    pub fn best(held_out_g: &[f64; Self::COUNT]) -> EstimatorKind {
        Self::ALL
            .into_iter()
            .zip(held_out_g)
            .min_by(|a, b| a.1.total_cmp(b.1))
            .map_or(EstimatorKind::Elastic, |(k, _)| k)
    }

    /// The loop taken off this estimator's input: the calibration's plays, but none before
    /// the bank (fitted with plays of its own).
    pub fn loop_taken_off(self, model: &TaxelModel) -> Plays {
        match self {
            EstimatorKind::Bank => Plays::default(),
            _ => model.hysteresis,
        }
    }

    /// The parameters of a [`TaxelModel`] this estimator runs on.
    fn parameter(self) -> ModelParameter {
        match self {
            EstimatorKind::Elastic => ModelParameter::Elastic,
            EstimatorKind::SecondOrderInverse => ModelParameter::SecondOrder,
            EstimatorKind::ScheduledInverse => ModelParameter::ScheduleEntry,
            EstimatorKind::Observer => ModelParameter::Observer,
            EstimatorKind::Bank => ModelParameter::Bank,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            EstimatorKind::Elastic => "elastic",
            EstimatorKind::SecondOrderInverse => "second-order inverse",
            EstimatorKind::ScheduledInverse => "scheduled inverse",
            EstimatorKind::Observer => "observer (EKF)",
            EstimatorKind::Bank => "force bank",
        }
    }
}

bitflags::bitflags! {
    /// What a calibration says about itself (stored in the table, logged by the firmware).
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
    pub struct CalibrationFlags: u8 {
        /// The best estimator's held-out error is above [`POOR_FIT_G`]: the taxel's force is
        /// not to be trusted to the memo's ±1 g.
        const POOR = 1;
        /// The fitted model misses the strain by more than [`LARGE_OFFSET_PCT`] on average
        /// with the offset measured at rest: something shifts the strain that the model lacks.
        const OFFSET = 2;
        /// The calibration held out worse than the nominal models, which the record carries.
        const NOMINAL = 4;
    }
}

/// Held-out RMS force error above which a calibration is flagged [`CalibrationFlags::POOR`], g
/// (the memo's ±1 g).
pub const POOR_FIT_G: f64 = 1.0;
/// Mean strain the model misses by before a calibration is flagged
/// [`CalibrationFlags::OFFSET`], percent (about 0.2 g through G₁ at 30 g).
pub const LARGE_OFFSET_PCT: f64 = 0.05;

/// One taxel's dynamic calibration.
#[derive(Clone, Debug, PartialEq)]
pub struct TaxelModel {
    pub taxel: TaxelId,
    /// Strain the fits found at zero force, beyond the rest calibration, percent.
    pub strain_offset_pct: f64,
    /// Elastic model ε = σ/G, g/%.
    pub elastic_g_per_pct: f64,
    /// Eq. 17 fitted to the whole calibration record (the memo's inverse, recalibrated).
    pub second_order: SecondOrder,
    /// Eq. 17 fitted at each load level (the scheduled inverse), in increasing load.
    pub schedule: Vec<(f32, SecondOrder), SCHEDULE_POINTS>,
    /// Eq. 14 with load-dependent springs (the observer's model).
    pub element: NonlinearMk,
    /// A periodic interference on the strain, notched before every estimator, Hz (0: none).
    pub notch_hz: f64,
    /// The largest load the calibration record covered, g (0: unknown).
    pub range_g: f64,
    /// Each estimator's RMS force error on the held-out part of the calibration record, g, in
    /// [`EstimatorKind::ALL`]'s order (`None`: not measured, as for the nominal models).
    pub held_out_g: Option<[f64; EstimatorKind::COUNT]>,
    /// The estimator the firmware runs on this taxel (the one that held out best).
    pub estimator: EstimatorKind,
    pub flags: CalibrationFlags,
    /// A loop in the strain, taken off before the taxel's estimator (none: empty).
    pub hysteresis: Plays,
    /// The force bank (without a fit: the elastic spring).
    pub bank: BankModel,
}

impl TaxelModel {
    /// Element 4,2 as the memo describes it, for a taxel without a calibration: the Table IV
    /// fit, Table I's element scheduled at its four loads (with the simulator's α), the guide
    /// laws of FACTS.md, and the elastic spring that is Table IV's static gain.
    pub fn nominal(taxel: TaxelId) -> TaxelModel {
        let mut schedule = Vec::new();
        for row in MaxwellKelvin::TABLE_I {
            let (load, row) = (row.load_g as f32, row.element);
            let mk = MaxwellKelvin {
                alpha: NonlinearMk::ELEMENT_4_2.alpha,
                ..row
            };
            // Four entries into a Vec of four: cannot fail.
            let _ = schedule.push((load, mk.second_order()));
        }
        let so = SecondOrder::MEMO_FIT;
        TaxelModel {
            taxel,
            strain_offset_pct: 0.0,
            elastic_g_per_pct: so.b2 / so.a2,
            second_order: so,
            schedule,
            element: NonlinearMk::ELEMENT_4_2,
            notch_hz: 0.0,
            range_g: 0.0,
            held_out_g: None,
            estimator: EstimatorKind::Observer,
            flags: CalibrationFlags::empty(),
            hysteresis: Plays::default(),
            bank: BankModel::elastic(so.b2 / so.a2),
        }
    }

    /// Whether every estimator runs on this calibration: each is built as the firmware builds
    /// it, at a nominal period (what they refuse, a parameter not finite or not positive or a
    /// model not stable, does not depend on the period). `Err`: the parameters that cannot.
    pub fn check(&self) -> Result<(), ModelParameter> {
        const NOMINAL_PERIOD_S: f64 = 1e-3;
        for kind in EstimatorKind::ALL {
            TaxelEstimator::new(kind, self, NOMINAL_PERIOD_S).map_err(|e| match e {
                ModelError::InvalidParameter { name } => name,
                _ => kind.parameter(),
            })?;
        }
        Ok(())
    }
}

/// The scheduled inverse's table from an element with load-dependent springs: its secant
/// springs at each of `loads_g` as eq. 17 (Table I's rows, one per load, from one law). Loads
/// beyond [`SCHEDULE_POINTS`] are left out.
pub fn secant_schedule(
    element: &NonlinearMk,
    loads_g: &[f64],
) -> Vec<(f32, SecondOrder), SCHEDULE_POINTS> {
    loads_g
        .iter()
        .take(SCHEDULE_POINTS)
        .map(|&load| (load as f32, element.linearized(load).second_order()))
        .collect()
}
