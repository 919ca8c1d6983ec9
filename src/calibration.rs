//! The per-taxel calibration table: what the host's dynamic calibration fits for each taxel
//! (`tactile calibrate`), written as bytes the firmware reads at start-up from its calibration
//! flash sector (or from a build-time file), checked before it is trusted.
//!
//! Layout (little-endian): `b"TCAL"`, version `u16`, taxel count `u16`, then one
//! [`RECORD_BYTES`] record per taxel, then the CRC-32 (IEEE) of everything before it. A record:
//! row `u8`, column `u8`, schedule length `u8`, a zero byte; strain offset (%), elastic spring
//! (g/%); the whole-record second-order fit a₁ a₂ b₀ b₁ b₂; [`SCHEDULE_POINTS`] schedule
//! entries of load (g) and a₁ a₂ b₀ b₁ b₂; the element law G₁ (base, √, linear), N₁, α, N₂,
//! G₂ (base, √, linear); the notch frequency (Hz, 0 for none) — all `f32`. Version 2 added
//! the notch.

use heapless::Vec;

use crate::estimator::SCHEDULE_POINTS;
use crate::tactile::{TaxelId, TAXELS};
use crate::viscoelastic::{MaxwellKelvin, NonlinearMk, SecondOrder, SpringLaw};

/// CRC-32 (IEEE, as zlib and Ethernet compute it), bit by bit: a lookup table would cost
/// the firmware 1–16 KB of flash to check a 700-byte table once at start-up.
fn crc32(bytes: &[u8]) -> u32 {
    const CRC: crc::Crc<u32, crc::NoTable> =
        crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISO_HDLC);
    CRC.checksum(bytes)
}

/// `N` bytes of `bytes` from `at` (zeros past the end: callers have checked the length).
fn bytes_at<const N: usize>(bytes: &[u8], at: usize) -> [u8; N] {
    bytes
        .get(at..at + N)
        .and_then(|b| b.try_into().ok())
        .unwrap_or([0; N])
}

pub const MAGIC: [u8; 4] = *b"TCAL";
pub const VERSION: u16 = 2;
const HEADER_BYTES: usize = 8;
const CRC_BYTES: usize = 4;
/// Floats in a record after its four leading bytes.
const RECORD_FLOATS: usize = 2 + 5 + SCHEDULE_POINTS * 6 + 9 + 1;
pub const RECORD_BYTES: usize = 4 + 4 * RECORD_FLOATS;
/// The largest table: every taxel of the array.
pub const MAX_TABLE_BYTES: usize = HEADER_BYTES + TAXELS * RECORD_BYTES + CRC_BYTES;

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
}

impl TaxelModel {
    /// Element 4,2 as the memo describes it, for a taxel without a calibration: the Table IV
    /// fit, Table I's element scheduled at its four loads (with the simulator's α), the guide
    /// laws of FACTS.md, and the elastic spring that is Table IV's static gain.
    pub fn nominal(taxel: TaxelId) -> TaxelModel {
        let mut schedule = Vec::new();
        for row in [
            MaxwellKelvin::TABLE_I_10G,
            MaxwellKelvin::TABLE_I_30G,
            MaxwellKelvin::TABLE_I_50G,
            MaxwellKelvin::TABLE_I_80G,
        ] {
            let load = match row.g1 {
                g if g < 3.0 => 10.0,
                g if g < 4.0 => 30.0,
                g if g < 5.0 => 50.0,
                _ => 80.0,
            };
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
        }
    }

    fn floats(&self) -> [f32; RECORD_FLOATS] {
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
        let _ = values.extend_from_slice(&[
            e.g1.base,
            e.g1.sqrt_coeff,
            e.g1.linear_coeff,
            e.n1,
            e.alpha,
            e.n2,
            e.g2.base,
            e.g2.sqrt_coeff,
            e.g2.linear_coeff,
            self.notch_hz,
        ]);
        for (slot, x) in v.iter_mut().zip(values) {
            *slot = x as f32;
        }
        v
    }

    fn from_floats(
        taxel: TaxelId,
        schedule_len: usize,
        f: &[f32; RECORD_FLOATS],
    ) -> Option<TaxelModel> {
        if f.iter().any(|v| !v.is_finite()) || schedule_len > SCHEDULE_POINTS {
            return None;
        }
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
        let law = |i: usize| SpringLaw {
            base: d(i),
            sqrt_coeff: d(i + 1),
            linear_coeff: d(i + 2),
        };
        Some(TaxelModel {
            taxel,
            strain_offset_pct: d(0),
            elastic_g_per_pct: d(1),
            second_order: so(2),
            schedule,
            element: NonlinearMk {
                g1: law(e),
                n1: d(e + 3),
                alpha: d(e + 4),
                n2: d(e + 5),
                g2: law(e + 6),
            },
            notch_hz: d(e + 9),
        })
    }
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

/// Why a table was refused (the firmware then runs the nominal models and says so).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TableError {
    /// Fewer bytes than the header and the records it announces.
    TooShort {
        bytes: usize,
        needed: usize,
    },
    /// Not a table (an erased flash sector reads `0xFF…`).
    BadMagic,
    UnsupportedVersion {
        found: u16,
    },
    /// The stored checksum does not match the contents.
    Checksum {
        stored: u32,
        computed: u32,
    },
    /// More taxels than the array has, or the same taxel twice.
    BadCount {
        count: u16,
    },
    DuplicateTaxel {
        row: u8,
        col: u8,
    },
    /// A record with a position off the array, a non-finite value or a bad schedule length.
    BadRecord {
        index: u16,
    },
    /// The output buffer is too small to hold the table.
    BufferTooSmall {
        needed: usize,
    },
}

impl core::fmt::Display for TableError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            TableError::TooShort { bytes, needed } => {
                write!(f, "calibration table too short: {bytes} bytes, need {needed}")
            }
            TableError::BadMagic => write!(f, "not a calibration table (no TCAL header)"),
            TableError::UnsupportedVersion { found } => write!(
                f,
                "calibration table version {found}; this build reads version {VERSION}"
            ),
            TableError::Checksum { stored, computed } => write!(
                f,
                "calibration table checksum {stored:#010x} does not match its contents ({computed:#010x})"
            ),
            TableError::BadCount { count } => {
                write!(f, "calibration table lists {count} taxels; the array has {TAXELS}")
            }
            TableError::DuplicateTaxel { row, col } => {
                write!(f, "calibration table lists taxel ({row}, {col}) twice")
            }
            TableError::BadRecord { index } => write!(
                f,
                "calibration table record {index}: position off the array, a non-finite value or a bad schedule length"
            ),
            TableError::BufferTooSmall { needed } => {
                write!(f, "calibration table needs a {needed}-byte buffer")
            }
        }
    }
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
        let (version, count) = (
            VERSION.to_le_bytes(),
            (self.taxels.len() as u16).to_le_bytes(),
        );
        let head = MAGIC.iter().chain(&version).chain(&count);
        for (slot, b) in header.iter_mut().zip(head) {
            *slot = *b;
        }
        for (record, model) in rest.chunks_exact_mut(RECORD_BYTES).zip(&self.taxels) {
            let (lead, floats) = record.split_at_mut(4);
            let position = [
                model.taxel.row() as u8,
                model.taxel.col() as u8,
                model.schedule.len() as u8,
                0,
            ];
            lead.copy_from_slice(&position);
            for (slot, v) in floats.chunks_exact_mut(4).zip(model.floats()) {
                slot.copy_from_slice(&v.to_le_bytes());
            }
        }
        let body = needed - CRC_BYTES;
        let crc = crc32(buf.get(..body).unwrap_or(&[]));
        if let Some(slot) = buf.get_mut(body..needed) {
            slot.copy_from_slice(&crc.to_le_bytes());
        }
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
    /// twice, finite values, schedule lengths).
    pub fn check(bytes: &'a [u8]) -> Result<TableView<'a>, TableError> {
        let too_short = |needed| TableError::TooShort {
            bytes: bytes.len(),
            needed,
        };
        let header = bytes.get(..HEADER_BYTES).ok_or(too_short(HEADER_BYTES))?;
        if header.get(..4) != Some(&MAGIC[..]) {
            return Err(TableError::BadMagic);
        }
        let u16_at = |i: usize| u16::from_le_bytes(bytes_at(header, i));
        let version = u16_at(4);
        if version != VERSION {
            return Err(TableError::UnsupportedVersion { found: version });
        }
        let count = u16_at(6);
        if usize::from(count) > TAXELS {
            return Err(TableError::BadCount { count });
        }
        let body = HEADER_BYTES + usize::from(count) * RECORD_BYTES;
        let needed = body + CRC_BYTES;
        let all = bytes.get(..needed).ok_or(too_short(needed))?;
        let (contents, stored) = all.split_at(body);
        let stored = u32::from_le_bytes(bytes_at(stored, 0));
        let computed = crc32(contents);
        if stored != computed {
            return Err(TableError::Checksum { stored, computed });
        }
        let view = TableView {
            records: contents.get(HEADER_BYTES..).unwrap_or(&[]),
            count,
        };
        let mut seen = 0u64;
        for index in 0..usize::from(count) {
            let model = view.record(index).ok_or(TableError::BadRecord {
                index: index as u16,
            })?;
            let bit = 1u64 << model.taxel.index();
            if seen & bit != 0 {
                return Err(TableError::DuplicateTaxel {
                    row: model.taxel.row() as u8,
                    col: model.taxel.col() as u8,
                });
            }
            seen |= bit;
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
        let (row, col, len) = match record {
            [row, col, len, 0, ..] => (*row, *col, *len),
            _ => return None,
        };
        let taxel = TaxelId::new(usize::from(row), usize::from(col))?;
        let mut floats = [0.0f32; RECORD_FLOATS];
        for (v, b) in floats
            .iter_mut()
            .zip(record.get(4..).unwrap_or(&[]).chunks_exact(4))
        {
            *v = f32::from_le_bytes(bytes_at(b, 0));
        }
        TaxelModel::from_floats(taxel, usize::from(len), &floats)
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
            m.element.g1.base *= k;
            m.strain_offset_pct = 0.03 * k;
            m.schedule.truncate(2 + i % 3);
            t.taxels.push(m).unwrap();
        }
        t
    }

    /// Values as f32 keeps them.
    fn rounded(m: &TaxelModel) -> TaxelModel {
        TaxelModel::from_floats(m.taxel, m.schedule.len(), &m.floats()).unwrap()
    }

    #[test]
    fn a_table_reads_back_as_written() {
        let t = table();
        let mut buf = [0u8; MAX_TABLE_BYTES];
        let n = t.encode(&mut buf).unwrap();
        assert_eq!(n, 8 + 3 * RECORD_BYTES + 4);
        assert_eq!(RECORD_BYTES, 168);
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
        let mut v1 = good.clone();
        v1[4] = 1;
        assert_eq!(
            CalibrationTable::decode(&v1),
            Err(TableError::UnsupportedVersion { found: 1 })
        );
        // Well-formed but wrong inside (checksum recomputed): a position off the array.
        let mut off = good.clone();
        off[8] = 9;
        let crc = crc32(&off[..n - 4]);
        off[n - 4..].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(
            CalibrationTable::decode(&off),
            Err(TableError::BadRecord { index: 0 })
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
