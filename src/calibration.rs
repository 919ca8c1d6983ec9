//! The per-taxel calibration table: what the host's dynamic calibration fits for each taxel
//! (`tactile calibrate`), written as bytes the firmware reads at start-up from its calibration
//! flash sector (or from a build-time file), checked before it is trusted.
//!
//! Layout (little-endian): `b"TCAL"`, version `u16`, taxel count `u16`, then one
//! [`RECORD_BYTES`] record per taxel, then the CRC-32 (IEEE) of everything before it. A record:
//! row `u8`, column `u8`, schedule length `u8`, the estimator the firmware runs (index in
//! [`EstimatorKind::ALL`]), the [`CalibrationFlags`] `u8`, three zero bytes; then `f32`s:
//! strain offset (%), elastic spring (g/%); the whole-record second-order fit a₁ a₂ b₀ b₁ b₂;
//! [`SCHEDULE_POINTS`] schedule entries of load (g) and a₁ a₂ b₀ b₁ b₂; G₁ and G₂ as curves
//! ([`CURVE_KNOTS`] stresses, then the strain at each); N₁, α, N₂; the notch frequency (Hz,
//! 0 for none); the calibrated range (g, 0 unknown); each estimator's held-out RMS error on the
//! calibration record (g, in [`EstimatorKind::ALL`]'s order; negative: not measured); the
//! hysteresis as [`PLAYS`] play radii (g), then their weights (%/g; 0: no play); the force
//! bank ([`BankModel`]): its strain scale (%), [`BANK_FILTERS`] time constants (s),
//! [`BANK_KNOTS`] hinges, [`BANK_PLAYS`] play radii, [`BANK_FEATURES`] weights (g), and its
//! re-zero's bound (g, 0: none), quiet band and time constant (s).
//! Version 2 added the notch; version 3 the curves (version 2's three-coefficient laws could
//! not follow a spring that stiffens by another law), the range, the held-out errors, the
//! chosen estimator and the flags; version 4 the hysteresis (`tactile diagnose`'s plays);
//! version 5 the force bank and its held-out error.

use heapless::Vec;

use crate::estimator::{
    BankModel, Rezero, TaxelEstimator, BANK_FEATURES, BANK_FILTERS, BANK_KNOTS, BANK_PLAYS,
};
use crate::hysteresis::{Plays, PLAYS};
use crate::lti::{ModelError, ModelParameter};
use crate::spring::{SpringCurve, SpringLaw, CURVE_KNOTS};
use crate::tactile::{TaxelId, TAXELS};
use crate::viscoelastic::{MaxwellKelvin, NonlinearMk, SecondOrder};

/// Most load levels a schedule holds (the scheduled inverse's table).
pub const SCHEDULE_POINTS: usize = 4;

/// The estimators a taxel can run, in the order [`TaxelEstimators::update`](crate::estimator::TaxelEstimators::update) reports them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EstimatorKind {
    /// σ = G (ε − ε₀), clamped at zero.
    Elastic,
    /// The memo's inverted second-order model (Table IV, or the taxel's own fit).
    SecondOrderInverse,
    /// [`ScheduledInverse`](crate::estimator::ScheduledInverse).
    ScheduledInverse,
    /// [`MkObserver`](crate::estimator::MkObserver).
    Observer,
    /// [`ForceBank`](crate::estimator::ForceBank).
    Bank,
}

impl EstimatorKind {
    pub const ALL: [EstimatorKind; 5] = [
        EstimatorKind::Elastic,
        EstimatorKind::SecondOrderInverse,
        EstimatorKind::ScheduledInverse,
        EstimatorKind::Observer,
        EstimatorKind::Bank,
    ];
    pub const COUNT: usize = Self::ALL.len();

    /// Index in [`Self::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// The estimator with the least of `held_out_g` (in [`Self::ALL`]'s order; the first of
    /// equals).
    pub fn best(held_out_g: &[f64; Self::COUNT]) -> EstimatorKind {
        Self::ALL
            .into_iter()
            .zip(held_out_g)
            .min_by(|a, b| a.1.total_cmp(b.1))
            .map_or(EstimatorKind::Elastic, |(k, _)| k)
    }

    /// The loop taken off this estimator's input: the calibration's plays, but none before
    /// the bank (fitted with plays of its own).
    pub fn loop_taken_off(self, model: &TaxelModel) -> Plays {
        match self {
            EstimatorKind::Bank => Plays::default(),
            _ => model.hysteresis,
        }
    }

    /// The parameters of a [`TaxelModel`] this estimator runs on.
    fn parameter(self) -> ModelParameter {
        match self {
            EstimatorKind::Elastic => ModelParameter::Elastic,
            EstimatorKind::SecondOrderInverse => ModelParameter::SecondOrder,
            EstimatorKind::ScheduledInverse => ModelParameter::ScheduleEntry,
            EstimatorKind::Observer => ModelParameter::Observer,
            EstimatorKind::Bank => ModelParameter::Bank,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            EstimatorKind::Elastic => "elastic",
            EstimatorKind::SecondOrderInverse => "second-order inverse",
            EstimatorKind::ScheduledInverse => "scheduled inverse",
            EstimatorKind::Observer => "observer (EKF)",
            EstimatorKind::Bank => "force bank",
        }
    }
}

/// CRC-32 (IEEE, as zlib and Ethernet compute it), bit by bit: a lookup table would cost
/// the firmware 1–16 KB of flash to check a 700-byte table once at start-up.
pub fn crc32(bytes: &[u8]) -> u32 {
    const CRC: crc::Crc<u32, crc::NoTable> =
        crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISO_HDLC);
    CRC.checksum(bytes)
}

/// Why a sealed form (a calibration or controller table, an applicator's form: 4 magic bytes,
/// a little-endian u16 version, their contents, then the CRC-32 of everything before it) was
/// refused; each form's own error names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SealError {
    TooShort { bytes: usize, needed: usize },
    BadMagic,
    UnsupportedVersion { found: u16 },
    Checksum { stored: u32, computed: u32 },
}

/// Checks a sealed form's magic and version.
pub fn check_head(bytes: &[u8], magic: [u8; 4], version: u16) -> Result<(), SealError> {
    let head = bytes.get(..6).ok_or(SealError::TooShort {
        bytes: bytes.len(),
        needed: 6,
    })?;
    if head.get(..4) != Some(&magic[..]) {
        return Err(SealError::BadMagic);
    }
    let found = u16::from_le_bytes(bytes_at(head, 4));
    if found != version {
        return Err(SealError::UnsupportedVersion { found });
    }
    Ok(())
}

/// Checks the CRC-32 in the last 4 of a sealed form's `len` bytes; the bytes before it.
pub fn check_crc(bytes: &[u8], len: usize) -> Result<&[u8], SealError> {
    let all = bytes.get(..len).ok_or(SealError::TooShort {
        bytes: bytes.len(),
        needed: len,
    })?;
    let (contents, stored) = all.split_at(len.saturating_sub(4));
    let stored = u32::from_le_bytes(bytes_at(stored, 0));
    let computed = crc32(contents);
    if stored != computed {
        return Err(SealError::Checksum { stored, computed });
    }
    Ok(contents)
}

/// Seals `out`, a form whose contents are written: the magic and version in its first 6 bytes,
/// the CRC-32 of all before them in its last 4.
pub fn seal(out: &mut [u8], magic: [u8; 4], version: u16) {
    let version = version.to_le_bytes();
    for (slot, b) in out.iter_mut().zip(magic.iter().chain(&version)) {
        *slot = *b;
    }
    let body = out.len().saturating_sub(4);
    let crc = crc32(out.get(..body).unwrap_or(&[]));
    if let Some(slot) = out.get_mut(body..) {
        slot.copy_from_slice(&crc.to_le_bytes());
    }
}

/// `N` bytes of `bytes` from `at` (zeros past the end: callers have checked the length).
pub fn bytes_at<const N: usize>(bytes: &[u8], at: usize) -> [u8; N] {
    bytes
        .get(at..at + N)
        .and_then(|b| b.try_into().ok())
        .unwrap_or([0; N])
}

pub const MAGIC: [u8; 4] = *b"TCAL";
pub const VERSION: u16 = 5;
const HEADER_BYTES: usize = 8;
/// Bytes of a record before its floats.
const LEAD_BYTES: usize = 8;
const CRC_BYTES: usize = 4;
/// Floats in a record after its four leading bytes.
const RECORD_FLOATS: usize = 2
    + 5
    + SCHEDULE_POINTS * 6
    + 2 * CURVE_FLOATS
    + 3
    + 1
    + 1
    + EstimatorKind::COUNT
    + 2 * PLAYS
    + BANK_FLOATS;
/// A bank's floats: scale, time constants, knots, radii, weights, re-zero.
const BANK_FLOATS: usize = 1 + BANK_FILTERS + BANK_KNOTS + BANK_PLAYS + BANK_FEATURES + 3;
/// A curve's floats: its knots' stresses, then its strains there.
const CURVE_FLOATS: usize = 2 * CURVE_KNOTS;
pub const RECORD_BYTES: usize = LEAD_BYTES + 4 * RECORD_FLOATS;

bitflags::bitflags! {
    /// What a calibration says about itself (stored in the table, logged by the firmware).
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
    pub struct CalibrationFlags: u8 {
        /// The best estimator's held-out error is above [`POOR_FIT_G`]: the taxel's force is
        /// not to be trusted to the memo's ±1 g.
        const POOR = 1;
        /// The fitted model misses the strain by more than [`LARGE_OFFSET_PCT`] on average
        /// with the offset measured at rest: something shifts the strain that the model lacks.
        const OFFSET = 2;
        /// The calibration held out worse than the nominal models, which the record carries.
        const NOMINAL = 4;
    }
}

/// Held-out RMS force error above which a calibration is flagged [`CalibrationFlags::POOR`], g
/// (the memo's ±1 g).
pub const POOR_FIT_G: f64 = 1.0;
/// Mean strain the model misses by before a calibration is flagged
/// [`CalibrationFlags::OFFSET`], percent (about 0.2 g through G₁ at 30 g).
pub const LARGE_OFFSET_PCT: f64 = 0.05;
/// Most taxels whose calibration carries hysteresis (the scanner keeps their plays' state in
/// RAM for these only: the F407's static RAM budget).
pub const MAX_LOOP_TAXELS: usize = 8;
/// The largest table: every taxel of the array.
pub const MAX_TABLE_BYTES: usize = table_bytes(TAXELS);

/// Bytes of a table of `taxels` records.
pub const fn table_bytes(taxels: usize) -> usize {
    HEADER_BYTES + taxels * RECORD_BYTES + CRC_BYTES
}

/// One taxel's dynamic calibration.
#[derive(Clone, Debug, PartialEq)]
pub struct TaxelModel {
    pub taxel: TaxelId,
    /// Strain the fits found at zero force, beyond the rest calibration, percent.
    pub strain_offset_pct: f64,
    /// Elastic model ε = σ/G, g/%.
    pub elastic_g_per_pct: f64,
    /// Eq. 17 fitted to the whole calibration record (the memo's inverse, recalibrated).
    pub second_order: SecondOrder,
    /// Eq. 17 fitted at each load level (the scheduled inverse), in increasing load.
    pub schedule: Vec<(f32, SecondOrder), SCHEDULE_POINTS>,
    /// Eq. 14 with load-dependent springs (the observer's model).
    pub element: NonlinearMk,
    /// A periodic interference on the strain, notched before every estimator, Hz (0: none).
    pub notch_hz: f64,
    /// The largest load the calibration record covered, g (0: unknown).
    pub range_g: f64,
    /// Each estimator's RMS force error on the held-out part of the calibration record, g, in
    /// [`EstimatorKind::ALL`]'s order (`None`: not measured, as for the nominal models).
    pub held_out_g: Option<[f64; EstimatorKind::COUNT]>,
    /// The estimator the firmware runs on this taxel (the one that held out best).
    pub estimator: EstimatorKind,
    pub flags: CalibrationFlags,
    /// A loop in the strain, taken off before the taxel's estimator (none: empty).
    pub hysteresis: Plays,
    /// The force bank (without a fit: the elastic spring).
    pub bank: BankModel,
}

impl TaxelModel {
    /// Element 4,2 as the memo describes it, for a taxel without a calibration: the Table IV
    /// fit, Table I's element scheduled at its four loads (with the simulator's α), the guide
    /// laws of FACTS.md, and the elastic spring that is Table IV's static gain.
    pub fn nominal(taxel: TaxelId) -> TaxelModel {
        let mut schedule = Vec::new();
        for row in MaxwellKelvin::TABLE_I {
            let (load, row) = (row.load_g as f32, row.element);
            let mk = MaxwellKelvin {
                alpha: NonlinearMk::ELEMENT_4_2.alpha,
                ..row
            };
            // Four entries into a Vec of four: cannot fail.
            let _ = schedule.push((load, mk.second_order()));
        }
        let so = SecondOrder::MEMO_FIT;
        TaxelModel {
            taxel,
            strain_offset_pct: 0.0,
            elastic_g_per_pct: so.b2 / so.a2,
            second_order: so,
            schedule,
            element: NonlinearMk::ELEMENT_4_2,
            notch_hz: 0.0,
            range_g: 0.0,
            held_out_g: None,
            estimator: EstimatorKind::Observer,
            flags: CalibrationFlags::empty(),
            hysteresis: Plays::default(),
            bank: BankModel::elastic(so.b2 / so.a2),
        }
    }

    /// Whether every estimator runs on this calibration: each is built as the firmware builds
    /// it, at a nominal period (what they refuse, a parameter not finite or not positive or a
    /// model not stable, does not depend on the period). `Err`: the parameters that cannot.
    pub fn check(&self) -> Result<(), ModelParameter> {
        const NOMINAL_PERIOD_S: f64 = 1e-3;
        for kind in EstimatorKind::ALL {
            TaxelEstimator::new(kind, self, NOMINAL_PERIOD_S).map_err(|e| match e {
                ModelError::InvalidParameter { name } => name,
                _ => kind.parameter(),
            })?;
        }
        Ok(())
    }

    /// The record's floats; `None` if a spring law cannot be tabulated.
    fn floats(&self) -> Option<[f32; RECORD_FLOATS]> {
        let mut v = [0.0f32; RECORD_FLOATS];
        let so = |s: &SecondOrder| [s.a1, s.a2, s.b0, s.b1, s.b2];
        let mut values: Vec<f64, RECORD_FLOATS> = Vec::new();
        let _ = values.extend_from_slice(&[self.strain_offset_pct, self.elastic_g_per_pct]);
        let _ = values.extend_from_slice(&so(&self.second_order));
        for k in 0..SCHEDULE_POINTS {
            let (load, s) = self
                .schedule
                .get(k)
                .copied()
                .unwrap_or((0.0, SecondOrder::MEMO_FIT));
            let _ = values.push(f64::from(load));
            let _ = values.extend_from_slice(&so(&s));
        }
        let e = &self.element;
        for law in [e.g1, e.g2] {
            let curve = law.curve().ok()?;
            let (stress, strain): (Vec<f32, CURVE_KNOTS>, Vec<f32, CURVE_KNOTS>) =
                curve.knots().unzip();
            for x in stress.iter().chain(&strain) {
                let _ = values.push(f64::from(*x));
            }
        }
        let held_out = self.held_out_g.unwrap_or([-1.0; EstimatorKind::COUNT]);
        let _ = values.extend_from_slice(&[e.n1, e.alpha, e.n2, self.notch_hz, self.range_g]);
        let _ = values.extend_from_slice(&held_out);
        let h = &self.hysteresis;
        for x in h.radius_g.iter().chain(&h.weight_pct_per_g) {
            let _ = values.push(f64::from(*x));
        }
        let b = &self.bank;
        let r = &b.rezero;
        for x in [b.strain_scale_pct]
            .iter()
            .chain(&b.tau_s)
            .chain(&b.knots)
            .chain(&b.play_radius)
            .chain(&b.weights_g)
            .chain(&[r.below_g, r.quiet, r.tau_s])
        {
            let _ = values.push(f64::from(*x));
        }
        for (slot, x) in v.iter_mut().zip(values) {
            *slot = x as f32;
        }
        Some(v)
    }

    fn from_floats(
        taxel: TaxelId,
        lead: [u8; LEAD_BYTES],
        f: &[f32; RECORD_FLOATS],
    ) -> Option<TaxelModel> {
        let [_, _, schedule_len, estimator, flags, 0, 0, 0] = lead else {
            return None;
        };
        let schedule_len = usize::from(schedule_len);
        if f.iter().any(|v| !v.is_finite()) || schedule_len > SCHEDULE_POINTS {
            return None;
        }
        let estimator = *EstimatorKind::ALL.get(usize::from(estimator))?;
        let flags = CalibrationFlags::from_bits(flags)?;
        let d = |i: usize| f.get(i).map_or(f64::NAN, |v| f64::from(*v));
        let so = |i: usize| SecondOrder {
            a1: d(i),
            a2: d(i + 1),
            b0: d(i + 2),
            b1: d(i + 3),
            b2: d(i + 4),
        };
        let mut schedule = Vec::new();
        for k in 0..schedule_len {
            let base = 7 + 6 * k;
            schedule.push((d(base) as f32, so(base + 1))).ok()?;
        }
        let e = 7 + 6 * SCHEDULE_POINTS;
        let at = |i: usize| f.get(i).copied().unwrap_or(f32::NAN);
        let curve = |i: usize| {
            let stress = core::array::from_fn(|k| at(i + k));
            SpringCurve::new(stress, core::array::from_fn(|k| at(i + CURVE_KNOTS + k))).ok()
        };
        let (g1, g2) = (curve(e)?, curve(e + CURVE_FLOATS)?);
        let p = e + 2 * CURVE_FLOATS;
        let held_out: [f64; EstimatorKind::COUNT] = core::array::from_fn(|k| d(p + 5 + k));
        let h = p + 5 + EstimatorKind::COUNT;
        let hysteresis = Plays {
            radius_g: core::array::from_fn(|k| at(h + k)),
            weight_pct_per_g: core::array::from_fn(|k| at(h + PLAYS + k)),
        };
        hysteresis.check().ok()?;
        let bank = bank_from(f.get(h + 2 * PLAYS..)?)?;
        Some(TaxelModel {
            taxel,
            strain_offset_pct: d(0),
            elastic_g_per_pct: d(1),
            second_order: so(2),
            schedule,
            element: NonlinearMk {
                g1: SpringLaw::Curve(g1),
                n1: d(p),
                alpha: d(p + 1),
                n2: d(p + 2),
                g2: SpringLaw::Curve(g2),
            },
            notch_hz: d(p + 3),
            range_g: d(p + 4),
            held_out_g: held_out.iter().all(|v| *v >= 0.0).then_some(held_out),
            estimator,
            flags,
            hysteresis,
            bank,
        })
    }
}

/// A bank from its floats in the record's order; `None` if out of range.
fn bank_from(f: &[f32]) -> Option<BankModel> {
    let (scale, f) = f.split_first()?;
    let (tau, f) = f.split_at_checked(BANK_FILTERS)?;
    let (knots, f) = f.split_at_checked(BANK_KNOTS)?;
    let (radii, f) = f.split_at_checked(BANK_PLAYS)?;
    let (weights, f) = f.split_at_checked(BANK_FEATURES)?;
    let [below_g, quiet, tau_s, ..] = *f else {
        return None;
    };
    let bank = BankModel {
        strain_scale_pct: *scale,
        tau_s: tau.try_into().ok()?,
        knots: knots.try_into().ok()?,
        play_radius: radii.try_into().ok()?,
        weights_g: weights.try_into().ok()?,
        rezero: Rezero {
            below_g,
            quiet,
            tau_s,
        },
    };
    bank.check().ok().map(|()| bank)
}

/// The scheduled inverse's table from an element with load-dependent springs: its secant
/// springs at each of `loads_g` as eq. 17 (Table I's rows, one per load, from one law). Loads
/// beyond [`SCHEDULE_POINTS`] are left out.
pub fn secant_schedule(
    element: &NonlinearMk,
    loads_g: &[f64],
) -> Vec<(f32, SecondOrder), SCHEDULE_POINTS> {
    loads_g
        .iter()
        .take(SCHEDULE_POINTS)
        .map(|&load| (load as f32, element.linearized(load).second_order()))
        .collect()
}

impl From<SealError> for TableError {
    fn from(e: SealError) -> Self {
        match e {
            SealError::TooShort { bytes, needed } => TableError::TooShort { bytes, needed },
            SealError::BadMagic => TableError::BadMagic,
            SealError::UnsupportedVersion { found } => TableError::UnsupportedVersion { found },
            SealError::Checksum { stored, computed } => TableError::Checksum { stored, computed },
        }
    }
}

/// Why a table was refused (the firmware then runs the nominal models and says so).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TableError {
    /// Fewer bytes than the header and the records it announces.
    #[error("calibration table too short: {bytes} bytes, need {needed}")]
    TooShort { bytes: usize, needed: usize },
    /// Not a table (an erased flash sector reads `0xFF…`).
    #[error("not a calibration table (no TCAL header)")]
    BadMagic,
    #[error("calibration table version {found}; this build reads version {VERSION}")]
    UnsupportedVersion { found: u16 },
    /// The stored checksum does not match the contents.
    #[error(
        "calibration table checksum {stored:#010x} does not match its contents ({computed:#010x})"
    )]
    Checksum { stored: u32, computed: u32 },
    /// More taxels than the array has, or the same taxel twice.
    #[error("calibration table lists {count} taxels; the array has {TAXELS}")]
    BadCount { count: u16 },
    #[error("calibration table lists taxel ({row}, {col}) twice")]
    DuplicateTaxel { row: u8, col: u8 },
    /// More taxels with hysteresis than the scanner keeps loops for.
    #[error("calibration table has hysteresis on more than {MAX_LOOP_TAXELS} taxels")]
    TooManyLoops,
    /// A record with a position off the array, a non-finite value or a bad schedule length.
    #[error("calibration table record {index}: position off the array, a non-finite value, a spring that is not a rising curve, a play of negative radius, or a bad schedule length, estimator or flag")]
    BadRecord { index: u16 },
    /// A record whose values are well formed but on which an estimator cannot run.
    #[error("calibration table record {index}: the {parameter} cannot run its estimator (not finite, not positive where it must be, or a model that is not stable)")]
    BadModel {
        index: u16,
        parameter: ModelParameter,
    },
    /// The output buffer is too small to hold the table.
    #[error("calibration table needs a {needed}-byte buffer")]
    BufferTooSmall { needed: usize },
}

/// Calibrated taxels (the rest run [`TaxelModel::nominal`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CalibrationTable {
    pub taxels: Vec<TaxelModel, TAXELS>,
}

impl CalibrationTable {
    /// The calibration of `taxel`, if the table has one.
    pub fn get(&self, taxel: TaxelId) -> Option<&TaxelModel> {
        self.taxels.iter().find(|m| m.taxel == taxel)
    }

    /// Bytes the encoded table takes.
    pub fn encoded_len(&self) -> usize {
        HEADER_BYTES + self.taxels.len() * RECORD_BYTES + CRC_BYTES
    }

    /// Writes the table into `out`; returns the bytes written.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, TableError> {
        let needed = self.encoded_len();
        let buf = out
            .get_mut(..needed)
            .ok_or(TableError::BufferTooSmall { needed })?;
        let (header, rest) = buf.split_at_mut(HEADER_BYTES);
        if let Some(slot) = header.get_mut(6..8) {
            slot.copy_from_slice(&(self.taxels.len() as u16).to_le_bytes());
        }
        for (index, (record, model)) in rest
            .chunks_exact_mut(RECORD_BYTES)
            .zip(&self.taxels)
            .enumerate()
        {
            let (lead, floats) = record.split_at_mut(LEAD_BYTES);
            let estimator = EstimatorKind::ALL
                .iter()
                .position(|k| *k == model.estimator)
                .unwrap_or(0);
            lead.copy_from_slice(&[
                model.taxel.row() as u8,
                model.taxel.col() as u8,
                model.schedule.len() as u8,
                estimator as u8,
                model.flags.bits(),
                0,
                0,
                0,
            ]);
            let index = index as u16;
            let values = model.floats().ok_or(TableError::BadRecord { index })?;
            model
                .check()
                .map_err(|parameter| TableError::BadModel { index, parameter })?;
            for (slot, v) in floats.chunks_exact_mut(4).zip(values) {
                slot.copy_from_slice(&v.to_le_bytes());
            }
        }
        seal(buf, MAGIC, VERSION);
        Ok(needed)
    }

    /// Reads a table, checking everything before trusting any of it. Bytes after the table
    /// (the rest of a flash sector) are ignored.
    pub fn decode(bytes: &[u8]) -> Result<CalibrationTable, TableError> {
        let view = TableView::check(bytes)?;
        let mut table = CalibrationTable::default();
        for model in view.models() {
            table
                .taxels
                .push(model)
                .map_err(|_| TableError::BadCount { count: view.count })?;
        }
        Ok(table)
    }
}

/// A checked table read in place (the firmware's view of its calibration sector: no copy of
/// the whole table on the stack).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableView<'a> {
    records: &'a [u8],
    count: u16,
}

impl<'a> TableView<'a> {
    /// Checks header, length, checksum and every record (positions on the array, no taxel
    /// twice, finite values, schedule lengths, models every estimator runs on).
    pub fn check(bytes: &'a [u8]) -> Result<TableView<'a>, TableError> {
        let too_short = |needed| TableError::TooShort {
            bytes: bytes.len(),
            needed,
        };
        let header = bytes.get(..HEADER_BYTES).ok_or(too_short(HEADER_BYTES))?;
        check_head(header, MAGIC, VERSION)?;
        let count = u16::from_le_bytes(bytes_at(header, 6));
        if usize::from(count) > TAXELS {
            return Err(TableError::BadCount { count });
        }
        let needed = HEADER_BYTES + usize::from(count) * RECORD_BYTES + CRC_BYTES;
        let contents = check_crc(bytes, needed)?;
        let view = TableView {
            records: contents.get(HEADER_BYTES..).unwrap_or(&[]),
            count,
        };
        let (mut seen, mut loops) = (0u64, 0usize);
        for index in 0..usize::from(count) {
            let model = view.record(index).ok_or(TableError::BadRecord {
                index: index as u16,
            })?;
            model.check().map_err(|parameter| TableError::BadModel {
                index: index as u16,
                parameter,
            })?;
            let bit = 1u64 << model.taxel.index();
            if seen & bit != 0 {
                return Err(TableError::DuplicateTaxel {
                    row: model.taxel.row() as u8,
                    col: model.taxel.col() as u8,
                });
            }
            seen |= bit;
            loops += usize::from(!model.hysteresis.is_empty());
        }
        if loops > MAX_LOOP_TAXELS {
            return Err(TableError::TooManyLoops);
        }
        Ok(view)
    }

    /// Taxels in the table.
    pub fn len(&self) -> usize {
        usize::from(self.count)
    }

    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Record `index`, `None` if out of range or malformed.
    fn record(&self, index: usize) -> Option<TaxelModel> {
        let record = self
            .records
            .get(index * RECORD_BYTES..(index + 1) * RECORD_BYTES)?;
        let lead: [u8; LEAD_BYTES] = bytes_at(record, 0);
        let [row, col, ..] = lead;
        let taxel = TaxelId::new(usize::from(row), usize::from(col))?;
        let mut floats = [0.0f32; RECORD_FLOATS];
        for (v, b) in floats
            .iter_mut()
            .zip(record.get(LEAD_BYTES..).unwrap_or(&[]).chunks_exact(4))
        {
            *v = f32::from_le_bytes(bytes_at(b, 0));
        }
        TaxelModel::from_floats(taxel, lead, &floats)
    }

    /// Every model, in table order.
    pub fn models(&self) -> impl Iterator<Item = TaxelModel> + '_ {
        (0..self.len()).filter_map(|i| self.record(i))
    }

    /// The calibration of `taxel`, if the table has one.
    pub fn get(&self, taxel: TaxelId) -> Option<TaxelModel> {
        self.models().find(|m| m.taxel == taxel)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> CalibrationTable {
        let mut t = CalibrationTable::default();
        for (i, k) in [(0usize, 1.0), (27, 1.2), (63, 0.8)] {
            let mut m = TaxelModel::nominal(TaxelId::from_index(i));
            m.element.g1 = m.element.g1.scaled(k);
            m.strain_offset_pct = 0.03 * k;
            m.schedule.truncate(2 + i % 3);
            m.estimator = EstimatorKind::ALL[i % 5];
            m.flags = CalibrationFlags::from_bits_truncate(i as u8);
            m.held_out_g = (i > 0).then_some([3.0, 2.5, 0.4, 0.2 * k, 0.3]);
            m.bank.tau_s[2] = 3.5 * k as f32;
            m.bank.weights_g[7] = -1.25;
            m.bank.rezero = Rezero {
                below_g: 4.0,
                quiet: 0.02,
                tau_s: 2.0,
            };
            m.range_g = 90.0 * k;
            m.hysteresis = Plays::new(&[(0.5, 0.01), (8.0 * k as f32, -0.002)]).unwrap();
            t.taxels.push(m).unwrap();
        }
        t
    }

    /// Values as f32 keeps them, the springs as curves.
    fn rounded(m: &TaxelModel) -> TaxelModel {
        let f = |x: f64| f64::from(x as f32);
        let so = |s: &SecondOrder| SecondOrder {
            a1: f(s.a1),
            a2: f(s.a2),
            b0: f(s.b0),
            b1: f(s.b1),
            b2: f(s.b2),
        };
        let e = &m.element;
        TaxelModel {
            strain_offset_pct: f(m.strain_offset_pct),
            elastic_g_per_pct: f(m.elastic_g_per_pct),
            second_order: so(&m.second_order),
            schedule: m.schedule.iter().map(|(l, s)| (*l, so(s))).collect(),
            element: NonlinearMk {
                g1: SpringLaw::Curve(e.g1.curve().unwrap()),
                n1: f(e.n1),
                alpha: f(e.alpha),
                n2: f(e.n2),
                g2: SpringLaw::Curve(e.g2.curve().unwrap()),
            },
            notch_hz: f(m.notch_hz),
            range_g: f(m.range_g),
            held_out_g: m.held_out_g.map(|h| h.map(f)),
            ..m.clone()
        }
    }

    #[test]
    fn a_table_reads_back_as_written() {
        let t = table();
        let mut buf = [0u8; MAX_TABLE_BYTES];
        let n = t.encode(&mut buf).unwrap();
        assert_eq!(n, 8 + 3 * RECORD_BYTES + 4);
        // 8 lead bytes and 125 floats: offset, elastic, eq. 17, 4 × 6 schedule, 2 × 20 curve,
        // N₁ α N₂, notch, range, 5 held-out errors, 5 play radii and 5 weights; the bank's
        // scale, 8 time constants, 3 knots, 3 radii, 16 weights and 3 re-zero values.
        assert_eq!(RECORD_BYTES, 8 + 4 * 125);
        // Trailing bytes (the rest of a sector) are ignored.
        let back = CalibrationTable::decode(&buf[..n + 100]).unwrap();
        assert_eq!(back.taxels.len(), 3);
        for (a, b) in t.taxels.iter().zip(&back.taxels) {
            assert_eq!(&rounded(a), b);
        }
        assert_eq!(back.get(TaxelId::from_index(27)).unwrap().schedule.len(), 2);
        assert!(back.get(TaxelId::from_index(5)).is_none());
    }

    #[test]
    fn damaged_tables_are_refused_with_the_reason() {
        let t = table();
        let mut buf = [0u8; MAX_TABLE_BYTES];
        let n = t.encode(&mut buf).unwrap();
        let good = buf[..n].to_vec();
        // An erased flash sector.
        assert_eq!(
            CalibrationTable::decode(&[0xff; 64]),
            Err(TableError::BadMagic)
        );
        assert!(matches!(
            CalibrationTable::decode(&good[..n - 1]),
            Err(TableError::TooShort { .. })
        ));
        assert!(matches!(
            CalibrationTable::decode(&good[..5]),
            Err(TableError::TooShort { .. })
        ));
        // One flipped bit anywhere in the contents.
        for i in [9, 100, n - 5] {
            let mut bad = good.clone();
            bad[i] ^= 0x10;
            assert!(
                matches!(
                    CalibrationTable::decode(&bad),
                    Err(TableError::Checksum { .. })
                ),
                "byte {i}"
            );
        }
        for old in [1u8, 2, 3, 4] {
            let mut v = good.clone();
            v[4] = old;
            assert_eq!(
                CalibrationTable::decode(&v),
                Err(TableError::UnsupportedVersion { found: old.into() })
            );
        }
        assert!(TableError::UnsupportedVersion { found: 4 }
            .to_string()
            .contains("version 4; this build reads version 5"));
        // Well-formed but wrong inside (checksum recomputed): a position off the array.
        let mut off = good.clone();
        off[8] = 9;
        let crc = crc32(&off[..n - 4]);
        off[n - 4..].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(
            CalibrationTable::decode(&off),
            Err(TableError::BadRecord { index: 0 })
        );
        // A play of negative radius.
        let mut bad_play = t.clone();
        bad_play.taxels[2].hysteresis.radius_g[1] = -1.0;
        let n3 = bad_play.encode(&mut buf).unwrap();
        assert_eq!(
            CalibrationTable::decode(&buf[..n3]),
            Err(TableError::BadRecord { index: 2 })
        );
        let mut loops = CalibrationTable::default();
        for i in 0..=MAX_LOOP_TAXELS {
            let mut m = TaxelModel::nominal(TaxelId::from_index(i));
            m.hysteresis = Plays::new(&[(1.0, 0.01)]).unwrap();
            loops.taxels.push(m).unwrap();
        }
        let n4 = loops.encode(&mut buf).unwrap();
        assert_eq!(
            CalibrationTable::decode(&buf[..n4]),
            Err(TableError::TooManyLoops)
        );
        let mut twice = t.clone();
        twice.taxels[1].taxel = twice.taxels[0].taxel;
        let n2 = twice.encode(&mut buf).unwrap();
        assert!(matches!(
            CalibrationTable::decode(&buf[..n2]),
            Err(TableError::DuplicateTaxel { row: 0, col: 0 })
        ));
        assert!(matches!(
            t.encode(&mut [0u8; 20]),
            Err(TableError::BufferTooSmall { .. })
        ));
        assert!(TableError::BadMagic.to_string().contains("TCAL"));
    }

    #[test]
    fn a_schedule_entry_whose_inverse_runs_away_is_refused_and_named() {
        let t = table();
        let mut buf = [0u8; MAX_TABLE_BYTES];
        let n = t.encode(&mut buf).unwrap();
        // Record 0's second schedule entry, a₁ = −5 (load, then a₁ a₂ b₀ b₁ b₂), checksum
        // recomputed: well formed, finite, and the scheduled inverse would run off to infinity.
        let a1 = HEADER_BYTES + LEAD_BYTES + 4 * (7 + 6 + 1);
        let mut bad = buf[..n].to_vec();
        bad[a1..a1 + 4].copy_from_slice(&(-5.0f32).to_le_bytes());
        let crc = crc32(&bad[..n - 4]);
        bad[n - 4..].copy_from_slice(&crc.to_le_bytes());
        let refused = CalibrationTable::decode(&bad).unwrap_err();
        assert_eq!(
            refused,
            TableError::BadModel {
                index: 0,
                parameter: ModelParameter::ScheduleEntry
            }
        );
        assert!(
            refused
                .to_string()
                .contains("record 0: the schedule entry a1"),
            "{refused}"
        );
        // Nor is such a model written.
        let mut unwritable = t.clone();
        unwritable.taxels[1].schedule[0].1.a1 = -5.0;
        assert_eq!(
            unwritable.encode(&mut buf),
            Err(TableError::BadModel {
                index: 1,
                parameter: ModelParameter::ScheduleEntry
            })
        );
        // A negative elastic spring is named as such.
        let mut elastic = t.clone();
        elastic.taxels[2].elastic_g_per_pct = -1.0;
        assert_eq!(
            elastic.encode(&mut buf),
            Err(TableError::BadModel {
                index: 2,
                parameter: ModelParameter::Elastic
            })
        );
    }

    #[test]
    fn crc_is_the_ieee_check_value() {
        // The CRC catalogue's check value of CRC-32/ISO-HDLC for "123456789".
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn the_nominal_model_is_the_memos() {
        let m = TaxelModel::nominal(TaxelId::default());
        assert_eq!(m.second_order, SecondOrder::MEMO_FIT);
        assert!((m.elastic_g_per_pct - 2.53 / 0.784).abs() < 1e-12);
        let loads: std::vec::Vec<f32> = m.schedule.iter().map(|(l, _)| *l).collect();
        assert_eq!(loads, [10.0, 30.0, 50.0, 80.0]);
        assert_eq!(m.element, NonlinearMk::ELEMENT_4_2);
    }
}
