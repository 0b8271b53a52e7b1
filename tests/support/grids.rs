//! Grids for the tests (random structured, zoo and polyhedral grids, the
//! unit cube, a box) and slicing helpers (one request, the sweep against
//! the brute force, two results compared).

use stratasweep::field::FieldSpec;
use stratasweep::pipeline::{LevelSpec, SliceRequest};

/// Per level, the polygons as (cell, corner positions).
pub type Levels = Vec<Vec<(u32, Vec<[f32; 3]>)>>;

/// `l` with each level's polygons sorted by (cell, corners), so that two
/// extractors can be compared whatever their emission order.
pub fn sorted(mut l: Levels) -> Levels {
    for lv in &mut l {
        lv.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.partial_cmp(&b.1).unwrap()));
    }
    l
}

/// The cells of each level of a [`sorted`] `l` (one entry per cell).
pub fn cells_of(l: &Levels) -> Vec<Vec<u32>> {
    l.iter()
        .map(|lv| {
            let mut c: Vec<u32> = lv.iter().map(|x| x.0).collect();
            c.dedup();
            c
        })
        .collect()
}

/// A one-thread sweep request for `count` levels along `axis` (0–2).
pub fn axis_request(axis: usize, count: usize) -> SliceRequest {
    SliceRequest {
        field: FieldSpec::Axis {
            axis,
            negative: false,
        },
        levels: LevelSpec::Count(count),
        attribute: None,
        threads: 1,
        brute_force: false,
        collect_mesh: false,
        sweep: Default::default(),
    }
}

use stratasweep::grid::{Cells, Grid, Property, Topology, vtk_type};

/// SplitMix64.
pub struct Rng(pub u64);
impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        z ^ (z >> 31)
    }
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// A structured grid of `n` cells per axis on integer-ish coordinates with
/// optional jitter, a quantised random point field `f` (so values sit
/// exactly on integer levels), plus a `vtkGhostType` hiding `holes` fraction
/// of the cells (holes and several components).
pub fn structured(n: [usize; 3], jitter: f64, holes: f64, rng: &mut Rng) -> Grid {
    let dims = [n[0] + 1, n[1] + 1, n[2] + 1];
    let mut points = Vec::new();
    let mut f = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let mut p = [i as f64, j as f64, k as f64];
                if jitter > 0.0 {
                    for c in p.iter_mut() {
                        *c += jitter * (rng.f64() - 0.5);
                    }
                }
                points.push(p);
                f.push((rng.f64() * 8.0).floor() * 0.5);
            }
        }
    }
    let ncells = n[0] * n[1] * n[2];
    let mut ghost = vec![0.0; ncells];
    let mut any = false;
    for g in ghost.iter_mut() {
        if rng.f64() < holes {
            *g = 32.0;
            any = true;
        }
    }
    let mut cell_data = Vec::new();
    if any {
        cell_data.push(Property::scalar("vtkGhostType", ghost));
    }
    Grid {
        points,
        topology: Topology::Structured { dims },
        point_data: vec![Property::scalar("f", f)],
        cell_data,
    }
}

/// Converts a structured grid into a conforming zoo grid: every hexahedron
/// becomes a hex, 2 wedges, 6 pyramids around a new centre, or 6 tets from
/// the centre... (only splits that keep faces conforming: hexes, wedge
/// columns split along the same diagonal in i-j, and pyramid-split hexes).
pub fn zoo_from_structured(g: &Grid, rng: &mut Rng) -> Grid {
    let Topology::Structured { dims } = g.topology else {
        panic!()
    };
    let [npi, npj, npk] = dims;
    let mut points = g.points.clone();
    let mut f = g.point_data[0].values.clone();
    let mut cells = Cells::default();
    let wedge_col: Vec<bool> = (0..(npi - 1) * (npj - 1))
        .map(|_| rng.f64() < 0.3)
        .collect();
    for k in 0..npk - 1 {
        for j in 0..npj - 1 {
            for i in 0..npi - 1 {
                let v = |di: usize, dj: usize, dk: usize| {
                    ((i + di) + (j + dj) * npi + (k + dk) * npi * npj) as u32
                };
                let h = [
                    v(0, 0, 0),
                    v(1, 0, 0),
                    v(1, 1, 0),
                    v(0, 1, 0),
                    v(0, 0, 1),
                    v(1, 0, 1),
                    v(1, 1, 1),
                    v(0, 1, 1),
                ];
                if wedge_col[i + j * (npi - 1)] {
                    // VTK wedge: the normal of (0,1,2) points toward (3,4,5).
                    cells.push(vtk_type::WEDGE, &[h[0], h[1], h[2], h[4], h[5], h[6]]);
                    cells.push(vtk_type::WEDGE, &[h[0], h[2], h[3], h[4], h[6], h[7]]);
                } else if rng.f64() < 0.35 {
                    let c = points.len() as u32;
                    let mut p = [0.0; 3];
                    let mut fc = 0.0;
                    for &x in &h {
                        for a in 0..3 {
                            p[a] += points[x as usize][a] / 8.0;
                        }
                        fc += f[x as usize] / 8.0;
                    }
                    points.push(p);
                    f.push(fc + 0.25 * (rng.f64() - 0.5));
                    for face in stratasweep::metacell::HEXAHEDRON_FACES {
                        // Pyramid base must be oriented with its normal toward the apex:
                        // reverse the outward face.
                        let b: Vec<u32> = face.iter().rev().map(|&l| h[l as usize]).collect();
                        if rng.f64() < 0.3 {
                            // Split into two tets along the diagonal through the base's
                            // smallest vertex id... only on boundary faces (always conforming).
                            let on_boundary = is_boundary_face(&b, dims);
                            if on_boundary {
                                let m = (0..4).min_by_key(|&q| b[q]).unwrap();
                                let q = |o: usize| b[(m + o) % 4];
                                cells.push(vtk_type::TETRA, &[q(0), q(1), q(2), c]);
                                cells.push(vtk_type::TETRA, &[q(0), q(2), q(3), c]);
                                continue;
                            }
                        }
                        cells.push(vtk_type::PYRAMID, &[b[0], b[1], b[2], b[3], c]);
                    }
                } else {
                    cells.push(vtk_type::HEXAHEDRON, &h);
                }
            }
        }
    }
    Grid {
        points,
        topology: Topology::Unstructured(cells),
        point_data: vec![Property::scalar("f", f)],
        cell_data: vec![],
    }
}

fn is_boundary_face(b: &[u32], dims: [usize; 3]) -> bool {
    let [npi, npj, npk] = dims;
    let ijk = |v: u32| {
        let v = v as usize;
        [v % npi, (v / npi) % npj, v / (npi * npj)]
    };
    (0..3).any(|a| {
        let lim = [npi - 1, npj - 1, npk - 1][a];
        let c: Vec<usize> = b.iter().map(|&v| ijk(v)[a]).collect();
        c.iter().all(|&x| x == 0) || c.iter().all(|&x| x == lim)
    })
}

/// A random polyhedral grid: a jittered structured grid whose hexahedra are
/// grouped into 2×2×1 blocks (18-vertex, 16-face polyhedra, beyond the
/// catalog), with the rest as single hexahedra given either as typed cells
/// or as 6-face polyhedra; holes hidden by the ghost array.
pub fn polyhedral(n: [usize; 3], jitter: f64, holes: f64, rng: &mut Rng) -> Grid {
    let s = structured(n, jitter, holes, rng);
    let Topology::Structured { dims } = s.topology else {
        unreachable!()
    };
    let (npi, npj) = (dims[0], dims[1]);
    let pid = |i: usize, j: usize, k: usize| (i + j * npi + k * npi * npj) as u32;
    let hidden_in = s.hidden_cells();
    let cid = |i: usize, j: usize, k: usize| i + j * n[0] + k * n[0] * n[1];
    let is_hidden = |i, j, k| hidden_in.as_ref().is_some_and(|h| h[cid(i, j, k)]);
    let mut cells = Cells::default();
    let mut ghost = Vec::new();
    let mut done = vec![false; n[0] * n[1] * n[2]];
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                if done[cid(i, j, k)] {
                    continue;
                }
                let block = i % 2 == 0
                    && j % 2 == 0
                    && i + 1 < n[0]
                    && j + 1 < n[1]
                    && rng.f64() < 0.6
                    && (0..2).all(|a| (0..2).all(|b| !done[cid(i + a, j + b, k)]));
                let (wi, wj) = if block { (2, 2) } else { (1, 1) };
                let hid = (0..wi).any(|a| (0..wj).any(|b| is_hidden(i + a, j + b, k)));
                for a in 0..wi {
                    for b in 0..wj {
                        done[cid(i + a, j + b, k)] = true;
                    }
                }
                ghost.push(if hid { 32.0 } else { 0.0 });
                if !block && rng.f64() < 0.5 {
                    let ids = [
                        pid(i, j, k),
                        pid(i + 1, j, k),
                        pid(i + 1, j + 1, k),
                        pid(i, j + 1, k),
                        pid(i, j, k + 1),
                        pid(i + 1, j, k + 1),
                        pid(i + 1, j + 1, k + 1),
                        pid(i, j + 1, k + 1),
                    ];
                    cells.push(vtk_type::HEXAHEDRON, &ids);
                    continue;
                }
                // Faces of the (wi × wj × 1) block, split per unit square, with
                // a random orientation (the build must orient them).
                let mut faces: Vec<Vec<u32>> = Vec::new();
                for kk in [k, k + 1] {
                    for a in 0..wi {
                        for b in 0..wj {
                            faces.push(vec![
                                pid(i + a, j + b, kk),
                                pid(i + a + 1, j + b, kk),
                                pid(i + a + 1, j + b + 1, kk),
                                pid(i + a, j + b + 1, kk),
                            ]);
                        }
                    }
                }
                for ii in [i, i + wi] {
                    for b in 0..wj {
                        faces.push(vec![
                            pid(ii, j + b, k),
                            pid(ii, j + b + 1, k),
                            pid(ii, j + b + 1, k + 1),
                            pid(ii, j + b, k + 1),
                        ]);
                    }
                }
                for jj in [j, j + wj] {
                    for a in 0..wi {
                        faces.push(vec![
                            pid(i + a, jj, k),
                            pid(i + a + 1, jj, k),
                            pid(i + a + 1, jj, k + 1),
                            pid(i + a, jj, k + 1),
                        ]);
                    }
                }
                for f in faces.iter_mut() {
                    if rng.f64() < 0.5 {
                        f.reverse();
                    }
                    let r = rng.below(f.len());
                    f.rotate_left(r);
                }
                cells.push_polyhedron(&faces);
            }
        }
    }
    let mut cell_data = Vec::new();
    if ghost.iter().any(|&g| g != 0.0) {
        cell_data.push(Property::scalar("vtkGhostType", ghost));
    }
    Grid {
        points: s.points,
        topology: Topology::Unstructured(cells),
        point_data: s.point_data,
        cell_data,
    }
}

/// A grid of one polyhedron with the given faces.
pub fn one_cell(faces: &[Vec<u32>], points: Vec<[f64; 3]>) -> Grid {
    let mut cells = Cells::default();
    cells.push_polyhedron(faces);
    Grid {
        points,
        topology: Topology::Unstructured(cells),
        point_data: vec![],
        cell_data: vec![],
    }
}

/// The unit cube's corners, corner `i` at the bits of `i`.
pub fn cube_points() -> Vec<[f64; 3]> {
    (0..8)
        .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
        .collect()
}

/// The unit cube's faces as loops over [`cube_points`].
pub fn cube_faces() -> Vec<Vec<u32>> {
    vec![
        vec![0, 2, 3, 1],
        vec![4, 5, 7, 6],
        vec![0, 1, 5, 4],
        vec![2, 6, 7, 3],
        vec![0, 4, 6, 2],
        vec![1, 3, 7, 5],
    ]
}

/// Slices `grid` along `axis` at `count` levels by the sweep and by the
/// brute force, checks that they cut the same cells per level, and returns
/// the sweep's result.
pub fn sweep_matches_brute_force(
    grid: &stratasweep::grid::Grid,
    s: &stratasweep::structures::Structure,
    axis: usize,
    count: usize,
    what: &str,
) -> stratasweep::pipeline::SliceResult {
    let mut req = axis_request(axis, count);
    let a = stratasweep::pipeline::slice(grid, s, &req, &|_| {}).unwrap();
    req.brute_force = true;
    let b = stratasweep::pipeline::slice(grid, s, &req, &|_| {}).unwrap();
    let cells = |r: &stratasweep::pipeline::SliceResult| {
        r.stats.iter().map(|s| s.cells).collect::<Vec<_>>()
    };
    assert_eq!(cells(&a), cells(&b), "{what}: axis {axis}");
    a
}

/// `slice` of `grid` through `s`, unwrapped.
pub fn slice_ok(
    grid: &Grid,
    s: &stratasweep::structures::Structure,
    req: &SliceRequest,
) -> stratasweep::pipeline::SliceResult {
    stratasweep::pipeline::slice(grid, s, req, &|_| {}).unwrap()
}

/// Per-level figures that must be identical (areas compared to 1e-12:
/// each run sums its polygons' areas in its own order), the same number
/// of levels, and the same polygons, vertex for vertex, bit for bit.
pub fn assert_same(
    a: &stratasweep::pipeline::SliceResult,
    b: &stratasweep::pipeline::SliceResult,
    what: &str,
) {
    assert_eq!(a.level_values, b.level_values, "{what}: levels");
    assert_eq!(a.stats.len(), b.stats.len());
    for (l, (x, y)) in a.stats.iter().zip(&b.stats).enumerate() {
        assert_eq!(
            (x.cells, x.polygons, x.triangles),
            (y.cells, y.polygons, y.triangles),
            "{what}: level {l}"
        );
        let tol = 1e-12 * x.area.abs().max(y.area.abs()).max(1e-300);
        assert!(
            (x.area - y.area).abs() <= tol,
            "{what}: level {l} area {} vs {}",
            x.area,
            y.area
        );
    }
    assert_eq!(a.mesh, b.mesh, "{what}: polygons");
}

/// A structured box [−h₀, h₀] × [−h₁, h₁] × [−h₂, h₂] of `dims` points,
/// evenly spaced, with the point property `one` = 1.
pub fn box_grid(dims: [usize; 3], half: [f64; 3]) -> Grid {
    let mut points = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let f = |n: usize, d: usize| n as f64 / (d - 1) as f64 * 2.0 - 1.0;
                points.push([
                    half[0] * f(i, dims[0]),
                    half[1] * f(j, dims[1]),
                    half[2] * f(k, dims[2]),
                ]);
            }
        }
    }
    Grid {
        point_data: vec![Property::scalar("one", vec![1.0; points.len()])],
        points,
        topology: Topology::Structured { dims },
        cell_data: Vec::new(),
    }
}
