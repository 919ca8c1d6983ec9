//! Least squares over a pool of regressors, scored on blocked folds from per-fold Gram blocks.
//!
//! Each regressor is stored once (f32: the noise is far above its rounding) and each pair's
//! per-fold cross-product is computed once, so a candidate costs only the products of its own
//! columns, and a fold's fit is a small solve on (total − fold).

use std::borrow::Cow;
use std::collections::HashMap;

use nalgebra::{DMatrix, DVector};

use crate::series::Folds;

mod blocks;
mod expand;
mod nnls;
mod prefetch;
mod shift;
mod sums;

use crate::terms::Rotation;
use blocks::{dot_cosine, fold_products, span, FoldReader};
use expand::Terms;
pub use nnls::nnls;

/// A column's sign constraint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sign {
    Free,
    NonNegative,
}

/// A regressor: stored, or another one delayed by a (fractional) number of samples. A delayed
/// column costs no memory: the filters are shift-invariant, so the baseline of a delayed force
/// is its own columns delayed.
enum Column {
    Stored(Vec<f32>),
    /// `terms::cosine(n, k)`, computed where it is read: a smooth basis needs no memory.
    Cosine(usize),
    Delayed {
        source: usize,
        whole: usize,
        frac: f32,
    },
    /// Built from its recipe where it is read: a candidate that is cheap to compute (a play, a
    /// slow branch: one pass over the force) costs no memory while it waits (a 600 s record
    /// at 1 kHz: 2.4 MB a column, 22 of them).
    Computed(Box<dyn Fn() -> Vec<f32> + Send + Sync>),
}

/// The regressors of a record, the strain they model, and the folds.
pub struct Pool {
    n: usize,
    folds: Folds,
    /// Usable-sample mask (excluded samples weigh nothing).
    weight: Vec<f32>,
    y: Vec<f64>,
    cols: Vec<Column>,
    signs: Vec<Sign>,
    names: Vec<String>,
    cross: HashMap<(usize, usize), Vec<f64>>,
    with_y: HashMap<usize, Vec<f64>>,
    /// Per half-cosine order, per fold: Σ w·cos (`cosine_sums`).
    cosine_sums: HashMap<usize, Vec<f64>>,
    /// Every sample counts: a delayed column's products are then its source's, moved
    /// (`shift`).
    plain: bool,
    /// Per pair of sources and the samples between them, per fold: `shift::pair_base`.
    pair_bases: HashMap<((usize, usize), usize), Vec<f64>>,
    /// Per column delayed by a fraction of a sample: its two whole-sample views (`expand`).
    views: HashMap<usize, [usize; 2]>,
    /// Per half-cosine order and source, per fold: `shift::cosine_base`.
    cosine_bases: HashMap<(usize, usize), Vec<[f64; 2]>>,
    yy: Vec<f64>,
    /// Judge each held-out fold after its own offset and slope (see `set_local_nuisance`).
    local: bool,
    /// Per column, per fold: Σ w·x and Σ w·τ·x, τ the time across the fold (−1 to 1).
    local_x: HashMap<usize, Vec<[f64; 2]>>,
    /// Per source, per fold: `shift::local_base`.
    local_bases: HashMap<usize, Vec<[f64; 2]>>,
    local_y: Vec<[f64; 2]>,
    /// Per fold: the Gram matrix of (1, τ), as (Σ w, Σ w·τ, Σ w·τ²).
    local_gram: Vec<[f64; 3]>,
}

/// A model scored on the folds.
#[derive(Clone, Debug)]
pub struct Scored {
    pub columns: Vec<usize>,
    /// Coefficients fitted on the whole record.
    pub beta: Vec<f64>,
    /// Held-out mean square error of each fold (fitted on the others).
    pub fold_mse: Vec<f64>,
    /// Coefficients of each fold's fit (on the other folds).
    pub fold_beta: Vec<Vec<f64>>,
    /// Held-out mean square error over the record (folds weighted by their samples).
    pub cv_mse: f64,
    /// In-sample mean square error of the whole-record fit.
    pub fit_mse: f64,
}

impl Pool {
    pub fn new(y: &[f64], excluded: &[bool], folds: Folds) -> Pool {
        let weight: Vec<f32> = excluded
            .iter()
            .map(|x| if *x { 0.0 } else { 1.0 })
            .collect();
        let mut pool = Pool {
            n: y.len(),
            folds,
            weight,
            y: y.to_vec(),
            cols: Vec::new(),
            signs: Vec::new(),
            names: Vec::new(),
            cross: HashMap::new(),
            with_y: HashMap::new(),
            cosine_sums: HashMap::new(),
            plain: excluded.iter().all(|x| !x),
            pair_bases: HashMap::new(),
            views: HashMap::new(),
            cosine_bases: HashMap::new(),
            yy: Vec::new(),
            local: false,
            local_x: HashMap::new(),
            local_bases: HashMap::new(),
            local_y: Vec::new(),
            local_gram: Vec::new(),
        };
        pool.yy = pool.per_fold(|i| {
            let v = pool.y[i];
            v * v
        });
        pool.local_y = pool
            .local_sums(|i| pool.y[i])
            .iter()
            .map(|s| [s[0], s[1]])
            .collect();
        pool.local_gram = pool.local_sums(|_| 1.0);
        pool
    }

    /// Whether each held-out fold is judged after an offset and a slope of its own, fitted to
    /// that fold's residual. A model that has a drift basis cannot interpolate a drift that
    /// turns inside a held-out block from the blocks around it, and any force-driven term that
    /// happens to follow the force's slow course wins there; with the block's own offset and
    /// slope taken out, a later effect is judged on what the drift cannot be. Only models
    /// that are compared with each other may be scored under one setting. Returns whether the
    /// setting changed (scores taken before it are then no longer comparable).
    pub fn set_local_nuisance(&mut self, on: bool) -> bool {
        core::mem::replace(&mut self.local, on) != on
    }

    /// The folds the pool scores on.
    pub fn folds(&self) -> &Folds {
        &self.folds
    }

    /// The strain the pool models.
    pub fn y(&self) -> &[f64] {
        &self.y
    }

    /// Adds a regressor; returns its index.
    pub fn add(&mut self, name: impl Into<String>, values: &[f64], sign: Sign) -> usize {
        self.add_stored(name, values.iter().map(|v| *v as f32).collect(), sign)
    }

    /// Adds a regressor of values already as stored; returns its index.
    pub fn add_stored(&mut self, name: impl Into<String>, values: Vec<f32>, sign: Sign) -> usize {
        self.cols.push(Column::Stored(values));
        self.signs.push(sign);
        self.names.push(name.into());
        self.cols.len() - 1
    }

    /// Adds a regressor computed by `recipe` wherever it is read (it is not stored).
    pub fn add_computed(
        &mut self,
        name: impl Into<String>,
        recipe: impl Fn() -> Vec<f32> + Send + Sync + 'static,
        sign: Sign,
    ) -> usize {
        self.cols.push(Column::Computed(Box::new(recipe)));
        self.signs.push(sign);
        self.names.push(name.into());
        self.cols.len() - 1
    }

    /// Adds the half-cosine `k` over the record (`terms::cosine`), stored as its formula.
    pub fn add_cosine(&mut self, name: impl Into<String>, k: usize, sign: Sign) -> usize {
        self.cols.push(Column::Cosine(k));
        self.signs.push(sign);
        self.names.push(name.into());
        self.cols.len() - 1
    }

    /// Adds column `source` delayed by `samples` (held at its first value), under the
    /// source's sign constraint; returns its index. A delay by a fraction of a sample adds its
    /// two whole-sample neighbours first, columns of their own (`expand`).
    pub fn add_delayed(&mut self, source: usize, samples: f64) -> usize {
        // A whole number of samples as a whole number (a delay of m·dt over dt is m only to
        // its last bit).
        let samples = if (samples - samples.round()).abs() < 1e-9 {
            samples.round()
        } else {
            samples
        };
        let whole = samples.max(0.0).floor() as usize;
        let frac = (samples.max(0.0) - whole as f64) as f32;
        let views = (frac != 0.0).then(|| {
            [
                self.push_delayed(source, whole, 0.0),
                self.push_delayed(source, whole + 1, 0.0),
            ]
        });
        let j = self.push_delayed(source, whole, frac);
        if let Some(views) = views {
            self.views.insert(j, views);
        }
        j
    }

    fn push_delayed(&mut self, source: usize, whole: usize, frac: f32) -> usize {
        let sign = self.signs.get(source).copied().unwrap_or(Sign::Free);
        self.cols.push(Column::Delayed {
            source,
            whole,
            frac,
        });
        self.signs.push(sign);
        let samples = whole as f64 + f64::from(frac);
        self.names
            .push(format!("{} delayed {samples:.2}", self.name(source)));
        self.cols.len() - 1
    }

    /// How many columns the pool holds (a delayed one may have brought its views).
    pub fn columns(&self) -> usize {
        self.cols.len()
    }

    /// The column `j` is a delayed copy of, if it is one.
    pub fn delayed_source(&self, j: usize) -> Option<usize> {
        match self.cols.get(j)? {
            Column::Delayed { source, .. } => Some(*source),
            _ => None,
        }
    }

    /// A column as (stored values, whole samples of delay, fraction of a sample): a delayed
    /// column is its source read at an offset. `None` for a formula column or one of nothing
    /// stored.
    fn raw(&self, j: usize) -> Option<(&[f32], usize, f32)> {
        match self.cols.get(j)? {
            Column::Stored(v) if v.len() == self.n => Some((v.as_slice(), 0, 0.0)),
            Column::Delayed {
                source,
                whole,
                frac,
            } => match self.cols.get(*source)? {
                Column::Stored(v) if v.len() == self.n => Some((v.as_slice(), *whole, *frac)),
                _ => None,
            },
            _ => None,
        }
    }

    /// A column's values (a delayed one is built on the fly).
    fn values(&self, j: usize) -> Cow<'_, [f32]> {
        match self.cols.get(j) {
            Some(Column::Stored(v)) => Cow::Borrowed(v.as_slice()),
            // Read from its stored source as the Gram products read it (a dropped source
            // reads as zeros).
            Some(Column::Delayed {
                source,
                whole,
                frac,
            }) => {
                let mut v = Vec::new();
                match (self.raw(j), self.cols.get(*source)) {
                    (Some(raw), _) => span(&mut v, raw, 0, self.n),
                    (None, Some(Column::Computed(recipe))) => {
                        span(&mut v, (recipe().as_slice(), *whole, *frac), 0, self.n)
                    }
                    _ => v.resize(self.n, 0.0),
                }
                Cow::Owned(v)
            }
            Some(Column::Computed(recipe)) => Cow::Owned(recipe()),
            Some(Column::Cosine(k)) => Cow::Owned(
                crate::terms::cosine(self.n, *k)
                    .into_iter()
                    .map(|v| v as f32)
                    .collect(),
            ),
            None => Cow::Owned(vec![0.0; self.n]),
        }
    }

    /// Stores a computed regressor's values (one the model keeps: every later score reads
    /// it, and building it each time cost more than its memory).
    pub fn store(&mut self, j: usize) {
        if let Some(Column::Computed(recipe)) = self.cols.get(j) {
            let v = recipe();
            self.cols[j] = Column::Stored(v);
        }
    }

    /// Frees a regressor's memory (its index stays taken).
    pub fn drop_column(&mut self, j: usize) {
        if let Some(c) = self.cols.get_mut(j) {
            *c = Column::Stored(Vec::new());
        }
        self.cross.retain(|k, _| k.0 != j && k.1 != j);
        self.pair_bases.retain(|k, _| k.0 .0 != j && k.0 .1 != j);
        self.cosine_bases.retain(|k, _| k.1 != j);
        self.with_y.remove(&j);
        self.local_x.remove(&j);
        self.local_bases.remove(&j);
        for view in self.views.remove(&j).into_iter().flatten() {
            self.drop_column(view);
        }
    }

    pub fn name(&self, j: usize) -> &str {
        self.names.get(j).map_or("", |s| s.as_str())
    }

    fn per_fold(&self, f: impl Fn(usize) -> f64) -> Vec<f64> {
        self.folds
            .ranges
            .iter()
            .map(|&(a, b)| {
                (a..b)
                    .map(|i| f64::from(self.weight[i]) * f(i))
                    .sum::<f64>()
            })
            .collect()
    }

    /// Column `j`, from `built` if it was built for the present score.
    fn read<'s>(&'s self, j: usize, built: &'s HashMap<usize, Vec<f32>>) -> Cow<'s, [f32]> {
        match built.get(&j) {
            Some(v) => Cow::Borrowed(v.as_slice()),
            None => self.values(j),
        }
    }

    fn cross_of(&mut self, a: usize, b: usize, built: &HashMap<usize, Vec<f32>>) -> Vec<f64> {
        let key = (a.min(b), a.max(b));
        if !self.cross.contains_key(&key) {
            self.take_products(&[a, b], built);
        }
        self.cross.get(&key).cloned().unwrap_or_default()
    }

    /// The per-fold products of every pair of `columns` not yet taken. Fold by fold, each
    /// column's samples are read once (a delayed one shifted, a half-cosine rotated) and every
    /// pair summed from them; the folds are shared among the machine's cores when there is
    /// enough work (each fold's sums are its own: the result does not depend on how they are
    /// shared).
    fn take_products(&mut self, columns: &[usize], built: &HashMap<usize, Vec<f32>>) {
        let mut missing: Vec<(usize, usize)> = Vec::new();
        for (r, &a) in columns.iter().enumerate() {
            for &b in &columns[r..] {
                let key = (a.min(b), a.max(b));
                if !self.cross.contains_key(&key) && !missing.contains(&key) {
                    missing.push(key);
                }
            }
        }
        // Two half-cosines: from the sums of their difference's and sum's orders.
        let (cosines, missing): (Vec<_>, Vec<_>) = missing
            .into_iter()
            .partition(|&(a, b)| self.cosine_orders(a, b).is_some());
        for key in cosines {
            if let Some((d, s)) = self.cosine_orders(key.0, key.1) {
                self.cosine_sums(d);
                self.cosine_sums(s);
                let sums = |k| self.cosine_sums.get(&k).cloned().unwrap_or_default();
                let v = sums(d)
                    .iter()
                    .zip(&sums(s))
                    .map(|(a, b)| 0.5 * (a + b))
                    .collect();
                self.cross.insert(key, v);
            }
        }
        // A delayed column against another delayed alike or a half-cosine: from its source's.
        let (moved, mut missing): (Vec<_>, Vec<_>) = missing
            .into_iter()
            .partition(|&(a, b)| self.moved_pair(a, b).is_some());
        self.prefetch_bases(&moved);
        for key in moved {
            match self.moved_products(key) {
                Some(v) => {
                    self.cross.insert(key, v);
                }
                None => missing.push(key),
            }
        }
        if missing.is_empty() {
            return;
        }
        let mut involved: Vec<usize> = missing.iter().flat_map(|&(a, b)| [a, b]).collect();
        involved.sort_unstable();
        involved.dedup();
        // Columns read from a recipe (not built for this score) are built once here.
        let to_build: Vec<usize> = involved
            .iter()
            .copied()
            .filter(|&c| {
                !built.contains_key(&c)
                    && self.raw(c).is_none()
                    && !matches!(self.cols.get(c), Some(Column::Cosine(_)))
            })
            .collect();
        let extra = self.build_all(&to_build);
        let at = |c| involved.binary_search(&c).unwrap_or(0);
        let pairs: Vec<(usize, usize)> = missing.iter().map(|&(a, b)| (at(a), at(b))).collect();
        let k = self.folds.len();
        let threads = std::thread::available_parallelism().map_or(1, |t| t.get());
        // NOTE: below some millions of samples' products a thread costs more than it saves.
        let threads = threads
            .min(k)
            .min(missing.len() * self.n / 2_000_000)
            .max(1);
        let this = &*self;
        let fold = |f: usize| -> Vec<f64> {
            let (s, e) = this.folds.ranges[f];
            let mut read: Vec<FoldReader> = involved
                .iter()
                .map(|&c| this.fold_reader(c, (s, e), built.get(&c).or(extra.get(&c))))
                .collect();
            fold_products(&mut read, &pairs, &this.weight[s..e])
        };
        let per_fold: Vec<Vec<f64>> = if threads == 1 {
            (0..k).map(fold).collect()
        } else {
            let fold = &fold;
            let mut done: Vec<(usize, Vec<f64>)> = std::thread::scope(|scope| {
                let runs: Vec<_> = (0..threads)
                    .map(|t| {
                        scope.spawn(move || {
                            (t..k)
                                .step_by(threads)
                                .map(|f| (f, fold(f)))
                                .collect::<Vec<_>>()
                        })
                    })
                    .collect();
                runs.into_iter()
                    .flat_map(|r| r.join().unwrap_or_default())
                    .collect()
            });
            done.sort_by_key(|d| d.0);
            done.into_iter().map(|d| d.1).collect()
        };
        for (i, key) in missing.into_iter().enumerate() {
            let v = per_fold
                .iter()
                .map(|p| p.get(i).copied().unwrap_or(0.0))
                .collect();
            self.cross.insert(key, v);
        }
    }

    /// Where columns `a` and `b`'s products follow from their sources' (`shift`): both
    /// delayed alike, or one delayed and one a half-cosine, from sources stored whole.
    fn moved_pair(&self, a: usize, b: usize) -> Option<Moved> {
        if !self.plain {
            return None;
        }
        // Delayed by whole samples: a fraction mixes two samples in f32, which no sum of the
        // source's products gives exactly (and the Gram matrix must be one matrix's).
        let delayed = |j: usize| match self.cols.get(j)? {
            Column::Delayed {
                source,
                whole,
                frac,
            } if *frac == 0.0 => match self.cols.get(*source)? {
                Column::Stored(v) if v.len() == self.n => Some((*source, *whole)),
                _ => None,
            },
            _ => None,
        };
        let cosine = |j: usize| match self.cols.get(j)? {
            Column::Cosine(k) => Some(*k),
            _ => None,
        };
        match (delayed(a), delayed(b)) {
            (Some((sa, wa)), Some((sb, wb))) if wa == wb => {
                Some(Moved::Pair((sa.min(sb), sa.max(sb)), wa, 0))
            }
            (Some((sa, wa)), Some((sb, wb))) if wa + 1 == wb => Some(Moved::Pair((sa, sb), wa, 1)),
            (Some((sa, wa)), Some((sb, wb))) if wb + 1 == wa => Some(Moved::Pair((sb, sa), wb, 1)),
            (Some((src, w)), None) => cosine(b).map(|k| Moved::Cosine(k, src, w)),
            (None, Some((src, w))) => cosine(a).map(|k| Moved::Cosine(k, src, w)),
            _ => None,
        }
    }

    /// Per fold, the products of a pair [`moved_pair`](Self::moved_pair) finds, their
    /// sources' fold sums taken once.
    fn moved_products(&mut self, (a, b): (usize, usize)) -> Option<Vec<f64>> {
        let moved = self.moved_pair(a, b)?;
        self.fill_base(&moved)?;
        let stored = |j: usize| match self.cols.get(j) {
            Some(Column::Stored(v)) => Some(v.as_slice()),
            _ => None,
        };
        let ranges = &self.folds.ranges;
        match moved {
            Moved::Pair(sources, delay, lag) => {
                let (va, vb) = (stored(sources.0)?, stored(sources.1)?);
                let bases = self.pair_bases.get(&(sources, lag))?;
                Some(
                    ranges
                        .iter()
                        .zip(bases)
                        .map(|(&r, &base)| shift::delayed_pair((va, vb), delay, lag, r, base))
                        .collect(),
                )
            }
            Moved::Cosine(k, src, delay) => {
                let (v, n) = (stored(src)?, self.n);
                let bases = self.cosine_bases.get(&(k, src))?;
                Some(
                    ranges
                        .iter()
                        .zip(bases)
                        .map(|(&r, &base)| shift::delayed_cosine(v, (n, k), delay, r, base))
                        .collect(),
                )
            }
        }
    }

    /// The fold sums `moved`'s products move from, taken into their cache if they are not
    /// there; `None` where a source is not stored.
    fn fill_base(&mut self, moved: &Moved) -> Option<()> {
        if self.has_base(moved) {
            return Some(());
        }
        let base = self.base_of(moved)?;
        self.keep_base(moved, base);
        Some(())
    }

    fn has_base(&self, moved: &Moved) -> bool {
        match moved.base_key() {
            BaseKey::Pair(sources, lag) => self.pair_bases.contains_key(&(sources, lag)),
            BaseKey::Cosine(k, src) => self.cosine_bases.contains_key(&(k, src)),
        }
    }

    /// Per fold, the sums `moved`'s products move from: a pair's products at its lag, or a
    /// half-cosine's and its quadrature's against the source.
    fn base_of(&self, moved: &Moved) -> Option<Base> {
        let stored = |j: usize| match self.cols.get(j) {
            Some(Column::Stored(v)) => Some(v.as_slice()),
            _ => None,
        };
        let ranges = &self.folds.ranges;
        Some(match *moved {
            Moved::Pair(sources, _, lag) => {
                let (va, vb) = (stored(sources.0)?, stored(sources.1)?);
                Base::Pair(
                    ranges
                        .iter()
                        .map(|&r| shift::pair_base(va, vb, lag, r))
                        .collect(),
                )
            }
            Moved::Cosine(k, src, _) => {
                let v = stored(src)?;
                Base::Cosine(
                    ranges
                        .iter()
                        .map(|&r| shift::cosine_base(v, self.n, k, r))
                        .collect(),
                )
            }
        })
    }

    fn keep_base(&mut self, moved: &Moved, base: Base) {
        match (moved.base_key(), base) {
            (BaseKey::Pair(sources, lag), Base::Pair(b)) => {
                self.pair_bases.insert((sources, lag), b);
            }
            (BaseKey::Cosine(k, src), Base::Cosine(b)) => {
                self.cosine_bases.insert((k, src), b);
            }
            _ => {}
        }
    }

    /// Column `c`'s samples `s..e` as the products read them: `whole` if it was built for this
    /// score, else its stored values (shifted, if delayed) or its half-cosine; a column of
    /// nothing stored reads as zeros.
    fn fold_reader<'s>(
        &'s self,
        c: usize,
        (s, e): (usize, usize),
        whole: Option<&'s Vec<f32>>,
    ) -> FoldReader<'s> {
        if let Some(v) = whole.filter(|v| v.len() == self.n) {
            return FoldReader::Samples(&v[s..e]);
        }
        if let Some(Column::Cosine(k)) = self.cols.get(c) {
            return FoldReader::Cosine(Rotation::new(self.n, *k, s), Vec::new());
        }
        match self.raw(c) {
            Some((v, 0, 0.0)) => FoldReader::Samples(&v[s..e]),
            Some(raw) => FoldReader::Delayed(raw, s, Vec::new()),
            None => FoldReader::Zeros(Vec::new()),
        }
    }

    /// For two half-cosine columns, the orders whose folds' sums make their products:
    /// cos a·cos b = ½·(cos(a − b) + cos(a + b)).
    fn cosine_orders(&self, a: usize, b: usize) -> Option<(usize, usize)> {
        match (self.cols.get(a), self.cols.get(b)) {
            (Some(Column::Cosine(ka)), Some(Column::Cosine(kb))) => {
                Some((ka.abs_diff(*kb), ka + kb))
            }
            _ => None,
        }
    }

    /// Per fold, Σ w·cos(π·k·(i + ½)/n) (kept: the products of two half-cosines are sums of
    /// these).
    fn cosine_sums(&mut self, k: usize) {
        if !self.cosine_sums.contains_key(&k) {
            let v = self.fold_cosine_sums(k);
            self.cosine_sums.insert(k, v);
        }
    }

    fn fold_cosine_sums(&self, k: usize) -> Vec<f64> {
        let w = &self.weight;
        // The mask is 0 or 1, so w·w = w.
        self.folds
            .ranges
            .iter()
            .map(|&(s, e)| dot_cosine(&w[s..e], &w[s..e], self.n, k, s))
            .collect()
    }

    /// Fits `columns` on every fold's complement and on the whole record.
    pub fn score(&mut self, columns: &[usize]) -> Scored {
        let p = columns.len();
        let k = self.folds.len();
        let mut g = vec![DMatrix::<f64>::zeros(p, p); k];
        let mut b = vec![DVector::<f64>::zeros(p); k];
        // Each column as the columns whose products are taken (`expand`).
        let terms: Vec<Terms> = columns.iter().map(|&c| self.terms_of(c)).collect();
        let mut taken: Vec<usize> = terms.iter().flatten().map(|t| t.0).collect();
        taken.sort_unstable();
        taken.dedup();
        // A computed column is built once for all its products still to be taken.
        let to_build: Vec<usize> = taken
            .iter()
            .copied()
            .filter(|&c| {
                matches!(self.cols.get(c), Some(Column::Computed(_)))
                    && (!self.with_y.contains_key(&c)
                        || (self.local && !self.local_x.contains_key(&c))
                        || taken
                            .iter()
                            .any(|&o| !self.cross.contains_key(&(c.min(o), c.max(o)))))
            })
            .collect();
        let built = self.build_all(&to_build);
        self.take_products(&taken, &built);
        self.prefetch_y(&taken, &built);
        for (r, tr) in terms.iter().enumerate() {
            let by = self.combined(tr, |pool, c| pool.y_of(c, &built));
            for f in 0..k {
                b[f][r] = by[f];
            }
            for (c, tc) in terms.iter().enumerate().skip(r) {
                let v = self.combined(tr, |pool, a| {
                    pool.combined(tc, |pool, b| pool.cross_of(a, b, &built))
                });
                for f in 0..k {
                    g[f][(r, c)] = v[f];
                    g[f][(c, r)] = v[f];
                }
            }
        }
        let local: Vec<Vec<[f64; 2]>> = if self.local {
            terms
                .iter()
                .map(|t| self.combined(t, |pool, c| pool.local_of(c, &built)))
                .collect()
        } else {
            Vec::new()
        };
        let total_g: DMatrix<f64> = g.iter().fold(DMatrix::zeros(p, p), |a, x| a + x);
        let total_b: DVector<f64> = b.iter().fold(DVector::zeros(p), |a, x| a + x);
        let total_yy: f64 = self.yy.iter().sum();
        let signs: Vec<Sign> = columns.iter().map(|&c| self.signs[c]).collect();
        let sse = |g: &DMatrix<f64>, b: &DVector<f64>, yy: f64, beta: &DVector<f64>| {
            (yy - 2.0 * beta.dot(b) + (g * beta).dot(beta)).max(0.0)
        };
        let mut fold_mse = Vec::with_capacity(k);
        let mut fold_beta = Vec::with_capacity(k);
        let mut held_sse = 0.0;
        for f in 0..k {
            let beta = nnls(&(&total_g - &g[f]), &(&total_b - &b[f]), &signs);
            let mut s = sse(&g[f], &b[f], self.yy[f], &beta);
            if self.local {
                // Less the residual's projection on the fold's (1, τ).
                let mut r = self.local_y[f];
                for (x, w) in local.iter().zip(beta.iter()) {
                    r[0] -= w * x[f][0];
                    r[1] -= w * x[f][1];
                }
                let [s0, s1, s2] = self.local_gram[f];
                let det = s0 * s2 - s1 * s1;
                if det > 0.0 {
                    s = (s - (s2 * r[0] * r[0] - 2.0 * s1 * r[0] * r[1] + s0 * r[1] * r[1]) / det)
                        .max(0.0);
                }
            }
            held_sse += s;
            fold_mse.push(s / self.folds.counts[f].max(1) as f64);
            fold_beta.push(beta.iter().copied().collect());
        }
        let beta = nnls(&total_g, &total_b, &signs);
        let used: usize = self.folds.counts.iter().sum();
        Scored {
            columns: columns.to_vec(),
            fit_mse: sse(&total_g, &total_b, total_yy, &beta) / used.max(1) as f64,
            beta: beta.iter().copied().collect(),
            fold_mse,
            fold_beta,
            cv_mse: held_sse / used.max(1) as f64,
        }
    }

    /// Σ β_j·column_j over the record.
    pub fn predict(&self, columns: &[usize], beta: &[f64]) -> Vec<f64> {
        self.predict_in(columns, beta, (0, self.n))
    }

    /// [`Pool::predict`] over samples `a..b` alone.
    pub fn predict_in(&self, columns: &[usize], beta: &[f64], (a, b): (usize, usize)) -> Vec<f64> {
        let b = b.min(self.n);
        let a = a.min(b);
        let mut out = vec![0.0; b - a];
        // A column the fit left at zero adds nothing (the non-negative fits leave many).
        for (&c, &w) in columns.iter().zip(beta).filter(|(_, w)| **w != 0.0) {
            // Stored, delayed from a stored source or a half-cosine: read block by block.
            let readable =
                self.raw(c).is_some() || matches!(self.cols.get(c), Some(Column::Cosine(_)));
            if readable {
                blocks::add_scaled(&mut out, self.fold_reader(c, (a, b), None), w);
                continue;
            }
            for (o, v) in out.iter_mut().zip(self.values(c).iter().skip(a)) {
                *o += w * f64::from(*v);
            }
        }
        out
    }
}

/// A pair of columns whose products follow from their sources' (`shift`): two sources delayed
/// alike or a sample apart (the less delayed first; the delay and the samples between them), or
/// a half-cosine's order and a delayed source; delays in whole samples.
#[derive(Clone, Copy)]
enum Moved {
    Pair((usize, usize), usize, usize),
    Cosine(usize, usize, usize),
}

impl Moved {
    /// What the fold sums it moves from are kept under: pairs of the same sources and lag,
    /// or half-cosines of the same order against the same source, move from the same sums.
    fn base_key(&self) -> BaseKey {
        match *self {
            Moved::Pair(sources, _, lag) => BaseKey::Pair(sources, lag),
            Moved::Cosine(k, src, _) => BaseKey::Cosine(k, src),
        }
    }
}

/// The key of a [`Base`]: a pair's sources and lag, or a half-cosine's order and source.
#[derive(Clone, Copy, PartialEq)]
enum BaseKey {
    Pair((usize, usize), usize),
    Cosine(usize, usize),
}

/// The fold sums a [`Moved`] pair's products move from.
enum Base {
    Pair(Vec<f64>),
    Cosine(Vec<[f64; 2]>),
}

#[cfg(test)]
mod tests {
    use super::blocks::dot3;
    use super::*;

    /// Sample `i` of `v` delayed by `whole + frac` samples, held at its first value, one at a
    /// time: what [`span`] must read.
    fn at(v: &[f32], whole: usize, frac: f32, i: usize) -> f32 {
        if whole == 0 && frac == 0.0 {
            v[i]
        } else if i > whole {
            v[i - whole] * (1.0 - frac) + v[i - whole - 1] * frac
        } else {
            v[0]
        }
    }

    #[test]
    fn the_cosine_dot_is_the_half_cosine_summed_sample_by_sample() {
        let n = 10_007;
        let x: Vec<f32> = (0..n)
            .map(|i| ((i * 37) % 101) as f32 / 50.0 - 1.0)
            .collect();
        let w: Vec<f32> = (0..n)
            .map(|i| if i % 97 == 0 { 0.0 } else { 1.0 })
            .collect();
        for k in [1, 2, 7, 16] {
            let c = crate::terms::cosine(n, k);
            for (s, e) in [(0, n), (3, 4), (5, 5000), (5000, n), (n - 7, n)] {
                let naive: f64 = (s..e).map(|i| f64::from(x[i] * w[i]) * c[i]).sum();
                let fast = dot_cosine(&x[s..e], &w[s..e], n, k, s);
                assert!(
                    (fast - naive).abs() <= 1e-9 * (e - s) as f64,
                    "k {k} {s}..{e}: {fast} {naive}"
                );
            }
        }
    }

    #[test]
    fn a_span_reads_what_the_sample_reader_reads_and_dot3_sums_it() {
        let v: Vec<f32> = (0..103).map(|i| ((i * 37) % 11) as f32 - 4.5).collect();
        let w: Vec<f32> = (0..103).map(|i| 1.0 + (i % 3) as f32).collect();
        let mut out = Vec::new();
        for (whole, frac) in [
            (0, 0.0),
            (0, 0.25),
            (3, 0.0),
            (3, 0.5),
            (40, 0.75),
            (120, 0.5),
        ] {
            for (s, e) in [(0, 103), (0, 2), (5, 61), (61, 103), (100, 103)] {
                span(&mut out, (&v, whole, frac), s, e);
                let want: Vec<f32> = (s..e).map(|i| at(&v, whole, frac, i)).collect();
                assert_eq!(out, want, "whole {whole} frac {frac} {s}..{e}");
                let naive: f64 = (s..e).map(|i| f64::from(want[i - s] * v[i] * w[i])).sum();
                let fast = dot3(&out, &v[s..e], &w[s..e]);
                assert!(
                    (fast - naive).abs() <= 1e-9 * naive.abs().max(1.0),
                    "{fast} {naive}"
                );
            }
        }
    }

    #[test]
    fn held_out_error_of_an_exact_model_is_zero_and_of_a_wrong_one_is_not() {
        let n = 1000;
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.05).sin()).collect();
        let z: Vec<f64> = (0..n).map(|i| (i as f64 * 0.011).cos()).collect();
        let y: Vec<f64> = x.iter().zip(&z).map(|(a, b)| 2.0 * a + 0.5 * b).collect();
        let mut pool = Pool::new(&y, &vec![false; n], Folds::blocked(&vec![false; n], 5));
        let cx = pool.add("x", &x, Sign::NonNegative);
        let cz = pool.add("z", &z, Sign::Free);
        let both = pool.score(&[cx, cz]);
        // Columns are stored as f32: exact up to their rounding.
        assert!(both.cv_mse < 1e-6, "{}", both.cv_mse);
        assert!((both.beta[0] - 2.0).abs() < 1e-4 && (both.beta[1] - 0.5).abs() < 1e-4);
        let one = pool.score(&[cx]);
        assert!(one.cv_mse > 0.05, "{}", one.cv_mse);
        assert_eq!(one.fold_mse.len(), 5);
    }

    #[test]
    fn half_cosine_columns_score_as_the_same_cosines_stored() {
        // Every product with a half-cosine is taken without building it (rotated along the
        // folds; two cosines by their sum and difference); stored, they are summed plainly.
        let n = 1000;
        let excluded: Vec<bool> = (0..n).map(|i| (300..340).contains(&i)).collect();
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.013).sin() + 0.3).collect();
        let y: Vec<f64> = (0..n)
            .map(|i| x[i] + 0.2 * ((i as f64 + 0.5) * 0.01).cos() + 0.01 * ((i % 7) as f64))
            .collect();
        let mut pool = Pool::new(&y, &excluded, Folds::blocked(&excluded, 5));
        let xs = pool.add("x", &x, Sign::Free);
        let xr = x.clone();
        let xc = pool.add_computed(
            "x computed",
            move || xr.iter().map(|v| *v as f32).collect(),
            Sign::Free,
        );
        let (formula, stored): (Vec<usize>, Vec<usize>) = [1usize, 3, 4]
            .iter()
            .map(|&k| {
                let c = crate::terms::cosine(n, k);
                (
                    pool.add_cosine(format!("cos {k}"), k, Sign::Free),
                    pool.add(format!("stored cos {k}"), &c, Sign::Free),
                )
            })
            .unzip();
        for other in [xs, xc] {
            let a = pool.score(&[&[other][..], &formula].concat());
            let b = pool.score(&[&[other][..], &stored].concat());
            for (u, v) in a.fold_mse.iter().zip(&b.fold_mse) {
                assert!((u - v).abs() <= 1e-6 * v.max(1e-9), "{u} {v}");
            }
            for (u, v) in a.beta.iter().zip(&b.beta) {
                assert!((u - v).abs() < 1e-4, "{u} {v}");
            }
        }
    }

    #[test]
    fn a_computed_column_scores_as_the_stored_one_alone_with_others_and_delayed() {
        let n = 900;
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.031).sin()).collect();
        let z: Vec<f64> = (0..n).map(|i| (i as f64 * 0.007).cos()).collect();
        let y: Vec<f64> = (0..n)
            .map(|i: usize| {
                1.5 * x[i.saturating_sub(2)] - 0.7 * z[i] + 0.01 * (((i * 7919) % 13) as f64 - 6.0)
            })
            .collect();
        let mut pool = Pool::new(&y, &vec![false; n], Folds::blocked(&vec![false; n], 4));
        let xs = pool.add("x stored", &x, Sign::Free);
        let zs = pool.add("z stored", &z, Sign::Free);
        let (xr, zr) = (x.clone(), z.clone());
        let to_f32 = |v: &[f64]| v.iter().map(|a| *a as f32).collect::<Vec<f32>>();
        let xc = pool.add_computed("x computed", move || to_f32(&xr), Sign::Free);
        let zc = pool.add_computed("z computed", move || to_f32(&zr), Sign::Free);
        let xsd = pool.add_delayed(xs, 2.0);
        let xcd = pool.add_delayed(xc, 2.0);
        for (stored, computed) in [
            (vec![xs], vec![xc]),
            (vec![xs, zs], vec![xc, zc]),
            (vec![xs, zc], vec![xc, zs]),
        ] {
            let (a, b) = (pool.score(&stored), pool.score(&computed));
            assert_eq!(a.fold_mse, b.fold_mse, "{stored:?} {computed:?}");
            assert_eq!(a.beta, b.beta);
            assert_eq!(
                pool.predict(&stored, &a.beta),
                pool.predict(&computed, &b.beta)
            );
        }
        // A stored source's delayed products are its own, moved (in f64, where the samples
        // multiply in f32): alike to the f32 rounding of a product.
        let (a, b) = (pool.score(&[xsd, zs]), pool.score(&[xcd, zc]));
        for (u, v) in a
            .fold_mse
            .iter()
            .zip(&b.fold_mse)
            .chain(a.beta.iter().zip(&b.beta))
        {
            assert!((u - v).abs() <= 1e-5 * v.abs(), "{u} {v}");
        }
        // The delay is what the data hold: 1.5 on x two samples back, a small held-out error.
        let d = pool.score(&[xcd, zc]);
        assert!((d.beta[0] - 1.5).abs() < 0.01 && (d.beta[1] + 0.7).abs() < 0.01);
        // The residual is the added ±0.06 pattern (mean square 0.0014); without the delay, x's
        // two-sample lag adds its own.
        let undelayed = pool.score(&[xc, zc]).cv_mse;
        assert!(
            d.cv_mse < 0.0016 && undelayed > 2.0 * d.cv_mse,
            "{} {undelayed}",
            d.cv_mse
        );
    }

    #[test]
    fn a_delay_between_samples_scores_as_its_interpolated_samples_do() {
        // Two sources delayed 3.4 samples, the strain that delay of them plus a half-cosine:
        // from a stored source, the delayed columns' products come from the whole-sample
        // views at 3 and 4 (moved); from a computed one, from the interpolated samples.
        let n = 2000;
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.031).sin()).collect();
        let z: Vec<f64> = (0..n)
            .map(|i| ((i * 7919) % 101) as f64 / 50.0 - 1.0)
            .collect();
        let lagged = |v: &[f64], i: usize| {
            if i > 3 {
                0.6 * v[i - 3] + 0.4 * v[i - 4]
            } else {
                v[0]
            }
        };
        let y: Vec<f64> = (0..n)
            .map(|i| {
                1.5 * lagged(&x, i) - 0.7 * lagged(&z, i)
                    + 0.3 * ((i as f64 + 0.5) * std::f64::consts::PI / n as f64).cos()
            })
            .collect();
        let mut pool = Pool::new(&y, &vec![false; n], Folds::blocked(&vec![false; n], 5));
        let to_f32 = |v: &[f64]| v.iter().map(|a| *a as f32).collect::<Vec<f32>>();
        let (xr, zr) = (x.clone(), z.clone());
        let (xs, zs) = (pool.add("x", &x, Sign::Free), pool.add("z", &z, Sign::Free));
        let xc = pool.add_computed("x computed", move || to_f32(&xr), Sign::Free);
        let zc = pool.add_computed("z computed", move || to_f32(&zr), Sign::Free);
        let cos = pool.add_cosine("cos 1", 1, Sign::Free);
        for local in [false, true] {
            pool.set_local_nuisance(local);
            for delay in [3.4, 3.0, 0.25, 11.75] {
                let moved = [
                    pool.add_delayed(xs, delay),
                    pool.add_delayed(zs, delay),
                    cos,
                ];
                let direct = [
                    pool.add_delayed(xc, delay),
                    pool.add_delayed(zc, delay),
                    cos,
                ];
                let (a, b) = (pool.score(&moved), pool.score(&direct));
                for (u, v) in a
                    .fold_mse
                    .iter()
                    .zip(&b.fold_mse)
                    .chain([(&a.cv_mse, &b.cv_mse)])
                {
                    // The normal equations cancel the strain's mean square (about 1) to the
                    // rounding of f32 products.
                    assert!((u - v).abs() <= 1e-5 * v + 1e-8, "{delay} {local}: {u} {v}");
                }
                for (u, v) in a.beta.iter().zip(&b.beta) {
                    assert!((u - v).abs() <= 1e-5, "{delay} {local}: {u} {v}");
                }
                if delay == 3.4 {
                    // The strain's own delay: its weights, and nothing left to hold out.
                    assert!((a.beta[0] - 1.5).abs() < 1e-3 && (a.beta[1] + 0.7).abs() < 1e-3);
                    assert!(a.cv_mse < 1e-8, "{}", a.cv_mse);
                }
                for c in moved.into_iter().chain(direct).filter(|&c| c != cos) {
                    pool.drop_column(c);
                }
            }
        }
    }
}
