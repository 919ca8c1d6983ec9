//! The diagnosis: a generalized Maxwell–Kelvin baseline, the named effects as groups of
//! regressors, forward selection by blocked cross-validation with a paired test over folds.
//!
//! In stages, one module each: `prepare` (the force as every model sees it, the strain's sign
//! and secant, the load basis's origin and scale, the grid of time constants and its support),
//! `floors` (the noise floors models are judged above), `tries` (the candidate columns and a
//! round's tries), `select` (scoring, judging, accepting, pruning, the chip's model) and
//! `report` (the errors, the sizes and the summary); `work` holds the regressors.

mod floors;
mod prepare;
mod report;
mod select;
mod tries;
mod work;

use serde::Serialize;

use crate::residual::ResidualTests;
use crate::series::{Intake, Series};
use crate::solve::{Pool, Scored};

use floors::Floors;
use tries::CandidateColumns;
use work::{baseline_columns, Work};

/// How the diagnosis decides. One documented struct; the defaults are what the tests and the
/// README's figures use.
#[derive(Clone, Debug, Serialize)]
pub struct Settings {
    /// One-sided p-value the paired test over folds must beat.
    pub alpha: f64,
    /// Least share of the held-out error above the noise floor an effect must remove.
    pub min_excess_share: f64,
    /// Least held-out gain as a share of the noise floor, in mean square (a gain inside the
    /// noise is no effect: at the floor the residual is the force's noise through the model,
    /// coloured, and a smooth basis takes a tenth of it).
    pub min_floor_share: f64,
    /// Share of the error above the floor an effect removes to be accepted without also
    /// whitening the residual (the right model's residual is the force estimate's coloured
    /// error).
    pub coloured_excess_share: f64,
    /// Most effects accepted one after another.
    pub max_rounds: usize,
    /// Fastest relaxation time of the baseline's grid, s (raised to two samples). Branches this
    /// fast let the baseline smooth a noisy force as a real sensor's fast dynamics would; a
    /// delay must do better than they do.
    pub tau_min_s: f64,
    /// Slowest relaxation time of the baseline's grid, s: slower relaxation is an effect.
    pub base_tau_max_s: f64,
    /// Grid points per decade of time constant.
    pub per_decade: f64,
    /// The range of eq. 14's N₁/α the baseline tries for its creep, s (the memo's element:
    /// N₁ of 5 000–8 250 and α of a few g/%); beside them eq. 11's permanent creep.
    pub alpha_tau_s: (f64, f64),
    /// Longest delay of the strain behind the force tried, s, and at most a quarter of the
    /// shortest fold (a held-out block must mostly see its own force): a fluid-filled skin
    /// lags by tenths of a second.
    pub delay_max_s: f64,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            alpha: 0.05,
            min_excess_share: 0.2,
            min_floor_share: 0.2,
            coloured_excess_share: 0.5,
            max_rounds: 3,
            tau_min_s: 0.005,
            base_tau_max_s: 20.0,
            per_decade: 6.0,
            alpha_tau_s: (300.0, 3000.0),
            delay_max_s: 1.0,
        }
    }
}

/// Radii of the hysteresis candidate's plays and Duhem operators, as shares of the record's force range (a loop that
/// spans the whole range, as a magnetic skin's does, needs the widest).
pub const PLAY_SHARES: [f64; 5] = [0.01, 0.03, 0.1, 0.3, 0.6];

/// Loading cycles (the force from about its lower quartile to its upper one and back) a record
/// needs before its plays are also tried settled.
pub const MIN_CYCLES_SETTLED: usize = 3;

/// The effects the diagnosis can name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    LoadDependentStiffness,
    Hysteresis,
    BaselineDrift,
    PeriodicInterference,
    TimeDelay,
    SlowRelaxation,
    SensitivityDrift,
}

impl core::fmt::Display for Effect {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.pad(self.name())
    }
}

impl Effect {
    pub fn name(self) -> &'static str {
        match self {
            Effect::LoadDependentStiffness => "load_dependent_stiffness",
            Effect::Hysteresis => "hysteresis",
            Effect::BaselineDrift => "baseline_drift",
            Effect::PeriodicInterference => "periodic_interference",
            Effect::TimeDelay => "time_delay",
            Effect::SlowRelaxation => "slow_relaxation",
            Effect::SensitivityDrift => "sensitivity_drift",
        }
    }
}

/// What a regressor is, so the model can be taken apart again (for the chip, for the sizes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Term {
    Offset,
    /// The force itself: the instantaneous compliance.
    Elastic,
    /// A Kelvin branch of the baseline, time constant s.
    Relaxation(f64),
    /// The Maxwell dashpot (permanent creep, eq. 11): ∫σ dt / T.
    Creep,
    /// Eq. 14's Maxwell branch, the dashpot N₁ beside the small spring α: the creep levelling
    /// off with this time constant N₁/α, s.
    Alpha(f64),
    /// A Kelvin branch slower than the baseline's grid, s.
    SlowRelaxation(f64),
    /// Load basis g(σ) = σ·|σ/σ_s|^(power) through a branch (None: instantaneous).
    Stiffening {
        power: f64,
        tau_s: Option<f64>,
    },
    /// A play operator of this radius, g, started in the middle of its loop (a sensor never
    /// loaded) or settled (where a pass over the record leaves it: a sensor cycled before).
    Play {
        radius_g: f64,
        settled: bool,
    },
    /// A Duhem operator of this radius, g (`terms::duhem`).
    Duhem {
        radius_g: f64,
    },
    /// cos(πkt/T).
    Drift(usize),
    /// sin (false) or cos (true) at this frequency.
    Line(f64, bool),
    /// Force-driven prediction × the Legendre polynomial of degree k over the record.
    Gain(usize),
    /// Force-driven prediction × cos(πkt/T).
    GainCosine(usize),
}

impl Term {
    fn force_driven(self) -> bool {
        matches!(
            self,
            Term::Elastic
                | Term::Relaxation(_)
                | Term::Creep
                | Term::Alpha(_)
                | Term::SlowRelaxation(_)
                | Term::Stiffening { .. }
                | Term::Play { .. }
                | Term::Duhem { .. }
        )
    }
}

/// One candidate's outcome.
#[derive(Clone, Debug, Serialize)]
pub struct Candidate {
    pub effect: Effect,
    pub variant: String,
    pub round: usize,
    pub held_out_rms_g: f64,
    pub held_out_rms_pct: f64,
    pub fit_rms_g: f64,
    pub ljung_box_ratio: f64,
    /// One-sided p-value of the paired test of its held-out gain over the folds.
    pub p_value: f64,
    pub folds_better: usize,
    /// Share of the current model's held-out error above the noise floor it removes.
    pub excess_removed: f64,
    pub accepted: bool,
    /// Held-out error of each fold, strain %.
    pub fold_rms_pct: Vec<f64>,
}

/// Errors of a model: strain % (what is measured) and grams through the record's secant.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Errors {
    pub fit_rms_g: f64,
    pub held_out_rms_g: f64,
    pub fit_rms_pct: f64,
    pub held_out_rms_pct: f64,
    /// Held-out RMS of each fold, % strain.
    pub fold_rms_pct: Vec<f64>,
}

/// A fold of the record.
#[derive(Clone, Debug, Serialize)]
pub struct Fold {
    pub start_s: f64,
    pub end_s: f64,
    pub samples: usize,
}

/// An accepted effect's size in physical units.
#[derive(Clone, Debug, Serialize)]
pub struct Size {
    pub effect: Effect,
    pub description: String,
    pub values: Vec<(String, f64)>,
}

/// The baseline in physical terms.
#[derive(Clone, Debug, Serialize)]
pub struct Baseline {
    pub offset_pct: f64,
    pub elastic_pct_per_g: f64,
    /// (time constant s, compliance %/g) of each Kelvin branch with weight.
    pub branches: Vec<(f64, f64)>,
    /// Permanent creep, % per g·s (eq. 11), or 0 where eq. 14's branch took its place.
    pub creep_pct_per_g_s: f64,
    /// Eq. 14's Maxwell branch where the record shows the creep levelling off: (N₁/α s, 1/α
    /// %/g).
    pub alpha_branch: Option<(f64, f64)>,
}

/// A model fitted on each fold's complement, and what turns its terms into grams: what the
/// chip's estimators need to be scored held out.
#[derive(Clone, Debug)]
pub struct FoldModels {
    /// Per fold, the terms fitted on the other folds.
    pub terms: Vec<Vec<(Term, f64)>>,
    /// Each fold's samples [start, end).
    pub folds: Vec<(usize, usize)>,
    pub force_scale_g: f64,
    pub force_origin_g: f64,
    pub secant_g_per_pct: f64,
    /// −1 when the strain falls as the force rises.
    pub orientation: f64,
}

/// The diagnosis of a record.
#[derive(Clone, Debug, Serialize)]
pub struct Diagnosis {
    /// How the record was taken in: its time stamps mended, the samples left out and why.
    pub intake: Intake,
    pub effect: String,
    pub effects: Vec<Effect>,
    pub before: Errors,
    pub after: Errors,
    /// `after` is judged on each held-out block less its own offset and slope (a drift that
    /// wanders, accepted as the last resort: no basis carries it across a block).
    pub after_per_block_line: bool,
    /// A first-order linear model (spring and one Kelvin branch) on the same folds: the floor
    /// any model of the sensor should beat.
    pub first_order: Errors,
    pub first_order_tau_s: f64,
    pub candidates: Vec<Candidate>,
    pub folds: Vec<Fold>,
    /// Judged again on blocks of at most [`SWING_BLOCK_S`]: nothing passed on the first
    /// folds, this many of them (a zero that swings every minute or more turns inside a longer
    /// block, where no drift basis follows it).
    pub first_folds: Option<usize>,
    /// Grams per % strain: the record's static secant (robust line of strain on force).
    pub secant_g_per_pct: f64,
    /// The strain's noise (and the force's, through the model), % and g.
    pub noise_floor_pct: f64,
    pub noise_floor_g: f64,
    pub sizes: Vec<Size>,
    pub baseline: Baseline,
    pub residual_before: ResidualTests,
    pub residual_after: ResidualTests,
    /// Where the residual lives, when nothing named explains it, or when what the named
    /// effects leave is far from white and over four noise floors.
    pub unexplained: Option<String>,
    pub summary: String,
    #[serde(skip)]
    pub model: Model,
}

impl Diagnosis {
    /// `terms` (one set per fold, as [`Model::fold_terms`]) with the record's folds and scale.
    pub fn fold_models(&self, terms: &[Vec<(Term, f64)>]) -> FoldModels {
        FoldModels {
            terms: terms.to_vec(),
            folds: self.model.folds.clone(),
            force_scale_g: self.model.force_scale_g,
            force_origin_g: self.model.force_origin_g,
            secant_g_per_pct: self.secant_g_per_pct,
            orientation: self.model.orientation,
        }
    }
}

/// The accepted model, for the chip and for plots.
#[derive(Clone, Debug, Default)]
pub struct Model {
    /// −1 when the strain falls as the force rises (the fit runs on the negated strain).
    pub orientation: f64,
    /// Force scale of the load basis, g.
    pub force_scale_g: f64,
    /// Load the load basis is measured from, g: 0, or the record's lowest (or, for a force
    /// recorded negative, highest) load where the force never comes near zero (a load cell
    /// not tared, a finger held preloaded): see [`stiffening_load`].
    pub force_origin_g: f64,
    /// The accepted delay of the strain behind the force, s (0: none).
    pub delay_s: f64,
    pub terms: Vec<(Term, f64)>,
    pub baseline_terms: Vec<(Term, f64)>,
    /// The same models fitted on each fold's complement (for held-out scores of their forms on
    /// the chip).
    pub fold_terms: Vec<Vec<(Term, f64)>>,
    /// The model in the chip's forms (`terms` but for a loop of Duhem operators, which the
    /// chip undoes as plays), and fitted on each fold's complement.
    pub chip_terms: Vec<(Term, f64)>,
    pub chip_fold_terms: Vec<Vec<(Term, f64)>>,
    pub baseline_fold_terms: Vec<Vec<(Term, f64)>>,
    /// Predicted strain of the baseline and of the accepted model, % (in the record's sign).
    pub baseline_prediction: Vec<f64>,
    pub prediction: Vec<f64>,
    pub folds: Vec<(usize, usize)>,
}

/// The model as it stands between rounds.
struct State {
    /// The accepted delay of the force, s.
    delay_s: f64,
    cols: Vec<usize>,
    groups: Vec<(Effect, Vec<usize>)>,
    scored: Scored,
    tests: ResidualTests,
    /// The drift was accepted on each held-out block less its own offset and slope: it
    /// wanders too much to be carried from the blocks around (see the round's last resort).
    drift_by_block: bool,
}

impl State {
    /// Whether `effect` is in the model.
    fn taken(&self, effect: Effect) -> bool {
        self.groups.iter().any(|g| g.0 == effect)
    }
}

/// A candidate: columns to add, columns it replaces (a delay replaces the baseline's).
struct Try {
    effect: Effect,
    variant: String,
    add: Vec<usize>,
    remove: Vec<usize>,
    delay_s: f64,
    /// Accepted effects whose columns this try builds anew rather than delays (a stiffening
    /// through the delayed fit's branches).
    regroup: Vec<(Effect, Vec<usize>)>,
    /// The model the try is judged against where it is not the model as it stands (the
    /// rebuilt basis without the delay).
    reference: Option<Scored>,
}

impl Try {
    fn adding(effect: Effect, variant: String, add: Vec<usize>) -> Try {
        Try {
            effect,
            variant,
            add,
            remove: Vec::new(),
            delay_s: 0.0,
            regroup: Vec::new(),
            reference: None,
        }
    }
}

/// The baseline as first fitted, for the report: its score and its residual's tests, and the
/// first-order model on the same folds.
struct Before {
    scored: Scored,
    tests: ResidualTests,
    first_order: Option<Scored>,
}

/// What every round of the selection reads besides the model as it stands.
struct Selection<'a> {
    settings: &'a Settings,
    floors: &'a Floors,
    columns: &'a CandidateColumns,
    /// Grams per % strain (the candidates are reported in both).
    secant: f64,
}

/// The load basis of a stiffening term of `power` at force `f_g`: the load above `origin_g`
/// times its size over `scale_g` to that power, (σ − σ₀)·|(σ − σ₀)/σs|^p. Where the force never
/// comes near zero the origin is the record's lowest load: measured from zero, the basis over a
/// narrow band far from it is nearly linear in the load, and an untared load cell's record
/// (300 g on an 80 g swing) had its stiffening named hysteresis.
pub fn stiffening_load(f_g: f64, origin_g: f64, scale_g: f64, power: f64) -> f64 {
    let d = f_g - origin_g;
    d * (d.abs() / scale_g).powf(power)
}

/// Diagnoses a checked record with the default settings.
pub fn diagnose(series: &Series) -> Diagnosis {
    diagnose_with(series, &Settings::default())
}

/// Diagnoses a checked record: the record prepared, the baseline's support and folds, the
/// baseline and its noise floors, the candidate columns, rounds of selection, the effects the
/// later ones explain pruned, the chip's model, the report.
///
/// A record left `unexplained` on blocks longer than [`SWING_BLOCK_S`] is judged again on blocks
/// that short, and that verdict kept where it names an effect: a zero that turns inside a
/// held-out block cannot be interpolated into it by any drift basis. The first blocks stand
/// where anything passed on them: a slow relaxation of τ is seen whole only in blocks of ~2τ,
/// and on short blocks a drift's half-cosines take its slow response.
pub fn diagnose_with(series: &Series, settings: &Settings) -> Diagnosis {
    diagnose_observed(series, settings, &|_| {})
}

/// [`diagnose_with`], handing `on_fitted` the fold models of the baseline as soon as they are
/// fitted, and of the model as it stands after each round that accepts an effect (the rounds
/// leave a core mostly idle: a caller can score them meanwhile; the last one handed over is
/// the diagnosis's chip model unless a later step changed it). A record judged again on
/// shorter blocks hands over a second series; compare folds and terms to find which is which.
pub fn diagnose_observed(
    series: &Series,
    settings: &Settings,
    on_fitted: &(dyn Fn(FoldModels) + Sync),
) -> Diagnosis {
    let d = diagnose_on(series, settings, None, on_fitted);
    let block_s = series.duration_s() / d.folds.len().max(1) as f64;
    if d.effect != "unexplained" || block_s <= SWING_BLOCK_S * 1.01 {
        return d;
    }
    let again = diagnose_on(series, settings, Some(d.folds.len()), on_fitted);
    if again.effect == "unexplained" {
        d
    } else {
        again
    }
}

/// The longest held-out block that judges a zero swinging every minute or more (a mount
/// settling, a room's temperature): it turns at most about once inside one.
pub const SWING_BLOCK_S: f64 = 45.0;

/// [`diagnose_with`] on the usual folds, or (`first_folds`: nothing passed on that many) on
/// blocks at most [`SWING_BLOCK_S`] long.
fn diagnose_on(
    series: &Series,
    settings: &Settings,
    first_folds: Option<usize>,
    on_fitted: &(dyn Fn(FoldModels) + Sync),
) -> Diagnosis {
    let prep = prepare::prepare(series, settings);
    let s = &prep.smoothed;
    let longest_block_s = first_folds.map_or(f64::INFINITY, |_| SWING_BLOCK_S);
    let (taus, creep, folds) = prepare::support_and_folds(&prep, settings, longest_block_s);

    // The baseline on the folds, its noise floors, and the first-order model beside it.
    let mut work = Work {
        s,
        pool: Pool::new(&prep.y, &s.excluded, folds.clone()),
        terms: Vec::new(),
        kept: prep.kept,
        force_kept: prep.force_kept,
        measured_force_kept: prep.measured_force_kept,
        force_scale: prep.force_scale,
        force_origin: prep.force_origin,
    };
    let base = baseline_columns(&mut work, &taus, creep);
    let scored = work.pool.score(&base);
    let tests = work.tests(&base, &scored.beta);
    let floors = Floors::new(
        &work,
        &scored,
        prep.force_noise,
        prep.force_noise_passed,
        prep.window,
    );
    let mut state = State {
        delay_s: 0.0,
        cols: base.clone(),
        groups: Vec::new(),
        scored,
        tests,
        drift_by_block: false,
    };
    let fold_models = |work: &Work, scored: &Scored| FoldModels {
        terms: report::fold_terms_of(work, scored),
        folds: folds.ranges.clone(),
        force_scale_g: work.force_scale,
        force_origin_g: work.force_origin,
        secant_g_per_pct: prep.secant,
        orientation: prep.orientation,
    };
    on_fitted(fold_models(&work, &state.scored));
    let first_order = floors::first_order(&mut work, &base);
    let before = Before {
        scored: state.scored.clone(),
        tests: state.tests.clone(),
        first_order,
    };

    // Then the candidates, and rounds of selection until no effect passes.
    let unsupported: Vec<f64> = prep
        .taus
        .iter()
        .copied()
        .filter(|t| !taus.contains(t))
        .collect();
    let columns = CandidateColumns::new(
        &mut work,
        settings,
        (prep.force_range, floors.force_noise),
        creep,
        &unsupported,
    );
    let selection = Selection {
        settings,
        floors: &floors,
        columns: &columns,
        secant: prep.secant,
    };
    let mut candidates = Vec::new();
    for round in 1..=settings.max_rounds {
        if !selection.round(&mut work, &mut state, round, &mut candidates) {
            break;
        }
        // The chip's model if the rounds stop here (a loop's Duhem terms are refitted as
        // plays for the chip afterwards: not handed over).
        if !state
            .cols
            .iter()
            .any(|c| matches!(work.terms[*c], Term::Duhem { .. }))
        {
            on_fitted(fold_models(&work, &state.scored));
        }
    }
    selection.prune(&mut work, &mut state, &mut candidates);

    // The report's held-out errors are plain cross-validation, but after a drift that only
    // each block's own offset and slope can follow: then under that judge (the summary says so).
    if work.pool.set_local_nuisance(state.drift_by_block) {
        state.scored = work.pool.score(&state.cols);
    }
    let chip = select::chip_model(&mut work, &state, &columns.plays);
    // The candidates' columns are no longer needed: free them before the report's copies.
    columns.free(&mut work, &state, chip.as_ref());
    report::finish(
        &work,
        state,
        chip,
        before,
        candidates,
        (folds, first_folds),
        prep.secant,
        floors.floor,
        prep.orientation,
    )
}

impl Selection<'_> {
    /// A round of selection: the tries against the model as it stands, the best variant of
    /// each effect scored and judged, the simpler of effects that explain the same residual,
    /// the last-resort drift judged by block, the winner accepted. Returns whether an effect
    /// was accepted (else the selection ends).
    fn round(
        &self,
        work: &mut Work,
        state: &mut State,
        round: usize,
        candidates: &mut Vec<Candidate>,
    ) -> bool {
        // Once a drift is in the model, later effects are judged on each held-out block
        // less its own offset and slope (`Pool::set_local_nuisance`).
        if state.taken(Effect::BaselineDrift) && work.pool.set_local_nuisance(true) {
            state.scored = work.pool.score(&state.cols);
        }
        let (tries, temporary) = tries::tries(work, state, self.columns, self.settings, round);
        let mut best = select::best_of_each(work, state, tries);

        // Judged against the model as it stands; the last resort only where nothing passed,
        // first or after a gain in time alone: where the load holds, a gain's basis takes a
        // zero's settling, and what it leaves of the zero swings inside the blocks.
        let judge = select::Judge::new(work, state, self, round);
        let (mut round_candidates, passed, winner) = judge.all(work, &best);
        let mut winner = judge.simpler(work, &best, &passed, winner);
        if winner.is_none()
            && state.groups.iter().all(|g| g.0 == Effect::SensitivityDrift)
            && floors::far_from_white(&state.tests, state.scored.cv_mse, self.floors.floor)
        {
            if let Some((candidate, accepted)) = judge.drift_by_block(work) {
                round_candidates.push(candidate);
                if let Some((t, sc, gain)) = accepted {
                    best.push((t, sc));
                    winner = Some((best.len() - 1, gain));
                    state.drift_by_block = true;
                }
            }
        }

        let next = winner.map(|(i, _)| {
            round_candidates[i].accepted = true;
            best.swap_remove(i)
        });
        candidates.extend(round_candidates);
        match next {
            Some((t, sc)) => {
                select::accept(work, state, t, sc, temporary);
                true
            }
            None => {
                for c in temporary {
                    work.pool.drop_column(c);
                }
                false
            }
        }
    }
}
