//! VTK XML reader: `UnstructuredGrid` (`.vtu`) and `StructuredGrid` (`.vts`),
//! with ascii, base64 `binary` and `appended` (raw or base64) data, `UInt32` or
//! `UInt64` block headers, either byte order, and zlib / LZMA / LZ4 compression.

use super::VtkReadError;
use super::common::{PolyFaces, build_cells, is_ws, to_points};
use crate::grid::{Cells, Grid, Property, Topology};

mod data;
mod scan;

use data::Compressor;
use scan::{Doc, Elem, scan};

/// Largest memory the LZMA decoder may use (VTK's presets need at most ~65 MiB).
const LZMA_MEMLIMIT: u64 = 256 << 20;

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

    // (data access methods: data.rs)

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
            points: to_points(&points, self.file)?,
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
        let FaceStreams {
            stream,
            stream32,
            ranges,
        } = if !has_poly {
            // faces arrays, if any, are irrelevant
            FaceStreams::default()
        } else if let (Some(fi), Some(foi)) = (
            self.named_array(ce, "faces"),
            self.named_array(ce, "faceoffsets"),
        ) {
            self.legacy_faces(fi, foi, nc)?
        } else {
            self.shared_faces(ce, nc)?
        };
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

    /// VTK < 9.4 polyhedra: per polyhedron a legacy face stream in `faces`
    /// (array `fi`); `faceoffsets` (array `foi`) are end offsets, -1 for
    /// other cells. The stream is narrowed to u32 when every id fits.
    fn legacy_faces(&self, fi: usize, foi: usize, nc: usize) -> Result<FaceStreams, VtkReadError> {
        let mut out = FaceStreams {
            stream32: self.values_u32_ids(fi)?,
            ..FaceStreams::default()
        };
        if out.stream32.is_none() {
            out.stream = self.values_i64(fi)?;
        }
        let stream_len = out.stream32.as_ref().map_or(out.stream.len(), Vec::len);
        let fo = self.ints(foi, nc, "values (NumberOfCells)")?;
        let mut prev = 0usize;
        for (c, &o) in fo.iter().enumerate() {
            if o < 0 {
                out.ranges.push(None);
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
            out.ranges.push(Some((prev, end)));
            prev = end;
        }
        Ok(out)
    }

    /// VTK >= 9.4 polyhedra: faces are shared cells of their own
    /// (`polyhedron_to_faces`, `polyhedron_offsets`, `face_connectivity`,
    /// `face_offsets`), rewritten here as legacy face streams.
    fn shared_faces(&self, ce: &Elem, nc: usize) -> Result<FaceStreams, VtkReadError> {
        let find = |a: &str, b: &str| self.named_array(ce, a).or_else(|| self.named_array(ce, b));
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
        let p2f = self.values_i64(pti)?;
        let poff = self.end_offsets(poi, nc, Some(p2f.len()))?;
        let fconn = self.values_i64(fci)?;
        let nf_total = self.values_i64(foi)?.len();
        let foff = self.end_offsets(foi, nf_total, Some(fconn.len()))?;
        let mut out = FaceStreams::default();
        for c in 0..nc {
            let (a, b) = (poff[c], poff[c + 1]);
            if a == b {
                out.ranges.push(None);
                continue;
            }
            let start = out.stream.len();
            out.stream.push((b - a) as i64);
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
                out.stream.push(ids.len() as i64);
                out.stream.extend_from_slice(ids);
            }
            out.ranges.push(Some((start, out.stream.len())));
        }
        Ok(out)
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
            points: to_points(&points, self.file)?,
            topology: Topology::Structured { dims },
            point_data,
            cell_data,
        })
    }
}

/// Polyhedron face streams of a piece: the legacy stream (as i64, or
/// narrowed to u32) and each cell's range in it (None: not a polyhedron).
#[derive(Default)]
struct FaceStreams {
    stream: Vec<i64>,
    stream32: Option<Vec<u32>>,
    ranges: Vec<Option<(usize, usize)>>,
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
    use super::data::base64_decode;
    use super::scan::decode_entities;

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
