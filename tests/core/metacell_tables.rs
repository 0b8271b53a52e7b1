//! Every code of every meta-cell: loops are closed, use only intersected
//! edges, use every intersected edge exactly once, and are oriented toward
//! increasing φ.

use stratasweep::grid::vtk_type;
use stratasweep::metacell::{Catalog, MetaCell, builtin};
use stratasweep::structures::{CellClass, classify_cell};

fn catalog_with_prisms() -> Catalog {
    let mut c = Catalog::new();
    c.for_vtk_type(vtk_type::PENTAGONAL_PRISM).unwrap();
    c.for_vtk_type(vtk_type::HEXAGONAL_PRISM).unwrap();
    c
}

/// Reference coordinates of each meta-cell by name (positively oriented, convex).
fn reference_coords(m: &MetaCell) -> Vec<[f64; 3]> {
    let ngon = |n: usize, z: f64| -> Vec<[f64; 3]> {
        (0..n)
            .map(|i| {
                let a = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
                [a.cos(), a.sin(), z]
            })
            .collect()
    };
    match m.name.as_str() {
        "tetrahedron" => vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
        "pyramid" => vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.5, 1.0],
        ],
        // VTK wedge: (0,1,2) normal points toward (3,4,5).
        "wedge" => vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [0.0, 1.0, 1.0],
        ],
        "hexahedron" => vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 1.0],
        ],
        "pentagonal prism" => [ngon(5, 0.0), ngon(5, 1.0)].concat(),
        "hexagonal prism" => [ngon(6, 0.0), ngon(6, 1.0)].concat(),
        other => panic!("no reference coordinates for {other}"),
    }
}

fn face_of_edge_pair(m: &MetaCell, e1: u8, e2: u8) -> bool {
    let [a, b] = m.edges[e1 as usize];
    let [c, d] = m.edges[e2 as usize];
    m.faces.iter().any(|f| {
        let has = |x: u8, y: u8| {
            (0..f.len()).any(|i| {
                let (p, q) = (f[i], f[(i + 1) % f.len()]);
                (p == x && q == y) || (p == y && q == x)
            })
        };
        has(a, b) && has(c, d)
    })
}

#[test]
fn every_code_of_every_meta_cell_gives_closed_loops_over_intersected_edges() {
    let cat = catalog_with_prisms();
    assert_eq!(cat.metas.len(), 6);
    for m in &cat.metas {
        let mut ambiguous = 0;
        for code in 0..m.code_count() {
            let above = |v: u8| code >> v & 1 == 1;
            let crossed: Vec<u8> = (0..m.edges.len() as u8)
                .filter(|&e| {
                    let [a, b] = m.edges[e as usize];
                    above(a) != above(b)
                })
                .collect();
            let nvar = 1u32 << m.ambiguous_faces[code].count_ones();
            if m.config_is_ambiguous(code) {
                ambiguous += 1;
            }
            for outcome in 0..nvar {
                let mut used = vec![0; m.edges.len()];
                for lp in m.loops(code, outcome) {
                    assert!(
                        lp.len() >= 3,
                        "{} code {code}: loop of {} edges",
                        m.name,
                        lp.len()
                    );
                    for i in 0..lp.len() {
                        let e = lp[i];
                        assert!(
                            crossed.contains(&e),
                            "{} code {code}: edge {e} not intersected",
                            m.name
                        );
                        used[e as usize] += 1;
                        // Closed: consecutive edges (cyclically) share a face.
                        assert!(
                            face_of_edge_pair(m, e, lp[(i + 1) % lp.len()]),
                            "{} code {code}: loop not closed",
                            m.name
                        );
                    }
                }
                for &e in &crossed {
                    assert_eq!(
                        used[e as usize], 1,
                        "{} code {code} variant {outcome}: edge {e} used {} times",
                        m.name, used[e as usize]
                    );
                }
                if code == 0 || code == m.code_count() - 1 {
                    assert_eq!(m.loops(code, outcome).count(), 0);
                }
            }
        }
        match m.name.as_str() {
            "tetrahedron" => assert_eq!(ambiguous, 0),
            "hexahedron" => assert!(ambiguous > 0, "hex must have ambiguous codes"),
            _ => {}
        }
    }
}

#[test]
fn loops_are_oriented_toward_increasing_phi_for_linear_fields() {
    let cat = catalog_with_prisms();
    let dirs = [
        [0.3, 0.5, 0.81],
        [-0.7, 0.2, 0.1],
        [0.05, -0.9, 0.4],
        [0.6, 0.6, -0.5],
    ];
    for m in &cat.metas {
        let x = reference_coords(m);
        assert!(
            m.signed_volume(&|v| x[v]) > 0.0,
            "{}: reference coords not positive",
            m.name
        );
        for d in dirs {
            let phi: Vec<f64> = x
                .iter()
                .map(|p| p[0] * d[0] + p[1] * d[1] + p[2] * d[2])
                .collect();
            let (lo, hi) = phi
                .iter()
                .fold((f64::MAX, f64::MIN), |a, &v| (a.0.min(v), a.1.max(v)));
            for s in 1..8 {
                let t = lo + (hi - lo) * s as f64 / 8.0 + 1e-7;
                let code = (0..m.nv).fold(0, |c, v| c | ((phi[v] >= t) as usize) << v);
                let mut loops = 0;
                for lp in m.loops(code, 0) {
                    loops += 1;
                    let pts: Vec<[f64; 3]> = lp
                        .iter()
                        .map(|&e| {
                            let [a, b] = m.edges[e as usize];
                            let (a, b) = (a as usize, b as usize);
                            let s = (t - phi[a]) / (phi[b] - phi[a]);
                            [0, 1, 2].map(|k| x[a][k] + s * (x[b][k] - x[a][k]))
                        })
                        .collect();
                    let mut n = [0.0; 3];
                    for i in 1..pts.len() - 1 {
                        let u = [0, 1, 2].map(|k| pts[i][k] - pts[0][k]);
                        let v = [0, 1, 2].map(|k| pts[i + 1][k] - pts[0][k]);
                        n[0] += u[1] * v[2] - u[2] * v[1];
                        n[1] += u[2] * v[0] - u[0] * v[2];
                        n[2] += u[0] * v[1] - u[1] * v[0];
                    }
                    let dot = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
                    assert!(
                        dot > 0.0,
                        "{} code {code}: loop normal points against grad φ",
                        m.name
                    );
                }
                // A plane cuts a convex cell in one polygon.
                if code != 0 && code != m.code_count() - 1 {
                    assert_eq!(loops, 1, "{} code {code}", m.name);
                }
            }
        }
    }
}

#[test]
fn hexahedron_two_opposite_corners_give_two_triangles() {
    let cat = Catalog::new();
    let hex = cat.get(builtin::HEXAHEDRON);
    let code = 1 | 1 << 6;
    assert!(!hex.config_is_ambiguous(code));
    let sizes: Vec<usize> = hex.loops(code, 0).map(|l| l.len()).collect();
    assert_eq!(sizes, vec![3, 3]);
    // Face-diagonal corners: the shared face is ambiguous, two variants.
    let code = 1 | 1 << 2;
    assert!(hex.config_is_ambiguous(code));
    let a: Vec<usize> = hex.loops(code, 0).map(|l| l.len()).collect();
    let b: Vec<usize> = hex.loops(code, 1).map(|l| l.len()).collect();
    assert_eq!(a, vec![3, 3]);
    assert_eq!(b, vec![6]);
}

#[test]
fn invalid_face_descriptions_are_rejected() {
    let open = vec![vec![0u8, 1, 2], vec![0, 3, 1], vec![1, 3, 2]];
    assert!(MetaCell::from_faces("open", 4, open).is_err());
    let flipped = vec![vec![0u8, 1, 3], vec![1, 2, 3], vec![2, 0, 3], vec![0, 1, 2]];
    assert!(MetaCell::from_faces("inconsistent", 4, flipped).is_err());
    let tiny = vec![vec![0u8, 1]];
    assert!(MetaCell::from_faces("degenerate", 2, tiny).is_err());
    assert!(MetaCell::from_faces("big", 13, vec![]).is_err());
}

/// The signed volume as first written (generic over the face lists, one
/// accumulator), kept here as the reference for the unrolled paths.
fn reference_signed_volume(m: &MetaCell, pos: &[[f64; 3]]) -> f64 {
    let n = m.nv;
    let mut c = [0.0; 3];
    for p in &pos[..n] {
        for a in 0..3 {
            c[a] += p[a];
        }
    }
    let pts: Vec<[f64; 3]> = pos[..n]
        .iter()
        .map(|p| std::array::from_fn(|a| p[a] - c[a] * (1.0 / n as f64)))
        .collect();
    let mut six_vol = 0.0;
    for f in &m.faces {
        let mut fc = [0.0; 3];
        for &v in f {
            for a in 0..3 {
                fc[a] += pts[v as usize][a];
            }
        }
        let fc = fc.map(|x| x * (1.0 / f.len() as f64));
        let mut prev = pts[*f.last().unwrap() as usize];
        for &v in f {
            let cur = pts[v as usize];
            six_vol += fc[0] * (prev[1] * cur[2] - prev[2] * cur[1])
                - fc[1] * (prev[0] * cur[2] - prev[2] * cur[0])
                + fc[2] * (prev[0] * cur[1] - prev[1] * cur[0]);
            prev = cur;
        }
    }
    six_vol / 6.0
}

/// The cell classification as first written, kept as the reference.
fn reference_class(m: &MetaCell, ids: &[u32], points: &[[f64; 3]]) -> CellClass {
    for a in 0..ids.len() {
        for b in a + 1..ids.len() {
            if ids[a] == ids[b] || points[ids[a] as usize] == points[ids[b] as usize] {
                return CellClass::RepeatedVertex;
            }
        }
    }
    // A quadrilateral face that crosses itself (issue 17): both diagonal
    // splits give triangles facing opposite ways (normals from the cyclic
    // rotations of the library's triangles, so rounded independently).
    for f in &m.faces {
        if let [a, b, c, d] = f[..] {
            let q = [a, b, c, d].map(|k| points[ids[k as usize] as usize]);
            let tri = |i: usize, j: usize, k: usize| {
                let (u, v) = (
                    std::array::from_fn::<f64, 3, _>(|x| q[j][x] - q[i][x]),
                    std::array::from_fn::<f64, 3, _>(|x| q[k][x] - q[i][x]),
                );
                [
                    u[1] * v[2] - u[2] * v[1],
                    u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0],
                ]
            };
            let against = |n: [f64; 3], m: [f64; 3]| {
                let dot = |x: [f64; 3], y: [f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
                let d = dot(n, m);
                d < 0.0 && d * d > 1e-12 * dot(n, n) * dot(m, m)
            };
            if against(tri(1, 2, 0), tri(2, 3, 0)) && against(tri(2, 3, 1), tri(3, 0, 1)) {
                return CellClass::SelfIntersecting;
            }
        }
    }
    let p0 = points[ids[0] as usize];
    let mut ext = 0.0f64;
    let local: Vec<[f64; 3]> = ids
        .iter()
        .map(|&v| {
            let p = points[v as usize];
            let l = [p[0] - p0[0], p[1] - p0[1], p[2] - p0[2]];
            ext = ext.max(l[0].abs()).max(l[1].abs()).max(l[2].abs());
            l
        })
        .collect();
    match reference_signed_volume(m, &local) {
        v if v.is_nan() || v.abs() <= 1e-12 * ext * ext * ext => CellClass::ZeroVolume,
        v if v < 0.0 => CellClass::Inverted,
        _ => CellClass::Valid,
    }
}

/// xorshift64*, in [-0.5, 0.5).
fn jitter(s: &mut u64) -> f64 {
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    (s.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64 - 0.5
}

#[test]
fn signed_volume_and_class_are_bit_identical_to_the_reference_formula() {
    let cat = catalog_with_prisms();
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let mut seen = [0usize; 6];
    for m in &cat.metas {
        let base = reference_coords(m);
        for trial in 0..4000 {
            // Large offsets (world coordinates), warps of every size, and
            // now and then a mirrored, flattened, repeated or NaN vertex.
            let off = [4.6e5, 5.93e6, -1.7e3];
            let amp = [0.0, 1e-9, 0.05, 0.4, 2.0][trial % 5];
            let mut pts: Vec<[f64; 3]> = base
                .iter()
                .map(|p| std::array::from_fn(|a| off[a] + 25.0 * (p[a] + amp * jitter(&mut seed))))
                .collect();
            let mut ids: Vec<u32> = (0..pts.len() as u32).collect();
            match trial % 11 {
                1 => pts.iter_mut().for_each(|p| p[2] = -p[2]),
                2 => pts.iter_mut().for_each(|p| p[2] = off[2]),
                3 => {
                    let (a, b) = (trial % pts.len(), (trial / 7) % pts.len());
                    pts[a] = pts[b];
                }
                4 => {
                    let k = ids.len();
                    ids[trial % k] = ids[(trial / 3) % k];
                }
                5 => pts[trial % m.nv][1] = f64::NAN,
                6 => pts[trial % m.nv][0] = -0.0 * pts[0][0],
                _ => {}
            }
            let got = m.signed_volume(&|v| pts[v]);
            let want = reference_signed_volume(m, &pts);
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "{} trial {trial}: volume {got:e} != reference {want:e}",
                m.name
            );
            let class = classify_cell(m, &ids, &pts);
            assert_eq!(
                class,
                reference_class(m, &ids, &pts),
                "{} trial {trial}: class",
                m.name
            );
            seen[class as usize] += 1;
        }
    }
    // Every swept / skipped class the catalog cells can take was exercised.
    for c in [
        CellClass::Valid,
        CellClass::Inverted,
        CellClass::ZeroVolume,
        CellClass::RepeatedVertex,
    ] {
        assert!(seen[c as usize] > 100, "class {c:?} seen {seen:?}");
    }
}

#[test]
fn face_masks_are_the_vertex_sets_of_the_faces() {
    for m in &catalog_with_prisms().metas {
        let masks = m.face_masks();
        assert_eq!(masks.len(), m.faces.len(), "{}", m.name);
        for (f, (&mask, face)) in masks.iter().zip(&m.faces).enumerate() {
            let want: u16 = (0..m.nv as u8)
                .filter(|v| face.contains(v))
                .map(|v| 1u16 << v)
                .sum();
            assert_eq!(mask, want, "{} face {f}", m.name);
        }
        // Distinct faces, distinct sets: a mask names one face.
        for a in 0..masks.len() {
            for b in a + 1..masks.len() {
                assert_ne!(masks[a], masks[b], "{} faces {a}, {b}", m.name);
            }
        }
    }
}

#[test]
fn vertex_lists_that_fit_no_meta_cell_are_non_volumetric() {
    let cat = Catalog::new();
    let hex = cat.get(builtin::HEXAHEDRON);
    let points: Vec<[f64; 3]> = (0..13).map(|i| [i as f64, (i * i) as f64, 1.0]).collect();
    let ids: Vec<u32> = (0..13).collect();
    assert_eq!(classify_cell(hex, &[], &points), CellClass::NonVolumetric);
    assert_eq!(classify_cell(hex, &ids, &points), CellClass::NonVolumetric);
}
