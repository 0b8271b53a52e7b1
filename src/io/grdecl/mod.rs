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

mod deck;
mod lexer;
mod parallel;
mod records;
mod writer;

pub use crate::io::number::parse_fortran as parse_number;
use deck::Parser;
use lexer::Lexer;
pub use writer::write_grdecl;

/// Longest token (number, word or quoted string) in bytes.
pub const MAX_TOKEN: usize = 4096;

/// Size of the read window: 64 KiB stays in the cache while it is parsed
/// (cold single-shot Reek parse 6.4 ms against 7.2 ms with 1 MiB).
const WINDOW: usize = 1 << 16;

/// Files at least this large are memory-mapped rather than read, so that
/// their big keywords can be parsed in parallel.
const MAP_AT_LEAST: u64 = 1 << 23;

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

/// Reads a GRDECL file or `.DATA` deck (its GRID section), following INCLUDEs.
pub fn read_grdecl(path: impl AsRef<Path>) -> Result<GrdeclDeck, GrdeclError> {
    let path = path.as_ref();
    let f = File::open(path).map_err(|e| GrdeclError::Io {
        file: path.into(),
        source: e,
    })?;
    parse_with(Lexer::open(f, path.to_path_buf()), path)
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
    parse_with(Lexer::new(r, name.to_path_buf(), len), name)
}

/// Parses the deck that `lx` reads, named `name`.
fn parse_with(mut lx: Lexer, name: &Path) -> Result<GrdeclDeck, GrdeclError> {
    let mut p = Parser::new();
    p.files.push(name.into());
    p.stack
        .push(name.canonicalize().unwrap_or_else(|_| name.to_path_buf()));
    let r = p.parse(&mut lx);
    lx.settle(r)?;
    p.finish(name)
}
