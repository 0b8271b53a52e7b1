//! Decimal number tokens of the text formats: GRDECL, and the ASCII arrays
//! of legacy and XML VTK files. One parser serves both: Clinger's fast path
//! (exact for up to 19 significant digits and a decimal exponent within
//! ±22: one correctly rounded multiplication or division by a power of
//! ten), the standard library's correctly rounded parser otherwise, so every
//! token gets the nearest `f64` whichever path it takes.
//!
//! The formats differ only in the exponent letters: VTK writes `e`/`E`
//! ([`parse_decimal`]); GRDECL also takes Fortran's `d`/`D`
//! ([`parse_fortran`], e.g. `1.0D+03`).

/// Powers of ten that are exact in `f64` (`10^22 < 2^53 · 2^22`).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Parses a decimal number with an `e`/`E` exponent (`1`, `-2.5`, `.5`,
/// `3.`, `1e-3`), as VTK writes them. Returns `None` for anything else;
/// NaN and infinities come back as such (`nan`, `inf`), for the caller to
/// reject.
pub(crate) fn parse_decimal(t: &[u8]) -> Option<f64> {
    match parse_prefix::<false>(t) {
        Some((v, n)) if n == t.len() => Some(v),
        Some(_) => None,
        // Not on the fast path (nan, inf, junk, too many digits, a large
        // exponent): the standard library decides on the whole token.
        None => std::str::from_utf8(t).ok()?.parse::<f64>().ok(),
    }
}

/// Parses a decimal number (`1`, `-2.5`, `.5`, `3.`, `1e-3`, Fortran
/// `1.0D+03`). Returns `None` for anything else; NaN and infinities come
/// back as such (`nan`, `inf`), for the caller to reject.
pub fn parse_fortran(t: &[u8]) -> Option<f64> {
    match parse_prefix::<true>(t) {
        Some((v, n)) if n == t.len() => Some(v),
        Some(_) => None,
        // Not on the fast path (nan, inf, junk, too many digits, a large
        // exponent): the standard library decides on the whole token.
        None => parse_slow_fortran(t),
    }
}

/// The fast path: a number at the start of `t` with at most 19 significant
/// digits and a decimal exponent within ±22 (exact by Clinger's rule), and
/// the bytes it used; the exponent letter is `e`/`E`, or also `d`/`D` when
/// `FORTRAN`. `None` when the fast path does not apply.
///
/// The digits are accumulated without per-digit checks (wrapping: a number
/// of more than 19 significant digits is rejected afterwards, so its
/// mantissa is never used); significant digits are the digits after the
/// leading zeros of the integer part and, when that part is all zeros, of
/// the fraction.
#[inline(always)]
pub(crate) fn parse_prefix<const FORTRAN: bool>(t: &[u8]) -> Option<(f64, usize)> {
    let n = t.len();
    let (neg, mut i) = sign(t, 0);
    let mut mant: u64 = 0;
    let int0 = i;
    while i < n && t[i].is_ascii_digit() {
        mant = mant.wrapping_mul(10).wrapping_add((t[i] - b'0') as u64);
        i += 1;
    }
    let int1 = i;
    let (mut frac0, mut frac1) = (i, i);
    if i < n && t[i] == b'.' {
        i += 1;
        frac0 = i;
        while i < n && t[i].is_ascii_digit() {
            mant = mant.wrapping_mul(10).wrapping_add((t[i] - b'0') as u64);
            i += 1;
        }
        frac1 = i;
    }
    let total = (int1 - int0) + (frac1 - frac0);
    if total == 0 {
        return None;
    }
    // Leading zeros (not significant).
    let mut lz = t[int0..int1].iter().take_while(|&&c| c == b'0').count();
    if lz == int1 - int0 {
        lz += t[frac0..frac1].iter().take_while(|&&c| c == b'0').count();
    }
    let mut exp = -((frac1 - frac0) as i32);
    if i < n && is_exponent_letter::<FORTRAN>(t[i]) {
        let (e, j) = exponent(t, i + 1)?;
        exp = exp.saturating_add(e);
        i = j;
    }
    if total - lz > 19 {
        return None;
    }
    Some((exact_value(mant, exp, neg)?, i))
}

/// Whether `c` starts an exponent: `e`/`E`, and `d`/`D` when `FORTRAN`.
#[inline(always)]
fn is_exponent_letter<const FORTRAN: bool>(c: u8) -> bool {
    matches!(c, b'e' | b'E') || (FORTRAN && matches!(c, b'd' | b'D'))
}

/// `±mant · 10^exp` when Clinger's fast path makes it exact (`mant < 2^53`,
/// `|exp| ≤ 22`: one correctly rounded multiplication or division).
#[inline(always)]
fn exact_value(mant: u64, exp: i32, neg: bool) -> Option<f64> {
    if mant >= 1 << 53 || !(-22..=22).contains(&exp) {
        return None;
    }
    let m = mant as f64;
    let v = if exp >= 0 {
        m * POW10[exp as usize]
    } else {
        m / POW10[(-exp) as usize]
    };
    Some(if neg { -v } else { v })
}

/// An optional sign at `t[i]`: whether it is `-`, and where what follows starts.
#[inline(always)]
fn sign(t: &[u8], i: usize) -> (bool, usize) {
    match t.get(i) {
        Some(b'-') => (true, i + 1),
        Some(b'+') => (false, i + 1),
        _ => (false, i),
    }
}

/// The exponent after the exponent letter of a number, from `t[i]` on: its
/// signed value (saturating) and where it ends; `None` without digits.
#[inline(always)]
fn exponent(t: &[u8], i: usize) -> Option<(i32, usize)> {
    let (neg, mut i) = sign(t, i);
    let s = i;
    let mut e: i32 = 0;
    while i < t.len() && t[i].is_ascii_digit() {
        e = e.saturating_mul(10).saturating_add((t[i] - b'0') as i32);
        i += 1;
    }
    (i > s).then_some((if neg { -e } else { e }, i))
}

/// The standard library's parse of a GRDECL token of at most 400 bytes,
/// its `d`/`D` exponent read as `e`.
fn parse_slow_fortran(t: &[u8]) -> Option<f64> {
    let s = std::str::from_utf8(t).ok()?;
    if s.len() > 400 {
        return None;
    }
    let s: String = s
        .chars()
        .map(|c| if c == 'd' || c == 'D' { 'e' } else { c })
        .collect();
    s.parse::<f64>().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The previous `parse_prefix` (per-digit significance counting), kept
    /// as the reference.
    fn parse_prefix_reference(t: &[u8]) -> Option<(f64, usize)> {
        let n = t.len();
        let (neg, mut i) = sign(t, 0);
        let mut mant: u64 = 0;
        let mut digits = 0u32;
        let mut any = false;
        let mut exp: i32 = 0;
        while i < n && t[i].is_ascii_digit() {
            any = true;
            if digits < 19 {
                mant = mant * 10 + (t[i] - b'0') as u64;
                if mant != 0 {
                    digits += 1;
                }
            } else {
                exp += 1;
                digits += 1;
            }
            i += 1;
        }
        if i < n && t[i] == b'.' {
            i += 1;
            while i < n && t[i].is_ascii_digit() {
                any = true;
                if digits < 19 {
                    mant = mant * 10 + (t[i] - b'0') as u64;
                    if mant != 0 {
                        digits += 1;
                    }
                    exp -= 1;
                } else {
                    digits += 1;
                }
                i += 1;
            }
        }
        if !any {
            return None;
        }
        if i < n && matches!(t[i], b'e' | b'E' | b'd' | b'D') {
            let (e, j) = exponent(t, i + 1)?;
            exp = exp.saturating_add(e);
            i = j;
        }
        if digits > 19 {
            return None;
        }
        Some((exact_value(mant, exp, neg)?, i))
    }

    /// `parse_prefix` gives the same value (bit for bit) and length as the
    /// reference on random tokens over the characters numbers are made of,
    /// and on long digit runs around the 19-digit and ±22 exponent limits.
    #[test]
    fn parse_prefix_equals_the_reference() {
        let alphabet = b"0000123456789..--++eEdD* /x";
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut tokens: Vec<Vec<u8>> = Vec::new();
        for _ in 0..200_000 {
            let len = (next() % 28) as usize;
            tokens.push(
                (0..len)
                    .map(|_| alphabet[(next() % alphabet.len() as u64) as usize])
                    .collect(),
            );
        }
        for int in 0..26 {
            for frac in 0..26 {
                for zeros in [0, 1, 5, 20] {
                    for e in ["", "e3", "E-22", "D+23", "e-5"] {
                        let z = "0".repeat(zeros);
                        tokens.push(
                            format!("{z}{}.{}{e}", "7".repeat(int), "3".repeat(frac)).into_bytes(),
                        );
                        tokens.push(format!("-0.{z}{}{e}", "9".repeat(frac)).into_bytes());
                        tokens.push(format!("{}{z}{e}", "1".repeat(int)).into_bytes());
                    }
                }
            }
        }
        for odd in [b':', b';', b'?', 0x7f, 0xfa, 0xff, 0x80, 0x00] {
            for at in 0..12 {
                let mut t = b"123456789012.3456789".to_vec();
                t.insert(at, odd);
                tokens.push(t);
            }
        }
        tokens.push(b"9007199254740992".to_vec());
        tokens.push(b"9007199254740991".to_vec());
        tokens.push(b"18446744073709551616".to_vec());
        // The same tokens followed by more bytes (the window goes on after
        // a token, so the eight-byte steps run): a separator, then digits.
        let padded: Vec<Vec<u8>> = tokens
            .iter()
            .enumerate()
            .map(|(k, t)| {
                let mut p = t.clone();
                p.push([b' ', b'/', b'\n', b'*', b'x', b'e'][k % 6]);
                p.extend_from_slice(b"1234567890");
                p
            })
            .collect();
        tokens.extend(padded);
        let mut parsed = 0;
        for t in &tokens {
            let a = parse_prefix::<true>(t).map(|(v, l)| (v.to_bits(), l));
            let b = parse_prefix_reference(t).map(|(v, l)| (v.to_bits(), l));
            assert_eq!(a, b, "{}", String::from_utf8_lossy(t));
            parsed += a.is_some() as usize;
        }
        assert!(parsed > 10_000, "only {parsed} tokens took the fast path");
    }

    #[test]
    fn fast_float_matches_std() {
        for s in [
            "0",
            "-0",
            "1",
            "0.1",
            "-2.5e-3",
            "3.90799e-16",
            "1e22",
            "1e23",
            "123456789012345678901",
            "0.000123",
            "1.7976931348623157e308",
            "5e-324",
            "2.2782070e-01",
            "9007199254740993",
            ".5",
            "5.",
            "+7",
        ] {
            let want: f64 = s.parse().unwrap();
            assert_eq!(
                parse_decimal(s.as_bytes()).map(f64::to_bits),
                Some(want.to_bits()),
                "{s}"
            );
        }
        assert!(parse_decimal(b"nan").unwrap().is_nan());
        assert_eq!(parse_decimal(b"-inf"), Some(f64::NEG_INFINITY));
        assert_eq!(parse_decimal(b"1e"), None);
        assert_eq!(parse_decimal(b"abc"), None);
        assert_eq!(parse_decimal(b"-"), None);
    }

    /// VTK's tokens: `parse_decimal` is the standard library's parse (bit
    /// for bit, and the same rejections) on random tokens over the
    /// characters numbers are made of, Fortran's `d` exponent included.
    #[test]
    fn parse_decimal_equals_std() {
        let alphabet = b"0000123456789..--++eEdD x";
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut parsed = 0;
        for _ in 0..200_000 {
            let len = (next() % 28) as usize;
            let t: Vec<u8> = (0..len)
                .map(|_| alphabet[(next() % alphabet.len() as u64) as usize])
                .collect();
            let want = std::str::from_utf8(&t).unwrap().parse::<f64>().ok();
            let got = parse_decimal(&t);
            assert_eq!(
                got.map(f64::to_bits),
                want.map(f64::to_bits),
                "{}",
                String::from_utf8_lossy(&t)
            );
            parsed += got.is_some() as usize;
        }
        assert!(parsed > 1_000, "only {parsed} tokens parsed");
    }
}
