//! `load(path)`: any grid file the crate reads, with its reader chosen by
//! content (magic bytes, XML root) and the extension as a hint, plus a load
//! report. The CLI, the benches, the tests, the viewer and the Python
//! package all load through here.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde_json::{Value, json};
use thiserror::Error;

use crate::cornerpoint::{CornerPointError, CornerPointGrid};
use crate::grid::Grid;
use crate::io::egrid::{EgridError, read_egrid};
use crate::io::grdecl::{GrdeclError, read_grdecl};
use crate::io::vtk_read::{VtkReadError, read_vtk_as};

/// The file formats [`load`] reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Legacy VTK (`# vtk DataFile Version …`), ASCII or binary.
    VtkLegacy,
    /// VTK XML (`.vtu`, `.vts`).
    VtkXml,
    /// Eclipse GRDECL text or a `.DATA` deck (GRID section, INCLUDEs).
    Grdecl,
    /// Eclipse EGRID (big-endian Fortran records), with its INIT beside it.
    Egrid,
}

impl Format {
    /// A short lower-case name (`vtk`, `vtk-xml`, `grdecl`, `egrid`).
    pub fn name(self) -> &'static str {
        match self {
            Format::VtkLegacy => "vtk",
            Format::VtkXml => "vtk-xml",
            Format::Grdecl => "grdecl",
            Format::Egrid => "egrid",
        }
    }

    /// True for the Eclipse corner-point formats.
    pub fn is_cornerpoint(self) -> bool {
        matches!(self, Format::Grdecl | Format::Egrid)
    }
}

/// A loaded grid and what the load found.
#[derive(Debug)]
pub struct Loaded {
    /// Things the load dropped or changed, one sentence each naming the
    /// file and the item (INIT arrays skipped, ...); the CLI prints them as
    /// warnings.
    pub warnings: Vec<String>,
    /// The grid (validated).
    pub grid: Grid,
    /// The format it was read as.
    pub format: Format,
    /// Every file read: the grid file, then INCLUDEs or the INIT file.
    pub inputs: Vec<PathBuf>,
    /// Corner-point input only: the conversion report as JSON (dims, classes,
    /// vertices, bulk volume, MAPAXES, units, timings and the reader's own
    /// summary under `input`), as `info --json` prints it.
    pub cornerpoint: Option<Value>,
    /// Corner-point input only: where each cell sits in the IJK box (for
    /// the corner-point graph).
    pub ijk: Option<crate::grid::IjkLayout>,
}

/// Everything that can go wrong in [`load`]. Every message names the file.
#[derive(Debug, Error)]
pub enum LoadError {
    /// The file cannot be opened or read.
    #[error("{}: cannot read file: {source}", file.display())]
    Io {
        /// The file.
        file: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A VTK reader error (names file and line or element).
    #[error(transparent)]
    Vtk(#[from] VtkReadError),
    /// A GRDECL reader error (names file, line and keyword).
    #[error(transparent)]
    Grdecl(#[from] GrdeclError),
    /// An EGRID / INIT reader error (names file and byte offset).
    #[error(transparent)]
    Egrid(#[from] EgridError),
    /// The corner-point geometry cannot be turned into cells.
    #[error(transparent)]
    CornerPoint(#[from] CornerPointError),
    /// The file is not in the format its name says, or its content cannot
    /// be used (no cells left, coordinates out of range).
    #[error("{}: {why}", file.display())]
    Content {
        /// The file.
        file: PathBuf,
        /// What is wrong, with its cause.
        why: String,
    },
    /// The grid parsed but fails [`Grid::validate`].
    #[error("{}: invalid grid: {source}", file.display())]
    Invalid {
        /// The file.
        file: PathBuf,
        /// The validation error.
        source: crate::grid::GridError,
    },
}

/// Chooses the reader for `path`: by the first bytes (legacy VTK header,
/// XML root, an EGRID record header), else by extension (`.vtk`, `.vtu`,
/// `.vts`, `.egrid`, `.fegrid`), else GRDECL text.
pub fn detect(path: &Path) -> Result<Format, LoadError> {
    let io_err = |source| LoadError::Io {
        file: path.into(),
        source,
    };
    let mut head = [0u8; 64];
    let mut f = std::fs::File::open(path).map_err(io_err)?;
    let mut n = 0;
    while n < head.len() {
        match f.read(&mut head[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(io_err(e)),
        }
    }
    Ok(detect_bytes(&head[..n]).unwrap_or_else(|| by_extension(path)))
}

/// The format the first bytes of a file show, if they show one.
pub fn detect_bytes(head: &[u8]) -> Option<Format> {
    let text = head.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(head);
    let start = text.iter().position(|b| !b.is_ascii_whitespace());
    let trimmed = start.map_or(&[][..], |s| &text[s..]);
    if trimmed.starts_with(b"# vtk DataFile") {
        return Some(Format::VtkLegacy);
    }
    if trimmed.starts_with(b"<?xml") || trimmed.starts_with(b"<VTKFile") {
        return Some(Format::VtkXml);
    }
    // EGRID: a 16-byte header record (8-char keyword, count, type).
    if head.len() >= 24
        && head[..4] == [0, 0, 0, 16]
        && head[4..12]
            .iter()
            .all(|b| b.is_ascii_graphic() || *b == b' ')
    {
        return Some(Format::Egrid);
    }
    None
}

fn by_extension(path: &Path) -> Format {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "vtk" => Format::VtkLegacy,
        "vtu" | "vts" => Format::VtkXml,
        "egrid" | "fegrid" => Format::Egrid,
        _ => Format::Grdecl,
    }
}

/// Loads any grid file the crate reads (see [`detect`]) and validates it.
pub fn load(path: &Path) -> Result<Loaded, LoadError> {
    let format = detect(path)?;
    if format == Format::Egrid {
        check_egrid_head(path)?;
    }
    let (grid, inputs, cornerpoint, ijk) = match format {
        Format::VtkLegacy | Format::VtkXml => {
            let g = read_vtk_as(path, format == Format::VtkXml)?;
            (g, vec![path.to_path_buf()], None, None)
        }
        Format::Grdecl | Format::Egrid => {
            let (g, inputs, info, ijk) = load_cornerpoint(path, format)?;
            (g, inputs, Some(info), Some(ijk))
        }
    };
    grid.validate().map_err(|source| LoadError::Invalid {
        file: path.into(),
        source,
    })?;
    crate::io::checks::check_f32_range(&grid).map_err(|why| LoadError::Content {
        file: path.into(),
        why,
    })?;
    let warnings = load_warnings(path, cornerpoint.as_ref());
    let mut cornerpoint = cornerpoint;
    if let Some(c) = cornerpoint.as_mut() {
        c["warnings"] = json!(warnings);
    }
    Ok(Loaded {
        warnings,
        grid,
        format,
        inputs,
        cornerpoint,
        ijk,
    })
}

/// Reads a corner-point grid (GRDECL, .DATA deck, EGRID) into a zoo grid,
/// with its JSON summary: per-class counts, bulk volume, skipped keywords.
fn load_cornerpoint(
    path: &Path,
    format: Format,
) -> Result<(Grid, Vec<PathBuf>, Value, crate::grid::IjkLayout), LoadError> {
    let t = Instant::now();
    let (cp, inputs, extra): (CornerPointGrid, Vec<PathBuf>, Value) = if format == Format::Egrid {
        let e = read_egrid(path)?;
        let skipped: Vec<Value> = e
            .skipped_init
            .iter()
            .map(|s| json!({"name": s.name, "reason": s.reason}))
            .collect();
        let n = &e.notes;
        let extra = json!({"format": "egrid", "init": e.init.as_ref().map(|p| p.display().to_string()),
            "init_looked_for": e.init_looked_for.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "skipped_init_arrays": skipped, "local_grids": n.local_grids,
            "dual_porosity": n.dual_porosity.map(|d| json!({"filehead_5": d,
                "matrix_active": n.matrix_active, "fracture_active": n.fracture_active}))});
        let mut inputs = vec![path.to_path_buf()];
        inputs.extend(e.init.iter().cloned());
        (e.grid, inputs, extra)
    } else {
        let d = read_grdecl(path)?;
        let s = t.elapsed().as_secs_f64();
        let extra = json!({
            "format": "grdecl", "files": d.files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
            "skipped_keywords": d.skipped, "text_bytes": d.bytes, "parse_s": s,
            "parse_mb_per_s": d.bytes as f64 / s.max(1e-9) / 1e6,
        });
        (d.grid, d.files, extra)
    };
    let read_s = t.elapsed().as_secs_f64();
    let (dims, mapaxes) = (cp.dims, cp.mapaxes);
    let (mapunits, gridunit) = (cp.mapunits.clone(), cp.gridunit.clone());
    let cells = cp.cell_count();
    let (grid, rep) = cp.into_grid()?;
    if grid.cell_count() == 0 {
        return Err(LoadError::Content {
            file: path.into(),
            why: crate::io::checks::no_cells_left(cells, &rep.class_counts()),
        });
    }
    let mut classes = serde_json::Map::new();
    for (k, v) in rep.class_counts() {
        classes.insert(k.into(), json!(v));
    }
    let info = json!({
        "dims": dims, "classes": classes, "vertices": rep.vertices,
        "bulk_volume": rep.bulk_volume, "mapaxes": mapaxes, "mapunits": mapunits,
        "gridunit": gridunit, "ijk_right_handed_up": rep.ijk_right_handed_up,
        "read_s": read_s, "to_grid_s": t.elapsed().as_secs_f64() - read_s, "input": extra,
    });
    let ijk = crate::grid::IjkLayout {
        dims,
        source_cell: rep.source_cell,
    };
    Ok((grid, inputs, info, ijk))
}

/// A file taken as EGRID by its extension must start like one; a text
/// file named `.EGRID` is reported as text rather than as a record whose
/// length is its first four letters.
fn check_egrid_head(path: &Path) -> Result<(), LoadError> {
    let mut head = [0u8; 64];
    let n = std::fs::File::open(path)
        .and_then(|mut f| f.read(&mut head))
        .map_err(|source| LoadError::Io {
            file: path.into(),
            source,
        })?;
    let head = &head[..n];
    if detect_bytes(head) == Some(Format::Egrid) {
        return Ok(());
    }
    let why = if crate::io::checks::looks_like_text(head) {
        "not an EGRID file: it looks like text (GRDECL keywords? then name it .grdecl)".to_string()
    } else {
        "not an EGRID file: it does not start with a 16-byte array header record (unformatted big-endian Eclipse output)".to_string()
    };
    Err(LoadError::Content {
        file: path.into(),
        why,
    })
}

/// The warnings a corner-point load report carries: an EGRID without its
/// INIT (naming the files looked for), a dual-porosity EGRID read as its
/// matrix, local grid refinements skipped, skipped INIT arrays.
fn load_warnings(path: &Path, cornerpoint: Option<&Value>) -> Vec<String> {
    let Some(c) = cornerpoint else {
        return Vec::new();
    };
    let input = &c["input"];
    let strs = |v: &Value| -> Vec<String> {
        v.as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|s| s.as_str().map(String::from))
                    .collect()
            })
            .unwrap_or_default()
    };
    let file = path.display();
    let mut out = Vec::new();
    let looked = strs(&input["init_looked_for"]);
    if !looked.is_empty() {
        let names: Vec<String> = looked
            .iter()
            .map(|p| {
                Path::new(p)
                    .file_name()
                    .map_or(p.clone(), |n| n.to_string_lossy().into_owned())
            })
            .collect();
        out.push(format!(
            "no INIT beside {file} (looked for {}): no properties",
            names.join(", ")
        ));
    }
    let dp = &input["dual_porosity"];
    if let Some(flag) = dp["filehead_5"].as_i64() {
        let kind = if flag == 2 {
            "dual permeability"
        } else {
            "dual porosity"
        };
        out.push(format!(
            "{file}: {kind} (FILEHEAD[5] = {flag}): only the matrix is shown ({} cells with an active matrix, ACTNUM bit 1); the fracture ({} active cells) and the fracture half of every INIT array are skipped",
            dp["matrix_active"], dp["fracture_active"]
        ));
    }
    let lgrs = strs(&input["local_grids"]);
    if !lgrs.is_empty() {
        let s = if lgrs.len() == 1 { "" } else { "s" };
        out.push(format!(
            "{file}: {} local grid refinement{s} ({}) skipped: only the main grid is shown",
            lgrs.len(),
            lgrs.join(", ")
        ));
    }
    let init = input["init"].as_str().unwrap_or("INIT");
    if let Some(a) = input["skipped_init_arrays"].as_array() {
        out.extend(a.iter().map(|s| {
            format!(
                "{init}: array {} skipped: {}",
                s["name"].as_str().unwrap_or("?"),
                s["reason"].as_str().unwrap_or("?")
            )
        }));
    }
    out
}
