//! VTK XML reader: `UnstructuredGrid` (`.vtu`) and `StructuredGrid` (`.vts`),
//! with ascii, base64 `binary` and `appended` (raw or base64) data, `UInt32` or
//! `UInt64` block headers, either byte order, and zlib / LZMA / LZ4 compression.

use super::VtkReadError;
use super::common::{
    PolyFaces, Scalar, build_cells, decode_f64, decode_i64, decode_u32_ids, is_ws, parse_f64,
    parse_i64, to_points,
};
use crate::grid::{Cells, Grid, Property, Topology};
use std::borrow::Cow;
use std::io::Read;

/// Largest memory the LZMA decoder may use (VTK's presets need at most ~65 MiB).
const LZMA_MEMLIMIT: u64 = 256 << 20;

/// An element of the (pre-`AppendedData`) XML tree.
struct Elem<'a> {
    name: &'a str,
    attrs: Vec<(&'a str, String)>,
    children: Vec<usize>,
    /// Byte ranges of the element's own (non-blank) text nodes.
    text: Vec<(usize, usize)>,
}

impl Elem<'_> {
    fn attr(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, v)| v.as_str())
    }
}

/// The appended data section: `start` is just after the `_` marker.
#[derive(Clone, Copy)]
struct Appended {
    base64: bool,
    start: usize,
    end: usize,
}

struct Doc<'a> {
    b: &'a [u8],
    elems: Vec<Elem<'a>>,
    root: usize,
    appended: Option<Appended>,
}

fn find(b: &[u8], from: usize, pat: &[u8]) -> Option<usize> {
    let hay = b.get(from..)?;
    if pat.len() == 1 {
        return hay.iter().position(|&c| c == pat[0]).map(|p| p + from);
    }
    hay.windows(pat.len())
        .position(|w| w == pat)
        .map(|p| p + from)
}

fn decode_entities(raw: &[u8]) -> String {
    let s = String::from_utf8_lossy(raw);
    if !s.contains('&') {
        return s.into_owned();
    }
    let mut out = String::with_capacity(s.len());
    let mut rest: &str = &s;
    while let Some(p) = rest.find('&') {
        out.push_str(&rest[..p]);
        let tail = &rest[p..];
        let Some(semi) = tail.find(';').filter(|&q| q <= 10) else {
            out.push('&');
            rest = &tail[1..];
            continue;
        };
        let ent = &tail[1..semi];
        let ch = match ent {
            "lt" => Some('<'),
            "gt" => Some('>'),
            "amp" => Some('&'),
            "quot" => Some('"'),
            "apos" => Some('\''),
            _ => ent.strip_prefix('#').and_then(|n| {
                let v = match n.strip_prefix('x').or_else(|| n.strip_prefix('X')) {
                    Some(h) => u32::from_str_radix(h, 16).ok(),
                    None => n.parse().ok(),
                };
                v.and_then(char::from_u32)
            }),
        };
        match ch {
            Some(c) => {
                out.push(c);
                rest = &tail[semi + 1..];
            }
            None => {
                out.push('&');
                rest = &tail[1..];
            }
        }
    }
    out.push_str(rest);
    out
}

/// Scans the XML markup up to (and including) the `<AppendedData>` start
/// tag; the bytes after it are raw data, not XML.
fn scan<'a>(b: &'a [u8], file: &str) -> Result<Doc<'a>, VtkReadError> {
    let err = |element: &str, msg: String| VtkReadError::Xml {
        file: file.to_string(),
        element: element.to_string(),
        msg,
    };
    let mut elems: Vec<Elem<'a>> = Vec::new();
    let mut stack: Vec<usize> = Vec::new();
    let mut roots = Vec::new();
    let mut appended = None;
    let mut i = 0;
    while i < b.len() {
        if b[i] != b'<' {
            let end = find(b, i, b"<").unwrap_or(b.len());
            if let Some(&top) = stack.last()
                && b[i..end].iter().any(|&c| !is_ws(c))
            {
                elems[top].text.push((i, end));
            }
            i = end;
            continue;
        }
        let rest = &b[i..];
        let skip_to = |pat: &[u8], what: &str| {
            find(b, i + 1, pat)
                .map(|p| p + pat.len())
                .ok_or_else(|| err("document", format!("unterminated {what}")))
        };
        if rest.starts_with(b"<?") {
            i = skip_to(b"?>", "processing instruction")?;
        } else if rest.starts_with(b"<!--") {
            i = skip_to(b"-->", "comment")?;
        } else if rest.starts_with(b"<![CDATA[") {
            let e = find(b, i + 9, b"]]>")
                .ok_or_else(|| err("document", "unterminated CDATA section".into()))?;
            if let Some(&top) = stack.last() {
                elems[top].text.push((i + 9, e));
            }
            i = e + 3;
        } else if rest.starts_with(b"<!") {
            i = skip_to(b">", "declaration")?;
        } else if rest.starts_with(b"</") {
            let e =
                find(b, i, b">").ok_or_else(|| err("document", "unterminated end tag".into()))?;
            let name = String::from_utf8_lossy(b[i + 2..e].trim_ascii());
            let Some(top) = stack.pop() else {
                return Err(err(
                    &format!("</{name}>"),
                    "end tag without a start tag".into(),
                ));
            };
            if elems[top].name != name {
                return Err(err(
                    &format!("<{}>", elems[top].name),
                    format!("closed by </{name}> (mismatched or truncated markup)"),
                ));
            }
            i = e + 1;
        } else {
            let (elem, self_closing, next) = start_tag(b, i + 1, file)?;
            let idx = elems.len();
            match stack.last() {
                Some(&p) => elems[p].children.push(idx),
                None => roots.push(idx),
            }
            let is_appended = elem.name == "AppendedData";
            elems.push(elem);
            i = next;
            if is_appended {
                let e = &elems[idx];
                let base64 = match e.attr("encoding").unwrap_or("raw") {
                    "raw" => false,
                    "base64" => true,
                    other => {
                        return Err(VtkReadError::Unsupported {
                            file: file.to_string(),
                            what: format!("<AppendedData> encoding '{other}'"),
                        });
                    }
                };
                let us = (i..b.len()).find(|&k| !is_ws(b[k]));
                let Some(us) = us.filter(|&k| b[k] == b'_') else {
                    return Err(err("<AppendedData>", "data does not start with '_'".into()));
                };
                let start = us + 1;
                let close = b"</AppendedData>";
                let end = b
                    .get(start..)
                    .and_then(|tail| tail.windows(close.len()).rposition(|w| w == close))
                    .map_or(b.len(), |p| p + start);
                appended = Some(Appended { base64, start, end });
                break;
            }
            if !self_closing {
                stack.push(idx);
            }
        }
    }
    if appended.is_none()
        && let Some(&top) = stack.last()
    {
        return Err(err(
            &format!("<{}>", elems[top].name),
            "not closed (truncated file?)".into(),
        ));
    }
    let root = *roots
        .first()
        .ok_or_else(|| err("document", "no root element".into()))?;
    Ok(Doc {
        b,
        elems,
        root,
        appended,
    })
}

/// Parses a start tag whose name begins at `j`. Returns the element, whether
/// it is self-closing and the position after `>`.
fn start_tag<'a>(
    b: &'a [u8],
    mut j: usize,
    file: &str,
) -> Result<(Elem<'a>, bool, usize), VtkReadError> {
    let err = |element: &str, msg: &str| VtkReadError::Xml {
        file: file.to_string(),
        element: element.to_string(),
        msg: msg.to_string(),
    };
    let ns = j;
    while b
        .get(j)
        .is_some_and(|&c| !is_ws(c) && c != b'/' && c != b'>')
    {
        j += 1;
    }
    let name =
        std::str::from_utf8(&b[ns..j]).map_err(|_| err("document", "tag name is not UTF-8"))?;
    if name.is_empty() {
        return Err(err("document", "empty tag name"));
    }
    let tag = format!("<{name}>");
    let mut attrs = Vec::new();
    loop {
        while b.get(j).is_some_and(|&c| is_ws(c)) {
            j += 1;
        }
        match b.get(j) {
            None => return Err(err(&tag, "unterminated start tag")),
            Some(b'>') => {
                return Ok((
                    Elem {
                        name,
                        attrs,
                        children: Vec::new(),
                        text: Vec::new(),
                    },
                    false,
                    j + 1,
                ));
            }
            Some(b'/') if b.get(j + 1) == Some(&b'>') => {
                return Ok((
                    Elem {
                        name,
                        attrs,
                        children: Vec::new(),
                        text: Vec::new(),
                    },
                    true,
                    j + 2,
                ));
            }
            Some(_) => {}
        }
        let ks = j;
        while b
            .get(j)
            .is_some_and(|&c| !is_ws(c) && c != b'=' && c != b'>' && c != b'/')
        {
            j += 1;
        }
        let key =
            std::str::from_utf8(&b[ks..j]).map_err(|_| err(&tag, "attribute name is not UTF-8"))?;
        if key.is_empty() {
            return Err(err(&tag, "malformed attribute"));
        }
        while b.get(j).is_some_and(|&c| is_ws(c)) {
            j += 1;
        }
        if b.get(j) != Some(&b'=') {
            return Err(err(&tag, &format!("attribute '{key}' without a value")));
        }
        j += 1;
        while b.get(j).is_some_and(|&c| is_ws(c)) {
            j += 1;
        }
        let q = match b.get(j) {
            Some(&q @ (b'"' | b'\'')) => q,
            _ => return Err(err(&tag, &format!("attribute '{key}' value is not quoted"))),
        };
        let ve = find(b, j + 1, &[q])
            .ok_or_else(|| err(&tag, &format!("unterminated value of attribute '{key}'")))?;
        attrs.push((key, decode_entities(&b[j + 1..ve])));
        j = ve + 1;
    }
}

/// Base64 decoding that skips whitespace and accepts padding in the middle
/// (VTK pads its header and its data separately).
fn base64_decode(text: &[u8]) -> Result<Vec<u8>, String> {
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
    let mut out = Vec::with_capacity(text.len() / 4 * 3 + 3);
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
enum Compressor {
    None,
    Zlib,
    Lzma,
    Lz4,
}

enum Payload<'a> {
    Text(Cow<'a, [u8]>),
    Bytes(Cow<'a, [u8]>),
}

struct Ctx<'a, 'd> {
    doc: &'d Doc<'a>,
    file: &'d str,
    big: bool,
    h64: bool,
    comp: Compressor,
    /// Sorted offsets of all appended arrays (for base64 appended: where each ends).
    app_offsets: Vec<usize>,
}

fn label(e: &Elem) -> String {
    format!("DataArray '{}'", e.attr("Name").unwrap_or(""))
}

impl<'a> Ctx<'a, '_> {
    fn el(&self, i: usize) -> &Elem<'a> {
        &self.doc.elems[i]
    }

    fn xml_err(&self, element: impl Into<String>, msg: impl Into<String>) -> VtkReadError {
        VtkReadError::Xml {
            file: self.file.to_string(),
            element: element.into(),
            msg: msg.into(),
        }
    }

    fn count_err(
        &self,
        element: impl Into<String>,
        what: impl Into<String>,
        expected: usize,
        found: usize,
    ) -> VtkReadError {
        VtkReadError::XmlCount {
            file: self.file.to_string(),
            element: element.into(),
            what: what.into(),
            expected,
            found,
        }
    }

    fn unsupported(&self, what: String) -> VtkReadError {
        VtkReadError::Unsupported {
            file: self.file.to_string(),
            what,
        }
    }

    fn child(&self, e: &Elem, name: &str) -> Option<usize> {
        e.children
            .iter()
            .copied()
            .find(|&c| self.el(c).name == name)
    }

    fn arrays(&self, e: &Elem) -> impl Iterator<Item = usize> + '_ {
        let kids: Vec<usize> = e.children.clone();
        kids.into_iter()
            .filter(|&c| matches!(self.el(c).name, "DataArray" | "Array"))
    }

    fn named_array(&self, e: &Elem, name: &str) -> Option<usize> {
        self.arrays(e)
            .find(|&c| self.el(c).attr("Name") == Some(name))
    }

    fn usize_attr(&self, e: &Elem, key: &str, element: &str) -> Result<usize, VtkReadError> {
        let v = e
            .attr(key)
            .ok_or_else(|| self.xml_err(element, format!("missing attribute {key}")))?;
        v.trim()
            .parse()
            .map_err(|_| self.xml_err(element, format!("invalid {key}=\"{v}\"")))
    }

    fn text(&self, e: &Elem) -> Cow<'a, [u8]> {
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

    fn header_word(&self, data: &[u8], k: usize) -> Option<u64> {
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
    fn unblock<'x>(&self, data: &'x [u8], name: &str) -> Result<Cow<'x, [u8]>, VtkReadError> {
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

    fn decompress(
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
                let mut buf = vec![0u8; expect];
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

    fn payload(&self, e: &Elem<'a>) -> Result<Payload<'a>, VtkReadError> {
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

    fn scalar(&self, e: &Elem) -> Result<Scalar, VtkReadError> {
        let t = e
            .attr("type")
            .ok_or_else(|| self.xml_err(label(e), "missing attribute type"))?;
        Scalar::from_xml(t).ok_or_else(|| self.unsupported(format!("{}: type '{t}'", label(e))))
    }

    fn components(&self, e: &Elem) -> Result<usize, VtkReadError> {
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

    fn check_bytes(&self, e: &Elem, b: &[u8], ty: Scalar) -> Result<(), VtkReadError> {
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
    fn text_values<T>(
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

    fn values_f64(&self, i: usize) -> Result<Vec<f64>, VtkReadError> {
        let e = self.el(i);
        let ty = self.scalar(e)?;
        match self.payload(e)? {
            Payload::Text(t) => self.text_values(e, &t, parse_f64, "number"),
            Payload::Bytes(b) => {
                self.check_bytes(e, &b, ty)?;
                Ok(decode_f64(&b, ty, self.big, 0))
            }
        }
    }

    fn values_i64(&self, i: usize) -> Result<Vec<i64>, VtkReadError> {
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
    fn values_u32_ids(&self, i: usize) -> Result<Option<Vec<u32>>, VtkReadError> {
        let e = self.el(i);
        let ty = self.scalar(e)?;
        match self.payload(e)? {
            Payload::Text(_) => Ok(None),
            Payload::Bytes(b) => {
                self.check_bytes(e, &b, ty)?;
                Ok(decode_u32_ids(&b, ty, self.big))
            }
        }
    }

    /// An integer array that must have `n` values.
    fn ints(&self, i: usize, n: usize, what: &str) -> Result<Vec<i64>, VtkReadError> {
        let v = self.values_i64(i)?;
        if v.len() != n {
            return Err(self.count_err(label(self.el(i)), what, n, v.len()));
        }
        Ok(v)
    }

    /// XML offsets (end offsets, no leading 0) into an array of length `len`,
    /// returned with the leading 0.
    fn end_offsets(
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

    /// The data arrays of a `<PointData>` / `<CellData>` element.
    fn properties(
        &self,
        parent: Option<usize>,
        n: usize,
        kind: &str,
    ) -> Result<Vec<Property>, VtkReadError> {
        let Some(p) = parent else {
            return Ok(Vec::new());
        };
        let mut out = Vec::new();
        for i in self.arrays(self.el(p)) {
            let e = self.el(i);
            if matches!(e.attr("type"), Some("String")) {
                continue; // string arrays are not grid properties
            }
            let comps = self.components(e)?;
            let values = self.values_f64(i)?;
            let expected = n.saturating_mul(comps);
            if values.len() != expected {
                return Err(self.count_err(
                    label(e),
                    format!("values ({kind} count {n} x {comps} components)"),
                    expected,
                    values.len(),
                ));
            }
            let name = e.attr("Name").unwrap_or("").to_string();
            out.push(Property {
                name,
                components: comps,
                values,
            });
        }
        Ok(out)
    }

    fn points(&self, piece: &Elem, np: usize) -> Result<Vec<f64>, VtkReadError> {
        let pts = self.child(piece, "Points");
        let arr = pts.and_then(|p| self.arrays(self.el(p)).next());
        let Some(arr) = arr else {
            if np == 0 {
                return Ok(Vec::new());
            }
            return Err(self.xml_err("<Piece>", "no <Points> DataArray"));
        };
        let e = self.el(arr);
        let comps = self.components(e)?;
        if comps != 3 {
            return Err(self.count_err(label(e), "NumberOfComponents of points", 3, comps));
        }
        let v = self.values_f64(arr)?;
        let expected = np.saturating_mul(3);
        if v.len() != expected {
            return Err(self.count_err(
                label(e),
                format!("values (NumberOfPoints {np} x 3)"),
                expected,
                v.len(),
            ));
        }
        Ok(v)
    }

    fn unstructured_piece(&self, piece: &Elem) -> Result<Grid, VtkReadError> {
        let np = self.usize_attr(piece, "NumberOfPoints", "<Piece>")?;
        let nc = self.usize_attr(piece, "NumberOfCells", "<Piece>")?;
        let points = self.points(piece, np)?;
        let cells = match self.child(piece, "Cells") {
            Some(ce) => self.cells(self.el(ce), nc)?,
            None if nc == 0 => Cells {
                offsets: vec![0],
                ..Cells::default()
            },
            None => {
                return Err(self.xml_err(
                    "<Piece>",
                    format!("NumberOfCells={nc} but no <Cells> element"),
                ));
            }
        };
        let point_data = self.properties(self.child(piece, "PointData"), np, "NumberOfPoints")?;
        let cell_data = self.properties(self.child(piece, "CellData"), nc, "NumberOfCells")?;
        Ok(Grid {
            points: to_points(&points),
            topology: Topology::Unstructured(cells),
            point_data,
            cell_data,
        })
    }

    fn cells(&self, ce: &Elem, nc: usize) -> Result<Cells, VtkReadError> {
        let need = |name: &str| {
            self.named_array(ce, name)
                .ok_or_else(|| self.xml_err("<Cells>", format!("no DataArray named '{name}'")))
        };
        let conn_i = need("connectivity")?;
        // Narrowed to u32 on the way in when every id fits (else i64, and
        // the bad id is named later).
        let conn32 = self.values_u32_ids(conn_i)?;
        let conn64 = match conn32 {
            Some(_) => Vec::new(),
            None => self.values_i64(conn_i)?,
        };
        let conn_len = conn32.as_ref().map_or(conn64.len(), Vec::len);
        let offsets = self.end_offsets(need("offsets")?, nc, None)?;
        let last = offsets.last().copied().unwrap_or(0);
        if last != conn_len {
            return Err(self.count_err(
                label(self.el(conn_i)),
                "values (the last cell offset)",
                last,
                conn_len,
            ));
        }
        let types = self.ints(need("types")?, nc, "values (NumberOfCells)")?;
        let has_poly = types.contains(&42);
        let mut stream: Vec<i64> = Vec::new();
        // The pre-9.4 `faces` array narrowed to u32 when it fits (no i64 copy).
        let mut stream32: Option<Vec<u32>> = None;
        let mut ranges: Vec<Option<(usize, usize)>> = Vec::new();
        if !has_poly {
            // faces arrays, if any, are irrelevant
        } else if let (Some(fi), Some(foi)) = (
            self.named_array(ce, "faces"),
            self.named_array(ce, "faceoffsets"),
        ) {
            // VTK < 9.4: per polyhedron a legacy face stream; faceoffsets are
            // end offsets, -1 for other cells.
            stream32 = self.values_u32_ids(fi)?;
            if stream32.is_none() {
                stream = self.values_i64(fi)?;
            }
            let stream_len = stream32.as_ref().map_or(stream.len(), Vec::len);
            let fo = self.ints(foi, nc, "values (NumberOfCells)")?;
            let mut prev = 0usize;
            for (c, &o) in fo.iter().enumerate() {
                if o < 0 {
                    ranges.push(None);
                    continue;
                }
                let end = usize::try_from(o)
                    .ok()
                    .filter(|&e| e >= prev && e <= stream_len)
                    .ok_or_else(|| {
                        self.xml_err(
                            label(self.el(foi)),
                            format!("value {o} for cell {c} is decreasing or beyond 'faces'"),
                        )
                    })?;
                ranges.push(Some((prev, end)));
                prev = end;
            }
        } else {
            let find =
                |a: &str, b: &str| self.named_array(ce, a).or_else(|| self.named_array(ce, b));
            let (Some(pti), Some(poi), Some(fci), Some(foi)) = (
                find("polyhedron_to_faces", "PolyhedronToFaces"),
                find("polyhedron_offsets", "PolyhedronOffsets"),
                find("face_connectivity", "FaceConnectivity"),
                find("face_offsets", "FaceOffsets"),
            ) else {
                return Err(self.xml_err(
                    "<Cells>",
                    "polyhedra (type 42) but neither faces/faceoffsets nor \
                     face_connectivity/face_offsets/polyhedron_to_faces/polyhedron_offsets",
                ));
            };
            // VTK >= 9.4: faces are shared cells of their own.
            let p2f = self.values_i64(pti)?;
            let poff = self.end_offsets(poi, nc, Some(p2f.len()))?;
            let fconn = self.values_i64(fci)?;
            let nf_total = self.values_i64(foi)?.len();
            let foff = self.end_offsets(foi, nf_total, Some(fconn.len()))?;
            for c in 0..nc {
                let (a, b) = (poff[c], poff[c + 1]);
                if a == b {
                    ranges.push(None);
                    continue;
                }
                let start = stream.len();
                stream.push((b - a) as i64);
                for &f in &p2f[a..b] {
                    let fu = usize::try_from(f)
                        .ok()
                        .filter(|&f| f < nf_total)
                        .ok_or_else(|| {
                            self.xml_err(
                                label(self.el(pti)),
                                format!("cell {c} references face {f} of {nf_total}"),
                            )
                        })?;
                    let ids = &fconn[foff[fu]..foff[fu + 1]];
                    stream.push(ids.len() as i64);
                    stream.extend_from_slice(ids);
                }
                ranges.push(Some((start, stream.len())));
            }
        }
        macro_rules! assemble {
            ($conn:expr) => {{
                if let Some(stream) = &stream32 {
                    let faces = PolyFaces::Streams {
                        stream,
                        ranges: &ranges,
                    };
                    return build_cells(&types, &offsets, $conn, faces, self.file);
                }
                let faces = if has_poly {
                    PolyFaces::Streams {
                        stream: &stream,
                        ranges: &ranges,
                    }
                } else {
                    PolyFaces::InConnectivity
                };
                build_cells(&types, &offsets, $conn, faces, self.file)
            }};
        }
        match &conn32 {
            Some(conn) => assemble!(conn),
            None => assemble!(&conn64),
        }
    }

    fn unstructured(&self, ds: &Elem) -> Result<Grid, VtkReadError> {
        let pieces: Vec<usize> = ds
            .children
            .iter()
            .copied()
            .filter(|&c| self.el(c).name == "Piece")
            .collect();
        let mut grids = pieces.iter().map(|&p| self.unstructured_piece(self.el(p)));
        let Some(first) = grids.next() else {
            return Ok(Grid {
                points: Vec::new(),
                topology: Topology::Unstructured(Cells {
                    offsets: vec![0],
                    ..Cells::default()
                }),
                point_data: Vec::new(),
                cell_data: Vec::new(),
            });
        };
        let mut grid = first?;
        for (k, g) in grids.enumerate() {
            self.append_piece(&mut grid, g?, k + 1)?;
        }
        Ok(grid)
    }

    /// Appends piece `g` (with piece-local point ids) to `grid`.
    fn append_piece(&self, grid: &mut Grid, g: Grid, k: usize) -> Result<(), VtkReadError> {
        let base = u32::try_from(grid.points.len())
            .map_err(|_| self.unsupported("more than 2^32 points".into()))?;
        let (Topology::Unstructured(dst), Topology::Unstructured(src)) =
            (&mut grid.topology, g.topology)
        else {
            return Ok(());
        };
        let same = |a: &[Property], b: &[Property]| {
            a.len() == b.len()
                && a.iter()
                    .zip(b)
                    .all(|(x, y)| x.name == y.name && x.components == y.components)
        };
        if !same(&grid.point_data, &g.point_data) || !same(&grid.cell_data, &g.cell_data) {
            return Err(self.xml_err(
                format!("<Piece> {k}"),
                "data arrays differ from those of the first piece",
            ));
        }
        let shift = |v: u32| {
            v.checked_add(base)
                .ok_or_else(|| self.unsupported("point ids beyond u32".into()))
        };
        let conn0 = u32::try_from(dst.connectivity.len())
            .map_err(|_| self.unsupported("connectivity beyond u32".into()))?;
        for &v in &src.connectivity {
            dst.connectivity.push(shift(v)?);
        }
        if dst.offsets.is_empty() {
            dst.offsets.push(0);
        }
        dst.offsets
            .extend(src.offsets.iter().skip(1).map(|&o| o + conn0));
        if !src.face_offsets.is_empty() || !dst.face_offsets.is_empty() {
            if dst.face_offsets.is_empty() {
                dst.face_offsets = vec![0; dst.types.len() + 1];
            }
            for c in 0..src.types.len() {
                // Re-walk the face stream (checked by build_cells) to shift point ids only.
                let s = faces_checked(&src, c);
                if let Some((&nf, mut rest)) = s.split_first() {
                    dst.face_stream.push(nf);
                    while let Some((&n, r)) = rest.split_first() {
                        dst.face_stream.push(n);
                        let k = (n as usize).min(r.len());
                        for &v in &r[..k] {
                            dst.face_stream.push(shift(v)?);
                        }
                        rest = &r[k..];
                    }
                }
                let end = u32::try_from(dst.face_stream.len())
                    .map_err(|_| self.unsupported("faces beyond u32".into()))?;
                dst.face_offsets.push(end);
            }
        }
        dst.types.extend_from_slice(&src.types);
        grid.points.extend(g.points);
        for (a, b) in grid.point_data.iter_mut().zip(g.point_data) {
            a.values.extend(b.values);
        }
        for (a, b) in grid.cell_data.iter_mut().zip(g.cell_data) {
            a.values.extend(b.values);
        }
        Ok(())
    }

    fn structured(&self, ds: &Elem) -> Result<Grid, VtkReadError> {
        let pieces: Vec<usize> = ds
            .children
            .iter()
            .copied()
            .filter(|&c| self.el(c).name == "Piece")
            .collect();
        let piece = match pieces.as_slice() {
            [p] => self.el(*p),
            [] => return Err(self.xml_err("<StructuredGrid>", "no <Piece>")),
            _ => {
                return Err(
                    self.unsupported(format!("StructuredGrid with {} pieces", pieces.len()))
                );
            }
        };
        let ext = piece
            .attr("Extent")
            .or_else(|| ds.attr("WholeExtent"))
            .ok_or_else(|| self.xml_err("<Piece>", "missing attribute Extent"))?;
        let e: Vec<i64> = ext
            .split_ascii_whitespace()
            .filter_map(|t| t.parse().ok())
            .collect();
        let bad = || self.xml_err("<Piece>", format!("invalid Extent=\"{ext}\""));
        if e.len() != 6 {
            return Err(bad());
        }
        let mut dims = [0usize; 3];
        for a in 0..3 {
            let d = e[2 * a + 1]
                .checked_sub(e[2 * a])
                .and_then(|d| d.checked_add(1))
                .ok_or_else(bad)?;
            dims[a] = usize::try_from(d)
                .ok()
                .filter(|&d| d >= 1)
                .ok_or_else(bad)?;
        }
        let np = dims[0]
            .checked_mul(dims[1])
            .and_then(|v| v.checked_mul(dims[2]))
            .ok_or_else(bad)?;
        let nc = super::common::structured_cells(dims).ok_or_else(bad)?;
        let points = self.points(piece, np)?;
        let point_data = self.properties(self.child(piece, "PointData"), np, "point")?;
        let cell_data = self.properties(self.child(piece, "CellData"), nc, "cell")?;
        Ok(Grid {
            points: to_points(&points),
            topology: Topology::Structured { dims },
            point_data,
            cell_data,
        })
    }
}

/// Face stream of cell `c`, empty when absent or out of range (never panics).
fn faces_checked(cells: &Cells, c: usize) -> &[u32] {
    match cells.face_offsets.get(c..c + 2) {
        Some(&[a, b]) => cells.face_stream.get(a as usize..b as usize).unwrap_or(&[]),
        _ => &[],
    }
}

fn tokens(t: &[u8]) -> impl Iterator<Item = &[u8]> {
    t.split(|&c| is_ws(c)).filter(|s| !s.is_empty())
}

/// Parses an XML file into an unvalidated grid.
pub(crate) fn parse(b: &[u8], file: &str) -> Result<Grid, VtkReadError> {
    let doc = scan(b, file)?;
    let root = &doc.elems[doc.root];
    let bad = |what: String| VtkReadError::Unsupported {
        file: file.to_string(),
        what,
    };
    if root.name != "VTKFile" {
        return Err(VtkReadError::Xml {
            file: file.to_string(),
            element: format!("<{}>", root.name),
            msg: "root element is not <VTKFile>".into(),
        });
    }
    let big = match root.attr("byte_order") {
        None | Some("LittleEndian") => false,
        Some("BigEndian") => true,
        Some(o) => return Err(bad(format!("byte_order '{o}'"))),
    };
    let h64 = match root.attr("header_type") {
        None | Some("UInt32") => false,
        Some("UInt64") => true,
        Some(o) => return Err(bad(format!("header_type '{o}'"))),
    };
    let comp = match root.attr("compressor") {
        None | Some("") => Compressor::None,
        Some("vtkZLibDataCompressor") => Compressor::Zlib,
        Some("vtkLZMADataCompressor") => Compressor::Lzma,
        Some("vtkLZ4DataCompressor") => Compressor::Lz4,
        Some(o) => return Err(bad(format!("compressor '{o}'"))),
    };
    let mut app_offsets: Vec<usize> = doc
        .elems
        .iter()
        .filter(|e| e.attr("format") == Some("appended"))
        .filter_map(|e| e.attr("offset").and_then(|o| o.trim().parse().ok()))
        .collect();
    app_offsets.sort_unstable();
    app_offsets.dedup();
    let kind = root.attr("type").unwrap_or("");
    let ctx = Ctx {
        doc: &doc,
        file,
        big,
        h64,
        comp,
        app_offsets,
    };
    let ds = ctx.child(root, kind).map(|i| ctx.el(i));
    match (kind, ds) {
        ("UnstructuredGrid", Some(ds)) => ctx.unstructured(ds),
        ("StructuredGrid", Some(ds)) => ctx.structured(ds),
        ("UnstructuredGrid" | "StructuredGrid", None) => Err(ctx.xml_err(
            "<VTKFile>",
            format!("type=\"{kind}\" but no <{kind}> element"),
        )),
        _ => Err(bad(format!(
            "VTK XML dataset type '{kind}' (only UnstructuredGrid and StructuredGrid)"
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_with_inner_padding() {
        // "ab" padded, then "cde" -> VTK-style separately padded chunks.
        assert_eq!(base64_decode(b"YWI=\nY2Rl").unwrap(), b"abcde");
        assert_eq!(base64_decode(b"YQ==YQ==").unwrap(), b"aa");
        assert_eq!(base64_decode(b"YWJj").unwrap(), b"abc");
        assert!(base64_decode(b"Y$==").is_err());
        assert!(base64_decode(b"=").is_err());
    }

    #[test]
    fn entities() {
        assert_eq!(
            decode_entities(b"a&lt;b&amp;c&#65;&#x42;&bogus;"),
            "a<b&cAB&bogus;"
        );
    }
}
