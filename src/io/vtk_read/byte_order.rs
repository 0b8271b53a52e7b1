//! Byte-order plausibility for BINARY legacy VTK: the format is big-endian,
//! but some tools write little-endian. Coordinates read with the wrong byte
//! order come out denormal or absurd (1e-41, 1e+38), while the same bytes
//! read little-endian look like a grid; such a file is refused with a
//! message naming the byte order rather than sliced "successfully".

use super::common::{Scalar, decode_f64};

/// A value no real coordinate takes: NaN or infinite, nonzero below 1e-30
/// in magnitude (denormal or nearly so), or above 1e30.
fn implausible(x: f64) -> bool {
    !x.is_finite() || (x != 0.0 && (x.abs() < 1e-30 || x.abs() > 1e30))
}

/// When `be` (the values `bytes` give read big-endian, as the format says)
/// hold implausible coordinates and the same bytes read little-endian hold
/// none, the message to refuse the file with.
pub(crate) fn little_endian_hint(bytes: &[u8], ty: Scalar, be: &[f64]) -> Option<String> {
    if !matches!(ty, Scalar::F32 | Scalar::F64) {
        return None;
    }
    let bad = be.iter().position(|&x| implausible(x))?;
    // No memory for the second reading: no hint (the values stand).
    let le = decode_f64(bytes, ty, false, be.len(), "POINTS (little-endian)").ok()?;
    let le_bad = le.iter().filter(|&&x| implausible(x)).count();
    let bad_count = be.iter().filter(|&&x| implausible(x)).count();
    if le_bad > 0 {
        return None;
    }
    Some(format!(
        "POINTS look little-endian: read big-endian, as legacy VTK BINARY files must be written, \
         value {bad} is {:e} ({bad_count} of {} values implausible), while read little-endian all \
         are plausible (value {bad} = {}). Rewrite the file big-endian (VTK's own writers do), or as ASCII or VTK XML",
        be[bad],
        be.len(),
        le[bad]
    ))
}
