//! VTK input: legacy `.vtk` files (ASCII and BINARY, `UNSTRUCTURED_GRID` and
//! `STRUCTURED_GRID`) and XML `.vtu` / `.vts` files, read into a [`Grid`].
//!
//! **vtkio vs hand-written.** Every reader in this module is hand-written; the
//! `vtkio` crate (0.6.3) is not a dependency. It was
//! tried first on the real grids in the shared data directory and failed on
//! six of the eleven files: all three GEOS `.vtu` files are rejected (raw
//! appended binary data (box_hybrid_mesh) fails in its XML deserializer; base64
//! inline data whose header and data are padded separately — VTK's normal
//! layout — fails in its base64 decoder; `faces`/`faceoffsets` polyhedron
//! arrays are refused), and three legacy files are rejected because its
//! `CellType` enum has no pentagonal (15) or hexagonal (16) prism. Of the files
//! it did read, it silently dropped the legacy `FIELD` point and cell arrays
//! (AngularSector.vtk), and on failure its parser prints to stdout. It also
//! has no VTK 5.1 legacy `OFFSETS`/`CONNECTIVITY` and no VTK 9.4 polyhedron
//! arrays. Working around all of that would have meant parsing most files
//! twice, so both formats are read directly: `legacy` is a byte-level
//! tokenizer with an exact fast float parser (no per-token allocation), and
//! `xml` is a small XML scanner that stops at `<AppendedData>` (the raw bytes
//! after it are not XML) plus VTK's block-header decoding, with `flate2`
//! (zlib), `xz2` (LZMA/xz) and `lz4_flex` (LZ4) as decompressors and its own
//! base64 decoder that accepts padding between VTK's header and data chunks.
//! Every count read from a file is checked against the bytes actually present
//! before anything is allocated, so bad input gives a [`VtkReadError`] naming
//! the file, never a panic or a huge allocation.
//!
//! After parsing, the grid goes through [`Grid::validate`]; its errors are
//! wrapped in [`VtkReadError::Invalid`] with the file name. Cell data arrays,
//! `vtkGhostType` included, are kept as they are: hidden cells are dropped by
//! the core, not here. Polyhedra (VTK type 42) get the legacy face stream in
//! [`crate::grid::Cells::face_stream`] and, like
//! [`crate::grid::Cells::push_polyhedron`], the sorted unique point ids of their
//! faces as connectivity.

mod arrays;
mod byte_order;
mod common;
mod decode;
mod explicit;
mod legacy;
mod xml;

pub use arrays::{UnstructuredArrays, grid_from_arrays, grid_from_structured};
pub use explicit::grid_from_explicit_structured;

use crate::grid::{Grid, GridError};
use std::path::Path;

/// Everything that can go wrong while reading a VTK file. Every variant names
/// the file; legacy errors carry the line, XML errors the element or
/// `DataArray`, count errors the expected and found counts.
#[derive(Debug, thiserror::Error)]
pub enum VtkReadError {
    /// The file could not be read from disk.
    #[error("{file}: cannot read file: {source}")]
    Io {
        /// File name.
        file: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// An array the file sizes did not fit in memory.
    #[error("{file}: {source}")]
    Memory {
        /// File name.
        file: String,
        /// What could not be allocated, and how much.
        source: crate::mem::AllocError,
    },
    /// The file name does not end in `.vtk`, `.vtu` or `.vts`.
    #[error("{file}: unsupported file extension '{ext}' (expected .vtk, .vtu or .vts)")]
    UnsupportedExtension {
        /// File name.
        file: String,
        /// The extension found (empty when there is none).
        ext: String,
    },
    /// A syntax or content error in a legacy file.
    #[error("{file}:{line}: {msg}")]
    Legacy {
        /// File name.
        file: String,
        /// 1-based line of the offending token or section header.
        line: usize,
        /// What is wrong.
        msg: String,
    },
    /// A legacy section with the wrong number of values (truncated data,
    /// inconsistent header counts).
    #[error("{file}:{line}: {what}: expected {expected}, found {found}")]
    LegacyCount {
        /// File name.
        file: String,
        /// 1-based line of the section header.
        line: usize,
        /// The section and what was counted.
        what: String,
        /// Expected count.
        expected: usize,
        /// Found count.
        found: usize,
    },
    /// A structural or content error in an XML file.
    #[error("{file}: {element}: {msg}")]
    Xml {
        /// File name.
        file: String,
        /// The element (for data arrays `DataArray 'Name'`).
        element: String,
        /// What is wrong.
        msg: String,
    },
    /// An XML data array (or its binary block) with the wrong size.
    #[error("{file}: {element}: {what}: expected {expected}, found {found}")]
    XmlCount {
        /// File name.
        file: String,
        /// The element, usually `DataArray 'Name'`.
        element: String,
        /// What was counted.
        what: String,
        /// Expected count.
        expected: usize,
        /// Found count.
        found: usize,
    },
    /// A cell whose definition cannot be represented (bad point id, malformed
    /// polyhedron face stream, type id out of range).
    #[error("{file}: cell {cell}: {msg}")]
    Cell {
        /// File name.
        file: String,
        /// Cell index (0-based, over all pieces).
        cell: usize,
        /// What is wrong.
        msg: String,
    },
    /// A dataset kind, data type, encoding or compressor this reader does not handle.
    #[error("{file}: unsupported: {what}")]
    Unsupported {
        /// File name.
        file: String,
        /// What is not supported (with its line or element where known).
        what: String,
    },
    /// The file parsed, but the grid failed [`Grid::validate`].
    #[error("{file}: invalid grid: {source}")]
    Invalid {
        /// File name.
        file: String,
        /// The validation error (names the cell, point or property).
        source: GridError,
    },
}

/// Reads a VTK file, choosing the parser by extension (case-insensitive):
/// `.vtk` is legacy, `.vtu` and `.vts` are XML.
pub fn read_vtk(path: &Path) -> Result<Grid, VtkReadError> {
    let file = path.display().to_string();
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "vtk" => read_vtk_as(path, false),
        "vtu" | "vts" => read_vtk_as(path, true),
        _ => Err(VtkReadError::UnsupportedExtension { file, ext }),
    }
}

/// Reads a VTK file as XML (`xml`) or legacy, whatever its extension.
pub fn read_vtk_as(path: &Path, xml: bool) -> Result<Grid, VtkReadError> {
    let file = path.display().to_string();
    let parse: fn(&[u8], &str) -> Result<Grid, VtkReadError> =
        if xml { parse_vtk_xml } else { parse_vtk_legacy };
    let io_err = |source| VtkReadError::Io {
        file: file.clone(),
        source,
    };
    let f = std::fs::File::open(path).map_err(io_err)?;
    let len = f.metadata().map_err(io_err)?.len();
    if len >= MAP_AT_LEAST {
        // Mapped rather than read: no copy of the whole file in fresh
        // memory (120 MB for a 100k-cell Voronoi grid). A truncation while
        // it is parsed reads zeros and is reported (`io::mapped`).
        if let Some(map) = crate::io::mapped::MappedFile::map(f.try_clone().map_err(io_err)?) {
            return map.settle(parse(&map, &file), io_err);
        }
    }
    let bytes = crate::mem::read_file(&f).map_err(io_err)?;
    parse(&bytes, &file)
}

/// Files at least this large are memory-mapped rather than read.
const MAP_AT_LEAST: u64 = 1 << 24;

/// Parses the bytes of a legacy VTK file (`# vtk DataFile Version ...`);
/// `file` is only used in error messages. Never panics.
pub fn parse_vtk_legacy(bytes: &[u8], file: &str) -> Result<Grid, VtkReadError> {
    let grid = legacy::parse(bytes, file)?;
    common::finish(grid, file)
}

/// Parses the bytes of a VTK XML file (`UnstructuredGrid` or `StructuredGrid`);
/// `file` is only used in error messages. Never panics.
pub fn parse_vtk_xml(bytes: &[u8], file: &str) -> Result<Grid, VtkReadError> {
    let grid = xml::parse(bytes, file)?;
    common::finish(grid, file)
}
