//! Identification of the applicator from a record of the excitation protocol: its frequency
//! response from the amplifier's drive to the gauge, and its resonances — the
//! first step of a controller designed from the rig rather than from the memo.
//!
//! The record is the closed loop's (the force law holds the probe at the preload while a chirp
//! is added to the drive after the loop's filter: a chirp on the command would be filtered out
//! before it reached the beam mode), so the response is taken as the ratio of the gauge's and
//! the drive's spectra, each averaged over whole periods of the chirp: noise that is not
//! periodic averages out of both, and the ratio is the plant's whatever the loop around it.
//! The resonances are picked from the measured response (peak and half-power bandwidth), and
//! a low-order model of the two-mass plant is fitted to it ([`fit_model`]); the controller
//! designed from that model is next.

use num_complex::Complex64;
use serde::Serialize;
use tactile_core::control::ActuatorConfig;
use tactile_core::gauge::AdcCode;
use tactile_core::profile::{
    Protocol, EXCITATION_END_HZ, EXCITATION_PERIOD_S, EXCITATION_SETTLE_S, EXCITATION_START_HZ,
};

use crate::rig::TickRecord;
use tactile_core::CONTROL_PERIOD_S;

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
    #[error("the probe left the finger at {t_s:.2} s: the response is then not the plant's (a smaller chirp or a larger preload keeps it on)")]
    LostContact { t_s: f64 },
    #[error("the supervisor stopped the drive at {t_s:.2} s ({faults})")]
    Faulted { t_s: f64, faults: String },
    #[error("the record has no drive_g column: the drive is what the response is taken against (the simulator's and the decoder's records carry it)")]
    NoDriveColumn,
    #[error("the gauge reads {gauge_g:.2} g during the hold before the chirp, not the {preload_g} g commanded (within {tolerance_g:.1} g): a loop that did not hold the preload, or a gauge that does not read the force")]
    HoldOffPreload {
        preload_g: f32,
        gauge_g: f64,
        tolerance_g: f64,
    },
    #[error("the hold before the chirp drives {drive_g:.2} g for {gauge_g:.2} g at the gauge: an applicator's static gain is within 0.2–5, so the drive column is not the drive")]
    HoldDrive { drive_g: f64, gauge_g: f64 },
    #[error("no still hold before the chirp: the record is shorter than the settling, or its drive or gauge is not finite there")]
    NoHold,
    #[error("the record is sampled at {hz:.1} Hz: identification needs whole samples in the chirp's 1 s period and the chirp's 301 Hz under half the rate (record at 1000 Hz)")]
    SampleRate { hz: f64 },
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
    period_means(ticks, protocol, actuator)?.response()
}

/// The drive and gauge of an excitation run over its analysed periods ([`PeriodMeans`]), the
/// run checked as [`frequency_response`] checks it.
pub fn period_means(
    ticks: &[TickRecord],
    protocol: Protocol,
    actuator: &ActuatorConfig,
) -> Result<PeriodMeans, IdentifyError> {
    let Protocol::Excitation { .. } = protocol else {
        return Err(IdentifyError::NotTheExcitation);
    };
    let start = analysed_from(CONTROL_PERIOD_S);
    let faulted: Vec<bool> = ticks.iter().map(|t| !t.faults.is_empty()).collect();
    if let Some(i) = first_of_run_into(&faulted, start) {
        return Err(IdentifyError::Faulted {
            t_s: ticks[i].t_s,
            faults: format!("{:?}", ticks[i].faults),
        });
    }
    let off: Vec<bool> = ticks.iter().map(|t| !t.in_contact).collect();
    if let Some(i) = first_of_run_into(&off, start) {
        return Err(IdentifyError::LostContact { t_s: ticks[i].t_s });
    }
    let drive: Vec<f64> = ticks
        .iter()
        .map(|t| f64::from(actuator.force_g(AdcCode(t.dac_code))))
        .collect();
    let gauge: Vec<f64> = ticks.iter().map(|t| f64::from(t.sensed_g)).collect();
    PeriodMeans::of(&drive, &gauge, CONTROL_PERIOD_S)
}

/// The still hold at the preload before the chirp (its last 0.5 s), in g.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hold {
    /// Mean drive and mean gauge force: across preloads the applicator's static gain and its
    /// stiction ([`static_line`]).
    pub drive_g: f64,
    pub gauge_g: f64,
    /// The gauge's noise, RMS of one reading: of the readings' successive differences over
    /// √2, which a slow drift of the held force (the finger creeping under a stuck motor)
    /// leaves out and white noise keeps (a difference of two draws has twice the variance).
    pub noise_g: f64,
}

impl Hold {
    /// The hold if it is what holding `preload_g` looks like: the gauge within
    /// [`HOLD_TOLERANCE`] of it (2 g and a fifth: A1's steady error, no integral, is under
    /// 1 g), the drive within a factor 2 of the gauge.
    pub fn at_preload(self, preload_g: f32) -> Result<Hold, IdentifyError> {
        let tolerance_g = HOLD_TOLERANCE.0 + HOLD_TOLERANCE.1 * f64::from(preload_g);
        if (self.gauge_g - f64::from(preload_g)).abs() > tolerance_g {
            return Err(IdentifyError::HoldOffPreload {
                preload_g,
                gauge_g: self.gauge_g,
                tolerance_g,
            });
        }
        let (lo, hi) = STATIC_GAIN_RANGE;
        if !(lo..=hi).contains(&(self.gauge_g / self.drive_g)) {
            return Err(IdentifyError::HoldDrive {
                drive_g: self.drive_g,
                gauge_g: self.gauge_g,
            });
        }
        Ok(self)
    }
}

/// Gauge grams per drive gram an applicator can have, the drive in the firmware's grams (the
/// memo's drive at 0.98): a torque constant ×0.6–1.5, an amplifier of 0.12–0.28 A/V and an arm
/// of 6–12 cm span 0.28–3.3; a hold's ratio or a fitted gain outside is not an applicator's.
pub const STATIC_GAIN_RANGE: (f64, f64) = (0.2, 5.0);

/// How far the hold's gauge may be from the preload: grams, and a share of the preload.
pub const HOLD_TOLERANCE: (f64, f64) = (2.0, 0.2);

/// The hold before the chirp; `None` if it is not in the record.
pub fn hold_means(ticks: &[TickRecord], actuator: &ActuatorConfig) -> Option<Hold> {
    let drive: Vec<f64> = ticks
        .iter()
        .map(|t| f64::from(actuator.force_g(AdcCode(t.dac_code))))
        .collect();
    let gauge: Vec<f64> = ticks.iter().map(|t| f64::from(t.sensed_g)).collect();
    hold_means_of(&drive, &gauge, CONTROL_PERIOD_S)
}

/// [`hold_means`] of a record of the excitation (its `drive_g` column and gauge force).
pub fn hold_means_of_record(rec: &tactile_record::Record) -> Option<Hold> {
    hold_means_of(rec.column("drive_g")?, &rec.force_g, record_dt_s(rec)?)
}

/// The excitation's preload in a record: its command, which holds still from half the
/// settling time to the end (`None` for a record of another protocol).
pub fn preload_of_record(rec: &tactile_record::Record) -> Option<f32> {
    let from = (0.5 * f64::from(EXCITATION_SETTLE_S) / record_dt_s(rec)?).ceil() as usize;
    let held = rec.column("command_g")?.get(from..)?;
    let command = *held.first()?;
    let still = held.iter().all(|c| (c - command).abs() <= 1e-3);
    (still && command.is_finite() && command > 0.0).then_some(command as f32)
}

fn hold_means_of(drive: &[f64], gauge: &[f64], dt_s: f64) -> Option<Hold> {
    let end = (f64::from(EXCITATION_SETTLE_S) / dt_s).round() as usize;
    let start = end.checked_sub((0.5 / dt_s) as usize)?;
    let (drive, gauge) = (drive.get(start..end)?, gauge.get(start..end)?);
    let n = drive.len() as f64;
    let steps = gauge.windows(2).map(|w| (w[1] - w[0]).powi(2));
    let noise_g = (steps.sum::<f64>() / (2.0 * (n - 1.0).max(1.0))).sqrt();
    let hold = Hold {
        drive_g: drive.iter().sum::<f64>() / n,
        gauge_g: gauge.iter().sum::<f64>() / n,
        noise_g,
    };
    [hold.drive_g, hold.gauge_g, noise_g]
        .iter()
        .all(|v| v.is_finite())
        .then_some(hold)
}

/// A record's sample period from its first and last times.
fn record_dt_s(rec: &tactile_record::Record) -> Option<f64> {
    match rec.t_s.as_slice() {
        [a, .., b] if b > a => Some((b - a) / (rec.t_s.len() - 1) as f64),
        _ => None,
    }
}

/// One preload's static reading, (drive, gauge) in grams: the hold before the chirp, reached
/// from below, and the means over the chirp's whole periods.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StaticPoint {
    pub hold: (f64, f64),
    pub chirp: (f64, f64),
}

/// The applicator's static line gauge = gain·drive − friction from the preloads' readings:
/// (gain, stiction), and whether the chirps gave the gain.
///
/// Each hold is reached from below and stops where the drive stopped overcoming friction, so
/// where all stop alike the stiction is an offset and the line through the holds is right
/// (one hold alone read the memo rig's gain 0.90 at 10 g and 0.99 at 100 g). But a hold stops
/// anywhere within the friction band: on a rig with 2.9 g of stiction the 10 g hold held
/// 2.7 g of it and the 100 g hold 1.4 g, which the holds' line read as a gain 1.2 % high. The
/// chirps' means do not: over whole periods the inertia and the viscous friction average to
/// nothing, and the chirp slides the motor both ways, so the Coulomb friction nearly does too.
/// Where the two gains differ by over [`HOLDS_AGREE`], the chirps' gain is taken, and the
/// stiction is the most friction a hold stopped with at that gain, the band's edge (the holds
/// deep in it read 1.4–2.2 g of that rig's 2.8 g; their median read its stiction 21 % low and
/// its 10 g sine about 100 g lost 0.7 dB); else the holds' line, with which the design's
/// friction shares were measured. `None` for fewer than
/// two preloads or a line that is not a rig's (gain not positive).
pub fn static_line(points: &[StaticPoint]) -> Option<StaticLine> {
    let (drive, gauge): (Vec<f64>, Vec<f64>) = points.iter().map(|p| p.hold).unzip();
    let (offset, held_gain) = tactile_ident::stats::line(&drive, &gauge)?;
    let held_gain = Some(held_gain).filter(|g| *g > 0.0)?;
    let (drive, gauge): (Vec<f64>, Vec<f64>) = points.iter().map(|p| p.chirp).unzip();
    let chirp_gain = tactile_ident::stats::line(&drive, &gauge).map(|(_, g)| g);
    let Some(gain) = chirp_gain.filter(|g| *g > 0.0 && (g / held_gain - 1.0).abs() > HOLDS_AGREE)
    else {
        return Some(((held_gain, (-offset).max(0.0)), false));
    };
    // A hold reached from below stops at most the stiction short of the friction-free line.
    let edge = points
        .iter()
        .map(|p| gain * p.hold.0 - p.hold.1)
        .fold(0.0, f64::max);
    Some(((gain, edge), true))
}

/// [`static_line`]'s (gain, stiction), and whether the chirps gave the gain.
pub type StaticLine = ((f64, f64), bool);

/// How far the holds' gain may be from the chirps' for the holds' line to stand: 0.3 %, 0.3 g
/// at 100 g, under a third of a step's ±1 g (the memo rig's differ by 0.04 %, a rig whose holds
/// stop 1.4 g apart in its band by 1.2 %).
pub const HOLDS_AGREE: f64 = 0.003;

/// The first sample analysed at sample period `dt_s`: after the settling and one period that
/// lets the loop settle into the periodic response.
fn analysed_from(dt_s: f64) -> usize {
    let per = (f64::from(EXCITATION_PERIOD_S) / dt_s).round() as usize;
    (f64::from(EXCITATION_SETTLE_S) / dt_s).round() as usize + per
}

/// [`frequency_response`] from a record of the excitation (`tactile experiment excitation
/// --record-hz 1000`): its `drive_g` column against its gauge force, the `faults` and `contact`
/// columns checked where the record has them.
pub fn frequency_response_of_record(
    rec: &tactile_record::Record,
) -> Result<Vec<ResponsePoint>, IdentifyError> {
    period_means_of_record(rec)?.response()
}

/// [`period_means`] of a record of the excitation, checked as
/// [`frequency_response_of_record`] checks it.
pub fn period_means_of_record(rec: &tactile_record::Record) -> Result<PeriodMeans, IdentifyError> {
    let drive = rec.column("drive_g").ok_or(IdentifyError::NoDriveColumn)?;
    let dt_s = record_dt_s(rec).ok_or(IdentifyError::TooFewPeriods { have: 0 })?;
    let per = f64::from(EXCITATION_PERIOD_S) / dt_s;
    // Whole samples per period, and the chirp's top under the record's Nyquist rate.
    if (per - per.round()).abs() > 1e-3 * per || 0.5 / dt_s <= f64::from(EXCITATION_END_HZ) {
        return Err(IdentifyError::SampleRate { hz: 1.0 / dt_s });
    }
    let start = analysed_from(dt_s);
    if let Some(faults) = rec.column("faults") {
        let faulted: Vec<bool> = faults.iter().map(|f| *f != 0.0).collect();
        if let Some(i) = first_of_run_into(&faulted, start) {
            let flags = tactile_core::telemetry::FaultFlags::from_bits_retain(faults[i] as u16);
            return Err(IdentifyError::Faulted {
                t_s: rec.t_s[i],
                faults: format!("{flags:?}"),
            });
        }
    }
    if let Some(i) = rec.column("contact").and_then(|c| {
        let off: Vec<bool> = c.iter().map(|v| *v == 0.0).collect();
        first_of_run_into(&off, start)
    }) {
        return Err(IdentifyError::LostContact { t_s: rec.t_s[i] });
    }
    PeriodMeans::of(drive, &rec.force_g, dt_s)
}

/// Where the run of `set` samples that reaches into the analysed part (from `start`) began:
/// what an error names (a fault latched in the first, settling period is reported when it
/// happened, not where the analysis starts).
fn first_of_run_into(set: &[bool], start: usize) -> Option<usize> {
    let first = (start..set.len()).find(|&i| set[i])?;
    let began = (0..first).rev().take_while(|&i| set[i]).last();
    Some(began.unwrap_or(first))
}

/// The drive and the gauge averaged over the whole periods of the chirp analysed, one period
/// of each, g: what the response is the ratio of (noise that is not periodic averages out).
#[derive(Clone, Debug, Serialize)]
pub struct PeriodMeans {
    pub drive_g: Vec<f64>,
    pub gauge_g: Vec<f64>,
    pub dt_s: f64,
}

impl PeriodMeans {
    /// Whole periods of drive and gauge sampled every `dt_s`, averaged.
    pub fn of(drive: &[f64], gauge: &[f64], dt_s: f64) -> Result<Self, IdentifyError> {
        let per = (f64::from(EXCITATION_PERIOD_S) / dt_s).round() as usize;
        let start = analysed_from(dt_s);
        let periods = drive.len().min(gauge.len()).saturating_sub(start) / per;
        if periods < 2 {
            return Err(IdentifyError::TooFewPeriods { have: periods });
        }
        let mean = |x: &[f64]| -> Vec<f64> {
            (0..per)
                .map(|i| (0..periods).map(|p| x[start + p * per + i]).sum::<f64>() / periods as f64)
                .collect()
        };
        Ok(Self {
            drive_g: mean(drive),
            gauge_g: mean(gauge),
            dt_s,
        })
    }

    /// The model fitted to the response of the drive less `stiction_g` of Coulomb friction
    /// ([`Self::less_friction`]): where the fit with the friction simulated starts, for the
    /// design and `tactile identify` alike (the amplifier's pole held at `pole_hz` where given).
    pub fn fit_less_friction(
        &self,
        stiction_g: f64,
        pole_hz: Option<f64>,
    ) -> Option<ApplicatorModel> {
        fit_model_with_pole(&self.less_friction(stiction_g).response().ok()?, pole_hz)
    }

    /// The drive less the motor's Coulomb friction, `stiction_g` against the motor's motion,
    /// referred to the drive: what the linear part of the plant was driven with. A chirp small
    /// enough to keep the probe on the finger moves the motor little, and the friction it
    /// meets reads as damping of the modes in the plain ratio (the memo rig's inertia–finger
    /// mode at 10 g: ζ 0.14 plain, 0.08 less the friction, 0.07 linearized without it); a
    /// feed-forward built on the plain ratio carries that damping, and with its friction
    /// compensation counted the friction twice (a quarter of the stiction was all it could
    /// take, and a 2 g sine about 10 g stuck from 25 Hz).
    ///
    /// The motor's motion is read from the gauge: below the beam's mode the motor and the tip
    /// move together and the gauge follows the contact, above it the tip hardly moves and the
    /// gauge follows the motor; either way the motor moves as the gauge's force changes. The
    /// direction is the gauge's change over the next two samples (the friction acts on the
    /// motor at once; the drive reaches it through the amplifier's pole a tick later).
    pub fn less_friction(&self, stiction_g: f64) -> Self {
        let n = self.gauge_g.len();
        let drive_g = (0..n)
            .map(|i| {
                let change = self.gauge_g[(i + 2) % n] - self.gauge_g[i];
                self.drive_g[i] - stiction_g * change.signum()
            })
            .collect();
        Self {
            drive_g,
            gauge_g: self.gauge_g.clone(),
            dt_s: self.dt_s,
        }
    }

    /// The response from drive to gauge at each whole hertz of the chirp's band.
    pub fn response(&self) -> Result<Vec<ResponsePoint>, IdentifyError> {
        let per = self.drive_g.len().min(self.gauge_g.len());
        let spectrum = Spectrum::of(self);
        let (u, y) = (
            spectrum.transform(&self.drive_g),
            spectrum.transform(&self.gauge_g),
        );
        let mut out = Vec::with_capacity(spectrum.hz.len());
        for ((&hz, u), y) in spectrum.hz.iter().zip(&u).zip(&y) {
            if u.norm() < 1e-9 * per as f64 {
                return Err(IdentifyError::NoDrive { hz });
            }
            let g = y / u;
            out.push(ResponsePoint {
                hz,
                re: g.re,
                im: g.im,
            });
        }
        Ok(out)
    }

    /// The drive less its mean over the period: the part that moves the plant about the
    /// preload (its mean holds the preload, and the friction's band takes it anywhere).
    pub(crate) fn centred_drive_g(&self) -> Vec<f64> {
        let mean = self.drive_g.iter().sum::<f64>() / self.drive_g.len().max(1) as f64;
        self.drive_g.iter().map(|d| d - mean).collect()
    }
}

/// The chirp's band in one period of [`PeriodMeans`]: each whole hertz from
/// [`EXCITATION_START_HZ`] to [`EXCITATION_END_HZ`] (or under half the rate), and the period's
/// twiddles at each, for every transform taken there (the measured response's, and the
/// simulated gauge's of [`crate::stick_slip`]).
pub(crate) struct Spectrum {
    pub(crate) hz: Vec<f64>,
    twiddles: Vec<Vec<Complex64>>,
}

impl Spectrum {
    pub(crate) fn of(means: &PeriodMeans) -> Self {
        let per = means.drive_g.len().min(means.gauge_g.len());
        let lo = EXCITATION_START_HZ.ceil() as usize;
        let hi = (EXCITATION_END_HZ as usize).min((per / 2).saturating_sub(1));
        let bins: Vec<usize> = (lo..hi).collect();
        Self {
            hz: bins
                .iter()
                .map(|&b| b as f64 / (per as f64 * means.dt_s))
                .collect(),
            twiddles: bins
                .iter()
                .map(|&b| {
                    let w = 2.0 * std::f64::consts::PI * b as f64 / per as f64;
                    (0..per)
                        .map(|i| Complex64::from_polar(1.0, -w * i as f64))
                        .collect()
                })
                .collect(),
        }
    }

    /// One period of `x` at each frequency.
    pub(crate) fn transform(&self, x: &[f64]) -> Vec<Complex64> {
        self.twiddles
            .iter()
            .map(|t| t.iter().zip(x).map(|(t, v)| t * v).sum())
            .collect()
    }
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
    // Not in the top twentieth of the band, where the chirp turns back to its start, nor
    // under a tenth of the static response, where what stiction makes of the chirp shows
    // as sharp bumps (a beam mode stands at a third of it or more).
    let top = band_lo + 0.95 * (band_hi - band_lo);
    let least = 0.1 * mag.first().copied().unwrap_or(f64::INFINITY);
    let mut maxima: Vec<(usize, f64)> = (1..mag.len().saturating_sub(1))
        .filter(|&i| mag[i] > mag[i - 1] && mag[i] >= mag[i + 1])
        .filter(|&i| response[i].hz <= top && mag[i] >= least)
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

/// A resonance (or anti-resonance) of the fitted model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Resonance {
    pub hz: f64,
    pub damping_ratio: f64,
}

impl Resonance {
    /// s²/ω² + 2ζs/ω + 1 at `s`.
    fn at(&self, s: Complex64) -> Complex64 {
        let w = 2.0 * std::f64::consts::PI * self.hz;
        s * s / (w * w) + 2.0 * self.damping_ratio * s / w + 1.0
    }
}

/// The applicator's response as a low-order model, drive grams to gauge grams: the motor's
/// inertia on the finger and the beam as two modes, the tip on the finger alone as the
/// anti-resonance between them, the current amplifier's pole, and a delay for the phase the
/// rest leaves (on the simulated rigs it fits as a lead of 0.3–1 ms: what the plant's contact
/// damping and the motor's stiction do to the phase is not in this form):
///
/// ```text
///         K (s²/ωz² + 2ζz s/ωz + 1) e^(−sτ)
/// G(s) = ───────────────────────────────────────────────────────────────
///        (s²/ω₁² + 2ζ₁ s/ω₁ + 1)(s²/ω₂² + 2ζ₂ s/ω₂ + 1)(1 + s/ωa)
/// ```
///
/// the form of the two-mass plant linearized about a load (`analysis::applicator_response`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ApplicatorModel {
    /// Static gain, gauge g per drive g.
    pub gain: f64,
    pub anti_resonance: Resonance,
    /// The inertia–finger mode and the beam's, in increasing frequency.
    pub modes: [Resonance; 2],
    pub pole_hz: f64,
    /// τ, s (negative: a lead).
    pub delay_s: f64,
    /// RMS over the fitted points of |ln(model / measured)| (0.1: about 10 %).
    pub rms_log_error: f64,
}

impl ApplicatorModel {
    /// The model's response at `hz`.
    pub fn response(&self, hz: f64) -> Complex64 {
        let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * hz);
        let pole = 1.0 + s / (2.0 * std::f64::consts::PI * self.pole_hz);
        self.gain * self.anti_resonance.at(s) * (-s * self.delay_s).exp()
            / (self.modes[0].at(s) * self.modes[1].at(s) * pole)
    }

    /// The parameters the fits search: logarithms of the gain, the frequencies and the
    /// dampings, and the delay in ms ([`Self::from_theta`]'s inverse).
    pub(crate) fn theta(&self) -> [f64; 9] {
        let [a, b] = self.modes;
        [
            self.gain.ln(),
            self.anti_resonance.hz.ln(),
            self.anti_resonance.damping_ratio.ln(),
            a.hz.ln(),
            a.damping_ratio.ln(),
            b.hz.ln(),
            b.damping_ratio.ln(),
            self.pole_hz.ln(),
            1e3 * self.delay_s,
        ]
    }

    pub(crate) fn from_theta(t: &[f64]) -> Option<Self> {
        let r = |a: f64, b: f64| Resonance {
            hz: a.exp(),
            damping_ratio: b.exp(),
        };
        let m = match t {
            [k, fz, zz, f1, z1, f2, z2, fa, tau_ms] => ApplicatorModel {
                gain: k.exp(),
                anti_resonance: r(*fz, *zz),
                modes: [r(*f1, *z1), r(*f2, *z2)],
                pole_hz: fa.exp(),
                delay_s: 1e-3 * tau_ms,
                rms_log_error: 0.0,
            },
            _ => return None,
        };
        m.response(1.0).is_finite().then_some(m)
    }
}

impl std::fmt::Display for ApplicatorModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [a, b] = self.modes;
        write!(
            f,
            "gain {:.2}, modes {:.1} Hz (ζ {:.2}) and {:.1} Hz (ζ {:.2}), anti-resonance {:.1} Hz, pole {:.0} Hz, delay {:+.2} ms; fits the measured response to {:.0} % RMS",
            self.gain,
            a.hz,
            a.damping_ratio,
            b.hz,
            b.damping_ratio,
            self.anti_resonance.hz,
            self.pole_hz,
            1e3 * self.delay_s,
            100.0 * self.rms_log_error
        )
    }
}

/// ln(model/measured) at each point, as (log-magnitude, phase) pairs.
fn log_errors(model: &ApplicatorModel, response: &[ResponsePoint]) -> Vec<f64> {
    response
        .iter()
        .flat_map(|p| {
            let e = (model.response(p.hz) / p.value()).ln();
            [e.re, e.im]
        })
        .collect()
}

/// The parameters a fit searches of `theta` ([`ApplicatorModel::theta`], and any after): all
/// but the pole's (index 7) where `pole_hz` holds it; [`with_pole`] puts it back.
pub(crate) fn searched(theta: &[f64], pole_hz: Option<f64>) -> Vec<f64> {
    let skip = pole_hz.map(|_| 7);
    theta
        .iter()
        .enumerate()
        .filter(|(i, _)| Some(*i) != skip)
        .map(|(_, v)| *v)
        .collect()
}

pub(crate) fn with_pole(theta: &[f64], pole_hz: Option<f64>) -> Vec<f64> {
    let mut t = theta.to_vec();
    if let Some(hz) = pole_hz {
        t.insert(7.min(t.len()), hz.ln());
    }
    t
}

/// A least-squares problem in the model's parameters ([`ApplicatorModel::from_theta`]): its
/// errors at a parameter vector, `None` where they cannot be computed or are not finite.
pub(crate) struct ModelProblem<'a> {
    pub(crate) errors: &'a (dyn Fn(&[f64]) -> Option<Vec<f64>> + Sync),
}

impl<'a> ModelProblem<'a> {
    /// Levenberg–Marquardt from `start`: the parameters it ends at.
    pub(crate) fn solve(
        errors: &'a (dyn Fn(&[f64]) -> Option<Vec<f64>> + Sync),
        start: &[f64],
    ) -> Vec<f64> {
        // A start the model cannot be computed at stays where it is.
        crate::least_squares::minimize(ModelProblem { errors }, start, 50)
            .map_or_else(|| start.to_vec(), |s| s.theta)
    }
}

impl crate::least_squares::Residuals for ModelProblem<'_> {
    fn residuals(&self, theta: &[f64]) -> Option<Vec<f64>> {
        let e = (self.errors)(theta)?;
        e.iter().all(|v| v.is_finite()).then_some(e)
    }
}

/// Fits [`ApplicatorModel`] to a measured response by least squares on the complex logarithm
/// (magnitude and phase weigh alike at every frequency), from starts at the picked resonances
/// and on a grid; `None` if no start converges.
pub fn fit_model(response: &[ResponsePoint]) -> Option<ApplicatorModel> {
    fit_model_with_pole(response, None)
}

/// [`fit_model`] with the amplifier's pole held at `pole_hz` where given (one beyond what the
/// chirp reaches runs off: a 400 Hz amplifier's fits put it at 10¹⁵ Hz).
pub fn fit_model_with_pole(
    response: &[ResponsePoint],
    pole_hz: Option<f64>,
) -> Option<ApplicatorModel> {
    let gain = response.first()?.value().norm();
    let top = response.last()?.hz;
    let picked = modes(response, 2);
    let mut pairs: Vec<(f64, f64)> = Vec::new();
    if let [a, b] = picked.as_slice() {
        pairs.push((a.hz, b.hz));
    }
    for f1 in [0.1, 0.2, 0.35] {
        for ratio in [2.5, 4.0] {
            pairs.push((f1 * top, (ratio * f1 * top).min(0.9 * top)));
        }
    }
    let mut best: Option<(f64, ApplicatorModel)> = None;
    for (f1, f2) in pairs {
        let resonance = |hz: f64, damping_ratio: f64| Resonance { hz, damping_ratio };
        let start = ApplicatorModel {
            gain,
            anti_resonance: resonance((f1 * f2).sqrt(), 0.05),
            modes: [resonance(f1, 0.1), resonance(f2, 0.02)],
            pole_hz: 0.6 * top,
            delay_s: 0.0,
            rms_log_error: 0.0,
        }
        .theta();
        let start = searched(&start, pole_hz);
        let errors = |theta: &[f64]| {
            let m = ApplicatorModel::from_theta(&with_pole(theta, pole_hz))?;
            Some(log_errors(&m, response))
        };
        let solved = ModelProblem::solve(&errors, &start);
        let Some(mut m) = ApplicatorModel::from_theta(&with_pole(&solved, pole_hz)) else {
            continue;
        };
        let e = log_errors(&m, response);
        let cost = e.iter().map(|v| v * v).sum::<f64>();
        if !cost.is_finite() || best.as_ref().is_some_and(|b| b.0 <= cost) {
            continue;
        }
        if m.modes[0].hz > m.modes[1].hz {
            m.modes.swap(0, 1);
        }
        m.rms_log_error = (cost / e.len().max(1) as f64).sqrt();
        best = Some((cost, m));
    }
    best.map(|b| b.1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_holds_noise_is_the_readings_not_the_held_forces_drift() {
        // A 1.5 s record at 1 kHz: 0.3 g of white noise on 50 g creeping 2 g over the hold's
        // 0.5 s (the drift alone has an RMS of 2/√12 = 0.58 g about its mean). The estimate
        // from 499 differences is within 5 % (its own spread is 1/√(2·499) ≈ 3.2 %; the
        // drift adds (4 µg per tick)², nothing).
        let mut noise = crate::noise::Noise::new(7);
        let n = 1500;
        let gauge: Vec<f64> = (0..n)
            .map(|k| 50.0 + 4e-3 * k as f64 + 0.3 * noise.gaussian())
            .collect();
        let drive = vec![51.0; n];
        let hold = hold_means_of(&drive, &gauge, 1e-3).unwrap();
        assert!((hold.noise_g / 0.3 - 1.0).abs() < 0.05, "{hold:?}");
        // The means are the last 0.5 s's: 50 + 4e-3·1249.5 = 55.0 g.
        assert!((hold.gauge_g - 55.0).abs() < 0.05, "{hold:?}");
        assert_eq!(hold.drive_g, 51.0);
        // A record cut before the hold's end has none.
        assert!(hold_means_of(&drive[..1000], &gauge[..1000], 1e-3).is_none());
    }

    #[test]
    fn an_error_names_where_its_run_began() {
        // A fault from sample 4 on, latched, the analysis from 5: named at 4; one that came
        // and went before the analysis is not named.
        let set = [false, true, false, false, true, true, true];
        assert_eq!(first_of_run_into(&set, 5), Some(4));
        assert_eq!(first_of_run_into(&set, 2), Some(4));
        assert_eq!(first_of_run_into(&set, 1), Some(1));
        assert_eq!(first_of_run_into(&set[..4], 2), None);
    }

    #[test]
    fn the_static_line_takes_the_gain_from_the_chirps_and_the_stiction_from_the_holds() {
        // A drive of gain 2 against 3 g of stiction. The holds, reached from below, stop with
        // less of the friction the heavier the preload (3 g at 10 g down to 1.5 g at 100 g).
        // The chirps slide the motor both ways: their means hold ±0.05 g of it.
        let points: Vec<StaticPoint> = [(10.0, 3.0), (20.0, 2.8), (50.0, 2.2), (100.0, 1.5)]
            .iter()
            .enumerate()
            .map(|(i, &(d, held_g))| StaticPoint {
                hold: (d, 2.0 * d - held_g),
                chirp: (
                    d + 0.3,
                    2.0 * (d + 0.3) - if i % 2 == 0 { 0.05 } else { -0.05 },
                ),
            })
            .collect();
        let ((gain, stiction), from_chirps) = static_line(&points).unwrap();
        assert!(from_chirps);
        // The chirps' ±0.05 g tilt the slope by Σ(d − d̄)·e/Σ(d − d̄)² = 3/4900.
        assert!((gain - 2.0).abs() < 2e-3, "{gain}");
        // The most friction a hold stopped with, 3 g at 10 g, and the gain's error times that
        // drive (0.01 g at most).
        assert!((stiction - 3.0).abs() < 0.015, "{stiction}");
        // The holds alone: least squares through (10, 17), (20, 37.2), (50, 97.8) and
        // (100, 198.5) has the slope 9881.5/4900 = 2.017.
        let holds: Vec<(f64, f64)> = points.iter().map(|p| p.hold).collect();
        let (hd, hg): (Vec<f64>, Vec<f64>) = holds.into_iter().unzip();
        let (_, hold_gain) = tactile_ident::stats::line(&hd, &hg).unwrap();
        assert!(hold_gain > 2.01, "{hold_gain}");
        assert_eq!(static_line(&points[..1]), None);
    }

    #[test]
    fn holds_that_stop_alike_in_the_band_keep_their_own_line() {
        // gauge = drive − 1.1 at every hold; the chirps' means read a gain 0.1 % higher.
        let points: Vec<StaticPoint> = [10.0, 20.0, 50.0, 100.0]
            .iter()
            .map(|&d| StaticPoint {
                hold: (d, d - 1.1),
                chirp: (d, 1.001 * d - 0.5),
            })
            .collect();
        let ((gain, stiction), from_chirps) = static_line(&points).unwrap();
        assert!(!from_chirps);
        assert!((gain - 1.0).abs() < 1e-12 && (stiction - 1.1).abs() < 1e-12);
    }
}
