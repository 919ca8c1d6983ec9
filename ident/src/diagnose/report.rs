//! The report: the errors before and after, the verdict, each accepted effect's size in
//! physical units, the model for the chip, and the summary's text.

use std::fmt::Write as _;

use crate::residual::ResidualTests;
use crate::series::{Folds, Intake};
use crate::solve::Scored;
use crate::{stats, terms};

use super::floors::far_from_white;
use super::work::Work;
use super::{
    stiffening_load, Baseline, Before, Candidate, Diagnosis, Effect, Errors, Fold, Model, Size,
    State, Term, SWING_BLOCK_S,
};

/// Held-out RMS error, in noise floors, above which what the named effects leave (far from
/// white) is reported: a delay or a line named right leaves 1.6–3.1 floors of coloured noise
/// (3.1 a two-sample delay at 20 Hz), a Duhem loop through the plays 13–23, a stiffening law
/// the load basis does not span 4.7 (`try synth 24 20 120 delay=2`, `try synth 21 200 180
/// hysteresis=0.08`, `try synth 21 100 240 stiffening=0.8`).
const LEFT_OVER_FLOORS: f64 = 4.0;

/// A description and named values of an effect's size.
type Described = (String, Vec<(String, f64)>);

fn errors(sc: &Scored, secant: f64) -> Errors {
    Errors {
        fit_rms_g: sc.fit_mse.sqrt() * secant,
        held_out_rms_g: sc.cv_mse.sqrt() * secant,
        fit_rms_pct: sc.fit_mse.sqrt(),
        held_out_rms_pct: sc.cv_mse.sqrt(),
        fold_rms_pct: sc.fold_mse.iter().map(|v| v.sqrt()).collect(),
    }
}

/// The terms of `sc`'s columns with the coefficients `beta`.
fn terms_with(work: &Work, sc: &Scored, beta: &[f64]) -> Vec<(Term, f64)> {
    sc.columns
        .iter()
        .zip(beta)
        .map(|(c, b)| (work.terms[*c], *b))
        .collect()
}

/// The terms of `sc` as fitted on the whole record.
fn terms_of(work: &Work, sc: &Scored) -> Vec<(Term, f64)> {
    terms_with(work, sc, &sc.beta)
}

/// The terms of `sc` as fitted on each fold's complement.
pub(super) fn fold_terms_of(work: &Work, sc: &Scored) -> Vec<Vec<(Term, f64)>> {
    sc.fold_beta
        .iter()
        .map(|b| terms_with(work, sc, b))
        .collect()
}

/// The diagnosis of the model as selected: its errors against the baseline's, the verdict,
/// the sizes, the models for the chip and the summary.
#[allow(clippy::too_many_arguments)]
pub(super) fn finish(
    work: &Work,
    state: State,
    chip: Option<Scored>,
    before: Before,
    candidates: Vec<Candidate>,
    (folds, first_folds): (Folds, Option<usize>),
    secant: f64,
    floor: f64,
    orientation: f64,
) -> Diagnosis {
    let s = work.s;
    let model_terms = terms_of(work, &state.scored);
    let baseline_terms = terms_of(work, &before.scored);
    let effects: Vec<Effect> = state.groups.iter().map(|g| g.0).collect();
    let floor_pct = floor.sqrt();
    let (effect, unexplained) = verdict(&state, &before.tests, &effects, floor);
    let sizes = sizes(work, &state, &model_terms, secant);
    let baseline = baseline(&baseline_terms, orientation, s.duration_s());
    let predict = |sc: &Scored| -> Vec<f64> {
        work.pool
            .predict(&sc.columns, &sc.beta)
            .into_iter()
            .map(|v| orientation * v)
            .collect()
    };
    let fold_list: Vec<Fold> = folds
        .ranges
        .iter()
        .zip(&folds.counts)
        .map(|(&(a, b), &n)| Fold {
            start_s: a as f64 * s.dt_s,
            end_s: b as f64 * s.dt_s,
            samples: n,
        })
        .collect();
    let chip = chip.as_ref().unwrap_or(&state.scored);
    let model = Model {
        orientation,
        force_scale_g: work.force_scale,
        force_origin_g: work.force_origin,
        delay_s: state.delay_s,
        terms: model_terms,
        baseline_terms,
        fold_terms: fold_terms_of(work, &state.scored),
        chip_terms: terms_of(work, chip),
        chip_fold_terms: fold_terms_of(work, chip),
        baseline_fold_terms: fold_terms_of(work, &before.scored),
        baseline_prediction: predict(&before.scored),
        prediction: predict(&state.scored),
        folds: folds.ranges.clone(),
    };
    let mut diagnosis = Diagnosis {
        intake: s.intake.clone(),
        effect,
        effects,
        before: errors(&before.scored, secant),
        after: errors(&state.scored, secant),
        after_per_block_line: state.drift_by_block,
        first_order: before
            .first_order
            .as_ref()
            .map(|sc| errors(sc, secant))
            .unwrap_or_default(),
        first_order_tau_s: before
            .first_order
            .as_ref()
            .and_then(|sc| {
                sc.columns.iter().find_map(|c| match work.terms[*c] {
                    Term::Relaxation(tau) => Some(tau),
                    _ => None,
                })
            })
            .unwrap_or(0.0),
        candidates,
        folds: fold_list,
        first_folds,
        secant_g_per_pct: secant,
        noise_floor_pct: floor_pct,
        noise_floor_g: floor_pct * secant,
        sizes,
        baseline,
        residual_before: before.tests,
        residual_after: state.tests,
        unexplained,
        summary: String::new(),
        model,
    };
    diagnosis.summary = summary(&diagnosis, work, before.first_order.as_ref());
    diagnosis
}

/// The verdict and what is left unexplained: the first effect found (and what the named
/// `effects` leave, when that is far from white and well above the `floor`), or
/// `unexplained` (the baseline's residual far from white, with `before_tests`), or `none`.
fn verdict(
    state: &State,
    before_tests: &ResidualTests,
    effects: &[Effect],
    floor: f64,
) -> (String, Option<String>) {
    if let Some(first) = effects.first() {
        // Said only when well above the floor: the right model's residual is the force
        // noise it passes, coloured, at one to three floors.
        let after_far = far_from_white(&state.tests, state.scored.cv_mse, floor)
            && state.scored.cv_mse > LEFT_OVER_FLOORS * LEFT_OVER_FLOORS * floor;
        (
            first.name().to_string(),
            after_far.then(|| {
                format!(
                    "after {}, the residual is still far from white: {}",
                    names(effects).join(" and "),
                    state.tests.describe()
                )
            }),
        )
    } else if far_from_white(before_tests, state.scored.cv_mse, floor) {
        ("unexplained".to_string(), Some(before_tests.describe()))
    } else {
        ("none".to_string(), None)
    }
}

/// The baseline's `terms` in physical terms, in the record's sign (`orientation`), for a
/// record of `duration_s`.
fn baseline(terms: &[(Term, f64)], orientation: f64, duration_s: f64) -> Baseline {
    Baseline {
        offset_pct: orientation * coef(terms, |t| t == Term::Offset),
        elastic_pct_per_g: orientation * coef(terms, |t| t == Term::Elastic),
        branches: terms
            .iter()
            .filter_map(|(t, b)| match t {
                Term::Relaxation(tau) if *b > 0.0 => Some((*tau, orientation * b)),
                _ => None,
            })
            .collect(),
        creep_pct_per_g_s: orientation * coef(terms, |t| t == Term::Creep) / duration_s,
        alpha_branch: terms.iter().find_map(|(t, b)| match t {
            Term::Alpha(tau) => Some((*tau, orientation * b)),
            _ => None,
        }),
    }
}

/// The summary's text of the diagnosis `d` (its summary not yet written): the baseline and
/// the folds, the record's secant and floor, the baseline's errors and residual, each round's
/// candidates, the sizes, the verdict.
fn summary(d: &Diagnosis, work: &Work, first_order: Option<&Scored>) -> String {
    let s = work.s;
    let folds = d.folds.len();
    let mut summary = String::new();
    let _ = writeln!(
        summary,
        "baseline: generalized Maxwell–Kelvin (elastic, Kelvin branches {}–{} s, {}); {} contiguous folds of {:.1} s held out in turn",
        seconds(work.terms.iter().find_map(|t| match t { Term::Relaxation(x) => Some(*x), _ => None }).unwrap_or(0.0)),
        seconds(work.terms.iter().filter_map(|t| match t { Term::Relaxation(x) => Some(*x), _ => None }).fold(0.0, f64::max)),
        match work.terms.iter().find_map(|t| match t { Term::Alpha(x) => Some(*x), _ => None }) {
            Some(tau) => format!("creep levelling off as eq. 14's α branch, N₁/α = {}", seconds(tau)),
            None => "permanent creep".to_string(),
        },
        folds,
        s.duration_s() / folds as f64
    );
    if let Some(k) = d.first_folds {
        let _ = writeln!(
            summary,
            "  judged again on blocks of at most {SWING_BLOCK_S:.0} s: on {k} folds of {:.1} s no effect passed, and a zero that swings every minute or more turns inside a longer block",
            s.duration_s() / k.max(1) as f64
        );
    }
    intake(&mut summary, &d.intake, &s.excluded);
    let _ = writeln!(
        summary,
        "  grams through the record's secant {:.3} g/%; noise floor {:.4} % ({:.3} g)",
        d.secant_g_per_pct, d.noise_floor_pct, d.noise_floor_g
    );
    let (before, t) = (&d.before, &d.residual_before);
    let _ = writeln!(
        summary,
        "  held out {:.4} % ({:.3} g), fitted {:.4} %; residual Ljung–Box {:.1}× its 5 % level, {:.0} % of 50 lags outside ±{:.4}",
        before.held_out_rms_pct,
        before.held_out_rms_g,
        before.fit_rms_pct,
        t.ljung_box_ratio,
        100.0 * t.acf_outside,
        t.acf_bound
    );
    if let Some(fo) = first_order {
        let _ = writeln!(
            summary,
            "  a first-order linear model (spring and one Kelvin branch) holds out {:.4} % ({:.3} g) on the same folds",
            fo.cv_mse.sqrt(),
            fo.cv_mse.sqrt() * d.secant_g_per_pct
        );
    }
    let _ = writeln!(summary, "  residual: {}", t.describe());
    for c in &d.candidates {
        let _ = writeln!(
            summary,
            "  round {} {:<25} held out {:.4} % ({:.3} g)  p {:.1e}  {}/{} folds better  {:>4.0} % of the excess  Q ratio {:>7.1}  {}  [{}]",
            c.round,
            c.effect,
            c.held_out_rms_pct,
            c.held_out_rms_g,
            c.p_value,
            c.folds_better,
            folds,
            100.0 * c.excess_removed,
            c.ljung_box_ratio,
            if c.accepted { "ACCEPTED" } else { "" },
            c.variant
        );
    }
    for z in &d.sizes {
        let _ = writeln!(summary, "  {}: {}", z.effect, z.description);
    }
    let _ = writeln!(
        summary,
        "verdict: {}\n  held out {:.4} % → {:.4} % strain ({:.3} g → {:.3} g){}",
        verdict_text(d),
        d.before.held_out_rms_pct,
        d.after.held_out_rms_pct,
        d.before.held_out_rms_g,
        d.after.held_out_rms_g,
        if d.after_per_block_line {
            ", after: each held-out block less its own offset and slope"
        } else {
            ""
        }
    );
    summary
}

/// How the record was taken in: its time stamps mended, its samples at the rail, its held
/// values, and any other samples its caller left out (`excluded`).
fn intake(summary: &mut String, intake: &Intake, excluded: &[bool]) {
    let share = |n: usize| 100.0 * n as f64 / excluded.len().max(1) as f64;
    if let Some(r) = &intake.resampling {
        if let Some(step) = r.resampled_step_s {
            let _ = writeln!(
                summary,
                "  the time stamps jitter by {:.0} % of the step: every column resampled onto an even {step:.6} s by linear interpolation",
                100.0 * r.jitter_share
            );
        }
        if r.merged_duplicates > 0 {
            let _ = writeln!(
                summary,
                "  {} rows stamped with the time of the row before: averaged into it",
                r.merged_duplicates
            );
        }
    }
    let railed = intake.rail_samples;
    if railed > 0 {
        let _ = writeln!(
            summary,
            "  the strain sits at its converter's rail for {railed} samples ({:.1} % of the record): left out of every fit and score",
            share(railed)
        );
    }
    let held = intake.held_samples;
    if held > 0 {
        let _ = writeln!(
            summary,
            "  the logger repeated a value instead of reading for {held} samples in {} runs ({:.1} % of the record): left out of every fit and score",
            intake.held_runs,
            share(held)
        );
    }
    let other = excluded
        .iter()
        .filter(|x| **x)
        .count()
        .saturating_sub(railed + held);
    if other > 0 {
        let _ = writeln!(
            summary,
            "  {other} samples ({:.1} % of the record) left out of every fit and score",
            share(other)
        );
    }
}

/// The verdict in words.
fn verdict_text(d: &Diagnosis) -> String {
    match d.effect.as_str() {
        "none" => "none: the baseline's residual is near white (or at the noise floor) and no effect lowers the held-out error consistently".to_string(),
        "unexplained" => format!(
            "unexplained: the residual is far from white and no named effect explains it consistently; {}",
            d.unexplained.clone().unwrap_or_default()
        ),
        _ => match &d.unexplained {
            // What the named effects leave is said, not hidden behind the names.
            Some(left) => format!(
                "found {}; {left} ({:.1}× the noise floor)",
                names(&d.effects).join(", then "),
                d.after.held_out_rms_pct / d.noise_floor_pct
            ),
            None => format!("found {}", names(&d.effects).join(", then ")),
        },
    }
}

/// A time constant to two significant figures ("0.012", "0.5", "1.5", "10"): a short record's
/// branches are fractions of a second, and a fixed precision printed "0.01–0 s".
pub(super) fn seconds(x: f64) -> String {
    if !(x.is_finite() && x > 0.0) {
        return format!("{x}");
    }
    let scale = 10f64.powf(x.log10().floor() - 1.0);
    let rounded = (x / scale).round() * scale;
    let digits = (1 - rounded.log10().floor() as i32).clamp(0, 4) as usize;
    format!("{rounded:.digits$}")
}

fn coef(terms: &[(Term, f64)], which: impl Fn(Term) -> bool) -> f64 {
    terms
        .iter()
        .filter(|(t, _)| which(*t))
        .map(|(_, b)| *b)
        .sum()
}

/// Peak-to-peak over the record of Σ b·basis(term) over the terms `basis` knows.
fn swing(terms: &[(Term, f64)], n: usize, basis: impl Fn(Term) -> Option<Vec<f64>>) -> f64 {
    let mut sum = vec![0.0; n];
    for (t, b) in terms {
        if let Some(v) = basis(*t) {
            for (o, c) in sum.iter_mut().zip(v) {
                *o += b * c;
            }
        }
    }
    sum.iter().fold(f64::MIN, |a, v| a.max(*v)) - sum.iter().fold(f64::MAX, |a, v| a.min(*v))
}

/// Each accepted effect's size in physical units, from the model's `terms`.
fn sizes(work: &Work, state: &State, terms: &[(Term, f64)], secant: f64) -> Vec<Size> {
    let s = work.s;
    let n = s.len();
    let mut out = Vec::new();
    for (effect, _) in &state.groups {
        let (description, values) = match effect {
            Effect::SlowRelaxation => slow_relaxation_size(terms),
            Effect::LoadDependentStiffness => stiffness_size(work, terms),
            Effect::Hysteresis => hysteresis_size(terms, secant),
            Effect::BaselineDrift => drift_size(terms, n, secant),
            Effect::PeriodicInterference => interference_size(terms, secant),
            Effect::TimeDelay => delay_size(state.delay_s, s.dt_s),
            Effect::SensitivityDrift => sensitivity_size(terms, n),
        };
        out.push(Size {
            effect: *effect,
            description,
            values,
        });
    }
    out
}

/// The slow branches' compliance and their time constant (the compliance-weighted geometric
/// mean).
fn slow_relaxation_size(terms: &[(Term, f64)]) -> Described {
    let parts: Vec<(f64, f64)> = terms
        .iter()
        .filter_map(|(t, b)| match t {
            Term::SlowRelaxation(tau) if *b > 0.0 => Some((*tau, *b)),
            _ => None,
        })
        .collect();
    let j: f64 = parts.iter().map(|p| p.1).sum();
    let tau = if j > 0.0 {
        (parts.iter().map(|p| p.1 * p.0.ln()).sum::<f64>() / j).exp()
    } else {
        0.0
    };
    let static_j: f64 = terms
        .iter()
        .filter(|(t, _)| {
            matches!(
                t,
                Term::Elastic | Term::Relaxation(_) | Term::SlowRelaxation(_)
            )
        })
        .map(|(_, b)| b.max(0.0))
        .sum();
    (
        format!(
            "a Kelvin branch of τ ≈ {tau:.0} s and compliance {j:.4} %/g ({:.0} % of the static compliance)",
            100.0 * j / static_j.max(f64::MIN_POSITIVE)
        ),
        vec![("tau_s".into(), tau), ("compliance_pct_per_g".into(), j)],
    )
}

/// The static secant stiffness at the force's 10th and 90th percentiles.
fn stiffness_size(work: &Work, terms: &[(Term, f64)]) -> Described {
    let fk = &work.force_kept;
    let (lo, hi) = (stats::quantile(fk, 0.1), stats::quantile(fk, 0.9));
    let strain_at = |f: f64| -> f64 {
        terms
            .iter()
            .map(|(t, b)| match t {
                Term::Elastic | Term::Relaxation(_) | Term::SlowRelaxation(_) => b * f,
                Term::Stiffening { power, .. } => {
                    b * stiffening_load(f, work.force_origin, work.force_scale, *power)
                }
                _ => 0.0,
            })
            .sum()
    };
    let k = |f: f64| f / strain_at(f).abs().max(f64::MIN_POSITIVE);
    let (klo, khi) = (k(lo.max(1e-9)), k(hi));
    (
        format!(
            "static secant stiffness {klo:.3} g/% at {lo:.1} g → {khi:.3} g/% at {hi:.1} g ({:+.0} %)",
            100.0 * (khi / klo - 1.0)
        ),
        vec![
            ("low_load_g".into(), lo),
            ("high_load_g".into(), hi),
            ("stiffness_change_pct".into(), 100.0 * (khi / klo - 1.0)),
        ],
    )
}

/// The gap between the loop's loading and unloading branches.
fn hysteresis_size(terms: &[(Term, f64)], secant: f64) -> Described {
    let gap: f64 = terms
        .iter()
        .filter_map(|(t, b)| match t {
            // Either saturates at its radius from the force, branches 2r apart:
            // a play trails the force (σ − r rising), a Duhem operator leads its
            // zero (+r rising, at the end of a long enough travel).
            Term::Play { radius_g, .. } => Some(2.0 * radius_g * b),
            Term::Duhem { radius_g } => Some(-2.0 * radius_g * b),
            _ => None,
        })
        .sum();
    (
        format!(
            "loading and unloading branches {:.4} % strain apart at equal load: a loop {:.2} g wide",
            gap,
            gap * secant
        ),
        vec![("play_width_g".into(), gap * secant), ("gap_pct".into(), gap)],
    )
}

/// How far the strain's zero wanders over a record of `n` samples.
fn drift_size(terms: &[(Term, f64)], n: usize, secant: f64) -> Described {
    let range = swing(terms, n, |t| match t {
        Term::Drift(k) => Some(terms::cosine(n, k)),
        _ => None,
    });
    (
        format!(
            "the strain's zero wanders {range:.4} % over the record ({:.2} g)",
            range * secant
        ),
        vec![
            ("drift_pct".into(), range),
            ("drift_g".into(), range * secant),
        ],
    )
}

/// Each line's frequency and amplitude (the first line's in the values).
fn interference_size(terms: &[(Term, f64)], secant: f64) -> Described {
    let mut lines: Vec<(f64, f64)> = Vec::new();
    for (t, b) in terms {
        if let Term::Line(hz, _) = t {
            match lines.iter_mut().find(|l| l.0 == *hz) {
                Some(l) => l.1 = l.1.hypot(*b),
                None => lines.push((*hz, b.abs())),
            }
        }
    }
    let text: Vec<String> = lines
        .iter()
        .map(|(hz, a)| format!("{hz:.3} Hz, amplitude {a:.4} % ({:.3} g)", a * secant))
        .collect();
    let mut values = Vec::new();
    if let Some((hz, a)) = lines.first() {
        values.push(("hz".into(), *hz));
        values.push(("amplitude_pct".into(), *a));
        values.push(("amplitude_g".into(), a * secant));
    }
    (format!("lines at {}", text.join("; ")), values)
}

/// The delay `d` s, in ms and in samples of `dt_s`.
fn delay_size(d: f64, dt_s: f64) -> Described {
    (
        format!(
            "the strain lags the force by {:.1} ms ({:.2} samples)",
            1e3 * d,
            d / dt_s
        ),
        vec![("delay_ms".into(), 1e3 * d)],
    )
}

/// How much the gain changes over a record of `n` samples.
fn sensitivity_size(terms: &[(Term, f64)], n: usize) -> Described {
    let range = swing(terms, n, |t| match t {
        Term::Gain(k) => Some(terms::legendre(n, k)),
        Term::GainCosine(k) => Some(terms::cosine(n, k)),
        _ => None,
    });
    (
        format!(
            "the sensitivity changes by {:.1} % over the record",
            100.0 * range
        ),
        vec![("gain_change_pct".into(), 100.0 * range)],
    )
}

/// The effects' names, in order.
fn names(effects: &[Effect]) -> Vec<&'static str> {
    effects.iter().map(|e| e.name()).collect()
}

#[cfg(test)]
mod tests {
    use super::seconds;

    #[test]
    fn a_time_constant_is_printed_to_two_figures() {
        let shown: Vec<String> = [0.01, 0.0123, 0.35, 1.5, 9.9999, 10.0, 42.0]
            .into_iter()
            .map(seconds)
            .collect();
        assert_eq!(shown, ["0.010", "0.012", "0.35", "1.5", "10", "10", "42"]);
    }
}
