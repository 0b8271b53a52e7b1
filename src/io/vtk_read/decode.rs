//! Binary VTK values decoded into arrays (in parallel), each allocated
//! first and fallibly, so that an array too big for memory is an error
//! naming it rather than an abort.

use super::common::Scalar;
use crate::mem::{AllocError, try_filled, try_vec};

macro_rules! decode_chunks {
    ($out:expr, $bytes:expr, $t:ty, $big:expr, $conv:expr) => {{
        const N: usize = std::mem::size_of::<$t>();
        // Indexed parallel decode (keeps the order; large arrays split
        // across threads) into `$out`, whose room is already there.
        rayon::iter::IndexedParallelIterator::collect_into_vec(
            rayon::iter::ParallelIterator::map(
                rayon::slice::ParallelSlice::par_chunks_exact($bytes, N),
                |c| {
                    let mut a = [0u8; N];
                    a.copy_from_slice(c);
                    let v = if $big {
                        <$t>::from_be_bytes(a)
                    } else {
                        <$t>::from_le_bytes(a)
                    };
                    $conv(v)
                },
            ),
            $out,
        )
    }};
}

/// Unpacks `n` bits, most significant bit first (legacy `bit` arrays).
fn unpack_bits(bytes: &[u8], n: usize) -> impl Iterator<Item = u8> + '_ {
    (0..n).map(move |i| bytes.get(i / 8).map_or(0, |b| (b >> (7 - (i % 8))) & 1))
}

/// Decodes binary values to f64 (`bytes.len()` must be a multiple of the
/// size; trailing bytes are ignored). For [`Scalar::Bit`], `bits` values.
/// The decoded array is allocated first, fallibly (`what` names it).
pub(crate) fn decode_f64(
    bytes: &[u8],
    ty: Scalar,
    big: bool,
    bits: usize,
    what: &str,
) -> Result<Vec<f64>, AllocError> {
    let mut out = try_vec(values_in(bytes, ty, bits), what)?;
    match ty {
        Scalar::Bit => out.extend(unpack_bits(bytes, bits).map(f64::from)),
        Scalar::I8 => out.extend(bytes.iter().map(|&b| f64::from(b as i8))),
        Scalar::U8 => out.extend(bytes.iter().map(|&b| f64::from(b))),
        Scalar::I16 => decode_chunks!(&mut out, bytes, i16, big, f64::from),
        Scalar::U16 => decode_chunks!(&mut out, bytes, u16, big, f64::from),
        Scalar::I32 => decode_chunks!(&mut out, bytes, i32, big, f64::from),
        Scalar::U32 => decode_chunks!(&mut out, bytes, u32, big, f64::from),
        Scalar::I64 => decode_chunks!(&mut out, bytes, i64, big, |v: i64| v as f64),
        Scalar::U64 => decode_chunks!(&mut out, bytes, u64, big, |v: u64| v as f64),
        Scalar::F32 => decode_chunks!(&mut out, bytes, f32, big, f64::from),
        Scalar::F64 => decode_chunks!(&mut out, bytes, f64, big, |v: f64| v),
    }
    Ok(out)
}

/// How many values of `ty` `bytes` hold (`bits` for packed bits).
fn values_in(bytes: &[u8], ty: Scalar, bits: usize) -> usize {
    match ty.size() {
        0 => bits,
        n => bytes.len() / n,
    }
}

/// Decodes binary integer values to i64. Floating-point types are refused;
/// `UInt64` values above `i64::MAX` are clamped to `i64::MAX` (they are
/// rejected later as out-of-range ids).
pub(crate) fn decode_i64(
    bytes: &[u8],
    ty: Scalar,
    big: bool,
    bits: usize,
) -> Result<Vec<i64>, String> {
    if matches!(ty, Scalar::F32 | Scalar::F64) {
        return Err(format!("{ty:?} values where integers are required"));
    }
    let values = values_in(bytes, ty, bits);
    let mut out = try_vec(values, "the decoded integers").map_err(|e| e.to_string())?;
    match ty {
        Scalar::Bit => out.extend(unpack_bits(bytes, bits).map(i64::from)),
        Scalar::I8 => out.extend(bytes.iter().map(|&b| i64::from(b as i8))),
        Scalar::U8 => out.extend(bytes.iter().map(|&b| i64::from(b))),
        Scalar::I16 => decode_chunks!(&mut out, bytes, i16, big, i64::from),
        Scalar::U16 => decode_chunks!(&mut out, bytes, u16, big, i64::from),
        Scalar::I32 => decode_chunks!(&mut out, bytes, i32, big, i64::from),
        Scalar::U32 => decode_chunks!(&mut out, bytes, u32, big, i64::from),
        Scalar::I64 => decode_chunks!(&mut out, bytes, i64, big, |v: i64| v),
        Scalar::U64 => decode_chunks!(&mut out, bytes, u64, big, |v: u64| i64::try_from(v)
            .unwrap_or(i64::MAX)),
        Scalar::F32 | Scalar::F64 => unreachable!("refused above"),
    }
    Ok(out)
}

/// Decodes binary integer values straight to u32 when every one is in
/// `0..u32::MAX` (ids and counts); `None` otherwise (the caller then takes
/// [`decode_i64`] and names the bad value). The array is allocated first,
/// fallibly (`what` names it).
pub(crate) fn decode_u32_ids(
    bytes: &[u8],
    ty: Scalar,
    big: bool,
    what: &str,
) -> Result<Option<Vec<u32>>, AllocError> {
    use rayon::prelude::*;
    /// Values per parallel task.
    const BLOCK: usize = 1 << 16;
    macro_rules! narrow {
        ($t:ty) => {{
            const N: usize = std::mem::size_of::<$t>();
            let mut out = try_filled(bytes.len() / N, 0u32, what)?;
            // Through i64 then u64: negatives and values past u32::MAX - 1
            // (including u64 values past i64::MAX) all land at or above
            // u32::MAX.
            let ok = out
                .par_chunks_mut(BLOCK)
                .zip(bytes.par_chunks(BLOCK * N))
                .map(|(o, b)| {
                    let mut ok = true;
                    for (d, c) in o.iter_mut().zip(b.chunks_exact(N)) {
                        let mut a = [0u8; N];
                        a.copy_from_slice(c);
                        let v = if big {
                            <$t>::from_be_bytes(a)
                        } else {
                            <$t>::from_le_bytes(a)
                        } as i64 as u64;
                        ok &= v < u32::MAX as u64;
                        *d = v as u32;
                    }
                    ok
                })
                .reduce(|| true, |a, b| a & b);
            Ok(ok.then_some(out))
        }};
    }
    match ty {
        Scalar::I32 => narrow!(i32),
        Scalar::U32 => narrow!(u32),
        Scalar::I64 => narrow!(i64),
        Scalar::U64 => narrow!(u64),
        _ => Ok(None),
    }
}
