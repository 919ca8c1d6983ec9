//! Identification of the applicator from a record of the excitation protocol (issue 13, item
//! 1): its frequency response from the amplifier's drive to the gauge, and its resonances — the
//! first step of a controller designed from the rig rather than from the memo.
//!
//! The record is the closed loop's (the force law holds the probe at the preload while a chirp
//! is added to the drive after the loop's filter: a chirp on the command would be filtered out
//! before it reached the beam mode), so the response is taken as the ratio of the gauge's and
//! the drive's spectra, each averaged over whole periods of the chirp: noise that is not
//! periodic averages out of both, and the ratio is the plant's whatever the loop around it.
//! The resonances are picked from the measured response (peak and half-power bandwidth); a
//! parametric model for the controller's design is next.

use num_complex::Complex64;
use serde::Serialize;
use tactile_core::control::ActuatorConfig;
use tactile_core::gauge::AdcCode;
use tactile_core::profile::{
    Protocol, EXCITATION_END_HZ, EXCITATION_PERIOD_S, EXCITATION_SETTLE_S, EXCITATION_START_HZ,
};

use crate::rig::{TickRecord, TICK_S};

/// Why a record cannot be identified.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum IdentifyError {
    #[error("not a record of the excitation protocol")]
    NotTheExcitation,
    #[error(
        "the record holds {have} whole periods of the chirp after the first; at least 2 are needed"
    )]
    TooFewPeriods { have: usize },
    #[error("the drive does not move at {hz} Hz: nothing to identify there")]
    NoDrive { hz: f64 },
}

/// One frequency of the measured response.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ResponsePoint {
    pub hz: f64,
    /// Gauge grams per gram of drive.
    pub re: f64,
    pub im: f64,
}

impl ResponsePoint {
    pub fn value(&self) -> Complex64 {
        Complex64::new(self.re, self.im)
    }
}

/// Measured frequency response from drive (g) to gauge (g), at each whole hertz of the chirp's
/// band, from the ticks of an excitation run.
pub fn frequency_response(
    ticks: &[TickRecord],
    protocol: Protocol,
    actuator: &ActuatorConfig,
) -> Result<Vec<ResponsePoint>, IdentifyError> {
    let Protocol::Excitation { .. } = protocol else {
        return Err(IdentifyError::NotTheExcitation);
    };
    let per = (f64::from(EXCITATION_PERIOD_S) / TICK_S).round() as usize;
    // The first period lets the loop settle into the periodic response.
    let start = (f64::from(EXCITATION_SETTLE_S) / TICK_S).round() as usize + per;
    let periods = ticks.len().saturating_sub(start) / per;
    if periods < 2 {
        return Err(IdentifyError::TooFewPeriods { have: periods });
    }
    let drive: Vec<f64> = ticks
        .iter()
        .map(|t| f64::from(actuator.force_g(AdcCode(t.dac_code))))
        .collect();
    let gauge: Vec<f64> = ticks.iter().map(|t| f64::from(t.sensed_g)).collect();
    let lo = EXCITATION_START_HZ.ceil() as usize;
    let hi = (EXCITATION_END_HZ as usize).min(per / 2 - 1);
    let mut out = Vec::new();
    for bin in lo..hi {
        let w = 2.0 * std::f64::consts::PI * bin as f64 / per as f64;
        let twiddle: Vec<Complex64> = (0..per)
            .map(|i| Complex64::from_polar(1.0, -w * i as f64))
            .collect();
        let dft = |x: &[f64]| -> Complex64 { x.iter().zip(&twiddle).map(|(v, t)| t * v).sum() };
        // Each period's spectrum, summed: the mean's ratio is the same as the sums'.
        let (mut u, mut y) = (Complex64::new(0.0, 0.0), Complex64::new(0.0, 0.0));
        for p in 0..periods {
            let range = start + p * per..start + (p + 1) * per;
            u += dft(&drive[range.clone()]);
            y += dft(&gauge[range]);
        }
        if u.norm() < 1e-9 * (per * periods) as f64 {
            return Err(IdentifyError::NoDrive {
                hz: bin as f64 / (per as f64 * TICK_S),
            });
        }
        let g = y / u;
        out.push(ResponsePoint {
            hz: bin as f64 / (per as f64 * TICK_S),
            re: g.re,
            im: g.im,
        });
    }
    Ok(out)
}

/// A resonance of the measured response.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Mode {
    /// Peak of |G|, Hz (parabolic interpolation between the whole hertz).
    pub hz: f64,
    /// From the half-power bandwidth, ζ ≈ Δf / 2f (`None` where |G| does not fall by √2 on
    /// both sides before the next mode).
    pub damping_ratio: Option<f64>,
    /// |G| at the peak over |G| at the lowest measured frequency.
    pub gain_over_static: f64,
}

/// The `count` clearest resonances (peak picking): local maxima of |G| ranked by how far they
/// stand above the lowest |G| within 30 % of their frequency on either side (the higher of the
/// two valleys, where the band allows; at least 1.5 times), each at least a factor 1.5 in
/// frequency from a clearer one; in increasing frequency. Ranked by prominence, not height:
/// the chirp's harmonics through the motor's stiction make low, broad bumps.
pub fn modes(response: &[ResponsePoint], count: usize) -> Vec<Mode> {
    // |G| through a 5-point median: a single bin that a harmonic of the chirp lands on is
    // not a resonance.
    let raw: Vec<f64> = response.iter().map(|p| p.value().norm()).collect();
    let mag: Vec<f64> = (0..raw.len())
        .map(|i| {
            let mut w: Vec<f64> = raw[i.saturating_sub(2)..(i + 3).min(raw.len())].to_vec();
            w.sort_by(f64::total_cmp);
            w[w.len() / 2]
        })
        .collect();
    let (band_lo, band_hi) = match (response.first(), response.last()) {
        (Some(a), Some(b)) => (a.hz, b.hz),
        _ => return Vec::new(),
    };
    let prominence = |i: usize| -> f64 {
        let hz = response[i].hz;
        let valley = |lo: f64, hi: f64| {
            response
                .iter()
                .zip(&mag)
                .filter(|(p, _)| (lo..=hi).contains(&p.hz))
                .map(|(_, m)| *m)
                .fold(f64::INFINITY, f64::min)
        };
        let left = (hz * 0.7 >= band_lo).then(|| valley(0.7 * hz, hz));
        let right = (hz * 1.3 <= band_hi).then(|| valley(hz, 1.3 * hz));
        let floor = match (left, right) {
            (Some(l), Some(r)) => l.max(r),
            (Some(x), None) | (None, Some(x)) => x,
            (None, None) => return 0.0,
        };
        mag[i] / floor
    };
    let mut maxima: Vec<(usize, f64)> = (1..mag.len().saturating_sub(1))
        .filter(|&i| mag[i] > mag[i - 1] && mag[i] >= mag[i + 1])
        .map(|i| (i, prominence(i)))
        .filter(|(_, p)| *p >= 1.5)
        .collect();
    maxima.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut kept: Vec<usize> = Vec::new();
    for (i, _) in maxima {
        let hz = response[i].hz;
        let apart = |k: &usize| {
            let other = response[*k].hz;
            hz / other > 1.5 || other / hz > 1.5
        };
        if kept.len() < count && kept.iter().all(apart) {
            kept.push(i);
        }
    }
    kept.sort_unstable();
    let base = mag.first().copied().unwrap_or(f64::NAN);
    kept.iter()
        .map(|&i| {
            // Parabola through the peak and its neighbours (the grid is 1 Hz).
            let (a, b, c) = (mag[i - 1], mag[i], mag[i + 1]);
            let step = response[i + 1].hz - response[i].hz;
            let denom = a - 2.0 * b + c;
            let shift = if denom < 0.0 {
                0.5 * (a - c) / denom
            } else {
                0.0
            };
            let hz = response[i].hz + shift * step;
            let half = b / std::f64::consts::SQRT_2;
            // Where |G| crosses the half-power level on each side, interpolated.
            let cross = |range: &mut dyn Iterator<Item = usize>| -> Option<f64> {
                let mut prev = i;
                for k in range {
                    if mag[k] > b {
                        return None;
                    }
                    if mag[k] <= half {
                        let t = (mag[prev] - half) / (mag[prev] - mag[k]);
                        return Some(response[prev].hz + t * (response[k].hz - response[prev].hz));
                    }
                    prev = k;
                }
                None
            };
            let lo = cross(&mut (0..i).rev());
            let hi = cross(&mut (i + 1..mag.len()));
            Mode {
                hz,
                damping_ratio: lo.zip(hi).map(|(l, h)| (h - l) / (2.0 * hz)),
                gain_over_static: b / base,
            }
        })
        .collect()
}
