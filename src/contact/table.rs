//! The array's spatial response as a table the firmware carries (`TSPA`): the pitch, the
//! rubber's depth over the plates, the plate's side and each taxel's gain, learned from presses
//! at known positions (`tactile calibrate --array`) and checked at start-up like the
//! calibration table (the seal: magic, version, CRC-32).
//!
//! Layout, little-endian: `TSPA`, u16 version, f32 pitch, depth and plate (mm), 64 × f32 gains
//! by taxel index, CRC-32 of everything before it: 278 bytes.

use super::response::SpatialResponse;
use crate::seal::{self, SealError};
use crate::tactile::TAXELS;

const MAGIC: [u8; 4] = *b"TSPA";
const VERSION: u16 = 1;
/// Bytes of a spatial table.
pub const SPATIAL_TABLE_BYTES: usize = 6 + 3 * 4 + TAXELS * 4 + 4;
/// A gain outside this range is no element the array could hold (a dead or shorted plate
/// reads as a bad taxel, not as a gain).
const GAIN_RANGE: (f32, f32) = (0.2, 5.0);
/// Pitch and depth, mm: a fingertip's array, not a misread number.
const LENGTH_RANGE_MM: (f32, f32) = (0.1, 50.0);

/// Why a spatial table was refused (the firmware then locates with the memo geometry and says
/// so).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SpatialTableError {
    #[error("spatial table too short: {bytes} bytes, need {needed}")]
    TooShort { bytes: usize, needed: usize },
    #[error("not a spatial table (no TSPA header)")]
    BadMagic,
    #[error("spatial table version {found}; this build reads version {VERSION}")]
    UnsupportedVersion { found: u16 },
    #[error(
        "spatial table checksum {stored:#010x} does not match its contents ({computed:#010x})"
    )]
    Checksum { stored: u32, computed: u32 },
    /// A pitch, depth or plate off the range a finger could have, or a plate wider than the
    /// pitch.
    #[error(
        "spatial table geometry out of range (pitch and depth 0.1–50 mm, plate within the pitch)"
    )]
    BadGeometry,
    /// A gain not finite or outside 0.2–5.
    #[error("spatial table gain of taxel {index} out of 0.2–5")]
    BadGain { index: u8 },
}

impl From<SealError> for SpatialTableError {
    fn from(e: SealError) -> Self {
        match e {
            SealError::TooShort { bytes, needed } => Self::TooShort { bytes, needed },
            SealError::BadMagic => Self::BadMagic,
            SealError::UnsupportedVersion { found } => Self::UnsupportedVersion { found },
            SealError::Checksum { stored, computed } => Self::Checksum { stored, computed },
        }
    }
}

impl SpatialResponse {
    /// The sealed table of this response.
    pub fn encode(&self) -> [u8; SPATIAL_TABLE_BYTES] {
        let mut out = [0u8; SPATIAL_TABLE_BYTES];
        let values = [self.pitch_mm, self.depth_mm, self.plate_mm]
            .into_iter()
            .chain(self.gain);
        for (slot, v) in out
            .get_mut(6..)
            .unwrap_or(&mut [])
            .chunks_exact_mut(4)
            .zip(values)
        {
            slot.copy_from_slice(&v.to_le_bytes());
        }
        seal::seal(&mut out, MAGIC, VERSION);
        out
    }

    /// A sealed table read and checked (header, length, CRC, geometry, every gain).
    pub fn decode(bytes: &[u8]) -> Result<SpatialResponse, SpatialTableError> {
        seal::check_head(bytes, MAGIC, VERSION)?;
        let contents = seal::check_crc(bytes, SPATIAL_TABLE_BYTES)?;
        let at = |k: usize| f32::from_le_bytes(seal::bytes_at(contents, 6 + 4 * k));
        let r = SpatialResponse {
            pitch_mm: at(0),
            depth_mm: at(1),
            plate_mm: at(2),
            gain: core::array::from_fn(|i| at(3 + i)),
        };
        r.check()?;
        Ok(r)
    }

    /// Whether this response is one a finger could have (what [`Self::decode`] checks).
    pub fn check(&self) -> Result<(), SpatialTableError> {
        let length = |v: f32| v >= LENGTH_RANGE_MM.0 && v <= LENGTH_RANGE_MM.1;
        if !(length(self.pitch_mm)
            && length(self.depth_mm)
            && self.plate_mm > 0.0
            && self.plate_mm <= self.pitch_mm)
        {
            return Err(SpatialTableError::BadGeometry);
        }
        match self
            .gain
            .iter()
            .position(|g| !(*g >= GAIN_RANGE.0 && *g <= GAIN_RANGE.1))
        {
            Some(i) => Err(SpatialTableError::BadGain { index: i as u8 }),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_table_reads_back_as_written_and_damage_is_named() {
        let mut r = SpatialResponse {
            pitch_mm: 5.0,
            depth_mm: 3.0,
            ..SpatialResponse::MEMO
        };
        r.gain[9] = 1.07;
        let bytes = r.encode();
        assert_eq!(SpatialResponse::decode(&bytes), Ok(r));
        let mut flipped = bytes;
        flipped[40] ^= 1;
        assert!(matches!(
            SpatialResponse::decode(&flipped),
            Err(SpatialTableError::Checksum { .. })
        ));
        assert!(matches!(
            SpatialResponse::decode(&bytes[..100]),
            Err(SpatialTableError::TooShort { .. })
        ));
        assert_eq!(
            SpatialResponse::decode(&[0xFF; SPATIAL_TABLE_BYTES]),
            Err(SpatialTableError::BadMagic)
        );
        r.gain[3] = f32::NAN;
        assert_eq!(
            SpatialResponse::decode(&r.encode()),
            Err(SpatialTableError::BadGain { index: 3 })
        );
        r.gain[3] = 1.0;
        r.plate_mm = 6.0;
        assert_eq!(
            SpatialResponse::decode(&r.encode()),
            Err(SpatialTableError::BadGeometry)
        );
    }
}
