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
//! ([`CURVE_KNOTS`] stresses, the strain at each, then the stiffness at no load, g/%); N₁, α,
//! N₂; the notch frequency (Hz, 0 for none); the calibrated range (g, 0 unknown); each
//! estimator's held-out RMS error on the calibration record (g, in [`EstimatorKind::ALL`]'s
//! order; negative: not measured); the hysteresis as [`PLAYS`] play radii (g), then their
//! weights (%/g; 0: no play); the force
//! bank ([`BankModel`]): its strain scale (%), [`BANK_FILTERS`] time constants (s),
//! [`BANK_KNOTS`] hinges, [`BANK_PLAYS`] play radii, [`BANK_FEATURES`] weights (g), and its
//! re-zero's bound (g, 0: none), quiet band and time constant (s).
//! Version 2 added the notch; version 3 the curves (version 2's three-coefficient laws could
//! not follow a spring that stiffens by another law), the range, the held-out errors, the
//! chosen estimator and the flags; version 4 the hysteresis (`tactile diagnose`'s plays);
//! version 5 the force bank and its held-out error; version 6 each curve's stiffness at no load
//! (a spring that starts soft, as G₁'s √σ, read 10–40 % high under its first knot without it).

use heapless::Vec;

use crate::estimator::{
    BankModel, CalibrationFlags, EstimatorKind, Rezero, TaxelModel, BANK_FEATURES, BANK_FILTERS,
    BANK_KNOTS, BANK_PLAYS, SCHEDULE_POINTS,
};
use crate::hysteresis::{Plays, PLAYS};
use crate::lti::ModelParameter;
use crate::seal::{bytes_at, check_crc, check_head, seal, SealError};
use crate::spring::{SpringCurve, SpringLaw, CURVE_KNOTS};
use crate::tactile::{TaxelId, TAXELS};
use crate::viscoelastic::{NonlinearMk, SecondOrder};

pub const MAGIC: [u8; 4] = *b"TCAL";
pub const VERSION: u16 = 6;
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
/// A curve's floats: its knots' stresses, its strains there, its stiffness at no load.
const CURVE_FLOATS: usize = 2 * CURVE_KNOTS + 1;
pub const RECORD_BYTES: usize = LEAD_BYTES + 4 * RECORD_FLOATS;

/// Most taxels whose calibration carries hysteresis (the scanner keeps their plays' state in
/// RAM for these only: the F407's static RAM budget).
pub const MAX_LOOP_TAXELS: usize = 8;
/// The largest table: every taxel of the array.
pub const MAX_TABLE_BYTES: usize = table_bytes(TAXELS);

/// Bytes of a table of `taxels` records.
pub const fn table_bytes(taxels: usize) -> usize {
    HEADER_BYTES + taxels * RECORD_BYTES + CRC_BYTES
}

impl TaxelModel {
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
            for x in stress
                .iter()
                .chain(&strain)
                .chain(&[curve.origin_g_per_pct()])
            {
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
            let strain = core::array::from_fn(|k| at(i + CURVE_KNOTS + k));
            SpringCurve::with_origin(stress, strain, at(i + 2 * CURVE_KNOTS)).ok()
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
    use crate::seal::crc32;

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
        // 8 lead bytes and 127 floats: offset, elastic, eq. 17, 4 × 6 schedule, 2 × 21 curve,
        // N₁ α N₂, notch, range, 5 held-out errors, 5 play radii and 5 weights; the bank's
        // scale, 8 time constants, 3 knots, 3 radii, 16 weights and 3 re-zero values.
        assert_eq!(RECORD_BYTES, 8 + 4 * 127);
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
        for old in [1u8, 2, 3, 4, 5] {
            let mut v = good.clone();
            v[4] = old;
            assert_eq!(
                CalibrationTable::decode(&v),
                Err(TableError::UnsupportedVersion { found: old.into() })
            );
        }
        assert!(TableError::UnsupportedVersion { found: 5 }
            .to_string()
            .contains("version 5; this build reads version 6"));
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
    fn the_nominal_model_is_the_memos() {
        let m = TaxelModel::nominal(TaxelId::default());
        assert_eq!(m.second_order, SecondOrder::MEMO_FIT);
        assert!((m.elastic_g_per_pct - 2.53 / 0.784).abs() < 1e-12);
        let loads: std::vec::Vec<f32> = m.schedule.iter().map(|(l, _)| *l).collect();
        assert_eq!(loads, [10.0, 30.0, 50.0, 80.0]);
        assert_eq!(m.element, NonlinearMk::ELEMENT_4_2);
    }
}
