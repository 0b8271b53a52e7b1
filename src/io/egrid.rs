//! Eclipse binary grids: EGRID (GRIDHEAD, COORD, ZCORN, ACTNUM, MAPAXES)
//! and, when present beside it, the INIT file's per-cell properties.
//!
//! Both are big-endian Fortran unformatted sequential files: every record
//! is `len (i32 BE) · bytes · len (i32 BE)`. An array is a 16-byte header
//! record (8-char keyword, i32 count, 4-char type: INTE, REAL, DOUB, LOGI,
//! CHAR, C0nn, MESS) followed by data records (blocks of at most 1000
//! numbers or 105 strings; the reader does not rely on the block size).
//! Only the main grid is read: local grid refinements (`LGR` … `ENDLGR`
//! sections, before or after it) are skipped and named, never taken for
//! the main grid. INIT properties stored for the active cells only are
//! expanded to all cells (0 for inactive ones, which the corner-point
//! conversion excludes anyway). A dual-porosity file (`FILEHEAD[5]` ≠ 0)
//! is read as its matrix: ACTNUM bit 1 says which cells are active, and
//! INIT arrays hold the matrix values first, then the fracture values, of
//! which the matrix half is kept (see [`EgridNotes`]).

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::cornerpoint::CornerPointGrid;
use crate::grid::Property;

/// Errors reading EGRID / INIT files. Offsets are byte offsets in the file.
#[derive(Debug, Error)]
pub enum EgridError {
    /// The file cannot be read.
    #[error("{file}: {source}")]
    Io {
        /// File.
        file: PathBuf,
        /// Cause.
        source: io::Error,
    },
    /// A record that runs past the end of the file.
    #[error(
        "{file}: record at byte {offset} ({keyword}) is truncated: needs {needed} bytes, {left} left"
    )]
    Truncated {
        /// File.
        file: PathBuf,
        /// Offset of the record.
        offset: usize,
        /// Keyword being read.
        keyword: String,
        /// Bytes needed.
        needed: usize,
        /// Bytes left.
        left: usize,
    },
    /// Leading and trailing record markers differ, or a marker is negative.
    #[error(
        "{file}: record at byte {offset} ({keyword}): bad Fortran record markers {head} / {tail}"
    )]
    BadMarker {
        /// File.
        file: PathBuf,
        /// Offset.
        offset: usize,
        /// Keyword being read.
        keyword: String,
        /// Leading marker.
        head: i64,
        /// Trailing marker.
        tail: i64,
    },
    /// A header record that is not 16 bytes or has an unknown type.
    #[error("{file}: bad array header at byte {offset}: {why}")]
    BadHeader {
        /// File.
        file: PathBuf,
        /// Offset.
        offset: usize,
        /// What is wrong.
        why: String,
    },
    /// A data record whose size is not a whole number of elements, or too many elements.
    #[error("{file}: {keyword} at byte {offset}: {why}")]
    BadData {
        /// File.
        file: PathBuf,
        /// Offset.
        offset: usize,
        /// Keyword.
        keyword: String,
        /// What is wrong.
        why: String,
    },
    /// A required keyword is missing.
    #[error("{file}: required keyword {keyword} is missing")]
    Missing {
        /// File.
        file: PathBuf,
        /// Keyword.
        keyword: String,
    },
    /// An array with the wrong element count or type.
    #[error("{file}: {keyword} has {found} values of type {kind}, expected {expected}")]
    Count {
        /// File.
        file: PathBuf,
        /// Keyword.
        keyword: String,
        /// Type found.
        kind: String,
        /// Expected count.
        expected: usize,
        /// Found count.
        found: usize,
    },
    /// Something the reader does not handle (radial grids, ...).
    #[error("{file}: {why}")]
    Unsupported {
        /// File.
        file: PathBuf,
        /// What.
        why: String,
    },
}

/// The data of one array.
#[derive(Clone, Debug, PartialEq)]
pub enum EclData {
    /// INTE.
    Int(Vec<i32>),
    /// REAL.
    Real(Vec<f32>),
    /// DOUB.
    Double(Vec<f64>),
    /// LOGI.
    Logical(Vec<bool>),
    /// CHAR or C0nn (trailing blanks kept).
    Char(Vec<String>),
    /// MESS (no data).
    Message,
}

impl EclData {
    /// Element count.
    pub fn len(&self) -> usize {
        match self {
            EclData::Int(v) => v.len(),
            EclData::Real(v) => v.len(),
            EclData::Double(v) => v.len(),
            EclData::Logical(v) => v.len(),
            EclData::Char(v) => v.len(),
            EclData::Message => 0,
        }
    }
    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Type name as in the file.
    pub fn type_name(&self) -> &'static str {
        match self {
            EclData::Int(_) => "INTE",
            EclData::Real(_) => "REAL",
            EclData::Double(_) => "DOUB",
            EclData::Logical(_) => "LOGI",
            EclData::Char(_) => "CHAR",
            EclData::Message => "MESS",
        }
    }
    /// Numeric values as f64 (`None` for strings and messages).
    pub fn to_f64(&self) -> Option<Vec<f64>> {
        Some(match self {
            EclData::Int(v) => v.iter().map(|&x| x as f64).collect(),
            EclData::Real(v) => v.iter().map(|&x| x as f64).collect(),
            EclData::Double(v) => v.clone(),
            EclData::Logical(v) => v.iter().map(|&x| x as u8 as f64).collect(),
            _ => return None,
        })
    }
}

/// One array: keyword and data.
#[derive(Clone, Debug, PartialEq)]
pub struct EclArray {
    /// Keyword, trailing blanks removed.
    pub keyword: String,
    /// Data.
    pub data: EclData,
}

/// Iterates over the arrays of an in-memory EGRID/INIT file.
pub struct ArrayReader<'a> {
    bytes: &'a [u8],
    pos: usize,
    file: PathBuf,
}

impl<'a> ArrayReader<'a> {
    /// A reader over `bytes`, naming `file` in errors.
    pub fn new(bytes: &'a [u8], file: &Path) -> Self {
        ArrayReader {
            bytes,
            pos: 0,
            file: file.into(),
        }
    }

    /// One Fortran record's payload.
    fn record(&mut self, keyword: &str) -> Result<&'a [u8], EgridError> {
        let off = self.pos;
        let left = self.bytes.len() - off;
        let trunc = |needed: usize| EgridError::Truncated {
            file: self.file.clone(),
            offset: off,
            keyword: keyword.into(),
            needed,
            left,
        };
        if left < 4 {
            return Err(trunc(4));
        }
        let head = i32::from_be_bytes(self.bytes[off..off + 4].try_into().unwrap_or([0; 4]));
        if head < 0 {
            return Err(EgridError::BadMarker {
                file: self.file.clone(),
                offset: off,
                keyword: keyword.into(),
                head: head as i64,
                tail: -1,
            });
        }
        let n = head as usize;
        if left < 8 + n {
            return Err(trunc(8 + n));
        }
        let tail = i32::from_be_bytes(
            self.bytes[off + 4 + n..off + 8 + n]
                .try_into()
                .unwrap_or([0; 4]),
        );
        if tail != head {
            return Err(EgridError::BadMarker {
                file: self.file.clone(),
                offset: off,
                keyword: keyword.into(),
                head: head as i64,
                tail: tail as i64,
            });
        }
        self.pos = off + 8 + n;
        Ok(&self.bytes[off + 4..off + 4 + n])
    }

    /// The next array's header, or `None` at the end of the file. Its
    /// data records follow: read them with [`ArrayReader::data`] (or
    /// [`ArrayReader::numeric`]) before the next header.
    fn header(&mut self) -> Result<Option<Header>, EgridError> {
        if self.pos >= self.bytes.len() {
            return Ok(None);
        }
        let off = self.pos;
        let h = self.record("array header")?;
        if h.len() != 16 {
            return Err(EgridError::BadHeader {
                file: self.file.clone(),
                offset: off,
                why: format!("header record of {} bytes, expected 16", h.len()),
            });
        }
        let keyword = String::from_utf8_lossy(&h[..8]).trim_end().to_string();
        let count = i32::from_be_bytes(h[8..12].try_into().unwrap_or([0; 4]));
        let ty = String::from_utf8_lossy(&h[12..16]).to_string();
        if count < 0 {
            return Err(EgridError::BadHeader {
                file: self.file.clone(),
                offset: off,
                why: format!("{keyword}: negative count {count}"),
            });
        }
        let count = count as usize;
        let (size, kind) = match ty.as_str() {
            "INTE" => (4, Kind::Int),
            "REAL" => (4, Kind::Real),
            "DOUB" => (8, Kind::Double),
            "LOGI" => (4, Kind::Logical),
            "CHAR" => (8, Kind::Char),
            "MESS" => (0, Kind::Message),
            t if t.starts_with("C0") && t[2..].parse::<usize>().is_ok_and(|n| n > 0) => {
                (t[2..].parse::<usize>().unwrap_or(8), Kind::Char)
            }
            _ => {
                return Err(EgridError::BadHeader {
                    file: self.file.clone(),
                    offset: off,
                    why: format!("{keyword}: unknown type '{ty}'"),
                });
            }
        };
        let count = if kind == Kind::Message { 0 } else { count };
        // The payload can never exceed the bytes left: reject absurd counts
        // before allocating.
        if count.saturating_mul(size) > self.bytes.len() - self.pos {
            return Err(EgridError::Truncated {
                file: self.file.clone(),
                offset: self.pos,
                keyword: keyword.clone(),
                needed: count.saturating_mul(size),
                left: self.bytes.len() - self.pos,
            });
        }
        Ok(Some(Header {
            keyword,
            count,
            size,
            kind,
        }))
    }

    /// The data records of the array `h`, each element decoded by `conv`.
    fn decode<T>(&mut self, h: &Header, conv: impl Fn(&[u8]) -> T) -> Result<Vec<T>, EgridError> {
        let (count, size) = (h.count, h.size);
        // Room for what the rest of the file can hold (a count past it is
        // reported by the record checks below).
        let most = (self.bytes.len() - self.pos.min(self.bytes.len())) / size.max(1);
        let mut v =
            crate::mem::try_vec(count.min(most), &h.keyword).map_err(|e| EgridError::Io {
                file: self.file.clone(),
                source: e.into(),
            })?;
        while v.len() < count {
            let roff = self.pos;
            let r = self.record(&h.keyword)?;
            let got = v.len();
            if r.is_empty() || r.len() % size != 0 || got + r.len() / size > count {
                return Err(EgridError::BadData {
                    file: self.file.clone(),
                    offset: roff,
                    keyword: h.keyword.clone(),
                    why: format!(
                        "data record of {} bytes after {got} of {count} elements of {size} bytes",
                        r.len()
                    ),
                });
            }
            v.extend(r.chunks_exact(size).map(&conv));
        }
        Ok(v)
    }

    /// The data of the array `h`.
    fn data(&mut self, h: &Header) -> Result<EclData, EgridError> {
        let word = |c: &[u8]| c.try_into().unwrap_or([0; 4]);
        Ok(match h.kind {
            Kind::Int => EclData::Int(self.decode(h, |c| i32::from_be_bytes(word(c)))?),
            Kind::Real => EclData::Real(self.decode(h, |c| f32::from_be_bytes(word(c)))?),
            Kind::Double => EclData::Double(
                self.decode(h, |c| f64::from_be_bytes(c.try_into().unwrap_or([0; 8])))?,
            ),
            Kind::Logical => EclData::Logical(self.decode(h, |c| c != [0, 0, 0, 0])?),
            Kind::Char => EclData::Char(
                self.decode(h, |c| String::from_utf8_lossy(c).trim_end().to_string())?,
            ),
            Kind::Message => EclData::Message,
        })
    }

    /// Steps over the data records of the array `h` (checked as
    /// [`ArrayReader::data`] checks them, nothing decoded).
    fn skip(&mut self, h: &Header) -> Result<(), EgridError> {
        self.decode(h, |_| ()).map(|_| ())
    }

    /// The data of the numeric (INTE, REAL, DOUB) array `h`, each value
    /// widened to f64 and mapped by `f`, without an intermediate array.
    fn numeric<T>(&mut self, h: &Header, f: impl Fn(f64) -> T) -> Result<Vec<T>, EgridError> {
        let word = |c: &[u8]| c.try_into().unwrap_or([0; 4]);
        match h.kind {
            Kind::Int => self.decode(h, |c| f(i32::from_be_bytes(word(c)) as f64)),
            Kind::Real => self.decode(h, |c| f(f32::from_be_bytes(word(c)) as f64)),
            _ => self.decode(h, |c| f(f64::from_be_bytes(c.try_into().unwrap_or([0; 8])))),
        }
    }

    /// The next array, or `None` at the end of the file.
    pub fn next_array(&mut self) -> Result<Option<EclArray>, EgridError> {
        let Some(h) = self.header()? else {
            return Ok(None);
        };
        let data = self.data(&h)?;
        Ok(Some(EclArray {
            keyword: h.keyword,
            data,
        }))
    }
}

/// Element types of an array.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Int,
    Real,
    Double,
    Logical,
    Char,
    Message,
}

impl Kind {
    /// Type name as [`EclData::type_name`] gives it.
    fn name(self) -> &'static str {
        match self {
            Kind::Int => "INTE",
            Kind::Real => "REAL",
            Kind::Double => "DOUB",
            Kind::Logical => "LOGI",
            Kind::Char => "CHAR",
            Kind::Message => "MESS",
        }
    }
}

/// An array header (the data records follow it).
struct Header {
    keyword: String,
    count: usize,
    size: usize,
    kind: Kind,
}

/// Appends one array in EGRID form (header record, then data records of at
/// most 1000 numbers or 105 strings). For writing test files.
pub fn write_array(out: &mut impl Write, keyword: &str, data: &EclData) -> io::Result<()> {
    let record = |out: &mut dyn Write, payload: &[u8]| -> io::Result<()> {
        let n = (payload.len() as i32).to_be_bytes();
        out.write_all(&n)?;
        out.write_all(payload)?;
        out.write_all(&n)
    };
    let mut h = Vec::with_capacity(16);
    let mut kw = keyword.as_bytes().to_vec();
    kw.resize(8, b' ');
    h.extend_from_slice(&kw[..8]);
    h.extend_from_slice(&(data.len() as i32).to_be_bytes());
    h.extend_from_slice(data.type_name().as_bytes());
    record(out, &h)?;
    let mut buf = Vec::new();
    macro_rules! blocks {
        ($v:expr, $per:expr, $enc:expr) => {
            for chunk in $v.chunks($per) {
                buf.clear();
                for x in chunk {
                    buf.extend_from_slice(&$enc(x));
                }
                record(out, &buf)?;
            }
        };
    }
    match data {
        EclData::Int(v) => blocks!(v, 1000, |x: &i32| x.to_be_bytes()),
        EclData::Real(v) => blocks!(v, 1000, |x: &f32| x.to_be_bytes()),
        EclData::Double(v) => blocks!(v, 1000, |x: &f64| x.to_be_bytes()),
        EclData::Logical(v) => blocks!(v, 1000, |x: &bool| (if *x { -1i32 } else { 0 })
            .to_be_bytes()),
        EclData::Char(v) => blocks!(v, 105, |x: &String| {
            let mut b = x.as_bytes().to_vec();
            b.resize(8, b' ');
            let mut a = [b' '; 8];
            a.copy_from_slice(&b[..8]);
            a
        }),
        EclData::Message => {}
    }
    Ok(())
}

/// What an EGRID read returns.
#[derive(Clone, Debug)]
pub struct EgridFile {
    /// The grid (with INIT properties when an INIT file was found).
    pub grid: CornerPointGrid,
    /// The INIT file read, if any.
    pub init: Option<PathBuf>,
    /// When no INIT file was found: the paths looked for, in order.
    pub init_looked_for: Vec<PathBuf>,
    /// INIT arrays not added as properties, with the reason.
    pub skipped_init: Vec<SkippedArray>,
    /// What the EGRID holds beyond the main single-porosity grid.
    pub notes: EgridNotes,
}

/// What an EGRID holds that the reader does not show: a dual-porosity
/// model's fracture half, local grid refinements.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EgridNotes {
    /// `FILEHEAD[5]` when it is not 0 (1 dual porosity, 2 dual
    /// permeability): only the matrix is read.
    pub dual_porosity: Option<i32>,
    /// Dual porosity: cells whose fracture is active (ACTNUM bit 2), not shown.
    pub fracture_active: usize,
    /// Dual porosity: cells whose matrix is active (ACTNUM bit 1), shown.
    pub matrix_active: usize,
    /// Names of the local grid refinements skipped, in file order.
    pub local_grids: Vec<String>,
}

/// Parses EGRID bytes (main grid only) into a corner-point grid.
pub fn parse_egrid(bytes: &[u8], file: &Path) -> Result<CornerPointGrid, EgridError> {
    Ok(parse_egrid_notes(bytes, file)?.0)
}

/// The dimensions a GRIDHEAD array gives (a corner-point grid of at least
/// one cell, small enough for u32 ids).
fn gridhead_dims(data: &EclData, file: &Path) -> Result<[usize; 3], EgridError> {
    let count_err = |found: usize| EgridError::Count {
        file: file.into(),
        keyword: "GRIDHEAD".into(),
        kind: data.type_name().into(),
        expected: 4,
        found,
    };
    let EclData::Int(v) = data else {
        return Err(count_err(data.len()));
    };
    if v.len() < 4 {
        return Err(count_err(v.len()));
    }
    if v[0] != 1 {
        return Err(EgridError::Unsupported {
            file: file.into(),
            why: format!("GRIDHEAD grid type {} (only corner-point, 1)", v[0]),
        });
    }
    if v[1..4].iter().any(|&x| x <= 0)
        || (v[1] as u128 + 1) * (v[2] as u128 + 1) * (v[3] as u128) * 8 >= u32::MAX as u128
    {
        return Err(EgridError::Unsupported {
            file: file.into(),
            why: format!("GRIDHEAD dimensions {:?}", &v[1..4]),
        });
    }
    Ok([v[1] as usize, v[2] as usize, v[3] as usize])
}

/// The ACTNUM array `h`: 0/1 per cell; for a dual-porosity grid (`notes`
/// says so) the matrix bit (1 of 1 | 2), the matrix and fracture counts
/// recorded in `notes`.
fn read_actnum(
    r: &mut ArrayReader<'_>,
    h: &Header,
    notes: &mut EgridNotes,
    file: &Path,
) -> Result<Vec<u8>, EgridError> {
    // NaN kept as 4 to be reported.
    let dual = notes.dual_porosity.is_some();
    let v = r.numeric(h, |x| match (x.is_finite(), dual) {
        (false, _) => 4,
        (true, false) => (x != 0.0) as u8,
        (true, true) => (x as i64 & 3) as u8,
    })?;
    if let Some(i) = v.iter().position(|&x| x == 4) {
        return Err(EgridError::BadData {
            file: file.into(),
            offset: r.pos,
            keyword: h.keyword.clone(),
            why: format!("value {i} is not finite"),
        });
    }
    if !dual {
        return Ok(v);
    }
    notes.fracture_active = v.iter().filter(|&&x| x & 2 != 0).count();
    notes.matrix_active = v.iter().filter(|&&x| x & 1 != 0).count();
    Ok(v.into_iter().map(|x| x & 1).collect())
}

/// The end of the file: an error when it ends inside a local grid
/// (`in_lgr`) before any main grid; a dual-porosity grid without ACTNUM
/// has every cell active in both halves.
fn close_notes(
    notes: &mut EgridNotes,
    in_lgr: Option<usize>,
    dims: Option<[usize; 3]>,
    has_actnum: bool,
    file: &Path,
) -> Result<(), EgridError> {
    if let (Some(l), None) = (in_lgr, dims) {
        return Err(EgridError::Missing {
            file: file.into(),
            keyword: format!(
                "GRIDHEAD of the main grid (the file ends inside local grid refinement {}, which has no ENDLGR)",
                notes.local_grids[l]
            ),
        });
    }
    if notes.dual_porosity.is_some() && !has_actnum {
        let n = dims.map_or(0, |[nx, ny, nz]| nx * ny * nz);
        (notes.matrix_active, notes.fracture_active) = (n, n);
    }
    Ok(())
}

/// Records an `LGR` record (or an `LGRNAME` inside a section) whose data
/// is `data`: outside a section (`current` = `None`) a new local grid named
/// by its first string (`#n` when it has none); inside one, a name for a
/// section that had none. Returns the section's index.
fn name_lgr(names: &mut Vec<String>, current: Option<usize>, data: &EclData) -> usize {
    let name = match data {
        EclData::Char(v) => v.first().cloned().unwrap_or_default(),
        _ => String::new(),
    };
    let unnamed = |n: usize| format!("#{}", n + 1);
    match current {
        Some(l) => {
            if names[l] == unnamed(l) && !name.is_empty() {
                names[l] = name;
            }
            l
        }
        None => {
            let l = names.len();
            names.push(if name.is_empty() { unnamed(l) } else { name });
            l
        }
    }
}

/// [`parse_egrid`], with what the file holds beyond the main
/// single-porosity grid: local grid refinements (their sections are
/// skipped wherever they stand, so one placed first is never taken for the
/// main grid) and the dual-porosity flag (`FILEHEAD[5]`; the grid is then
/// its matrix: ACTNUM bit 1).
pub fn parse_egrid_notes(
    bytes: &[u8],
    file: &Path,
) -> Result<(CornerPointGrid, EgridNotes), EgridError> {
    let mut r = ArrayReader::new(bytes, file);
    let mut notes = EgridNotes::default();
    // Inside an LGR section (from `LGR` to `ENDLGR`): its name.
    let mut in_lgr: Option<usize> = None;
    let mut main_done = false;
    let mut dims = None;
    let mut coord = None;
    let mut zcorn = None;
    let mut actnum = None;
    let mut mapaxes = None;
    let mut mapunits = None;
    let mut gridunit = None;
    let count_err = |kw: &str, kind: &str, found: usize, expected: usize| EgridError::Count {
        file: file.into(),
        keyword: kw.into(),
        kind: kind.into(),
        expected,
        found,
    };
    while let Some(h) = r.header()? {
        if h.keyword == "LGR" || (h.keyword == "LGRNAME" && in_lgr.is_some()) {
            let data = r.data(&h)?;
            in_lgr = Some(name_lgr(&mut notes.local_grids, in_lgr, &data));
            continue;
        }
        if in_lgr.is_some() || main_done {
            if h.keyword == "ENDLGR" {
                in_lgr = None;
            }
            r.skip(&h)?;
            continue;
        }
        if matches!(h.keyword.as_str(), "COORD" | "ZCORN" | "ACTNUM" | "MAPAXES") {
            // Numeric arrays decoded straight to their final form.
            let Some([nx, ny, nz]) = dims.or((h.keyword == "MAPAXES").then_some([0, 0, 0])) else {
                return Err(EgridError::Missing {
                    file: file.into(),
                    keyword: format!("GRIDHEAD (before {})", h.keyword),
                });
            };
            let expected = match h.keyword.as_str() {
                "COORD" => 6 * (nx + 1) * (ny + 1),
                "ZCORN" => 8 * nx * ny * nz,
                "ACTNUM" => nx * ny * nz,
                _ => 6,
            };
            let numeric = matches!(h.kind, Kind::Int | Kind::Real | Kind::Double);
            if h.count != expected || !numeric {
                return Err(count_err(&h.keyword, h.kind.name(), h.count, expected));
            }
            let non_finite = |i: usize, offset: usize| EgridError::BadData {
                file: file.into(),
                offset,
                keyword: h.keyword.clone(),
                why: format!("value {i} is not finite"),
            };
            if h.keyword == "ACTNUM" {
                actnum = Some(read_actnum(&mut r, &h, &mut notes, file)?);
                continue;
            }
            let v = r.numeric(&h, |x| x)?;
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                return Err(non_finite(i, r.pos));
            }
            match h.keyword.as_str() {
                "COORD" => coord = Some(v),
                "ZCORN" => zcorn = Some(v),
                _ => mapaxes = Some([v[0], v[1], v[2], v[3], v[4], v[5]]),
            }
            continue;
        }
        let a = EclArray {
            data: r.data(&h)?,
            keyword: h.keyword,
        };
        match a.keyword.as_str() {
            "FILEHEAD" => {
                if let EclData::Int(v) = &a.data
                    && v.get(5).is_some_and(|&d| d != 0)
                {
                    notes.dual_porosity = Some(v[5]);
                }
            }
            "GRIDHEAD" => dims = Some(gridhead_dims(&a.data, file)?),
            "MAPUNITS" | "GRIDUNIT" => {
                if let EclData::Char(s) = &a.data {
                    let s = s.first().cloned();
                    if a.keyword == "MAPUNITS" {
                        mapunits = s;
                    } else {
                        gridunit = s;
                    }
                }
            }
            "ENDGRID" => main_done = true,
            _ => {}
        }
    }
    close_notes(&mut notes, in_lgr, dims, actnum.is_some(), file)?;
    let missing = |k: &str| EgridError::Missing {
        file: file.into(),
        keyword: k.into(),
    };
    let grid = CornerPointGrid {
        dims: dims.ok_or_else(|| missing("GRIDHEAD"))?,
        coord: coord.ok_or_else(|| missing("COORD"))?,
        zcorn: zcorn.ok_or_else(|| missing("ZCORN"))?,
        actnum,
        mapaxes,
        mapunits,
        gridunit,
        properties: Vec::new(),
    };
    Ok((grid, notes))
}

/// Adds the per-cell arrays of INIT bytes to `grid`: arrays of `nx·ny·nz`
/// values as they are, arrays of one value per active cell expanded (0 for
/// inactive cells). Returns the names added.
pub fn add_init_properties(
    grid: &mut CornerPointGrid,
    bytes: &[u8],
    file: &Path,
) -> Result<Vec<String>, EgridError> {
    Ok(add_init_properties_report(grid, bytes, file)?.0)
}

/// An INIT array that was not added as a property, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct SkippedArray {
    /// The array's keyword.
    pub name: String,
    /// Why it was skipped (wrong length, a value that is not finite).
    pub reason: String,
}

/// As [`add_init_properties`], also returning the numeric per-cell-looking
/// arrays skipped, each with its reason (header and logical arrays are not
/// properties and are not listed).
pub fn add_init_properties_report(
    grid: &mut CornerPointGrid,
    bytes: &[u8],
    file: &Path,
) -> Result<(Vec<String>, Vec<SkippedArray>), EgridError> {
    add_init_properties_with(grid, bytes, file, &EgridNotes::default())
}

/// The per-cell values of an INIT array `v` of `grid` (`active`: its active
/// cells), or `None` when its length fits no layout. Single porosity: one
/// value per cell, or per active cell. Dual porosity (`notes`): the matrix
/// half of one value per cell for each half (`2·n`), or of one per active
/// matrix cell then one per active fracture cell.
fn per_cell(v: Vec<f64>, n: usize, active: &[usize], notes: &EgridNotes) -> Option<Vec<f64>> {
    let expand = |v: &[f64]| {
        let mut full = vec![0.0; n];
        for (&c, &x) in active.iter().zip(v) {
            full[c] = x;
        }
        full
    };
    if notes.dual_porosity.is_some() {
        return if v.len() == 2 * n {
            let mut v = v;
            v.truncate(n);
            Some(v)
        } else if v.len() == notes.matrix_active + notes.fracture_active && !active.is_empty() {
            Some(expand(&v[..active.len()]))
        } else {
            None
        };
    }
    if v.len() == n {
        Some(v)
    } else if v.len() == active.len() && !active.is_empty() {
        Some(expand(&v))
    } else {
        None
    }
}

/// [`add_init_properties_report`] for the EGRID whose [`EgridNotes`] are
/// `notes`: for a dual-porosity grid, every array's matrix half.
pub fn add_init_properties_with(
    grid: &mut CornerPointGrid,
    bytes: &[u8],
    file: &Path,
    notes: &EgridNotes,
) -> Result<(Vec<String>, Vec<SkippedArray>), EgridError> {
    let n = grid.cell_count();
    let mut skipped = Vec::new();
    let active: Vec<usize> = (0..n).filter(|&c| grid.is_active(c)).collect();
    let mut r = ArrayReader::new(bytes, file);
    let mut names = Vec::new();
    while let Some(a) = r.next_array()? {
        let Some(v) = a.data.to_f64() else { continue };
        if matches!(a.data, EclData::Logical(_)) || a.keyword.ends_with("HEAD") {
            continue;
        }
        let len = v.len();
        let Some(full) = per_cell(v, n, &active, notes) else {
            // Only arrays that look per-cell (at least half the active
            // count, at most twice the cells) are worth a word: TAB,
            // TABDIMS and the like are not properties.
            if a.keyword != "TAB" && len * 2 >= active.len().max(2) && len <= 2 * n {
                let layout = if notes.dual_porosity.is_some() {
                    format!(
                        "; dual porosity expects {} (matrix and fracture per cell) or {} (active matrix, then active fracture cells)",
                        2 * n,
                        notes.matrix_active + notes.fracture_active
                    )
                } else {
                    String::new()
                };
                skipped.push(SkippedArray {
                    name: a.keyword.clone(),
                    reason: format!(
                        "has {len} values; the grid has {n} cells, {} of them active{layout}",
                        active.len()
                    ),
                });
            }
            continue;
        };
        if let Some(i) = full.iter().position(|x| !x.is_finite()) {
            skipped.push(SkippedArray {
                name: a.keyword.clone(),
                reason: format!("value {i} is {} (not finite)", full[i]),
            });
            continue;
        }
        grid.properties.retain(|p| p.name != a.keyword);
        grid.properties
            .push(Property::scalar(a.keyword.clone(), full));
        names.push(a.keyword);
    }
    Ok((names, skipped))
}

/// Reads an EGRID file and, when a file with the same stem and extension
/// `INIT` (or `init`) sits beside it, its per-cell properties.
pub fn read_egrid(path: impl AsRef<Path>) -> Result<EgridFile, EgridError> {
    let path = path.as_ref();
    let read = |p: &Path| {
        std::fs::File::open(p)
            .and_then(|f| crate::mem::read_file(&f))
            .map_err(|e| EgridError::Io {
                file: p.into(),
                source: e,
            })
    };
    let bytes = read(path)?;
    let (mut grid, notes) = parse_egrid_notes(&bytes, path)?;
    drop(bytes);
    let mut init = None;
    let mut skipped_init = Vec::new();
    let looked: Vec<PathBuf> = ["INIT", "init"]
        .iter()
        .map(|e| path.with_extension(e))
        .collect();
    for p in &looked {
        if p.is_file() {
            let b = read(p)?;
            skipped_init = add_init_properties_with(&mut grid, &b, p, &notes)?.1;
            init = Some(p.clone());
            break;
        }
    }
    Ok(EgridFile {
        grid,
        init_looked_for: if init.is_none() { looked } else { Vec::new() },
        init,
        skipped_init,
        notes,
    })
}
