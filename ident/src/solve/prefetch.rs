//! What a score would otherwise compute one at a time in its serial sums — computed columns
//! built, columns' sums against the strain, the fold sums delayed products move from — done
//! first, on every core. Each is exactly what it is computed alone ([`par::map`]).

use std::collections::HashMap;

use super::{Moved, Pool};
use crate::par;

impl Pool {
    /// Columns `cols` built from their recipes.
    pub(super) fn build_all(&self, cols: &[usize]) -> HashMap<usize, Vec<f32>> {
        let built = par::map(cols, |&c| self.values(c).into_owned());
        cols.iter()
            .zip(built)
            .map(|(&c, v)| (c, v.unwrap_or_else(|| self.values(c).into_owned())))
            .collect()
    }

    /// The strain sums of those of `cols` that have none yet.
    pub(super) fn prefetch_y(&mut self, cols: &[usize], built: &HashMap<usize, Vec<f32>>) {
        let mut todo: Vec<usize> = cols
            .iter()
            .copied()
            .filter(|c| !self.with_y.contains_key(c))
            .collect();
        todo.sort_unstable();
        todo.dedup();
        if todo.len() < 2 {
            return;
        }
        let sums = par::map(&todo, |&c| self.y_sums(c, built));
        for (c, v) in todo.into_iter().zip(sums) {
            if let Some(v) = v {
                self.with_y.insert(c, v);
            }
        }
    }

    /// The fold sums the products of `pairs` move from, where missing.
    pub(super) fn prefetch_bases(&mut self, pairs: &[(usize, usize)]) {
        let mut todo: Vec<Moved> = Vec::new();
        for &(a, b) in pairs {
            let Some(m) = self.moved_pair(a, b) else {
                continue;
            };
            if !self.has_base(&m) && !todo.iter().any(|t| t.same_base(&m)) {
                todo.push(m);
            }
        }
        if todo.len() < 2 {
            return;
        }
        let bases = par::map(&todo, |m| self.base_of(m));
        for (m, base) in todo.iter().zip(bases) {
            if let Some(Some(base)) = base {
                self.keep_base(m, base);
            }
        }
    }
}

impl Moved {
    /// Whether `self` and `other` move from the same fold sums.
    fn same_base(&self, other: &Moved) -> bool {
        match (*self, *other) {
            (Moved::Pair(s, _, lag), Moved::Pair(t, _, lag2)) => s == t && lag == lag2,
            (Moved::Cosine(k, src, _), Moved::Cosine(k2, src2, _)) => k == k2 && src == src2,
            _ => false,
        }
    }
}
