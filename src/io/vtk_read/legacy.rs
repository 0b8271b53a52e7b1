//! Legacy VTK reader (`# vtk DataFile Version x.y`), ASCII and BINARY
//! (big-endian), datasets `UNSTRUCTURED_GRID` and `STRUCTURED_GRID`.

use super::VtkReadError;
use super::common::{
    PolyFaces, Scalar, build_cells, decode_f64, decode_i64, decode_name, is_ws, parse_i64,
    structured_cells, to_points,
};
use crate::grid::{Grid, Property, Topology};
use crate::io::number::parse_decimal;

/// Byte cursor with whitespace-delimited tokens and raw binary reads.
struct Lexer<'a> {
    b: &'a [u8],
    pos: usize,
}

impl<'a> Lexer<'a> {
    fn skip_ws(&mut self) {
        while self.b.get(self.pos).is_some_and(|&c| is_ws(c)) {
            self.pos += 1;
        }
    }

    /// Next token and its start position.
    fn token(&mut self) -> Option<(usize, &'a [u8])> {
        self.skip_ws();
        let start = self.pos;
        while self.b.get(self.pos).is_some_and(|&c| !is_ws(c)) {
            self.pos += 1;
        }
        (self.pos > start).then(|| (start, &self.b[start..self.pos]))
    }

    /// Next token without consuming it.
    fn peek(&self) -> Option<&'a [u8]> {
        let mut l = Lexer {
            b: self.b,
            pos: self.pos,
        };
        l.token().map(|t| t.1)
    }

    /// Next token if it is on the current line.
    fn token_on_line(&mut self) -> Option<&'a [u8]> {
        while self
            .b
            .get(self.pos)
            .is_some_and(|&c| c != b'\n' && is_ws(c))
        {
            self.pos += 1;
        }
        if self.b.get(self.pos).is_none_or(|&c| c == b'\n') {
            return None;
        }
        self.token().map(|t| t.1)
    }

    /// Moves past the next newline (or to the end).
    fn next_line(&mut self) {
        match self
            .b
            .get(self.pos..)
            .and_then(|r| r.iter().position(|&c| c == b'\n'))
        {
            Some(i) => self.pos += i + 1,
            None => self.pos = self.b.len(),
        }
    }

    /// The rest of the current line (without the newline), consuming it.
    fn rest_of_line(&mut self) -> &'a [u8] {
        let start = self.pos.min(self.b.len());
        self.next_line();
        let mut end = self.pos;
        while end > start && is_ws(self.b[end - 1]) {
            end -= 1;
        }
        &self.b[start..end]
    }

    fn remaining(&self) -> usize {
        self.b.len().saturating_sub(self.pos)
    }

    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.pos.checked_add(n)?;
        let s = self.b.get(self.pos..end)?;
        self.pos = end;
        Some(s)
    }

    /// 1-based line number of byte position `pos`.
    fn line_at(&self, pos: usize) -> usize {
        1 + self.b[..pos.min(self.b.len())]
            .iter()
            .filter(|&&c| c == b'\n')
            .count()
    }
}

fn lossy(t: &[u8]) -> String {
    let s = String::from_utf8_lossy(&t[..t.len().min(40)]).into_owned();
    if t.len() > 40 { format!("{s}...") } else { s }
}

/// An upper-case section keyword (`CELL_TYPES`, `POINT_DATA`, ...) where a
/// number was expected means the section before it is short.
fn looks_like_keyword(t: &[u8]) -> bool {
    t.len() >= 2
        && t[0].is_ascii_uppercase()
        && t.iter()
            .all(|&c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == b'_')
}

fn keyword_is(t: &[u8], k: &str) -> bool {
    t.eq_ignore_ascii_case(k.as_bytes())
}

/// Which attribute section we are in.
#[derive(Clone, Copy, Default, PartialEq)]
enum Section {
    #[default]
    None,
    Point(usize),
    Cell(usize),
}

#[derive(PartialEq)]
enum Dataset {
    Unstructured,
    Structured,
}

/// What the keywords read so far gave, each with the byte offset of its
/// keyword (for messages).
#[derive(Default)]
struct Sections {
    dataset: Option<Dataset>,
    points: Option<(usize, Vec<f64>)>,
    cells: Option<(usize, Vec<usize>, Vec<i64>)>,
    types: Option<(usize, Vec<i64>)>,
    dims: Option<(usize, [usize; 3])>,
    /// The attribute section being read.
    section: Section,
    point_data: Vec<Property>,
    cell_data: Vec<Property>,
}

struct Parser<'a> {
    lx: Lexer<'a>,
    file: &'a str,
    binary: bool,
}

impl<'a> Parser<'a> {
    fn err(&self, pos: usize, msg: impl Into<String>) -> VtkReadError {
        VtkReadError::Legacy {
            file: self.file.to_string(),
            line: self.lx.line_at(pos),
            msg: msg.into(),
        }
    }

    fn count_err(
        &self,
        pos: usize,
        what: impl Into<String>,
        expected: usize,
        found: usize,
    ) -> VtkReadError {
        VtkReadError::LegacyCount {
            file: self.file.to_string(),
            line: self.lx.line_at(pos),
            what: what.into(),
            expected,
            found,
        }
    }

    fn unsupported(&self, pos: usize, what: impl std::fmt::Display) -> VtkReadError {
        VtkReadError::Unsupported {
            file: self.file.to_string(),
            what: format!("{what} (line {})", self.lx.line_at(pos)),
        }
    }

    /// A required header token.
    fn word(&mut self, what: &str, kw_pos: usize) -> Result<(usize, &'a [u8]), VtkReadError> {
        self.lx
            .token()
            .ok_or_else(|| self.err(kw_pos, format!("unexpected end of file: missing {what}")))
    }

    /// A required non-negative count in a header.
    fn count(&mut self, what: &str, kw_pos: usize) -> Result<usize, VtkReadError> {
        let (p, t) = self.word(what, kw_pos)?;
        parse_i64(t)
            .and_then(|v| usize::try_from(v).ok())
            .ok_or_else(|| self.err(p, format!("invalid {what} '{}'", lossy(t))))
    }

    fn scalar(&mut self, kw_pos: usize) -> Result<Scalar, VtkReadError> {
        let (p, t) = self.word("data type", kw_pos)?;
        Scalar::from_legacy(t)
            .ok_or_else(|| self.unsupported(p, format!("data type '{}'", lossy(t))))
    }

    /// In binary files the data starts after the newline ending the header line.
    fn end_header(&mut self) {
        if self.binary {
            self.lx.next_line();
        }
    }

    /// Capacity for `n` ASCII values: never more than the input could hold.
    fn cap(&self, n: usize) -> usize {
        n.min(self.lx.remaining() / 2 + 1)
    }

    /// Reads `n` values as f64. `what` names the section for errors; `hdr` is
    /// the position of its keyword.
    fn read_f64(
        &mut self,
        n: usize,
        ty: Scalar,
        what: &str,
        hdr: usize,
    ) -> Result<Vec<f64>, VtkReadError> {
        if self.binary {
            let bytes = self.binary_bytes(n, ty, what, hdr)?;
            return decode_f64(bytes, ty, true, n, what).map_err(|m| self.err(hdr, m.to_string()));
        }
        let mut v = Vec::with_capacity(self.cap(n));
        for i in 0..n {
            let Some((p, t)) = self.lx.token() else {
                return Err(self.count_err(hdr, format!("{what}: values"), n, i));
            };
            match parse_decimal(t) {
                Some(x) => v.push(x),
                None if looks_like_keyword(t) => {
                    return Err(self.count_err(hdr, format!("{what}: values"), n, i));
                }
                None => return Err(self.err(p, format!("{what}: invalid number '{}'", lossy(t)))),
            }
        }
        Ok(v)
    }

    /// Reads `n` values as i64 (integer data: cells, types, offsets).
    fn read_i64(
        &mut self,
        n: usize,
        ty: Scalar,
        what: &str,
        hdr: usize,
    ) -> Result<Vec<i64>, VtkReadError> {
        if self.binary {
            let bytes = self.binary_bytes(n, ty, what, hdr)?;
            return decode_i64(bytes, ty, true, n)
                .map_err(|m| self.err(hdr, format!("{what}: {m}")));
        }
        let mut v = Vec::with_capacity(self.cap(n));
        for i in 0..n {
            let Some((p, t)) = self.lx.token() else {
                return Err(self.count_err(hdr, format!("{what}: values"), n, i));
            };
            match parse_i64(t) {
                Some(x) => v.push(x),
                None if looks_like_keyword(t) => {
                    return Err(self.count_err(hdr, format!("{what}: values"), n, i));
                }
                None => return Err(self.err(p, format!("{what}: invalid integer '{}'", lossy(t)))),
            }
        }
        Ok(v)
    }

    fn binary_bytes(
        &mut self,
        n: usize,
        ty: Scalar,
        what: &str,
        hdr: usize,
    ) -> Result<&'a [u8], VtkReadError> {
        let nbytes = if ty == Scalar::Bit {
            n.div_ceil(8)
        } else {
            n.saturating_mul(ty.size())
        };
        let rem = self.lx.remaining();
        self.lx.take(nbytes).ok_or_else(|| {
            let found = if ty == Scalar::Bit {
                rem.saturating_mul(8)
            } else {
                rem / ty.size().max(1)
            };
            self.count_err(hdr, format!("{what}: binary values"), n, found.min(n))
        })
    }

    /// Skips `n` string values (legacy `string` arrays: one per line in ASCII).
    fn skip_strings(&mut self, n: usize, hdr: usize) -> Result<(), VtkReadError> {
        if self.binary {
            return Err(self.unsupported(hdr, "binary string arrays"));
        }
        self.lx.next_line();
        for i in 0..n {
            if self.lx.remaining() == 0 {
                return Err(self.count_err(hdr, "string array: values", n, i));
            }
            self.lx.next_line();
        }
        Ok(())
    }

    /// Skips a `METADATA` block: lines up to the first empty one.
    fn skip_metadata(&mut self) {
        self.lx.next_line();
        while self.lx.remaining() > 0 {
            if self.lx.rest_of_line().is_empty() {
                break;
            }
        }
    }

    fn skip_optional_metadata(&mut self) {
        if self.lx.peek().is_some_and(|t| keyword_is(t, "METADATA")) {
            self.lx.token();
            self.skip_metadata();
        }
    }

    /// `FIELD name n` followed by `n` arrays. Returns the numeric arrays;
    /// `tuples` (when given) is the count every array must have.
    fn field(&mut self, kw: usize, tuples: Option<usize>) -> Result<Vec<Property>, VtkReadError> {
        self.word("field name", kw)?;
        let n = self.count("number of field arrays", kw)?;
        let mut out = Vec::new();
        for _ in 0..n {
            let (p, name) = self.word("field array name", kw)?;
            if keyword_is(name, "NULL_ARRAY") {
                continue;
            }
            let name = decode_name(name);
            let comps = self.count("number of components", p)?;
            let ntup = self.count("number of tuples", p)?;
            let (tp, tname) = self.word("data type", p)?;
            let what = format!("FIELD array '{name}'");
            let total = comps
                .checked_mul(ntup)
                .ok_or_else(|| self.err(p, format!("{what}: size overflows")))?;
            if tname.eq_ignore_ascii_case(b"string") || tname.eq_ignore_ascii_case(b"utf8_string") {
                self.skip_strings(total, p)?;
                self.skip_optional_metadata();
                continue;
            }
            let ty = Scalar::from_legacy(tname).ok_or_else(|| {
                self.unsupported(tp, format!("{what}: data type '{}'", lossy(tname)))
            })?;
            if let Some(t) = tuples
                && t != ntup
            {
                return Err(self.count_err(p, format!("{what}: tuples"), t, ntup));
            }
            self.end_header();
            let values = self.read_f64(total, ty, &what, p)?;
            out.push(Property {
                name,
                components: comps.max(1),
                values,
            });
            self.skip_optional_metadata();
        }
        Ok(out)
    }

    /// `SCALARS name type [numComp]` then an optional `LOOKUP_TABLE name` line.
    fn scalars(&mut self, kw: usize, n: usize) -> Result<Property, VtkReadError> {
        let (_, name) = self.word("array name", kw)?;
        let name = decode_name(name);
        let ty = self.scalar(kw)?;
        let mut comps = 1;
        let mut lut = false;
        if let Some(t) = self.lx.token_on_line() {
            if keyword_is(t, "LOOKUP_TABLE") {
                lut = true;
                self.lx.token_on_line();
            } else {
                comps = parse_i64(t)
                    .and_then(|v| usize::try_from(v).ok())
                    .filter(|&c| (1..=1024).contains(&c))
                    .ok_or_else(|| {
                        self.err(
                            kw,
                            format!("SCALARS '{name}': invalid component count '{}'", lossy(t)),
                        )
                    })?;
            }
        }
        self.lx.next_line();
        if !lut
            && self
                .lx
                .peek()
                .is_some_and(|t| keyword_is(t, "LOOKUP_TABLE"))
        {
            self.lx.token();
            self.lx.token_on_line();
            self.lx.next_line();
        }
        let total = n
            .checked_mul(comps)
            .ok_or_else(|| self.err(kw, "SCALARS size overflows"))?;
        let values = self.read_f64(total, ty, &format!("SCALARS '{name}'"), kw)?;
        Ok(Property {
            name,
            components: comps,
            values,
        })
    }

    /// `KEYWORD name type` with a fixed number of components.
    fn fixed(
        &mut self,
        kw: usize,
        kwname: &str,
        n: usize,
        comps: usize,
    ) -> Result<Property, VtkReadError> {
        let (_, name) = self.word("array name", kw)?;
        let name = decode_name(name);
        let ty = self.scalar(kw)?;
        self.end_header();
        let total = n
            .checked_mul(comps)
            .ok_or_else(|| self.err(kw, format!("{kwname} size overflows")))?;
        let values = self.read_f64(total, ty, &format!("{kwname} '{name}'"), kw)?;
        Ok(Property {
            name,
            components: comps,
            values,
        })
    }

    /// Reads the file: the header, then its keywords in order, then the
    /// grid assembled from the sections read.
    fn parse(&mut self) -> Result<Grid, VtkReadError> {
        self.header()?;
        let mut s = Sections::default();
        while let Some((kw, t)) = self.lx.token() {
            self.keyword(kw, t, &mut s)?;
        }
        self.assemble(s)
    }

    /// The header: magic line, title line, ASCII|BINARY.
    fn header(&mut self) -> Result<(), VtkReadError> {
        let magic = self.lx.rest_of_line();
        if magic.len() < 5 || !magic[..5].eq_ignore_ascii_case(b"# vtk") {
            return Err(self.err(
                0,
                "not a legacy VTK file: first line must be '# vtk DataFile Version x.y'",
            ));
        }
        self.lx.next_line(); // title
        let (fp, fmt) = self
            .lx
            .token()
            .ok_or_else(|| self.err(self.lx.pos, "missing ASCII/BINARY line"))?;
        self.binary = if keyword_is(fmt, "ASCII") {
            false
        } else if keyword_is(fmt, "BINARY") {
            true
        } else {
            return Err(self.err(
                fp,
                format!("expected ASCII or BINARY, found '{}'", lossy(fmt)),
            ));
        };
        Ok(())
    }

    /// One keyword `t` at byte `kw` and what follows it, into `s`.
    fn keyword(&mut self, kw: usize, t: &[u8], s: &mut Sections) -> Result<(), VtkReadError> {
        let key = t.to_ascii_uppercase();
        match key.as_slice() {
            b"DATASET" => {
                let (p, d) = self.word("dataset type", kw)?;
                s.dataset = Some(if keyword_is(d, "UNSTRUCTURED_GRID") {
                    Dataset::Unstructured
                } else if keyword_is(d, "STRUCTURED_GRID") {
                    Dataset::Structured
                } else {
                    return Err(self.unsupported(p, format!("dataset type '{}'", lossy(d))));
                });
            }
            b"METADATA" => self.skip_metadata(),
            b"FIELD" => {
                let tuples = match s.section {
                    Section::None => None,
                    Section::Point(n) | Section::Cell(n) => Some(n),
                };
                let arrays = self.field(kw, tuples)?;
                match s.section {
                    Section::None => {} // dataset-level field data (TIME, CYCLE, ...) is not grid data
                    Section::Point(_) => s.point_data.extend(arrays),
                    Section::Cell(_) => s.cell_data.extend(arrays),
                }
            }
            b"POINTS" => {
                let v = self.points(kw, s)?;
                s.points = Some((kw, v));
            }
            b"DIMENSIONS" => {
                let d = [
                    self.count("dimension", kw)?,
                    self.count("dimension", kw)?,
                    self.count("dimension", kw)?,
                ];
                s.dims = Some((kw, d));
            }
            b"CELLS" => {
                let a = self.count("cell count", kw)?;
                let b = self.count("cell array size", kw)?;
                let c = if self.lx.peek().is_some_and(|t| keyword_is(t, "OFFSETS")) {
                    self.cells_51(kw, a, b)?
                } else {
                    self.cells_old(kw, a, b)?
                };
                s.cells = Some((kw, c.0, c.1));
            }
            b"CELL_TYPES" => {
                let n = self.count("cell count", kw)?;
                self.end_header();
                s.types = Some((kw, self.read_i64(n, Scalar::I32, "CELL_TYPES", kw)?));
            }
            b"POINT_DATA" | b"CELL_DATA" => {
                s.section = self.data_section(kw, key.as_slice() == b"POINT_DATA", s)?;
            }
            _ => {
                let n = match s.section {
                    Section::Point(n) | Section::Cell(n) => n,
                    Section::None => {
                        return Err(self.err(kw, format!("unrecognized keyword '{}'", lossy(t))));
                    }
                };
                if let Some(p) = self.attribute(kw, t, &key, n)? {
                    match s.section {
                        Section::Point(_) => s.point_data.push(p),
                        _ => s.cell_data.push(p),
                    }
                }
                self.skip_optional_metadata();
            }
        }
        Ok(())
    }

    /// `POINTS n type` and the coordinates (checked against the
    /// structured grid's DIMENSIONS when these came first).
    fn points(&mut self, kw: usize, s: &Sections) -> Result<Vec<f64>, VtkReadError> {
        let n = self.count("point count", kw)?;
        let ty = self.scalar(kw)?;
        self.end_header();
        let total = n
            .checked_mul(3)
            .ok_or_else(|| self.err(kw, "point count overflows"))?;
        if let Some((_, d)) = s.dims
            && s.dataset == Some(Dataset::Structured)
        {
            let need = d[0].checked_mul(d[1]).and_then(|v| v.checked_mul(d[2]));
            if need != Some(n) {
                return Err(self.err(
                    kw,
                    format!(
                        "POINTS {n}, but DIMENSIONS {} {} {} give {} points",
                        d[0],
                        d[1],
                        d[2],
                        need.map_or("too many".into(), |x| x.to_string())
                    ),
                ));
            }
        }
        let v = if self.binary {
            let bytes = self.binary_bytes(total, ty, "POINTS", kw)?;
            let v = decode_f64(bytes, ty, true, total, "POINTS")
                .map_err(|m| self.err(kw, m.to_string()))?;
            if let Some(why) = super::byte_order::little_endian_hint(bytes, ty, &v) {
                return Err(self.err(kw, why));
            }
            v
        } else {
            self.read_f64(total, ty, "POINTS", kw)?
        };
        self.skip_optional_metadata();
        Ok(v)
    }

    /// `POINT_DATA n` or `CELL_DATA n`: the section that starts, its tuple
    /// count checked against the points or cells read so far.
    fn data_section(
        &mut self,
        kw: usize,
        is_point: bool,
        s: &Sections,
    ) -> Result<Section, VtkReadError> {
        let n = self.count("tuple count", kw)?;
        let known = if is_point {
            s.points.as_ref().map(|p| p.1.len() / 3)
        } else if let Some((_, d)) = s.dims {
            structured_cells(d)
        } else {
            s.types
                .as_ref()
                .map(|t| t.1.len())
                .or(s.cells.as_ref().map(|c| c.1.len().saturating_sub(1)))
        };
        if let Some(k) = known
            && k != n
        {
            let what = if is_point {
                "POINT_DATA count vs points"
            } else {
                "CELL_DATA count vs cells"
            };
            return Err(self.count_err(kw, what, k, n));
        }
        Ok(if is_point {
            Section::Point(n)
        } else {
            Section::Cell(n)
        })
    }

    /// An attribute keyword `t` (upper case `key`) of a data section of
    /// `n` tuples: its property, or None for a lookup table.
    fn attribute(
        &mut self,
        kw: usize,
        t: &[u8],
        key: &[u8],
        n: usize,
    ) -> Result<Option<Property>, VtkReadError> {
        let kname = String::from_utf8_lossy(key).into_owned();
        Ok(match key {
            b"SCALARS" => Some(self.scalars(kw, n)?),
            b"VECTORS" | b"NORMALS" => Some(self.fixed(kw, &kname, n, 3)?),
            b"TENSORS" => Some(self.fixed(kw, &kname, n, 9)?),
            b"TENSORS6" => Some(self.fixed(kw, &kname, n, 6)?),
            b"GLOBAL_IDS" | b"PEDIGREE_IDS" | b"EDGE_FLAGS" => Some(self.fixed(kw, &kname, n, 1)?),
            b"TEXTURE_COORDINATES" => Some(self.texture_coordinates(kw, n)?),
            b"COLOR_SCALARS" => Some(self.color_scalars(kw, n)?),
            b"LOOKUP_TABLE" => {
                self.word("lookup table name", kw)?;
                let m = self.count("lookup table size", kw)?;
                self.end_header();
                let total = m.saturating_mul(4);
                let ty = if self.binary { Scalar::U8 } else { Scalar::F32 };
                self.read_f64(total, ty, "LOOKUP_TABLE", kw)?;
                None
            }
            _ => {
                return Err(self.err(kw, format!("unrecognized keyword '{}'", lossy(t))));
            }
        })
    }

    /// `TEXTURE_COORDINATES name dim type` and `n` tuples.
    fn texture_coordinates(&mut self, kw: usize, n: usize) -> Result<Property, VtkReadError> {
        let (_, name) = self.word("array name", kw)?;
        let name = decode_name(name);
        let dim = self.count("texture dimension", kw)?;
        if !(1..=3).contains(&dim) {
            return Err(self.err(kw, format!("texture dimension {dim} not in 1..=3")));
        }
        let ty = self.scalar(kw)?;
        self.end_header();
        let total = n.saturating_mul(dim);
        let values = self.read_f64(total, ty, "TEXTURE_COORDINATES", kw)?;
        Ok(Property {
            name,
            components: dim,
            values,
        })
    }

    /// `COLOR_SCALARS name m` and `n` tuples (bytes scaled to 0..1 in
    /// binary files).
    fn color_scalars(&mut self, kw: usize, n: usize) -> Result<Property, VtkReadError> {
        let (_, name) = self.word("array name", kw)?;
        let name = decode_name(name);
        let m = self.count("color component count", kw)?;
        if !(1..=4).contains(&m) {
            return Err(self.err(kw, format!("color component count {m} not in 1..=4")));
        }
        self.end_header();
        let total = n.saturating_mul(m);
        let values = if self.binary {
            let v = self.read_f64(total, Scalar::U8, "COLOR_SCALARS", kw)?;
            v.into_iter().map(|x| x / 255.0).collect()
        } else {
            self.read_f64(total, Scalar::F32, "COLOR_SCALARS", kw)?
        };
        Ok(Property {
            name,
            components: m,
            values,
        })
    }

    /// The grid from the sections read.
    fn assemble(&self, s: Sections) -> Result<Grid, VtkReadError> {
        let Sections {
            dataset,
            points,
            cells,
            types,
            dims,
            point_data,
            cell_data,
            ..
        } = s;
        let Some(dataset) = dataset else {
            return Err(self.err(self.lx.pos, "no DATASET section"));
        };
        let pts = to_points(&points.map(|p| p.1).unwrap_or_default(), self.file)?;
        let topology = match dataset {
            Dataset::Structured => {
                let Some((dp, d)) = dims else {
                    return Err(self.err(self.lx.pos, "STRUCTURED_GRID without DIMENSIONS"));
                };
                let need = d[0].checked_mul(d[1]).and_then(|v| v.checked_mul(d[2]));
                if need != Some(pts.len()) {
                    return Err(self.count_err(
                        dp,
                        "DIMENSIONS: points",
                        need.unwrap_or(usize::MAX),
                        pts.len(),
                    ));
                }
                Topology::Structured { dims: d }
            }
            Dataset::Unstructured => {
                let (cp, offsets, conn) = cells.unwrap_or((0, vec![0], Vec::new()));
                let (tp, tys) = types.unwrap_or((cp, Vec::new()));
                let ncells = offsets.len() - 1;
                if tys.len() != ncells {
                    return Err(self.count_err(tp, "CELL_TYPES count vs CELLS", ncells, tys.len()));
                }
                Topology::Unstructured(build_cells(
                    &tys,
                    &offsets,
                    &conn,
                    PolyFaces::<i64>::InConnectivity,
                    self.file,
                )?)
            }
        };
        Ok(Grid {
            points: pts,
            topology,
            point_data,
            cell_data,
        })
    }

    /// Old form: `CELLS n size` then per cell `k id0 .. id(k-1)`.
    /// Returns offsets (len n+1) and connectivity.
    fn cells_old(
        &mut self,
        kw: usize,
        n: usize,
        size: usize,
    ) -> Result<(Vec<usize>, Vec<i64>), VtkReadError> {
        self.end_header();
        let raw = self.read_i64(size, Scalar::I32, "CELLS", kw)?;
        let mut offsets = Vec::with_capacity(n.min(raw.len()) + 1);
        let mut conn = Vec::with_capacity(raw.len().saturating_sub(n));
        offsets.push(0);
        let mut i = 0;
        for c in 0..n {
            let Some(&k) = raw.get(i) else {
                return Err(self.count_err(kw, "CELLS: cells in the given size", n, c));
            };
            let ku = usize::try_from(k)
                .map_err(|_| self.err(kw, format!("CELLS: cell {c} has vertex count {k}")))?;
            let ids = raw.get(i + 1..).and_then(|r| r.get(..ku)).ok_or_else(|| {
                let need = i.saturating_add(1).saturating_add(ku);
                self.count_err(
                    kw,
                    format!("CELLS: size (values needed through cell {c})"),
                    need,
                    size,
                )
            })?;
            conn.extend_from_slice(ids);
            offsets.push(conn.len());
            i += 1 + ku;
        }
        if i != size {
            return Err(self.count_err(kw, "CELLS: size vs values used by the cells", size, i));
        }
        Ok((offsets, conn))
    }

    /// VTK 5.1 form: `CELLS nOffsets nConn`, `OFFSETS type`, `CONNECTIVITY type`.
    fn cells_51(
        &mut self,
        kw: usize,
        noff: usize,
        nconn: usize,
    ) -> Result<(Vec<usize>, Vec<i64>), VtkReadError> {
        let (op, _) = self.word("OFFSETS", kw)?;
        let ty = self.scalar(op)?;
        self.end_header();
        let off = self.read_i64(noff, ty, "OFFSETS", op)?;
        let (cp, ckw) = self.word("CONNECTIVITY", kw)?;
        if !keyword_is(ckw, "CONNECTIVITY") {
            return Err(self.err(cp, format!("expected CONNECTIVITY, found '{}'", lossy(ckw))));
        }
        let ty = self.scalar(cp)?;
        self.end_header();
        let conn = self.read_i64(nconn, ty, "CONNECTIVITY", cp)?;
        if off.is_empty() {
            return Ok((vec![0], conn));
        }
        let mut offsets = Vec::with_capacity(off.len());
        let mut prev = 0usize;
        for (i, &o) in off.iter().enumerate() {
            let ou = usize::try_from(o).ok().filter(|&o| o >= prev && (i > 0 || o == 0)).ok_or_else(|| {
                self.err(op, format!("OFFSETS: value {o} at index {i} is not a non-decreasing offset starting at 0"))
            })?;
            offsets.push(ou);
            prev = ou;
        }
        if prev != conn.len() {
            return Err(self.count_err(
                op,
                "OFFSETS: last offset vs CONNECTIVITY size",
                conn.len(),
                prev,
            ));
        }
        Ok((offsets, conn))
    }
}

/// Parses a legacy file into an unvalidated grid.
pub(crate) fn parse(bytes: &[u8], file: &str) -> Result<Grid, VtkReadError> {
    Parser {
        lx: Lexer { b: bytes, pos: 0 },
        file,
        binary: false,
    }
    .parse()
}
