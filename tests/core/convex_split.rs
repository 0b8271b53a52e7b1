//! Non-convex polyhedra split into convex pieces (`convex_split`), checked
//! against analytic slice areas and volumes, the brute force, a per-cell
//! reference of the cut cells, and VTK's plane cutter.

use crate::support;
use crate::support::Rng;
use std::collections::BTreeSet;
use stratasweep::field::FieldSpec;
use stratasweep::grid::{Cells, Grid, Property, Topology, vtk_type};
use stratasweep::pipeline::{LevelSpec, SliceRequest, SliceResult, slice};
use stratasweep::structures::convex_split::{split_non_convex, split_non_convex_cells};
use stratasweep::structures::{Structure, StructureChoice};

type P = [f64; 3];

fn grid_of(points: Vec<P>, cells: &[Vec<Vec<u32>>]) -> Grid {
    let mut c = Cells::default();
    for faces in cells {
        c.push_polyhedron(faces);
    }
    let f: Vec<f64> = points.iter().map(|p| p[0] + 2.0 * p[1] - p[2]).collect();
    let n = c.len();
    Grid {
        points,
        topology: Topology::Unstructured(c),
        point_data: vec![Property::scalar("f", f)],
        cell_data: vec![Property::scalar(
            "id",
            (0..n).map(|i| i as f64 * 10.0).collect(),
        )],
    }
}

/// A prism over a planar polygon in z = 0 (counter-clockwise), height `h`,
/// faces outward; points appended to `pts` after applying `map`.
fn prism(pts: &mut Vec<P>, base: &[[f64; 2]], h: f64, map: &dyn Fn(P) -> P) -> Vec<Vec<u32>> {
    let o = pts.len() as u32;
    let n = base.len() as u32;
    for z in [0.0, h] {
        for b in base {
            pts.push(map([b[0], b[1], z]));
        }
    }
    let mut faces = vec![(0..n).rev().map(|i| o + i).collect::<Vec<u32>>()];
    faces.push((0..n).map(|i| o + n + i).collect());
    for i in 0..n {
        let j = (i + 1) % n;
        faces.push(vec![o + i, o + j, o + n + j, o + n + i]);
    }
    faces
}

/// The L of two 4×1 arms (reflex corner at (1, 1)).
const L: [[f64; 2]; 6] = [[0., 0.], [4., 0.], [4., 1.], [1., 1.], [1., 4.], [0., 4.]];

/// 45° about z: x' = (x + y)/√2, so x' = c slices the L along x + y = c√2.
fn rot45(p: P) -> P {
    let r = std::f64::consts::FRAC_1_SQRT_2;
    [(p[0] + p[1]) * r, (p[1] - p[0]) * r, p[2]]
}

/// Area of the rotated L-prism (height 1) at x' = c: the length of
/// x + y = s in the L, by rectangles (arms minus their overlap).
fn l_area(c: f64) -> f64 {
    let s = c * std::f64::consts::SQRT_2;
    let len = |x0: f64, x1: f64, y0: f64, y1: f64| {
        let a = x0.max(s - y1);
        let b = x1.min(s - y0);
        std::f64::consts::SQRT_2 * (b - a).max(0.0)
    };
    len(0., 4., 0., 1.) + len(0., 1., 0., 4.) - len(0., 1., 0., 1.)
}

/// A unit box whose top is a valley roof: the reflex edge (0.5, y, h).
fn valley(pts: &mut Vec<P>, h: f64, shift: P) -> Vec<Vec<u32>> {
    let o = pts.len() as u32;
    let raw: [P; 10] = [
        [0., 0., 0.],
        [1., 0., 0.],
        [1., 1., 0.],
        [0., 1., 0.],
        [0., 0., 1.],
        [1., 0., 1.],
        [1., 1., 1.],
        [0., 1., 1.],
        [0.5, 0., h],
        [0.5, 1., h],
    ];
    for p in raw {
        pts.push([p[0] + shift[0], p[1] + shift[1], p[2] + shift[2]]);
    }
    let f = |v: &[u32]| v.iter().map(|&i| o + i).collect::<Vec<u32>>();
    vec![
        f(&[0, 3, 2, 1]),
        f(&[0, 1, 5, 8, 4]),
        f(&[3, 7, 9, 6, 2]),
        f(&[0, 4, 7, 3]),
        f(&[1, 2, 6, 5]),
        f(&[4, 8, 9, 7]),
        f(&[8, 5, 6, 9]),
    ]
}

/// Cross-section area of the valley cell at height t.
fn valley_area(h: f64, t: f64) -> f64 {
    if t <= h {
        1.0
    } else {
        1.0 - (t - h) / (1.0 - h)
    }
}

/// The cube [−1, 1]³ with a square pyramid (apex at 3 along the axis) on
/// every face: 14 vertices, 24 triangles, reflex edges along the cube's
/// edges, star-shaped from the centre. (Apexes at 2 would make adjacent
/// triangles coplanar: a convex rhombic dodecahedron.)
fn stellated(pts: &mut Vec<P>, shift: P) -> Vec<Vec<u32>> {
    let o = pts.len() as u32;
    for k in 0..8 {
        let c = [k & 1, (k >> 1) & 1, (k >> 2) & 1].map(|b| if b == 1 { 1.0 } else { -1.0 });
        pts.push([c[0] + shift[0], c[1] + shift[1], c[2] + shift[2]]);
    }
    let mut faces = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let mut apex = shift;
            apex[axis] += 3.0 * sign;
            let a = pts.len() as u32;
            pts.push(apex);
            // The face's 4 corners in cyclic order around the axis.
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |cu: f64, cv: f64| {
                let mut bits = 0;
                let mut set = |ax: usize, val: f64| {
                    if val > 0.0 {
                        bits |= 1 << ax;
                    }
                };
                set(axis, sign);
                set(u, cu);
                set(v, cv);
                o + bits
            };
            let ring = [
                corner(-1., -1.),
                corner(1., -1.),
                corner(1., 1.),
                corner(-1., 1.),
            ];
            for i in 0..4 {
                let (p, q) = (ring[i], ring[(i + 1) % 4]);
                // Outward: counter-clockwise seen from outside (along +sign·axis).
                if sign > 0.0 {
                    faces.push(vec![p, q, a]);
                } else {
                    faces.push(vec![q, p, a]);
                }
            }
        }
    }
    faces
}

/// Section of the stellated cube at height t: the square plus four spike
/// sections (∫ from 1 to 3 − 2|t| of (3 − x) dx each), or a spike's square.
fn stellated_area(t: f64) -> f64 {
    let z = t.abs();
    if z <= 1.0 {
        4.0 + 8.0 * (1.0 - z * z)
    } else if z < 3.0 {
        (3.0 - z) * (3.0 - z)
    } else {
        0.0
    }
}

fn request(axis: usize, levels: Vec<f64>, brute_force: bool) -> SliceRequest {
    SliceRequest {
        field: FieldSpec::Axis {
            axis,
            negative: false,
        },
        levels: LevelSpec::Values(levels),
        attribute: None,
        threads: 1,
        brute_force,
        collect_mesh: true,
        sweep: Default::default(),
    }
}

fn run(g: &Grid, choice: StructureChoice, req: &SliceRequest) -> SliceResult {
    let s = Structure::build(g, choice).unwrap();
    slice(g, &s, req, &|_| {}).unwrap()
}

/// Slices `g` along `axis` with CIEL (sweep and brute force) and the auto
/// structure, checks each level's area against `area(t)`.
fn check_areas(name: &str, g: &Grid, axis: usize, levels: &[f64], area: &dyn Fn(f64) -> f64) {
    for (choice, bf) in [
        (StructureChoice::Ciel, false),
        (StructureChoice::Ciel, true),
        (StructureChoice::Auto, false),
        (StructureChoice::Auto, true),
    ] {
        let r = run(g, choice, &request(axis, levels.to_vec(), bf));
        for (k, &t) in levels.iter().enumerate() {
            let (got, want) = (r.stats[k].area, area(t));
            assert!(
                (got - want).abs() < 1e-5 * want.max(1.0),
                "{name} ({choice:?}, brute force {bf}): level {t}: area {got}, analytic {want}"
            );
            // One input cell, however many pieces it became.
            assert_eq!(r.stats[k].cells, (want > 0.0) as u64, "{name} level {t}");
            let m = r.mesh.as_ref().unwrap();
            assert!(m.poly_cell.iter().all(|&c| c == 0), "{name}: source ids");
        }
    }
}

#[test]
fn l_prism_slices_have_the_analytic_area() {
    let mut pts = Vec::new();
    let faces = prism(&mut pts, &L, 1.0, &rot45);
    let g = grid_of(pts, &[faces]);
    // x' in (0, 4/√2·…): s = x + y from 0 to 5.
    let levels: Vec<f64> = [0.3, 0.9, 1.5, 2.2, 2.5, 3.0, 3.7, 4.4, 4.9]
        .iter()
        .map(|s| s * std::f64::consts::FRAC_1_SQRT_2)
        .collect();
    check_areas("L prism", &g, 0, &levels, &l_area);
    // Horizontal slices: the L's area, 7.
    check_areas("L prism (z)", &g, 2, &[0.1, 0.5, 0.93], &|_| 7.0);
}

#[test]
fn reflex_edge_cell_slices_have_the_analytic_area() {
    let h = 0.2;
    let mut pts = Vec::new();
    let faces = valley(&mut pts, h, [0.0; 3]);
    let g = grid_of(pts, &[faces]);
    let levels = [0.05, 0.15, 0.25, 0.3, 0.4, 0.6, 0.85, 0.97];
    check_areas("valley", &g, 2, &levels, &|t| valley_area(h, t));
    // Along x: the section is the box's profile minus the valley: 1 − (1 − h)(1 − 2|x − ½|)... as a function of x.
    check_areas("valley (x)", &g, 0, &[0.1, 0.3, 0.45, 0.55, 0.8], &|x| {
        h + (1.0 - h) * (2.0 * (x - 0.5)).abs()
    });
}

#[test]
fn stellated_cube_slices_have_the_analytic_area() {
    let mut pts = Vec::new();
    let faces = stellated(&mut pts, [0.0; 3]);
    let g = grid_of(pts, &[faces]);
    let levels = [-2.9, -1.9, -1.3, -0.7, -0.2, 0.25, 0.8, 1.1, 1.6, 2.5];
    check_areas("stellated cube", &g, 2, &levels, &stellated_area);
    check_areas("stellated cube (x)", &g, 0, &levels, &stellated_area);
}

/// |volume| of a cell of a grid, by the divergence theorem over its faces
/// (fans from each face's first vertex), written independently of the crate.
fn cell_volume(g: &Grid, c: usize) -> f64 {
    let Topology::Unstructured(cells) = &g.topology else {
        panic!()
    };
    let ids = cells.cell(c);
    let faces: Vec<Vec<u32>> = match cells.types[c] {
        vtk_type::TETRA => vec![
            vec![ids[0], ids[1], ids[3]],
            vec![ids[1], ids[2], ids[3]],
            vec![ids[2], ids[0], ids[3]],
            vec![ids[0], ids[2], ids[1]],
        ],
        vtk_type::PYRAMID => vec![
            vec![ids[0], ids[3], ids[2], ids[1]],
            vec![ids[0], ids[1], ids[4]],
            vec![ids[1], ids[2], ids[4]],
            vec![ids[2], ids[3], ids[4]],
            vec![ids[3], ids[0], ids[4]],
        ],
        vtk_type::POLYHEDRON => {
            let s = cells.faces_of(c);
            let mut out = Vec::new();
            let mut p = 1;
            for _ in 0..s[0] {
                let n = s[p] as usize;
                out.push(s[p + 1..p + 1 + n].to_vec());
                p += 1 + n;
            }
            out
        }
        t => panic!("unexpected piece type {t}"),
    };
    let q = |v: u32| g.points[v as usize];
    let det = |a: P, b: P, c: P| {
        a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0])
    };
    let mut v = 0.0;
    for f in &faces {
        for i in 1..f.len() - 1 {
            v += det(q(f[0]), q(f[i]), q(f[i + 1]));
        }
    }
    (v / 6.0).abs()
}

#[test]
fn pieces_are_positive_and_their_volumes_sum_to_the_cell() {
    let mut pts = Vec::new();
    let a = prism(&mut pts, &L, 1.0, &rot45);
    let b = valley(&mut pts, 0.2, [10.0, 0.0, 0.0]);
    let c = stellated(&mut pts, [20.0, 0.0, 0.0]);
    let cube = prism(
        &mut pts,
        &[[0., 0.], [1., 0.], [1., 1.], [0., 1.]],
        1.0,
        &|p| [p[0] + 30.0, p[1], p[2]],
    );
    let g = grid_of(pts, &[a, b, c, cube]);
    let original: Vec<f64> = (0..4).map(|c| cell_volume(&g, c)).collect();
    for (c, want) in [7.0, 0.6, 24.0, 1.0].into_iter().enumerate() {
        assert!(
            (original[c] - want).abs() < 1e-12,
            "cell {c}: {}",
            original[c]
        );
    }
    let s = split_non_convex(&g, None)
        .unwrap()
        .expect("three non-convex cells");
    s.grid.validate().unwrap();
    assert_eq!(s.map.report.non_convex, 3);
    assert_eq!(s.map.input_cells, 4);
    let mut sum = [0.0f64; 4];
    let mut pieces = [0usize; 4];
    for (k, &src) in s.map.source.iter().enumerate() {
        let v = cell_volume(&s.grid, k);
        assert!(v > 1e-9, "piece {k} of cell {src} is flat: {v}");
        sum[src as usize] += v;
        pieces[src as usize] += 1;
    }
    for c in 0..4 {
        assert!(
            (sum[c] - original[c]).abs() < 1e-9 * original[c],
            "cell {c}: pieces {} vs {}",
            sum[c],
            original[c]
        );
    }
    assert_eq!(pieces[3], 1, "the convex cube is kept whole");
    assert!(pieces[..3].iter().all(|&p| p > 1));
    assert_eq!(
        s.map.report.pieces,
        pieces[..3].iter().sum::<usize>(),
        "report"
    );
    // Cell properties follow the source, new vertices get means.
    let id = s.grid.cell_property("id").unwrap();
    for (k, &src) in s.map.source.iter().enumerate() {
        assert_eq!(id.values[k], src as f64 * 10.0);
    }
    let f = s.grid.point_property("f").unwrap();
    assert_eq!(f.values.len(), s.grid.points.len());
    for (i, w) in s.map.mean_offsets.windows(2).enumerate() {
        let ids = &s.map.mean_ids[w[0] as usize..w[1] as usize];
        let m = ids.iter().map(|&v| f.values[v as usize]).sum::<f64>() / ids.len() as f64;
        assert!((f.values[s.map.input_points + i] - m).abs() < 1e-12);
    }
}

/// A box of n³ unit cubes given as polyhedra (faces outward, or in random
/// directions when `flip`), with some interior vertices moved: the cubes
/// around them get non-planar faces and reflex edges; the others stay convex.
fn dented_box(n: usize, flip: bool, rng: &mut Rng) -> Grid {
    let np = n + 1;
    let id = |i: usize, j: usize, k: usize| (i + np * (j + np * k)) as u32;
    let mut pts = Vec::new();
    for k in 0..np {
        for j in 0..np {
            for i in 0..np {
                let mut p = [i as f64, j as f64, k as f64];
                let interior = [i, j, k].iter().all(|&x| x > 0 && x < n);
                if interior && rng.f64() < 0.5 {
                    for c in p.iter_mut() {
                        *c += 0.5 * (rng.f64() - 0.5);
                    }
                }
                pts.push(p);
            }
        }
    }
    let mut cells = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let h = [
                    id(i, j, k),
                    id(i + 1, j, k),
                    id(i + 1, j + 1, k),
                    id(i, j + 1, k),
                    id(i, j, k + 1),
                    id(i + 1, j, k + 1),
                    id(i + 1, j + 1, k + 1),
                    id(i, j + 1, k + 1),
                ];
                let mut faces: Vec<Vec<u32>> = stratasweep::metacell::HEXAHEDRON_FACES
                    .iter()
                    .map(|f| f.iter().map(|&l| h[l as usize]).collect())
                    .collect();
                for f in faces.iter_mut() {
                    if flip && rng.f64() < 0.3 {
                        f.reverse();
                    }
                }
                cells.push(faces);
            }
        }
    }
    grid_of(pts, &cells)
}

/// Per level, the input cells whose vertex range satisfies lo < t ≤ hi.
fn reference_cells(g: &Grid, axis: usize, levels: &[f64]) -> Vec<BTreeSet<u32>> {
    let Topology::Unstructured(cells) = &g.topology else {
        panic!()
    };
    levels
        .iter()
        .map(|&t| {
            (0..cells.len())
                .filter(|&c| {
                    let v = cells.cell(c).iter().map(|&v| g.points[v as usize][axis]);
                    let lo = v.clone().fold(f64::INFINITY, f64::min);
                    let hi = v.fold(f64::NEG_INFINITY, f64::max);
                    lo < t && t <= hi
                })
                .map(|c| c as u32)
                .collect()
        })
        .collect()
}

fn level_sets(r: &SliceResult) -> Vec<BTreeSet<u32>> {
    let m = r.mesh.as_ref().unwrap();
    let mut out = vec![BTreeSet::new(); r.level_values.len()];
    for (p, &c) in m.poly_cell.iter().enumerate() {
        out[m.poly_level[p] as usize].insert(c);
    }
    out
}

#[test]
fn mixed_grid_ciel_brute_force_and_cgraph_agree_with_the_reference() {
    for seed in 0..4 {
        let mut rng = Rng(seed);
        let n = 4;
        let g = dented_box(n, true, &mut rng);
        let s = split_non_convex(&g, None).unwrap().expect("dented cells");
        let nc = s.map.report.non_convex;
        assert!(nc > 0 && nc < n * n * n, "seed {seed}: {nc} non-convex");
        for axis in 0..3 {
            // Generic levels (no vertex sits on one).
            let levels: Vec<f64> = (0..9).map(|k| 0.213 + 0.4437 * k as f64).collect();
            let want = reference_cells(&g, axis, &levels);
            for (choice, bf, threads) in [
                (StructureChoice::Ciel, false, 1),
                (StructureChoice::Ciel, true, 1),
                (StructureChoice::Auto, false, 3),
                (StructureChoice::Auto, true, 1),
            ] {
                let mut req = request(axis, levels.clone(), bf);
                req.threads = threads;
                let st = Structure::build(&g, choice).unwrap();
                assert_eq!(st.live_cells(), n * n * n);
                let r = slice(&g, &st, &req, &|_| {}).unwrap();
                let got = level_sets(&r);
                for k in 0..levels.len() {
                    let tag = format!("seed {seed} axis {axis} {} bf {bf} level {k}", st.name());
                    assert_eq!(got[k], want[k], "{tag}");
                    assert_eq!(r.stats[k].cells as usize, want[k].len(), "{tag}");
                    // The slices of the box are n × n squares.
                    let a = r.stats[k].area;
                    assert!((a - (n * n) as f64).abs() < 1e-4, "{tag}: area {a}");
                }
            }
        }
    }
}

#[test]
fn split_cells_carry_their_source_cell_values() {
    // Runs of unsplit cells and pieces of split ones, one- and
    // three-component cell properties: every output cell holds its source
    // cell's tuple.
    let mut g = dented_box(6, false, &mut Rng(11));
    let n = g.cell_count();
    let vec3: Vec<f64> = (0..3 * n).map(|i| i as f64 * 0.5 - 7.0).collect();
    g.cell_data.push(Property {
        name: "v".into(),
        components: 3,
        values: vec3.clone(),
    });
    let s = split_non_convex(&g, None)
        .unwrap()
        .expect("dented cells split");
    let src = &s.map.source;
    assert!(src.len() > n, "some cells split into pieces");
    assert!(src.windows(2).any(|w| w[0] == w[1]) && src.windows(2).any(|w| w[1] == w[0] + 1));
    let id = &s.grid.cell_data[0];
    let v = &s.grid.cell_data[1];
    assert_eq!(
        (id.values.len(), v.values.len(), v.components),
        (src.len(), 3 * src.len(), 3)
    );
    for (o, &c) in src.iter().enumerate() {
        let c = c as usize;
        assert_eq!(id.values[o], c as f64 * 10.0, "output cell {o}");
        assert_eq!(
            v.values[3 * o..3 * o + 3],
            vec3[3 * c..3 * c + 3],
            "output cell {o}"
        );
    }
}

#[test]
fn split_without_properties_has_the_same_cells_and_hidden_flags() {
    // The structures' split (no properties) gives the same cells, points
    // and map as the full split, and the pieces' hidden flags from the map
    // equal those the full split grid's gathered vtkGhostType gives.
    let mut g = dented_box(6, true, &mut Rng(5));
    let n = g.cell_count();
    let ghost: Vec<f64> = (0..n)
        .map(|c| if c % 5 == 2 { 32.0 } else { 0.0 })
        .collect();
    g.cell_data.push(Property {
        name: "vtkGhostType".into(),
        components: 1,
        values: ghost,
    });
    let hidden = g.hidden_cells().expect("ghost array");
    let full = split_non_convex(&g, Some(&hidden))
        .unwrap()
        .expect("dented cells split");
    let bare = split_non_convex_cells(&g, Some(&hidden))
        .unwrap()
        .expect("dented cells split");
    assert!(full.map.report.non_convex > 0);
    assert_eq!(bare.grid.topology, full.grid.topology);
    assert_eq!(bare.grid.points, full.grid.points);
    assert_eq!(bare.map.source, full.map.source);
    assert_eq!(
        (&bare.map.mean_offsets, &bare.map.mean_ids),
        (&full.map.mean_offsets, &full.map.mean_ids)
    );
    assert!(bare.grid.cell_data.is_empty() && bare.grid.point_data.is_empty());
    let from_map = bare.map.hidden_cells(Some(&hidden)).expect("hidden given");
    let gathered = full.grid.hidden_cells().expect("ghost array gathered");
    assert_eq!(from_map, gathered);
    assert!(from_map.iter().any(|&h| h) && from_map.iter().any(|&h| !h));
    assert_eq!(bare.map.hidden_cells(None), None);
}

#[test]
fn split_output_does_not_depend_on_threads() {
    let g = dented_box(5, true, &mut Rng(7));
    let levels: Vec<f64> = (0..7).map(|k| 0.31 + 0.7 * k as f64).collect();
    let s = Structure::build(&g, StructureChoice::Auto).unwrap();
    assert!(s.split().is_some());
    let mut req = request(2, levels, false);
    let one = slice(&g, &s, &req, &|_| {}).unwrap().mesh.unwrap();
    req.threads = 4;
    let four = slice(&g, &s, &req, &|_| {}).unwrap().mesh.unwrap();
    assert_eq!(one.poly_cell, four.poly_cell);
    assert_eq!(one.poly_indices, four.poly_indices);
    assert_eq!(one.positions, four.positions);
}

/// A cell that cannot be split costs that cell, not the grid: it is
/// skipped, counted and named with its reason, and the other cells are
/// sliced (they used to be refused with the whole grid).
#[test]
fn non_star_shaped_cell_is_skipped_and_named() {
    // A U-shaped prism: the two arms' inner walls face each other, so no
    // point sees both.
    let u = [
        [0., 0.],
        [3., 0.],
        [3., 1.],
        [1., 1.],
        [1., 2.],
        [3., 2.],
        [3., 3.],
        [0., 3.],
    ];
    let mut pts = Vec::new();
    let cube = prism(
        &mut pts,
        &[[0., 0.], [1., 0.], [1., 1.], [0., 1.]],
        1.0,
        &|p| [p[0] - 5.0, p[1], p[2]],
    );
    let uf = prism(&mut pts, &u, 1.0, &|p| p);
    let g = grid_of(pts, &[cube, uf]);
    let r = split_non_convex(&g, None)
        .unwrap()
        .expect("split")
        .map
        .report;
    assert_eq!((r.skipped, r.skipped_first.clone()), (1, vec![1]), "{r:?}");
    assert!(
        r.skipped_reason.contains("cell 1") && r.skipped_reason.contains("star-shaped"),
        "{}",
        r.skipped_reason
    );
    for choice in [StructureChoice::Ciel, StructureChoice::Auto] {
        let s = Structure::build(&g, choice).unwrap();
        assert_eq!(s.live_cells(), 1, "{choice:?}");
        let notes = s.cell_notes();
        assert!(
            notes.len() == 1 && notes[0].contains("[1]") && notes[0].contains("star-shaped"),
            "{notes:?}"
        );
        // Only the cube is cut: unit area at every level through it.
        let res = run(&g, choice, &request(2, vec![0.25, 0.5, 0.75], false));
        for st in &res.stats {
            assert!((st.area - 1.0).abs() < 1e-6, "{choice:?}: {}", st.area);
        }
    }
    // Hidden, it is left alone.
    let mut g = g;
    g.cell_data
        .push(Property::scalar("vtkGhostType", vec![0.0, 32.0]));
    let s = Structure::build(&g, StructureChoice::Ciel).unwrap();
    assert!(s.cell_notes().is_empty(), "{:?}", s.cell_notes());
}

/// Unit cubes as 6-face polyhedra, `n` per axis; with `bad`, the grid's
/// corner vertex (in the first cell only) is moved so that that cell's
/// bottom face crosses itself (it cannot be triangulated). Cells listed in
/// `skip` are left out.
fn cube_polyhedra(n: [usize; 3], bad: bool, skip: &[usize]) -> Grid {
    let pid = |i: usize, j: usize, k: usize| (i + (n[0] + 1) * (j + (n[1] + 1) * k)) as u32;
    let mut points = Vec::new();
    for k in 0..=n[2] {
        for j in 0..=n[1] {
            for i in 0..=n[0] {
                points.push([i as f64, j as f64, k as f64 * 0.7]);
            }
        }
    }
    if bad {
        points[0] = [2.0, 0.5, 0.0];
    }
    let mut cells = Vec::new();
    let mut c = 0;
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let v = |a: usize, b: usize, d: usize| pid(i + a, j + b, k + d);
                let faces = vec![
                    vec![v(0, 0, 0), v(0, 1, 0), v(1, 1, 0), v(1, 0, 0)],
                    vec![v(0, 0, 1), v(1, 0, 1), v(1, 1, 1), v(0, 1, 1)],
                    vec![v(0, 0, 0), v(1, 0, 0), v(1, 0, 1), v(0, 0, 1)],
                    vec![v(0, 1, 0), v(0, 1, 1), v(1, 1, 1), v(1, 1, 0)],
                    vec![v(0, 0, 0), v(0, 0, 1), v(0, 1, 1), v(0, 1, 0)],
                    vec![v(1, 0, 0), v(1, 1, 0), v(1, 1, 1), v(1, 0, 1)],
                ];
                if !skip.contains(&c) {
                    cells.push(faces);
                }
                c += 1;
            }
        }
    }
    grid_of(points, &cells)
}

/// One face that cannot be triangulated (it crosses itself) costs its one
/// cell, named in the report and the notes; the grid loads and the other
/// cells slice exactly as the same grid without that cell does, on every
/// structure and the brute force (before: "cell 0, face 0: the face cannot
/// be triangulated", and no structure at all).
#[test]
fn an_untriangulable_face_costs_one_cell() {
    let n = [3, 3, 2];
    let g = cube_polyhedra(n, true, &[]);
    let want = cube_polyhedra(n, false, &[0]);
    let r = split_non_convex_cells(&g, None)
        .unwrap()
        .expect("split")
        .map
        .report;
    assert_eq!((r.skipped, r.skipped_first.clone()), (1, vec![0]), "{r:?}");
    assert!(r.skipped_reason.contains("cell 0"), "{}", r.skipped_reason);
    for axis in 0..3 {
        let levels: Vec<f64> = (1..12).map(|k| k as f64 * 0.25 + 0.011).collect();
        let reference = run(
            &want,
            StructureChoice::Auto,
            &request(axis, levels.clone(), false),
        );
        for (choice, brute) in [
            (StructureChoice::Auto, false),
            (StructureChoice::Auto, true),
            (StructureChoice::Ciel, false),
            (StructureChoice::CGraph, false),
        ] {
            let s = Structure::build(&g, choice).unwrap();
            assert_eq!(s.live_cells(), n[0] * n[1] * n[2] - 1, "{choice:?}");
            let notes = s.cell_notes();
            assert!(
                notes.len() == 1 && notes[0].contains("first ids [0]"),
                "{notes:?}"
            );
            let res = run(&g, choice, &request(axis, levels.clone(), brute));
            for (k, (a, b)) in res.stats.iter().zip(&reference.stats).enumerate() {
                assert_eq!(a.cells, b.cells, "{choice:?} axis {axis} level {k}");
                assert!(
                    (a.area - b.area).abs() < 1e-6 * b.area.max(1.0),
                    "{choice:?} axis {axis} level {k}: {} vs {}",
                    a.area,
                    b.area
                );
            }
        }
    }
}

/// VTK's plane cutter on the same non-convex cells, written to a temporary
/// `.vtu` (the peer's Python from STRATASWEEP_PEER_PYTHON, else
/// `.venv-peer` in the crate).
#[test]
fn areas_match_vtk_on_non_convex_cells() {
    let Some((py, script)) = support::peer::peer("VTK comparison of split cells") else {
        return;
    };
    let dir = support::tmp_dir("convex-split");
    let mut cases: Vec<(&str, Grid, usize)> = Vec::new();
    let mut pts = Vec::new();
    let f = prism(&mut pts, &L, 1.0, &rot45);
    cases.push(("lprism", grid_of(pts, &[f]), 0));
    let mut pts = Vec::new();
    let f = valley(&mut pts, 0.2, [0.0; 3]);
    cases.push(("valley", grid_of(pts, &[f]), 2));
    let mut pts = Vec::new();
    let f = stellated(&mut pts, [0.0; 3]);
    cases.push(("stellated", grid_of(pts, &[f]), 2));
    // Outward faces: VTK slices inward-facing polyhedra wrongly (see
    // ARCHITECTURE, pebi3d).
    cases.push(("dented", dented_box(3, false, &mut Rng(3)), 1));
    let count = 17;
    for (name, g, axis) in cases {
        let path = dir.join(format!("{name}.vtu"));
        stratasweep::io::writers::write_vtk_xml_grid(&path, &g).unwrap();
        let v = support::peer::vtk_slices(&py, &script, &path, axis, count);
        let values: Vec<f64> = v["slices"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["value"].as_f64().unwrap())
            .collect();
        let r = run(
            &g,
            StructureChoice::Ciel,
            &request(axis, values.clone(), false),
        );
        let mut worst = 0.0f64;
        for (k, s) in v["slices"].as_array().unwrap().iter().enumerate() {
            let pa = s["area"].as_f64().unwrap();
            let rel = (r.stats[k].area - pa).abs() / pa.max(1e-12);
            worst = worst.max(rel);
            assert!(
                rel < 1e-5,
                "{name}: slice {k} at {}: area {} vs VTK {pa}",
                values[k],
                r.stats[k].area
            );
        }
        eprintln!("{name}: {count} slices, worst relative area difference to VTK {worst:.2e}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
