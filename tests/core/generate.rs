//! Tests of the synthetic grid generators: orientation, conformity,
//! exact box filling, Jacobians, determinism and the property ranges.

use std::collections::HashMap;
use stratasweep::generate::{UTM_OFFSET, marschner_lobb, warped, zoo};
use stratasweep::grid::{Cells, Grid, Topology, vtk_type};

type P = [f64; 3];

fn sub(a: P, b: P) -> P {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: P, b: P) -> P {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn dot(a: P, b: P) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn det(a: P, b: P, c: P) -> f64 {
    dot(a, cross(b, c))
}
fn mean(ps: impl Iterator<Item = P>) -> P {
    let mut s = [0.0; 3];
    let mut n = 0.0;
    for p in ps {
        for a in 0..3 {
            s[a] += p[a];
        }
        n += 1.0;
    }
    s.map(|v| v / n)
}

/// Outward faces (local vertex ids) of the VTK linear cells, written from
/// VTK's conventions independently of the generator.
fn outward_faces(t: u8) -> Vec<Vec<usize>> {
    match t {
        vtk_type::TETRA => vec![vec![0, 2, 1], vec![0, 1, 3], vec![1, 2, 3], vec![0, 3, 2]],
        vtk_type::PYRAMID => vec![
            vec![0, 3, 2, 1],
            vec![0, 1, 4],
            vec![1, 2, 4],
            vec![2, 3, 4],
            vec![3, 0, 4],
        ],
        vtk_type::WEDGE => vec![
            vec![0, 2, 1],
            vec![3, 4, 5],
            vec![0, 1, 4, 3],
            vec![1, 2, 5, 4],
            vec![2, 0, 3, 5],
        ],
        vtk_type::HEXAHEDRON => vec![
            vec![0, 3, 2, 1],
            vec![4, 5, 6, 7],
            vec![0, 1, 5, 4],
            vec![1, 2, 6, 5],
            vec![2, 3, 7, 6],
            vec![3, 0, 4, 7],
        ],
        t => panic!("unexpected cell type {t}"),
    }
}

/// Triangles of a face (global ids → positions): triangles as is, larger
/// faces as a fan from the face centroid (orientation independent, so both
/// sides of a shared face triangulate identically).
fn face_triangles(pts: &[P], face: &[u32]) -> Vec<[P; 3]> {
    let q: Vec<P> = face.iter().map(|&v| pts[v as usize]).collect();
    if q.len() == 3 {
        return vec![[q[0], q[1], q[2]]];
    }
    let mut sorted: Vec<u32> = face.to_vec();
    sorted.sort_unstable();
    let c = mean(sorted.iter().map(|&v| pts[v as usize]));
    (0..q.len())
        .map(|i| [c, q[i], q[(i + 1) % q.len()]])
        .collect()
}

/// Signed volume of a cell and the minimum signed volume of its
/// decomposition into tets (cell centroid, outward face triangle).
fn cell_volume(pts: &[P], t: u8, ids: &[u32]) -> (f64, f64) {
    let o = mean(ids.iter().map(|&v| pts[v as usize]));
    let mut vol = 0.0;
    let mut min_tet = f64::INFINITY;
    for f in outward_faces(t) {
        let g: Vec<u32> = f.iter().map(|&l| ids[l]).collect();
        for [a, b, c] in face_triangles(pts, &g) {
            let v = det(sub(a, o), sub(b, o), sub(c, o)) / 6.0;
            vol += v;
            min_tet = min_tet.min(v);
        }
    }
    (vol, min_tet)
}

fn cells_of(g: &Grid) -> &Cells {
    match &g.topology {
        Topology::Unstructured(c) => c,
        _ => panic!("expected an unstructured grid"),
    }
}

#[test]
fn reference_cells_have_positive_volume() {
    // Sanity check of the test's own volume code on unit cells in VTK order.
    let pts: Vec<P> = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
        [0.5, 0.5, 1.0],
    ];
    let (v, _) = cell_volume(&pts, vtk_type::HEXAHEDRON, &[0, 1, 2, 3, 4, 5, 6, 7]);
    assert!((v - 1.0).abs() < 1e-12, "{v}");
    let (v, _) = cell_volume(&pts, vtk_type::WEDGE, &[0, 1, 3, 4, 5, 7]);
    assert!((v - 0.5).abs() < 1e-12, "{v}");
    let (v, _) = cell_volume(&pts, vtk_type::PYRAMID, &[0, 1, 2, 3, 8]);
    assert!((v - 1.0 / 3.0).abs() < 1e-12, "{v}");
    let (v, _) = cell_volume(&pts, vtk_type::TETRA, &[0, 1, 3, 4]);
    assert!((v - 1.0 / 6.0).abs() < 1e-12, "{v}");
    // Reversed orientation is negative.
    let (v, _) = cell_volume(&pts, vtk_type::TETRA, &[0, 3, 1, 4]);
    assert!(v < 0.0);
}

#[test]
fn zoo_cells_have_positive_volume_and_fill_the_box() {
    for seed in [1u64, 2, 3] {
        let g = zoo(20_000, seed);
        g.validate().unwrap();
        let cells = cells_of(&g);
        let mut total = 0.0;
        for c in 0..cells.len() {
            let (v, min_tet) = cell_volume(&g.points, cells.types[c], cells.cell(c));
            assert!(
                v > 0.0,
                "seed {seed}: cell {c} (type {}) has volume {v}",
                cells.types[c]
            );
            assert!(
                min_tet > 0.0,
                "seed {seed}: cell {c} (type {}) has an inverted sub-tet {min_tet}",
                cells.types[c]
            );
            total += v;
        }
        assert!(
            (total - 8.0).abs() < 8.0 * 1e-9,
            "seed {seed}: total volume {total}, box is 8"
        );
        let (lo, hi) = g.bounds();
        assert_eq!((lo, hi), ([-1.0; 3], [1.0; 3]));
    }
}

#[test]
fn zoo_contains_all_four_types_in_sensible_proportions() {
    let g = zoo(50_000, 7);
    let cells = cells_of(&g);
    let n = cells.len() as f64;
    assert!(
        (n - 50_000.0).abs() < 0.25 * 50_000.0,
        "{n} cells for a target of 50000"
    );
    let frac = |t: u8| cells.types.iter().filter(|&&x| x == t).count() as f64 / n;
    let (tet, pyr, wedge, hex) = (
        frac(vtk_type::TETRA),
        frac(vtk_type::PYRAMID),
        frac(vtk_type::WEDGE),
        frac(vtk_type::HEXAHEDRON),
    );
    eprintln!("zoo fractions: tet {tet:.3} pyramid {pyr:.3} wedge {wedge:.3} hex {hex:.3}");
    for (name, f) in [
        ("tet", tet),
        ("pyramid", pyr),
        ("wedge", wedge),
        ("hex", hex),
    ] {
        assert!((0.05..0.7).contains(&f), "{name} fraction {f}");
    }
    assert!(
        (tet + pyr + wedge + hex - 1.0).abs() < 1e-12,
        "only the four types are used"
    );
}

#[test]
fn zoo_is_conforming_and_watertight() {
    for seed in [4u64, 5] {
        let g = zoo(20_000, seed);
        let cells = cells_of(&g);
        // sorted vertex set -> the oriented faces seen so far
        let mut faces: HashMap<Vec<u32>, Vec<Vec<u32>>> = HashMap::new();
        for c in 0..cells.len() {
            let ids = cells.cell(c);
            for f in outward_faces(cells.types[c]) {
                let g: Vec<u32> = f.iter().map(|&l| ids[l]).collect();
                let mut key = g.clone();
                key.sort_unstable();
                faces.entry(key).or_default().push(g);
            }
        }
        let mut area = 0.0;
        let mut boundary = 0;
        for (key, occ) in &faces {
            assert!(
                occ.len() <= 2,
                "seed {seed}: face {key:?} is shared by {} cells",
                occ.len()
            );
            if occ.len() == 2 {
                // Opposite orientations: the second is a rotation of the first reversed.
                let a = &occ[0];
                let mut b = occ[1].clone();
                b.reverse();
                let r = b.iter().position(|&v| v == a[0]).unwrap();
                b.rotate_left(r);
                assert_eq!(
                    a, &b,
                    "seed {seed}: shared face {key:?} not oppositely oriented"
                );
                continue;
            }
            boundary += 1;
            // A boundary face must lie in one box plane.
            let on_plane = (0..3).any(|ax| {
                [-1.0, 1.0]
                    .iter()
                    .any(|&s| key.iter().all(|&v| g.points[v as usize][ax] == s))
            });
            assert!(
                on_plane,
                "seed {seed}: face {key:?} is unmatched but not on the box boundary"
            );
            for [a, b, c] in face_triangles(&g.points, &occ[0]) {
                let n = cross(sub(b, a), sub(c, a));
                area += 0.5 * dot(n, n).sqrt();
            }
        }
        assert!(boundary > 0);
        assert!(
            (area - 24.0).abs() < 24.0 * 1e-9,
            "seed {seed}: boundary area {area}, box surface is 24"
        );
    }
}

#[test]
fn zoo_is_deterministic_and_seed_dependent() {
    assert_eq!(zoo(5_000, 42), zoo(5_000, 42));
    assert_ne!(zoo(5_000, 42), zoo(5_000, 43));
}

#[test]
fn zoo_property_is_noisy_but_bounded() {
    let g = zoo(5_000, 9);
    let f = g.point_property("f").expect("property f");
    assert_eq!(f.len(), g.points.len());
    assert!(
        f.values
            .iter()
            .all(|v| v.is_finite() && (-0.2..=1.5).contains(v))
    );
    let (lo, hi) = f
        .values
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(hi - lo > 0.5, "range {lo}..{hi}");
}

/// Positions of the 8 lattice corners of cell (i, j, k) of a structured grid.
fn corner(g: &Grid, d: [usize; 3], i: usize, j: usize, k: usize) -> P {
    g.points[i + d[0] * (j + d[1] * k)]
}

#[test]
fn warped_jacobians_are_positive_at_all_corners() {
    for (dims, seed) in [
        ([12, 9, 7], 1u64),
        ([5, 5, 5], 2),
        ([1, 1, 1], 3),
        ([30, 4, 16], 4),
    ] {
        let g = warped(dims, seed);
        g.validate().unwrap();
        let Topology::Structured { dims: d } = g.topology else {
            panic!("structured expected")
        };
        assert_eq!(d, dims.map(|n| n + 1));
        assert_eq!(g.cell_count(), dims[0] * dims[1] * dims[2]);
        let mut min_rel = f64::INFINITY;
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    for (a, b, c) in (0..8).map(|m| (m & 1, (m >> 1) & 1, (m >> 2) & 1)) {
                        let p = |x: usize, y: usize, z: usize| corner(&g, d, i + x, j + y, k + z);
                        let ex = sub(p(1, b, c), p(0, b, c));
                        let ey = sub(p(a, 1, c), p(a, 0, c));
                        let ez = sub(p(a, b, 1), p(a, b, 0));
                        let jac = det(ex, ey, ez);
                        let scale = dot(ex, ex).sqrt() * dot(ey, ey).sqrt() * dot(ez, ez).sqrt();
                        assert!(
                            jac > 0.0,
                            "dims {dims:?} cell ({i},{j},{k}) corner ({a},{b},{c}): J = {jac}"
                        );
                        min_rel = min_rel.min(jac / scale);
                    }
                }
            }
        }
        assert!(
            min_rel > 0.3,
            "dims {dims:?}: scaled Jacobian down to {min_rel}"
        );
    }
}

#[test]
fn warped_is_off_axis_far_from_origin_and_about_unit_size() {
    for seed in 0..8u64 {
        let dims = [16, 12, 10];
        let g = warped(dims, seed);
        let d = dims.map(|n| n + 1);
        let (lo, hi) = g.bounds();
        for a in 0..3 {
            let centre = 0.5 * (lo[a] + hi[a]);
            assert!(
                (centre - UTM_OFFSET[a]).abs() < 0.3,
                "seed {seed} axis {a}: centre {centre}"
            );
            let ext = hi[a] - lo[a];
            assert!(
                (1.9..3.6).contains(&ext),
                "seed {seed} axis {a}: extent {ext}"
            );
        }
        // The lattice's I, J, K directions are rotated away from every world axis.
        for (p, q) in [
            (corner(&g, d, 0, 0, 0), corner(&g, d, dims[0], 0, 0)),
            (corner(&g, d, 0, 0, 0), corner(&g, d, 0, dims[1], 0)),
            (corner(&g, d, 0, 0, 0), corner(&g, d, 0, 0, dims[2])),
        ] {
            let v = sub(q, p);
            let len = dot(v, v).sqrt();
            for a in 0..3 {
                let cos = (v[a] / len).abs();
                assert!(
                    cos < 2f64.to_radians().cos(),
                    "seed {seed}: lattice direction {v:?} is axis aligned"
                );
            }
        }
    }
}

#[test]
fn warped_property_is_marschner_lobb_of_the_reference_lattice() {
    let dims = [20, 17, 11];
    let g = warped(dims, 5);
    let f = g.point_property("f").expect("property f");
    assert_eq!(f.len(), g.points.len());
    assert!(f.values.iter().all(|v| (0.0..=1.0).contains(v)));
    let (lo, hi) = f
        .values
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(lo < 0.1 && hi > 0.9, "range {lo}..{hi}");
    let d = dims.map(|n| n + 1);
    for k in 0..d[2] {
        for j in 0..d[1] {
            for i in 0..d[0] {
                let u = [
                    i as f64 / dims[0] as f64,
                    j as f64 / dims[1] as f64,
                    k as f64 / dims[2] as f64,
                ]
                .map(|t| 2.0 * t - 1.0);
                let v = f.values[i + d[0] * (j + d[1] * k)];
                assert!((v - marschner_lobb(u)).abs() < 1e-12, "({i},{j},{k})");
            }
        }
    }
    // Spot values of the published formula.
    assert!((marschner_lobb([0.0, 0.0, -1.0]) - 1.0).abs() < 1e-12); // (1+1+α·2)/(2(1+α)) = 1
    assert!((marschner_lobb([0.0, 0.0, 1.0]) - 0.2).abs() < 1e-12); // 2α/(2(1+α)) = 0.2
}

#[test]
fn warped_is_deterministic_and_seed_dependent() {
    assert_eq!(warped([6, 5, 4], 11), warped([6, 5, 4], 11));
    assert_ne!(warped([6, 5, 4], 11).points, warped([6, 5, 4], 12).points);
}

/// The seed scan: small faulted grids (few cells, several faults), where
/// the fold and the thickness waves used to twist a cell's face over itself
/// (5×4×3 with 3 faults: 7 of 12 seeds gave a face that cannot be
/// triangulated, and the grid did not load), have no face that crosses
/// itself, build with no cell skipped or decomposed, and slice as the brute
/// force does, level by level.
#[test]
fn small_faulted_grids_have_no_crossed_face_and_slice_as_the_brute_force() {
    use stratasweep::field::FieldSpec;
    use stratasweep::grid::IjkLayout;
    use stratasweep::pipeline::{LevelSpec, SliceRequest, slice};
    use stratasweep::structures::{Structure, StructureChoice};
    let mut grids = 0;
    for dims in [[5, 4, 3], [3, 3, 2], [4, 4, 4], [6, 5, 3], [8, 6, 4]] {
        for faults in [2, 3, 4] {
            for seed in 0..=11u64 {
                let cp = stratasweep::generate::faulted(dims, faults, seed);
                let (grid, rep) = cp.into_grid().unwrap();
                let label = format!("{dims:?} faults {faults} seed {seed}");
                let (crossed, _) =
                    stratasweep::structures::cell_check::self_intersecting_cells(&grid, 5);
                assert_eq!(crossed.len(), 0, "{label}: cells {crossed:?}");
                let layout = IjkLayout {
                    dims,
                    source_cell: rep.source_cell,
                };
                let s = Structure::build_with(&grid, StructureChoice::Auto, Some(&layout))
                    .unwrap_or_else(|e| panic!("{label}: {e}"));
                if let Some(m) = s.split() {
                    let r = &m.report;
                    assert_eq!((r.skipped, r.twisted), (0, 0), "{label}: {r:?}");
                }
                assert_eq!(s.twisted_left(), 0, "{label}");
                assert!(s.cell_notes().is_empty(), "{label}: {:?}", s.cell_notes());
                for axis in 0..3 {
                    let mut req = SliceRequest {
                        field: FieldSpec::Axis {
                            axis,
                            negative: false,
                        },
                        levels: LevelSpec::Count(9),
                        attribute: None,
                        threads: 1,
                        brute_force: false,
                        collect_mesh: false,
                        sweep: Default::default(),
                    };
                    let ours = slice(&grid, &s, &req, &|_| {}).unwrap();
                    req.brute_force = true;
                    let brute = slice(&grid, &s, &req, &|_| {}).unwrap();
                    for (k, (a, b)) in ours.stats.iter().zip(&brute.stats).enumerate() {
                        assert_eq!(a.cells, b.cells, "{label} axis {axis} level {k}");
                        assert!(
                            (a.area - b.area).abs() <= 1e-9 * b.area.max(1.0),
                            "{label} axis {axis} level {k}: {} vs {}",
                            a.area,
                            b.area
                        );
                    }
                    assert!(ours.stats.iter().any(|st| st.area > 0.0), "{label}");
                }
                grids += 1;
            }
        }
    }
    assert_eq!(grids, 180);
}
