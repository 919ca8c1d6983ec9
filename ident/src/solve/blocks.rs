//! The Gram products' inner loops: a fold's columns read block by block (a delayed one
//! shifted, a half-cosine rotated on), every pair summed in eight lanes while the block is in
//! cache.

use crate::terms::{cosine_span, Rotation};

/// A column's samples over one fold, read block by block as the Gram products take them.
pub(super) enum FoldReader<'a> {
    /// Its samples over the fold, stored (or built for this score).
    Samples(&'a [f32]),
    /// A stored column delayed (`raw`) from the fold's start, shifted block by block into its
    /// buffer.
    Delayed((&'a [f32], usize, f32), usize, Vec<f32>),
    /// A half-cosine, rotated on from block to block into its buffer.
    Cosine(Rotation, Vec<f64>),
    Zeros(Vec<f32>),
}

impl FoldReader<'_> {
    /// Reads samples `b0..b1` of the fold into the buffer, where the column needs one.
    fn fill(&mut self, b0: usize, b1: usize) {
        match self {
            FoldReader::Samples(_) => {}
            FoldReader::Delayed(raw, s, buf) => {
                if whole_past_head(*raw, *s + b0).is_none() {
                    span(buf, *raw, *s + b0, *s + b1)
                }
            }
            FoldReader::Cosine(rotation, buf) => {
                buf.clear();
                rotation.fill(buf, b1 - b0);
            }
            FoldReader::Zeros(buf) => buf.resize(b1 - b0, 0.0),
        }
    }

    /// Samples `b0..b1` of the fold, once [`fill`](Self::fill)ed.
    fn view(&self, b0: usize, b1: usize) -> FoldSlice<'_> {
        match self {
            FoldReader::Samples(v) => FoldSlice::Samples(&v[b0..b1]),
            FoldReader::Delayed(raw, s, buf) => match whole_past_head(*raw, *s + b0) {
                Some((v, whole)) => FoldSlice::Samples(&v[*s + b0 - whole..*s + b1 - whole]),
                None => FoldSlice::Samples(buf),
            },
            FoldReader::Zeros(buf) => FoldSlice::Samples(buf),
            FoldReader::Cosine(_, buf) => FoldSlice::Cosine(buf),
        }
    }
}

/// out += w·column, the column read block by block as the Gram products read it (a
/// half-cosine rounded to f32, as a column's values are): no column built whole.
pub(super) fn add_scaled(out: &mut [f64], mut read: FoldReader, w: f64) {
    for b0 in (0..out.len()).step_by(BLOCK) {
        let b1 = (b0 + BLOCK).min(out.len());
        read.fill(b0, b1);
        let o = &mut out[b0..b1];
        match read.view(b0, b1) {
            FoldSlice::Samples(x) => o
                .iter_mut()
                .zip(x)
                .for_each(|(o, x)| *o += w * f64::from(*x)),
            FoldSlice::Cosine(c) => o
                .iter_mut()
                .zip(c)
                .for_each(|(o, c)| *o += w * f64::from(*c as f32)),
        }
    }
}

/// A raw column (stored, or delayed by whole samples) read from sample `from` on, past any
/// held head: its source and delay, sample i being the source's i − delay, in place.
pub(super) fn whole_past_head(
    (v, whole, frac): (&[f32], usize, f32),
    from: usize,
) -> Option<(&[f32], usize)> {
    (frac == 0.0 && (whole == 0 || from > whole)).then_some((v, whole))
}

/// A block of a column's samples.
enum FoldSlice<'a> {
    Samples(&'a [f32]),
    /// A half-cosine's values, in f64.
    Cosine(&'a [f64]),
}

/// Σ a·b·w over a fold for each pair of `read`, block by block: each column's block read once
/// and every pair summed from it while it is in cache. Built for AVX2 where the processor has
/// it: the same operations lane by lane, so the same sums, twice as many at a time.
pub(super) fn fold_products(
    read: &mut [FoldReader],
    pairs: &[(usize, usize)],
    w: &[f32],
) -> Vec<f64> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the processor has AVX2 (detected above).
        return unsafe { fold_products_avx2(read, pairs, w) };
    }
    fold_products_with(read, pairs, w)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn fold_products_avx2(
    read: &mut [FoldReader],
    pairs: &[(usize, usize)],
    w: &[f32],
) -> Vec<f64> {
    fold_products_with(read, pairs, w)
}

#[inline(always)]
fn fold_products_with(read: &mut [FoldReader], pairs: &[(usize, usize)], w: &[f32]) -> Vec<f64> {
    // Eight lanes a pair over whole groups of eight samples, and the fold's last few apart.
    let whole = w.len() - w.len() % 8;
    let mut lanes = vec![[0.0f64; 8]; pairs.len()];
    let mut tails = vec![[0.0f64; 8]; pairs.len()];
    for b0 in (0..w.len()).step_by(BLOCK) {
        let b1 = (b0 + BLOCK).min(w.len());
        read.iter_mut().for_each(|r| r.fill(b0, b1));
        let views: Vec<FoldSlice> = read.iter().map(|r| r.view(b0, b1)).collect();
        let (wb, body) = (&w[b0..b1], whole.max(b0).min(b1) - b0);
        for ((acc, tail), &(a, b)) in lanes.iter_mut().zip(&mut tails).zip(pairs) {
            FoldSlice::lanes(acc, &views[a], &views[b], wb, 0..body);
            if body < b1 - b0 {
                FoldSlice::lanes(tail, &views[a], &views[b], wb, body..b1 - b0);
            }
        }
    }
    lanes
        .iter()
        .zip(&tails)
        .map(|(acc, tail)| acc.iter().sum::<f64>() + tail.iter().sum::<f64>())
        .collect()
}

/// Samples a block of every column's fold holds for the Gram products: a few columns' blocks
/// stay in the core's cache while every pair of them is summed.
const BLOCK: usize = 4096;

impl FoldSlice<'_> {
    /// Adds a·b·w over `range` of the fold into eight lanes (sample i into lane i mod 8, as
    /// [`dot3`] sums): a range shorter than eight samples is a tail, one sample a lane.
    #[inline(always)]
    fn lanes(
        acc: &mut [f64; 8],
        a: &FoldSlice,
        b: &FoldSlice,
        w: &[f32],
        range: core::ops::Range<usize>,
    ) {
        let w = &w[range.clone()];
        match (a, b) {
            (FoldSlice::Samples(x), FoldSlice::Samples(y)) => {
                lanes3(acc, &x[range.clone()], &y[range], w)
            }
            (FoldSlice::Samples(x), FoldSlice::Cosine(c))
            | (FoldSlice::Cosine(c), FoldSlice::Samples(x)) => {
                lanes_with(acc, &x[range.clone()], w, &c[range])
            }
            (FoldSlice::Cosine(c), FoldSlice::Cosine(d)) => {
                for (i, ((p, q), r)) in c[range.clone()].iter().zip(&d[range]).zip(w).enumerate() {
                    acc[i % 8] += p * q * f64::from(*r);
                }
            }
        }
    }
}

/// Σ a·b·w into eight lanes, sample i into lane i mod 8 (one sum is a chain of dependent
/// additions the compiler may not reorder: a quarter of the speed on a long record).
#[inline(always)]
fn lanes3(acc: &mut [f64; 8], a: &[f32], b: &[f32], w: &[f32]) {
    let (ca, cb, cw) = (a.chunks_exact(8), b.chunks_exact(8), w.chunks_exact(8));
    for (i, ((x, y), z)) in ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .zip(cw.remainder())
        .enumerate()
    {
        acc[i] += f64::from(x * y * z);
    }
    for ((x, y), z) in ca.zip(cb).zip(cw) {
        for k in 0..8 {
            acc[k] += f64::from(x[k] * y[k] * z[k]);
        }
    }
}

/// Σ a·b·w.
#[cfg(test)]
pub(super) fn dot3(a: &[f32], b: &[f32], w: &[f32]) -> f64 {
    let whole = a.len() - a.len() % 8;
    let (mut acc, mut tail) = ([0.0f64; 8], [0.0f64; 8]);
    lanes3(&mut acc, &a[..whole], &b[..whole], &w[..whole]);
    lanes3(&mut tail, &a[whole..], &b[whole..], &w[whole..]);
    acc.iter().sum::<f64>() + tail.iter().sum::<f64>()
}

/// Σ x·w·c into eight lanes, as [`lanes3`] sums.
#[inline(always)]
fn lanes_with(acc: &mut [f64; 8], x: &[f32], w: &[f32], c: &[f64]) {
    let (cx, cw, cc) = (x.chunks_exact(8), w.chunks_exact(8), c.chunks_exact(8));
    for (i, ((a, b), l)) in cx
        .remainder()
        .iter()
        .zip(cw.remainder())
        .zip(cc.remainder())
        .enumerate()
    {
        acc[i] += f64::from(a * b) * l;
    }
    for ((a, b), l) in cx.zip(cw).zip(cc) {
        for j in 0..8 {
            acc[j] += f64::from(a[j] * b[j]) * l[j];
        }
    }
}

/// Σ x·w·cos(π·k·(i + ½)/n) over samples i = start, start + 1, ….
pub(super) fn dot_cosine(x: &[f32], w: &[f32], n: usize, k: usize, start: usize) -> f64 {
    dot_with(x, w, &cosine_span(n, k, start, x.len()))
}

/// Σ x·w·c, in eight lanes.
pub(super) fn dot_with(x: &[f32], w: &[f32], c: &[f64]) -> f64 {
    let whole = x.len() - x.len() % 8;
    let (mut acc, mut tail) = ([0.0f64; 8], [0.0f64; 8]);
    lanes_with(&mut acc, &x[..whole], &w[..whole], &c[..whole]);
    lanes_with(&mut tail, &x[whole..], &w[whole..], &c[whole..]);
    acc.iter().sum::<f64>() + tail.iter().sum::<f64>()
}

/// Samples `s..e` of a raw column (`v` delayed by `whole + frac` samples, held at its first
/// value: sample i is v[i − whole]·(1 − frac) + v[i − whole − 1]·frac) into `out`, in whole
/// slices the compiler can vectorize.
pub(super) fn span(out: &mut Vec<f32>, (v, whole, frac): (&[f32], usize, f32), s: usize, e: usize) {
    out.clear();
    let first = v.first().copied().unwrap_or(0.0);
    if whole == 0 && frac == 0.0 {
        out.extend_from_slice(&v[s..e]);
        return;
    }
    // Samples at or before `whole` hold the first value.
    let split = (whole + 1).clamp(s, e);
    out.resize(split - s, first);
    if split == e {
        return;
    }
    if frac == 0.0 {
        out.extend_from_slice(&v[split - whole..e - whole]);
        return;
    }
    let (now, before) = (
        &v[split - whole..e - whole],
        &v[split - whole - 1..e - whole - 1],
    );
    out.extend(
        now.iter()
            .zip(before)
            .map(|(x, y)| x * (1.0 - frac) + y * frac),
    );
}
