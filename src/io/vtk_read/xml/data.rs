//! Data arrays: ascii text, base64 and raw appended payloads, block
//! headers, zlib / LZMA / LZ4 decompression, typed values.

use super::scan::Elem;
use super::{Ctx, LZMA_MEMLIMIT, VtkReadError, label, tokens};
use crate::io::number::parse_decimal;
use crate::io::vtk_read::common::{
    Scalar, decode_f64, decode_i64, decode_u32_ids, is_ws, parse_i64,
};
use std::borrow::Cow;
use std::io::Read;

/// Base64 decoding that skips whitespace and accepts padding in the middle
/// (VTK pads its header and its data separately).
pub(super) fn base64_decode(text: &[u8]) -> Result<Vec<u8>, String> {
    fn val(c: u8) -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        } as u32)
    }
    let mut out = crate::mem::try_vec(text.len() / 4 * 3 + 3, "the base64-decoded bytes")
        .map_err(|e| e.to_string())?;
    let mut quad = [0u8; 4];
    let mut n = 0;
    let flush = |quad: &[u8; 4], n: usize, out: &mut Vec<u8>| -> Result<(), String> {
        // `n` significant characters (2..=4), the rest is padding.
        let mut acc = 0u32;
        for (k, &c) in quad.iter().enumerate() {
            let v = if k < n {
                val(c).ok_or_else(|| format!("invalid base64 character '{}'", c as char))?
            } else {
                0
            };
            acc = (acc << 6) | v;
        }
        let bytes = acc.to_be_bytes();
        match n {
            4 => out.extend_from_slice(&bytes[1..4]),
            3 => out.extend_from_slice(&bytes[1..3]),
            2 => out.push(bytes[1]),
            _ => return Err("truncated base64 group".into()),
        }
        Ok(())
    };
    let mut pad = 0;
    for &c in text {
        if is_ws(c) {
            continue;
        }
        if c == b'=' {
            pad += 1;
            if n + pad == 4 {
                flush(&quad, n, &mut out)?;
                n = 0;
                pad = 0;
            } else if n + pad > 4 || n < 2 {
                return Err("misplaced base64 padding".into());
            }
            continue;
        }
        if pad > 0 {
            return Err("base64 data after incomplete padding".into());
        }
        if val(c).is_none() {
            return Err(format!(
                "invalid base64 character '{}'",
                (c as char).escape_default()
            ));
        }
        quad[n] = c;
        n += 1;
        if n == 4 {
            flush(&quad, 4, &mut out)?;
            n = 0;
        }
    }
    if n > 0 || pad > 0 {
        // Unpadded tail: decode what is there.
        flush(&quad, n, &mut out)?;
    }
    Ok(out)
}

#[derive(Clone, Copy, PartialEq, Debug)]
pub(super) enum Compressor {
    None,
    Zlib,
    Lzma,
    Lz4,
}

pub(super) enum Payload<'a> {
    Text(Cow<'a, [u8]>),
    Bytes(Cow<'a, [u8]>),
}

impl<'a> Ctx<'a, '_> {
    pub(super) fn text(&self, e: &Elem) -> Cow<'a, [u8]> {
        match e.text.as_slice() {
            [] => Cow::Borrowed(&[][..]),
            [(a, b)] => Cow::Borrowed(&self.doc.b[*a..*b]),
            many => {
                let mut v = Vec::new();
                for &(a, b) in many {
                    v.extend_from_slice(&self.doc.b[a..b]);
                    v.push(b' ');
                }
                Cow::Owned(v)
            }
        }
    }

    pub(super) fn header_word(&self, data: &[u8], k: usize) -> Option<u64> {
        let hs = if self.h64 { 8 } else { 4 };
        let s = data.get(k.checked_mul(hs)?..k.checked_add(1)?.checked_mul(hs)?)?;
        Some(if self.h64 {
            let a: [u8; 8] = s.try_into().ok()?;
            if self.big {
                u64::from_be_bytes(a)
            } else {
                u64::from_le_bytes(a)
            }
        } else {
            let a: [u8; 4] = s.try_into().ok()?;
            u64::from(if self.big {
                u32::from_be_bytes(a)
            } else {
                u32::from_le_bytes(a)
            })
        })
    }

    /// Strips the block header (and decompresses) from binary array data.
    pub(super) fn unblock<'x>(
        &self,
        data: &'x [u8],
        name: &str,
    ) -> Result<Cow<'x, [u8]>, VtkReadError> {
        let hs: usize = if self.h64 { 8 } else { 4 };
        let word = |k: usize, what: &str| {
            let w = self.header_word(data, k).ok_or_else(|| {
                self.count_err(
                    name,
                    format!("{what} (binary header bytes)"),
                    (k + 1) * hs,
                    data.len(),
                )
            })?;
            usize::try_from(w).map_err(|_| self.xml_err(name, format!("{what} {w} out of range")))
        };
        if self.comp == Compressor::None {
            let n = word(0, "byte count")?;
            let body = data.get(hs..).unwrap_or(&[]);
            return body.get(..n).map(Cow::Borrowed).ok_or_else(|| {
                self.count_err(name, "data bytes given by the header", n, body.len())
            });
        }
        let nb = word(0, "block count")?;
        let bs = word(1, "block size")?;
        let last = word(2, "last block size")?;
        let head = nb
            .checked_add(3)
            .and_then(|v| v.checked_mul(hs))
            .filter(|&h| h <= data.len())
            .ok_or_else(|| {
                self.count_err(
                    name,
                    "compression header bytes",
                    nb.saturating_add(3).saturating_mul(hs),
                    data.len(),
                )
            })?;
        let mut out = Vec::new();
        let mut pos = head;
        for k in 0..nb {
            let cs = word(3 + k, "compressed block size")?;
            let blk = pos
                .checked_add(cs)
                .and_then(|e| data.get(pos..e))
                .ok_or_else(|| {
                    self.count_err(
                        name,
                        format!("bytes of compressed block {k}"),
                        cs,
                        data.len().saturating_sub(pos),
                    )
                })?;
            let expect = if k + 1 == nb && last != 0 { last } else { bs };
            self.decompress(blk, expect, &mut out, name, k)?;
            pos += cs;
        }
        Ok(Cow::Owned(out))
    }

    pub(super) fn decompress(
        &self,
        blk: &[u8],
        expect: usize,
        out: &mut Vec<u8>,
        name: &str,
        k: usize,
    ) -> Result<(), VtkReadError> {
        let before = out.len();
        let fail = |e: String| {
            self.xml_err(
                name,
                format!("block {k}: {:?} decompression failed: {e}", self.comp),
            )
        };
        match self.comp {
            Compressor::None => out.extend_from_slice(blk),
            Compressor::Zlib => {
                flate2::read::ZlibDecoder::new(blk)
                    .take(expect as u64)
                    .read_to_end(out)
                    .map_err(|e| fail(e.to_string()))?;
            }
            Compressor::Lzma => {
                let stream = xz2::stream::Stream::new_auto_decoder(LZMA_MEMLIMIT, 0)
                    .map_err(|e| fail(e.to_string()))?;
                xz2::read::XzDecoder::new_stream(blk, stream)
                    .take(expect as u64)
                    .read_to_end(out)
                    .map_err(|e| fail(e.to_string()))?;
            }
            Compressor::Lz4 => {
                // LZ4 cannot expand more than ~255x: refuse headers claiming more.
                if expect > blk.len().saturating_mul(255).saturating_add(64) {
                    return Err(self.count_err(
                        name,
                        format!("plausible size of LZ4 block {k}"),
                        blk.len() * 255,
                        expect,
                    ));
                }
                let mut buf = crate::mem::try_filled(expect, 0u8, "an LZ4 block")
                    .map_err(|e| fail(e.to_string()))?;
                let n = lz4_flex::block::decompress_into(blk, &mut buf)
                    .map_err(|e| fail(e.to_string()))?;
                out.extend_from_slice(&buf[..n.min(expect)]);
            }
        }
        let got = out.len() - before;
        if got != expect {
            return Err(self.count_err(
                name,
                format!("decompressed bytes of block {k}"),
                expect,
                got,
            ));
        }
        Ok(())
    }

    pub(super) fn payload(&self, e: &Elem<'a>) -> Result<Payload<'a>, VtkReadError> {
        let name = label(e);
        let fmt = e
            .attr("format")
            .ok_or_else(|| self.xml_err(&name, "missing attribute format"))?;
        match fmt {
            "ascii" => Ok(Payload::Text(self.text(e))),
            "binary" => {
                let raw = base64_decode(&self.text(e)).map_err(|m| self.xml_err(&name, m))?;
                Ok(Payload::Bytes(Cow::Owned(
                    self.unblock(&raw, &name)?.into_owned(),
                )))
            }
            "appended" => {
                let app = self.doc.appended.ok_or_else(|| {
                    self.xml_err(&name, "format=\"appended\" but no <AppendedData>")
                })?;
                let off = self.usize_attr(e, "offset", &name)?;
                let start = app
                    .start
                    .checked_add(off)
                    .filter(|&s| s <= app.end)
                    .ok_or_else(|| {
                        self.count_err(
                            &name,
                            "appended offset within the appended data",
                            app.end - app.start,
                            off,
                        )
                    })?;
                if app.base64 {
                    let next = self.app_offsets.iter().copied().find(|&o| o > off);
                    let end = next
                        .and_then(|o| app.start.checked_add(o))
                        .map_or(app.end, |e| e.min(app.end));
                    let raw = base64_decode(&self.doc.b[start..end])
                        .map_err(|m| self.xml_err(&name, m))?;
                    Ok(Payload::Bytes(Cow::Owned(
                        self.unblock(&raw, &name)?.into_owned(),
                    )))
                } else {
                    Ok(Payload::Bytes(
                        self.unblock(&self.doc.b[start..app.end], &name)?,
                    ))
                }
            }
            other => Err(self.unsupported(format!("{name}: format '{other}'"))),
        }
    }

    pub(super) fn scalar(&self, e: &Elem) -> Result<Scalar, VtkReadError> {
        let t = e
            .attr("type")
            .ok_or_else(|| self.xml_err(label(e), "missing attribute type"))?;
        Scalar::from_xml(t).ok_or_else(|| self.unsupported(format!("{}: type '{t}'", label(e))))
    }

    pub(super) fn components(&self, e: &Elem) -> Result<usize, VtkReadError> {
        match e.attr("NumberOfComponents") {
            None => Ok(1),
            Some(v) => v
                .trim()
                .parse::<usize>()
                .ok()
                .filter(|c| (1..=65536).contains(c))
                .ok_or_else(|| {
                    self.xml_err(label(e), format!("invalid NumberOfComponents=\"{v}\""))
                }),
        }
    }

    pub(super) fn check_bytes(&self, e: &Elem, b: &[u8], ty: Scalar) -> Result<(), VtkReadError> {
        let size = ty.size().max(1);
        if !b.len().is_multiple_of(size) {
            return Err(self.count_err(
                label(e),
                format!("bytes (a multiple of {size}, the size of {ty:?})"),
                b.len() / size * size,
                b.len(),
            ));
        }
        Ok(())
    }

    /// The whitespace-separated values of an ASCII payload; a token that
    /// `parse` rejects is an error naming it as an invalid `what`.
    pub(super) fn text_values<T>(
        &self,
        e: &Elem,
        text: &[u8],
        parse: impl Fn(&[u8]) -> Option<T>,
        what: &str,
    ) -> Result<Vec<T>, VtkReadError> {
        tokens(text)
            .map(|tok| {
                parse(tok).ok_or_else(|| {
                    self.xml_err(
                        label(e),
                        format!("invalid {what} '{}'", String::from_utf8_lossy(tok)),
                    )
                })
            })
            .collect()
    }

    pub(super) fn values_f64(&self, i: usize) -> Result<Vec<f64>, VtkReadError> {
        let e = self.el(i);
        let ty = self.scalar(e)?;
        match self.payload(e)? {
            Payload::Text(t) => self.text_values(e, &t, parse_decimal, "number"),
            Payload::Bytes(b) => {
                self.check_bytes(e, &b, ty)?;
                decode_f64(&b, ty, self.big, 0, "the decoded values")
                    .map_err(|m| self.xml_err(label(e), m.to_string()))
            }
        }
    }

    pub(super) fn values_i64(&self, i: usize) -> Result<Vec<i64>, VtkReadError> {
        let e = self.el(i);
        let ty = self.scalar(e)?;
        match self.payload(e)? {
            Payload::Text(t) => self.text_values(e, &t, parse_i64, "integer"),
            Payload::Bytes(b) => {
                self.check_bytes(e, &b, ty)?;
                decode_i64(&b, ty, self.big, 0).map_err(|m| self.xml_err(label(e), m))
            }
        }
    }

    /// A binary integer array narrowed to u32 on the way in, when every
    /// value is in `0..u32::MAX`; `None` for text payloads or other values
    /// (then [`Ctx::values_i64`] reads it and the bad value is named later).
    pub(super) fn values_u32_ids(&self, i: usize) -> Result<Option<Vec<u32>>, VtkReadError> {
        let e = self.el(i);
        let ty = self.scalar(e)?;
        match self.payload(e)? {
            Payload::Text(_) => Ok(None),
            Payload::Bytes(b) => {
                self.check_bytes(e, &b, ty)?;
                decode_u32_ids(&b, ty, self.big, "the decoded ids")
                    .map_err(|m| self.xml_err(label(e), m.to_string()))
            }
        }
    }

    /// An integer array that must have `n` values.
    pub(super) fn ints(&self, i: usize, n: usize, what: &str) -> Result<Vec<i64>, VtkReadError> {
        let v = self.values_i64(i)?;
        if v.len() != n {
            return Err(self.count_err(label(self.el(i)), what, n, v.len()));
        }
        Ok(v)
    }

    /// XML offsets (end offsets, no leading 0) into an array of length `len`,
    /// returned with the leading 0.
    pub(super) fn end_offsets(
        &self,
        i: usize,
        n: usize,
        len: Option<usize>,
    ) -> Result<Vec<usize>, VtkReadError> {
        let raw = self.ints(i, n, "values (one per cell)")?;
        let mut out = Vec::with_capacity(n + 1);
        out.push(0);
        let mut prev = 0usize;
        for (k, &o) in raw.iter().enumerate() {
            let ou = usize::try_from(o)
                .ok()
                .filter(|&o| o >= prev)
                .ok_or_else(|| {
                    self.xml_err(
                        label(self.el(i)),
                        format!("value {o} at index {k} is negative or decreasing"),
                    )
                })?;
            out.push(ou);
            prev = ou;
        }
        if let Some(len) = len
            && prev > len
        {
            return Err(self.count_err(
                label(self.el(i)),
                "last offset within the indexed array",
                len,
                prev,
            ));
        }
        Ok(out)
    }
}
