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
        cols.iter().zip(built).map(|(&c, v)| (c, v)).collect()
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
        self.with_y.extend(todo.into_iter().zip(sums));
    }

    /// The fold sums the products of `pairs` move from, where missing.
    pub(super) fn prefetch_bases(&mut self, pairs: &[(usize, usize)]) {
        let mut todo: Vec<Moved> = Vec::new();
        for &(a, b) in pairs {
            let Some(m) = self.moved_pair(a, b) else {
                continue;
            };
            if !self.has_base(&m) && !todo.iter().any(|t| t.base_key() == m.base_key()) {
                todo.push(m);
            }
        }
        if todo.len() < 2 {
            return;
        }
        let bases = par::map(&todo, |m| self.base_of(m));
        for (m, base) in todo.iter().zip(bases) {
            if let Some(base) = base {
                self.keep_base(m, base);
            }
        }
    }
}
