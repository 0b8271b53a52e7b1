//! Tests of the VTK readers (`stratasweep::io::vtk_read`).
//!
//! * Tiny fixtures (tests/fixtures/vtk, written by `gen_fixtures.py` there) in
//!   every supported encoding must all give exactly the same grid.
//! * Bad input must give an error naming the file (and line / cell).
//! * With `STRATASWEEP_DATA` pointing at the shared data directory, every VTK
//!   file there is read and checked against counts obtained independently
//!   (README, and Python counts over the ASCII / decoded XML arrays).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use stratasweep::grid::{Cells, Grid, Property, Topology};
use stratasweep::io::vtk_read::{VtkReadError, parse_vtk_legacy, parse_vtk_xml, read_vtk};

use crate::support;

// ------------------------------------------------------------------ fixtures

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/vtk")
        .join(name)
}

fn read_ok(path: &Path) -> Grid {
    read_vtk(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn fixture_points() -> Vec<[f64; 3]> {
    vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
        [0.5, 0.5, 1.75],
    ]
}

/// Grid "a": a hexahedron and a pyramid with point and cell data.
fn expected_a() -> Grid {
    let mut cells = Cells::default();
    cells.push(12, &[0, 1, 2, 3, 4, 5, 6, 7]);
    cells.push(14, &[4, 5, 6, 7, 8]);
    let vel = (0..9)
        .flat_map(|i| [f64::from(i) * 0.25, -f64::from(i), 0.5])
        .collect();
    Grid {
        points: fixture_points(),
        topology: Topology::Unstructured(cells),
        point_data: vec![
            Property::scalar("temp", vec![0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.25]),
            Property {
                name: "vel".into(),
                components: 3,
                values: vel,
            },
        ],
        cell_data: vec![
            Property::scalar("PORO", vec![0.25, 0.125]),
            Property::scalar("vtkGhostType", vec![0.0, 32.0]),
            Property::scalar("region", vec![7.0, -3.0]),
        ],
    }
}

/// Grid "b": a cube given as a polyhedron, and a tetrahedron.
fn expected_b() -> Grid {
    let mut cells = Cells::default();
    cells.push_polyhedron(&[
        vec![0, 3, 2, 1],
        vec![4, 5, 6, 7],
        vec![0, 1, 5, 4],
        vec![1, 2, 6, 5],
        vec![2, 3, 7, 6],
        vec![3, 0, 4, 7],
    ]);
    cells.push(10, &[4, 5, 7, 8]);
    Grid {
        points: fixture_points(),
        topology: Topology::Unstructured(cells),
        point_data: vec![],
        cell_data: vec![Property::scalar("PORO", vec![0.25, 0.125])],
    }
}

/// Grid "c": structured, 3 x 2 x 2 points.
fn expected_c() -> Grid {
    let mut points = Vec::new();
    for k in 0..2 {
        for j in 0..2 {
            for i in 0..3 {
                points.push([f64::from(i) * 0.5, f64::from(j), f64::from(k) * 2.0]);
            }
        }
    }
    Grid {
        points,
        topology: Topology::Structured { dims: [3, 2, 2] },
        point_data: vec![Property::scalar(
            "p",
            (0..12).map(|n| f64::from(n) * 0.5).collect(),
        )],
        cell_data: vec![Property::scalar("c", vec![1.5, 2.5])],
    }
}

const A_FILES: [&str; 14] = [
    "a_legacy_ascii_42.vtk",
    "a_legacy_ascii_51.vtk",
    "a_legacy_binary_42.vtk",
    "a_legacy_binary_51.vtk",
    "a_ascii.vtu",
    "a_base64_u32.vtu",
    "a_base64_u64.vtu",
    "a_appended_raw_u64.vtu",
    "a_appended_base64_u32.vtu",
    "a_zlib_base64_u32.vtu",
    "a_zlib_appended_u64_blocks.vtu",
    "a_lzma_base64_u64.vtu",
    "a_lz4_appended_u32.vtu",
    "a_bigendian_zlib.vtu",
];

const B_FILES: [&str; 7] = [
    "b_legacy_ascii_42.vtk",
    "b_legacy_ascii_51.vtk",
    "b_legacy_binary_51.vtk",
    "b_faces_ascii.vtu",
    "b_faces_zlib.vtu",
    "b_vtk94_ascii.vtu",
    "b_vtk94_appended.vtu",
];

const C_FILES: [&str; 4] = [
    "c_legacy_ascii.vtk",
    "c_legacy_binary.vtk",
    "c_ascii.vts",
    "c_zlib_appended.vts",
];

#[test]
fn fixture_a_all_encodings_give_identical_grids() {
    let want = expected_a();
    for f in A_FILES {
        assert_eq!(read_ok(&fixture(f)), want, "{f}");
    }
}

#[test]
fn fixture_a_ascii_binary_legacy_and_xml_agree() {
    // Same grid through the two legacy encodings and the public byte parsers.
    let ascii = std::fs::read(fixture("a_legacy_ascii_42.vtk")).unwrap();
    let binary = std::fs::read(fixture("a_legacy_binary_42.vtk")).unwrap();
    assert_ne!(ascii, binary);
    let ga = parse_vtk_legacy(&ascii, "ascii.vtk").unwrap();
    let gb = parse_vtk_legacy(&binary, "binary.vtk").unwrap();
    assert_eq!(ga, gb);
    let xml_ascii = std::fs::read(fixture("a_ascii.vtu")).unwrap();
    let xml_raw = std::fs::read(fixture("a_appended_raw_u64.vtu")).unwrap();
    assert_eq!(
        parse_vtk_xml(&xml_ascii, "a.vtu").unwrap(),
        parse_vtk_xml(&xml_raw, "b.vtu").unwrap()
    );
    assert_eq!(ga, parse_vtk_xml(&xml_ascii, "a.vtu").unwrap());
}

#[test]
fn fixture_a_keeps_hidden_cells_and_ghost_array() {
    let g = read_ok(&fixture("a_zlib_base64_u32.vtu"));
    assert_eq!(g.cell_count(), 2, "the reader must not drop hidden cells");
    assert_eq!(g.hidden_cells(), Some(vec![false, true]));
}

#[test]
fn fixture_a_two_pieces_are_concatenated() {
    let a = expected_a();
    let g = read_ok(&fixture("a_two_pieces.vtu"));
    let ids2 = [4usize, 5, 6, 7, 8];
    let mut points = a.points[..8].to_vec();
    points.extend(ids2.iter().map(|&i| a.points[i]));
    assert_eq!(g.points, points);
    let Topology::Unstructured(c) = &g.topology else {
        panic!("unstructured expected")
    };
    assert_eq!(c.types, vec![12, 14]);
    assert_eq!(c.cell(0), &[0, 1, 2, 3, 4, 5, 6, 7]);
    assert_eq!(c.cell(1), &[8, 9, 10, 11, 12]);
    let temp = &g.point_property("temp").unwrap().values;
    assert_eq!(temp.len(), 13);
    assert_eq!(temp[8..], [2.0, 2.5, 3.0, 3.5, 4.25]);
    assert_eq!(g.cell_data, a.cell_data);
}

#[test]
fn fixture_b_polyhedra_all_encodings() {
    let want = expected_b();
    for f in B_FILES {
        let g = read_ok(&fixture(f));
        assert_eq!(g, want, "{f}");
        let Topology::Unstructured(c) = &g.topology else {
            panic!()
        };
        assert_eq!(
            c.cell(0),
            &[0, 1, 2, 3, 4, 5, 6, 7],
            "{f}: polyhedron connectivity = sorted unique ids"
        );
        assert_eq!(c.faces_of(0)[..6], [6, 4, 0, 3, 2, 1], "{f}");
        assert!(c.faces_of(1).is_empty(), "{f}");
    }
}

#[test]
fn fixture_c_structured_all_encodings() {
    let want = expected_c();
    for f in C_FILES {
        assert_eq!(read_ok(&fixture(f)), want, "{f}");
    }
}

// ------------------------------------------------------------------ bad input

fn legacy_err(text: &str) -> String {
    let e = parse_vtk_legacy(text.as_bytes(), "bad_input.vtk").expect_err("must fail");
    let msg = e.to_string();
    assert!(
        msg.contains("bad_input.vtk"),
        "error does not name the file: {msg}"
    );
    msg
}

fn xml_err(text: &str) -> String {
    let e = parse_vtk_xml(text.as_bytes(), "bad_input.vtu").expect_err("must fail");
    let msg = e.to_string();
    assert!(
        msg.contains("bad_input.vtu"),
        "error does not name the file: {msg}"
    );
    msg
}

const HEADER: &str = "# vtk DataFile Version 4.2\nt\nASCII\nDATASET UNSTRUCTURED_GRID\n";
const TET_POINTS: &str = "POINTS 4 float\n0 0 0  1 0 0  0 1 0  0 0 1\n";

#[test]
fn truncated_legacy_ascii_names_file_and_line() {
    let full = std::fs::read_to_string(fixture("a_legacy_ascii_42.vtk")).unwrap();
    let cut = &full[..full.find("1 1 1 0 1 1").unwrap()];
    let msg = legacy_err(cut);
    assert!(msg.contains("bad_input.vtk:8:"), "{msg}"); // POINTS is on line 8
    assert!(
        msg.contains("POINTS") && msg.contains("expected 27, found 18"),
        "{msg}"
    );
}

#[test]
fn truncated_legacy_binary_and_xml_fail_cleanly() {
    for f in [
        "a_legacy_binary_42.vtk",
        "a_legacy_binary_51.vtk",
        "b_legacy_binary_51.vtk",
    ] {
        let b = std::fs::read(fixture(f)).unwrap();
        for cut in [b.len() / 3, b.len() / 2, b.len() - 40] {
            let e = parse_vtk_legacy(&b[..cut], "cut.vtk").expect_err(f);
            assert!(e.to_string().contains("cut.vtk"), "{e}");
        }
    }
    for f in A_FILES
        .iter()
        .chain(&B_FILES)
        .chain(&C_FILES)
        .filter(|f| !f.ends_with(".vtk"))
    {
        let b = std::fs::read(fixture(f)).unwrap();
        // Cut inside the markup, and (for appended files) inside the raw data.
        for cut in [b.len() / 2, b.len() - 40] {
            let r = parse_vtk_xml(&b[..cut], "cut.vtu");
            let e = r.expect_err(f);
            assert!(e.to_string().contains("cut.vtu"), "{f}: {e}");
        }
    }
}

#[test]
fn truncated_appended_data_reports_counts() {
    let b = std::fs::read(fixture("a_appended_raw_u64.vtu")).unwrap();
    let end = b
        .windows(15)
        .rposition(|w| w == b"</AppendedData>")
        .unwrap();
    let msg = parse_vtk_xml(&b[..end - 20], "short.vtu")
        .unwrap_err()
        .to_string();
    // The cut removes the 10 bytes of 'types' and 13 of the 24 of 'offsets' (read first).
    assert!(
        msg.contains("short.vtu") && msg.contains("DataArray 'offsets'"),
        "{msg}"
    );
    assert!(msg.contains("expected 16, found 7"), "{msg}");
}

#[test]
fn legacy_count_mismatches() {
    let msg = legacy_err(&format!(
        "{HEADER}{TET_POINTS}CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 2\n10 10\n"
    ));
    assert!(
        msg.contains("bad_input.vtk:9:") && msg.contains("expected 1, found 2"),
        "{msg}"
    );
    let msg = legacy_err(&format!(
        "{HEADER}{TET_POINTS}CELLS 1 6\n4 0 1 2 3\nCELL_TYPES 1\n10\n"
    ));
    assert!(
        msg.contains(":7:") && msg.contains("CELLS: values: expected 6, found 5"),
        "{msg}"
    );
    let msg = legacy_err(&format!(
        "{HEADER}{TET_POINTS}CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nPOINT_DATA 3\nSCALARS s float\nLOOKUP_TABLE default\n1 2 3\n"
    ));
    assert!(
        msg.contains(":11:") && msg.contains("expected 4, found 3"),
        "{msg}"
    );
    let msg = legacy_err(&format!(
        "{HEADER}{TET_POINTS}CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nCELL_DATA 1\nFIELD f 1\nx 1 2 float\n1 2\n"
    ));
    assert!(
        msg.contains(":13:")
            && msg.contains("FIELD array 'x'")
            && msg.contains("expected 1, found 2"),
        "{msg}"
    );
}

#[test]
fn xml_count_mismatch_names_data_array() {
    let s = std::fs::read_to_string(fixture("a_ascii.vtu")).unwrap();
    let msg = xml_err(&s.replace("NumberOfPoints=\"9\"", "NumberOfPoints=\"10\""));
    assert!(
        msg.contains("DataArray 'Points'") && msg.contains("expected 30, found 27"),
        "{msg}"
    );
    let msg = xml_err(&s.replace("NumberOfCells=\"2\"", "NumberOfCells=\"3\""));
    assert!(
        msg.contains("DataArray '") && msg.contains("expected 3, found 2"),
        "{msg}"
    );
}

#[test]
fn nan_coordinate_is_an_error() {
    let msg = legacy_err(&format!(
        "{HEADER}POINTS 4 float\n0 0 0  nan 0 0  0 1 0  0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n"
    ));
    assert!(
        msg.contains("point 1") && msg.contains("non-finite"),
        "{msg}"
    );
    let s = std::fs::read_to_string(fixture("a_ascii.vtu")).unwrap();
    let msg = xml_err(&s.replace("0 0 0 1 0 0 1 1 0", "0 0 0 NaN 0 0 1 1 0"));
    assert!(msg.contains("point 1"), "{msg}");
}

#[test]
fn missing_vertex_is_an_error() {
    let msg = legacy_err(&format!(
        "{HEADER}{TET_POINTS}CELLS 2 10\n4 0 1 2 3\n4 0 1 2 4\nCELL_TYPES 2\n10 10\n"
    ));
    assert!(msg.contains("cell 1 references point 4"), "{msg}");
    let msg = legacy_err(&format!(
        "{HEADER}{TET_POINTS}CELLS 1 5\n4 0 1 2 -1\nCELL_TYPES 1\n10\n"
    ));
    assert!(
        msg.contains("cell 0") && msg.contains("negative point id -1"),
        "{msg}"
    );
}

#[test]
fn unknown_cell_type_is_an_error() {
    // 25 = VTK_QUADRATIC_HEXAHEDRON, not supported by the grid model.
    let msg = legacy_err(&format!(
        "{HEADER}{TET_POINTS}CELLS 2 9\n4 0 1 2 3\n3 0 1 2\nCELL_TYPES 2\n10 25\n"
    ));
    assert!(
        msg.contains("cell 1 has unsupported VTK cell type 25"),
        "{msg}"
    );
    let msg = legacy_err(&format!(
        "{HEADER}{TET_POINTS}CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n300\n"
    ));
    assert!(msg.contains("cell 0") && msg.contains("300"), "{msg}");
    let s = std::fs::read_to_string(fixture("a_ascii.vtu")).unwrap();
    let msg = xml_err(&s.replace("\n  12 14\n", "\n  12 70\n"));
    assert!(
        msg.contains("cell 1 has unsupported VTK cell type 70"),
        "{msg}"
    );
}

#[test]
fn lower_dimensional_cells_are_kept() {
    // Triangles, quads and lines carry no volume; the grid model accepts
    // them (the sweep skips them), so the reader must keep them as they are.
    let g = parse_vtk_legacy(
        format!(
            "{HEADER}{TET_POINTS}CELLS 3 12\n4 0 1 2 3\n3 0 1 2\n2 0 3\nCELL_TYPES 3\n10 5 3\n"
        )
        .as_bytes(),
        "lower.vtk",
    )
    .unwrap();
    let Topology::Unstructured(c) = &g.topology else {
        panic!()
    };
    assert_eq!(c.types, vec![10, 5, 3]);
    assert_eq!(c.cell(1), &[0, 1, 2]);
    assert_eq!(c.cell(2), &[0, 3]);
}

#[test]
fn wrong_vertex_count_and_bad_polyhedron() {
    let msg = legacy_err(&format!(
        "{HEADER}{TET_POINTS}CELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n10\n"
    ));
    assert!(
        msg.contains("cell 0 of VTK type 10 has 3 vertices, expected 4"),
        "{msg}"
    );
    // A polyhedron whose face stream announces 4 faces but holds 1.
    let msg = legacy_err(&format!(
        "{HEADER}{TET_POINTS}CELLS 1 6\n5 4 3 0 1 2\nCELL_TYPES 1\n42\n"
    ));
    assert!(
        msg.contains("cell 0") && msg.contains("face stream ends before face 1"),
        "{msg}"
    );
}

#[test]
fn empty_grids_are_errors() {
    let msg = legacy_err(&format!(
        "{HEADER}POINTS 0 float\nCELLS 0 0\nCELL_TYPES 0\n"
    ));
    assert!(msg.contains("empty grid: 0 points, 0 cells"), "{msg}");
    let msg = legacy_err(&format!("{HEADER}{TET_POINTS}"));
    assert!(msg.contains("empty grid: 4 points, 0 cells"), "{msg}");
    let msg = xml_err(
        r#"<VTKFile type="UnstructuredGrid"><UnstructuredGrid><Piece NumberOfPoints="0" NumberOfCells="0"/></UnstructuredGrid></VTKFile>"#,
    );
    assert!(msg.contains("empty grid"), "{msg}");
}

#[test]
fn malformed_headers_and_markup() {
    let msg = legacy_err("hello\n");
    assert!(msg.contains("bad_input.vtk:1:"), "{msg}");
    let msg = legacy_err("# vtk DataFile Version 4.2\nt\nASCII\nDATASET POLYDATA\n");
    assert!(msg.contains("POLYDATA"), "{msg}");
    let msg = legacy_err(&format!("{HEADER}{TET_POINTS}BOGUS 1\n"));
    assert!(msg.contains(":7:") && msg.contains("BOGUS"), "{msg}");
    let msg = legacy_err(&format!(
        "{HEADER}POINTS 4 float\n0 0 0 1 x 0 0 1 0 0 0 1\n"
    ));
    assert!(
        msg.contains(":6:") && msg.contains("invalid number 'x'"),
        "{msg}"
    );
    let msg = xml_err("<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid></VTKFile>");
    assert!(msg.contains("UnstructuredGrid"), "{msg}");
    let msg = xml_err("<VTKFile type=\"ImageData\"><ImageData/></VTKFile>");
    assert!(msg.contains("ImageData"), "{msg}");
    let s = std::fs::read_to_string(fixture("a_base64_u32.vtu")).unwrap();
    let msg = xml_err(&s.replacen("format=\"binary\">\n  ", "format=\"binary\">\n  !", 1));
    assert!(
        msg.contains("DataArray 'temp'") && msg.contains("base64"),
        "{msg}"
    );
}

#[test]
fn read_vtk_errors_name_the_path() {
    let missing = fixture("does_not_exist.vtu");
    let e = read_vtk(&missing).unwrap_err();
    assert!(
        matches!(e, VtkReadError::Io { .. }) && e.to_string().contains("does_not_exist.vtu"),
        "{e}"
    );
    let e = read_vtk(&fixture("gen_fixtures.py")).unwrap_err();
    assert!(
        matches!(e, VtkReadError::UnsupportedExtension { .. })
            && e.to_string().contains("gen_fixtures.py")
    );
}

// ------------------------------------------------------------------ real data

/// Expected content of one real file: counts, cell-type histogram and, per
/// property, (name, components, first value, last value).
struct Expect {
    file: &'static str,
    points: usize,
    cells: usize,
    types: &'static [(u8, usize)],
    point_data: &'static [(&'static str, usize, f64, f64)],
    cell_data: &'static [(&'static str, usize, f64, f64)],
    first_point: [f64; 3],
    last_point: [f64; 3],
}

const REAL: &[Expect] = &[
    Expect {
        file: "geos/pebi3d_with_properties.vtu",
        points: 3388,
        cells: 1630,
        types: &[(42, 1630)],
        point_data: &[
            ("vtkOriginalPointIds", 1, 0.0, 3387.0),
            ("GLOBAL_IDS_POINTS", 1, 0.0, 3387.0),
        ],
        cell_data: &[
            ("DENSITY", 1, 2600.0, 2700.0),
            ("BULKMOD", 1, 4.5e9, 5.5e9),
            ("PORO", 1, 0.1, 0.075),
            ("NTG", 1, 0.9, 0.9),
            ("PERM", 3, 3e-16, 1e-16),
            ("vtkOriginalCellIds", 1, 0.0, 1629.0),
            ("GLOBAL_IDS_CELLS", 1, 0.0, 1629.0),
        ],
        first_point: [0.0, 0.0, 0.0],
        last_point: [1.0, 1.0, 1.0],
    },
    Expect {
        file: "geos/box_hybrid_mesh.vtu",
        points: 3655,
        cells: 9407,
        types: &[(10, 7949), (12, 943), (14, 515)],
        point_data: &[],
        cell_data: &[("attribute", 1, 5.0, 2.0)],
        first_point: [15.402015686035156, 14.304766654968262, -2.6573739051818848],
        last_point: [14.132420539855957, 13.857866287231445, -5.400000095367432],
    },
    Expect {
        file: "geos/synthetic.vtu",
        points: 24578,
        cells: 135957,
        types: &[(10, 135957)],
        point_data: &[],
        cell_data: &[("attribute", 1, 1.0, 3.0)],
        first_point: [0.0, 10000.0, -500.0],
        last_point: [9675.341282743519, 2518.414352866751, -1542.8695348],
    },
    Expect {
        file: "geos/hybridHexPrismMesh.vtk",
        points: 660,
        cells: 300,
        types: &[(12, 70), (15, 100), (16, 130)],
        point_data: &[],
        cell_data: &[("attribute", 1, 0.0, 2.0)],
        first_point: [0.0, 0.2278207, 0.0],
        last_point: [f64::NAN; 3],
    },
    Expect {
        file: "geos/supportedElements.vtk",
        points: 143,
        cells: 12,
        types: &[
            (10, 1),
            (11, 1),
            (12, 1),
            (13, 1),
            (14, 1),
            (15, 1),
            (16, 1),
            (42, 5),
        ],
        point_data: &[],
        cell_data: &[("attribute", 1, 0.0, 10.0)],
        first_point: [-1.49982, -1.19425, 0.634363],
        last_point: [f64::NAN; 3],
    },
    Expect {
        file: "pyvista/AngularSector.vtk",
        points: 10141,
        cells: 7776,
        types: &[(12, 7632), (14, 144)],
        point_data: &[("PointId", 1, 2874.0, 9126.0)],
        cell_data: &[("CellId", 1, 2592.0, 7775.0)],
        first_point: [0.104, 0.0, 0.0],
        last_point: [f64::NAN; 3],
    },
    Expect {
        file: "pyvista/PentaHexa.vtk",
        points: 401,
        cells: 210,
        types: &[(15, 60), (16, 150)],
        point_data: &[("scalar2", 1, 0.0, 1.0)],
        cell_data: &[("scalar1", 1, 1.0, 210.0)],
        first_point: [0.0, 0.0, 0.0],
        last_point: [f64::NAN; 3],
    },
    Expect {
        // One cell of each linear type 1, 3..12 (0D-2D cells included).
        file: "pyvista/VTKCellTypes.vtk",
        points: 27,
        cells: 11,
        types: &[
            (1, 1),
            (3, 1),
            (4, 1),
            (5, 1),
            (6, 1),
            (7, 1),
            (8, 1),
            (9, 1),
            (10, 1),
            (11, 1),
            (12, 1),
        ],
        point_data: &[("scalars", 1, 0.0, 26.0), ("vectors", 3, 1.0, 1.0)],
        cell_data: &[("scalars", 1, 0.0, 10.0)],
        first_point: [0.0, 0.0, 0.0],
        last_point: [2.0, 1.0, 6.0],
    },
    Expect {
        file: "pyvista/uGridEx.vtk",
        points: 27,
        cells: 12,
        types: &[
            (1, 1),
            (3, 2),
            (5, 2),
            (6, 1),
            (7, 1),
            (9, 1),
            (10, 2),
            (12, 2),
        ],
        point_data: &[("scalars", 1, 0.0, 26.0), ("vectors", 3, 1.0, 1.0)],
        cell_data: &[],
        first_point: [0.0, 0.0, 0.0],
        last_point: [2.0, 1.0, 6.0],
    },
    Expect {
        file: "pyvista/hexa.vtk",
        points: 12167,
        cells: 10648,
        types: &[(12, 10648)],
        point_data: &[("scalars", 1, 17.320508, 15.814377)],
        cell_data: &[],
        first_point: [0.0, 0.0, 0.0],
        last_point: [f64::NAN; 3],
    },
    Expect {
        file: "structured/SampleStructGrid.vtk",
        points: 24000,
        cells: 19 * 29 * 39,
        types: &[],
        point_data: &[("scalars", 1, 0.0, 1.30456)],
        cell_data: &[("scalars", 1, 1.0, -0.262933)],
        first_point: [3.90799e-16, 9.85395e-06, 0.00041631],
        last_point: [0.983481, 0.726099, 0.481848],
    },
];

fn close(a: f64, b: f64) -> bool {
    (a.is_nan() && b.is_nan()) || (a - b).abs() <= 1e-6 * a.abs().max(b.abs()).max(1e-300)
}

fn check_props(
    file: &str,
    kind: &str,
    got: &[Property],
    want: &[(&str, usize, f64, f64)],
    n: usize,
) {
    let names: Vec<&str> = got.iter().map(|p| p.name.as_str()).collect();
    let want_names: Vec<&str> = want.iter().map(|w| w.0).collect();
    assert_eq!(names, want_names, "{file}: {kind} data names");
    for (p, &(name, comps, first, last)) in got.iter().zip(want) {
        assert_eq!(p.components, comps, "{file}: {name} components");
        assert_eq!(p.len(), n, "{file}: {name} tuples");
        let (f, l) = (p.values[0], p.values[p.values.len() - 1]);
        assert!(
            close(f, first) && close(l, last),
            "{file}: {name} first/last {f} {l}, expected {first} {last}"
        );
    }
}

fn histogram(g: &Grid) -> Vec<(u8, usize)> {
    let mut h = BTreeMap::new();
    if let Topology::Unstructured(c) = &g.topology {
        for &t in &c.types {
            *h.entry(t).or_insert(0) += 1;
        }
    }
    h.into_iter().collect()
}

#[test]
fn real_files_counts_types_and_properties() {
    let Some(dir) = support::data_dir("real_files_counts_types_and_properties") else {
        return;
    };
    for e in REAL {
        let t = std::time::Instant::now();
        let g = read_ok(&dir.join(e.file));
        eprintln!("{}: read in {:?}", e.file, t.elapsed());
        assert_eq!(g.points.len(), e.points, "{}: points", e.file);
        assert_eq!(g.cell_count(), e.cells, "{}: cells", e.file);
        assert_eq!(histogram(&g), e.types, "{}: cell types", e.file);
        check_props(e.file, "point", &g.point_data, e.point_data, e.points);
        check_props(e.file, "cell", &g.cell_data, e.cell_data, e.cells);
        for (got, want) in [
            (g.points[0], e.first_point),
            (g.points[e.points - 1], e.last_point),
        ] {
            if !want[0].is_nan() {
                assert!(
                    (0..3).all(|a| close(got[a], want[a])),
                    "{}: point {got:?} vs {want:?}",
                    e.file
                );
            }
        }
    }
}

#[test]
fn real_structured_grid_dims() {
    let Some(dir) = support::data_dir("real_structured_grid_dims") else {
        return;
    };
    let g = read_ok(&dir.join("structured/SampleStructGrid.vtk"));
    assert_eq!(g.topology, Topology::Structured { dims: [20, 30, 40] });
}

#[test]
fn real_legacy_polyhedra_face_streams() {
    let Some(dir) = support::data_dir("real_legacy_polyhedra_face_streams") else {
        return;
    };
    let g = read_ok(&dir.join("geos/supportedElements.vtk"));
    let Topology::Unstructured(c) = &g.topology else {
        panic!()
    };
    // Cell 7 is the first polyhedron: "52 9 7 53 54 55 56 57 58 59 7 60 ..." in the file.
    assert_eq!(c.types[7], 42);
    let s = c.faces_of(7);
    assert_eq!(s.len(), 52);
    assert_eq!(s[..11], [9, 7, 53, 54, 55, 56, 57, 58, 59, 7, 60]);
    assert_eq!(c.cell(7), (53..=66).collect::<Vec<u32>>());
    // Typed cells keep their order; e.g. the tetrahedron is cell 0.
    assert_eq!(c.cell(0), &[0, 1, 2, 3]);
    assert!(c.faces_of(0).is_empty());
    // Last polyhedron ends with face "4 131 121 132 142".
    assert_eq!(
        c.faces_of(11)[c.faces_of(11).len() - 5..],
        [4, 131, 121, 132, 142]
    );
}

#[test]
fn real_vtu_polyhedra_face_streams() {
    let Some(dir) = support::data_dir("real_vtu_polyhedra_face_streams") else {
        return;
    };
    let g = read_ok(&dir.join("geos/pebi3d_with_properties.vtu"));
    let Topology::Unstructured(c) = &g.topology else {
        panic!()
    };
    assert_eq!(c.face_stream.len(), 67470, "faces array length in the file");
    assert_eq!(c.faces_of(0)[..3], [7, 5, 194]);
    assert_eq!(c.faces_of(0).len(), 38);
    assert_eq!(
        c.cell(0),
        &[194, 195, 216, 227, 229, 502, 503, 524, 535, 537]
    );
    assert_eq!(
        c.cell(1629),
        &[3058, 3059, 3078, 3079, 3366, 3367, 3386, 3387]
    );
}

#[test]
fn real_data_dir_is_fully_covered() {
    let Some(dir) = support::data_dir("real_data_dir_is_fully_covered") else {
        return;
    };
    let mut found = Vec::new();
    for sub in ["geos", "pyvista", "structured"] {
        for entry in std::fs::read_dir(dir.join(sub)).unwrap() {
            let name = entry.unwrap().file_name().to_string_lossy().into_owned();
            if [".vtk", ".vtu", ".vts"].iter().any(|e| name.ends_with(e)) {
                found.push(format!("{sub}/{name}"));
            }
        }
    }
    found.sort();
    let mut known: Vec<String> = REAL.iter().map(|e| e.file.to_string()).collect();
    known.sort();
    assert_eq!(
        found, known,
        "every VTK file in the data directory has expectations"
    );
}

/// A `vtkGhostType` cell array of two components (tuples (0, 32) and
/// (0, 0)): read flat, its values 0, 32 would hide cell 1, read by
/// component 0 no cell. VTK's ghost array has one component, so the readers
/// (legacy FIELD, XML DataArray) and the array path refuse it, naming the
/// array and its component count.
#[test]
fn multi_component_ghost_array_is_refused() {
    let xml = std::fs::read_to_string(fixture("a_ascii.vtu")).unwrap();
    let two = xml.replace(
        "<DataArray type=\"UInt8\" Name=\"vtkGhostType\" format=\"ascii\">\n  0 32",
        "<DataArray type=\"UInt8\" Name=\"vtkGhostType\" NumberOfComponents=\"2\" format=\"ascii\">\n  0 32 0 0",
    );
    assert_ne!(two, xml, "fixture layout changed");
    let e = xml_err(&two);
    assert!(
        e.contains("vtkGhostType") && e.contains("2 components"),
        "{e}"
    );
    let legacy = std::fs::read_to_string(fixture("a_legacy_ascii_42.vtk")).unwrap();
    let two = legacy.replace(
        "vtkGhostType 1 2 unsigned_char\n0 32",
        "vtkGhostType 2 2 unsigned_char\n0 32 0 0",
    );
    assert_ne!(two, legacy, "fixture layout changed");
    let e = legacy_err(&two);
    assert!(
        e.contains("vtkGhostType") && e.contains("2 components"),
        "{e}"
    );
    // The one-component array still hides cell 1 only.
    let g = parse_vtk_xml(xml.as_bytes(), "a.vtu").unwrap();
    assert_eq!(g.hidden_cells().unwrap(), vec![false, true]);
    // In-memory grids (Python's from_arrays) go through the same check.
    let mut g = g;
    let ghost = g
        .cell_data
        .iter_mut()
        .find(|p| p.name == "vtkGhostType")
        .unwrap();
    *ghost = Property {
        name: "vtkGhostType".into(),
        components: 2,
        values: vec![0.0, 32.0, 0.0, 0.0],
    };
    let e = g.validate().unwrap_err().to_string();
    assert!(
        e.contains("vtkGhostType") && e.contains("2 components"),
        "{e}"
    );
    // Read without validation, component 0 decides: no cell hidden.
    assert_eq!(g.hidden_cells().unwrap(), vec![false, false]);
}
