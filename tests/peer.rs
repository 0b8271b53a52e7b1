//! Slice areas against VTK's plane cutter (../shared/peer/vtk_slices.py),
//! run through the Python named by STRATASWEEP_PEER_PYTHON.

use std::path::PathBuf;
use std::process::Command;

use stratasweep::field::FieldSpec;
use stratasweep::pipeline::{LevelSpec, SliceRequest, Structure, StructureChoice, slice};

fn peer() -> Option<(String, PathBuf)> {
    let py = std::env::var("STRATASWEEP_PEER_PYTHON").ok()?;
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/peer/vtk_slices.py");
    script.exists().then_some((py, script))
}

fn compare(
    grid_path: &std::path::Path,
    grid: &stratasweep::grid::Grid,
    axis: usize,
    count: usize,
    tol: f64,
) {
    let Some((py, script)) = peer() else {
        eprintln!(
            "SKIP peer comparison: STRATASWEEP_PEER_PYTHON not set or ../shared/peer missing"
        );
        return;
    };
    // In the temp dir, never beside the grid (real grids sit in shared data).
    let json = std::env::temp_dir().join(format!(
        "peer-{}-{}-{axis}.json",
        std::process::id(),
        grid_path.file_stem().unwrap().to_string_lossy()
    ));
    let out = Command::new(&py)
        .arg(&script)
        .arg(grid_path)
        .args([
            "--axis",
            ["x", "y", "z"][axis],
            "--count",
            &count.to_string(),
            "--json",
        ])
        .arg(&json)
        .output()
        .expect("run peer");
    assert!(
        out.status.success(),
        "peer failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let _ = std::fs::remove_file(&json);
    let s = Structure::build(grid, StructureChoice::Auto).unwrap();
    let req = SliceRequest {
        field: FieldSpec::Axis {
            axis,
            negative: false,
        },
        levels: LevelSpec::Count(count),
        attribute: None,
        threads: 1,
        brute_force: false,
        collect_mesh: false,
    };
    let r = slice(grid, &s, &req, &|_| {}).unwrap();
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
    let p = std::env::temp_dir().join(format!("peer-warped-{}.vts", std::process::id()));
    stratasweep::io::writers::write_vtk_xml_grid(&p, &g).unwrap();
    for axis in 0..3 {
        compare(&p, &g, axis, 25, 1e-5);
    }
    let _ = std::fs::remove_file(&p);
}

#[test]
fn zoo_grid_areas_match_vtk() {
    let g = stratasweep::generate::zoo(4000, 9);
    let p = std::env::temp_dir().join(format!("peer-zoo-{}.vtu", std::process::id()));
    stratasweep::io::writers::write_vtk_xml_grid(&p, &g).unwrap();
    compare(&p, &g, 2, 30, 1e-5);
    let _ = std::fs::remove_file(&p);
}

#[test]
fn real_grids_areas_match_vtk() {
    let Ok(data) = std::env::var("STRATASWEEP_DATA") else {
        eprintln!("SKIP real-grid peer comparison: STRATASWEEP_DATA not set");
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
