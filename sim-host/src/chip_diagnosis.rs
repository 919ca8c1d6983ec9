//! `tactile diagnose`: the identification crate's diagnosis of a record, and its accepted model
//! carried to the chip — the eq. 14 element the firmware's estimators run, with the diagnosed
//! stiffening as its spring laws and schedule and the interference as a notch — scored on the
//! held-out folds with the core's own estimators, and exported only where it helps.

use serde::Serialize;
use tactile_core::estimator::{secant_schedule, EstimatorKind, TaxelModel};
use tactile_core::estimator::{StrainConditioner, TaxelEstimators, HINGE_TERMS, PLAY_TERMS};
use tactile_core::hysteresis::{Plays, PLAYS};
use tactile_core::spring::SpringCurve;
use tactile_core::tactile::TaxelId;
use tactile_core::viscoelastic::{NonlinearMk, SpringLaw};
pub use tactile_ident::diagnose::{Diagnosis, Term};
use tactile_ident::diagnose::{FoldModels, Settings};
// Every play the diagnosis fits reaches the chip.
const _: () = assert!(tactile_ident::diagnose::PLAY_SHARES.len() <= PLAYS);
use tactile_ident::diagnose::{stiffening_load, Effect};
use tactile_ident::force_fit;
use tactile_ident::solve::Sign;
use tactile_ident::{Refusal, Series};

use crate::record::Record;

mod early;

/// Load levels the exported schedule samples a stiffening law at, grams: the scheduled
/// inverse's table loads, as the calibration protocol excites them.
pub const EXPORT_LOADS_G: [f64; 4] = {
    let l = tactile_core::profile::CALIBRATION_OFFSETS_G;
    [l[0] as f64, l[1] as f64, l[2] as f64, l[3] as f64]
};

/// The record as the identification takes it: its period, force, strain, the strain's rail
/// samples and the logger's held values left out (a held force bridged, as the models' input
/// needs a value at every sample), and how its time stamps were mended.
pub fn series_of(r: &Record) -> Result<Series, Refusal> {
    into_series(r.clone())
}

/// [`series_of`] without a copy of a long record.
pub fn into_series(r: Record) -> Result<Series, Refusal> {
    let mut rail = at_top_rail(&r.strain_pct);
    // A strain that never moves is not "at its rail": say that it does not vary.
    if rail.iter().all(|x| *x) {
        rail.iter_mut().for_each(|x| *x = false);
    }
    let dt = r.sample_period_s().unwrap_or(0.0);
    Series::logged(dt, r.force_g, r.strain_pct, rail, r.resampling)
}

/// Samples at the strain's converter rail: the record's largest value, repeated for at least
/// 1 % of the record and three times as often as the next value down (a held load spreads over
/// a few codes with its largest a tail; a clipped one piles up on the rail). Beyond the rail the
/// strain says nothing about the load, so fits and scores leave those samples out.
pub fn at_top_rail(strain: &[f64]) -> Vec<bool> {
    let none = vec![false; strain.len()];
    let Some(top) = strain
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .reduce(f64::max)
    else {
        return none;
    };
    let at_top = strain.iter().filter(|v| **v == top).count();
    let below = strain
        .iter()
        .copied()
        .filter(|v| *v < top)
        .reduce(f64::max)
        .map_or(0, |next| strain.iter().filter(|v| **v == next).count());
    if at_top >= 50 && at_top * 100 >= strain.len() && at_top >= 3 * below {
        strain.iter().map(|v| *v == top).collect()
    } else {
        none
    }
}

/// Force estimated from strain on the chip, before and after the accepted effects.
#[derive(Clone, Debug, Serialize)]
pub struct ForceEstimate {
    /// Held-out RMS (g) of the on-chip observer with the baseline's form, and with the accepted
    /// model's form (each fitted on the other folds); null where there is no on-chip form.
    pub before_rms_g: Option<f64>,
    pub after_rms_g: Option<f64>,
    /// The same with the scheduled inverse.
    pub scheduled_before_rms_g: Option<f64>,
    pub scheduled_after_rms_g: Option<f64>,
    /// Whether the accepted model is what `--table` writes (it lowers the held-out error).
    pub exported: bool,
    /// What each accepted effect becomes on the chip, or why it cannot.
    pub on_chip: Vec<(Effect, String)>,
}

/// The diagnosis with its on-chip form.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    #[serde(flatten)]
    pub diagnosis: Diagnosis,
    pub force_estimate: ForceEstimate,
    #[serde(skip)]
    pub table_model: Option<TaxelModel>,
}

/// How a model of many terms becomes the chip's eq. 14. Neither choice is best on every
/// finger, so each record's is chosen on its held-out folds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChipForm {
    pub springs: SpringForm,
    pub branches: Reduction,
}

/// How the chip carries a diagnosed stiffening law.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpringForm {
    /// The law itself, tabulated (the chip's [`SpringCurve`]).
    Curve,
    /// The closest of the memo's guide laws G = a + b√σ + cσ that only stiffens (smoother:
    /// it may hold out better where the load basis fits noise).
    GuideLaw,
}

/// How the relaxation spectrum becomes eq. 14's one or two Kelvin branches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reduction {
    /// Split at the compliance-weighted middle, each side merged at its weighted mean log τ.
    Merge,
    /// The branches whose creep function fits best ([`reduce_branches`]).
    CreepFit,
}

impl ChipForm {
    pub const ALL: [ChipForm; 4] = [
        ChipForm {
            springs: SpringForm::Curve,
            branches: Reduction::Merge,
        },
        ChipForm {
            springs: SpringForm::GuideLaw,
            branches: Reduction::Merge,
        },
        ChipForm {
            springs: SpringForm::Curve,
            branches: Reduction::CreepFit,
        },
        ChipForm {
            springs: SpringForm::GuideLaw,
            branches: Reduction::CreepFit,
        },
    ];
}

/// Branches faster than this act as the spring on the chip's time scale, s.
const FAST_BRANCH_S: f64 = 0.02;

/// What an effect becomes on the chip.
fn on_chip(effect: Effect) -> &'static str {
    match effect {
        Effect::LoadDependentStiffness => "the observer's spring laws and the scheduled inverse's table (secant springs at 10/25/45/70 g)",
        Effect::PeriodicInterference => "a notch on the strain at the strongest line, before every estimator",
        Effect::TimeDelay => "none: undoing a delay needs the future strain (a causal estimate can only be late by it)",
        Effect::BaselineDrift => "none: a wandering zero cannot be told from a load without moments of known zero force",
        Effect::Hysteresis => "its plays, driven by the estimated force, taken off the strain before the estimator (one update late)",
        Effect::SlowRelaxation => "merged into eq. 14's two branches (the chip's element has no third)",
        Effect::SensitivityDrift => "none: a gain that changes with time needs a reference force to track",
    }
}

/// `count` (one or two) Kelvin branches in place of many: split at the compliance-weighted
/// middle, each side merged at its compliance-weighted mean log time constant; in increasing
/// time constant.
fn merge_branches(branches: &[(f64, f64)], count: usize) -> Vec<(f64, f64)> {
    let merge = |bs: &[(f64, f64)]| -> Option<(f64, f64)> {
        let j: f64 = bs.iter().map(|b| b.1).sum();
        (j > 0.0).then(|| {
            let tau = (bs.iter().map(|b| b.1 * b.0.ln()).sum::<f64>() / j).exp();
            (tau, j)
        })
    };
    if count < 2 || branches.len() < 2 {
        return merge(branches).into_iter().collect();
    }
    let total: f64 = branches.iter().map(|b| b.1).sum();
    let mut acc = 0.0;
    let split = branches
        .iter()
        .position(|b| {
            acc += b.1;
            acc >= 0.5 * total
        })
        .map_or(1, |i| (i + 1).clamp(1, branches.len() - 1));
    merge(&branches[..split])
        .into_iter()
        .chain(merge(&branches[split..]))
        .collect()
}

/// A spring and `count` Kelvin branches in place of a spring and many: the time constants
/// among the given branches' whose creep function J(t) = J₀ + Σ Jᵢ (1 − e^(−t/τᵢ)) fits the
/// given one best (non-negative least squares on a log grid of times, every choice tried), in
/// increasing time constant. Model reduction for the chip's eq. 14.
fn reduce_branches(j0: f64, branches: &[(f64, f64)], count: usize) -> (f64, Vec<(f64, f64)>) {
    if branches.len() <= count {
        return (j0, branches.to_vec());
    }
    let taus: Vec<f64> = branches.iter().map(|b| b.0).collect();
    let (lo, hi) = (
        0.3 * taus.iter().copied().fold(f64::INFINITY, f64::min),
        3.0 * taus.iter().copied().fold(0.0, f64::max),
    );
    const POINTS: usize = 80;
    let times: Vec<f64> = (0..POINTS)
        .map(|i| lo * (hi / lo).powf(i as f64 / (POINTS - 1) as f64))
        .collect();
    let creep = |t: f64, tau: f64| 1.0 - (-t / tau).exp();
    let target: Vec<f64> = times
        .iter()
        .map(|&t| {
            j0 + branches
                .iter()
                .map(|(tau, j)| j * creep(t, *tau))
                .sum::<f64>()
        })
        .collect();
    let choices: Vec<Vec<f64>> = if count == 1 {
        taus.iter().map(|t| vec![*t]).collect()
    } else {
        taus.iter()
            .enumerate()
            .flat_map(|(i, a)| taus[i + 1..].iter().map(move |b| vec![*a, *b]))
            .collect()
    };
    // (squared miss, spring, branches)
    type Reduced = (f64, f64, Vec<(f64, f64)>);
    let mut best: Option<Reduced> = None;
    for choice in choices {
        let a = nalgebra::DMatrix::from_fn(POINTS, choice.len() + 1, |i, k| match k {
            0 => 1.0,
            _ => creep(times[i], choice[k - 1]),
        });
        let y = nalgebra::DVector::from_column_slice(&target);
        let c = tactile_ident::solve::nnls(
            &(a.transpose() * &a),
            &(a.transpose() * &y),
            &vec![Sign::NonNegative; choice.len() + 1],
        );
        let miss = (&a * &c - &y).norm_squared();
        if miss.is_finite() && best.as_ref().is_none_or(|b| miss < b.0) {
            let kept = choice
                .iter()
                .zip(c.iter().skip(1))
                .filter(|(_, j)| **j > 0.0)
                .map(|(t, j)| (*t, *j))
                .collect();
            best = Some((miss, c[0], kept));
        }
    }
    match best {
        Some((_, j, kept)) => (j, kept),
        None => (j0, branches.iter().take(count).copied().collect()),
    }
}

/// Eq. 14 (the chip's element) from a generalized Maxwell–Kelvin model: the elastic term, the
/// permanent creep as N₁ (α = 0) with one Kelvin branch, or without creep two branches, a slow
/// (N₁ ∥ α) and a fast (N₂ ∥ G₂), chosen by [`reduce_branches`]; the diagnosed stiffening as
/// the springs' laws over the loads the record saw.
pub fn element_of(
    terms: &[(Term, f64)],
    (force_scale_g, force_origin_g): (f64, f64),
    loads: (f64, f64),
    form: ChipForm,
) -> Option<NonlinearMk> {
    let sum = |f: &dyn Fn(Term) -> bool| -> f64 {
        terms.iter().filter(|(t, _)| f(*t)).map(|(_, b)| *b).sum()
    };
    let mut branches: Vec<(f64, f64)> = terms
        .iter()
        .filter_map(|(t, b)| match t {
            Term::Relaxation(tau) | Term::SlowRelaxation(tau) | Term::Alpha(tau) if *b > 0.0 => {
                Some((*tau, *b))
            }
            _ => None,
        })
        .collect();
    branches.sort_by(|a, b| a.0.total_cmp(&b.0));
    let fast: f64 = branches
        .iter()
        .filter(|b| b.0 < FAST_BRANCH_S)
        .map(|b| b.1)
        .sum();
    branches.retain(|b| b.0 >= FAST_BRANCH_S);
    // A play is the force plus a bounded remainder (the chip's stop form): the force's part
    // belongs to the spring.
    let plays = sum(&|t| matches!(t, Term::Play { .. }));
    let mut j0 = sum(&|t| t == Term::Elastic) + fast + plays;
    // A sensor with no instantaneous response (a fluid channel): its fastest branch stands in
    // for the spring on the chip (eq. 14 needs one).
    if j0 <= 0.0 && !branches.is_empty() {
        j0 = branches.remove(0).1;
    }
    let creep = sum(&|t| t == Term::Creep);
    // With permanent creep eq. 14 has one Kelvin branch left; without, two (the slower as
    // N₁ ∥ α).
    let count = if creep > 0.0 { 1 } else { 2 };
    let (j0, kept) = match form.branches {
        Reduction::CreepFit => reduce_branches(j0, &branches, count),
        Reduction::Merge => (j0, merge_branches(&branches, count)),
    };
    let (maxwell, kelvin) = match kept.as_slice() {
        [] => (None, None),
        [one] => (None, Some(*one)),
        [fast, slow, ..] => (Some(*slow), Some(*fast)),
    };
    if j0.is_nan() || j0 <= 0.0 {
        return None;
    }
    let (tau_k, j_k) = kelvin.unwrap_or((1.0, j0 * 1e-3));
    // Stiffening: compliance at load σ = J + Σ c·b(σ)/σ, b the load basis
    // ([`tactile_ident::diagnose::stiffening_load`]), per spring; fitted as a + b√σ + cσ.
    let law = |base_j: f64, through: &dyn Fn(Option<f64>) -> bool| -> SpringLaw {
        let extra: Vec<(f64, f64)> = terms
            .iter()
            .filter_map(|(t, b)| match t {
                Term::Stiffening { power, tau_s } if through(*tau_s) => Some((*power, *b)),
                _ => None,
            })
            .collect();
        if extra.is_empty() {
            return SpringLaw::constant(1.0 / base_j);
        }
        let (lo, hi) = (loads.0.max(1.0), loads.1.max(loads.0 + 1.0));
        // Below the loads the record saw the compliance is held too where the basis is measured
        // from the record's lowest load (from zero it goes to the spring's own at no load).
        let lowest = if force_origin_g == 0.0 { 0.0 } else { lo };
        let compliance = |s: f64| -> f64 {
            let s = s.max(lowest);
            let extra_strain: f64 = extra
                .iter()
                .map(|(p, c)| c * stiffening_load(s, force_origin_g, force_scale_g, *p))
                .sum();
            let j = base_j + if s > 0.0 { extra_strain / s } else { 0.0 };
            j.max(base_j * 0.05)
        };
        // The law as the chip's curve: the strain at each knot; above the loads the record saw
        // the compliance is held at its last value (the basis, powers of the load, goes to
        // the spring's own at no load, but extrapolated upwards runs anywhere).
        let knots = SpringCurve::DEFAULT_STRESS_G;
        let strain = knots.map(|s| {
            let s = f64::from(s);
            (s * compliance(s.min(hi))) as f32
        });
        if let (SpringForm::Curve, Ok(curve)) = (form.springs, SpringCurve::new(knots, strain)) {
            return SpringLaw::Curve(curve);
        }
        let pts: Vec<(f64, f64)> = (0..=20)
            .map(|i| {
                let s = lo + (hi - lo) * i as f64 / 20.0;
                (s, 1.0 / compliance(s))
            })
            .collect();
        // As the memo's guide laws, or where the strain does not rise with the load (no curve):
        // a + b√σ + cσ with b, c ≥ 0, the closest law that only stiffens.
        let a = nalgebra::DMatrix::from_fn(pts.len(), 3, |i, j| pts[i].0.powf(j as f64 * 0.5));
        let y = nalgebra::DVector::from_iterator(pts.len(), pts.iter().map(|p| p.1));
        let c = tactile_ident::solve::nnls(
            &(a.transpose() * &a),
            &(a.transpose() * &y),
            &[Sign::NonNegative; 3],
        );
        if c.iter().all(|v| v.is_finite()) && c[0] > 0.0 {
            SpringLaw::power(c[0], c[1], c[2])
        } else {
            SpringLaw::constant(1.0 / base_j)
        }
    };
    let g1 = law(j0, &|tau| tau.is_none_or(|t| t < FAST_BRANCH_S));
    let g2 = law(j_k, &|tau| tau.is_some_and(|t| t >= FAST_BRANCH_S));
    // The chip's inverse needs a static gain, so α is never 0: permanent creep becomes a
    // branch of a 10⁴ s time constant, and no Maxwell branch a stiff one (10⁻⁴ %/g).
    let (n1, alpha) = match maxwell {
        Some((tau, j)) => (tau / j, 1.0 / j),
        None if creep > 0.0 => (1.0 / creep, 1.0 / creep / 1e4),
        None => (1e8, 1e4),
    };
    Some(NonlinearMk {
        g1,
        n1,
        alpha,
        n2: tau_k / j_k,
        g2,
    })
}

/// The chip's calibration entry for a model given as terms.
fn taxel_model_of(
    terms: &[(Term, f64)],
    m: &FoldModels,
    (series, loads): (&Series, (f64, f64)),
    taxel: TaxelId,
    form: ChipForm,
) -> Option<TaxelModel> {
    // The creep term was scaled by the record's length. A creep that adds under a tenth of the
    // slow branches' compliance over the whole record is left out: eq. 14 would spend its slow
    // branch on it and merge the others into one.
    let t = series.duration_s();
    let branches: f64 = terms
        .iter()
        .filter(|(t, _)| {
            matches!(t, Term::Relaxation(tau) | Term::SlowRelaxation(tau) | Term::Alpha(tau) if *tau >= FAST_BRANCH_S)
        })
        .map(|(_, b)| b.max(0.0))
        .sum();
    let scaled: Vec<(Term, f64)> = terms
        .iter()
        .filter_map(|(term, b)| match term {
            Term::Creep if *b < 0.1 * branches => None,
            Term::Creep => Some((*term, b / t)),
            _ => Some((*term, *b)),
        })
        .collect();
    let element = element_of(&scaled, (m.force_scale_g, m.force_origin_g), loads, form)?;
    let stiffening = stiffens(terms);
    let mid = 0.5 * (loads.0 + loads.1);
    let at_mid = element.linearized(mid.max(1.0)).second_order();
    let schedule = if stiffening {
        secant_schedule(&element, &EXPORT_LOADS_G)
    } else {
        [(mid as f32, at_mid)].into_iter().collect()
    };
    let notch_hz = terms
        .iter()
        .find_map(|(t, _)| match t {
            Term::Line(hz, _) => Some(*hz),
            _ => None,
        })
        .unwrap_or(0.0);
    let offset: f64 = terms
        .iter()
        .filter(|(t, _)| *t == Term::Offset)
        .map(|(_, b)| *b)
        .sum();
    let plays: Vec<(f32, f32)> = terms
        .iter()
        .filter_map(|(t, b)| match t {
            // NOTE: the chip's plays start in the middle; settled plays
            // differ from them until the first full loading (the export gate scores that).
            Term::Play { radius_g, .. } if *b != 0.0 => Some((*radius_g as f32, *b as f32)),
            _ => None,
        })
        .collect();
    Some(TaxelModel {
        taxel,
        strain_offset_pct: offset,
        elastic_g_per_pct: m.secant_g_per_pct,
        second_order: at_mid,
        schedule,
        element,
        notch_hz,
        hysteresis: Plays::new(&plays).ok()?,
        ..TaxelModel::nominal(taxel)
    })
}

/// The loads the record saw (5–95 %), g.
fn load_range_g(series: &Series) -> (f64, f64) {
    let fk = series.kept(&series.force_g);
    (
        tactile_ident::stats::quantile(&fk, 0.05),
        tactile_ident::stats::quantile(&fk, 0.95),
    )
}

/// The estimators whose model the diagnosis' terms give (the bank is fitted apart).
const MODEL_KINDS: [EstimatorKind; 4] = [
    EstimatorKind::Elastic,
    EstimatorKind::SecondOrderInverse,
    EstimatorKind::ScheduledInverse,
    EstimatorKind::Observer,
];
/// Where [`MODEL_KINDS`] puts the observer and the scheduled inverse.
const OBSERVER: usize = 3;
const SCHEDULED: usize = 2;

/// A model's best form on the chip and its held-out errors.
type Scored = (ChipForm, Option<[f64; 4]>);

/// Held-out RMS (g) of each of `kinds` built per fold from `m`.
fn held_out_force<const K: usize>(
    m: &FoldModels,
    (series, loads): (&Series, (f64, f64)),
    form: ChipForm,
    kinds: [EstimatorKind; K],
) -> Option<[f64; K]> {
    let (mut sums, mut count) = ([0.0; K], 0usize);
    for (terms, &(a, b)) in m.terms.iter().zip(&m.folds) {
        let model = taxel_model_of(terms, m, (series, loads), TaxelId::default(), form)?;
        let mut est = TaxelEstimators::new(&model, series.dt_s).ok()?;
        // From the record's start: the estimators' state at the fold is its whole history's.
        for i in 0..b {
            let forces = est.update_kinds(series.strain_pct[i] as f32, kinds);
            if i >= a && !series.excluded[i] {
                let f = series.force_g[i];
                // An estimate that ran away counts as the chip would show it: no force.
                let v = |x: f32| if x.is_finite() { f64::from(x) } else { 0.0 };
                for (sum, x) in sums.iter_mut().zip(forces) {
                    *sum += (v(x) - f).powi(2);
                }
                count += 1;
            }
        }
    }
    let rms = sums.map(|s| (s / count.max(1) as f64).sqrt());
    rms.iter().all(|v| v.is_finite()).then_some(rms)
}

/// Held-out RMS (g) of each of [`MODEL_KINDS`] but the observer, whose is `observer_g`, each
/// kind on a thread of its own (they run apart: the same figures as run together).
fn held_out_kinds(
    m: &FoldModels,
    record: (&Series, (f64, f64)),
    form: ChipForm,
    observer_g: f64,
) -> Option<[f64; 4]> {
    let each: Vec<Option<f64>> = std::thread::scope(|scope| {
        let runs: Vec<_> = MODEL_KINDS[..OBSERVER]
            .iter()
            .map(|&kind| scope.spawn(move || held_out_force(m, record, form, [kind]).map(|v| v[0])))
            .collect();
        runs.into_iter().map(|r| r.join().ok().flatten()).collect()
    });
    let mut out = [observer_g; 4];
    for (o, v) in out.iter_mut().zip(each) {
        *o = v?;
    }
    Some(out)
}

/// `model` with the force bank fitted on the record, every estimator's held-out error (the
/// model's four from `held_out`) and the one that held out best as the one the chip runs.
fn with_bank(mut model: TaxelModel, series: &Series, held_out: [f64; 4]) -> TaxelModel {
    let mut conditioner = StrainConditioner::new(&model, series.dt_s);
    let strain: Vec<f64> = series
        .strain_pct
        .iter()
        .map(|e| f64::from(conditioner.update(*e as f32)))
        .collect();
    let scored: Vec<bool> = series.excluded.iter().map(|x| !x).collect();
    let bank = force_fit::fit_bank(series.dt_s, &series.force_g, &strain, &scored);
    let bank_g = bank.as_ref().map_or(f64::INFINITY, |b| b.held_out_g);
    if let Some(b) = bank {
        model.bank = b.model;
    }
    let all = [held_out[0], held_out[1], held_out[2], held_out[3], bank_g];
    model.estimator = EstimatorKind::best(&all);
    // Not measured (the bank did not fit): negative, as the table stores it.
    model.held_out_g = Some(all.map(|v| if v.is_finite() { v } else { -1.0 }));
    model
}

/// Whether `terms` hold a stiffening the fit kept.
fn stiffens(terms: &[(Term, f64)]) -> bool {
    terms
        .iter()
        .any(|(t, b)| matches!(t, Term::Stiffening { .. }) && *b != 0.0)
}

/// A model's best form on the chip and its held-out errors (none for a strain that falls as
/// the force rises).
fn form_of(m: &FoldModels, record: (&Series, (f64, f64))) -> Scored {
    if m.orientation < 0.0 {
        return (ChipForm::ALL[0], None);
    }
    best_form(m, record, forms_of(m))
}

/// The chip's forms that differ for `m`: without a stiffening its springs are the same in
/// either form, and only the branches' reductions are compared.
fn forms_of(m: &FoldModels) -> &'static [ChipForm] {
    const LINEAR: [ChipForm; 2] = [ChipForm::ALL[0], ChipForm::ALL[2]];
    if m.terms.iter().any(|terms| stiffens(terms)) {
        &ChipForm::ALL
    } else {
        &LINEAR
    }
}

/// The form among `forms` whose observer holds out best on the chip, with its held-out errors:
/// each form's observer on a thread of its own, then the other estimators of the best (of the
/// next best where one of them has no figure).
fn best_form(
    m: &FoldModels,
    record: (&Series, (f64, f64)),
    forms: &[ChipForm],
) -> (ChipForm, Option<[f64; 4]>) {
    let observer: Vec<Option<f64>> = std::thread::scope(|scope| {
        let runs: Vec<_> = forms
            .iter()
            .map(|&form| {
                scope.spawn(move || {
                    held_out_force(m, record, form, [EstimatorKind::Observer]).map(|v| v[0])
                })
            })
            .collect();
        runs.into_iter().map(|r| r.join().ok().flatten()).collect()
    });
    let mut order: Vec<(ChipForm, f64)> = forms
        .iter()
        .zip(&observer)
        .filter_map(|(f, o)| Some((*f, (*o)?)))
        .collect();
    // Stable: of forms that hold out alike, the first.
    order.sort_by(|a, b| a.1.total_cmp(&b.1));
    order
        .into_iter()
        .find_map(|(form, observer_g)| {
            held_out_kinds(m, record, form, observer_g).map(|v| (form, Some(v)))
        })
        .unwrap_or((forms.first().copied().unwrap_or(ChipForm::ALL[0]), None))
}

/// What the chip runs and why: every estimator's held-out error, the one it runs marked.
pub fn chip_choice(m: &TaxelModel) -> String {
    let Some(held_out) = m.held_out_g else {
        return format!(
            "  the chip runs its {} (not measured)\n",
            m.estimator.name()
        );
    };
    let all: Vec<String> = EstimatorKind::ALL
        .iter()
        .zip(held_out)
        .map(|(k, v)| {
            let mark = if *k == m.estimator { " ←" } else { "" };
            if v >= 0.0 {
                format!("{} {v:.3} g{mark}", k.name())
            } else {
                format!("{} not fitted{mark}", k.name())
            }
        })
        .collect();
    let b = &m.bank;
    let rezero = if b.rezero.is_on() {
        format!(
            "re-zeroes where it reads under {:.1} g and the strain is still",
            b.rezero.below_g
        )
    } else {
        "no re-zero".to_string()
    };
    format!(
        "  the chip runs its {} (held-out force error, g: {})\n  the force bank: lowpasses of {:.2}–{:.0} s{}{}; {rezero}\n",
        m.estimator.name(),
        all.join(", "),
        b.tau_s.first().copied().unwrap_or(0.0),
        b.tau_s.last().copied().unwrap_or(0.0),
        if b.uses(HINGE_TERMS) { ", a curve in hinges" } else { "" },
        if b.uses(PLAY_TERMS) { ", plays" } else { "" },
    )
}

/// Diagnoses a checked record and carries the result to the chip.
pub fn diagnose(series: &Series, taxel: TaxelId) -> Report {
    // The baseline's forms, and each round's accepted model's, are scored on the chip while
    // the diagnosis's rounds run.
    let record = (series, load_range_g(series));
    let (sender, fitted) = std::sync::mpsc::channel();
    let (mut d, early) = std::thread::scope(|scope| {
        let worker = scope.spawn(move || early::work_through(fitted, record));
        let d = tactile_ident::diagnose::diagnose_observed(series, &Settings::default(), &|m| {
            // NOTE: a worker gone (it panicked) is scored again below.
            let _ = sender.send(m);
        });
        drop(sender);
        (d, worker.join().unwrap_or_default())
    });
    let mut summary = d.summary.clone();
    let mut on_chip_list: Vec<(Effect, String)> = d
        .effects
        .iter()
        .map(|e| (*e, on_chip(*e).to_string()))
        .collect();
    let inverted = d.model.orientation < 0.0;
    // Scored early where the same folds and terms were handed over, else now.
    let scored = |terms: &[Vec<(Term, f64)>]| {
        early
            .scored(&d.model.folds, terms)
            .unwrap_or_else(|| form_of(&d.fold_models(terms), record))
    };
    let (base_form, before) = scored(&d.model.baseline_fold_terms);
    let (form, after) = if inverted || d.effects.is_empty() {
        (base_form, before)
    } else {
        scored(&d.model.chip_fold_terms)
    };
    let before_all = before.unwrap_or([f64::NAN; 4]);
    let after_all = after.unwrap_or(before_all);
    let (before_o, before_s) = (before_all[OBSERVER], before_all[SCHEDULED]);
    let (after_o, after_s) = (after_all[OBSERVER], after_all[SCHEDULED]);
    let exported = !d.effects.is_empty() && after_o < before_o;
    let (chosen, form) = if exported {
        (&d.model.chip_terms, form)
    } else {
        (&d.model.baseline_terms, base_form)
    };
    // Nothing the chip can run (no form held out on it): nothing to export.
    let table_model = if inverted || before.is_none() {
        None
    } else {
        let held_out = if exported { after_all } else { before_all };
        taxel_model_of(chosen, &d.fold_models(&[]), record, taxel, form)
            .map(|m| with_bank(m, series, held_out))
    };
    if inverted {
        summary.push_str("  on the chip: the strain falls as the force rises; the chip's estimators assume it rises, so no calibration is exported\n");
    } else if before.is_none() {
        summary.push_str("  on the chip: the fitted model gives none the chip's estimators can run (no elastic compliance, or loads centred at or below zero force), so no calibration is exported\n");
    } else {
        summary.push_str(&format!(
            "  force from strain on the chip (held-out folds): observer {before_o:.3} g → {after_o:.3} g, scheduled inverse {before_s:.3} g → {after_s:.3} g\n"
        ));
        if let Some(m) = &table_model {
            summary.push_str(&chip_choice(m));
        }
        if !d.effects.is_empty() {
            if exported {
                summary.push_str(
                    "  the accepted model lowers the on-chip error: `--table` writes it\n",
                );
            } else {
                summary.push_str("  the accepted model does not lower the on-chip error: `--table` writes the baseline's\n");
                for e in on_chip_list.iter_mut() {
                    e.1 = format!("not exported (no on-chip gain); {}", e.1);
                }
            }
            for (e, what) in &on_chip_list {
                summary.push_str(&format!("  on the chip, {e}: {what}\n"));
            }
        }
    }
    let finite = |v: f64| v.is_finite().then_some(v);
    d.summary = summary;
    Report {
        force_estimate: ForceEstimate {
            before_rms_g: finite(before_o),
            after_rms_g: finite(after_o),
            scheduled_before_rms_g: finite(before_s),
            scheduled_after_rms_g: finite(after_s),
            exported,
            on_chip: on_chip_list,
        },
        diagnosis: d,
        table_model,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_chip_figures_are_the_final_models_though_scored_while_the_rounds_ran() {
        // Two effects accepted in two rounds: the first round's model is handed over and
        // scored too, and the report must carry the forms of the model the rounds ended with.
        use tactile_ident::synth::{generate, Spec, SynthEffect};
        let g = generate(&Spec {
            seed: 42,
            rate_hz: 200.0,
            duration_s: 180.0,
            effects: vec![SynthEffect::Stiffening(0.5), SynthEffect::Drift(0.04)],
        });
        let series = Series::new(g.dt_s, g.force_g, g.strain_pct, vec![]).unwrap();
        let r = diagnose(&series, TaxelId::default());
        assert_eq!(r.diagnosis.effects.len(), 2, "{}", r.diagnosis.summary);
        let record = (&series, load_range_g(&series));
        let fresh = |terms: &[Vec<(Term, f64)>]| {
            let m = r.diagnosis.fold_models(terms);
            best_form(&m, record, forms_of(&m)).1.map(|v| v[OBSERVER])
        };
        let f = &r.force_estimate;
        assert_eq!(f.after_rms_g, fresh(&r.diagnosis.model.chip_fold_terms));
        assert_eq!(
            f.before_rms_g,
            fresh(&r.diagnosis.model.baseline_fold_terms)
        );
        assert_ne!(f.after_rms_g, f.before_rms_g);
    }

    #[test]
    fn a_clipped_strain_is_found_at_its_rail_and_a_held_one_is_not() {
        // A held load: a few codes about a level, its largest a tail.
        let held: Vec<f64> = (0..10_000)
            .map(|i| 10.0 + 0.011 * [0.0, 1.0, -1.0, 0.0, 2.0, 0.0, -1.0, 1.0][i % 8])
            .collect();
        assert!(at_top_rail(&held).iter().all(|x| !x));
        // A load beyond the converter for 40 % of the record: every sample there on the rail.
        let mut clipped = held.clone();
        for v in clipped.iter_mut().take(4000) {
            *v = 10.05;
        }
        let rail = at_top_rail(&clipped);
        assert_eq!(rail.iter().filter(|x| **x).count(), 4000);
        assert!(at_top_rail(&[]).is_empty());
    }
}
