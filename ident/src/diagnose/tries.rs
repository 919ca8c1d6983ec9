//! The candidates: the columns that do not depend on the model (slow branches, plays, Duhem
//! operators, half-cosines), and a round's tries against the model as it stands, one function
//! an effect.

use std::borrow::Cow;
use std::sync::Arc;

use crate::solve::{Scored, Sign};
use crate::{stats, terms};

use super::report::seconds;
use super::work::{grid, relaxation_columns, Creep, Work};
use super::{stiffening_load, Effect, Settings, State, Term, Try, MIN_CYCLES_SETTLED, PLAY_SHARES};

/// Candidate columns that do not depend on the current model: one pass over the force each,
/// computed where they are read rather than stored.
pub(super) struct CandidateColumns {
    /// Kelvin branches slower than the baseline's grid (none on a short record), to
    /// `slow_max_s`.
    pub(super) slow: Vec<usize>,
    pub(super) slow_max_s: f64,
    /// Eq. 14's branch again over its range, beside the slow modes: the baseline's N₁/α was
    /// fitted without them, and a slow mode pulls it down toward its own.
    pub(super) alphas: Vec<usize>,
    /// Plays of each radius started in the middle of their loop, and settled.
    pub(super) plays: [Vec<usize>; 2],
    pub(super) duhems: Vec<usize>,
    /// Half-cosines 1 to `drift_max`.
    pub(super) drift: Vec<usize>,
    pub(super) drift_max: usize,
    /// The grid's Kelvin branches the baseline's support left out, for the delay: the first
    /// fit, undelayed, bent its branches to stand in for the lag.
    pub(super) unsupported: Vec<usize>,
}

impl CandidateColumns {
    /// Adds the candidate columns to `work`; `force_range` is the force's, g, and
    /// `force_noise` the variance of its noise; `creep` the baseline's; `unsupported` the
    /// grid's time constants outside the baseline's support.
    pub(super) fn new(
        work: &mut Work,
        settings: &Settings,
        (force_range, force_noise): (f64, f64),
        creep: Creep,
        unsupported: &[f64],
    ) -> CandidateColumns {
        let s = work.s;
        let (dt, t_s) = (s.dt_s, s.duration_s());
        let force: Arc<[f64]> = s.force_g.as_slice().into();
        // To half the record, and below the baseline's eq. 14 branch: what that branch is, a
        // slower mode would only take again.
        let slowest = match creep {
            Creep::Permanent => t_s / 2.0,
            Creep::Alpha(tau) => (t_s / 2.0).min(tau / 2.0),
        };
        // Stored: each delay tried reads them through a view.
        let unsupported = relaxation_columns(work, &force, unsupported);
        // Kelvin branches of the time constants `taus`, each a `term`.
        let mut branches = |taus: Vec<f64>, term: fn(f64) -> Term| -> Vec<usize> {
            taus.into_iter()
                .map(|tau| {
                    let f = Arc::clone(&force);
                    let recipe = move || terms::lowpass(&f, tau, dt);
                    work.add_computed(term(tau), recipe, Sign::NonNegative)
                })
                .collect()
        };
        let slow = if slowest > 1.5 * settings.base_tau_max_s {
            let taus = grid(settings.base_tau_max_s * 1.5, slowest, settings.per_decade);
            branches(taus, Term::SlowRelaxation)
        } else {
            Vec::new()
        };
        let alphas = match creep {
            Creep::Alpha(_) if !slow.is_empty() => {
                let (lo, hi) = settings.alpha_tau_s;
                branches(grid(lo, hi, settings.per_decade / 2.0), Term::Alpha)
            }
            _ => Vec::new(),
        };
        // Both starting states: which one the record began in is unknown, and the wrong one is a
        // step at the first loading that only the first fold sees (held out, it extrapolates).
        // Settled only on a record that cycles: on one or two loadings, plays started anywhere are
        // shapes in time free to stand in for a slow mode.
        let cycles = loading_cycles(&work.force_kept);
        let plays: [Vec<usize>; 2] = [false, true].map(|settled| {
            if settled && cycles < MIN_CYCLES_SETTLED {
                return Vec::new();
            }
            PLAY_SHARES
                .iter()
                .filter_map(|share| {
                    let r = share * force_range;
                    let v = terms::play(&s.force_g, r, settled);
                    // A play that never turns is a constant: the offset's, at any weight.
                    let swing = v.iter().fold(f64::NEG_INFINITY, |a, b| a.max(*b))
                        - v.iter().fold(f64::INFINITY, |a, b| a.min(*b));
                    let term = Term::Play {
                        radius_g: r,
                        settled,
                    };
                    let f = Arc::clone(&force);
                    let recipe = move || terms::play(&f, r, settled);
                    (swing > 0.01 * r).then(|| work.add_computed(term, recipe, Sign::Free))
                })
                .collect()
        });
        // The force's travel counts in a Duhem operator, and the noise left in the smoothed force
        // travels: seen through a play of twice its deviation, a hold is still.
        let deadband = 2.0 * force_noise.max(0.0).sqrt();
        let duhems: Vec<usize> = PLAY_SHARES
            .iter()
            .map(|share| {
                let r = share * force_range;
                let f = Arc::clone(&force);
                let recipe = move || terms::duhem(&terms::play(&f, deadband, false), r);
                work.add_computed(Term::Duhem { radius_g: r }, recipe, Sign::Free)
            })
            .collect();
        let drift_max = ((t_s / 15.0) as usize).clamp(1, DRIFT_COSINES[DRIFT_COSINES.len() - 1]);
        let drift: Vec<usize> = (1..=drift_max)
            .map(|k| {
                let term = Term::Drift(k);
                work.terms.push(term);
                work.pool.add_cosine(format!("{term:?}"), k, Sign::Free)
            })
            .collect();
        CandidateColumns {
            slow,
            slow_max_s: slowest,
            alphas,
            plays,
            duhems,
            drift,
            drift_max,
            unsupported,
        }
    }

    /// Frees the candidates' columns that neither the model nor the chip's model `chip` uses.
    pub(super) fn free(&self, work: &mut Work, state: &State, chip: Option<&Scored>) {
        for c in self
            .slow
            .iter()
            .chain(&self.alphas)
            .chain(self.plays.iter().flatten())
            .chain(&self.drift)
            .chain(&self.duhems)
            .chain(&self.unsupported)
            .filter(|c| chip.is_none_or(|sc| !sc.columns.contains(c)))
        {
            if !state.cols.contains(c) {
                work.pool.drop_column(*c);
            }
        }
    }
}

/// Loading cycles in `force`: swings from about its lower quartile to its upper one and back
/// (just inside the quartiles: a record at rest a quarter of the time reaches its lower one).
fn loading_cycles(force: &[f64]) -> usize {
    let (q1, q3) = (stats::quantile(force, 0.25), stats::quantile(force, 0.75));
    let (lo, hi) = (q1 + 0.1 * (q3 - q1), q3 - 0.1 * (q3 - q1));
    let mut high = false;
    let mut turns = 0;
    for &v in force {
        if (high && v < lo) || (!high && v > hi) {
            high = !high;
            turns += 1;
        }
    }
    turns / 2
}

/// A round's tries of the effects not yet in the model, and the columns built for them this
/// round (freed at its end unless accepted).
pub(super) fn tries(
    work: &mut Work,
    state: &State,
    columns: &CandidateColumns,
    settings: &Settings,
    round: usize,
) -> (Vec<Try>, Vec<usize>) {
    let mut tries: Vec<Try> = Vec::new();
    if !columns.slow.is_empty() && !state.taken(Effect::SlowRelaxation) {
        tries.push(slow_relaxation(columns, settings));
    }
    if !state.taken(Effect::Hysteresis) {
        tries.extend(hysteresis(columns));
    }
    if !state.taken(Effect::BaselineDrift) {
        tries.extend(drift(columns));
    }
    // Model-dependent columns, rebuilt each round from the current whole-record fit.
    let mut built: Vec<Try> = Vec::new();
    if !state.taken(Effect::LoadDependentStiffness) {
        built.push(stiffening(work, state));
    }
    if !state.taken(Effect::PeriodicInterference) {
        built.extend(interference(work, state));
    }
    if !state.taken(Effect::TimeDelay) {
        built.extend(delay(work, state, columns, settings));
    }
    if !state.taken(Effect::SensitivityDrift) {
        built.extend(sensitivity_drift(work, state, round));
    }
    let temporary = built.iter().flat_map(|t| t.add.iter().copied()).collect();
    tries.extend(built);
    (tries, temporary)
}

/// Kelvin branches slower than the baseline's grid.
fn slow_relaxation(columns: &CandidateColumns, settings: &Settings) -> Try {
    Try::adding(
        Effect::SlowRelaxation,
        format!(
            "Kelvin branches {}–{} s",
            seconds(1.5 * settings.base_tau_max_s),
            seconds(columns.slow_max_s)
        ),
        columns
            .slow
            .iter()
            .chain(&columns.alphas)
            .copied()
            .collect(),
    )
}

/// Plays started in the middle and settled, and Duhem operators.
fn hysteresis(columns: &CandidateColumns) -> Vec<Try> {
    let radii = PLAY_SHARES.map(|p| format!("{:.0}", 100.0 * p)).join(", ");
    let mut tries = Vec::new();
    for (cols, start) in columns
        .plays
        .iter()
        .zip(["in the middle", "settled"])
        .filter(|(c, _)| !c.is_empty())
    {
        tries.push(Try::adding(
            Effect::Hysteresis,
            format!("plays of {radii} % of the force range, started {start}"),
            cols.clone(),
        ));
    }
    tries.push(Try::adding(
        Effect::Hysteresis,
        format!("Duhem operators of {radii} % of the force range"),
        columns.duhems.clone(),
    ));
    tries
}

/// Numbers of half-cosines a drift is tried with.
pub(super) const DRIFT_COSINES: [usize; 5] = [1, 2, 4, 8, 16];

/// Half-cosines, 1 to 16 of them.
fn drift(columns: &CandidateColumns) -> Vec<Try> {
    DRIFT_COSINES
        .into_iter()
        .filter(|k| *k <= columns.drift_max)
        .map(|k| {
            Try::adding(
                Effect::BaselineDrift,
                format!("{k} half-cosines"),
                columns.drift[..k].to_vec(),
            )
        })
        .collect()
}

/// Load basis through the instantaneous spring and the two heaviest branches.
fn stiffening(work: &mut Work, state: &State) -> Try {
    let taus = heaviest_branches(work, &state.cols, &state.scored.beta);
    Try::adding(
        Effect::LoadDependentStiffness,
        "load basis σ·|σ/σs|^½, σ·|σ/σs| through the spring and two branches".into(),
        stiffening_columns(work, &taus, 0.0),
    )
}

/// The time constants of the two heaviest Kelvin branches of a fit of `cols` to `beta`.
fn heaviest_branches(work: &Work, cols: &[usize], beta: &[f64]) -> Vec<f64> {
    let mut branches: Vec<(f64, f64)> = cols
        .iter()
        .zip(beta)
        .filter_map(|(c, b)| match work.terms[*c] {
            Term::Relaxation(tau) | Term::SlowRelaxation(tau) if *b > 0.0 => Some((tau, *b)),
            _ => None,
        })
        .collect();
    branches.sort_by(|a, b| b.1.total_cmp(&a.1));
    branches.into_iter().take(2).map(|b| b.0).collect()
}

/// The load basis of the force delayed by `delay_s`, through the spring and branches `taus`.
fn stiffening_columns(work: &mut Work, taus: &[f64], delay_s: f64) -> Vec<usize> {
    let s = work.s;
    let force: Cow<[f64]> = if delay_s > 0.0 {
        Cow::Owned(terms::delayed(&s.force_g, delay_s / s.dt_s))
    } else {
        Cow::Borrowed(&s.force_g)
    };
    let mut cols = Vec::new();
    for power in [0.5, 1.0] {
        let g: Vec<f64> = force
            .iter()
            .map(|f| stiffening_load(*f, work.force_origin, work.force_scale, power))
            .collect();
        cols.push(work.add(Term::Stiffening { power, tau_s: None }, &g, Sign::Free));
        for &tau in taus {
            let v = terms::lowpass(&g, tau, s.dt_s);
            cols.push(work.add(
                Term::Stiffening {
                    power,
                    tau_s: Some(tau),
                },
                &v,
                Sign::Free,
            ));
        }
    }
    cols
}

/// Lines the model's residual has and the measured force has not (none: no try).
fn interference(work: &mut Work, state: &State) -> Option<Try> {
    let s = work.s;
    let r = work.residual(&state.cols, &state.scored.beta);
    let lines = terms::lines(&r, &work.measured_force_kept, s.dt_s, 0.3, 20.0, 2);
    if lines.is_empty() {
        return None;
    }
    let mut cols = Vec::new();
    for l in &lines {
        let (sn, cs) = terms::sinusoid(s.len(), s.dt_s, l.hz);
        cols.push(work.add(Term::Line(l.hz, false), &sn, Sign::Free));
        cols.push(work.add(Term::Line(l.hz, true), &cs, Sign::Free));
    }
    let hz: Vec<String> = lines.iter().map(|l| format!("{:.3} Hz", l.hz)).collect();
    Some(Try::adding(
        Effect::PeriodicInterference,
        format!("lines at {}", hz.join(", ")),
        cols,
    ))
}

/// The force shifted later by d, through every force-driven term of the model (a play or a
/// stiffening of the delayed force is the term delayed: each is causal and time-invariant), up
/// to [`Settings::delay_max_s`] or a quarter of the shortest fold.
fn delay(
    work: &mut Work,
    state: &State,
    columns: &CandidateColumns,
    settings: &Settings,
) -> Option<Try> {
    let driven_now: Vec<usize> = state
        .cols
        .iter()
        .copied()
        .filter(|c| work.terms[*c].force_driven())
        .collect();
    let others: Vec<usize> = state
        .cols
        .iter()
        .copied()
        .filter(|c| !driven_now.contains(c))
        .collect();
    let dt = work.s.dt_s;
    let shortest = work
        .pool
        .folds()
        .ranges
        .iter()
        .map(|(a, b)| b - a)
        .min()
        .unwrap_or(0);
    let longest = settings
        .delay_max_s
        .min(shortest as f64 * dt / 4.0)
        .max(2.5 * dt);
    // The force-driven terms in use, delayed (views of their columns, no copies); then every
    // force-driven term and the grid's branches the support left out, and the set that holds
    // out better. A lag of tenths of a second bends the undelayed fit's branches: it leaves at
    // zero, or outside its support, the finger's fast modes the delayed model needs. But
    // branches faster than a short delay trade against it (a 14 ms delay named 12.3 ms).
    let active: Vec<usize> = driven_now
        .iter()
        .copied()
        .filter(|c| {
            state
                .cols
                .iter()
                .zip(&state.scored.beta)
                .any(|(k, b)| k == c && (*b != 0.0 || work.terms[*c] == Term::Elastic))
        })
        .collect();
    let mut views = Views::default();
    let Some(mut best) = best_delay(work, &others, longest, |work, d| views.of(work, &active, d))
    else {
        views.free_except(work, &[]);
        return None;
    };
    let all: Vec<usize> = driven_now
        .iter()
        .chain(&columns.unsupported)
        .copied()
        .collect();
    let mut variants = Vec::new();
    if all.len() > active.len() {
        variants.extend(best_delay(work, &others, longest, |work, d| {
            views.of(work, &all, d)
        }));
    }
    // After a stiffening, its basis rebuilt through the delayed fit's branches too.
    let base: Option<Vec<usize>> = state
        .groups
        .iter()
        .find(|g| g.0 == Effect::LoadDependentStiffness)
        .map(|(_, stiff)| all.iter().copied().filter(|c| !stiff.contains(c)).collect());
    if let Some(base) = &base {
        variants.extend(rebuilt_stiffening_delay(
            work, &others, base, longest, &mut views,
        ));
    }
    for other in variants {
        let (worse, better) = if other.1 < best.1 {
            (best, other)
        } else {
            (other, best)
        };
        free_built(work, &worse.2);
        best = better;
    }
    let (d, _, cols) = best;
    views.free_except(work, &cols);
    // The rebuilt basis, where that variant won: its own columns, not delayed views.
    let regroup = base
        .as_ref()
        .map(|_| {
            let rebuilt: Vec<usize> = cols
                .iter()
                .copied()
                .filter(|c| {
                    work.pool.delayed_source(*c).is_none()
                        && matches!(work.terms[*c], Term::Stiffening { .. })
                })
                .collect();
            (Effect::LoadDependentStiffness, rebuilt)
        })
        .filter(|(_, rebuilt)| !rebuilt.is_empty());
    let reference = regroup
        .as_ref()
        .zip(base.as_ref())
        .and_then(|((_, rebuilt), base)| undelayed_reference(work, state, &others, base, rebuilt));
    Some(Try {
        effect: Effect::TimeDelay,
        variant: format!("force delayed {:.1} ms", 1e3 * d),
        add: cols,
        remove: driven_now,
        delay_s: d,
        regroup: regroup.into_iter().collect(),
        reference,
    })
}

/// The delay beside `others` that holds out best with a stiffening's basis rebuilt through the
/// delayed fit's branches, `base` the other force-driven columns. The basis runs through the
/// heaviest branches of the fit it was built on, and an undelayed fit of a lagging strain puts
/// its weight on branches of about the lag (a 30 ms delay: 20–30 ms, no spring).
fn rebuilt_stiffening_delay(
    work: &mut Work,
    others: &[usize],
    base: &[usize],
    longest: f64,
    views: &mut Views,
) -> Option<(f64, f64, Vec<usize>)> {
    let rebuilt = |work: &mut Work, d: f64| -> Vec<usize> {
        let delayed = views.of(work, base, d);
        let fit: Vec<usize> = others.iter().chain(&delayed).copied().collect();
        let sc = work.pool.score(&fit);
        let taus = heaviest_branches(work, &sc.columns, &sc.beta);
        let basis = stiffening_columns(work, &taus, d);
        delayed.into_iter().chain(basis).collect()
    };
    best_delay(work, others, longest, rebuilt)
}

/// The model with the basis `rebuilt` (columns of a rebuilt stiffening) undelayed, where it
/// holds out better than the model as it stands: a basis rebuilt through other branches may fit
/// better at no delay at all, and the delay is judged against it.
fn undelayed_reference(
    work: &mut Work,
    state: &State,
    others: &[usize],
    base: &[usize],
    rebuilt: &[usize],
) -> Option<Scored> {
    // Each power runs through the same branches: one power's give them.
    let taus: Vec<f64> = rebuilt
        .iter()
        .filter_map(|c| match work.terms[*c] {
            Term::Stiffening {
                power: 0.5,
                tau_s: Some(tau),
            } => Some(tau),
            _ => None,
        })
        .collect();
    let basis = stiffening_columns(work, &taus, 0.0);
    let undelayed: Vec<usize> = others.iter().chain(base).chain(&basis).copied().collect();
    let sc = work.pool.score(&undelayed);
    basis.iter().for_each(|c| work.pool.drop_column(*c));
    (sc.cv_mse < state.scored.cv_mse).then_some(sc)
}

/// Delayed views made during one delay search, each of a column and a delay once: its variants
/// share their products (a view costs no memory, only its products).
#[derive(Default)]
struct Views(Vec<((usize, u64), usize)>);

impl Views {
    /// Each of `sources` delayed by `d` s.
    fn of(&mut self, work: &mut Work, sources: &[usize], d: f64) -> Vec<usize> {
        sources
            .iter()
            .map(|&c| match self.0.iter().find(|v| v.0 == (c, d.to_bits())) {
                Some(v) => v.1,
                None => {
                    let j = work.add_delayed(c, d);
                    self.0.push(((c, d.to_bits()), j));
                    j
                }
            })
            .collect()
    }

    /// Frees every view but `keep`'s.
    fn free_except(self, work: &mut Work, keep: &[usize]) {
        for (_, j) in self.0 {
            if !keep.contains(&j) {
                work.pool.drop_column(j);
            }
        }
    }
}

/// Frees the columns a delay's variant built, but the views ([`Views`] frees them).
fn free_built(work: &mut Work, cols: &[usize]) {
    for &c in cols {
        if work.pool.delayed_source(c).is_none() {
            work.pool.drop_column(c);
        }
    }
}

/// The delay beside `others` that holds out best, its held-out error and the columns `build`
/// made for it. Doubling delays from one sample to `longest` s, then the best refined between
/// its neighbours; only the best delay's columns are kept (a delayed column is a view of its
/// source: each variant costs a score, not a copy).
fn best_delay(
    work: &mut Work,
    others: &[usize],
    longest: f64,
    mut build: impl FnMut(&mut Work, f64) -> Vec<usize>,
) -> Option<(f64, f64, Vec<usize>)> {
    let dt = work.s.dt_s;
    let mut best: Option<(f64, f64, Vec<usize>)> = None;
    // The refinements meet delays already scored (at the search's ends): each is scored once.
    let mut scored: Vec<f64> = Vec::new();
    let mut consider = |work: &mut Work, d: f64, best: &mut Option<(f64, f64, Vec<usize>)>| {
        if scored.iter().any(|s| (s - d).abs() <= 1e-9 * dt) {
            return;
        }
        scored.push(d);
        let cols = build(work, d);
        let all: Vec<usize> = others.iter().chain(&cols).copied().collect();
        let mse = work.pool.score(&all).cv_mse;
        if best.as_ref().is_none_or(|b| mse < b.1) {
            if let Some((_, _, old)) = best.take() {
                free_built(work, &old);
            }
            *best = Some((d, mse, cols));
        } else {
            free_built(work, &cols);
        }
    };
    let mut d = dt;
    while d <= longest {
        consider(work, d, &mut best);
        d *= 2.0;
    }
    // Refined twice: by a sixth of an octave, then by a twenty-fourth and the nearest
    // whole sample (a 12 ms delay at 500 Hz named 11.3 ms left 8.5 floors; the third
    // finger's `delay_ms=12`).
    for factors in [[0.71, 0.84, 1.19, 1.41], [0.92, 0.96, 1.04, 1.09]] {
        let Some(centre) = best.as_ref().map(|b| b.0) else {
            break;
        };
        for factor in factors {
            consider(work, (centre * factor).clamp(dt, longest), &mut best);
        }
    }
    if let Some(centre) = best.as_ref().map(|b| b.0) {
        let whole = (centre / dt).round().max(1.0) * dt;
        if (whole - centre).abs() > 1e-9 * dt {
            consider(work, whole, &mut best);
        }
    }
    // A twenty-fourth of an octave is ten samples at 250: then whole samples, steps halved
    // from a fiftieth of the delay down to one.
    let mut step = 0.02 * best.as_ref().map_or(0.0, |b| b.0) / dt;
    while step >= 1.0 {
        let Some(centre) = best.as_ref().map(|b| b.0) else {
            break;
        };
        for sign in [-1.0, 1.0] {
            let d = ((centre / dt).round() + sign * step.round()) * dt;
            consider(work, d.clamp(dt, longest), &mut best);
        }
        step /= 2.0;
    }
    best
}

/// A gain's shape in time over the record: Legendre polynomials of degree 1 to `top`, or
/// half-cosines 1 to `k`.
#[derive(Clone, Copy)]
enum GainShape {
    Polynomial(usize),
    Cosines(usize),
}

/// Columns of the force-driven strain `part` × each function of `shape`, computed where they
/// are read (a 600 s record at 1 kHz: 2.4 MB a column, up to 17 of them).
fn gain_columns(work: &mut Work, part: &Arc<Vec<f64>>, shape: GainShape) -> Vec<usize> {
    let n = work.s.len();
    let mut add = |term: Term, basis: Basis| {
        let part = Arc::clone(part);
        work.add_computed_stored(term, move || basis.times(n, &part), Sign::Free)
    };
    match shape {
        GainShape::Polynomial(top) => (1..=top)
            .map(|k| add(Term::Gain(k), Basis::Legendre(k)))
            .collect(),
        // Half-cosines all start and end level; a line beside them lets the gain move at the
        // record's ends (a cycle caught mid-swing).
        GainShape::Cosines(top) => {
            let mut cols: Vec<usize> = (1..=top)
                .map(|k| add(Term::GainCosine(k), Basis::Cosine(k)))
                .collect();
            cols.push(add(Term::Gain(1), Basis::Legendre(1)));
            cols
        }
    }
}

/// A function of time a gain's column multiplies the force-driven strain by.
#[derive(Clone, Copy)]
enum Basis {
    Legendre(usize),
    Cosine(usize),
}

impl Basis {
    /// The basis over `n` samples × `part`, as the pool stores it, a block at a time: columns
    /// are built on every core at once, and a basis whole is 4.8 MB at 600 s and 1 kHz.
    fn times(self, n: usize, part: &[f64]) -> Vec<f32> {
        const BLOCK: usize = 4096; // whole eights: the rotation's lanes move by eight
        let part = &part[..n.min(part.len())];
        let mut out = Vec::with_capacity(part.len());
        match self {
            Basis::Legendre(k) => out.extend(
                part.iter()
                    .enumerate()
                    .map(|(i, p)| (terms::legendre_at(n, k, i) * p) as f32),
            ),
            Basis::Cosine(k) => {
                let mut rotation = terms::Rotation::new(n, k, 0);
                let mut block = Vec::with_capacity(BLOCK);
                for chunk in part.chunks(BLOCK) {
                    block.clear();
                    rotation.fill(&mut block, chunk.len());
                    out.extend(block.iter().zip(chunk).map(|(c, p)| (c * p) as f32));
                }
            }
        }
        out
    }
}

/// Shortest half-period of a gain's swing, s: a temperature moves a sensor's gain over
/// minutes, and a faster swing of the force-driven strain is another effect's misfit.
const GAIN_HALF_PERIOD_MIN_S: f64 = 120.0;

/// A gain that changes with time: the force-driven strain × a polynomial in time, or on a
/// record of several minutes × half-cosines (a temperature cycle).
fn sensitivity_drift(work: &mut Work, state: &State, round: usize) -> Option<Try> {
    let force_part = Arc::new(work.force_part(&state.cols, &state.scored.beta));
    // A gain × (the force-driven strain) is bilinear; the strain that multiplies the
    // gain is the one the model fitted with the gain: the baseline alone, fitted to a
    // record whose sensitivity changes, is bent by it. Two refinements. A cubic too: a
    // sag that settles (an exponential over a third of the record) bends more than a
    // parabola, and what a parabola leaves was taken by the drift. The cubic in the first
    // round only: after another effect, what that effect's basis leaves of a varied load
    // (a stiffening by each branch's own law) was taken by the cubic (seed 62).
    let mut shapes: Vec<(GainShape, String)> = vec![(
        GainShape::Polynomial(2),
        "a line and a parabola".to_string(),
    )];
    if round == 1 {
        shapes.push((
            GainShape::Polynomial(3),
            "Legendre polynomials to the cubic".into(),
        ));
        shapes.push((
            GainShape::Polynomial(4),
            "Legendre polynomials to the quartic".into(),
        ));
    }
    // On a record of several such half-periods, a line and half-cosines to half of them: a
    // swing between two of the basis's frequencies needs the next ones too.
    let most = (work.s.duration_s() / GAIN_HALF_PERIOD_MIN_S) as usize;
    if most >= 4 {
        let k = (2 * most).min(16);
        shapes.push((
            GainShape::Cosines(k),
            format!("a line and {k} half-cosines"),
        ));
    }
    // Only the best degree's columns are kept (a 1 kHz record's are 4.8 MB each).
    let mut kept: Option<(f64, String, Vec<usize>)> = None;
    for (top, shape) in shapes {
        let mut cols = gain_columns(work, &force_part, top);
        for _ in 0..2 {
            let all: Vec<usize> = state.cols.iter().chain(&cols).copied().collect();
            let sc = work.pool.score(&all);
            let part = Arc::new(work.force_part(&sc.columns, &sc.beta));
            for c in cols {
                work.pool.drop_column(c);
            }
            cols = gain_columns(work, &part, top);
        }
        let all: Vec<usize> = state.cols.iter().chain(&cols).copied().collect();
        let mse = work.pool.score(&all).cv_mse;
        if kept.as_ref().is_none_or(|k| mse < k.0) {
            if let Some((_, _, old)) = kept.replace((mse, shape, cols)) {
                old.into_iter().for_each(|c| work.pool.drop_column(c));
            }
        } else {
            cols.into_iter().for_each(|c| work.pool.drop_column(c));
        }
    }
    let (_, shape, cols) = kept?;
    Some(Try::adding(
        Effect::SensitivityDrift,
        format!("force-driven strain × {shape} in time"),
        cols,
    ))
}
