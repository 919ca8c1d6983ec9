//! The chip's figures of the models the diagnosis hands over while its rounds run, worked out
//! on the core the rounds leave idle: each model's best form and held-out errors.

use std::sync::mpsc::Receiver;

use tactile_ident::diagnose::{FoldModels, Term};
use tactile_ident::Series;

use super::{form_of, Scored};

/// What was worked out early; the caller looks up the final models in it.
#[derive(Default)]
pub(super) struct Early {
    /// Each model handed over, with its form and errors.
    scored: Vec<(FoldModels, Scored)>,
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
}

/// Scores each model `fitted` hands over, until the rounds are done.
pub(super) fn work_through(fitted: Receiver<FoldModels>, record: (&Series, (f64, f64))) -> Early {
    Early {
        scored: fitted
            .into_iter()
            .map(|m| {
                let scored = form_of(&m, record);
                (m, scored)
            })
            .collect(),
    }
}
