//! Corner-point geometry on hand-built grids: analytic volumes, welding and
//! faults, pinch-out classes, collapse patterns against the catalog's
//! cells, property averaging without bleeding across faults. The real and
//! generated grids are in `cornerpoint_data.rs`.

use crate::support::{axis_request, sweep_matches_brute_force};

use stratasweep::cornerpoint::{CornerPointGrid, trilinear_volume};
use stratasweep::grid::{Property, Topology, vtk_type};
use stratasweep::pipeline::{SliceRequest, slice, vertex_property};
use stratasweep::structures::{Structure, StructureChoice};

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
