//! The chip's figures of the models the diagnosis hands over while its rounds run, worked out
//! on the core the rounds leave idle: each model's best form and held-out errors, and the
//! force bank of the table the chip would get if the rounds stopped at it.

use std::sync::mpsc::{Receiver, TryRecvError};

use tactile_ident::diagnose::{Fitted, FoldModels, Term};
use tactile_ident::force_fit::BankFit;
use tactile_ident::Series;

use super::{bank_fit, conditioning_of, form_of, Conditioning, Scored, OBSERVER};

/// What was worked out early; the caller looks up the final models in it.
#[derive(Default)]
pub(super) struct Early {
    /// Each model handed over, with its form and errors.
    scored: Vec<(FoldModels, Scored)>,
    /// The force bank fitted on the strain as the table of the last model scored would
    /// condition it.
    bank: Option<(Conditioning, Option<BankFit>)>,
}

impl Early {
    /// The form and errors of the model of `terms` on `folds`, where it was handed over.
    pub(super) fn scored(
        &self,
        folds: &[(usize, usize)],
        terms: &[Vec<(Term, f64)>],
    ) -> Option<Scored> {
        self.scored
            .iter()
            .find(|(m, _)| m.folds == folds && m.terms == terms)
            .map(|(_, scored)| *scored)
    }

    /// The force bank for a strain conditioned by `c`, where it was fitted early.
    pub(super) fn bank(&self, c: Conditioning) -> Option<&Option<BankFit>> {
        self.bank.as_ref().filter(|(k, _)| *k == c).map(|(_, b)| b)
    }
}

/// Scores each model `fitted` hands over; after a round's model, when no newer one waits, fits
/// the bank the table would carry if the rounds stopped there (the table's choice as the
/// caller makes it: the round's model where it lowers the observer's held-out error, else the
/// baseline's).
pub(super) fn work_through(fitted: Receiver<Fitted>, record: (&Series, (f64, f64))) -> Early {
    let mut early = Early::default();
    // The latest pass's baseline, and its held-out errors.
    let mut baseline: Option<(Fitted, Scored)> = None;
    let mut next = fitted.recv().ok();
    while let Some(f) = next {
        let scored = form_of(&f.folds, record);
        if f.baseline {
            baseline = Some((f.clone(), scored));
        }
        // Not for a baseline: a round that accepts an effect usually follows it, and the bank
        // would be fitted for nothing on a core the rounds use.
        let table = baseline
            .as_ref()
            .filter(|_| !f.baseline)
            .and_then(|(base, (_, before))| {
                let before = (*before)?;
                let after = scored.1.unwrap_or(before);
                let exported = after[OBSERVER] < before[OBSERVER];
                let inverted = f.folds.orientation < 0.0;
                (!inverted).then(|| conditioning_of(if exported { &f.terms } else { &base.terms }))
            });
        early.scored.push((f.folds, scored));
        next = match fitted.try_recv() {
            Ok(f) => Some(f),
            // The rounds are over: the caller fits what it needs.
            Err(TryRecvError::Disconnected) => None,
            Err(TryRecvError::Empty) => {
                if let Some(c) = table.filter(|c| early.bank(*c).is_none()) {
                    early.bank = Some((c, bank_fit(record.0, c)));
                }
                fitted.recv().ok()
            }
        };
    }
    early
}
