//! A column's per-fold sums beside its Gram products: against the strain, and against each
//! held-out fold's own offset and slope (the local nuisance). A stored or delayed column is read
//! fold by fold, not built whole; one delayed by whole samples takes the latter from its
//! source's, moved (`shift`).

use std::collections::HashMap;

use super::blocks::{dot_with, span, whole_past_head};
use super::{shift, Column, Pool};

impl Pool {
    /// Per fold: (Σ w·f, Σ w·τ·f, Σ w·τ²·f), τ the time across the fold from −1 to 1.
    pub(super) fn local_sums(&self, f: impl Fn(usize) -> f64) -> Vec<[f64; 3]> {
        self.folds
            .ranges
            .iter()
            .map(|&fold| self.fold_local_sums(fold, &f))
            .collect()
    }

    /// [`local_sums`](Self::local_sums) over one fold [a, b).
    fn fold_local_sums(&self, (a, b): (usize, usize), f: impl Fn(usize) -> f64) -> [f64; 3] {
        let half = ((b - a).max(2) - 1) as f64 / 2.0;
        (a..b).fold([0.0; 3], |s, i| {
            let v = f64::from(self.weight[i]) * f(i);
            let tau = (i - a) as f64 / half - 1.0;
            [s[0] + v, s[1] + v * tau, s[2] + v * tau * tau]
        })
    }

    pub(super) fn y_of(&mut self, a: usize, built: &HashMap<usize, Vec<f32>>) -> Vec<f64> {
        if let Some(v) = self.with_y.get(&a) {
            return v.clone();
        }
        let v = self.y_sums(a, built);
        self.with_y.insert(a, v.clone());
        v
    }

    /// Per fold, Σ w·x·y of column `a` (x) against the strain (y).
    pub(super) fn y_sums(&self, a: usize, built: &HashMap<usize, Vec<f32>>) -> Vec<f64> {
        let (w, y) = (&self.weight, &self.y);
        let sum = |ca: &[f32], (s, e): (usize, usize)| dot_with(ca, &w[s..e], &y[s..e]);
        self.per_fold_of(a, built, sum)
    }

    /// Per fold, `sum` of column `a`'s samples of the fold (given from the fold's start): a
    /// stored or delayed column read fold by fold, not built whole.
    fn per_fold_of<T>(
        &self,
        a: usize,
        built: &HashMap<usize, Vec<f32>>,
        sum: impl Fn(&[f32], (usize, usize)) -> T,
    ) -> Vec<T> {
        let ranges = &self.folds.ranges;
        match (built.get(&a), self.raw(a)) {
            (None, Some(raw)) => {
                let mut buf = Vec::new();
                ranges
                    .iter()
                    .map(|&(s, e)| match whole_past_head(raw, s) {
                        // Stored, or delayed past its head: read in place.
                        Some((v, whole)) => sum(&v[s - whole..e - whole], (s, e)),
                        None => {
                            span(&mut buf, raw, s, e);
                            sum(&buf, (s, e))
                        }
                    })
                    .collect()
            }
            _ => {
                let ca = self.read(a, built);
                ranges
                    .iter()
                    .map(|&(s, e)| sum(&ca[s..e], (s, e)))
                    .collect()
            }
        }
    }

    pub(super) fn local_of(&mut self, a: usize, built: &HashMap<usize, Vec<f32>>) -> Vec<[f64; 2]> {
        if let Some(v) = self.local_x.get(&a) {
            return v.clone();
        }
        let v = match self.moved_local(a) {
            Some(v) => v,
            None => {
                let sum = |ca: &[f32], fold: (usize, usize)| {
                    let [x, tx, _] = self.fold_local_sums(fold, |i| f64::from(ca[i - fold.0]));
                    [x, tx]
                };
                self.per_fold_of(a, built, sum)
            }
        };
        self.local_x.insert(a, v.clone());
        v
    }

    /// A column delayed by whole samples: its sums against each fold's offset and slope from
    /// its source's (`shift::delayed_local`), where every sample counts.
    fn moved_local(&mut self, a: usize) -> Option<Vec<[f64; 2]>> {
        let Some(Column::Delayed {
            source,
            whole,
            frac,
        }) = self.cols.get(a)
        else {
            return None;
        };
        let (source, whole) = (*source, *whole);
        let Some(Column::Stored(v)) = self.cols.get(source) else {
            return None;
        };
        if !self.plain || *frac != 0.0 || v.len() != self.n {
            return None;
        }
        let ranges = &self.folds.ranges;
        let bases = self
            .local_bases
            .entry(source)
            .or_insert_with(|| ranges.iter().map(|&r| shift::local_base(v, r)).collect());
        Some(
            ranges
                .iter()
                .zip(bases.iter())
                .map(|(&r, &base)| shift::delayed_local(v, whole, r, base))
                .collect(),
        )
    }
}
