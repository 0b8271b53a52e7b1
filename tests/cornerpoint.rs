//! Corner-point geometry: analytic volumes of hand-built cells, welding and
//! faults, pinch-out classes, property averaging without bleeding across
//! faults, and the real grids (Reek GRDECL/EGRID, SPE9, SPE10) from
//! `STRATASWEEP_DATA`: bulk volume against xtgeo, Cavalieri, EGRID = GRDECL.

use std::path::PathBuf;

mod common;
use common::axis_request;

use stratasweep::cornerpoint::{CornerPointGrid, trilinear_volume};
use stratasweep::grid::{Property, Topology, vtk_type};
use stratasweep::pipeline::{SliceRequest, slice, vertex_property};
use stratasweep::structures::{Structure, StructureChoice};

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
    build_pillars(
        dims,
        |pi, pj| {
            let (x, y) = (pi as f64, pj as f64);
            ([x, y, 0.0], [x + shear[0], y + shear[1], 100.0])
        },
        depth,
    )
}

/// An nx×ny×nz grid with pillar `(pi, pj)` from `pillar(pi, pj) = (top,
/// bottom)` and corner depths from `depth(i, j, k, corner)`.
fn build_pillars(
    dims: [usize; 3],
    pillar: impl Fn(usize, usize) -> ([f64; 3], [f64; 3]),
    depth: impl Fn(usize, usize, usize, usize) -> f64,
) -> CornerPointGrid {
    let [nx, ny, nz] = dims;
    let mut coord = Vec::new();
    for pj in 0..=ny {
        for pi in 0..=nx {
            let (t, b) = pillar(pi, pj);
            coord.extend_from_slice(&t);
            coord.extend_from_slice(&b);
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
    assert_eq!(cg.class_counts[1..], [0, 0, 0, 0, 0]);
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
    assert_eq!(cg.class_counts[1..], [0, 0, 0, 0, 0]);
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
    assert_eq!(cg.class_counts[1..], [0, 0, 0, 0, 0]);
    assert_eq!(s.live_cells(), 1);
    // Planes near the pinched corners cut the two faces that share two
    // edges: such zero-area two-point loops must not be emitted.
    for axis in 0..3 {
        let req = SliceRequest {
            collect_mesh: true,
            ..axis_request(axis, 97)
        };
        let m = slice(&grid, &s, &req, &|_| {}).unwrap().mesh.unwrap();
        assert!(m.polygon_count() > 0);
        assert!((0..m.polygon_count()).all(|p| m.polygon(p).len() >= 3));
    }
}

/// Slices `grid` along `axis` at `count` levels by the sweep and by the
/// brute force, checks that they cut the same cells per level, and returns
/// the sweep's result.
fn sweep_matches_brute_force(
    grid: &stratasweep::grid::Grid,
    s: &Structure,
    axis: usize,
    count: usize,
    what: &str,
) -> stratasweep::pipeline::SliceResult {
    let mut req = axis_request(axis, count);
    let a = slice(grid, s, &req, &|_| {}).unwrap();
    req.brute_force = true;
    let b = slice(grid, s, &req, &|_| {}).unwrap();
    let cells = |r: &stratasweep::pipeline::SliceResult| {
        r.stats.iter().map(|s| s.cells).collect::<Vec<_>>()
    };
    assert_eq!(cells(&a), cells(&b), "{what}: axis {axis}");
    a
}

/// Area of the convex polygon spanned by `p` (monotone-chain hull + shoelace).
fn hull_area(mut p: Vec<[f64; 2]>) -> f64 {
    p.sort_by(|a, b| a.partial_cmp(b).unwrap());
    p.dedup();
    if p.len() < 3 {
        return 0.0;
    }
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut h: Vec<[f64; 2]> = Vec::new();
    for &x in &p {
        while h.len() >= 2 && cross(h[h.len() - 2], h[h.len() - 1], x) <= 0.0 {
            h.pop();
        }
        h.push(x);
    }
    let lower = h.len() + 1;
    for &x in p.iter().rev().skip(1) {
        while h.len() >= lower && cross(h[h.len() - 2], h[h.len() - 1], x) <= 0.0 {
            h.pop();
        }
        h.push(x);
    }
    h.pop();
    let n = h.len();
    (0..n)
        .map(|i| h[i][0] * h[(i + 1) % n][1] - h[i][1] * h[(i + 1) % n][0])
        .sum::<f64>()
        .abs()
        / 2.0
}

/// Independent brute force for a convex cell: the area of the section of
/// the convex hull of `pts` by the plane `x[axis] = t` (the crossings of
/// every segment between two points, then their 2D hull).
fn convex_section_area(pts: &[[f64; 3]], axis: usize, t: f64) -> f64 {
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let mut q = Vec::new();
    for a in 0..pts.len() {
        let da = pts[a][axis] - t;
        if da == 0.0 {
            q.push([pts[a][u], pts[a][v]]);
        }
        for b in a + 1..pts.len() {
            let db = pts[b][axis] - t;
            if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
                let s = da / (da - db);
                q.push([
                    pts[a][u] + s * (pts[b][u] - pts[a][u]),
                    pts[a][v] + s * (pts[b][v] - pts[a][v]),
                ]);
            }
        }
    }
    hull_area(q)
}

/// Converts `g` (convex cells with planar faces), checks the class counts
/// `[hexahedra, wedges, pyramids, tetrahedra, polyhedra]`, the bulk volume
/// against the analytic `volume` and each cell's trilinear volume, that the
/// CGraph takes every cell as valid, and the sweep's slice areas along x, y
/// and z against the convex brute force summed over the cells. Does the
/// same with y mirrored (the other handedness). Returns the grid and the
/// CGraph's sewn face count.
fn check_collapsed(
    what: &str,
    g: &CornerPointGrid,
    classes: [usize; 5],
    volume: f64,
) -> (stratasweep::grid::Grid, usize) {
    let mut mirrored = g.clone();
    for p in mirrored.coord.chunks_mut(3) {
        p[1] = -p[1];
    }
    let mut first = None;
    for g in [g, &mirrored] {
        let [nx, ny, nz] = g.dims;
        let corners: Vec<[[f64; 3]; 8]> = (0..nz)
            .flat_map(|k| (0..ny).flat_map(move |j| (0..nx).map(move |i| (i, j, k))))
            .map(|(i, j, k)| g.cell_corners(i, j, k))
            .collect();
        let tri: f64 = corners.iter().map(|c| trilinear_volume(c).abs()).sum();
        let (grid, rep) = g.to_grid().unwrap();
        assert_eq!(
            [
                rep.hexahedra,
                rep.wedges,
                rep.pyramids,
                rep.tetrahedra,
                rep.polyhedra
            ],
            classes,
            "{what}: {rep:?}"
        );
        assert_eq!(
            (rep.zero_volume, rep.inverted, rep.merge_fallback),
            (0, 0, 0)
        );
        assert!(
            (rep.bulk_volume - volume).abs() < 1e-12 * volume.max(1.0),
            "{what}: bulk {} vs analytic {volume}",
            rep.bulk_volume
        );
        assert!(
            (tri - volume).abs() < 1e-12 * volume.max(1.0),
            "{what}: {tri}"
        );
        let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
        let Structure::CGraph(cg) = &s else { panic!() };
        assert_eq!(
            cg.class_counts,
            [grid.cell_count(), 0, 0, 0, 0, 0],
            "{what}"
        );
        for axis in 0..3 {
            let req = axis_request(axis, 40);
            let r = slice(&grid, &s, &req, &|_| {}).unwrap();
            let mut top = 0.0f64;
            let mut sum = 0.0;
            for (l, &t) in r.level_values.iter().enumerate() {
                let want: f64 = corners
                    .iter()
                    .map(|c| convex_section_area(c, axis, t))
                    .sum();
                top = top.max(want);
                let got = r.stats[l].area;
                assert!(
                    (got - want).abs() <= 1e-5 * top.max(1e-3),
                    "{what}: axis {axis} level {l} (t = {t}): sweep area {got} vs brute force {want}"
                );
                sum += got;
            }
            assert!(sum > 0.0, "{what}: axis {axis} cut nothing");
        }
        first.get_or_insert((grid, cg.sewn_faces));
    }
    first.unwrap()
}

#[test]
fn collapse_patterns_become_catalog_cells() {
    let lattice = |pi: usize, pj: usize| {
        let (x, y) = (pi as f64, pj as f64);
        ([x, y, 0.0], [x, y, 100.0])
    };
    // Hexahedron (a box 1 × 1 × 2).
    let hex = build_pillars(
        [1, 1, 1],
        lattice,
        |_, _, _, c| {
            if c < 4 { 10.0 } else { 12.0 }
        },
    );
    check_collapsed("hexahedron", &hex, [1, 0, 0, 0, 0], 2.0);
    // Pinch-out: the two pillar edges at i = 0 collapse, planar bottom: a wedge.
    let pinch = build_pillars([1, 1, 1], lattice, |_, _, _, c| {
        if c < 4 || c & 1 == 0 { 10.0 } else { 12.0 }
    });
    check_collapsed("pinch-out wedge", &pinch, [0, 1, 0, 0, 0], 1.0);
    // Pillars (0,0) and (1,0) coincide: corners 0 = 1 and 4 = 5 merge
    // across pillars, a triangular prism (wedge) of base 1/2 and height 2.
    let side_pillars = |pi: usize, pj: usize| {
        let (x, y) = if pj == 0 {
            (0.5, 0.0)
        } else {
            (pi as f64, 1.0)
        };
        ([x, y, 0.0], [x, y, 100.0])
    };
    let side = build_pillars(
        [1, 1, 1],
        side_pillars,
        |_, _, _, c| if c < 4 { 10.0 } else { 12.0 },
    );
    check_collapsed("collapsed-side wedge", &side, [0, 1, 0, 0, 0], 1.0);
    // Four pillars meeting at depth 13: the bottom corners merge into an
    // apex, a pyramid of base 1 and height 3.
    let apex = [0.5, 0.5, 13.0];
    let pyr = build_pillars(
        [1, 1, 1],
        |pi, pj| ([pi as f64, pj as f64, 10.0], apex),
        |_, _, _, c| if c < 4 { 10.0 } else { 13.0 },
    );
    check_collapsed("pyramid", &pyr, [0, 0, 1, 0, 0], 1.0);
    // Same, with pillars (0,0) and (1,0) starting at the same point: the
    // top is a triangle of area 1/2, a tetrahedron of volume 1/2.
    let tet = build_pillars(
        [1, 1, 1],
        |pi, pj| {
            let top = if pj == 0 {
                [1.0, 0.0, 10.0]
            } else {
                [pi as f64, 1.0, 10.0]
            };
            (top, apex)
        },
        |_, _, _, c| if c < 4 { 10.0 } else { 13.0 },
    );
    check_collapsed("tetrahedron", &tet, [0, 0, 0, 1, 0], 0.5);
    // A pinch-out on a pillar pair next to a collapsed side: the cell with
    // pillars (0,0) = (1,0) and its pillar edges at j = 1, i = 0 collapsed
    // (corners 2 = 6) keeps 5 distinct corners and is a pyramid: base the
    // vertical quad on pillars (1,0) and (1,1), apex at corner 2.
    let mixed = build_pillars([1, 1, 1], side_pillars, |_, _, _, c| {
        if c < 4 || c == 6 { 10.0 } else { 12.0 }
    });
    // Prism of base 1/2 and height 2 less the tetrahedron at the pinched
    // corner (1/3).
    check_collapsed(
        "pinch-out by a collapsed side",
        &mixed,
        [0, 0, 1, 0, 0],
        2.0 / 3.0,
    );
}

#[test]
fn converging_pillars_give_sewn_pyramids_and_tetrahedra() {
    // 3×3 columns whose 16 pillars all end at one apex 30 below the top
    // (pillar (0,0) starts on pillar (1,0)): three layers, 10 thick. The
    // two upper layers are frusta (hexahedra; wedges in column (0,0)), the
    // bottom layer pyramids (a tetrahedron in column (0,0)). The grid is the
    // cone over the top polygon: 3×3 minus a half unit square, V = 8.5·30/3.
    let apex = [1.5, 1.5, 30.0];
    let g = build_pillars(
        [3, 3, 3],
        |pi, pj| {
            let top = if (pi, pj) == (0, 0) {
                [1.0, 0.0, 0.0]
            } else {
                [pi as f64, pj as f64, 0.0]
            };
            (top, apex)
        },
        |_, _, k, c| 10.0 * (k + (c >> 2)) as f64,
    );
    let (grid, sewn) = check_collapsed("converging pillars", &g, [16, 2, 8, 1, 0], 85.0);
    // Coincident corners are one vertex: 15 distinct pillar positions at
    // depths 0, 10, 20, plus the apex; every interior face is sewn (36
    // between columns, 18 between layers), each counted from both sides.
    assert_eq!(grid.points.len(), 15 * 3 + 1);
    let mut pts = grid.points.clone();
    pts.sort_by(|a, b| a.partial_cmp(b).unwrap());
    pts.dedup();
    assert_eq!(pts.len(), grid.points.len());
    assert_eq!(sewn, 2 * (36 + 18));
    // The sweep cuts exactly the cells the brute force cuts.
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    for axis in 0..3 {
        let a = sweep_matches_brute_force(&grid, &s, axis, 31, "converging pillars");
        assert_eq!(a.minima, 1, "axis {axis}: a sewn grid has one minimum");
    }
}

#[test]
fn twisted_cell_keeps_its_pillar_shape() {
    // Pillars (0,0) and (1,1) cross at the top: corners 0 and 3 coincide,
    // the merged top face would pass twice through one corner. The cell is
    // not merged (counted as a fallback), keeps its trilinear volume, and
    // the sweep structure skips it as a cell with a repeated vertex.
    let g = build_pillars(
        [1, 1, 1],
        |pi, pj| {
            let (x, y) = (pi as f64, pj as f64);
            let top = if pi == pj {
                [0.5, 0.5, 10.0]
            } else {
                [x, y, 10.0]
            };
            (top, [x, y, 20.0])
        },
        |_, _, _, c| if c < 4 { 10.0 } else { 20.0 },
    );
    let (grid, rep) = g.to_grid().unwrap();
    assert_eq!((rep.merge_fallback, rep.hexahedra), (1, 1), "{rep:?}");
    let t = trilinear_volume(&g.cell_corners(0, 0, 0)).abs();
    assert!(t > 1.0 && (rep.bulk_volume - t).abs() < 1e-12, "{t}");
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let Structure::CGraph(cg) = &s else { panic!() };
    assert_eq!(cg.class_counts, [0, 0, 0, 1, 0, 0]);
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

/// The Python of an xtgeo virtual environment: `STRATASWEEP_XTGEO_PYTHON`,
/// else `../venv-xtgeo/bin/python` beside the crate.
fn xtgeo_python() -> Option<PathBuf> {
    let p = std::env::var_os("STRATASWEEP_XTGEO_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../venv-xtgeo/bin/python")
        });
    if p.exists() {
        Some(p)
    } else {
        eprintln!(
            "\n*** SKIP xtgeo comparison: no {} (python3 -m venv ../venv-xtgeo && ../venv-xtgeo/bin/pip install xtgeo, or set STRATASWEEP_XTGEO_PYTHON) ***\n",
            p.display()
        );
        None
    }
}

#[test]
fn generated_faulted_grids_read_by_xtgeo() {
    let Some(py) = xtgeo_python() else { return };
    let dir = std::env::temp_dir().join(format!("stratasweep-xtgeo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
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
