//! Corner-point grids from files and generators: the real grids (Reek
//! GRDECL/EGRID, SPE9, SPE10) from `STRATASWEEP_DATA` (bulk volume against
//! xtgeo, Cavalieri, EGRID = GRDECL), generated faulted grids (round trip,
//! fault geometry, read by xtgeo), and the CGraph's neighbours against a
//! brute-force face matching.

use crate::support;
use crate::support::{axis_request, data_dir, sweep_matches_brute_force};

use stratasweep::cornerpoint::CornerPointGrid;
use stratasweep::grid::{Topology, vtk_type};
use stratasweep::pipeline::{SliceRequest, slice};
use stratasweep::structures::{Structure, StructureChoice};

fn reek(data: &std::path::Path) -> stratasweep::io::grdecl::GrdeclDeck {
    stratasweep::io::grdecl::read_grdecl(data.join("reek/2_R001_REEK-0.DATA")).unwrap()
}

#[test]
fn reek_grdecl_counts_volume_and_cavalieri() {
    let Some(data) = data_dir("reek_grdecl_counts_volume_and_cavalieri") else {
        return;
    };
    let deck = reek(&data);
    let cp = &deck.grid;
    assert_eq!(cp.dims, [40, 64, 14]);
    let names: Vec<&str> = cp.properties.iter().map(|p| p.name.as_str()).collect();
    // The GRID section's MULTIPLY (PERMZ × 0.3) and EQUALS (MULTZ) apply.
    assert_eq!(names, ["PORO", "PERMX", "PERMY", "PERMZ", "MULTZ"]);
    assert!(
        !deck
            .skipped
            .iter()
            .any(|s| s == "MULTIPLY" || s == "EQUALS")
    );
    let raw = stratasweep::io::grdecl::read_grdecl_from(
        format!(
            "INCLUDE\n '{}' /\nINCLUDE\n '{}' /\n",
            data.join("reek/reek.grid").display(),
            data.join("reek/reek.perm").display()
        )
        .as_bytes(),
        std::path::Path::new("raw.grdecl"),
    )
    .unwrap();
    let raw_z: Vec<f64> = raw.grid.properties[2]
        .values
        .iter()
        .map(|v| v * 0.3)
        .collect();
    assert_eq!(raw.grid.properties[2].name, "PERMZ");
    assert_eq!(cp.properties[3].values, raw_z);
    let (grid, rep) = cp.to_grid().unwrap();
    assert_eq!((rep.active, rep.inactive), (35_820, 20));
    assert_eq!(
        rep.hexahedra + rep.wedges + rep.pyramids + rep.tetrahedra + rep.polyhedra,
        grid.cell_count()
    );
    assert_eq!(rep.zero_volume + grid.cell_count(), rep.active);
    // xtgeo 4.27.0, exact same file set, obtained with
    //   .venv-xtgeo/bin/python -c "import xtgeo; g = xtgeo.grid_from_file(
    //     '/work/shared/data/reek/reek.grid', fformat='grdecl');
    //     print(repr(float(g.get_bulk_volume(precision=4).values.sum())))"
    // → 2586939031.414506 (precision=2 gives 2587149873.970394).
    let xtgeo = 2_586_939_031.414_506;
    let rel = (rep.bulk_volume - xtgeo).abs() / xtgeo;
    eprintln!(
        "Reek bulk volume {} vs xtgeo {xtgeo}: rel {rel:.3e}",
        rep.bulk_volume
    );
    assert!(rel < 1e-5, "relative difference {rel}");
    assert!((cp.bulk_volume() - rep.bulk_volume).abs() < 1e-6 * xtgeo);
    // Every output cell is valid for the sweep (none inverted or degenerate).
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let Structure::CGraph(cg) = &s else { panic!() };
    // Non-convex polyhedra are split: the CGraph counts pieces, live_cells input cells.
    assert_eq!(
        cg.class_counts[1..],
        [0, 0, 0, 0, 0],
        "{:?}",
        cg.class_counts
    );
    assert_eq!(s.live_cells(), grid.cell_count());
    // Every emitted polygon has at least 3 vertices (pinched cells included).
    let req = SliceRequest {
        attribute: Some("PORO".into()),
        collect_mesh: true,
        ..axis_request(2, 50)
    };
    let m = slice(&grid, &s, &req, &|_| {}).unwrap().mesh.unwrap();
    assert!((0..m.polygon_count()).all(|p| m.polygon(p).len() >= 3));
    // Cavalieri: Σ area_k · Δ → bulk volume.
    let mut errs = Vec::new();
    for k in [50, 400] {
        let req = axis_request(2, k);
        let r = slice(&grid, &s, &req, &|_| {}).unwrap();
        let dz = r.level_values[1] - r.level_values[0];
        let v: f64 = r.stats.iter().map(|s| s.area).sum::<f64>() * dz;
        let e = (v - rep.bulk_volume).abs() / rep.bulk_volume;
        eprintln!(
            "Cavalieri K={k}: {v} vs {}: rel error {e:.3e}",
            rep.bulk_volume
        );
        errs.push(e);
    }
    assert!(errs[1] < 5e-3, "{errs:?}");
    assert!(errs[1] <= errs[0] + 1e-4, "no convergence: {errs:?}");
}

#[test]
fn reek_egrid_matches_grdecl() {
    let Some(data) = data_dir("reek_egrid_matches_grdecl") else {
        return;
    };
    let g = reek(&data).grid;
    let e = stratasweep::io::egrid::read_egrid(data.join("reek/2_R001_REEK-0.EGRID"))
        .unwrap()
        .grid;
    assert_eq!(e.dims, g.dims);
    let f32_close =
        |a: f64, b: f64| (a - b).abs() <= (a.abs().max(b.abs()) as f32 * f32::EPSILON) as f64;
    for (i, (&a, &b)) in g.coord.iter().zip(&e.coord).enumerate() {
        assert!(f32_close(a, b), "COORD[{i}]: {a} vs {b}");
    }
    for (i, (&a, &b)) in g.zcorn.iter().zip(&e.zcorn).enumerate() {
        assert!(f32_close(a, b), "ZCORN[{i}]: {a} vs {b}");
    }
    let (ma, mb) = (g.mapaxes.unwrap(), e.mapaxes.unwrap());
    for a in 0..6 {
        assert!(f32_close(ma[a], mb[a]));
    }
    // World corners agree to f32 rounding of UTM coordinates.
    for c in (0..g.cell_count()).step_by(97) {
        let (i, j, k) = (c % 40, c / 40 % 64, c / 2560);
        let (p, q) = (g.cell_corners(i, j, k), e.cell_corners(i, j, k));
        for n in 0..8 {
            for a in 0..3 {
                assert!(
                    (p[n][a] - q[n][a]).abs() <= 2.0 * (p[n][a].abs() as f32 * f32::EPSILON) as f64,
                    "cell {c} corner {n}: {:?} vs {:?}",
                    p[n],
                    q[n]
                );
            }
        }
    }
    // Active cells: the simulator deactivated 3 more cells than the GRDECL's
    // ACTNUM (35,817 vs 35,820, as xtgeo also reports); every EGRID-active
    // cell is GRDECL-active.
    let ga = g.actnum.as_ref().unwrap();
    let ea = e.actnum.as_ref().unwrap();
    let only_grdecl: Vec<usize> = (0..ga.len())
        .filter(|&c| ga[c] == 1 && ea[c] == 0)
        .collect();
    let only_egrid = (0..ga.len()).filter(|&c| ga[c] == 0 && ea[c] == 1).count();
    eprintln!("cells active in GRDECL only: {only_grdecl:?}");
    assert_eq!((only_grdecl.len(), only_egrid), (3, 0));
    // xtgeo 4.27.0 on the EGRID, get_bulk_volume(precision=4): 2586747007.9955997.
    let (_, rep) = e.to_grid().unwrap();
    let rel = (rep.bulk_volume - 2_586_747_007.995_599_7).abs() / 2.586_747e9;
    assert!(rel < 1e-5, "{rel}");
}

#[test]
fn spe9_and_spe10_load() {
    let Some(data) = data_dir("spe9_and_spe10_load") else {
        return;
    };
    let d = stratasweep::io::grdecl::read_grdecl(data.join("spe9/SPE9_CP.DATA")).unwrap();
    let (grid, rep) = d.grid.to_grid().unwrap();
    assert_eq!(
        (d.grid.dims, grid.cell_count(), rep.hexahedra),
        ([24, 25, 15], 9000, 9000)
    );
    let names: Vec<&str> = d.grid.properties.iter().map(|p| p.name.as_str()).collect();
    // PERMY and PERMZ come from the deck's COPY (and MULTIPLY).
    assert_eq!(names, ["PORO", "PERMX", "PERMY", "PERMZ"]);
    assert_eq!(d.grid.properties[0].values[0], 0.087);
    assert_eq!(d.grid.properties[0].values[8999], 0.157);
    let d =
        stratasweep::io::grdecl::read_grdecl(data.join("spe10m1/SPE10_MODEL1_CP.DATA")).unwrap();
    let (grid, rep) = d.grid.to_grid().unwrap();
    assert_eq!((d.grid.dims, grid.cell_count()), ([100, 1, 20], 2000));
    // 2000 cells of 25 ft × 25 ft × 2.5 ft.
    assert!((rep.bulk_volume - 2000.0 * 25.0 * 25.0 * 2.5).abs() < 1e-6);
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    assert_eq!(s.live_cells(), 2000);
}

/// Slice areas × spacing (evenly spaced levels) within `tol` (relative)
/// of `volume`.
fn assert_cavalieri(r: &stratasweep::pipeline::SliceResult, volume: f64, tol: f64, what: &str) {
    let d = r.level_values[1] - r.level_values[0];
    let v: f64 = r.stats.iter().map(|s| s.area).sum::<f64>() * d;
    assert!(
        (v - volume).abs() / volume < tol,
        "{what}: Cavalieri {v} vs {volume}"
    );
}

/// `g` written as GRDECL and read back.
fn grdecl_round_trip(g: &CornerPointGrid) -> CornerPointGrid {
    let mut buf = Vec::new();
    stratasweep::io::grdecl::write_grdecl(&mut buf, g).unwrap();
    stratasweep::io::grdecl::read_grdecl_from(&buf[..], std::path::Path::new("gen.grdecl"))
        .unwrap()
        .grid
}

#[test]
fn generated_faulted_grid_round_trips_and_sweeps() {
    let g = stratasweep::generate::faulted([30, 20, 12], 3, 7);
    assert_eq!(grdecl_round_trip(&g), g);
    let (grid, rep) = g.to_grid().unwrap();
    assert!(
        rep.inactive > 0 && rep.wedges > 0 && rep.polyhedra > 0 && rep.hexahedra > 0,
        "{rep:?}"
    );
    assert_eq!(rep.inverted, 0);
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let Structure::CGraph(cg) = &s else { panic!() };
    // Non-convex polyhedra are split: the CGraph counts pieces, live_cells input cells.
    assert_eq!(
        cg.class_counts[1..],
        [0, 0, 0, 0, 0],
        "{:?}",
        cg.class_counts
    );
    assert_eq!(s.live_cells(), grid.cell_count());
    // The sweep cuts exactly the cells the brute force cuts, on a faulted grid.
    let mut req = SliceRequest {
        attribute: Some("PORO".into()),
        ..axis_request(2, 40)
    };
    let a = slice(&grid, &s, &req, &|_| {}).unwrap();
    req.brute_force = true;
    let b = slice(&grid, &s, &req, &|_| {}).unwrap();
    let cells = |r: &stratasweep::pipeline::SliceResult| {
        r.stats.iter().map(|s| s.cells).collect::<Vec<_>>()
    };
    assert_eq!(cells(&a), cells(&b));
    // Cavalieri on the generated grid too.
    assert_cavalieri(&a, rep.bulk_volume, 0.02, "generated");
}

/// Horizontal lean (per unit depth) of the pillars that carry a fault: a
/// pillar is on a fault when two cells of one layer around it give it
/// different depths.
fn fault_pillar_leans(g: &CornerPointGrid) -> Vec<f64> {
    let [nx, ny, nz] = g.dims;
    let mut out = Vec::new();
    for pj in 0..=ny {
        for pi in 0..=nx {
            let mut faulted = false;
            for k in 0..nz {
                let mut seen: Option<f64> = None;
                for (ci, ii) in [(pi.wrapping_sub(1), 1), (pi, 0)] {
                    for (cj, jj) in [(pj.wrapping_sub(1), 1), (pj, 0)] {
                        if ci >= nx || cj >= ny {
                            continue;
                        }
                        let z = g.zcorn[g.zcorn_index(ci, cj, k, ii + 2 * jj)];
                        faulted |= seen.is_some_and(|s| s != z);
                        seen = Some(z);
                    }
                }
            }
            if faulted {
                let c = &g.coord[6 * (pi + (nx + 1) * pj)..][..6];
                out.push(((c[3] - c[0]).hypot(c[4] - c[1])) / (c[5] - c[2]));
            }
        }
    }
    out
}

#[test]
fn generated_faults_vertical_or_inclined() {
    for (dip, seed) in [
        (Some(90.0), 3),
        (Some(60.0), 3),
        (Some(45.0), 11),
        (None, 5),
    ] {
        let g = stratasweep::generate::faulted_with_dip([30, 20, 12], 3, dip, seed);
        let leans = fault_pillar_leans(&g);
        assert!(!leans.is_empty(), "{dip:?}: no fault pillar");
        let mut sorted = leans.clone();
        sorted.sort_by(f64::total_cmp);
        let (min, median, max) = (
            sorted[0],
            sorted[sorted.len() / 2],
            sorted[sorted.len() - 1],
        );
        match dip {
            // Only the grid's slight global tilt (≤ 40 m over 1000 m).
            Some(90.0) => assert!(max <= 0.06, "vertical faults lean {max}"),
            // cot(dip) on the traces (other faults' fading leans perturb a
            // few pillars), never more (+ the global tilt).
            Some(d) => {
                let cot = 1.0 / f64::to_radians(d).tan();
                assert!(
                    median > 0.9 * cot && max < cot + 0.06,
                    "dip {d}: fault pillars lean {min}..{max}, median {median}, cot = {cot}"
                );
            }
            // The default mix: a vertical fault and inclined ones.
            None => assert!(min <= 0.06 && max > 0.15, "mix: leans {min}..{max}"),
        }
        // Inclined pillars are written and read back exactly.
        assert_eq!(grdecl_round_trip(&g), g, "{dip:?}");
        // No cell turns over; the sweep cuts what the brute force cuts.
        let (grid, rep) = g.to_grid().unwrap();
        assert_eq!(rep.inverted, 0, "{dip:?}: {rep:?}");
        let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
        let Structure::CGraph(cg) = &s else { panic!() };
        // Every piece is a good cell (non-convex cells are split, so the
        // counts are of pieces) and every input cell is live.
        assert_eq!(cg.class_counts[1..], [0, 0, 0, 0, 0], "{dip:?}");
        assert_eq!(s.live_cells(), grid.cell_count(), "{dip:?}");
        for axis in [0, 2] {
            let a = sweep_matches_brute_force(&grid, &s, axis, 60, &format!("{dip:?}"));
            assert_cavalieri(&a, rep.bulk_volume, 0.02, &format!("{dip:?} axis {axis}"));
        }
    }
}

#[test]
fn generated_faulted_grids_read_by_xtgeo() {
    let Some(py) = support::xtgeo_python("generated_faulted_grids_read_by_xtgeo") else {
        return;
    };
    let dir = support::tmp_dir("xtgeo");
    let cases = [(None, 5), (Some(90.0), 3), (Some(45.0), 11)];
    let mut files = Vec::new();
    let mut ours = Vec::new();
    for (n, &(dip, seed)) in cases.iter().enumerate() {
        let g = stratasweep::generate::faulted_with_dip([30, 20, 12], 3, dip, seed);
        let path = dir.join(format!("f{n}.grdecl"));
        let mut f = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
        stratasweep::io::grdecl::write_grdecl(&mut f, &g).unwrap();
        drop(f);
        let (_, rep) = g.to_grid().unwrap();
        files.push(path);
        ours.push(rep);
    }
    let script = "import sys, json, numpy as np, xtgeo\n\
        out = []\n\
        for p in sys.argv[1:]:\n\
        \x20   g = xtgeo.grid_from_file(p, fformat='grdecl')\n\
        \x20   v = g.get_bulk_volume(asmasked=True, precision=4).values\n\
        \x20   out.append([g.ncol, g.nrow, g.nlay, int(g.nactive), float(np.ma.sum(v))])\n\
        print(json.dumps(out))\n";
    let out = std::process::Command::new(&py)
        .arg("-c")
        .arg(script)
        .args(&files)
        .output()
        .expect("run xtgeo");
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(
        out.status.success(),
        "xtgeo failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Vec<(usize, usize, usize, usize, f64)> =
        serde_json::from_slice(&out.stdout).expect("xtgeo JSON");
    for ((dip, _), (x, rep)) in cases.iter().zip(v.iter().zip(&ours)) {
        assert_eq!((x.0, x.1, x.2), (30, 20, 12), "{dip:?}");
        assert_eq!(x.3, rep.active, "{dip:?}: active cells");
        let rel = (x.4 - rep.bulk_volume).abs() / rep.bulk_volume;
        eprintln!(
            "dip {dip:?}: bulk volume {} vs xtgeo {} (relative {rel:.2e})",
            rep.bulk_volume, x.4
        );
        assert!(rel < 1e-5, "{dip:?}: {} vs xtgeo {}", rep.bulk_volume, x.4);
    }
}

/// Per cell, per face (catalog order) the neighbour a brute force expects:
/// the smallest other live cell with a face of exactly the same vertex set
/// (`NONE` without one, and for dead cells).
fn brute_force_neighbours(g: &stratasweep::structures::cgraph::CGraph) -> Vec<Vec<u32>> {
    use std::collections::HashMap;
    use stratasweep::sweep::CellGraph;
    let none = stratasweep::structures::cgraph::NONE;
    let mut ids = [0u32; 12];
    let faces_of = |c: u32, ids: &mut [u32; 12]| -> Vec<Vec<u32>> {
        let (m, n) = g.cell(c, ids);
        if n == 0 {
            return Vec::new();
        }
        g.catalog
            .get(m)
            .faces
            .iter()
            .map(|f| {
                let mut k: Vec<u32> = f.iter().map(|&l| ids[l as usize]).collect();
                k.sort_unstable();
                k
            })
            .collect()
    };
    let mut by_set: HashMap<Vec<u32>, Vec<u32>> = HashMap::new();
    for c in 0..g.cell_count() as u32 {
        if g.is_live(c) {
            for k in faces_of(c, &mut ids) {
                by_set.entry(k).or_default().push(c);
            }
        }
    }
    (0..g.cell_count() as u32)
        .map(|c| {
            let live = g.is_live(c);
            faces_of(c, &mut ids)
                .into_iter()
                .map(|k| {
                    let others = by_set[&k].iter().filter(|&&d| d != c);
                    match (live, others.min()) {
                        (true, Some(&d)) => d,
                        _ => none,
                    }
                })
                .collect()
        })
        .collect()
}

fn assert_neighbours_brute_force(g: &stratasweep::structures::cgraph::CGraph, what: &str) -> usize {
    let want = brute_force_neighbours(g);
    let mut sewn = 0;
    for (c, w) in want.iter().enumerate() {
        let got = g.neighbours(c as u32);
        assert_eq!(&got, w, "{what}: neighbours of cell {c}");
        sewn += w
            .iter()
            .filter(|&&d| d != stratasweep::structures::cgraph::NONE)
            .count();
    }
    assert_eq!(sewn, g.sewn_faces, "{what}: sewn face count");
    sewn
}

fn cgraph_of(
    grid: &stratasweep::grid::Grid,
) -> stratasweep::structures::convex_split::Split<stratasweep::structures::cgraph::CGraph> {
    match Structure::build(grid, StructureChoice::CGraph).unwrap() {
        Structure::CGraph(g) => g,
        _ => panic!("expected a CGraph"),
    }
}

/// The CGraph's face neighbours (each shared face searched once, written on
/// both sides) equal a brute-force matching of sorted face vertex sets, on
/// a generated faulted grid (split cells included), on a face shared by
/// three cells, and on Reek.
#[test]
fn cgraph_neighbours_match_brute_force_face_matching() {
    let (grid, _) = stratasweep::generate::faulted([12, 10, 6], 3, 5)
        .into_grid()
        .unwrap();
    let g = cgraph_of(&grid);
    let sewn = assert_neighbours_brute_force(&g, "faulted 12x10x6");
    assert!(sewn > 2 * g.cell_count(), "faulted: only {sewn} sewn faces");
    // One face (z = 1) shared by three hexahedra: cell 0 below it, cells 1
    // and 2 above it (tops at z = 2 and 3); cell 3 spans z = 2..3, so it
    // shares its bottom with cell 1 and its top with cell 2. The smallest
    // other cell wins.
    let mut points: Vec<[f64; 3]> = Vec::new();
    for z in [0.0, 1.0, 2.0, 3.0] {
        points.extend([[0.0, 0.0, z], [1.0, 0.0, z], [1.0, 1.0, z], [0.0, 1.0, z]]);
    }
    let hex = |b: u32, t: u32| [b, b + 1, b + 2, b + 3, t, t + 1, t + 2, t + 3];
    let mut cells = stratasweep::grid::Cells::default();
    for (b, t) in [(0, 4), (4, 8), (4, 12), (8, 12)] {
        cells.push(vtk_type::HEXAHEDRON, &hex(b, t));
    }
    let grid = stratasweep::grid::Grid {
        points,
        topology: Topology::Unstructured(cells),
        point_data: Vec::new(),
        cell_data: Vec::new(),
    };
    let g = cgraph_of(&grid);
    assert_neighbours_brute_force(&g, "three cells on one face");
    // VTK hexahedron faces 4 and 5 are the bottom and the top.
    let bottom_of = |c: u32| g.neighbours(c)[4];
    let top_of = |c: u32| g.neighbours(c)[5];
    assert_eq!((top_of(0), bottom_of(1), bottom_of(2)), (1, 0, 0));
    assert_eq!((top_of(1), bottom_of(3)), (3, 1));
    assert_eq!((top_of(2), top_of(3)), (3, 2));
    let Some(data) = data_dir("cgraph_neighbours_match_brute_force_face_matching (Reek)") else {
        return;
    };
    let e = stratasweep::io::egrid::read_egrid(data.join("reek/2_R001_REEK-0.EGRID")).unwrap();
    let (grid, _) = e.grid.into_grid().unwrap();
    let g = cgraph_of(&grid);
    assert!(g.map.is_some(), "Reek has non-convex cells to split");
    let sewn = assert_neighbours_brute_force(&g, "Reek");
    assert!(sewn > 4 * g.cell_count(), "Reek: only {sewn} sewn faces");
}
