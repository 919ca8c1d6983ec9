//! The seal of the project's binary forms (the calibration and controller tables, an
//! applicator's form): 4 magic bytes, a little-endian u16 version, the contents, then the
//! CRC-32 of everything before it.

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_is_the_ieee_check_value() {
        // The CRC catalogue's check value of CRC-32/ISO-HDLC for "123456789".
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }
}
