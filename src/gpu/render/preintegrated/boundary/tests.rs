use std::collections::HashMap;

use super::*;
use crate::grid::{Cells, Property, vtk_type};
use crate::metacell::{Catalog, MAX_META_VERTICES};

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(u: [f64; 3], v: [f64; 3]) -> [f64; 3] {
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

fn dot(u: [f64; 3], v: [f64; 3]) -> f64 {
    u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
}

fn corners(s: &Surface, t: &[u32; 3]) -> [[f64; 3]; 3] {
    t.map(|v| s.points[v as usize])
}

/// Total triangle area.
fn area(s: &Surface) -> f64 {
    s.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = corners(s, t);
            let n = cross(sub(b, a), sub(c, a));
            0.5 * dot(n, n).sqrt()
        })
        .sum()
}

/// Enclosed volume by the divergence theorem: the cones from a reference
/// point `o` over every triangle.
fn volume(s: &Surface, o: [f64; 3]) -> f64 {
    s.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = corners(s, t).map(|p| sub(p, o));
            dot(a, cross(b, c)) / 6.0
        })
        .sum()
}

/// Every directed edge a→b is matched by as many b→a: the surface is
/// closed (a cycle) and consistently oriented. Returns the largest number
/// of triangles on one edge (2 for a manifold).
fn assert_closed(s: &Surface) -> usize {
    let mut edges: HashMap<(u32, u32), i64> = HashMap::new();
    let mut uses: HashMap<(u32, u32), usize> = HashMap::new();
    for t in &s.triangles {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            assert_ne!(a, b, "degenerate triangle {t:?}");
            *edges.entry((a.min(b), a.max(b))).or_default() += if a < b { 1 } else { -1 };
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    for (e, n) in &edges {
        assert_eq!(*n, 0, "edge {e:?} is unbalanced by {n}");
    }
    uses.values().copied().max().unwrap_or(0)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

/// Nearest and farthest ray parameter over a set of triangles (Möller–Trumbore).
fn hits(tris: &[[[f64; 3]; 3]], o: [f64; 3], d: [f64; 3]) -> Option<(f64, f64)> {
    let mut best: Option<(f64, f64)> = None;
    for [a, b, c] in tris {
        let (e1, e2) = (sub(*b, *a), sub(*c, *a));
        let p = cross(d, e2);
        let det = dot(e1, p);
        if det.abs() < 1e-300 {
            continue;
        }
        let s = sub(o, *a);
        let u = dot(s, p) / det;
        let q = cross(s, e1);
        let v = dot(d, q) / det;
        if !(-1e-12..=1.0 + 1e-12).contains(&u) || v < -1e-12 || u + v > 1.0 + 1e-12 {
            continue;
        }
        let t = dot(e2, q) / det;
        best = Some(best.map_or((t, t), |(n, f)| (n.min(t), f.max(t))));
    }
    best
}

/// Every face of every shown cell, triangulated alike (fan around the
/// vertex mean): the brute-force twin of the outer surface, whose nearest
/// and farthest hits are the true ray entry and exit.
fn all_cell_faces(grid: &Grid) -> Vec<[[f64; 3]; 3]> {
    let Topology::Unstructured(cells) = &grid.topology else {
        panic!("unstructured grids only");
    };
    let mut out = Vec::new();
    for c in 0..cells.len() {
        // Each cell alone: its faces are all open.
        let mut open = OpenFaces::default();
        faces::toggle_cell_faces(cells, &grid.points, c, &mut open);
        let mut pts = grid.points.clone();
        let tris = faces::triangulate(&open.loops(), &mut pts);
        out.extend(tris.iter().map(|t| t.map(|v| pts[v as usize])));
    }
    out
}

/// Rays from outside the bounding box toward random points inside: the
/// outer surface's nearest and farthest hits equal those over all cell
/// faces (to 1e-9 of the box size); returns how many rays hit.
fn assert_rays_enter_and_leave_through(grid: &Grid, s: &Surface, rays: usize) -> usize {
    let all = all_cell_faces(grid);
    let surf: Vec<[[f64; 3]; 3]> = s.triangles.iter().map(|t| corners(s, t)).collect();
    let (lo, hi) = grid.bounds();
    let size = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
    let mut state = 0x1234_5678_u64;
    let mut unit = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut hit = 0;
    for _ in 0..rays {
        let target = [0, 1, 2].map(|a| lo[a] + (hi[a] - lo[a]) * unit());
        let dir = [0, 1, 2].map(|_| unit() - 0.5);
        let n = dot(dir, dir).sqrt();
        let dir = dir.map(|x| x / n);
        let o = [0, 1, 2].map(|a| target[a] - 2.0 * size * dir[a]);
        let truth = hits(&all, o, dir);
        let got = hits(&surf, o, dir);
        match (truth, got) {
            (None, None) => {}
            (Some(t), Some(g)) => {
                assert!((t.0 - g.0).abs() < 1e-9 * size, "entry {t:?} vs {g:?}");
                assert!((t.1 - g.1).abs() < 1e-9 * size, "exit {t:?} vs {g:?}");
                hit += 1;
            }
            _ => panic!("ray from {o:?} along {dir:?}: cells {truth:?}, surface {got:?}"),
        }
    }
    hit
}

fn lattice_points(n: usize) -> Vec<[f64; 3]> {
    let mut points = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                points.push([i as f64, j as f64, k as f64]);
            }
        }
    }
    points
}

fn cube(n: usize) -> Grid {
    Grid {
        points: lattice_points(n),
        topology: Topology::Structured { dims: [n; 3] },
        point_data: Vec::new(),
        cell_data: Vec::new(),
    }
}

/// The same unit cubes as explicit hexahedra.
fn cube_as_hexahedra(n: usize) -> Grid {
    let mut cells = Cells::default();
    let off = hex_corner_offsets(n, n * n);
    for k in 0..n - 1 {
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let first = i + n * (j + n * k);
                let ids = off.map(|o| (first + o) as u32);
                cells.push(vtk_type::HEXAHEDRON, &ids);
            }
        }
    }
    Grid {
        topology: Topology::Unstructured(cells),
        ..cube(n)
    }
}

fn with_hidden(mut g: Grid, hidden: &[usize]) -> Grid {
    let mut ghost = vec![0.0; g.cell_count()];
    for &c in hidden {
        ghost[c] = crate::grid::GHOST_HIDDEN_CELL as f64;
    }
    g.cell_data.push(Property::scalar("vtkGhostType", ghost));
    g
}

/// Sum of the cell volumes: the crate's [`crate::metacell::MetaCell::signed_volume`]
/// (faces fanned around their vertex mean) for cells of up to 12 vertices;
/// larger polyhedra (Voronoi cells, beyond the meta-cell tables) by CIEL's
/// formula in f64: cones from the first vertex over the faces fanned from
/// their first vertex (a split other than the surface's; the same volume
/// for planar faces).
fn cell_volumes(grid: &Grid) -> f64 {
    let Topology::Unstructured(cells) = &grid.topology else {
        panic!("unstructured grids only");
    };
    let mut cat = Catalog::new();
    let mut total = 0.0;
    for c in 0..cells.len() {
        let ids = cells.cell(c);
        let stream = cells.faces_of(c);
        let mut faces: Vec<&[u32]> = Vec::new();
        let mut at = 1;
        for _ in 0..stream.first().copied().unwrap_or(0) {
            let n = stream[at] as usize;
            faces.push(&stream[at + 1..at + 1 + n]);
            at += 1 + n;
        }
        if cells.types[c] != vtk_type::POLYHEDRON || ids.len() <= 12 {
            let meta = if cells.types[c] == vtk_type::POLYHEDRON {
                let local = |v: &u32| ids.iter().position(|x| x == v).unwrap() as u8;
                let loops: Vec<Vec<u8>> = faces
                    .iter()
                    .map(|f| f.iter().map(local).collect())
                    .collect();
                cat.for_faces(ids.len(), &loops)
                    .expect("a valid polyhedron")
            } else {
                cat.for_vtk_type(cells.types[c]).expect("known type")
            };
            let pos = |v: usize| grid.points[ids[v] as usize];
            total += cat.get(meta).signed_volume(&pos);
            continue;
        }
        let p0 = grid.points[ids[0] as usize];
        let rel = |v: u32| sub(grid.points[v as usize], p0);
        for f in faces {
            for w in f[1..].windows(2) {
                total += dot(rel(f[0]), cross(rel(w[0]), rel(w[1]))) / 6.0;
            }
        }
    }
    total
}

#[test]
fn the_outer_surface_of_a_cube_covers_its_six_faces_once() {
    let n = 5;
    let g = cube(n);
    let t = boundary_triangles(&g).expect("a surface");
    // 6 faces of (n−1)² quads, 2 triangles each.
    assert_eq!(t.len(), 6 * (n - 1) * (n - 1) * 2 * 3);
    // Every corner lies on the box surface (origin at the centre: ±2).
    let h = (n - 1) as f32 / 2.0;
    for p in &t {
        assert!(p[..3].iter().any(|c| (c.abs() - h).abs() < 1e-6), "{p:?}");
        // The index coordinate is the position shifted by the centre.
        for a in 0..3 {
            assert_eq!(p[3 + a], p[a] + h, "{p:?}");
        }
    }
    let s = outer_surface(&g);
    assert_eq!(assert_closed(&s), 2);
    assert!(rel(area(&s), 6.0 * 16.0) < 1e-12, "{}", area(&s));
    assert!(rel(volume(&s, [0.0; 3]), 64.0) < 1e-12);
}

#[test]
fn explicit_hexahedra_give_the_lattice_surface() {
    let n = 5;
    let s = outer_surface(&cube_as_hexahedra(n));
    assert_eq!(assert_closed(&s), 2);
    // 6 (n−1)² quads, a fan of 4 triangles each.
    assert_eq!(s.triangles.len(), 6 * 16 * 4);
    assert!(rel(area(&s), 96.0) < 1e-12);
    assert!(rel(volume(&s, [2.0; 3]), 64.0) < 1e-12);
    assert_eq!(
        assert_rays_enter_and_leave_through(&cube_as_hexahedra(n), &s, 200),
        200
    );
}

#[test]
fn hidden_cells_are_not_part_of_the_grid() {
    let n = 5;
    // A corner cell: the notch takes 3 unit squares and gives 3 back.
    // An inner cell (1,1,1): a cavity adds its 6 faces.
    let inner = 1 + 4 * (1 + 4);
    for (hidden, area_want, vol_want) in [(vec![0], 96.0, 63.0), (vec![inner], 102.0, 63.0)] {
        for g in [
            with_hidden(cube(n), &hidden),
            with_hidden(cube_as_hexahedra(n), &hidden),
        ] {
            let s = outer_surface(&g);
            assert_eq!(assert_closed(&s), 2);
            assert!(rel(area(&s), area_want) < 1e-12, "{hidden:?} {}", area(&s));
            assert!(rel(volume(&s, [2.0; 3]), vol_want) < 1e-12);
        }
    }
}

/// On the unit lattice a point's index coordinate is its position: every
/// surface point, face centres included, must carry it; unstructured grids
/// carry none.
#[test]
fn structured_surfaces_carry_each_point_s_index_coordinate() {
    let n = 5;
    let inner = 1 + 4 * (1 + 4);
    for s in [
        outer_surface(&cube(n)),
        outer_surface(&with_hidden(cube(n), &[0, inner])),
        outer_surface_in(&cube(6), Some([[1, 3], [0, 5], [2, 9]])),
    ] {
        assert_eq!(s.ijk.len(), s.points.len());
        assert_eq!(s.ijk, s.points);
    }
    assert!(outer_surface(&cube_as_hexahedra(n)).ijk.is_empty());
    let t = boundary_triangles(&cube_as_hexahedra(n)).expect("a surface");
    assert!(t.iter().all(|p| p[3..] == [0.0; 3]));
}

#[test]
fn a_clipped_lattice_is_bounded_by_its_box() {
    let s = outer_surface_in(&cube(6), Some([[1, 3], [0, 5], [2, 9]]));
    assert_eq!(assert_closed(&s), 2);
    // 2 × 5 × 3 cells (K cut to the grid's 5).
    assert!(rel(volume(&s, [0.0; 3]), 30.0) < 1e-12);
    assert!(rel(area(&s), 2.0 * (10.0 + 6.0 + 15.0)) < 1e-12);
    assert!(
        outer_surface_in(&cube(6), Some([[3, 3], [0, 5], [0, 5]]))
            .triangles
            .is_empty()
    );
}

#[test]
fn the_outer_surface_of_a_zoo_grid_is_its_box() {
    let g = crate::generate::zoo(3000, 7);
    let s = outer_surface(&g);
    // Tetrahedra, pyramids, wedges and hexahedra, conforming: a manifold.
    assert_eq!(assert_closed(&s), 2);
    // The zoo fills [-1, 1]³.
    assert!(rel(area(&s), 24.0) < 1e-9, "{}", area(&s));
    let v = volume(&s, [0.0; 3]);
    assert!(rel(v, 8.0) < 1e-9, "{v}");
    assert!(rel(v, cell_volumes(&g)) < 1e-9, "{v} {}", cell_volumes(&g));
    assert!(assert_rays_enter_and_leave_through(&g, &s, 100) > 50);
}

#[test]
fn the_outer_surface_of_a_voronoi_grid_is_the_unit_box() {
    let g = crate::voronoi::voronoi(300, 3);
    let s = outer_surface(&g);
    assert_eq!(assert_closed(&s), 2);
    assert!(rel(area(&s), 6.0) < 1e-9, "{}", area(&s));
    let v = volume(&s, [0.5; 3]);
    assert!(rel(v, 1.0) < 1e-9, "{v}");
    assert!(rel(v, cell_volumes(&g)) < 1e-9, "{v} {}", cell_volumes(&g));
    assert!(assert_rays_enter_and_leave_through(&g, &s, 100) > 50);
}

#[test]
fn a_faulted_corner_point_grid_is_bounded_with_its_fault_faces() {
    for (dims, faults, seed) in [([8, 7, 5], 2, 1u64), ([12, 9, 6], 3, 7)] {
        let cp = crate::generate::faulted(dims, faults, seed);
        let (g, report) = cp.to_grid().expect("converts");
        assert!(report.inactive > 0, "the test wants inactive cells");
        let s = outer_surface(&g);
        // Closed as a chain; fault faces kept whole make it no manifold.
        assert_closed(&s);
        let o = g.origin();
        let v = volume(&s, o);
        let bulk = cp.bulk_volume();
        assert!(rel(v, bulk) < 1e-9, "{dims:?}: surface {v}, bulk {bulk}");
        assert!(rel(v, cell_volumes(&g)) < 1e-9);
        assert!(assert_rays_enter_and_leave_through(&g, &s, 60) > 20);
    }
}

#[test]
fn polyhedron_faces_listed_either_way_round_are_turned_outward() {
    let n = 4;
    let hexes = cube_as_hexahedra(n);
    let Topology::Unstructured(h) = &hexes.topology else {
        unreachable!()
    };
    let mut cells = Cells::default();
    for c in 0..h.len() {
        let ids = h.cell(c);
        let mut faces: Vec<Vec<u32>> = crate::metacell::HEXAHEDRON_FACES
            .iter()
            .map(|f| f.iter().map(|&v| ids[v as usize]).collect())
            .collect();
        // Some faces inward, and every third cell inside out.
        faces[c % 6].reverse();
        faces[(c + 3) % 6].reverse();
        if c % 3 == 0 {
            faces.iter_mut().for_each(|f| f.reverse());
        }
        cells.push_polyhedron(&faces);
    }
    let g = Grid {
        topology: Topology::Unstructured(cells),
        ..hexes.clone()
    };
    let s = outer_surface(&g);
    assert_eq!(assert_closed(&s), 2);
    assert!(rel(volume(&s, [0.0; 3]), 27.0) < 1e-12);
    assert_eq!(s, outer_surface(&hexes));
}

/// A triangle soup (position, ijk) welded by exact position into a
/// [`Surface`] in the world frame (`origin` added back), with its `ijk`.
fn welded(soup: &[[f32; 6]], origin: [f64; 3]) -> Surface {
    let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
    let mut s = Surface::default();
    for t in soup.chunks(3) {
        let tri: Vec<u32> = t
            .iter()
            .map(|c| {
                let key = [c[0].to_bits(), c[1].to_bits(), c[2].to_bits()];
                *ids.entry(key).or_insert_with(|| {
                    s.points.push([0, 1, 2].map(|a| c[a] as f64 + origin[a]));
                    s.ijk.push([c[3], c[4], c[5]].map(f64::from));
                    s.points.len() as u32 - 1
                })
            })
            .collect();
        if tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2] {
            s.triangles.push([tri[0], tri[1], tri[2]]);
        }
    }
    s
}

/// The CP-Graph of a corner-point grid (which must have collapsed cells).
fn cp_graph(cp: &crate::cornerpoint::CornerPointGrid) -> crate::structures::cpgraph::CpGraph {
    let (grid, rep) = cp.to_grid().expect("converts");
    assert!(rep.collapsed > 0, "the test wants collapsed cells");
    let layout = crate::grid::IjkLayout {
        dims: cp.dims,
        source_cell: rep.source_cell,
    };
    let s = crate::structures::Structure::build_with(
        &grid,
        crate::structures::StructureChoice::CpGraph,
        Some(&layout),
    )
    .expect("builds");
    let crate::structures::Structure::CpGraph(g) = s else {
        panic!("not a CP-Graph");
    };
    *g
}

/// Per live cell of `g` (world frame): its signed volume by its
/// meta-cell, and its faces fanned around their vertex means, each cell
/// alone (the brute-force twin of the outer surface).
fn graph_cells(g: &crate::structures::cpgraph::CpGraph) -> (f64, Vec<[[f64; 3]; 3]>) {
    let (mut volume, mut tris) = (0.0, Vec::new());
    let mut ids = [0u32; MAX_META_VERTICES];
    let world = |v: u32| [0, 1, 2].map(|a| g.positions[v as usize][a] as f64 + g.origin[a]);
    for slot in 0..g.slot_count() as u32 {
        if !g.is_live(slot) {
            continue;
        }
        let (m, n) = g.cell(slot, &mut ids);
        let meta = g.catalog.get(m);
        volume += meta.signed_volume(&|v: usize| world(ids[v]));
        let mut open = OpenFaces::default();
        faces::toggle_local(&meta.faces, &ids[..n], &mut open);
        let mut pts: Vec<[f64; 3]> = (0..g.positions.len() as u32).map(world).collect();
        for t in faces::triangulate(&open.loops(), &mut pts) {
            tris.push(t.map(|v| pts[v as usize]));
        }
    }
    (volume, tris)
}

#[test]
fn a_corner_point_graph_with_collapsed_cells_is_bounded_without_holes() {
    // Faulted, folded layers that pinch out: collapsed cells (wedges,
    // polyhedra split into convex pieces) reach the grid's outside.
    for (dims, faults, seed) in [([8, 7, 5], 2, 1u64), ([12, 9, 6], 3, 7)] {
        let g = cp_graph(&crate::generate::faulted(dims, faults, seed));
        let ijk = g.vertex_ijk();
        let s = welded(&graph_boundary_triangles(&g, &ijk), g.origin);
        // Closed as a chain and oriented outward: it encloses the live
        // cells' volume.
        assert_closed(&s);
        let (cells, all) = graph_cells(&g);
        let v = volume(&s, g.origin);
        assert!(rel(v, cells) < 1e-6, "{dims:?}: surface {v}, cells {cells}");
        // Nearest and farthest hits are the true entry and exit (to the
        // f32 rounding of the soup's positions).
        let surf: Vec<[[f64; 3]; 3]> = s.triangles.iter().map(|t| corners(&s, t)).collect();
        let (lo, hi) = all
            .iter()
            .flatten()
            .fold(([f64::MAX; 3], [f64::MIN; 3]), |(l, h), p| {
                (
                    [0, 1, 2].map(|a| l[a].min(p[a])),
                    [0, 1, 2].map(|a| h[a].max(p[a])),
                )
            });
        let size = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
        let mut hit = 0;
        for r in 0..400 {
            let f = |n: usize| ((r * n + n) % 97) as f64 / 97.0;
            let target = [0, 1, 2].map(|a| lo[a] + (hi[a] - lo[a]) * f(a + 3));
            let dir = [f(5) - 0.5, f(11) - 0.5, 0.6 * f(13) - 0.3];
            let n = dot(dir, dir).sqrt();
            let dir = dir.map(|x| x / n);
            let o = [0, 1, 2].map(|a| target[a] - 2.0 * size * dir[a]);
            match (hits(&all, o, dir), hits(&surf, o, dir)) {
                (None, None) => {}
                (Some(t), Some(h)) => {
                    assert!((t.0 - h.0).abs() < 1e-6 * size, "entry {t:?} vs {h:?}");
                    assert!((t.1 - h.1).abs() < 1e-6 * size, "exit {t:?} vs {h:?}");
                    hit += 1;
                }
                (t, h) => panic!("ray from {o:?} along {dir:?}: cells {t:?}, surface {h:?}"),
            }
        }
        assert!(hit > 100, "{dims:?}: {hit} rays hit");
    }
}

#[test]
fn a_corner_point_box_is_bounded_by_its_six_sides_with_their_nodes() {
    // 3 × 2 × 4 cells: pillars at x = i, y = j, layers 0.5 thick (z = −depth).
    let dims = [3usize, 2, 4];
    let [nx, ny, nz] = dims;
    let mut coord = Vec::new();
    for pj in 0..=ny {
        for pi in 0..=nx {
            coord.extend_from_slice(&[pi as f64, pj as f64, 0.0, pi as f64, pj as f64, 2.0]);
        }
    }
    let zcorn = (0..8 * nx * ny * nz)
        .map(|n| 0.5 * (n / (4 * nx * ny)).div_ceil(2) as f64)
        .collect();
    let cp = crate::cornerpoint::CornerPointGrid {
        dims,
        coord,
        zcorn,
        actnum: None,
        mapaxes: None,
        mapunits: None,
        gridunit: None,
        properties: Vec::new(),
    };
    let (grid, rep) = cp.to_grid().expect("converts");
    let layout = crate::grid::IjkLayout {
        dims,
        source_cell: rep.source_cell,
    };
    let crate::structures::Structure::CpGraph(g) = crate::structures::Structure::build_with(
        &grid,
        crate::structures::StructureChoice::CpGraph,
        Some(&layout),
    )
    .expect("builds") else {
        panic!("not a CP-Graph");
    };
    let t = graph_boundary_triangles(g.as_ref(), &g.vertex_ijk());
    // Top and bottom 3·2 quads each, the j-sides 3·4, the i-sides 2·4;
    // four triangles per quad (a fan around its centre).
    let quads = 2 * (3 * 2) + 2 * (3 * 4) + 2 * (2 * 4);
    assert_eq!(t.len(), 3 * 4 * quads);
    let s = welded(&t, g.origin);
    assert_eq!(assert_closed(&s), 2);
    assert!(rel(volume(&s, [0.0; 3]), 3.0 * 2.0 * 2.0) < 1e-6);
    // Every corner (fan centres too) carries its node: x = i, y = j, z = −k/2.
    for (p, n) in s.points.iter().zip(&s.ijk) {
        let want = [p[0], p[1], -2.0 * p[2]];
        for a in 0..3 {
            assert!((n[a] - want[a]).abs() < 1e-5, "{p:?}: {n:?}");
        }
    }
}
