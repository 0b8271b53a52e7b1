//! Eclipse GRDECL text (and the GRID section of `.DATA` decks): a streaming
//! tokenizer that writes straight into typed arrays.
//!
//! The file is read through a fixed 64 KiB window (a small file: its own
//! size), small enough to stay in cache; a token is never longer
//! than [`MAX_TOKEN`] bytes. Numbers are parsed from the window's bytes
//! (Clinger's fast path, exact for up to 19 significant digits and
//! exponents within ±22, `str::parse` otherwise) and pushed into the
//! keyword's preallocated array, so no vector of string tokens is ever
//! built and the peak memory is the final arrays plus the window.
//!
//! Syntax: `--` comments, `N*value` repeats, `N*` defaults (only where the
//! keyword has a default: ACTNUM = 1, the optional items of SPECGRID),
//! `/` terminators, quoted strings (`'…'` or `"…"`), `INCLUDE` resolved
//! relative to the including file (falling back to the file name in that
//! directory), `DIMENS` or `SPECGRID`.
//!
//! Keywords: SPECGRID, DIMENS, COORD, ZCORN, ACTNUM, MAPAXES, MAPUNITS,
//! GRIDUNIT, and any per-cell numeric property of `nx·ny·nz` values
//! (known names such as PORO, PERMX, NTG, FIPNUM are checked for length;
//! other keywords whose single record has exactly `nx·ny·nz` numbers are
//! taken as properties too). Unknown keywords are skipped and listed once
//! in [`GrdeclDeck::skipped`]. In a deck (a file with a `GRID` section
//! keyword), reading stops at the first section after `GRID`.

use std::collections::HashSet;
use std::fs::File;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::cornerpoint::CornerPointGrid;
use crate::grid::Property;

/// Longest token (number, word or quoted string) in bytes.
pub const MAX_TOKEN: usize = 4096;

/// Size of the read window: 64 KiB stays in the cache while it is parsed
/// (cold single-shot Reek parse 6.4 ms against 7.2 ms with 1 MiB).
const WINDOW: usize = 1 << 16;

/// Deepest INCLUDE nesting accepted.
const MAX_INCLUDE_DEPTH: usize = 32;

/// Most cells an operator (EQUALS, COPY, ...) may create an array for
/// before ZCORN has been read (8 Mi cells, 64 MiB per f64 array): a deck
/// whose header claims a huge grid must show its geometry before it costs
/// gigabytes.
const MAX_CELLS_BEFORE_GEOMETRY: usize = 8 << 20;

/// Errors reading GRDECL text. Every variant names the file, the line and
/// (where there is one) the keyword.
#[derive(Debug, Error)]
pub enum GrdeclError {
    /// The file cannot be opened or read.
    #[error("{file}: {source}")]
    Io {
        /// File.
        file: PathBuf,
        /// Cause.
        source: io::Error,
    },
    /// A keyword that needs the grid dimensions came before SPECGRID/DIMENS.
    #[error(
        "{file}:{line}: {keyword} needs the grid size, but no SPECGRID or DIMENS came before it"
    )]
    MissingSpecgrid {
        /// File.
        file: PathBuf,
        /// Line of the keyword.
        line: usize,
        /// Keyword.
        keyword: String,
    },
    /// The grid ended without any SPECGRID/DIMENS.
    #[error("{file}: no SPECGRID or DIMENS keyword (keyword {keyword} missing)")]
    NoSpecgrid {
        /// File.
        file: PathBuf,
        /// Always `SPECGRID`.
        keyword: String,
    },
    /// A required keyword never appeared.
    #[error("{file}: required keyword {keyword} is missing")]
    MissingKeyword {
        /// File.
        file: PathBuf,
        /// Keyword.
        keyword: String,
    },
    /// A keyword with the wrong number of values.
    #[error("{file}:{line}: {keyword} has {found} values, expected {expected}")]
    CountMismatch {
        /// File.
        file: PathBuf,
        /// Line of the keyword.
        line: usize,
        /// Keyword.
        keyword: String,
        /// Expected value count.
        expected: usize,
        /// Found value count.
        found: usize,
    },
    /// The data of a keyword ends (end of file or next keyword) without `/`.
    #[error(
        "{file}:{line}: {keyword} is truncated: {found} values, expected {expected}, then {next} instead of '/'"
    )]
    Truncated {
        /// File.
        file: PathBuf,
        /// Line where the data stopped.
        line: usize,
        /// Keyword.
        keyword: String,
        /// Expected value count.
        expected: usize,
        /// Values read.
        found: usize,
        /// What came instead of `/`.
        next: String,
    },
    /// A malformed repeat (`*5`, `0*1`, `2.5*3`, or `N*` where the keyword has no default).
    #[error("{file}:{line}: {keyword}: bad repeat '{token}': {why}")]
    BadRepeat {
        /// File.
        file: PathBuf,
        /// Line.
        line: usize,
        /// Keyword.
        keyword: String,
        /// The token.
        token: String,
        /// What is wrong.
        why: &'static str,
    },
    /// A token that is not a number where a number is needed.
    #[error("{file}:{line}: {keyword}: '{token}' is not a number")]
    NotNumeric {
        /// File.
        file: PathBuf,
        /// Line.
        line: usize,
        /// Keyword.
        keyword: String,
        /// The token.
        token: String,
    },
    /// NaN or infinity.
    #[error("{file}:{line}: {keyword}: '{token}' is not finite")]
    NotFinite {
        /// File.
        file: PathBuf,
        /// Line.
        line: usize,
        /// Keyword.
        keyword: String,
        /// The token.
        token: String,
    },
    /// An ACTNUM value other than 0 or 1.
    #[error("{file}:{line}: {keyword}: value {value} at cell {index} is not 0 or 1")]
    NotActnum {
        /// File.
        file: PathBuf,
        /// Line.
        line: usize,
        /// Keyword (ACTNUM).
        keyword: String,
        /// The value.
        value: f64,
        /// Cell index (0-based, I fastest).
        index: usize,
    },
    /// A bad record (unterminated string, token too long, unsupported option...).
    #[error("{file}:{line}: {keyword}: {why}")]
    BadRecord {
        /// File.
        file: PathBuf,
        /// Line.
        line: usize,
        /// Keyword.
        keyword: String,
        /// What is wrong.
        why: String,
    },
    /// An INCLUDE file that does not exist.
    #[error("{file}:{line}: {keyword}: include file '{path}' not found (looked for {tried})")]
    MissingInclude {
        /// Including file.
        file: PathBuf,
        /// Line.
        line: usize,
        /// Always `INCLUDE`.
        keyword: String,
        /// The path as written.
        path: String,
        /// Paths tried.
        tried: String,
    },
    /// An INCLUDE that includes one of the files including it.
    #[error("{file}:{line}: {keyword}: include cycle: '{path}' is already being read ({chain})")]
    IncludeCycle {
        /// Including file.
        file: PathBuf,
        /// Line.
        line: usize,
        /// Always `INCLUDE`.
        keyword: String,
        /// The path as written.
        path: String,
        /// The chain of including files.
        chain: String,
    },
}

/// What a GRDECL read returns: the corner-point grid plus what was skipped.
#[derive(Clone, Debug)]
pub struct GrdeclDeck {
    /// The grid.
    pub grid: CornerPointGrid,
    /// Keywords skipped (each listed once, in order of first appearance).
    pub skipped: Vec<String>,
    /// Files read (the main file, then includes in order).
    pub files: Vec<PathBuf>,
    /// Bytes of text read over all files.
    pub bytes: u64,
}

// ---------------------------------------------------------------------------
// Lexer

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Slash,
    Word,
    Quoted,
    Eof,
}

#[derive(Clone, Copy, Debug)]
struct Tok {
    kind: Kind,
    start: usize,
    len: usize,
    line: usize,
    /// Starts in the first column of its line.
    col0: bool,
}

struct Lexer<'r> {
    r: Box<dyn Read + 'r>,
    buf: Vec<u8>,
    pos: usize,
    end: usize,
    eof: bool,
    line: usize,
    bol: bool,
    in_comment: bool,
    pushed: Option<Tok>,
    file: PathBuf,
    bytes: u64,
    /// The input's length when known.
    len: Option<u64>,
}

impl<'r> Lexer<'r> {
    /// Capacity to reserve for an array of `n` values before they are read:
    /// `n`, but never more values than the input could spell out plainly
    /// (two bytes each), so that a header alone (SPECGRID, DIMENS) never
    /// costs more memory than the file's size. Repeats (`N*v`) grow the
    /// array as their data arrives.
    fn reserve_hint(&self, n: usize) -> usize {
        let most = self.len.map_or(1 << 20, |l| (l / 2) as usize + 1024);
        n.min(most)
    }

    /// A lexer over `r`; `len` is the input's length when known (a file), so
    /// that a small file gets a window of its size rather than [`WINDOW`]
    /// zeroed bytes (decks include many small files).
    fn new(r: Box<dyn Read + 'r>, file: PathBuf, len: Option<u64>) -> Self {
        let size = len.map_or(WINDOW, |n| {
            usize::try_from(n.saturating_add(1))
                .unwrap_or(WINDOW)
                .clamp(2 * MAX_TOKEN, WINDOW)
        });
        Lexer {
            r,
            buf: vec![0; size],
            pos: 0,
            end: 0,
            eof: false,
            line: 1,
            bol: true,
            in_comment: false,
            pushed: None,
            file,
            bytes: 0,
            len,
        }
    }

    fn refill(&mut self) -> Result<(), GrdeclError> {
        if self.eof {
            return Ok(());
        }
        self.buf.copy_within(self.pos..self.end, 0);
        self.end -= self.pos;
        self.pos = 0;
        while self.end < self.buf.len() {
            match self.r.read(&mut self.buf[self.end..]) {
                Ok(0) => {
                    self.eof = true;
                    break;
                }
                Ok(n) => {
                    self.end += n;
                    self.bytes += n as u64;
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => {
                    return Err(GrdeclError::Io {
                        file: self.file.clone(),
                        source: e,
                    });
                }
            }
        }
        Ok(())
    }

    fn text(&self, t: &Tok) -> &[u8] {
        &self.buf[t.start..t.start + t.len]
    }

    fn text_string(&self, t: &Tok) -> String {
        match t.kind {
            Kind::Eof => "end of file".into(),
            Kind::Slash => "/".into(),
            _ => String::from_utf8_lossy(self.text(t)).into_owned(),
        }
    }

    /// The repeat count `n` of token `t` (`n*...`) in keyword `kw`.
    fn repeat(&self, t: &Tok, kw: &str, n: &[u8]) -> Result<usize, GrdeclError> {
        repeat_count(n).map_err(|why| GrdeclError::BadRepeat {
            file: self.file.clone(),
            line: t.line,
            keyword: kw.into(),
            token: self.text_string(t),
            why,
        })
    }

    fn push_back(&mut self, t: Tok) {
        self.pushed = Some(t);
    }

    fn peek(&mut self) -> Result<Tok, GrdeclError> {
        let t = self.next()?;
        self.pushed = Some(t);
        Ok(t)
    }

    fn bad(&self, line: usize, keyword: &str, why: impl Into<String>) -> GrdeclError {
        GrdeclError::BadRecord {
            file: self.file.clone(),
            line,
            keyword: keyword.into(),
            why: why.into(),
        }
    }

    /// Plain numbers and `N*v` repeats straight from the window into
    /// `sink`, until anything else (a default `N*`, a comment, `/`, a word,
    /// the window's margin): then the general path takes over. Same results as `next` + `parse_number`.
    #[inline]
    fn fast_values(&mut self, sink: &mut Sink) {
        if self.pushed.is_some() || self.in_comment {
            return;
        }
        let end = self.end;
        let limit = if self.eof {
            end
        } else {
            end.saturating_sub(MAX_TOKEN)
        };
        let b = &self.buf[..end];
        let mut p = self.pos;
        let mut line = self.line;
        let mut bol = self.bol;
        while p < limit {
            let c = b[p];
            if c <= b' ' {
                if c == b'\n' {
                    line += 1;
                    bol = true;
                } else {
                    bol = false;
                }
                p += 1;
                continue;
            }
            let Some((mut v, len)) = parse_prefix(&b[p..]) else {
                break;
            };
            let mut q = p + len;
            let mut count = 1;
            if q < end && b[q] == b'*' {
                // `N*v` with N a plain positive integer (as `repeat_count`
                // takes it) and v a plain number; anything else (`N*`,
                // errors) is left to the general path.
                let n = &b[p..q];
                if n.len() > 12 || !n.iter().all(u8::is_ascii_digit) {
                    break;
                }
                count = n.iter().fold(0usize, |a, &c| a * 10 + (c - b'0') as usize);
                let Some((w, l)) = parse_prefix(&b[q + 1..]) else {
                    break;
                };
                if count == 0 {
                    break;
                }
                v = w;
                q += 1 + l;
            }
            if q < end && b[q] > b' ' && b[q] != b'/' {
                break;
            }
            sink.push(v, count);
            bol = false;
            p = q;
        }
        self.pos = p;
        self.line = line;
        self.bol = bol;
    }

    /// The next token. Tokens stay valid until the next call to `next`.
    fn next(&mut self) -> Result<Tok, GrdeclError> {
        if let Some(t) = self.pushed.take() {
            return Ok(t);
        }
        loop {
            if self.end - self.pos < MAX_TOKEN && !self.eof {
                self.refill()?;
            }
            let end = self.end;
            let b = &self.buf[..end];
            let mut p = self.pos;
            if self.in_comment {
                while p < end && b[p] != b'\n' {
                    p += 1;
                }
                self.pos = p;
                if p == end {
                    if self.eof {
                        self.in_comment = false;
                        continue;
                    }
                    continue;
                }
                self.in_comment = false;
            }
            while p < end {
                let c = b[p];
                if c == b'\n' {
                    self.line += 1;
                    self.bol = true;
                } else if c <= b' ' {
                    self.bol = false;
                } else {
                    break;
                }
                p += 1;
            }
            self.pos = p;
            if p == end {
                if self.eof {
                    return Ok(Tok {
                        kind: Kind::Eof,
                        start: p,
                        len: 0,
                        line: self.line,
                        col0: self.bol,
                    });
                }
                continue;
            }
            let c = b[p];
            if c == b'-' && p + 1 < end && b[p + 1] == b'-' {
                self.in_comment = true;
                self.bol = false;
                continue;
            }
            let col0 = self.bol;
            self.bol = false;
            let line = self.line;
            if c == b'/' {
                self.pos = p + 1;
                return Ok(Tok {
                    kind: Kind::Slash,
                    start: p,
                    len: 1,
                    line,
                    col0,
                });
            }
            if c == b'\'' || c == b'"' {
                let Some(q) = b[p + 1..].iter().position(|&x| x == c || x == b'\n') else {
                    return Err(self.bad(line, "", "unterminated quoted string"));
                };
                if b[p + 1 + q] != c {
                    return Err(self.bad(line, "", "unterminated quoted string"));
                }
                self.pos = p + 2 + q;
                return Ok(Tok {
                    kind: Kind::Quoted,
                    start: p + 1,
                    len: q,
                    line,
                    col0,
                });
            }
            let mut q = p;
            while q < end {
                let x = b[q];
                if x <= b' ' || x == b'/' {
                    break;
                }
                q += 1;
            }
            if q == end && !self.eof {
                return Err(self.bad(line, "", format!("token longer than {MAX_TOKEN} bytes")));
            }
            self.pos = q;
            return Ok(Tok {
                kind: Kind::Word,
                start: p,
                len: q - p,
                line,
                col0,
            });
        }
    }
}

// ---------------------------------------------------------------------------
// Numbers

const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Parses a decimal number (`1`, `-2.5`, `.5`, `3.`, `1e-3`, Fortran `1.0D+03`).
/// Returns `None` for anything else; NaN and infinities come back as such
/// (`nan`, `inf`), for the caller to reject.
pub fn parse_number(t: &[u8]) -> Option<f64> {
    match parse_prefix(t) {
        Some((v, n)) if n == t.len() => Some(v),
        Some(_) => None,
        // Not on the fast path (nan, inf, junk, too many digits, a large
        // exponent): the standard library decides on the whole token.
        None => parse_slow(t),
    }
}

/// The fast path: a number at the start of `t` with at most 19 significant
/// digits and a decimal exponent within ±22 (exact by Clinger's rule), and
/// the bytes it used. `None` when the fast path does not apply.
///
/// The digits are accumulated without per-digit checks (wrapping: a number
/// of more than 19 significant digits is rejected afterwards, so its
/// mantissa is never used); significant digits are the digits after the
/// leading zeros of the integer part and, when that part is all zeros, of
/// the fraction.
#[inline(always)]
fn parse_prefix(t: &[u8]) -> Option<(f64, usize)> {
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
    if i < n && matches!(t[i], b'e' | b'E' | b'd' | b'D') {
        let (e, j) = exponent(t, i + 1)?;
        exp = exp.saturating_add(e);
        i = j;
    }
    if total - lz > 19 {
        return None;
    }
    Some((exact_value(mant, exp, neg)?, i))
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

/// The exponent after `e`/`E`/`d`/`D` of a number, from `t[i]` on: its
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

fn parse_slow(t: &[u8]) -> Option<f64> {
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

// ---------------------------------------------------------------------------
// Keyword tables

const SECTIONS_AFTER_GRID: [&str; 7] = [
    "EDIT", "PROPS", "REGIONS", "SOLUTION", "SUMMARY", "SCHEDULE", "END",
];

/// Keywords that take no data.
const NO_DATA: [&str; 39] = [
    "RUNSPEC", "GRID", "ECHO", "NOECHO", "OIL", "GAS", "WATER", "DISGAS", "VAPOIL", "METRIC",
    "FIELD", "LAB", "PVT-M", "UNIFIN", "UNIFOUT", "NOINSPEC", "NORSSPEC", "INIT", "NOSIM", "NONNC",
    "FMTIN", "FMTOUT", "NEWTRAN", "OLDTRAN", "NOWARN", "WARN", "MULTOUT", "MULTIN", "IMPES",
    "FULLIMP", "DUALPORO", "DUALPERM", "BRINE", "THERMAL", "NOGGF", "NOMIX", "SKIPREST", "SKIP",
    "ENDSKIP",
];

/// Keywords of exactly one record whose data may start with a word in column 0.
const SINGLE_RECORD: [&str; 18] = [
    "GDORIENT", "PINCH", "GRIDOPTS", "MESSAGES", "GRIDFILE", "TABDIMS", "EQLDIMS", "WELLDIMS",
    "REGDIMS", "START", "EQLOPTS", "FAULTDIM", "VFPPDIMS", "VFPIDIMS", "SMRYDIMS", "MINPV",
    "NSTACK", "ROCKCOMP",
];

/// Keywords made of several records closed by an empty record.
const MULTI_RECORD: [&str; 12] = [
    "MINVALUE", "MAXVALUE", "OPERATE", "MULTIREG", "COPYREG", "ADDREG", "EQUALREG", "FAULTS",
    "MULTFLT", "EDITNNC", "NNC", "THPRES",
];

/// Array operators applied to cell arrays (records up to an empty record).
const OPERATORS: [&str; 4] = ["EQUALS", "MULTIPLY", "ADD", "COPY"];

/// Per-cell properties whose length is checked (others are recognised by length).
const KNOWN_PROPERTIES: [&str; 26] = [
    "PORO", "PERMX", "PERMY", "PERMZ", "NTG", "FIPNUM", "SATNUM", "EQLNUM", "PVTNUM", "ROCKNUM",
    "IMBNUM", "MULTPV", "MULTX", "MULTY", "MULTZ", "MULTX-", "MULTY-", "MULTZ-", "SWATINIT", "SWL",
    "SWCR", "SWU", "SGU", "SOWCR", "PORV", "PERMXY",
];

fn is_keyword_like(t: &[u8]) -> bool {
    !t.is_empty()
        && t.len() <= 8
        && t[0].is_ascii_alphabetic()
        && t.iter()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, b'_' | b'-' | b'+'))
}

// ---------------------------------------------------------------------------
// Parser

/// A numeric sink with an expected count.
struct Sink<'a> {
    out: &'a mut Vec<f64>,
    expected: usize,
    found: usize,
}

impl Sink<'_> {
    #[inline(always)]
    fn push(&mut self, v: f64, n: usize) {
        let room = self.expected.saturating_sub(self.found);
        let k = n.min(room);
        if k == 1 {
            self.out.push(v);
        } else if k > 0 {
            self.out.resize(self.out.len() + k, v);
        }
        self.found = self.found.saturating_add(n);
    }
}

struct Parser {
    dims: Option<[usize; 3]>,
    coord: Option<Vec<f64>>,
    zcorn: Option<Vec<f64>>,
    actnum: Option<Vec<u8>>,
    mapaxes: Option<[f64; 6]>,
    mapunits: Option<String>,
    gridunit: Option<String>,
    properties: Vec<Property>,
    skipped: Vec<String>,
    skipped_set: HashSet<String>,
    files: Vec<PathBuf>,
    stack: Vec<PathBuf>,
    bytes: u64,
    /// A GRID section keyword was seen (deck mode).
    in_grid: bool,
    done: bool,
    /// The input box set by BOX (1-based inclusive `i1 i2 j1 j2 k1 k2`).
    input_box: Option<[usize; 6]>,
}

enum Flow {
    Go,
    Stop,
}

impl Parser {
    fn new() -> Self {
        Parser {
            dims: None,
            coord: None,
            zcorn: None,
            actnum: None,
            mapaxes: None,
            mapunits: None,
            gridunit: None,
            properties: Vec::new(),
            skipped: Vec::new(),
            skipped_set: HashSet::new(),
            files: Vec::new(),
            stack: Vec::new(),
            bytes: 0,
            in_grid: false,
            done: false,
            input_box: None,
        }
    }

    fn skip_note(&mut self, kw: &str) {
        if self.skipped_set.insert(kw.to_string()) {
            self.skipped.push(kw.to_string());
        }
    }

    fn cells(&self, lx: &Lexer, line: usize, kw: &str) -> Result<usize, GrdeclError> {
        match self.dims {
            Some(d) => Ok(d[0] * d[1] * d[2]),
            None => Err(GrdeclError::MissingSpecgrid {
                file: lx.file.clone(),
                line,
                keyword: kw.into(),
            }),
        }
    }

    fn parse(&mut self, lx: &mut Lexer) -> Result<(), GrdeclError> {
        while !self.done {
            let t = lx.next()?;
            match t.kind {
                Kind::Eof => break,
                Kind::Slash | Kind::Quoted => continue,
                Kind::Word => {}
            }
            let raw = lx.text(&t);
            if !is_keyword_like(raw) {
                let s = format!(
                    "stray '{}'",
                    String::from_utf8_lossy(&raw[..raw.len().min(40)])
                );
                self.skip_note(&s);
                continue;
            }
            let kw: String = String::from_utf8_lossy(&raw[..raw.len().min(8)]).to_ascii_uppercase();
            if let Flow::Stop = self.keyword(lx, &kw, t.line)? {
                self.done = true;
            }
        }
        self.bytes += lx.bytes;
        Ok(())
    }

    fn keyword(&mut self, lx: &mut Lexer, kw: &str, line: usize) -> Result<Flow, GrdeclError> {
        match kw {
            "SPECGRID" | "DIMENS" => {
                let v = read_small(lx, kw, line, 3, if kw == "SPECGRID" { 5 } else { 3 })?;
                let mut d = [0usize; 3];
                for a in 0..3 {
                    let x =
                        v[a].ok_or_else(|| lx.bad(line, kw, "the dimensions have no default"))?;
                    if x.fract() != 0.0 || !(1.0..=1e9).contains(&x) {
                        return Err(lx.bad(
                            line,
                            kw,
                            format!("dimension {x} is not a positive integer"),
                        ));
                    }
                    d[a] = x as usize;
                }
                if d.iter().map(|&x| x as u128).product::<u128>() * 8 >= u32::MAX as u128 {
                    return Err(lx.bad(line, kw, format!("grid {d:?} is too large")));
                }
                if kw == "SPECGRID"
                    && let Some(Some(c)) = v.get(4)
                    && *c != 0.0
                {
                    return Err(lx.bad(line, kw, "radial (cylindrical) grids are not supported"));
                }
                if let Some(old) = self.dims
                    && old != d
                {
                    return Err(lx.bad(
                        line,
                        kw,
                        format!("grid size {d:?} differs from the earlier {old:?}"),
                    ));
                }
                self.dims = Some(d);
            }
            "COORD" => {
                let [nx, ny, _] = self.dims_or(lx, line, kw)?;
                let n = 6 * (nx + 1) * (ny + 1);
                let mut v = Vec::with_capacity(lx.reserve_hint(n));
                read_values(lx, kw, line, n, &mut v, None)?;
                self.coord = Some(v);
            }
            "ZCORN" => {
                let n = 8 * self.cells(lx, line, kw)?;
                let mut v = Vec::with_capacity(lx.reserve_hint(n));
                read_values(lx, kw, line, n, &mut v, None)?;
                self.zcorn = Some(v);
            }
            "ACTNUM" => {
                let n = self.cells(lx, line, kw)?;
                let mut v = Vec::with_capacity(lx.reserve_hint(n));
                read_values(lx, kw, line, n, &mut v, Some(1.0))?;
                let mut a = Vec::with_capacity(n);
                for (i, &x) in v.iter().enumerate() {
                    if x != 0.0 && x != 1.0 {
                        return Err(GrdeclError::NotActnum {
                            file: lx.file.clone(),
                            line,
                            keyword: kw.into(),
                            value: x,
                            index: i,
                        });
                    }
                    a.push(x as u8);
                }
                self.actnum = Some(a);
            }
            "MAPAXES" => {
                let mut v = Vec::with_capacity(6);
                read_values(lx, kw, line, 6, &mut v, None)?;
                self.mapaxes = Some([v[0], v[1], v[2], v[3], v[4], v[5]]);
            }
            "MAPUNITS" | "GRIDUNIT" => {
                let s = read_strings(lx, kw, line)?;
                let s = s.first().cloned().unwrap_or_default().trim().to_string();
                if kw == "MAPUNITS" {
                    self.mapunits = Some(s);
                } else {
                    self.gridunit = Some(s);
                }
            }
            "INCLUDE" => {
                let s = read_strings(lx, kw, line)?;
                let Some(p) = s.first() else {
                    return Err(lx.bad(line, kw, "no file name"));
                };
                self.include(lx, line, p)?;
            }
            "TITLE" => {
                // The title is the next line, without '/'.
                let t = lx.next()?;
                let l = t.line;
                loop {
                    let u = lx.next()?;
                    if u.kind == Kind::Eof || u.line != l {
                        lx.push_back(u);
                        break;
                    }
                }
            }
            _ if OPERATORS.contains(&kw) => self.operator(lx, kw, line)?,
            "BOX" => {
                let dims = self.dims_or(lx, line, kw)?;
                let v = read_small(lx, kw, line, 6, 6)?;
                let items: Vec<Option<String>> =
                    v.iter().map(|x| x.map(|x| x.to_string())).collect();
                self.input_box = Some(op_box(lx, kw, line, dims, &items, None)?);
            }
            "ENDBOX" => self.input_box = None,
            _ if kw == "GRID" => self.in_grid = true,
            _ if SECTIONS_AFTER_GRID.contains(&kw) => {
                if self.in_grid || kw == "END" {
                    return Ok(Flow::Stop);
                }
            }
            _ if NO_DATA.contains(&kw) => {}
            _ if SINGLE_RECORD.contains(&kw) => {
                self.skip_note(kw);
                loop {
                    let t = lx.next()?;
                    if matches!(t.kind, Kind::Eof | Kind::Slash) {
                        break;
                    }
                }
            }
            _ if MULTI_RECORD.contains(&kw) => {
                self.skip_note(kw);
                loop {
                    let t = lx.next()?;
                    match t.kind {
                        Kind::Eof => break,
                        Kind::Slash => break,
                        // A record runs to its '/', whatever column its words start in.
                        _ => loop {
                            let u = lx.next()?;
                            if matches!(u.kind, Kind::Eof | Kind::Slash) {
                                break;
                            }
                        },
                    }
                }
            }
            _ if KNOWN_PROPERTIES.contains(&kw) => {
                let n = self.cells(lx, line, kw)?;
                let mut v = Vec::with_capacity(lx.reserve_hint(n));
                read_values(lx, kw, line, n, &mut v, None)?;
                self.set_property(kw, v);
            }
            _ => self.unknown(lx, kw)?,
        }
        Ok(Flow::Go)
    }

    /// EQUALS, MULTIPLY, ADD (`array value [box]`) and COPY (`source
    /// target [box]`): records up to an empty record, applied in order to
    /// the cell arrays read so far. Defaulted box items take the previous
    /// record's (the first record's: the BOX, else the whole grid). An
    /// array that EQUALS or COPY creates over part of the grid only must
    /// have a default (1 for the MULT* arrays and NTG). ACTNUM takes EQUALS
    /// and COPY of 0/1 values.
    fn operator(&mut self, lx: &mut Lexer, kw: &str, line: usize) -> Result<(), GrdeclError> {
        let dims = self.dims_or(lx, line, kw)?;
        let [nx, ny, nz] = dims;
        let n = nx * ny * nz;
        let mut last = self.input_box.unwrap_or([1, nx, 1, ny, 1, nz]);
        while let Some((items, rline)) = read_record(lx, kw, line)? {
            let bad = |why: String| lx.bad(rline, kw, why);
            if items.len() < 2 || items.len() > 8 || items[..2].iter().any(|x| x.is_none()) {
                return Err(bad(format!(
                    "a record needs {} then at most 6 box indices; found {} item(s)",
                    if kw == "COPY" {
                        "a source and a target array"
                    } else {
                        "an array and a value"
                    },
                    items.len()
                )));
            }
            let name = items[0]
                .as_deref()
                .unwrap_or_default()
                .trim()
                .to_ascii_uppercase();
            let arg = items[1].as_deref().unwrap_or_default().trim().to_string();
            let bx = op_box(lx, kw, rline, dims, &items[2..], Some(last))?;
            last = bx;
            // The box's cells, I fastest (iterated, never collected).
            let cells = || {
                (bx[4] - 1..bx[5]).flat_map(move |k| {
                    (bx[2] - 1..bx[3])
                        .flat_map(move |j| (bx[0] - 1..bx[1]).map(move |i| i + nx * (j + ny * k)))
                })
            };
            let whole = (bx[1] - bx[0] + 1) * (bx[3] - bx[2] + 1) * (bx[5] - bx[4] + 1) == n;
            let target_name = if kw == "COPY" {
                arg.to_ascii_uppercase()
            } else {
                name.clone()
            };
            let missing = |t: &str| {
                if t == "ACTNUM" {
                    self.actnum.is_none()
                } else {
                    !self.properties.iter().any(|p| p.name == t)
                }
            };
            let creates =
                missing(&target_name) || (kw == "COPY" && name == "ACTNUM" && missing(&name));
            if creates && self.zcorn.is_none() && n > MAX_CELLS_BEFORE_GEOMETRY {
                return Err(bad(format!(
                    "{kw} would create an array of {n} cells before COORD and ZCORN were read \
                     (more than {MAX_CELLS_BEFORE_GEOMETRY} cells are allowed only once the geometry has arrived): \
                     is COORD or ZCORN missing, or does the grid size {dims:?} hold a typo?"
                )));
            }
            let (target, value) = if kw == "COPY" {
                let src = name.clone();
                let v: Vec<f64> = if src == "ACTNUM" {
                    match &self.actnum {
                        Some(a) => a.iter().map(|&x| x as f64).collect(),
                        None => vec![1.0; n],
                    }
                } else {
                    match self.properties.iter().find(|p| p.name == src) {
                        Some(p) => p.values.clone(),
                        None => return Err(bad(format!("COPY from {src}, which is not defined"))),
                    }
                };
                (arg.to_ascii_uppercase(), Err(v))
            } else {
                let x = parse_number(arg.as_bytes())
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| bad(format!("'{arg}' is not a finite number")))?;
                (name.clone(), Ok(x))
            };
            if matches!(target.as_str(), "COORD" | "ZCORN" | "MAPAXES") {
                return Err(bad(format!("{kw} cannot change {target}")));
            }
            if target == "ACTNUM" {
                if kw == "MULTIPLY" || kw == "ADD" {
                    return Err(bad(format!("{kw} cannot change ACTNUM (0/1 flags)")));
                }
                let a = self.actnum.get_or_insert_with(|| vec![1; n]);
                for c in cells() {
                    let x = match &value {
                        Ok(x) => *x,
                        Err(v) => v[c],
                    };
                    if x != 0.0 && x != 1.0 {
                        return Err(GrdeclError::NotActnum {
                            file: lx.file.clone(),
                            line: rline,
                            keyword: format!("{kw} ACTNUM"),
                            value: x,
                            index: c,
                        });
                    }
                    a[c] = x as u8;
                }
                continue;
            }
            let exists = self.properties.iter().any(|p| p.name == target);
            if !exists {
                if kw == "MULTIPLY" || kw == "ADD" {
                    return Err(bad(format!("{kw} on {target}, which is not defined")));
                }
                let default = if target.starts_with("MULT") || target == "NTG" {
                    1.0
                } else if whole {
                    0.0
                } else {
                    return Err(bad(format!(
                        "{kw} defines {target} in part of the grid only, and {target} has no default value"
                    )));
                };
                self.set_property(&target, vec![default; n]);
            }
            let p = self
                .properties
                .iter_mut()
                .find(|p| p.name == target)
                .expect("defined above");
            for c in cells() {
                let v = &mut p.values[c];
                match (kw, &value) {
                    ("EQUALS", Ok(x)) => *v = *x,
                    ("MULTIPLY", Ok(x)) => *v *= *x,
                    ("ADD", Ok(x)) => *v += *x,
                    (_, Err(src)) => *v = src[c],
                    _ => unreachable!("value kinds match the keyword"),
                }
            }
        }
        Ok(())
    }

    fn dims_or(&self, lx: &Lexer, line: usize, kw: &str) -> Result<[usize; 3], GrdeclError> {
        self.dims.ok_or_else(|| GrdeclError::MissingSpecgrid {
            file: lx.file.clone(),
            line,
            keyword: kw.into(),
        })
    }

    fn set_property(&mut self, kw: &str, v: Vec<f64>) {
        self.properties.retain(|p| p.name != kw);
        self.properties.push(Property::scalar(kw, v));
    }

    /// An unknown keyword: no data if a keyword follows in column 0;
    /// otherwise records until a keyword in column 0, an empty record or
    /// the end. A single all-numeric record of `nx·ny·nz` values is taken
    /// as a property.
    fn unknown(&mut self, lx: &mut Lexer, kw: &str) -> Result<(), GrdeclError> {
        let n = self.dims.map(|d| d[0] * d[1] * d[2]);
        let mut nums: Vec<f64> = Vec::new();
        let mut numeric = n.is_some();
        let mut records = 0usize;
        loop {
            let t = lx.next()?;
            match t.kind {
                Kind::Eof => break,
                Kind::Slash => {
                    records += 1;
                    // Another record follows unless a keyword, '/' or EOF is next.
                    let u = lx.peek()?;
                    match u.kind {
                        Kind::Eof => break,
                        Kind::Slash => {
                            lx.next()?;
                            break;
                        }
                        Kind::Word if u.col0 && is_keyword_like(lx.text(&u)) => break,
                        _ => numeric = false,
                    }
                }
                Kind::Word if t.col0 && is_keyword_like(lx.text(&t)) => {
                    lx.push_back(t);
                    break;
                }
                Kind::Word if numeric => {
                    let s = lx.text(&t);
                    match value_token(s) {
                        Some((r, Some(v))) if v.is_finite() && nums.len() + r <= n.unwrap_or(0) => {
                            nums.resize(nums.len() + r, v);
                        }
                        _ => {
                            numeric = false;
                            nums = Vec::new();
                        }
                    }
                }
                _ => {
                    numeric = false;
                    nums = Vec::new();
                }
            }
        }
        if numeric && records == 1 && Some(nums.len()) == n {
            self.set_property(kw, nums);
        } else {
            self.skip_note(kw);
        }
        Ok(())
    }

    fn include(&mut self, lx: &Lexer, line: usize, p: &str) -> Result<(), GrdeclError> {
        let base = lx.file.parent().unwrap_or(Path::new(""));
        let direct = base.join(p);
        let mut tried = vec![direct.clone()];
        if direct.is_dir() {
            return Err(lx.bad(
                line,
                "INCLUDE",
                format!(
                    "'{p}' is a directory ({}), not a file: INCLUDE takes a file name",
                    direct.display()
                ),
            ));
        }
        let path = if direct.is_file() {
            direct
        } else {
            let by_name = Path::new(p).file_name().map(|f| base.join(f));
            match by_name {
                Some(b) if b.is_file() => b,
                Some(b) => {
                    if b != direct {
                        tried.push(b);
                    }
                    return Err(self.missing(lx, line, p, &tried));
                }
                None => return Err(self.missing(lx, line, p, &tried)),
            }
        };
        let canon = path.canonicalize().unwrap_or_else(|_| path.clone());
        if self.stack.contains(&canon) {
            return Err(GrdeclError::IncludeCycle {
                file: lx.file.clone(),
                line,
                keyword: "INCLUDE".into(),
                path: p.into(),
                chain: self
                    .stack
                    .iter()
                    .map(|x| x.display().to_string())
                    .collect::<Vec<_>>()
                    .join(" -> "),
            });
        }
        if self.stack.len() >= MAX_INCLUDE_DEPTH {
            return Err(lx.bad(line, "INCLUDE", "includes nested too deep"));
        }
        let f = File::open(&path).map_err(|e| GrdeclError::Io {
            file: path.clone(),
            source: e,
        })?;
        self.files.push(path.clone());
        self.stack.push(canon);
        let len = f.metadata().ok().map(|m| m.len());
        let mut sub = Lexer::new(Box::new(f), path, len);
        let r = self.parse(&mut sub);
        self.stack.pop();
        r
    }

    fn missing(&self, lx: &Lexer, line: usize, p: &str, tried: &[PathBuf]) -> GrdeclError {
        GrdeclError::MissingInclude {
            file: lx.file.clone(),
            line,
            keyword: "INCLUDE".into(),
            path: p.into(),
            tried: tried
                .iter()
                .map(|x| x.display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
        }
    }

    fn finish(self, file: &Path) -> Result<GrdeclDeck, GrdeclError> {
        let Some(dims) = self.dims else {
            return Err(GrdeclError::NoSpecgrid {
                file: file.into(),
                keyword: "SPECGRID".into(),
            });
        };
        let missing = |k: &str| GrdeclError::MissingKeyword {
            file: file.into(),
            keyword: k.into(),
        };
        let coord = self.coord.ok_or_else(|| missing("COORD"))?;
        let zcorn = self.zcorn.ok_or_else(|| missing("ZCORN"))?;
        Ok(GrdeclDeck {
            grid: CornerPointGrid {
                dims,
                coord,
                zcorn,
                actnum: self.actnum,
                mapaxes: self.mapaxes,
                mapunits: self.mapunits,
                gridunit: self.gridunit,
                properties: self.properties,
            },
            skipped: self.skipped,
            files: self.files,
            bytes: self.bytes,
        })
    }
}

/// Splits a value token into `(repeat, value)`; value `None` = default.
/// Returns `None` when the token is malformed (the caller reports why).
fn value_token(s: &[u8]) -> Option<(usize, Option<f64>)> {
    match s.iter().position(|&c| c == b'*') {
        None => parse_number(s).map(|v| (1, Some(v))),
        Some(k) => {
            let r = repeat_count(&s[..k]).ok()?;
            if k + 1 == s.len() {
                Some((r, None))
            } else {
                parse_number(&s[k + 1..]).map(|v| (r, Some(v)))
            }
        }
    }
}

fn repeat_count(s: &[u8]) -> Result<usize, &'static str> {
    if s.is_empty() {
        return Err("the repeat count is missing");
    }
    if !s.iter().all(|c| c.is_ascii_digit()) {
        return Err("the repeat count is not a positive integer");
    }
    if s.len() > 12 {
        return Err("the repeat count is too large");
    }
    let r = s.iter().fold(0usize, |a, &c| a * 10 + (c - b'0') as usize);
    if r == 0 {
        return Err("the repeat count is zero");
    }
    Ok(r)
}

/// Reads a numeric record of exactly `expected` values into `out`.
fn read_values(
    lx: &mut Lexer,
    kw: &str,
    kw_line: usize,
    expected: usize,
    out: &mut Vec<f64>,
    default: Option<f64>,
) -> Result<(), GrdeclError> {
    let mut sink = Sink {
        out,
        expected,
        found: 0,
    };
    loop {
        lx.fast_values(&mut sink);
        let t = lx.next()?;
        match t.kind {
            Kind::Slash => break,
            Kind::Eof => {
                return Err(GrdeclError::Truncated {
                    file: lx.file.clone(),
                    line: t.line,
                    keyword: kw.into(),
                    expected,
                    found: sink.found,
                    next: "end of file".into(),
                });
            }
            Kind::Quoted => {
                return Err(GrdeclError::NotNumeric {
                    file: lx.file.clone(),
                    line: t.line,
                    keyword: kw.into(),
                    token: lx.text_string(&t),
                });
            }
            Kind::Word => {}
        }
        let s = lx.text(&t);
        // Fast path: a plain number.
        if let Some(v) = parse_number(s) {
            if !v.is_finite() {
                return Err(not_finite(lx, &t, kw));
            }
            sink.push(v, 1);
            continue;
        }
        let Some(k) = s.iter().position(|&c| c == b'*') else {
            if t.col0 && is_keyword_like(s) {
                return Err(GrdeclError::Truncated {
                    file: lx.file.clone(),
                    line: t.line,
                    keyword: kw.into(),
                    expected,
                    found: sink.found,
                    next: format!("keyword {}", lx.text_string(&t)),
                });
            }
            return Err(GrdeclError::NotNumeric {
                file: lx.file.clone(),
                line: t.line,
                keyword: kw.into(),
                token: lx.text_string(&t),
            });
        };
        let r = lx.repeat(&t, kw, &s[..k])?;
        let v = if k + 1 == s.len() {
            match default {
                Some(d) => d,
                None => {
                    return Err(GrdeclError::BadRepeat {
                        file: lx.file.clone(),
                        line: t.line,
                        keyword: kw.into(),
                        token: lx.text_string(&t),
                        why: "this keyword has no default value",
                    });
                }
            }
        } else {
            match parse_number(&s[k + 1..]) {
                Some(v) if v.is_finite() => v,
                Some(_) => return Err(not_finite(lx, &t, kw)),
                None => {
                    return Err(GrdeclError::NotNumeric {
                        file: lx.file.clone(),
                        line: t.line,
                        keyword: kw.into(),
                        token: lx.text_string(&t),
                    });
                }
            }
        };
        sink.push(v, r);
    }
    if sink.found != expected {
        return Err(GrdeclError::CountMismatch {
            file: lx.file.clone(),
            line: kw_line,
            keyword: kw.into(),
            expected,
            found: sink.found,
        });
    }
    Ok(())
}

fn not_finite(lx: &Lexer, t: &Tok, kw: &str) -> GrdeclError {
    GrdeclError::NotFinite {
        file: lx.file.clone(),
        line: t.line,
        keyword: kw.into(),
        token: lx.text_string(t),
    }
}

/// Reads a short record of at least `min` and at most `max` items, where
/// `N*` defaults give `None`.
fn read_small(
    lx: &mut Lexer,
    kw: &str,
    line: usize,
    min: usize,
    max: usize,
) -> Result<Vec<Option<f64>>, GrdeclError> {
    let mut v: Vec<Option<f64>> = Vec::new();
    loop {
        let t = lx.next()?;
        match t.kind {
            Kind::Slash => break,
            Kind::Eof => {
                return Err(GrdeclError::Truncated {
                    file: lx.file.clone(),
                    line: t.line,
                    keyword: kw.into(),
                    expected: min,
                    found: v.len(),
                    next: "end of file".into(),
                });
            }
            Kind::Quoted => v.push(None),
            Kind::Word => {
                let s = lx.text(&t);
                if v.len() >= min {
                    // Optional trailing items: SPECGRID's COORDTYPE is 'F' or 'T'.
                    match s {
                        b"F" | b"f" => {
                            v.push(Some(0.0));
                            continue;
                        }
                        b"T" | b"t" => {
                            v.push(Some(1.0));
                            continue;
                        }
                        _ => {}
                    }
                }
                match s.iter().position(|&c| c == b'*') {
                    Some(k) => {
                        let r = lx.repeat(&t, kw, &s[..k])?;
                        let val = if k + 1 == s.len() {
                            None
                        } else {
                            Some(parse_number(&s[k + 1..]).ok_or_else(|| {
                                GrdeclError::NotNumeric {
                                    file: lx.file.clone(),
                                    line: t.line,
                                    keyword: kw.into(),
                                    token: lx.text_string(&t),
                                }
                            })?)
                        };
                        if v.len() + r > max {
                            return Err(count_err(lx, kw, line, max, v.len() + r));
                        }
                        v.resize(v.len() + r, val);
                    }
                    None => {
                        let x = parse_number(s).ok_or_else(|| GrdeclError::NotNumeric {
                            file: lx.file.clone(),
                            line: t.line,
                            keyword: kw.into(),
                            token: lx.text_string(&t),
                        })?;
                        if !x.is_finite() {
                            return Err(not_finite(lx, &t, kw));
                        }
                        v.push(Some(x));
                    }
                }
                if v.len() > max {
                    return Err(count_err(lx, kw, line, max, v.len()));
                }
            }
        }
    }
    if v.len() < min {
        return Err(count_err(lx, kw, line, min, v.len()));
    }
    Ok(v)
}

/// One record of an operator keyword up to its `/` (`N*` expanded to `N`
/// defaulted items), and the record's line; the rest of the `/`'s line is
/// a comment. `None` for the empty record that ends the keyword.
#[allow(clippy::type_complexity)]
fn read_record(
    lx: &mut Lexer,
    kw: &str,
    line: usize,
) -> Result<Option<(Vec<Option<String>>, usize)>, GrdeclError> {
    let mut items = Vec::new();
    let mut first = None;
    loop {
        let t = lx.next()?;
        match t.kind {
            Kind::Eof => {
                return Err(GrdeclError::Truncated {
                    file: lx.file.clone(),
                    line: first.unwrap_or(line),
                    keyword: kw.into(),
                    expected: 1,
                    found: items.len(),
                    next: "end of file before the closing '/'".into(),
                });
            }
            Kind::Slash => {
                let Some(l) = first else { return Ok(None) };
                loop {
                    let u = lx.next()?;
                    if u.kind == Kind::Eof || u.line != t.line {
                        lx.push_back(u);
                        break;
                    }
                }
                return Ok(Some((items, l)));
            }
            _ => {
                first.get_or_insert(t.line);
                let s = lx.text(&t);
                match s.iter().position(|&c| c == b'*') {
                    Some(k) if t.kind == Kind::Word => {
                        let r = lx.repeat(&t, kw, &s[..k])?;
                        if r > 8 {
                            return Err(lx.bad(t.line, kw, "a record has at most 8 items"));
                        }
                        let v = (k + 1 < s.len())
                            .then(|| String::from_utf8_lossy(&s[k + 1..]).into_owned());
                        items.extend(std::iter::repeat_n(v, r));
                    }
                    _ => items.push(Some(lx.text_string(&t))),
                }
            }
        }
    }
}

/// A box `[i1, i2, j1, j2, k1, k2]` (1-based, inclusive) from up to six
/// items; missing or defaulted items take `prev`'s (none: the whole grid).
fn op_box(
    lx: &Lexer,
    kw: &str,
    line: usize,
    dims: [usize; 3],
    items: &[Option<String>],
    prev: Option<[usize; 6]>,
) -> Result<[usize; 6], GrdeclError> {
    let full = [1, dims[0], 1, dims[1], 1, dims[2]];
    let prev = prev.unwrap_or(full);
    let mut b = prev;
    for (a, item) in items.iter().enumerate() {
        if let Some(s) = item {
            let x = parse_number(s.trim().as_bytes())
                .filter(|x| x.fract() == 0.0 && *x >= 1.0)
                .ok_or_else(|| {
                    lx.bad(
                        line,
                        kw,
                        format!("box index '{s}' is not a positive integer"),
                    )
                })?;
            let dim = full[2 * (a / 2) + 1];
            if x > dim as f64 {
                let axis = ["I", "J", "K"][a / 2];
                return Err(lx.bad(
                    line,
                    kw,
                    format!(
                        "box index {s} is out of range: {axis} runs from 1 to {dim} in this grid"
                    ),
                ));
            }
            b[a] = x as usize;
        }
    }
    for (a, axis) in ["I", "J", "K"].iter().enumerate() {
        let (lo, hi) = (b[2 * a], b[2 * a + 1]);
        if lo > hi || hi > full[2 * a + 1] {
            return Err(lx.bad(
                line,
                kw,
                format!("box {axis} {lo}..{hi} is not within 1..{}", full[2 * a + 1]),
            ));
        }
    }
    Ok(b)
}

fn count_err(lx: &Lexer, kw: &str, line: usize, expected: usize, found: usize) -> GrdeclError {
    GrdeclError::CountMismatch {
        file: lx.file.clone(),
        line,
        keyword: kw.into(),
        expected,
        found,
    }
}

/// Reads a record of strings (quoted or not) up to `/`.
fn read_strings(lx: &mut Lexer, kw: &str, line: usize) -> Result<Vec<String>, GrdeclError> {
    let mut v = Vec::new();
    loop {
        let t = lx.next()?;
        match t.kind {
            Kind::Slash => return Ok(v),
            Kind::Eof => {
                return Err(GrdeclError::Truncated {
                    file: lx.file.clone(),
                    line,
                    keyword: kw.into(),
                    expected: 1,
                    found: v.len(),
                    next: "end of file".into(),
                });
            }
            _ => v.push(lx.text_string(&t)),
        }
    }
}

/// Reads a GRDECL file or `.DATA` deck (its GRID section), following INCLUDEs.
pub fn read_grdecl(path: impl AsRef<Path>) -> Result<GrdeclDeck, GrdeclError> {
    let path = path.as_ref();
    let f = File::open(path).map_err(|e| GrdeclError::Io {
        file: path.into(),
        source: e,
    })?;
    let len = f.metadata().ok().map(|m| m.len());
    read_from(Box::new(f), path, len)
}

/// Reads GRDECL text from `r`, named `name` (INCLUDEs are resolved relative
/// to `name`'s directory).
pub fn read_grdecl_from(r: impl Read, name: &Path) -> Result<GrdeclDeck, GrdeclError> {
    read_from(Box::new(r), name, None)
}

/// [`read_grdecl_from`] with the input's length when known.
fn read_from(
    r: Box<dyn Read + '_>,
    name: &Path,
    len: Option<u64>,
) -> Result<GrdeclDeck, GrdeclError> {
    let mut p = Parser::new();
    p.files.push(name.into());
    p.stack
        .push(name.canonicalize().unwrap_or_else(|_| name.to_path_buf()));
    let mut lx = Lexer::new(r, name.to_path_buf(), len);
    p.parse(&mut lx)?;
    p.finish(name)
}

// ---------------------------------------------------------------------------
// Writer

/// Writes a corner-point grid as GRDECL (SPECGRID, optional MAPAXES,
/// COORD, ZCORN, ACTNUM, then every property), with `N*v` runs.
pub fn write_grdecl(w: &mut impl Write, g: &CornerPointGrid) -> io::Result<()> {
    let [nx, ny, nz] = g.dims;
    if let Some(u) = &g.mapunits {
        writeln!(w, "MAPUNITS\n  '{u}' /\n")?;
    }
    if let Some(m) = &g.mapaxes {
        writeln!(
            w,
            "MAPAXES\n  {} {} {} {} {} {} /\n",
            m[0], m[1], m[2], m[3], m[4], m[5]
        )?;
    }
    if let Some(u) = &g.gridunit {
        writeln!(w, "GRIDUNIT\n  '{u}' '' /\n")?;
    }
    writeln!(w, "SPECGRID\n  {nx} {ny} {nz} 1 F /\n")?;
    write_array(w, "COORD", &g.coord, 6)?;
    write_array(w, "ZCORN", &g.zcorn, 6)?;
    if let Some(a) = &g.actnum {
        let v: Vec<f64> = a.iter().map(|&x| x as f64).collect();
        write_array(w, "ACTNUM", &v, 6)?;
    }
    for p in &g.properties {
        write_array(w, &p.name, &p.values, 6)?;
    }
    Ok(())
}

/// Writes one keyword, six values (or runs) per line, runs as `N*v`.
fn write_array(w: &mut impl Write, kw: &str, v: &[f64], per_line: usize) -> io::Result<()> {
    writeln!(w, "{kw}")?;
    let mut i = 0;
    let mut on_line = 0;
    let mut s = String::with_capacity(64);
    while i < v.len() {
        let mut j = i + 1;
        while j < v.len() && v[j].to_bits() == v[i].to_bits() {
            j += 1;
        }
        s.clear();
        if j - i > 1 {
            use std::fmt::Write as _;
            let _ = write!(s, "{}*{}", j - i, v[i]);
        } else {
            use std::fmt::Write as _;
            let _ = write!(s, "{}", v[i]);
        }
        w.write_all(s.as_bytes())?;
        on_line += 1;
        if on_line == per_line {
            w.write_all(b"\n")?;
            on_line = 0;
        } else {
            w.write_all(b" ")?;
        }
        i = j;
    }
    w.write_all(b"/\n\n")
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
            let a = parse_prefix(t).map(|(v, l)| (v.to_bits(), l));
            let b = parse_prefix_reference(t).map(|(v, l)| (v.to_bits(), l));
            assert_eq!(a, b, "{}", String::from_utf8_lossy(t));
            parsed += a.is_some() as usize;
        }
        assert!(parsed > 10_000, "only {parsed} tokens took the fast path");
    }
}
