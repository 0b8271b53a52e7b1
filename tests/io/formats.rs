//! One model, every format: a generated corner-point model with pinch-outs
//! written as GRDECL, EGRID (+ INIT) and VTU, and handed over as arrays the
//! way an explicit structured grid cast to an `UnstructuredGrid` holds it
//! (each cell owning its eight corners, pinched corners repeated by
//! position). Every route keeps the same cells (pinched ones typed as the
//! corner-point path types them) and reports the same bulk volume, which
//! agrees with xtgeo's.

use std::path::Path;

use stratasweep::cornerpoint::{CornerPointGrid, bulk_volume};
use stratasweep::grid::{Grid, Topology, vtk_type};
use stratasweep::io::vtk_read::{UnstructuredArrays, grid_from_arrays};
use stratasweep::report::{InfoContext, info_json};
use stratasweep::structures::{Structure, StructureChoice};

use crate::support;

/// VTK hexahedron vertex l is corner-point corner `VTK_TO_CP[l]`.
const VTK_TO_CP: [usize; 8] = [0, 1, 3, 2, 4, 5, 7, 6];

/// The generated model: 10×8×5, three faults, pinch-outs (wedges and
/// polyhedra), inactive cells; every coordinate rounded to f32, so that
/// EGRID (REAL arrays) holds the very numbers GRDECL and VTU hold.
fn model() -> CornerPointGrid {
    let mut g = stratasweep::generate::faulted([10, 8, 5], 3, 1);
    let f32s = |v: &mut [f64]| v.iter_mut().for_each(|x| *x = *x as f32 as f64);
    f32s(&mut g.coord);
    f32s(&mut g.zcorn);
    if let Some(m) = g.mapaxes.as_mut() {
        f32s(m);
    }
    g
}

/// What `info` reports as the bulk volume (CLI and Python alike).
fn info_volume(grid: &Grid, cornerpoint: Option<serde_json::Value>) -> f64 {
    let s = Structure::build(grid, StructureChoice::Auto).unwrap();
    let ctx = InfoContext {
        name: "m".into(),
        cornerpoint,
        load_s: 0.0,
        build_s: 0.0,
        load_cpu_s: None,
        build_cpu_s: None,
    };
    info_json(grid, &s, &ctx)["bulk_volume"].as_f64().unwrap()
}

/// The arrays of an explicit structured grid cast to an unstructured grid:
/// per active cell a hexahedron owning its eight corners (VTK order).
fn cast_arrays(cp: &CornerPointGrid) -> (Vec<[f64; 3]>, Vec<i64>, Vec<i64>) {
    let [ni, nj, nk] = cp.dims;
    let (mut points, mut cells, mut types) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..nk {
        for j in 0..nj {
            for i in 0..ni {
                if !cp.is_active(i + ni * (j + nj * k)) {
                    continue;
                }
                let corners = cp.cell_corners(i, j, k);
                cells.push(8);
                for q in VTK_TO_CP {
                    cells.push(points.len() as i64);
                    points.push(corners[q]);
                }
                types.push(i64::from(vtk_type::HEXAHEDRON));
            }
        }
    }
    (points, cells, types)
}

fn type_counts(g: &Grid) -> [usize; 5] {
    let Topology::Unstructured(c) = &g.topology else {
        panic!("unstructured expected")
    };
    let hidden = g.hidden_cells().unwrap_or_else(|| vec![false; c.len()]);
    let mut n = [0; 5];
    for (k, t) in [
        vtk_type::HEXAHEDRON,
        vtk_type::WEDGE,
        vtk_type::PYRAMID,
        vtk_type::TETRA,
        vtk_type::POLYHEDRON,
    ]
    .into_iter()
    .enumerate()
    {
        n[k] = (0..c.len())
            .filter(|&i| !hidden[i] && c.types[i] == t)
            .count();
    }
    n
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// GRDECL, EGRID, VTU and the cast arrays: same kept cells by type, same
/// live cells in the sweep structure, and bulk volumes equal to 1e-9
/// (as `info` reports them and as the exact volume of the grid's cells).
#[test]
fn bulk_volume_and_cells_agree_across_formats() {
    let cp = model();
    let d = support::tmp_dir("formats");
    let (grdecl, egrid, vtu) = (d.join("M.grdecl"), d.join("M.EGRID"), d.join("M.vtu"));
    let mut text = Vec::new();
    stratasweep::io::grdecl::write_grdecl(&mut text, &cp).unwrap();
    std::fs::write(&grdecl, text).unwrap();
    let mut b = Vec::new();
    stratasweep::io::egrid_write::write_egrid(&mut b, &cp).unwrap();
    std::fs::write(&egrid, b).unwrap();
    let mut b = Vec::new();
    stratasweep::io::egrid_write::write_init(&mut b, &cp).unwrap();
    std::fs::write(d.join("M.INIT"), b).unwrap();
    let (zoo, rep) = cp.clone().into_grid().unwrap();
    stratasweep::io::writers::write_vtk_xml_grid(&vtu, &zoo).unwrap();
    // The model has pinch-outs and no dropped zero-volume cells.
    assert!(rep.wedges > 0 && rep.polyhedra > 0, "{rep:?}");
    assert_eq!(rep.zero_volume, 0);

    let loaded: Vec<_> = [&grdecl, &egrid, &vtu]
        .iter()
        .map(|p| stratasweep::io::load(p).unwrap())
        .collect();
    let (points, cells, types) = cast_arrays(&cp);
    let a = UnstructuredArrays {
        points: &points,
        cells: &cells,
        celltypes: &types,
    };
    let arrays = grid_from_arrays(a, vec![], vec![], false, "from_arrays").unwrap();
    let welded = grid_from_arrays(a, vec![], vec![], true, "from_arrays").unwrap();

    let reference = rep.bulk_volume;
    let mut grids: Vec<(&str, &Grid, Option<serde_json::Value>)> = vec![
        ("GRDECL", &loaded[0].grid, loaded[0].cornerpoint.clone()),
        ("EGRID", &loaded[1].grid, loaded[1].cornerpoint.clone()),
        ("VTU", &loaded[2].grid, None),
    ];
    grids.push(("arrays", &arrays, None));
    grids.push(("arrays, welded", &welded, None));
    let live0 = Structure::build(&zoo, StructureChoice::CGraph)
        .unwrap()
        .live_cells();
    for (what, g, cpj) in grids {
        let info = info_volume(g, cpj);
        let exact = bulk_volume(g);
        eprintln!("{what}: info bulk volume {info}, exact {exact} (reference {reference})");
        assert!(
            rel(info, reference) < 1e-9,
            "{what}: info {info} vs {reference}"
        );
        assert!(
            rel(exact, reference) < 1e-9,
            "{what}: {exact} vs {reference}"
        );
        assert_eq!(type_counts(g), type_counts(&zoo), "{what}");
        let hidden = g
            .hidden_cells()
            .map_or(0, |h| h.iter().filter(|&&x| x).count());
        assert_eq!(g.cell_count() - hidden, zoo.cell_count(), "{what}");
        let live = Structure::build(g, StructureChoice::CGraph)
            .unwrap()
            .live_cells();
        assert_eq!(live, live0, "{what}: cells the sweep keeps");
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// Without rounding to f32, GRDECL (full f64 text) and VTU (Float64) hold
/// the same numbers: their bulk volumes agree to 1e-9 too.
#[test]
fn grdecl_and_vtu_agree_on_the_raw_generator() {
    let cp = stratasweep::generate::faulted([9, 7, 6], 2, 5);
    let d = support::tmp_dir("formats-raw");
    let mut text = Vec::new();
    stratasweep::io::grdecl::write_grdecl(&mut text, &cp).unwrap();
    std::fs::write(d.join("R.grdecl"), text).unwrap();
    let (zoo, rep) = cp.into_grid().unwrap();
    stratasweep::io::writers::write_vtk_xml_grid(d.join("R.vtu"), &zoo).unwrap();
    let g = stratasweep::io::load(&d.join("R.grdecl")).unwrap();
    let v = stratasweep::io::load(&d.join("R.vtu")).unwrap();
    let gv = g.cornerpoint.as_ref().unwrap()["bulk_volume"]
        .as_f64()
        .unwrap();
    assert!(rel(gv, rep.bulk_volume) < 1e-12);
    assert!(rel(info_volume(&v.grid, None), gv) < 1e-9);
    assert_eq!(v.grid.cell_count(), g.grid.cell_count());
    let _ = std::fs::remove_dir_all(&d);
}

/// The model's bulk volume against xtgeo's on the same GRDECL file:
/// `grid_from_file(path, fformat="grdecl").get_bulk_volume(precision=4)`,
/// a tetrahedral decomposition rather than the exact trilinear volume, so
/// the two agree to 1e-4, not to rounding (xtgeo 4.27 on the model of
/// stop 25: 2.2e-5). Run with `STRATASWEEP_XTGEO_PYTHON` (set by `.ci/run`).
#[test]
fn bulk_volume_agrees_with_xtgeo() {
    let Some(py) = support::xtgeo_python("bulk_volume_agrees_with_xtgeo") else {
        return;
    };
    let cp = model();
    let (_, rep) = cp.clone().into_grid().unwrap();
    let d = support::tmp_dir("formats-xtgeo");
    let path = d.join("X.grdecl");
    let mut text = Vec::new();
    stratasweep::io::grdecl::write_grdecl(&mut text, &cp).unwrap();
    std::fs::write(&path, text).unwrap();
    let out = run_xtgeo(Path::new(&py), &path);
    let xtgeo: f64 = out.trim().parse().unwrap();
    let _ = std::fs::remove_dir_all(&d);
    let r = rel(rep.bulk_volume, xtgeo);
    eprintln!(
        "bulk volume {} vs xtgeo {xtgeo}: rel {r:.3e}",
        rep.bulk_volume
    );
    assert!(r < 1e-4, "{r}");
}

fn run_xtgeo(py: &Path, grdecl: &Path) -> String {
    let script = "import sys, xtgeo\n\
        g = xtgeo.grid_from_file(sys.argv[1], fformat='grdecl')\n\
        print(repr(float(g.get_bulk_volume(precision=4).values.sum())))\n";
    let out = std::process::Command::new(py)
        .arg("-c")
        .arg(script)
        .arg(grdecl)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}
