//! Slice areas against VTK's plane cutter (../shared/peer/vtk_slices.py),
//! run through the Python named by STRATASWEEP_PEER_PYTHON.

use std::path::PathBuf;

use stratasweep::pipeline::slice;
use stratasweep::structures::{Structure, StructureChoice};

use crate::support;

fn compare(
    grid_path: &std::path::Path,
    grid: &stratasweep::grid::Grid,
    axis: usize,
    count: usize,
    tol: f64,
) {
    let Some((py, script)) = support::peer::peer("peer comparison") else {
        return;
    };
    let v = support::peer::vtk_slices(&py, &script, grid_path, axis, count);
    let s = Structure::build(grid, StructureChoice::Auto).unwrap();
    let r = slice(grid, &s, &support::axis_request(axis, count), &|_| {}).unwrap();
    let peer_slices = v["slices"].as_array().unwrap();
    assert_eq!(peer_slices.len(), count);
    let mut worst = 0.0f64;
    for (k, ps) in peer_slices.iter().enumerate() {
        let (pa, pv) = (ps["area"].as_f64().unwrap(), ps["value"].as_f64().unwrap());
        let ours = r.stats[k].area;
        assert!(
            (pv - r.level_values[k]).abs() < 1e-6 * (1.0 + pv.abs()),
            "level {k}: {pv} vs {}",
            r.level_values[k]
        );
        let rel = (ours - pa).abs() / pa.max(1e-300);
        worst = worst.max(rel);
        assert!(
            rel < tol,
            "{}: slice {k} area {ours} vs VTK {pa} (rel {rel:e})",
            grid_path.display()
        );
    }
    eprintln!(
        "{}: axis {axis}, {count} slices, worst relative area difference vs VTK {worst:e}",
        grid_path.display()
    );
}

#[test]
fn warped_grid_areas_match_vtk() {
    let g = stratasweep::generate::warped([20, 24, 18], 5);
    let p = support::tmp("peer", "warped.vts");
    stratasweep::io::writers::write_vtk_xml_grid(&p, &g).unwrap();
    for axis in 0..3 {
        compare(&p, &g, axis, 25, 1e-5);
    }
    let _ = std::fs::remove_file(&p);
}

#[test]
fn zoo_grid_areas_match_vtk() {
    let g = stratasweep::generate::zoo(4000, 9);
    let p = support::tmp("peer", "zoo.vtu");
    stratasweep::io::writers::write_vtk_xml_grid(&p, &g).unwrap();
    compare(&p, &g, 2, 30, 1e-5);
    let _ = std::fs::remove_file(&p);
}

#[test]
fn real_grids_areas_match_vtk() {
    let Some(data) = support::data_dir("real_grids_areas_match_vtk") else {
        return;
    };
    for f in [
        "geos/box_hybrid_mesh.vtu",
        "pyvista/hexa.vtk",
        "structured/SampleStructGrid.vtk",
        "geos/synthetic.vtu",
    ] {
        let p = PathBuf::from(&data).join(f);
        let g = stratasweep::io::vtk_read::read_vtk(&p).unwrap();
        compare(&p, &g, 2, 20, 1e-5);
    }
}
