//! What a logger on a PC or a Raspberry Pi does to a record, and how the reader undoes it: time
//! stamps that jitter (each row stamped when the logger got to it), rows stamped twice, and
//! values held when a read is missed (sample-and-hold dropouts).

use serde::Serialize;

use crate::Record;

/// How the time column was mended on reading, for the diagnosis' report.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Resampling {
    /// Spread of the time stamps about the even grid that fits them (latest less earliest), as
    /// a share of the step: a logger that stamps each row up to 80 % of a step late gives 0.8.
    pub jitter_share: f64,
    /// Rows stamped with the time of the row before, averaged into it.
    pub merged_duplicates: usize,
    /// The step every column was linearly interpolated onto (the even grid's that fits the
    /// stamps), s; `None`: the stamps were even and the values are as written.
    pub resampled_step_s: Option<f64>,
}

/// Steps within this share of the median are even sampling (the values are kept as written).
const EVEN_STEP_SHARE: f64 = 0.01;
/// Most the time stamps may spread about the even grid that fits them, as a share of the step:
/// a logger stamps each row when it reads it, up to most of a step late; a wider spread is a
/// clock that changes rate within the record, which no single step describes.
pub const JITTER_SHARE: f64 = 1.0;
/// A step longer than this many median steps is a gap: samples were lost, and interpolating
/// across them would invent a signal. (Jitter of up to a step lengthens a step to under three.)
pub const GAP_STEPS: f64 = 3.0;

pub(crate) fn median_step(t: &[f64]) -> Option<f64> {
    let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    if d.is_empty() {
        return None;
    }
    d.sort_by(f64::total_cmp);
    Some(d[d.len() / 2])
}

/// The even grid that fits the time stamps best (least squares): its first time and its step.
fn grid(t: &[f64]) -> Option<(f64, f64)> {
    let n = t.len();
    if n < 2 {
        return None;
    }
    let nf = n as f64;
    let k_mean = (nf - 1.0) / 2.0;
    let t_mean = t.iter().sum::<f64>() / nf;
    let (mut skt, mut skk) = (0.0, 0.0);
    for (k, v) in t.iter().enumerate() {
        let dk = k as f64 - k_mean;
        skt += dk * (v - t_mean);
        skk += dk * dk;
    }
    let step = skt / skk;
    Some((t_mean - step * k_mean, step))
}

/// Each time stamp's departure from the grid `(t0, step)`, as a share of its step.
fn grid_offsets(t: &[f64], (t0, step): (f64, f64)) -> impl Iterator<Item = f64> + '_ {
    t.iter()
        .enumerate()
        .map(move |(k, v)| (v - (t0 + k as f64 * step)) / step)
}

/// Spread of the time stamps about the even grid that fits them, as a share of its step.
pub(crate) fn stamp_spread(t: &[f64]) -> Option<f64> {
    spread_about(t, grid(t)?)
}

/// Spread of the time stamps about the grid `g`, as a share of its step.
fn spread_about(t: &[f64], g: (f64, f64)) -> Option<f64> {
    let (lo, hi) = grid_offsets(t, g).fold((f64::INFINITY, f64::NEG_INFINITY), |m, d| {
        (m.0.min(d), m.1.max(d))
    });
    let spread = hi - lo;
    spread.is_finite().then_some(spread)
}

/// Mends the time column of a record read with strictly increasing stamps (`merged` rows
/// already averaged into the row before): even stamps are kept; stamps that jitter are
/// resampled onto the step of the even grid that fits them (the median step can be far off:
/// a logger late by turns has its steps bunch on one side of the true one). `Err`: the index of the first row that breaks the sampling
/// (a gap, a clock that changes rate) and what to do.
pub(crate) fn mend_time(rec: &mut Record, merged: usize) -> Result<(), (usize, String)> {
    let t = &rec.t_s;
    let Some(step) = median_step(t).filter(|s| s.is_finite() && *s > 0.0) else {
        return Err((0, "the time stamps give no usable step".into()));
    };
    let even = t
        .windows(2)
        .all(|w| ((w[1] - w[0]) - step).abs() <= EVEN_STEP_SHARE * step);
    let mut resampling = Resampling {
        merged_duplicates: merged,
        ..Resampling::default()
    };
    if !even {
        check_gaps(t, step)?;
        let fitted = grid(t).filter(|g| g.1.is_finite() && g.1 > 0.0);
        let spread = fitted
            .and_then(|g| spread_about(t, g))
            .unwrap_or(f64::INFINITY);
        if spread > JITTER_SHARE {
            let fitted = fitted.unwrap_or((t[0], step));
            let (k, off) = grid_offsets(t, fitted)
                .enumerate()
                .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                .unwrap_or((0, 0.0));
            return Err((
                k,
                format!(
                    "uneven sampling: time {} s is {:.0} % of a step off the even grid of {:.6} s \
                     that fits the time stamps (they may spread over {:.0} % of a step): a rate \
                     that changes within the record; split the record where it changes",
                    t[k],
                    100.0 * off.abs(),
                    fitted.1,
                    100.0 * JITTER_SHARE
                ),
            ));
        }
        let step = fitted.map_or(step, |g| g.1);
        resampling.jitter_share = spread;
        resampling.resampled_step_s = Some(step);
        resample(rec, step);
    }
    if resampling != Resampling::default() {
        rec.resampling = Some(resampling);
    }
    Ok(())
}

/// The first step longer than [`GAP_STEPS`] median steps, refused with what to do.
fn check_gaps(t: &[f64], step: f64) -> Result<(), (usize, String)> {
    for (k, w) in t.windows(2).enumerate() {
        let d = w[1] - w[0];
        if d > GAP_STEPS * step {
            let missing = ((d / step).round() - 1.0).max(1.0);
            let samples = if missing > 1.0 { "samples" } else { "sample" };
            return Err((
                k + 1,
                format!(
                    "a gap of {d:.6} s after {} s (about {missing:.0} {samples} missing at the \
                     median step {step:.6} s): split the record there or fill the gap",
                    w[0]
                ),
            ));
        }
    }
    Ok(())
}

/// Every column linearly interpolated onto `t_s[0] + k·step` up to the last stamp: a logger's
/// stamps are when it read each sample, so between two reads the signal is taken as a line
/// (its error is ω²h²/8 of a sine's amplitude for a step h, a thousandth at a tenth of Nyquist).
fn resample(rec: &mut Record, step: f64) {
    let t = std::mem::take(&mut rec.t_s);
    let (t0, last) = (t[0], t[t.len() - 1]);
    // The small allowance keeps the last stamp when it lies on the grid but for rounding.
    let m = ((last - t0) / step + 1e-9).floor() as usize + 1;
    let grid: Vec<f64> = (0..m).map(|k| t0 + k as f64 * step).collect();
    // For each grid time the stamp at or before it and the weight of the one after.
    let mut at = Vec::with_capacity(m);
    let mut i = 0;
    for &g in &grid {
        while i + 2 < t.len() && t[i + 1] <= g {
            i += 1;
        }
        let span = t[i + 1] - t[i];
        at.push((i, ((g - t[i]) / span).clamp(0.0, 1.0)));
    }
    let onto = |v: &[f64]| -> Vec<f64> {
        at.iter()
            .map(|&(i, w)| v[i] + w * (v[i + 1] - v[i]))
            .collect()
    };
    rec.force_g = onto(&rec.force_g);
    rec.strain_pct = onto(&rec.strain_pct);
    for (_, v) in rec.extra.iter_mut() {
        *v = onto(v);
    }
    rec.t_s = grid;
}

/// Fewest equal values in a row that can be a dropout: the sample read and four repeats.
pub const MIN_HELD_RUN: usize = 5;
/// Most: a longer run is the signal's own hold (a rest, a rail), not a missed read.
pub const MAX_HELD_RUN: usize = 100;
/// Samples on each side of a run that say whether the signal moves there.
const HELD_AROUND: usize = 16;
/// Least share of distinct values among the samples around a run for it to be a dropout.
const HELD_DISTINCT_SHARE: f64 = 0.9;

/// Samples a logger repeated instead of reading (the repeats, not the first read of a held
/// value), in one channel. A run of [`MIN_HELD_RUN`] to [`MAX_HELD_RUN`] exactly equal values
/// counts where the signal around it moves: of the [`HELD_AROUND`] samples on each side and
/// the held value, at least 90 % distinct, and the held value not the channel's smallest or
/// largest. Why: a converter repeats a code only while its signal stays within one quantum,
/// and then its neighbours revisit codes too (noise on coarse codes at rest, a slow creep up a
/// staircase); where every neighbour differs, the signal moves by more than a quantum per
/// sample and five equal reads are the logger's. A run at the channel's extreme is a rail or a
/// clamp, said apart.
pub fn held_values(v: &[f64]) -> Vec<bool> {
    let n = v.len();
    let mut held = vec![false; n];
    let (lo, hi) = v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |m, x| {
        (m.0.min(*x), m.1.max(*x))
    });
    let mut a = 0;
    while a < n {
        let len = v[a..].iter().take_while(|x| **x == v[a]).count().max(1);
        let (b0, c1) = (
            a.saturating_sub(HELD_AROUND),
            (a + len + HELD_AROUND).min(n),
        );
        if (MIN_HELD_RUN..=MAX_HELD_RUN).contains(&len)
            && v[a] != lo
            && v[a] != hi
            && a > 0
            && a + len < n
            && c1 - b0 - len >= HELD_AROUND
        {
            let mut around: Vec<f64> = v[b0..a].iter().chain(&v[a + len..c1]).copied().collect();
            around.push(v[a]);
            around.sort_by(f64::total_cmp);
            let count = around.len();
            around.dedup();
            if around.len() as f64 >= HELD_DISTINCT_SHARE * count as f64 {
                held[a + 1..a + len].iter_mut().for_each(|h| *h = true);
            }
        }
        a += len;
    }
    held
}

/// Contiguous runs of `true` in a mask.
pub fn runs_of(mask: &[bool]) -> usize {
    mask.iter()
        .enumerate()
        .filter(|(i, x)| **x && (*i == 0 || !mask[i - 1]))
        .count()
}

/// Each run of `held` samples of `v` replaced by the line from the read before it to the read
/// after it: where a model's input (the force) was held, its history needs a value at every
/// sample, and the line is the closest guess at one (the held one lags the signal).
pub fn bridge_held(v: &mut [f64], held: &[bool]) {
    let n = v.len().min(held.len());
    let mut k = 0;
    while k < n {
        if !held[k] || k == 0 {
            k += 1;
            continue;
        }
        let end = (k..n).find(|&j| !held[j]).unwrap_or(n);
        if end < n {
            let (a, b, span) = (v[k - 1], v[end], (end - k + 1) as f64);
            for (i, x) in v[k..end].iter_mut().enumerate() {
                *x = a + (b - a) * (i + 1) as f64 / span;
            }
        }
        k = end;
    }
}

impl Record {
    /// Samples the logger repeated in the force or the strain ([`held_values`]).
    pub fn held_values(&self) -> Vec<bool> {
        held_values(&self.force_g)
            .into_iter()
            .zip(held_values(&self.strain_pct))
            .map(|(f, s)| f || s)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{parse_record, RecordError};
    use std::path::Path;

    fn parse(text: &str) -> Result<Record, RecordError> {
        parse_record(text.as_bytes(), Path::new("log.csv"))
    }

    /// A reproducible uniform draw in [0, 1) (SplitMix64; the crate needs no generator).
    fn uniform(state: &mut u64) -> f64 {
        *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = *state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// `n` rows at `rate_hz`, each read and stamped up to `late` of a step late, of the sine
    /// `amp·sin(ωt)` (force) and its half (strain) at the stamped time.
    fn logged_sine(seed: u64, rate_hz: f64, n: usize, late: f64, hz: f64, amp: f64) -> String {
        let (mut s, h, w) = (seed, 1.0 / rate_hz, std::f64::consts::TAU * hz);
        let mut text = String::from("# logger=pc\nt_s,force_g,strain_pct\n");
        for k in 0..n {
            let t = (k as f64 + late * uniform(&mut s)) * h;
            let v = amp * (w * t).sin();
            text.push_str(&format!("{t:.9},{v:.9},{:.9}\n", v / 2.0));
        }
        text
    }

    #[test]
    fn a_sine_stamped_up_to_80_percent_late_is_resampled_onto_it() {
        for (seed, rate_hz, n) in [(1, 800.0, 4000), (2, 100.0, 1500), (3, 1000.0, 10_000)] {
            // A tone at a twentieth of the rate: ωh = 0.314.
            let (hz, amp) = (rate_hz / 20.0, 10.0);
            let r = parse(&logged_sine(seed, rate_hz, n, 0.8, hz, amp)).unwrap();
            let rs = r.resampling.clone().unwrap();
            // Uniform lateness over 0.8 of a step spreads the stamps by nearly 0.8 about the
            // grid that fits them (the fit's own wobble is a few thousandths).
            assert!((0.7..0.82).contains(&rs.jitter_share), "{seed}: {rs:?}");
            assert!((r.jitter() - rs.jitter_share).abs() < 1e-12);
            let step = rs.resampled_step_s.unwrap();
            assert!((step * rate_hz - 1.0).abs() < 1e-3, "{seed}: {step}");
            assert!((r.sample_period_s().unwrap() - step).abs() < 1e-9);
            // Linear interpolation between stamps at most 1.8 steps apart misses a sine by at
            // most ω²d²/8·A (the curvature over the span): 0.04 A here. Reading the stamps as
            // even instead would miss it by up to ω·0.4h·A = 0.126 A.
            let w = std::f64::consts::TAU * hz;
            let bound = w * w * (1.8 * step).powi(2) / 8.0 * amp + 1e-6;
            let worst = r
                .t_s
                .iter()
                .zip(&r.force_g)
                .map(|(t, v)| (v - amp * (w * t).sin()).abs())
                .fold(0.0, f64::max);
            assert!(worst <= bound, "{seed}: {worst} > {bound}");
            assert!(worst > 0.0 && r.force_g.iter().all(|v| v.is_finite()));
            assert!((r.strain_pct[n / 2] - r.force_g[n / 2] / 2.0).abs() < 1e-6);
            // The record runs to its last stamp: about as many samples as rows.
            assert!(r.len() + 2 >= n && r.len() <= n, "{seed}: {}", r.len());
        }
    }

    #[test]
    fn rows_stamped_alike_are_averaged_into_one() {
        let r = parse(
            "t_s,force_g,strain_pct,drive_g\n0.00,1,0.1,7\n0.01,2,0.2,8\n0.01,4,0.5,8\n\
             0.01,9,0.2,11\n0.02,5,0.3,9\n",
        )
        .unwrap();
        assert_eq!(r.t_s, vec![0.0, 0.01, 0.02]);
        // (2 + 4 + 9)/3 = 5, (0.2 + 0.5 + 0.2)/3 = 0.3, (8 + 8 + 11)/3 = 9.
        assert_eq!(r.force_g, vec![1.0, 5.0, 5.0]);
        assert!((r.strain_pct[1] - 0.3).abs() < 1e-12);
        assert_eq!(r.column("drive_g"), Some(&[7.0, 9.0, 9.0][..]));
        let rs = r.resampling.unwrap();
        assert_eq!((rs.merged_duplicates, rs.resampled_step_s), (2, None));
        // Two rows at one time only: one sample, too few.
        assert!(parse("t_s,force_g,strain_pct\n0,1,1\n0,2,2\n").is_err());
    }

    #[test]
    fn a_gap_of_four_steps_is_refused_at_its_line_and_jitter_is_not() {
        for seed in [4, 5, 6] {
            let text = logged_sine(seed, 800.0, 2000, 0.8, 5.0, 3.0);
            assert!(parse(&text).is_ok(), "{seed}");
            // Rows 1000 to 1002 left out: a step of about four.
            let mut lines: Vec<&str> = text.lines().collect();
            lines.drain(1002..1005);
            let e = parse(&lines.join("\n")).unwrap_err();
            assert!(e.message.contains("a gap of 0.00"), "{e}");
            assert!(e.message.contains("split the record there"), "{e}");
            // The row after the gap: row 1003, now on the file's line 1003 (two lines before
            // the rows, three rows fewer).
            assert_eq!(
                (e.line, e.column.as_deref()),
                (Some(1003), Some("t_s")),
                "{e}"
            );
        }
    }

    #[test]
    fn odd_time_stamps_are_refused_or_read_never_a_panic() {
        let cases = [
            "0,1e308,-1e308",
            "0,1e-300,2e-300,3e-300",
            "1e15,1e15,1e15,1e15",
            "0,1,1.5,1.5000000001,4",
            "5,4",
            "-1e308,0,1e308",
        ];
        for case in cases {
            let mut text = String::from("t_s,force_g,strain_pct\n");
            for t in case.split(',') {
                text.push_str(&format!("{t},1,2\n"));
            }
            match parse(&text) {
                Ok(r) => assert!(
                    r.t_s.iter().chain(&r.force_g).all(|v| v.is_finite()) && r.jitter().is_finite(),
                    "{case}: {r:?}"
                ),
                Err(e) => assert!(!e.message.is_empty()),
            }
        }
    }

    /// A mask's count of `true`.
    fn count(mask: &[bool]) -> usize {
        mask.iter().filter(|x| **x).count()
    }

    #[test]
    fn held_values_are_found_where_the_signal_moves() {
        let mut s = 7u64;
        // A slow sine with noise, fine codes: every run of repeats is the logger's.
        let mut v: Vec<f64> = (0..8000)
            .map(|k| 20.0 * (k as f64 * 0.002).sin() + 0.1 * (uniform(&mut s) - 0.5))
            .collect();
        let (mut injected, mut runs, mut a) = (0, 0, 300);
        while a + 60 < v.len() {
            let repeats = 4 + (uniform(&mut s) * 46.0) as usize;
            let held = v[a];
            v[a + 1..=a + repeats].iter_mut().for_each(|x| *x = held);
            injected += repeats;
            runs += 1;
            a += 700 + (uniform(&mut s) * 200.0) as usize;
        }
        let mask = held_values(&v);
        assert_eq!(count(&mask), injected);
        assert_eq!(runs_of(&mask), runs);
        // Coarse codes at rest with noise, a slow staircase, a rail: the sensor's own repeats.
        let rest: Vec<f64> = (0..8000)
            .map(|_| (50.0 + 0.8 * (uniform(&mut s) - 0.5)).round() * 0.1)
            .collect();
        let stair: Vec<f64> = (0..8000).map(|k| (k as f64 * 0.07).round() * 0.1).collect();
        let railed: Vec<f64> = (0..8000)
            .map(|k| (k as f64 * 0.01).sin().min(0.9))
            .collect();
        for v in [rest, stair, railed] {
            assert_eq!(count(&held_values(&v)), 0);
        }
        assert!(held_values(&[]).is_empty() && held_values(&[1.0; 20]).iter().all(|x| !x));
    }

    #[test]
    fn a_held_run_is_bridged_by_the_line_between_its_reads() {
        let mut v = [0.0, 1.0, 1.0, 1.0, 1.0, 5.0, 6.0];
        let held = [false, false, true, true, true, false, false];
        bridge_held(&mut v, &held);
        // From 1 (the read) to 5 (the next) in four steps.
        assert_eq!(v, [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        // A run to the end has no read after it: left as held.
        let mut w = [0.0, 1.0, 1.0];
        bridge_held(&mut w, &[false, false, true]);
        assert_eq!(w, [0.0, 1.0, 1.0]);
    }

    #[test]
    fn the_shared_records_have_no_held_values() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
        let mut read = 0;
        for dir in [root.clone(), root.join("real")] {
            let Ok(entries) = std::fs::read_dir(&dir) else {
                continue;
            };
            for path in entries.flatten().map(|e| e.path()) {
                if path.extension().is_some_and(|x| x == "csv") {
                    let r = crate::read_record(&path).unwrap();
                    assert_eq!(count(&r.held_values()), 0, "{}", path.display());
                    assert_eq!(r.resampling, None, "{}", path.display());
                    read += 1;
                }
            }
        }
        eprintln!("{read} shared records checked");
    }
}
