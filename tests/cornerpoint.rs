//! Corner-point geometry: analytic volumes of hand-built cells, welding and
//! faults, pinch-out classes, property averaging without bleeding across
//! faults, and the real grids (Reek GRDECL/EGRID, SPE9, SPE10) from
//! `STRATASWEEP_DATA`: bulk volume against xtgeo, Cavalieri, EGRID = GRDECL.

use std::path::PathBuf;

use stratasweep::cornerpoint::{CornerPointGrid, trilinear_volume};
use stratasweep::field::FieldSpec;
use stratasweep::grid::{Property, Topology, vtk_type};
use stratasweep::pipeline::{
    LevelSpec, SliceRequest, Structure, StructureChoice, slice, vertex_property,
};

fn data_dir(test: &str) -> Option<PathBuf> {
    match std::env::var_os("STRATASWEEP_DATA") {
        Some(d) => Some(PathBuf::from(d)),
        None => {
            eprintln!(
                "\n*** SKIP {test}: STRATASWEEP_DATA is not set (real grids not tested) ***\n"
            );
            None
        }
    }
}

/// An nx×ny×nz grid of vertical pillars on a unit lattice (optionally
/// sheared: bottom of each pillar moved by `shear`), with layer depths
/// `depth(i, j, k, corner)` from a closure.
fn build(
    dims: [usize; 3],
    shear: [f64; 2],
    depth: impl Fn(usize, usize, usize, usize) -> f64,
) -> CornerPointGrid {
    let [nx, ny, nz] = dims;
    let mut coord = Vec::new();
    for pj in 0..=ny {
        for pi in 0..=nx {
            coord.extend_from_slice(&[pi as f64, pj as f64, 0.0]);
            coord.extend_from_slice(&[pi as f64 + shear[0], pj as f64 + shear[1], 100.0]);
        }
    }
    let mut g = CornerPointGrid {
        dims,
        coord,
        zcorn: vec![0.0; 8 * nx * ny * nz],
        ..Default::default()
    };
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                for c in 0..8 {
                    let z = g.zcorn_index(i, j, k, c);
                    g.zcorn[z] = depth(i, j, k, c);
                }
            }
        }
    }
    g
}

#[test]
fn trilinear_volume_of_boxes_and_warped_cells() {
    // Unit cube scaled: 2 × 3 × 4.
    let c: [[f64; 3]; 8] = std::array::from_fn(|n| {
        [
            2.0 * (n & 1) as f64,
            3.0 * (n >> 1 & 1) as f64,
            4.0 * (n >> 2) as f64,
        ]
    });
    assert!((trilinear_volume(&c) - 24.0).abs() < 1e-12);
    // Mirrored frame: negative.
    let m: [[f64; 3]; 8] = std::array::from_fn(|n| [c[n][0], c[n][1], -c[n][2]]);
    assert!((trilinear_volume(&m) + 24.0).abs() < 1e-12);
    // Vertical pillars, bilinear top and bottom: V = area · mean thickness
    // (exact for any depths).
    let top = [0.3, 1.7, -0.4, 0.9];
    let bot = [5.0, 4.1, 6.3, 3.2];
    let g = build([1, 1, 1], [0.0, 0.0], |_, _, _, c| {
        if c < 4 { top[c] } else { bot[c - 4] }
    });
    let want: f64 = (0..4).map(|p| bot[p] - top[p]).sum::<f64>() / 4.0;
    let v = g.cell_volume(0, 0, 0);
    assert!((v.abs() - want).abs() < 1e-12, "{v} vs {want}");
    // Sheared parallel pillars, flat layers: a parallelepiped, V = base · height.
    let g = build(
        [1, 1, 1],
        [30.0, -20.0],
        |_, _, _, c| if c < 4 { 10.0 } else { 12.5 },
    );
    assert!((g.cell_volume(0, 0, 0).abs() - 2.5).abs() < 1e-12);
    // UTM-far coordinates through MAPAXES (rotated by 30°) keep the volume.
    let mut g = build([1, 1, 1], [0.0, 0.0], |_, _, _, c| {
        if c < 4 { top[c] } else { bot[c - 4] }
    });
    let (s, co) = (0.5f64, 3f64.sqrt() / 2.0);
    let (ox, oy) = (4.6e5, 5.9e6);
    g.mapaxes = Some([
        ox - s * 100.0,
        oy + co * 100.0,
        ox,
        oy,
        ox + co * 100.0,
        oy + s * 100.0,
    ]);
    let v = g.cell_volume(0, 0, 0);
    assert!((v.abs() - want).abs() < 1e-8, "{v} vs {want}");
    let (grid, rep) = g.to_grid().unwrap();
    assert!((rep.bulk_volume - want).abs() < 1e-8);
    let (lo, _) = grid.bounds();
    assert!(lo[0] > 4.5e5 && lo[1] > 5.8e6 && lo[2] < 6.5, "{lo:?}");
}

#[test]
fn welding_and_faults() {
    // Two columns, two layers, no throw: every corner on a shared pillar is
    // welded, faces sewn.
    let flat = |_: usize, _: usize, k: usize, c: usize| 10.0 * (k + (c >> 2)) as f64;
    let g = build([2, 1, 2], [0.0, 0.0], flat);
    let (grid, rep) = g.to_grid().unwrap();
    assert_eq!(rep.vertices, 6 * 3);
    assert_eq!(rep.hexahedra, 4);
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let Structure::CGraph(cg) = &s else { panic!() };
    assert_eq!(cg.sewn_faces, 2 * 4);
    // Throw of 3 on the right column: across the fault no vertex is shared
    // and no face is sewn; within each column, the layers still are.
    let faulted = |i: usize, j: usize, k: usize, c: usize| flat(i, j, k, c) + 3.0 * i as f64;
    let g = build([2, 1, 2], [0.0, 0.0], faulted);
    let (grid, rep) = g.to_grid().unwrap();
    assert_eq!(rep.vertices, 6 * 3 + 2 * 3);
    let Topology::Unstructured(cells) = &grid.topology else {
        panic!()
    };
    let left: Vec<u32> = [0, 2]
        .iter()
        .flat_map(|&c| cells.cell(c).to_vec())
        .collect();
    let right: Vec<u32> = [1, 3]
        .iter()
        .flat_map(|&c| cells.cell(c).to_vec())
        .collect();
    assert!(left.iter().all(|v| !right.contains(v)));
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let Structure::CGraph(cg) = &s else { panic!() };
    assert_eq!(cg.sewn_faces, 2 * 2);
    // PORO averaged to the vertices never crosses the fault.
    let mut g = g;
    g.properties
        .push(Property::scalar("PORO", vec![0.1, 0.3, 0.1, 0.3]));
    let (grid, _) = g.to_grid().unwrap();
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let v = vertex_property(&grid, &s, "PORO").unwrap();
    for &id in &left {
        assert_eq!(v[id as usize], 0.1f32);
    }
    for &id in &right {
        assert_eq!(v[id as usize], 0.3f32);
    }
    // Without the fault the shared pillar gets the volume-weighted mean.
    let mut g = build([2, 1, 2], [0.0, 0.0], flat);
    g.properties
        .push(Property::scalar("PORO", vec![0.1, 0.3, 0.1, 0.3]));
    let (grid, _) = g.to_grid().unwrap();
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let v = vertex_property(&grid, &s, "PORO").unwrap();
    assert!(v.iter().any(|&x| (x - 0.2).abs() < 1e-6));
}

#[test]
fn pinch_outs_inactive_and_zero_volume() {
    // 4 columns × 1 layer; column i collapses pillar edges by pattern.
    // Column 0: none (hex); column 1: the two pillars at i+1 (wedge);
    // column 2: one pillar (polyhedron); column 3: all four (zero volume).
    let g = build([4, 1, 1], [0.0, 0.0], |i, _, _, c| {
        let (ii, kk) = (c & 1, c >> 2);
        let collapsed = match i {
            0 => false,
            1 => ii == 1,
            2 => ii == 1 && (c >> 1 & 1) == 0,
            _ => true,
        };
        if kk == 0 || collapsed { 10.0 } else { 12.0 }
    });
    let (grid, rep) = g.to_grid().unwrap();
    assert_eq!(
        (rep.hexahedra, rep.wedges, rep.polyhedra, rep.zero_volume),
        (1, 1, 1, 1),
        "{rep:?}"
    );
    let Topology::Unstructured(cells) = &grid.topology else {
        panic!()
    };
    assert_eq!(
        cells.types,
        [vtk_type::HEXAHEDRON, vtk_type::WEDGE, vtk_type::POLYHEDRON]
    );
    // Exact volumes: 2, 1 (half the box), 3/4 · 2 = 1.5.
    assert!((rep.bulk_volume - 4.5).abs() < 1e-12, "{}", rep.bulk_volume);
    // The sweep structure sees every cell as valid (positive, not inverted),
    // and its planar-face volumes match (these cells have planar faces but
    // the polyhedron's warped quad, whose volume the meta-cell splits).
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let Structure::CGraph(cg) = &s else { panic!() };
    // Non-convex polyhedra are split: the CGraph counts pieces, live_cells input cells.
    assert_eq!(cg.class_counts[1..], [0, 0, 0, 0]);
    assert_eq!(s.live_cells(), 3);
    // Same with j mirrored (right-handed IJK): still valid, same volume.
    let mut m = g.clone();
    for p in m.coord.chunks_mut(3) {
        p[1] = -p[1];
    }
    let (grid2, rep2) = m.to_grid().unwrap();
    assert_ne!(rep.ijk_right_handed_up, rep2.ijk_right_handed_up);
    assert!((rep2.bulk_volume - 4.5).abs() < 1e-12);
    let s = Structure::build(&grid2, StructureChoice::Auto).unwrap();
    let Structure::CGraph(cg) = &s else { panic!() };
    // Non-convex polyhedra are split: the CGraph counts pieces, live_cells input cells.
    assert_eq!(cg.class_counts[1..], [0, 0, 0, 0]);
    assert_eq!(s.live_cells(), 3);
    // Inactive cells are excluded, properties follow the kept cells.
    let mut a = g.clone();
    a.actnum = Some(vec![1, 0, 1, 1]);
    a.properties
        .push(Property::scalar("PORO", vec![0.1, 0.2, 0.3, 0.4]));
    let (grid3, rep3) = a.to_grid().unwrap();
    assert_eq!((rep3.inactive, rep3.active, grid3.cell_count()), (1, 3, 2));
    assert_eq!(rep3.source_cell, [0, 2]);
    assert_eq!(grid3.cell_data[0].values, [0.1, 0.3]);
    // An inverted cell (bottom above top) is kept and reported.
    let inv = build([3, 1, 1], [0.0, 0.0], |i, _, _, c| {
        let down = if i == 2 { -1.0 } else { 1.0 };
        if c < 4 { 10.0 } else { 10.0 + down }
    });
    let (_, r) = inv.to_grid().unwrap();
    assert_eq!((r.inverted, r.hexahedra), (1, 3));
}

#[test]
fn three_collapsed_pillar_edges() {
    // Collapsing three pillar edges leaves 5 corners: two quads and two
    // triangles (a polyhedron); the volume is still the trilinear one.
    let g = build(
        [1, 1, 1],
        [0.0, 0.0],
        |_, _, _, c| if c == 7 { 12.0 } else { 10.0 },
    );
    let (grid, rep) = g.to_grid().unwrap();
    assert_eq!(rep.polyhedra, 1, "{rep:?}");
    assert!((rep.bulk_volume - 2.0 / 4.0).abs() < 1e-12);
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let Structure::CGraph(cg) = &s else { panic!() };
    // Non-convex polyhedra are split: the CGraph counts pieces, live_cells input cells.
    assert_eq!(cg.class_counts[1..], [0, 0, 0, 0]);
    assert_eq!(s.live_cells(), 1);
    // Planes near the pinched corners cut the two faces that share two
    // edges: such zero-area two-point loops must not be emitted.
    for axis in 0..3 {
        let req = SliceRequest {
            field: FieldSpec::Axis {
                axis,
                negative: false,
            },
            levels: LevelSpec::Count(97),
            attribute: None,
            threads: 1,
            brute_force: false,
            collect_mesh: true,
        };
        let m = slice(&grid, &s, &req, &|_| {}).unwrap().mesh.unwrap();
        assert!(m.polygon_count() > 0);
        assert!((0..m.polygon_count()).all(|p| m.polygon(p).len() >= 3));
    }
}

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
    assert_eq!(names, ["PORO", "PERMX", "PERMY", "PERMZ"]);
    assert!(deck.skipped.contains(&"MULTIPLY".to_string()));
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
    assert_eq!(cg.class_counts[1..], [0, 0, 0, 0], "{:?}", cg.class_counts);
    assert_eq!(s.live_cells(), grid.cell_count());
    // Every emitted polygon has at least 3 vertices (pinched cells included).
    let req = SliceRequest {
        field: FieldSpec::Axis {
            axis: 2,
            negative: false,
        },
        levels: LevelSpec::Count(50),
        attribute: Some("PORO".into()),
        threads: 1,
        brute_force: false,
        collect_mesh: true,
    };
    let m = slice(&grid, &s, &req, &|_| {}).unwrap().mesh.unwrap();
    assert!((0..m.polygon_count()).all(|p| m.polygon(p).len() >= 3));
    // Cavalieri: Σ area_k · Δ → bulk volume.
    let mut errs = Vec::new();
    for k in [50, 400] {
        let req = SliceRequest {
            field: FieldSpec::Axis {
                axis: 2,
                negative: false,
            },
            levels: LevelSpec::Count(k),
            attribute: None,
            threads: 1,
            brute_force: false,
            collect_mesh: false,
        };
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
    assert_eq!(names, ["PORO", "PERMX"]);
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

#[test]
fn generated_faulted_grid_round_trips_and_sweeps() {
    let g = stratasweep::generate::faulted([30, 20, 12], 3, 7);
    let mut buf = Vec::new();
    stratasweep::io::grdecl::write_grdecl(&mut buf, &g).unwrap();
    let back =
        stratasweep::io::grdecl::read_grdecl_from(&buf[..], std::path::Path::new("gen.grdecl"))
            .unwrap()
            .grid;
    assert_eq!(back, g);
    let (grid, rep) = g.to_grid().unwrap();
    assert!(
        rep.inactive > 0 && rep.wedges > 0 && rep.polyhedra > 0 && rep.hexahedra > 0,
        "{rep:?}"
    );
    assert_eq!(rep.inverted, 0);
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let Structure::CGraph(cg) = &s else { panic!() };
    // Non-convex polyhedra are split: the CGraph counts pieces, live_cells input cells.
    assert_eq!(cg.class_counts[1..], [0, 0, 0, 0], "{:?}", cg.class_counts);
    assert_eq!(s.live_cells(), grid.cell_count());
    // The sweep cuts exactly the cells the brute force cuts, on a faulted grid.
    let mut req = SliceRequest {
        field: FieldSpec::Axis {
            axis: 2,
            negative: false,
        },
        levels: LevelSpec::Count(40),
        attribute: Some("PORO".into()),
        threads: 1,
        brute_force: false,
        collect_mesh: false,
    };
    let a = slice(&grid, &s, &req, &|_| {}).unwrap();
    req.brute_force = true;
    let b = slice(&grid, &s, &req, &|_| {}).unwrap();
    let cells = |r: &stratasweep::pipeline::SliceResult| {
        r.stats.iter().map(|s| s.cells).collect::<Vec<_>>()
    };
    assert_eq!(cells(&a), cells(&b));
    // Cavalieri on the generated grid too.
    let dz = a.level_values[1] - a.level_values[0];
    let v: f64 = a.stats.iter().map(|s| s.area).sum::<f64>() * dz;
    assert!(
        (v - rep.bulk_volume).abs() / rep.bulk_volume < 0.02,
        "{v} vs {}",
        rep.bulk_volume
    );
}
