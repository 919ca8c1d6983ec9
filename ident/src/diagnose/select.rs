//! The selection: every try scored on the folds, the best variant of each effect judged
//! against the model as it stands, the simpler of effects that explain the same residual, the
//! last-resort drift judged by block, the winner accepted; then the effects the later ones
//! explain pruned, and the chip's model.

use crate::par;
use crate::solve::Scored;
use crate::stats;

use super::floors::Floors;
use super::work::Work;
use super::{Candidate, Effect, Selection, State, Term, Try};

/// A try against the model as it stands: what it is accepted by, and reported with.
struct Judged {
    /// The per-fold gains of the paired test (log ratios, the try's folds less the force
    /// noise it passes beyond the model's), and the t-test's p-value on them.
    fold_gains: Vec<f64>,
    p_value: f64,
    /// The held-out mean square it takes off, the floor of the two models, and what the model
    /// holds out above that floor.
    gain: f64,
    floor: f64,
    excess: f64,
    ljung_box_ratio: f64,
    /// Its residual's coloured power.
    colored: f64,
}

impl Candidate {
    /// The candidate's line: try `sc` of `effect`'s `variant` in `round`, as `j` judged it.
    fn judged(
        (effect, variant, round): (Effect, String, usize),
        sc: &Scored,
        j: &Judged,
        secant: f64,
    ) -> Self {
        Candidate {
            effect,
            variant,
            round,
            held_out_rms_g: sc.cv_mse.sqrt() * secant,
            held_out_rms_pct: sc.cv_mse.sqrt(),
            fit_rms_g: sc.fit_mse.sqrt() * secant,
            ljung_box_ratio: j.ljung_box_ratio,
            p_value: j.p_value,
            folds_better: j.fold_gains.iter().filter(|v| **v > 0.0).count(),
            excess_removed: if j.excess > 0.0 {
                j.gain / j.excess
            } else {
                0.0
            },
            accepted: false,
            fold_rms_pct: sc.fold_mse.iter().map(|v| v.sqrt()).collect(),
        }
    }
}

/// A try that passed, its score, and the held-out mean square it takes off.
pub(super) type Passed = (Try, Scored, f64);

/// Scores every try; per effect, the best variant.
pub(super) fn best_of_each(work: &mut Work, state: &State, tries: Vec<Try>) -> Vec<(Try, Scored)> {
    let mut best: Vec<(Try, Scored)> = Vec::new();
    for t in tries {
        let all: Vec<usize> = state
            .cols
            .iter()
            .filter(|c| !t.remove.contains(c))
            .chain(&t.add)
            .copied()
            .collect();
        let sc = work.pool.score(&all);
        match best.iter_mut().find(|b| b.0.effect == t.effect) {
            Some(b) if b.1.cv_mse <= sc.cv_mse => {}
            Some(b) => *b = (t, sc),
            None => best.push((t, sc)),
        }
    }
    best
}

/// The bar a round's tries clear against the model as it stands.
pub(super) struct Judge<'a> {
    sel: &'a Selection<'a>,
    state: &'a State,
    round: usize,
    /// The model's residual's coloured power, and its energy (`Floors::energy_of`).
    colored: f64,
    energy: f64,
}

impl<'a> Judge<'a> {
    pub(super) fn new(
        work: &Work,
        state: &'a State,
        sel: &'a Selection<'a>,
        round: usize,
    ) -> Judge<'a> {
        Judge {
            sel,
            state,
            round,
            colored: work.whiteness(&state.cols, &state.scored.beta).1,
            energy: Floors::energy_of(work, &state.scored),
        }
    }

    /// A try against the model as it stands (or the try's own reference).
    fn judge(&self, work: &Work, reference: Option<&Scored>, sc: &Scored) -> Judged {
        let floors = self.sel.floors;
        let (current, energy) = match reference {
            Some(r) => (r, Floors::energy_of(work, r)),
            None => (&self.state.scored, self.energy),
        };
        let fold_gains = fold_gains(&current.fold_mse, &floors.noise_matched(work, sc, energy));
        let (ljung_box_ratio, colored) = work.whiteness(&sc.columns, &sc.beta);
        let floor = floors.floor_at(Floors::energy_of(work, sc).max(energy));
        Judged {
            p_value: stats::paired_p_value(&fold_gains),
            fold_gains,
            gain: current.cv_mse - sc.cv_mse,
            floor,
            excess: (current.cv_mse - floor).max(0.0),
            ljung_box_ratio,
            colored,
        }
    }

    /// Effect `a` beats `b` by the bar an effect clears against the model without it:
    /// consistently over the folds, and a share of what `b` leaves above the floor.
    fn beats(&self, work: &Work, a: &Scored, b: &Scored) -> bool {
        let (floors, settings) = (self.sel.floors, self.sel.settings);
        let (energy_a, energy_b) = (Floors::energy_of(work, a), Floors::energy_of(work, b));
        paired(&fold_gains(
            &b.fold_mse,
            &floors.noise_matched(work, a, energy_b),
        )) < settings.alpha
            && b.cv_mse - a.cv_mse
                >= settings.min_excess_share
                    * (b.cv_mse - floors.floor_at(energy_a.max(energy_b))).max(0.0)
    }

    /// A gain on the force-driven strain is an additive slow term wherever the load moves
    /// slowly: it is named only where it beats a drift alone, passing or not (a drift beside
    /// hysteresis was taken by the gain's cubic, seed 24; by its quartic, 14 % better than
    /// the drift's half-cosines, seeds 105 and 107).
    fn drift_does_as_well(&self, work: &Work, best: &[(Try, Scored)], gain: &Scored) -> bool {
        best.iter()
            .any(|(t, sc)| t.effect == Effect::BaselineDrift && !self.beats(work, gain, sc))
    }

    /// The p-value a try must beat: a further effect clears a stricter test, each round
    /// being another look.
    fn alpha(&self) -> f64 {
        let strict = if self.round > 1 { 5.0 } else { 1.0 };
        self.sel.settings.alpha / strict
    }

    /// Whether try `t`, scored `sc` and `judged`, passes: consistently better over the folds,
    /// a share of the excess and of the floor, and whiter (or most of the excess).
    fn passes(
        &self,
        work: &Work,
        best: &[(Try, Scored)],
        (t, sc): (&Try, &Scored),
        judged: &Judged,
    ) -> bool {
        let settings = self.sel.settings;
        let (p, gain, excess, colored) =
            (judged.p_value, judged.gain, judged.excess, judged.colored);
        // A second effect of another kind takes the share a first takes (what the first
        // leaves holds its basis's misfit: a delay beside a stiffening took all of its own
        // part and a fifth of the excess); one whose basis could take the first's misfit, or
        // a third, half.
        let stands_in = self.state.groups.iter().any(|g| kin(t.effect, g.0));
        let share = if self.round > 2 || stands_in {
            0.5
        } else {
            settings.min_excess_share
        };
        p < self.alpha()
            && gain >= share * excess
            && gain > 0.0
            && gain >= settings.min_floor_share * judged.floor
            && (colored < self.colored || gain >= settings.coloured_excess_share * excess)
            && !(t.effect == Effect::SensitivityDrift && self.drift_does_as_well(work, best, sc))
    }

    /// Judges the best variant of each effect: the round's candidates, whether each passed,
    /// and the winner (of those that passed, the largest gain) with its gain.
    pub(super) fn all(
        &self,
        work: &Work,
        best: &[(Try, Scored)],
    ) -> (Vec<Candidate>, Vec<bool>, Option<(usize, f64)>) {
        let mut winner: Option<(usize, f64)> = None;
        let mut round_candidates = Vec::new();
        let mut passed = Vec::new();
        // Each try judged apart (its whiteness and floors: a pass over the record each).
        let judged = par::map(best, |(t, sc)| self.judge(work, t.reference.as_ref(), sc));
        for (i, ((t, sc), judged)) in best.iter().zip(judged).enumerate() {
            let pass = self.passes(work, best, (t, sc), &judged);
            passed.push(pass);
            if pass && winner.is_none_or(|w| judged.gain > w.1) {
                winner = Some((i, judged.gain));
            }
            round_candidates.push(Candidate::judged(
                (t.effect, t.variant.clone(), self.round),
                sc,
                &judged,
                self.sel.secant,
            ));
        }
        (round_candidates, passed, winner)
    }

    /// Effects that explain the same slow residual, head to head: the simplest one that the
    /// winner does not beat as an effect must beat the model without it (in the spirit of
    /// the one-standard-error rule of cross-validation). Returns the winner, or that simpler
    /// effect with its gain.
    pub(super) fn simpler(
        &self,
        work: &Work,
        best: &[(Try, Scored)],
        passed: &[bool],
        winner: Option<(usize, f64)>,
    ) -> Option<(usize, f64)> {
        let (w, _) = winner?;
        // Size: the columns the fit uses beyond the model's (NNLS leaves most of a relaxation
        // grid at zero; a free basis uses all of it). Net of the model's own columns it sets to
        // zero: eq. 14's branch refitted beside a slow mode takes the place of the baseline's,
        // which the mode had pulled toward itself.
        let used = |sc: &Scored| sc.beta.iter().filter(|b| **b != 0.0).count() as isize;
        let size = |i: usize| used(&best[i].1) - used(&self.state.scored);
        if !confusable(best[w].0.effect) {
            return winner;
        }
        let simpler = (0..best.len())
            .filter(|&i| {
                i != w
                    && passed[i]
                    && confusable(best[i].0.effect)
                    && size(i) < size(w)
                    && !self.beats(work, &best[w].1, &best[i].1)
            })
            .min_by_key(|&i| size(i));
        match simpler {
            Some(i) => Some((i, self.state.scored.cv_mse - best[i].1.cv_mse)),
            None => winner,
        }
    }

    /// Last resort: a drift that wanders (a settling and a slow swing, no low-order shape)
    /// is a function of time the half-cosines fitted on the other blocks cannot carry into
    /// a 30–60 s held-out block. When nothing passed on a record that would be left
    /// `unexplained`, the drift is judged on each held-out block less its own offset and
    /// slope (2 of its thousands of samples' freedom), against the baseline judged plainly:
    /// the force-driven effects that could take the same slow residual were tried above and
    /// predicted nothing. Only then: after a named effect, a block's own line also takes
    /// the slow misfit of that effect's basis (half of what a play model leaves of a Duhem
    /// loop), and near the floor it takes a share of the noise. The one exception is a gain
    /// in time, and then the drift must also beat a block's own gain line
    /// ([`Judge::beats_gain_line`]).
    ///
    /// Returns the best number of half-cosines as a candidate, and when it passes, its try,
    /// score and gain.
    pub(super) fn drift_by_block(&self, work: &mut Work) -> Option<(Candidate, Option<Passed>)> {
        let (settings, columns) = (self.sel.settings, self.sel.columns);
        work.pool.set_local_nuisance(true);
        let by_block = super::tries::DRIFT_COSINES
            .into_iter()
            .filter(|k| *k <= columns.drift_max)
            .map(|k| {
                let all: Vec<usize> = self
                    .state
                    .cols
                    .iter()
                    .chain(&columns.drift[..k])
                    .copied()
                    .collect();
                (k, work.pool.score(&all))
            })
            .min_by(|a, b| a.1.cv_mse.total_cmp(&b.1.cv_mse));
        work.pool.set_local_nuisance(false);
        let (k, sc) = by_block?;
        let mut judged = self.judge(work, None, &sc);
        // The t-test or the signed-rank test, as effects are compared head to head.
        judged.p_value = paired(&judged.fold_gains);
        let (gain, excess) = (judged.gain, judged.excess);
        // Half the excess at least: the blocks' own lines take a little of any slow
        // misfit, a drift most of the residual.
        let pass = judged.p_value < self.alpha()
            && gain >= settings.coloured_excess_share * excess
            && gain >= settings.min_floor_share * judged.floor
            && judged.colored < self.colored
            && (!self.state.taken(Effect::SensitivityDrift) || self.beats_gain_line(work, &sc));
        let candidate = Candidate::judged(
            (
                Effect::BaselineDrift,
                format!("{k} half-cosines, each held-out block less its own offset and slope"),
                self.round,
            ),
            &sc,
            &judged,
            self.sel.secant,
        );
        let accepted = pass.then(|| {
            let t = Try::adding(
                Effect::BaselineDrift,
                String::new(),
                columns.drift[..k].to_vec(),
            );
            (t, sc, gain)
        });
        Some((candidate, accepted))
    }
}

impl Judge<'_> {
    /// After a gain in time, a block's own line also takes what the gain's basis leaves of
    /// the sensitivity's course; but a gain multiplies the load and a zero does not. The drift
    /// judged by block must beat, as an effect beats the model without it, the model judged on
    /// each held-out block less a gain line of its own (the force-driven strain and it × time).
    fn beats_gain_line(&self, work: &Work, drift: &Scored) -> bool {
        let (floors, settings) = (self.sel.floors, self.sel.settings);
        let model = &self.state.scored;
        let part = work.force_part(&model.columns, &model.beta);
        let fold_mse = less_block_gain_line(work, model, &part);
        let counts = &work.pool.folds().counts;
        let used: usize = counts.iter().sum();
        let cv: f64 = fold_mse
            .iter()
            .zip(counts)
            .map(|(m, n)| m * *n as f64)
            .sum::<f64>()
            / used.max(1) as f64;
        let energy = Floors::energy_of(work, model);
        let d = fold_gains(&fold_mse, &floors.noise_matched(work, drift, energy));
        let floor = floors.floor_at(Floors::energy_of(work, drift).max(energy));
        paired(&d) < self.alpha()
            && cv - drift.cv_mse >= settings.min_excess_share * (cv - floor).max(0.0)
    }
}

/// Each fold's held-out mean square of `sc` less the fold's own gain line: its residual's
/// projection on the force-driven strain `part` and `part` × time within the fold.
fn less_block_gain_line(work: &Work, sc: &Scored, part: &[f64]) -> Vec<f64> {
    let y = work.pool.y();
    let folds = work.pool.folds();
    folds
        .ranges
        .iter()
        .zip(&folds.counts)
        .zip(&sc.fold_beta)
        .map(|((&(a, b), &n), beta)| {
            let prediction = work.pool.predict_in(&sc.columns, beta, (a, b));
            let mid = 0.5 * (a + b) as f64;
            let [mut uu, mut uv, mut vv, mut ru, mut rv, mut rr] = [0.0; 6];
            for i in (a..b).filter(|&i| work.kept[i]) {
                let r = y[i] - prediction[i - a];
                let (u, v) = (part[i], part[i] * (i as f64 - mid));
                uu += u * u;
                uv += u * v;
                vv += v * v;
                ru += r * u;
                rv += r * v;
                rr += r * r;
            }
            let det = uu * vv - uv * uv;
            let taken = if det > 1e-12 * uu * vv {
                (vv * ru * ru - 2.0 * uv * ru * rv + uu * rv * rv) / det
            } else if uu > 0.0 {
                ru * ru / uu
            } else {
                0.0
            };
            (rr - taken).max(0.0) / n.max(1) as f64
        })
        .collect()
}

/// Effects whose bases can take each other's misfit: both slow (see [`confusable`]), or both
/// functions of the load's history (a play basis leaves a loop's curved backbone, a load basis
/// a loop's width).
fn kin(a: Effect, b: Effect) -> bool {
    let load = |e| matches!(e, Effect::LoadDependentStiffness | Effect::Hysteresis);
    (confusable(a) && confusable(b)) || (load(a) && load(b))
}

/// Effects that can explain the same slow residual.
fn confusable(e: Effect) -> bool {
    matches!(
        e,
        Effect::SlowRelaxation
            | Effect::BaselineDrift
            | Effect::LoadDependentStiffness
            | Effect::SensitivityDrift
    )
}

/// Accepts try `t`, scored `sc`: its columns join the model (stored: every later score reads
/// them), the round's other `temporary` columns are freed.
pub(super) fn accept(
    work: &mut Work,
    state: &mut State,
    t: Try,
    sc: Scored,
    temporary: Vec<usize>,
) {
    for c in temporary.into_iter().filter(|c| !t.add.contains(c)) {
        work.pool.drop_column(c);
    }
    state.cols.retain(|c| !t.remove.contains(c));
    state.cols.extend(&t.add);
    for c in &t.add {
        work.pool.store(*c);
    }
    if t.effect == Effect::TimeDelay {
        state.delay_s = t.delay_s;
        // An effect's columns are now its delayed ones (taken out later, it leaves with
        // them; a column the fit left at zero is gone).
        for g in state.groups.iter_mut() {
            if let Some((_, rebuilt)) = t.regroup.iter().find(|r| r.0 == g.0) {
                g.1.clone_from(rebuilt);
                continue;
            }
            g.1 =
                g.1.iter()
                    .filter_map(|&c| {
                        if t.remove.contains(&c) {
                            t.add
                                .iter()
                                .copied()
                                .find(|&a| work.pool.delayed_source(a) == Some(c))
                        } else {
                            Some(c)
                        }
                    })
                    .collect();
        }
    }
    state.groups.push((t.effect, t.add));
    state.tests = work.tests(&sc.columns, &sc.beta);
    state.scored = sc;
}

impl Selection<'_> {
    /// An effect accepted early may have been standing in for a later one: keep only those the
    /// final model still needs by the same test.
    pub(super) fn prune(&self, work: &mut Work, state: &mut State, candidates: &mut [Candidate]) {
        if state.groups.len() <= 1 {
            return;
        }
        let (floors, settings) = (self.floors, self.settings);
        let mut i = 0;
        while i < state.groups.len() && state.groups.len() > 1 {
            // A delay replaced the baseline's columns: it is not taken out again. The effects
            // after a drift were judged with it as each block's nuisance: they presuppose it.
            if state.groups[i].0 == Effect::TimeDelay
                || (state.groups[i].0 == Effect::BaselineDrift
                    && (i + 1 < state.groups.len() || state.drift_by_block))
            {
                i += 1;
                continue;
            }
            let without: Vec<usize> = state
                .cols
                .iter()
                .copied()
                .filter(|c| !state.groups[i].1.contains(c))
                .collect();
            // Under the same judge as when it was added: each block less its own line only
            // after a drift (before it, a block's line would take a slow mode's response), or
            // wherever the drift was accepted by block (the model is judged so throughout).
            let local = state.drift_by_block
                || state.groups[..i]
                    .iter()
                    .any(|g| g.0 == Effect::BaselineDrift);
            if work.pool.set_local_nuisance(local) {
                state.scored = work.pool.score(&state.cols);
            }
            let sc = work.pool.score(&without);
            let energy_without = Floors::energy_of(work, &sc);
            let d = fold_gains(
                &sc.fold_mse,
                &floors.noise_matched(work, &state.scored, energy_without),
            );
            let gain = sc.cv_mse - state.scored.cv_mse;
            let floor = floors.floor_at(Floors::energy_of(work, &state.scored).max(energy_without));
            let excess = (sc.cv_mse - floor).max(0.0);
            let needed = stats::paired_p_value(&d) < settings.alpha
                && gain >= settings.min_excess_share * excess
                && gain >= settings.min_floor_share * floor;
            if needed {
                i += 1;
            } else {
                let effect = state.groups[i].0;
                if let Some(c) = candidates
                    .iter_mut()
                    .find(|c| c.accepted && c.effect == effect)
                {
                    c.accepted = false;
                    c.variant
                        .push_str(" (dropped: the later effects explain it)");
                }
                state.groups.remove(i);
                state.cols = without;
                state.tests = work.tests(&sc.columns, &sc.beta);
                state.scored = sc;
            }
        }
    }
}

/// The chip undoes a loop with plays (`tactile_core::hysteresis`): where the loop was named
/// by Duhem operators, the chip's model has the plays in their place (delayed as the rest),
/// the set that holds out better. None: the chip runs the model as it is.
pub(super) fn chip_model(work: &mut Work, state: &State, plays: &[Vec<usize>]) -> Option<Scored> {
    state
        .cols
        .iter()
        .any(|c| matches!(work.terms[*c], Term::Duhem { .. }))
        .then(|| {
            let kept: Vec<usize> = state
                .cols
                .iter()
                .copied()
                .filter(|c| !matches!(work.terms[*c], Term::Duhem { .. }))
                .collect();
            plays
                .iter()
                .filter(|p| !p.is_empty())
                .map(|p| {
                    let cols: Vec<usize> = if state.delay_s > 0.0 {
                        p.iter()
                            .map(|&c| work.add_delayed(c, state.delay_s))
                            .collect()
                    } else {
                        p.clone()
                    };
                    let all: Vec<usize> = kept.iter().chain(&cols).copied().collect();
                    work.pool.score(&all)
                })
                .min_by(|a, b| a.cv_mse.total_cmp(&b.cv_mse))
        })
        .flatten()
}

/// The paired test over folds: Student's t, which has power on four folds, or the signed-rank
/// test, which one fold's outsized gain does not defeat.
fn paired(d: &[f64]) -> f64 {
    stats::paired_p_value(d).min(stats::signed_rank_p_value(d))
}

/// Per-fold gains as log ratios of held-out mean square errors: folds differ in level (a
/// stretch of steps holds out worse than a rest), and the test should weigh each fold's
/// relative gain alike. A gain under [`RESOLVED_GAIN`] is none.
fn fold_gains(before: &[f64], after: &[f64]) -> Vec<f64> {
    before
        .iter()
        .zip(after)
        .map(|(a, b)| (a.max(f64::MIN_POSITIVE) / b.max(f64::MIN_POSITIVE)).ln())
        .map(|g| if g.abs() < RESOLVED_GAIN { 0.0 } else { g })
        .collect()
}

/// The least fold gain (log ratio) the held-out errors resolve. A fold's error is a difference
/// of sums over the record of products taken in f32 (relative rounding ~1e-7 each), and a good
/// fit leaves 1e-4 of the strain's power: a column the fit leaves at zero moves it by rounding
/// alone, and the order of those sums must not count as folds gained.
const RESOLVED_GAIN: f64 = 1e-6;
