//! Round trips of the writers through independent parsers written here,
//! error cases, and (when `STRATASWEEP_PEER_PYTHON` points to a Python with
//! the `vtk` module) a peer check with VTK's own readers.

use std::collections::HashMap;
use std::path::Path;
use stratasweep::generate::{warped, zoo};
use stratasweep::grid::{Cells, Grid, Property, Topology, vtk_type};
use stratasweep::io::writers::{
    WriteError, grid_extension, ply_property_name, write_ply, write_vtk_xml_grid, write_vtp,
};
use stratasweep::mesh::PolyMesh;

use crate::support;

// ---------------------------------------------------------------------------
// Fixtures.

/// Small deterministic generator, independent of the crate's.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0 >> 33
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn f32(&mut self) -> f32 {
        (self.next() as f64 / (1u64 << 31) as f64 * 2.0 - 1.0) as f32
    }
}

/// A mesh far from the origin with polygons of 3..=9 vertices (plus one of
/// exactly 255), spanning several encoding chunks.
fn sample_mesh(seed: u64, polygons: usize, name: &str) -> PolyMesh {
    let mut r = Lcg(seed);
    let nv = polygons + 300;
    let mut m = PolyMesh {
        origin: [4.6e5 + 0.123, 5.9e6 + 0.456, -1.7e3 + 0.789],
        property_name: name.into(),
        positions: (0..nv)
            .map(|_| [r.f32() * 900.0, r.f32() * 900.0, r.f32() * 90.0])
            .collect(),
        values: (0..nv).map(|_| r.f32()).collect(),
        level_values: (0..7).map(|l| -1.7e3 + 12.5 * l as f64).collect(),
        poly_offsets: vec![0],
        ..Default::default()
    };
    for p in 0..polygons {
        let n = if p == polygons / 2 {
            255
        } else {
            3 + r.below(7) as usize
        };
        for _ in 0..n {
            m.poly_indices.push(r.below(nv as u64) as u32);
        }
        m.poly_offsets.push(m.poly_indices.len() as u32);
        m.poly_level.push(r.below(7) as u32);
        m.poly_cell.push(r.below(3_000_000) as u32);
    }
    m
}

fn world(m: &PolyMesh, v: usize) -> [f64; 3] {
    let p = m.positions[v];
    [
        m.origin[0] + p[0] as f64,
        m.origin[1] + p[1] as f64,
        m.origin[2] + p[2] as f64,
    ]
}

// ---------------------------------------------------------------------------
// An independent PLY parser.

#[derive(Debug)]
enum PlyProp {
    Scalar {
        ty: String,
        name: String,
    },
    List {
        count_ty: String,
        item_ty: String,
        name: String,
    },
}

#[derive(Debug)]
struct PlyElement {
    name: String,
    count: usize,
    props: Vec<PlyProp>,
    /// Per property, per record, the values (one for scalars).
    data: Vec<Vec<Vec<f64>>>,
}

fn ply_type_size(t: &str) -> usize {
    match t {
        "char" | "uchar" | "int8" | "uint8" => 1,
        "short" | "ushort" | "int16" | "uint16" => 2,
        "int" | "uint" | "float" | "int32" | "uint32" | "float32" => 4,
        "double" | "float64" => 8,
        t => panic!("unknown PLY type {t}"),
    }
}

fn ply_read_le(t: &str, b: &[u8]) -> f64 {
    match t {
        "char" | "int8" => b[0] as i8 as f64,
        "uchar" | "uint8" => b[0] as f64,
        "short" | "int16" => i16::from_le_bytes([b[0], b[1]]) as f64,
        "ushort" | "uint16" => u16::from_le_bytes([b[0], b[1]]) as f64,
        "int" | "int32" => i32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
        "uint" | "uint32" => u32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
        "float" | "float32" => f32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
        "double" | "float64" => f64::from_le_bytes(b[..8].try_into().unwrap()),
        t => panic!("unknown PLY type {t}"),
    }
}

fn parse_ply(bytes: &[u8]) -> Vec<PlyElement> {
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .expect("end_header")
        + 11;
    let header = std::str::from_utf8(&bytes[..end]).expect("ASCII header");
    let mut lines = header.lines();
    assert_eq!(lines.next(), Some("ply"));
    let mut elements: Vec<PlyElement> = Vec::new();
    for line in lines {
        let t: Vec<&str> = line.split_whitespace().collect();
        match t.first().copied() {
            Some("format") => assert_eq!(&t[1..], ["binary_little_endian", "1.0"]),
            Some("comment") | Some("end_header") => {}
            Some("element") => elements.push(PlyElement {
                name: t[1].into(),
                count: t[2].parse().unwrap(),
                props: vec![],
                data: vec![],
            }),
            Some("property") if t[1] == "list" => {
                elements.last_mut().unwrap().props.push(PlyProp::List {
                    count_ty: t[2].into(),
                    item_ty: t[3].into(),
                    name: t[4].into(),
                })
            }
            Some("property") => elements.last_mut().unwrap().props.push(PlyProp::Scalar {
                ty: t[1].into(),
                name: t[2].into(),
            }),
            other => panic!("unexpected header line {other:?}"),
        }
    }
    let mut pos = end;
    for e in &mut elements {
        e.data = e
            .props
            .iter()
            .map(|_| Vec::with_capacity(e.count))
            .collect();
        for _ in 0..e.count {
            for (k, p) in e.props.iter().enumerate() {
                match p {
                    PlyProp::Scalar { ty, .. } => {
                        let s = ply_type_size(ty);
                        e.data[k].push(vec![ply_read_le(ty, &bytes[pos..pos + s])]);
                        pos += s;
                    }
                    PlyProp::List {
                        count_ty, item_ty, ..
                    } => {
                        let cs = ply_type_size(count_ty);
                        let n = ply_read_le(count_ty, &bytes[pos..pos + cs]) as usize;
                        pos += cs;
                        let s = ply_type_size(item_ty);
                        let items = (0..n)
                            .map(|i| ply_read_le(item_ty, &bytes[pos + i * s..pos + (i + 1) * s]))
                            .collect();
                        pos += n * s;
                        e.data[k].push(items);
                    }
                }
            }
        }
    }
    assert_eq!(pos, bytes.len(), "trailing bytes after the PLY body");
    elements
}

fn ply_scalar(e: &PlyElement, name: &str, ty: &str) -> Vec<f64> {
    let k = e
        .props
        .iter()
        .position(|p| matches!(p, PlyProp::Scalar { name: n, ty: t } if n == name && t == ty))
        .unwrap_or_else(|| panic!("no {ty} property {name} in {:?}", e.props));
    e.data[k].iter().map(|v| v[0]).collect()
}

// ---------------------------------------------------------------------------
// An independent VTK XML (appended raw, UInt64 header) parser.

#[derive(Debug, Default)]
struct VtkXml {
    root_attrs: HashMap<String, String>,
    /// Attributes of the dataset element (e.g. WholeExtent) and the Piece.
    dataset_attrs: HashMap<String, String>,
    piece_attrs: HashMap<String, String>,
    /// (section, name) -> (type, components, values)
    arrays: HashMap<(String, String), (String, usize, Vec<f64>)>,
    /// Section order of arrays as declared.
    order: Vec<(String, String)>,
}

fn xml_unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

fn attrs(tag: &str) -> HashMap<String, String> {
    let mut out = HashMap::new();
    let mut rest = tag;
    while let Some(eq) = rest.find("=\"") {
        let key = rest[..eq]
            .rsplit(|c: char| c.is_whitespace())
            .next()
            .unwrap()
            .to_string();
        let after = &rest[eq + 2..];
        let close = after.find('"').unwrap();
        out.insert(key, xml_unescape(&after[..close]));
        rest = &after[close + 1..];
    }
    out
}

fn vtk_type_size(t: &str) -> usize {
    match t {
        "Int8" | "UInt8" => 1,
        "Int16" | "UInt16" => 2,
        "Int32" | "UInt32" | "Float32" => 4,
        "Int64" | "UInt64" | "Float64" => 8,
        t => panic!("unknown VTK type {t}"),
    }
}

fn vtk_read_le(t: &str, b: &[u8]) -> f64 {
    match t {
        "Int8" => b[0] as i8 as f64,
        "UInt8" => b[0] as f64,
        "Int32" => i32::from_le_bytes(b.try_into().unwrap()) as f64,
        "UInt32" => u32::from_le_bytes(b.try_into().unwrap()) as f64,
        "Float32" => f32::from_le_bytes(b.try_into().unwrap()) as f64,
        "Int64" => i64::from_le_bytes(b.try_into().unwrap()) as f64,
        "UInt64" => u64::from_le_bytes(b.try_into().unwrap()) as f64,
        "Float64" => f64::from_le_bytes(b.try_into().unwrap()),
        t => panic!("unhandled VTK type {t}"),
    }
}

fn parse_vtk_xml(bytes: &[u8]) -> VtkXml {
    let marker = b"<AppendedData encoding=\"raw\">";
    let m = bytes
        .windows(marker.len())
        .position(|w| w == marker)
        .expect("raw AppendedData");
    let us = m
        + marker.len()
        + bytes[m + marker.len()..]
            .iter()
            .position(|&b| b == b'_')
            .expect("_ marker");
    let data = us + 1;
    let xml = std::str::from_utf8(&bytes[..m]).expect("UTF-8 XML part");
    let mut out = VtkXml::default();
    let mut section = String::new();
    let mut block_end = data;
    for raw in xml.split('<').skip(1) {
        let tag = raw.split('>').next().unwrap();
        let name = tag
            .split_whitespace()
            .next()
            .unwrap_or("")
            .trim_end_matches('/');
        match name {
            "VTKFile" => out.root_attrs = attrs(tag),
            "PolyData" | "StructuredGrid" | "UnstructuredGrid" => out.dataset_attrs = attrs(tag),
            "Piece" => out.piece_attrs = attrs(tag),
            "PointData" | "CellData" | "Points" | "Polys" | "Cells" => section = name.into(),
            "DataArray" => {
                let a = attrs(tag);
                assert_eq!(a["format"], "appended");
                let ty = a["type"].clone();
                let comps: usize = a
                    .get("NumberOfComponents")
                    .map_or(1, |c| c.parse().unwrap());
                let off: usize = a["offset"].parse().unwrap();
                let start = data + off;
                let len = u64::from_le_bytes(bytes[start..start + 8].try_into().unwrap()) as usize;
                let s = vtk_type_size(&ty);
                assert_eq!(len % (s * comps), 0, "block size of {}", a["Name"]);
                let body = &bytes[start + 8..start + 8 + len];
                let values = body.chunks_exact(s).map(|c| vtk_read_le(&ty, c)).collect();
                block_end = block_end.max(start + 8 + len);
                let key = (section.clone(), a["Name"].clone());
                out.order.push(key.clone());
                out.arrays.insert(key, (ty, comps, values));
            }
            _ => {}
        }
    }
    let tail = std::str::from_utf8(&bytes[block_end..]).expect("UTF-8 tail");
    assert_eq!(
        tail.trim(),
        "</AppendedData>\n</VTKFile>",
        "the last block must end right before the closing tags"
    );
    assert_eq!(out.root_attrs["header_type"], "UInt64");
    assert_eq!(out.root_attrs["byte_order"], "LittleEndian");
    assert!(!out.root_attrs.contains_key("compressor"));
    out
}

impl VtkXml {
    fn array(&self, section: &str, name: &str) -> &(String, usize, Vec<f64>) {
        self.arrays
            .get(&(section.to_string(), name.to_string()))
            .unwrap_or_else(|| panic!("no array {section}/{name}; have {:?}", self.order))
    }
}

// ---------------------------------------------------------------------------
// PLY.

#[test]
fn ply_round_trip() {
    let m = sample_mesh(1, 40_000, "poro (frac)");
    let path = support::tmp("writers", "round_trip.ply");
    write_ply(&path, &m).unwrap();
    let els = parse_ply(&std::fs::read(&path).unwrap());
    assert_eq!(els.len(), 2);
    let (v, f) = (&els[0], &els[1]);
    assert_eq!((v.name.as_str(), v.count), ("vertex", m.positions.len()));
    assert_eq!((f.name.as_str(), f.count), ("face", m.polygon_count()));
    let (x, y, z) = (
        ply_scalar(v, "x", "double"),
        ply_scalar(v, "y", "double"),
        ply_scalar(v, "z", "double"),
    );
    let val = ply_scalar(v, "poro__frac_", "float");
    for i in 0..m.positions.len() {
        assert_eq!([x[i], y[i], z[i]], world(&m, i), "vertex {i}");
        assert_eq!(val[i], m.values[i] as f64, "value {i}");
    }
    assert!(
        matches!(&f.props[0], PlyProp::List { count_ty, item_ty, name }
        if count_ty == "uchar" && item_ty == "uint" && name == "vertex_indices")
    );
    let level = ply_scalar(f, "level", "int");
    let cell = ply_scalar(f, "cell_id", "int");
    for p in 0..m.polygon_count() {
        let ids: Vec<f64> = m.polygon(p).iter().map(|&i| i as f64).collect();
        assert_eq!(f.data[0][p], ids, "polygon {p}");
        assert_eq!(level[p], m.poly_level[p] as f64);
        assert_eq!(cell[p], m.poly_cell[p] as f64);
    }
}

#[test]
fn ply_property_names_are_sanitized() {
    assert_eq!(ply_property_name("f"), "f");
    assert_eq!(ply_property_name("PORO"), "PORO");
    assert_eq!(ply_property_name("poro (frac)"), "poro__frac_");
    assert_eq!(ply_property_name(""), "value");
    assert_eq!(ply_property_name("x"), "x_value");
    assert_eq!(ply_property_name("été"), "_t_");
}

#[test]
fn ply_rejects_polygons_over_255_vertices() {
    let mut m = sample_mesh(2, 10, "f");
    let n = m.positions.len() as u32;
    m.poly_indices.extend((0..256).map(|i| i % n));
    m.poly_offsets.push(m.poly_indices.len() as u32);
    m.poly_level.push(0);
    m.poly_cell.push(0);
    let path = support::tmp("writers", "too_large.ply");
    match write_ply(&path, &m) {
        Err(WriteError::PolygonTooLarge {
            path: p,
            polygon,
            vertices,
        }) => {
            assert_eq!((p, polygon, vertices), (path.clone(), 10, 256));
        }
        other => panic!("expected PolygonTooLarge, got {other:?}"),
    }
    // ... while VTP has no such limit.
    write_vtp(support::tmp("writers", "large_polygon.vtp"), &m).unwrap();
}

#[test]
fn empty_mesh_writes_valid_files() {
    let m = PolyMesh {
        property_name: "f".into(),
        ..Default::default()
    };
    let path = support::tmp("writers", "empty.ply");
    write_ply(&path, &m).unwrap();
    let els = parse_ply(&std::fs::read(&path).unwrap());
    assert_eq!((els[0].count, els[1].count), (0, 0));
    let path = support::tmp("writers", "empty.vtp");
    write_vtp(&path, &m).unwrap();
    let x = parse_vtk_xml(&std::fs::read(&path).unwrap());
    assert_eq!(x.piece_attrs["NumberOfPoints"], "0");
    assert_eq!(x.piece_attrs["NumberOfPolys"], "0");
    assert!(x.array("Polys", "offsets").2.is_empty());
}

#[test]
fn invalid_meshes_are_rejected_naming_the_file() {
    let good = sample_mesh(3, 50, "f");
    let mut bad_index = good.clone();
    bad_index.poly_indices[7] = good.positions.len() as u32;
    let mut bad_level = good.clone();
    bad_level.poly_level[3] = good.level_values.len() as u32;
    let mut bad_counts = good.clone();
    bad_counts.values.pop();
    let mut bad_cells = good.clone();
    bad_cells.poly_cell.pop();
    for (what, m) in [
        ("index", &bad_index),
        ("values", &bad_counts),
        ("cells", &bad_cells),
    ] {
        let path = support::tmp("writers", &format!("bad_{what}.ply"));
        let e = write_ply(&path, m).unwrap_err();
        assert!(matches!(e, WriteError::InvalidMesh { .. }), "{what}: {e:?}");
        assert!(e.to_string().contains(path.to_str().unwrap()), "{e}");
        let path = support::tmp("writers", &format!("bad_{what}.vtp"));
        assert!(
            matches!(write_vtp(&path, m), Err(WriteError::InvalidMesh { .. })),
            "{what}"
        );
    }
    // Levels beyond level_values only matter where level_value is written.
    assert!(matches!(
        write_vtp(support::tmp("writers", "bad_level.vtp"), &bad_level),
        Err(WriteError::InvalidMesh { .. })
    ));
    write_ply(support::tmp("writers", "bad_level.ply"), &bad_level).unwrap();
}

#[test]
fn io_errors_name_the_file() {
    let m = sample_mesh(4, 5, "f");
    let path = support::tmp("writers", "no_such_dir").join("x.ply");
    let e = write_ply(&path, &m).unwrap_err();
    assert!(matches!(e, WriteError::Io { .. }));
    assert!(e.to_string().contains("no_such_dir"), "{e}");
}

// ---------------------------------------------------------------------------
// VTP.

#[test]
fn vtp_round_trip() {
    let m = sample_mesh(5, 40_000, "a<b & \"c\"");
    let path = support::tmp("writers", "round_trip.vtp");
    write_vtp(&path, &m).unwrap();
    let x = parse_vtk_xml(&std::fs::read(&path).unwrap());
    assert_eq!(x.root_attrs["type"], "PolyData");
    let (nv, np) = (m.positions.len(), m.polygon_count());
    assert_eq!(x.piece_attrs["NumberOfPoints"], nv.to_string());
    assert_eq!(x.piece_attrs["NumberOfPolys"], np.to_string());

    let (ty, comps, pts) = x.array("Points", "Points");
    assert_eq!((ty.as_str(), *comps, pts.len()), ("Float64", 3, 3 * nv));
    let (ty, _, vals) = x.array("PointData", "a<b & \"c\"");
    assert_eq!(ty, "Float32");
    for i in 0..nv {
        assert_eq!(pts[3 * i..3 * i + 3], world(&m, i), "point {i}");
        assert_eq!(vals[i], m.values[i] as f64);
    }
    let (ty, _, level) = x.array("CellData", "level");
    assert_eq!(ty, "Int32");
    let (_, _, cell) = x.array("CellData", "cell_id");
    let (ty, _, lv) = x.array("CellData", "level_value");
    assert_eq!(ty, "Float64");
    let (ty, _, conn) = x.array("Polys", "connectivity");
    assert_eq!(ty, "Int64");
    let (_, _, offs) = x.array("Polys", "offsets");
    assert_eq!(
        (level.len(), cell.len(), lv.len(), offs.len()),
        (np, np, np, np)
    );
    let mut start = 0usize;
    for p in 0..np {
        let end = offs[p] as usize;
        let ids: Vec<u32> = conn[start..end].iter().map(|&v| v as u32).collect();
        assert_eq!(ids, m.polygon(p), "polygon {p}");
        assert_eq!(level[p], m.poly_level[p] as f64);
        assert_eq!(cell[p], m.poly_cell[p] as f64);
        assert_eq!(lv[p], m.level_values[m.poly_level[p] as usize]);
        start = end;
    }
    assert_eq!(start, conn.len());
}

#[test]
fn vtp_handles_offsets_not_starting_at_zero() {
    // poly_offsets may index a sub-range of poly_indices.
    let mut m = sample_mesh(6, 20, "f");
    m.poly_indices.splice(0..0, [9, 9, 9, 9]);
    for o in &mut m.poly_offsets {
        *o += 4;
    }
    m.poly_indices.extend([1, 2, 3]);
    let path = support::tmp("writers", "offset.vtp");
    write_vtp(&path, &m).unwrap();
    let x = parse_vtk_xml(&std::fs::read(&path).unwrap());
    let (_, _, conn) = x.array("Polys", "connectivity");
    let (_, _, offs) = x.array("Polys", "offsets");
    assert_eq!(
        conn.len(),
        (m.poly_offsets[20] - m.poly_offsets[0]) as usize
    );
    assert_eq!(offs[0] as usize, m.polygon(0).len());
    let first: Vec<u32> = conn[..offs[0] as usize].iter().map(|&v| v as u32).collect();
    assert_eq!(first, m.polygon(0));
}

// ---------------------------------------------------------------------------
// VTK XML grids.

#[test]
fn vts_round_trip_of_a_warped_grid() {
    let mut g = warped([9, 7, 5], 3);
    let nc = g.cell_count();
    g.cell_data.push(Property {
        name: "vec".into(),
        components: 3,
        values: (0..3 * nc).map(|i| i as f64 * 0.5).collect(),
    });
    g.cell_data.push(Property::scalar(
        "vtkGhostType",
        (0..nc)
            .map(|c| if c % 7 == 0 { 32.0 } else { 0.0 })
            .collect(),
    ));
    assert_eq!(grid_extension(&g), "vts");
    let path = support::tmp("writers", "warped.vts");
    write_vtk_xml_grid(&path, &g).unwrap();
    let x = parse_vtk_xml(&std::fs::read(&path).unwrap());
    assert_eq!(x.root_attrs["type"], "StructuredGrid");
    assert_eq!(x.dataset_attrs["WholeExtent"], "0 9 0 7 0 5");
    assert_eq!(x.piece_attrs["Extent"], "0 9 0 7 0 5");
    let (ty, comps, pts) = x.array("Points", "Points");
    assert_eq!((ty.as_str(), *comps), ("Float64", 3));
    let flat: Vec<f64> = g.points.iter().flatten().copied().collect();
    assert_eq!(pts, &flat, "points are written bit-exactly");
    let (ty, comps, f) = x.array("PointData", "f");
    assert_eq!((ty.as_str(), *comps), ("Float64", 1));
    assert_eq!(f, &g.point_property("f").unwrap().values);
    let (ty, comps, v) = x.array("CellData", "vec");
    assert_eq!((ty.as_str(), *comps), ("Float64", 3));
    assert_eq!(v, &g.cell_data[0].values);
    let (ty, _, ghost) = x.array("CellData", "vtkGhostType");
    assert_eq!(ty, "UInt8");
    assert_eq!(ghost, &g.cell_data[1].values);
}

/// A small grid with typed cells and two polyhedra (a unit cube and a
/// triangular prism given by outward faces); total volume 2.
fn polyhedral_grid() -> Grid {
    let points = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
        [2.0, 0.0, 0.0],
        [2.0, 0.0, 1.0],
        [2.0, 1.0, 0.0],
        [2.0, 1.0, 1.0],
        [1.0, 2.0, 0.0],
        [0.5, 0.5, 2.0],
    ];
    let mut cells = Cells::default();
    // Volumes: tet 1/6, cube 1, pyramid 1/3, prism 1/2.
    cells.push(vtk_type::TETRA, &[2, 10, 12, 6]);
    cells.push_polyhedron(&[
        vec![0, 3, 2, 1],
        vec![4, 5, 6, 7],
        vec![0, 1, 5, 4],
        vec![1, 2, 6, 5],
        vec![2, 3, 7, 6],
        vec![3, 0, 4, 7],
    ]);
    cells.push(vtk_type::PYRAMID, &[4, 5, 6, 7, 13]);
    cells.push_polyhedron(&[
        vec![1, 10, 8],
        vec![5, 9, 11],
        vec![1, 8, 9, 5],
        vec![8, 10, 11, 9],
        vec![10, 1, 5, 11],
    ]);
    let np = points.len();
    Grid {
        points,
        topology: Topology::Unstructured(cells),
        point_data: vec![Property::scalar(
            "f",
            (0..np).map(|i| i as f64 / 10.0).collect(),
        )],
        cell_data: vec![Property {
            name: "k".into(),
            components: 2,
            values: vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0],
        }],
    }
}

fn check_vtu(g: &Grid, path: &Path) {
    let cells = match &g.topology {
        Topology::Unstructured(c) => c,
        _ => unreachable!(),
    };
    let x = parse_vtk_xml(&std::fs::read(path).unwrap());
    assert_eq!(x.root_attrs["type"], "UnstructuredGrid");
    assert_eq!(x.piece_attrs["NumberOfPoints"], g.points.len().to_string());
    assert_eq!(x.piece_attrs["NumberOfCells"], cells.len().to_string());
    let (_, _, pts) = x.array("Points", "Points");
    let flat: Vec<f64> = g.points.iter().flatten().copied().collect();
    assert_eq!(pts, &flat);
    let as_f = |v: &[u32]| v.iter().map(|&i| i as f64).collect::<Vec<_>>();
    let (ty, _, conn) = x.array("Cells", "connectivity");
    assert_eq!(ty, "Int64");
    assert_eq!(conn, &as_f(&cells.connectivity));
    let (ty, _, offs) = x.array("Cells", "offsets");
    assert_eq!(ty, "Int64");
    assert_eq!(offs, &as_f(&cells.offsets[1..]));
    let (ty, _, types) = x.array("Cells", "types");
    assert_eq!(ty, "UInt8");
    assert_eq!(
        types,
        &cells.types.iter().map(|&t| t as f64).collect::<Vec<_>>()
    );
    for p in g.point_data.iter() {
        let (_, comps, v) = x.array("PointData", &p.name);
        assert_eq!((*comps, v), (p.components, &p.values));
    }
    for p in g.cell_data.iter() {
        let (_, comps, v) = x.array("CellData", &p.name);
        assert_eq!((*comps, v), (p.components, &p.values));
    }
    let has_poly = cells.types.contains(&vtk_type::POLYHEDRON);
    let faces = x.arrays.get(&("Cells".to_string(), "faces".to_string()));
    assert_eq!(faces.is_some(), has_poly);
    if has_poly {
        let (_, _, fo) = x.array("Cells", "faceoffsets");
        let faces = &faces.unwrap().2;
        assert_eq!(fo.len(), cells.len());
        for (c, &end) in fo.iter().enumerate() {
            if cells.types[c] == vtk_type::POLYHEDRON {
                let end = end as usize;
                let stream = cells.faces_of(c);
                assert_eq!(
                    &faces[end - stream.len()..end],
                    as_f(stream).as_slice(),
                    "cell {c}"
                );
            } else {
                assert_eq!(end, -1.0, "cell {c}");
            }
        }
    }
}

#[test]
fn vtu_round_trip_of_a_zoo_grid() {
    let mut g = zoo(3_000, 8);
    let nc = g.cell_count();
    g.cell_data.push(Property::scalar(
        "region",
        (0..nc).map(|c| (c % 5) as f64).collect(),
    ));
    assert_eq!(grid_extension(&g), "vtu");
    let path = support::tmp("writers", "zoo.vtu");
    write_vtk_xml_grid(&path, &g).unwrap();
    check_vtu(&g, &path);
}

#[test]
fn vtu_round_trip_with_polyhedra() {
    let g = polyhedral_grid();
    g.validate().unwrap();
    let path = support::tmp("writers", "polyhedra.vtu");
    write_vtk_xml_grid(&path, &g).unwrap();
    check_vtu(&g, &path);
}

#[test]
fn grid_writer_checks_extension_and_validity() {
    let g = warped([2, 2, 2], 1);
    let e = write_vtk_xml_grid(support::tmp("writers", "warped.vtu"), &g).unwrap_err();
    assert!(
        matches!(
            e,
            WriteError::Extension {
                expected: "vts",
                ..
            }
        ),
        "{e:?}"
    );
    write_vtk_xml_grid(support::tmp("writers", "warped_upper.VTS"), &g).unwrap();
    let z = zoo(100, 1);
    let e = write_vtk_xml_grid(support::tmp("writers", "zoo.vts"), &z).unwrap_err();
    assert!(
        matches!(
            e,
            WriteError::Extension {
                expected: "vtu",
                ..
            }
        ),
        "{e:?}"
    );
    let mut bad = g.clone();
    bad.points.pop();
    let e = write_vtk_xml_grid(support::tmp("writers", "bad.vts"), &bad).unwrap_err();
    assert!(matches!(e, WriteError::InvalidGrid { .. }), "{e:?}");
    assert!(e.to_string().contains("bad.vts"), "{e}");
}

// ---------------------------------------------------------------------------
// Peer check with VTK's readers.

const PEER_SCRIPT: &str = r#"
import json, struct, sys
import vtk
a = json.loads(sys.argv[1])
out = {"version": vtk.vtkVersion.GetVTKVersion()}

def bits(x):
    # exact f64 transport: the IEEE bits as an integer
    return struct.unpack("<Q", struct.pack("<d", x))[0]

def pt(d, i):
    return [bits(c) for c in d.GetPoint(i)]

r = vtk.vtkXMLPolyDataReader(); r.SetFileName(a["vtp"]); r.Update(); d = r.GetOutput()
ids = vtk.vtkIdList(); d.GetCellPoints(a["poly"], ids)
cd = d.GetCellData()
out["vtp"] = {"points": d.GetNumberOfPoints(), "polys": d.GetNumberOfPolys(), "point": pt(d, a["vertex"]),
  "poly_ids": [ids.GetId(i) for i in range(ids.GetNumberOfIds())],
  "value": bits(d.GetPointData().GetArray(a["name"]).GetTuple1(a["vertex"])),
  "level": cd.GetArray("level").GetTuple1(a["poly"]), "cell_id": cd.GetArray("cell_id").GetTuple1(a["poly"]),
  "level_value": bits(cd.GetArray("level_value").GetTuple1(a["poly"]))}

r = vtk.vtkPLYReader(); r.SetFileName(a["ply"]); r.Update(); d = r.GetOutput()
ids = vtk.vtkIdList(); d.GetCellPoints(a["poly"], ids)
out["ply"] = {"points": d.GetNumberOfPoints(), "polys": d.GetNumberOfPolys(), "point": pt(d, a["vertex"]),
  "poly_ids": [ids.GetId(i) for i in range(ids.GetNumberOfIds())]}

def volumes(d):
    f = vtk.vtkCellSizeFilter(); f.SetInputData(d); f.ComputeVolumeOn(); f.Update()
    v = f.GetOutput().GetCellData().GetArray("Volume")
    vals = [v.GetTuple1(i) for i in range(v.GetNumberOfTuples())]
    return min(vals), sum(vals)

def bad_orientation(d):
    c = vtk.vtkCellValidator(); c.SetInputData(d); c.Update()
    s = c.GetOutput().GetCellData().GetArray("ValidityState")
    return sum(1 for i in range(s.GetNumberOfTuples()) if int(s.GetTuple1(i)) & 32)

r = vtk.vtkXMLStructuredGridReader(); r.SetFileName(a["vts"]); r.Update(); d = r.GetOutput()
vmin, vsum = volumes(d)
dims = [0, 0, 0]; d.GetDimensions(dims)
out["vts"] = {"dims": dims, "points": d.GetNumberOfPoints(), "cells": d.GetNumberOfCells(),
  "point": pt(d, a["grid_point"]), "f": bits(d.GetPointData().GetArray("f").GetTuple1(a["grid_point"])),
  "min_volume": vmin, "volume": vsum}

r = vtk.vtkXMLUnstructuredGridReader(); r.SetFileName(a["vtu"]); r.Update(); d = r.GetOutput()
vmin, vsum = volumes(d)
types = {}
for i in range(d.GetNumberOfCells()):
    t = d.GetCellType(i); types[str(t)] = types.get(str(t), 0) + 1
out["vtu"] = {"points": d.GetNumberOfPoints(), "cells": d.GetNumberOfCells(), "types": types,
  "point": pt(d, a["grid_point"]), "f": bits(d.GetPointData().GetArray("f").GetTuple1(a["grid_point"])),
  "min_volume": vmin, "volume": vsum, "bad_orientation": bad_orientation(d)}

r = vtk.vtkXMLUnstructuredGridReader(); r.SetFileName(a["poly_vtu"]); r.Update(); d = r.GetOutput()
vmin, vsum = volumes(d)
streams = []
for c in range(d.GetNumberOfCells()):
    if d.GetCellType(c) == 42:
        s = vtk.vtkIdList(); d.GetFaceStream(c, s)
        streams.append([s.GetId(i) for i in range(s.GetNumberOfIds())])
out["poly_vtu"] = {"cells": d.GetNumberOfCells(), "types": [d.GetCellType(c) for c in range(d.GetNumberOfCells())],
  "streams": streams, "min_volume": vmin, "volume": vsum}
print(json.dumps(out))
"#;

#[test]
fn peer_vtk_reads_every_format() {
    let Some(py) = support::peer_python("peer_vtk_reads_every_format") else {
        return;
    };
    let m = sample_mesh(11, 30_000, "poro <&> \"x\"");
    let (vtp, ply) = (
        support::tmp("writers", "peer.vtp"),
        support::tmp("writers", "peer.ply"),
    );
    write_vtp(&vtp, &m).unwrap();
    write_ply(&ply, &m).unwrap();
    let w = warped([10, 8, 6], 2);
    let z = zoo(4_000, 3);
    let pg = polyhedral_grid();
    let (vts, vtu, poly_vtu) = (
        support::tmp("writers", "peer.vts"),
        support::tmp("writers", "peer.vtu"),
        support::tmp("writers", "peer_poly.vtu"),
    );
    write_vtk_xml_grid(&vts, &w).unwrap();
    write_vtk_xml_grid(&vtu, &z).unwrap();
    write_vtk_xml_grid(&poly_vtu, &pg).unwrap();
    let (poly, vertex, grid_point) = (m.polygon_count() / 2, 1234usize, 77usize);
    let args = serde_json::json!({
        "vtp": vtp, "ply": ply, "vts": vts, "vtu": vtu, "poly_vtu": poly_vtu,
        "poly": poly, "vertex": vertex, "grid_point": grid_point, "name": m.property_name,
    });
    let out = std::process::Command::new(py)
        .arg("-c")
        .arg(PEER_SCRIPT)
        .arg(args.to_string())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "peer script failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).expect("peer JSON");
    eprintln!("peer VTK {}: {}", r["version"], r);
    let (f64_of, close, ids) = (peer_f64, peer_close, peer_ids);

    // VTP: exact f64 coordinates.
    let t = &r["vtp"];
    assert_eq!(t["points"], m.positions.len());
    assert_eq!(t["polys"], m.polygon_count());
    assert!(
        close(&t["point"], world(&m, vertex), 0.0),
        "vtp point {} vs {:?}",
        t["point"],
        world(&m, vertex)
    );
    assert_eq!(ids(&t["poly_ids"]), m.polygon(poly));
    assert_eq!(f64_of(&t["value"]), m.values[vertex] as f64);
    assert_eq!(t["level"].as_f64().unwrap(), m.poly_level[poly] as f64);
    assert_eq!(t["cell_id"].as_f64().unwrap(), m.poly_cell[poly] as f64);
    assert_eq!(
        f64_of(&t["level_value"]),
        m.level_values[m.poly_level[poly] as usize]
    );

    // PLY: VTK keeps points as float32, so ~0.5 m resolution at 5.9e6.
    let t = &r["ply"];
    assert_eq!(t["points"], m.positions.len());
    assert_eq!(t["polys"], m.polygon_count());
    assert!(
        close(&t["point"], world(&m, vertex), 1.0),
        "ply point {} vs {:?}",
        t["point"],
        world(&m, vertex)
    );
    assert_eq!(ids(&t["poly_ids"]), m.polygon(poly));

    check_peer_grids(&r, [&w, &z, &pg], grid_point);
}

/// An f64 the peer script sent as its bits.
fn peer_f64(v: &serde_json::Value) -> f64 {
    f64::from_bits(v.as_u64().expect("f64 bits"))
}

/// Whether the peer's point (three f64 bit patterns) is within `tol` of
/// `want` on every axis.
fn peer_close(v: &serde_json::Value, want: [f64; 3], tol: f64) -> bool {
    let got: Vec<f64> = v.as_array().unwrap().iter().map(peer_f64).collect();
    (0..3).all(|a| (got[a] - want[a]).abs() <= tol)
}

/// A list of vertex ids the peer script sent.
fn peer_ids(v: &serde_json::Value) -> Vec<u32> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap() as u32)
        .collect()
}

/// [`peer_vtk_reads_every_format`]'s checks of the grid files as VTK read
/// them: the warped VTS, the zoo VTU and the polyhedral VTU.
fn check_peer_grids(r: &serde_json::Value, [w, z, pg]: [&Grid; 3], grid_point: usize) {
    let (f64_of, close, ids) = (peer_f64, peer_close, peer_ids);
    // VTS: dims, exact coordinates, positive cell volumes.
    let t = &r["vts"];
    assert_eq!(t["dims"], serde_json::json!([11, 9, 7]));
    assert_eq!(t["points"], w.points.len());
    assert_eq!(t["cells"], w.cell_count());
    assert!(close(&t["point"], w.points[grid_point], 0.0));
    assert_eq!(
        f64_of(&t["f"]),
        w.point_property("f").unwrap().values[grid_point]
    );
    assert!(
        t["min_volume"].as_f64().unwrap() > 0.0,
        "VTK finds a non-positive warped cell volume"
    );

    // VTU: the zoo, all four types, positive VTK volumes filling the box.
    let t = &r["vtu"];
    assert_eq!(t["points"], z.points.len());
    assert_eq!(t["cells"], z.cell_count());
    let Topology::Unstructured(zc) = &z.topology else {
        unreachable!()
    };
    for ty in [
        vtk_type::TETRA,
        vtk_type::PYRAMID,
        vtk_type::WEDGE,
        vtk_type::HEXAHEDRON,
    ] {
        let n = zc.types.iter().filter(|&&x| x == ty).count();
        assert!(n > 0);
        assert_eq!(t["types"][ty.to_string()], n, "type {ty}");
    }
    assert!(close(&t["point"], z.points[grid_point], 0.0));
    assert_eq!(
        f64_of(&t["f"]),
        z.point_property("f").unwrap().values[grid_point]
    );
    assert!(
        t["min_volume"].as_f64().unwrap() > 0.0,
        "VTK finds a non-positive zoo cell volume"
    );
    assert!(
        (t["volume"].as_f64().unwrap() - 8.0).abs() < 1e-2,
        "VTK zoo volume {}",
        t["volume"]
    );
    assert_eq!(
        t["bad_orientation"], 0,
        "VTK's validator flags wrongly oriented zoo cells"
    );

    // Polyhedra: the face streams survive the legacy faces/faceoffsets arrays.
    let t = &r["poly_vtu"];
    let Topology::Unstructured(pc) = &pg.topology else {
        unreachable!()
    };
    assert_eq!(t["types"], serde_json::json!(pc.types));
    let streams: Vec<Vec<u32>> = t["streams"].as_array().unwrap().iter().map(ids).collect();
    assert_eq!(
        streams,
        vec![pc.faces_of(1).to_vec(), pc.faces_of(3).to_vec()]
    );
    assert!(
        (t["volume"].as_f64().unwrap() - 2.0).abs() < 1e-9,
        "{}",
        t["volume"]
    );
}
