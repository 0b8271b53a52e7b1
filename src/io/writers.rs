//! Writers: PLY, VTP polydata, and VTK XML grids (`.vts` / `.vtu`).
//!
//! All writers stream through an [`AtomicFile`] (a 1 MiB `BufWriter` over a temporary file renamed into place) and encode their binary
//! payload in parallel chunks (rayon), so meshes of tens of millions of
//! polygons are written at disk speed. Coordinates are always written in
//! world space as f64 (`origin + position`, summed in f64), so nothing is
//! lost far from the origin (UTM-like coordinates).
//!
//! * [`write_ply`]: PLY `binary_little_endian 1.0`.
//! * [`write_vtp`]: VTK XML PolyData, appended raw binary, `UInt64` headers.
//! * [`write_vtk_xml_grid`]: VTK XML StructuredGrid (`.vts`) or
//!   UnstructuredGrid (`.vtu`), appended raw binary, `UInt64` headers.

use crate::grid::{Cells, Grid, GridError, Property, Topology, vtk_type};
use crate::io::atomic::AtomicFile;
use crate::mesh::PolyMesh;
use rayon::prelude::*;
use std::fmt::Write as _;
use std::io::{self, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Errors of the writers; every variant names the file.
#[derive(Debug, Error)]
pub enum WriteError {
    /// Creating or writing the file failed.
    #[error("cannot write {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: io::Error,
    },
    /// The mesh is inconsistent (lengths, offsets or indices out of range).
    #[error("cannot write {}: invalid mesh: {why}", path.display())]
    InvalidMesh {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        why: String,
    },
    /// A polygon has more vertices than a PLY `uchar` list count holds.
    #[error("cannot write {}: polygon {polygon} has {vertices} vertices, PLY lists hold at most 255", path.display())]
    PolygonTooLarge {
        /// The file.
        path: PathBuf,
        /// Polygon index.
        polygon: usize,
        /// Its vertex count.
        vertices: usize,
    },
    /// The grid does not validate.
    #[error("cannot write {}: invalid grid: {source}", path.display())]
    InvalidGrid {
        /// The file.
        path: PathBuf,
        /// Why the grid is invalid.
        #[source]
        source: GridError,
    },
    /// The file extension does not match the format the grid is written in.
    #[error("cannot write {}: a {kind} grid is written as VTK XML .{expected}", path.display())]
    Extension {
        /// The file.
        path: PathBuf,
        /// "structured" or "unstructured".
        kind: &'static str,
        /// The extension expected, without the dot.
        expected: &'static str,
    },
}

// ---------------------------------------------------------------------------
// Low-level encoding.

/// Items per encoding chunk.
const CHUNK: usize = 1 << 14;
/// Chunks encoded in parallel before being written in order.
const BATCH: usize = 64;

/// Encodes `n` items in parallel chunks with `encode(range, buf)` (which
/// appends the little-endian bytes of items `range` to `buf`) and writes the
/// chunks in order. Memory stays bounded by `BATCH` chunks.
fn write_encoded<W, F>(w: &mut W, n: usize, encode: F) -> io::Result<()>
where
    W: Write,
    F: Fn(Range<usize>, &mut Vec<u8>) + Sync,
{
    let chunks = n.div_ceil(CHUNK);
    let mut first = 0;
    while first < chunks {
        let last = (first + BATCH).min(chunks);
        let bufs: Vec<Vec<u8>> = (first..last)
            .into_par_iter()
            .map(|c| {
                let mut b = Vec::new();
                encode(c * CHUNK..((c + 1) * CHUNK).min(n), &mut b);
                b
            })
            .collect();
        for b in &bufs {
            w.write_all(b)?;
        }
        first = last;
    }
    Ok(())
}

/// Writes a slice of plain numbers in little-endian order: zero-copy on
/// little-endian targets.
fn write_le_slice<W: Write, T: LeBytes>(w: &mut W, data: &[T]) -> io::Result<()> {
    if cfg!(target_endian = "little") {
        w.write_all(bytemuck::cast_slice(data))
    } else {
        write_encoded(w, data.len(), |r, b| {
            for v in &data[r] {
                v.put(b);
            }
        })
    }
}

/// Numbers with a fixed little-endian encoding.
trait LeBytes: bytemuck::Pod + Sync {
    fn put(&self, b: &mut Vec<u8>);
}

macro_rules! le_bytes {
    ($($t:ty),*) => {$(
        impl LeBytes for $t {
            #[inline]
            fn put(&self, b: &mut Vec<u8>) {
                b.extend_from_slice(&self.to_le_bytes());
            }
        }
    )*};
}
le_bytes!(u8, i32, u32, i64, u64, f32, f64);

/// Opens `path` for buffered writing through a temporary file beside it
/// ([`AtomicFile`]); nothing replaces `path` until [`AtomicFile::commit`].
fn create(path: &Path) -> Result<AtomicFile, WriteError> {
    AtomicFile::create(path).map_err(io_err(path))
}

/// Maps an I/O error to [`WriteError::Io`] naming `path`.
fn io_err(path: &Path) -> impl Fn(io::Error) -> WriteError + '_ {
    move |source| WriteError::Io {
        path: path.to_path_buf(),
        source,
    }
}

// ---------------------------------------------------------------------------
// Mesh validation.

/// Checks the internal consistency of a [`PolyMesh`]; returns the range of
/// `poly_indices` used by the polygons.
fn check_mesh(m: &PolyMesh, need_level_values: bool) -> Result<Range<usize>, String> {
    let nv = m.positions.len();
    if m.values.len() != nv {
        return Err(format!("{} values for {nv} positions", m.values.len()));
    }
    let np = m.polygon_count();
    if np == 0 {
        return Ok(0..0);
    }
    if let Some(p) = m.poly_offsets.windows(2).position(|w| w[0] > w[1]) {
        return Err(format!("poly_offsets decrease at polygon {p}"));
    }
    let used = m.poly_offsets[0] as usize..m.poly_offsets[np] as usize;
    if used.end > m.poly_indices.len() {
        return Err(format!(
            "poly_offsets end at {} but there are {} indices",
            used.end,
            m.poly_indices.len()
        ));
    }
    if let Some(p) = m.poly_offsets.windows(2).position(|w| w[1] - w[0] < 3) {
        return Err(format!("polygon {p} has fewer than 3 vertices"));
    }
    if m.poly_level.len() != np {
        return Err(format!(
            "{} poly_level entries for {np} polygons",
            m.poly_level.len()
        ));
    }
    if m.poly_cell.len() != np {
        return Err(format!(
            "{} poly_cell entries for {np} polygons",
            m.poly_cell.len()
        ));
    }
    if let Some(&v) = m.poly_indices[used.clone()]
        .par_iter()
        .find_any(|&&v| v as usize >= nv)
    {
        return Err(format!(
            "polygon vertex index {v} out of range ({nv} vertices)"
        ));
    }
    let max_level = m.poly_level.par_iter().copied().max().unwrap_or(0);
    if max_level > i32::MAX as u32 {
        return Err(format!("level {max_level} does not fit an int32"));
    }
    if need_level_values && max_level as usize >= m.level_values.len() {
        return Err(format!(
            "level {max_level} but only {} level_values",
            m.level_values.len()
        ));
    }
    Ok(used)
}

// ---------------------------------------------------------------------------
// PLY.

/// The PLY property name for `name`: ASCII letters, digits and `_` kept,
/// anything else replaced by `_`; empty names become `value`, and names
/// that would collide with `x`, `y`, `z` get a `_value` suffix.
pub fn ply_property_name(name: &str) -> String {
    let mut s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() {
        s = "value".into();
    }
    if matches!(s.as_str(), "x" | "y" | "z") {
        s.push_str("_value");
    }
    s
}

/// Writes `mesh` as PLY `binary_little_endian 1.0`.
///
/// Element `vertex`: `double x, y, z` (world coordinates, `origin +
/// position` in f64) and `float <property>` (name from
/// [`ply_property_name`]). Element `face`: `list uchar uint
/// vertex_indices`, `int level`, `int cell_id`. Polygons with more than
/// 255 vertices, and levels or cell ids above `i32::MAX`, are errors.
pub fn write_ply(path: impl AsRef<Path>, mesh: &PolyMesh) -> Result<(), WriteError> {
    let path = path.as_ref();
    let invalid = |why: String| WriteError::InvalidMesh {
        path: path.to_path_buf(),
        why,
    };
    check_mesh(mesh, false).map_err(invalid)?;
    let np = mesh.polygon_count();
    if let Some(p) = mesh
        .poly_offsets
        .par_windows(2)
        .position_first(|w| w[1] - w[0] > 255)
    {
        return Err(WriteError::PolygonTooLarge {
            path: path.to_path_buf(),
            polygon: p,
            vertices: (mesh.poly_offsets[p + 1] - mesh.poly_offsets[p]) as usize,
        });
    }
    if let Some(&c) = mesh
        .poly_cell
        .par_iter()
        .find_any(|&&c| c > i32::MAX as u32)
    {
        return Err(invalid(format!("cell id {c} does not fit a PLY int")));
    }

    let mut header = String::new();
    let o = mesh.origin;
    let _ = write!(
        header,
        "ply\nformat binary_little_endian 1.0\ncomment stratasweep {}\n\
         comment origin {:?} {:?} {:?}\nelement vertex {}\nproperty double x\nproperty double y\n\
         property double z\nproperty float {}\nelement face {np}\n\
         property list uchar uint vertex_indices\nproperty int level\nproperty int cell_id\nend_header\n",
        env!("CARGO_PKG_VERSION"),
        o[0],
        o[1],
        o[2],
        mesh.positions.len(),
        ply_property_name(&mesh.property_name),
    );
    let mut w = create(path)?;
    let body = |w: &mut AtomicFile| -> io::Result<()> {
        w.write_all(header.as_bytes())?;
        write_encoded(w, mesh.positions.len(), |r, b| {
            b.reserve(r.len() * 28);
            for v in r {
                let p = mesh.positions[v];
                for a in 0..3 {
                    (o[a] + p[a] as f64).put(b);
                }
                mesh.values[v].put(b);
            }
        })?;
        let off = &mesh.poly_offsets;
        write_encoded(w, np, |r, b| {
            b.reserve(r.len() * 9 + (off[r.end] - off[r.start]) as usize * 4);
            for p in r {
                let ids = &mesh.poly_indices[off[p] as usize..off[p + 1] as usize];
                b.push(ids.len() as u8);
                for i in ids {
                    i.put(b);
                }
                (mesh.poly_level[p] as i32).put(b);
                (mesh.poly_cell[p] as i32).put(b);
            }
        })?;
        w.flush()
    };
    body(&mut w).and_then(|_| w.commit()).map_err(io_err(path))
}

// ---------------------------------------------------------------------------
// VTK XML, appended raw data.

/// Escapes a string for an XML attribute value.
fn xml_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c if (c as u32) < 0x20 => out.push(' '),
            c => out.push(c),
        }
    }
    out
}

/// Builds the XML of a VTK file whose arrays live in one appended raw
/// block, tracking each array's offset in that block.
struct XmlBuilder {
    xml: String,
    offset: u64,
    indent: usize,
}

impl XmlBuilder {
    fn new(kind: &str) -> Self {
        let mut xml = String::new();
        let _ = writeln!(
            xml,
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"{kind}\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">"
        );
        XmlBuilder {
            xml,
            offset: 0,
            indent: 1,
        }
    }
    fn line(&mut self, s: &str) {
        for _ in 0..self.indent {
            self.xml.push_str("  ");
        }
        self.xml.push_str(s);
        self.xml.push('\n');
    }
    fn open(&mut self, s: &str) {
        self.line(s);
        self.indent += 1;
    }
    fn close(&mut self, s: &str) {
        self.indent -= 1;
        self.line(s);
    }
    /// Declares an appended array of `count` values of `size` bytes each.
    fn array(&mut self, ty: &str, name: &str, components: usize, count: usize, size: usize) {
        let s = format!(
            "<DataArray type=\"{ty}\" Name=\"{}\" NumberOfComponents=\"{components}\" format=\"appended\" offset=\"{}\"/>",
            xml_escape(name),
            self.offset
        );
        self.line(&s);
        self.offset += 8 + (count * size) as u64;
    }
    /// Closes the XML part and opens the appended data (ends with `_`).
    fn finish(mut self) -> String {
        self.xml.push_str("  <AppendedData encoding=\"raw\">\n   _");
        self.xml
    }
}

/// Closing text after the appended blocks.
const XML_TAIL: &[u8] = b"\n  </AppendedData>\n</VTKFile>\n";

/// Writes one appended block's UInt64 byte count.
fn block_header<W: Write>(w: &mut W, count: usize, size: usize) -> io::Result<()> {
    w.write_all(&((count * size) as u64).to_le_bytes())
}

/// Writes `mesh` as VTK XML PolyData (`.vtp`), binary appended raw data
/// with `UInt64` headers and no compression.
///
/// Points: Float64 world coordinates. PointData: the property as Float32
/// (named `property_name`, or `value` when empty). CellData: `level`
/// (Int32), `cell_id` (UInt32) and `level_value` (Float64, the level's
/// world value). Polys: `connectivity` and `offsets` (Int64).
pub fn write_vtp(path: impl AsRef<Path>, mesh: &PolyMesh) -> Result<(), WriteError> {
    let path = path.as_ref();
    let used = check_mesh(mesh, true).map_err(|why| WriteError::InvalidMesh {
        path: path.to_path_buf(),
        why,
    })?;
    let nv = mesh.positions.len();
    let np = mesh.polygon_count();
    let ni = used.len();
    let name = if mesh.property_name.is_empty() {
        "value"
    } else {
        mesh.property_name.as_str()
    };

    let mut x = XmlBuilder::new("PolyData");
    x.open("<PolyData>");
    x.open(&format!(
        "<Piece NumberOfPoints=\"{nv}\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"{np}\">"
    ));
    x.open(&format!("<PointData Scalars=\"{}\">", xml_escape(name)));
    x.array("Float32", name, 1, nv, 4);
    x.close("</PointData>");
    x.open("<CellData Scalars=\"level\">");
    x.array("Int32", "level", 1, np, 4);
    x.array("UInt32", "cell_id", 1, np, 4);
    x.array("Float64", "level_value", 1, np, 8);
    x.close("</CellData>");
    x.open("<Points>");
    x.array("Float64", "Points", 3, nv, 24);
    x.close("</Points>");
    x.open("<Polys>");
    x.array("Int64", "connectivity", 1, ni, 8);
    x.array("Int64", "offsets", 1, np, 8);
    x.close("</Polys>");
    x.close("</Piece>");
    x.close("</PolyData>");
    let xml = x.finish();

    let mut w = create(path)?;
    let body = |w: &mut AtomicFile| -> io::Result<()> {
        w.write_all(xml.as_bytes())?;
        block_header(w, nv, 4)?;
        write_le_slice(w, &mesh.values)?;
        block_header(w, np, 4)?;
        write_le_slice(w, bytemuck::cast_slice::<u32, i32>(&mesh.poly_level[..np]))?;
        block_header(w, np, 4)?;
        write_le_slice(w, &mesh.poly_cell[..np])?;
        block_header(w, np, 8)?;
        write_encoded(w, np, |r, b| {
            for p in r {
                mesh.level_values[mesh.poly_level[p] as usize].put(b);
            }
        })?;
        block_header(w, nv, 24)?;
        let o = mesh.origin;
        write_encoded(w, nv, |r, b| {
            for v in r {
                let p = mesh.positions[v];
                for a in 0..3 {
                    (o[a] + p[a] as f64).put(b);
                }
            }
        })?;
        block_header(w, ni, 8)?;
        let idx = &mesh.poly_indices[used.clone()];
        write_encoded(w, ni, |r, b| {
            for &i in &idx[r] {
                (i as i64).put(b);
            }
        })?;
        block_header(w, np, 8)?;
        let base = used.start as i64;
        write_encoded(w, np, |r, b| {
            for &e in &mesh.poly_offsets[r.start + 1..r.end + 1] {
                (e as i64 - base).put(b);
            }
        })?;
        w.write_all(XML_TAIL)?;
        w.flush()
    };
    body(&mut w).and_then(|_| w.commit()).map_err(io_err(path))
}

/// The VTK XML extension (without the dot) [`write_vtk_xml_grid`] uses for
/// `grid`: `vts` for structured grids, `vtu` for unstructured ones.
pub fn grid_extension(grid: &Grid) -> &'static str {
    match grid.topology {
        Topology::Structured { .. } => "vts",
        Topology::Unstructured(_) => "vtu",
    }
}

/// The VTK XML type and element size a property is written with: Float64,
/// except `vtkGhostType`, which VTK requires as UInt8.
fn property_type(p: &Property) -> (&'static str, usize) {
    if p.name == "vtkGhostType" {
        ("UInt8", 1)
    } else {
        ("Float64", 8)
    }
}

/// Declares the point and cell data arrays of `grid`.
fn declare_properties(x: &mut XmlBuilder, grid: &Grid) {
    for (tag, props) in [
        ("PointData", &grid.point_data),
        ("CellData", &grid.cell_data),
    ] {
        match props
            .iter()
            .find(|p| p.components == 1 && p.name != "vtkGhostType")
        {
            Some(s) => x.open(&format!("<{tag} Scalars=\"{}\">", xml_escape(&s.name))),
            None => x.open(&format!("<{tag}>")),
        }
        for p in props.iter() {
            let (ty, size) = property_type(p);
            let c = p.components.max(1);
            x.array(ty, &p.name, c, p.len(), size * c);
        }
        x.close(&format!("</{tag}>"));
    }
}

/// Writes the point and cell data blocks of `grid`, in declaration order.
fn write_properties<W: Write>(w: &mut W, grid: &Grid) -> io::Result<()> {
    for p in grid.point_data.iter().chain(&grid.cell_data) {
        let (_, size) = property_type(p);
        block_header(w, p.values.len(), size)?;
        if size == 1 {
            write_encoded(w, p.values.len(), |r, b| {
                b.extend(p.values[r].iter().map(|&v| v as u8))
            })?;
        } else {
            write_le_slice(w, &p.values)?;
        }
    }
    Ok(())
}

/// Writes `grid` as VTK XML: `.vts` (StructuredGrid, `WholeExtent` from the
/// point dims) for [`Topology::Structured`], `.vtu` (UnstructuredGrid,
/// `connectivity` / `offsets` Int64 and `types` UInt8; polyhedra through the
/// legacy `faces` / `faceoffsets` Int64 arrays) for
/// [`Topology::Unstructured`]. Points are Float64, every point and cell
/// property is Float64 with its `NumberOfComponents` (`vtkGhostType` as
/// UInt8); binary appended raw data, `UInt64` headers, no compression.
///
/// The grid must pass [`Grid::validate`], and `path` must end in the
/// extension given by [`grid_extension`] (case-insensitive).
pub fn write_vtk_xml_grid(path: impl AsRef<Path>, grid: &Grid) -> Result<(), WriteError> {
    let path = path.as_ref();
    grid.validate().map_err(|source| WriteError::InvalidGrid {
        path: path.to_path_buf(),
        source,
    })?;
    let expected = grid_extension(grid);
    let ext_ok = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(expected));
    if !ext_ok {
        let kind = if expected == "vts" {
            "structured"
        } else {
            "unstructured"
        };
        return Err(WriteError::Extension {
            path: path.to_path_buf(),
            kind,
            expected,
        });
    }
    let np = grid.points.len();
    let nc = grid.cell_count();
    let mut w = create(path)?;
    let res = match &grid.topology {
        Topology::Structured { dims } => {
            let extent = format!("0 {} 0 {} 0 {}", dims[0] - 1, dims[1] - 1, dims[2] - 1);
            let mut x = XmlBuilder::new("StructuredGrid");
            x.open(&format!("<StructuredGrid WholeExtent=\"{extent}\">"));
            x.open(&format!("<Piece Extent=\"{extent}\">"));
            declare_properties(&mut x, grid);
            x.open("<Points>");
            x.array("Float64", "Points", 3, np, 24);
            x.close("</Points>");
            x.close("</Piece>");
            x.close("</StructuredGrid>");
            let xml = x.finish();
            (|| -> io::Result<()> {
                w.write_all(xml.as_bytes())?;
                write_properties(&mut w, grid)?;
                block_header(&mut w, np, 24)?;
                write_le_slice(&mut w, bytemuck::cast_slice::<[f64; 3], f64>(&grid.points))?;
                w.write_all(XML_TAIL)?;
                w.flush()
            })()
        }
        Topology::Unstructured(cells) => write_vtu_body(&mut w, grid, cells, np, nc),
    };
    res.and_then(|_| w.commit()).map_err(io_err(path))
}

/// The `.vtu` part of [`write_vtk_xml_grid`].
fn write_vtu_body<W: Write>(
    w: &mut W,
    grid: &Grid,
    cells: &Cells,
    np: usize,
    nc: usize,
) -> io::Result<()> {
    let has_poly = !cells.face_offsets.is_empty() && cells.types.contains(&vtk_type::POLYHEDRON);
    let nconn = cells.connectivity.len();
    let nfaces = if has_poly { cells.face_stream.len() } else { 0 };
    let mut x = XmlBuilder::new("UnstructuredGrid");
    x.open("<UnstructuredGrid>");
    x.open(&format!(
        "<Piece NumberOfPoints=\"{np}\" NumberOfCells=\"{nc}\">"
    ));
    declare_properties(&mut x, grid);
    x.open("<Points>");
    x.array("Float64", "Points", 3, np, 24);
    x.close("</Points>");
    x.open("<Cells>");
    x.array("Int64", "connectivity", 1, nconn, 8);
    x.array("Int64", "offsets", 1, nc, 8);
    x.array("UInt8", "types", 1, nc, 1);
    if has_poly {
        x.array("Int64", "faces", 1, nfaces, 8);
        x.array("Int64", "faceoffsets", 1, nc, 8);
    }
    x.close("</Cells>");
    x.close("</Piece>");
    x.close("</UnstructuredGrid>");
    let xml = x.finish();

    w.write_all(xml.as_bytes())?;
    write_properties(w, grid)?;
    block_header(w, np, 24)?;
    write_le_slice(w, bytemuck::cast_slice::<[f64; 3], f64>(&grid.points))?;
    block_header(w, nconn, 8)?;
    write_encoded(w, nconn, |r, b| {
        for &i in &cells.connectivity[r] {
            (i as i64).put(b);
        }
    })?;
    block_header(w, nc, 8)?;
    write_encoded(w, nc, |r, b| {
        for &e in &cells.offsets[r.start + 1..r.end + 1] {
            (e as i64).put(b);
        }
    })?;
    block_header(w, nc, 1)?;
    write_le_slice(w, &cells.types)?;
    if has_poly {
        // The face stream is already VTK's legacy layout with global ids:
        // per polyhedron `nf, n0, ids.., n1, ids..`; `faceoffsets` holds the
        // end of each polyhedron's stream, -1 for other cells.
        block_header(w, nfaces, 8)?;
        write_encoded(w, nfaces, |r, b| {
            for &v in &cells.face_stream[r] {
                (v as i64).put(b);
            }
        })?;
        block_header(w, nc, 8)?;
        write_encoded(w, nc, |r, b| {
            for c in r {
                let e = if cells.types[c] == vtk_type::POLYHEDRON {
                    cells.face_offsets[c + 1] as i64
                } else {
                    -1
                };
                e.put(b);
            }
        })?;
    }
    w.write_all(XML_TAIL)?;
    w.flush()
}
