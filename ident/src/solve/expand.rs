//! A column delayed by a fraction of a sample as its two whole-sample views: x delayed by
//! w + f samples is (1 − f)·(x delayed by w) + f·(x delayed by w + 1), as `span` reads it. Its
//! products are then combinations of whole-sample products, which move from their sources'
//! (`shift`): a delay search's refinements between samples cost what its whole delays cost.
//! Every product of such a column is taken so, never from its interpolated samples, so the
//! Gram matrix stays one matrix's (mixing the two roundings made it indefinite).

use super::{Column, Pool};

/// A column as weighted columns whose products the pool takes.
pub(super) type Terms = Vec<(usize, f64)>;

/// Per-fold sums a column's terms combine linearly.
pub(super) trait Linear: Copy {
    fn scaled(self, w: f64) -> Self;
    fn plus(self, other: Self) -> Self;
}

impl Linear for f64 {
    fn scaled(self, w: f64) -> Self {
        self * w
    }
    fn plus(self, other: Self) -> Self {
        self + other
    }
}

impl Linear for [f64; 2] {
    fn scaled(self, w: f64) -> Self {
        self.map(|x| x * w)
    }
    fn plus(self, other: Self) -> Self {
        [self[0] + other[0], self[1] + other[1]]
    }
}

impl Pool {
    /// Column `c` as the columns whose products are taken: one delayed by a fraction of a
    /// sample from a stored source, where every sample counts, as its two whole-sample views;
    /// any other as itself.
    pub(super) fn terms_of(&self, c: usize) -> Terms {
        match (self.cols.get(c), self.views.get(&c)) {
            (Some(&Column::Delayed { frac, .. }), Some(&[at, next]))
                if self.plain && self.raw(c).is_some() =>
            {
                let f = f64::from(frac);
                vec![(at, 1.0 - f), (next, f)]
            }
            _ => vec![(c, 1.0)],
        }
    }

    /// Per fold, Σ weight·`sums`(term) over `terms` (a column that is its own term: its sums
    /// as they are).
    pub(super) fn combined<T: Linear>(
        &mut self,
        terms: &[(usize, f64)],
        mut sums: impl FnMut(&mut Pool, usize) -> Vec<T>,
    ) -> Vec<T> {
        match terms {
            [(c, w)] if *w == 1.0 => sums(self, *c),
            _ => {
                let mut out: Vec<T> = Vec::new();
                for &(c, w) in terms {
                    let v = sums(self, c);
                    if out.is_empty() {
                        out = v.iter().map(|x| x.scaled(w)).collect();
                    } else {
                        for (o, x) in out.iter_mut().zip(v) {
                            *o = o.plus(x.scaled(w));
                        }
                    }
                }
                out
            }
        }
    }
}
