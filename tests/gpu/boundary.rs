//! Pre-integrated volume mode on unstructured grids, whose ray entry and
//! exit now come from the outer surface of any grid (`gpu::render::preintegrated::boundary`):
//! against a CPU integration along the ray (as `gpu_preintegrate.rs` does
//! for an IJK box). The value is linear in z, so between slices the slab
//! is exact, and what is left is where the ray enters and leaves.
//!
//! * A faulted block: two columns of hexahedra side by side with a throw,
//!   sharing no vertex on the fault (as corner-point grids across faults).
//!   Seen at 35°, the centre ray enters one block's top and leaves through
//!   the part of its fault face the other block does not cover.
//! * A box of tetrahedra (six per cube, conforming) with a slanted top.

use crate::support;
use crate::support::ray::integrate_linear;

use stratasweep::gpu::render::{Mode, RenderOptions, Renderer};
use stratasweep::grid::{Cells, Grid, Property, Topology, vtk_type};
use stratasweep::structures::{Structure, StructureChoice};

/// Lowest and highest z of the grids; v = (z − Z0) / (Z1 − Z0).
const Z0: f64 = -0.5;
const Z1: f64 = 0.9;

/// A box of `n` cells per axis as hexahedra (ids offset by `first`).
struct Block {
    lo: [f64; 3],
    hi: [f64; 3],
    n: [usize; 3],
}

impl Block {
    fn point(&self, ijk: [usize; 3]) -> [f64; 3] {
        [0, 1, 2].map(|a| self.lo[a] + (self.hi[a] - self.lo[a]) * ijk[a] as f64 / self.n[a] as f64)
    }

    /// Appends the block's points and hexahedra.
    fn push(&self, points: &mut Vec<[f64; 3]>, cells: &mut Cells) {
        let first = points.len();
        let np = self.n.map(|x| x + 1);
        for k in 0..np[2] {
            for j in 0..np[1] {
                for i in 0..np[0] {
                    points.push(self.point([i, j, k]));
                }
            }
        }
        let id = |i: usize, j: usize, k: usize| (first + i + np[0] * (j + np[1] * k)) as u32;
        for k in 0..self.n[2] {
            for j in 0..self.n[1] {
                for i in 0..self.n[0] {
                    let q = |kk| {
                        [
                            id(i, j, kk),
                            id(i + 1, j, kk),
                            id(i + 1, j + 1, kk),
                            id(i, j + 1, kk),
                        ]
                    };
                    let (b, t) = (q(k), q(k + 1));
                    cells.push(vtk_type::HEXAHEDRON, &[b, t].concat());
                }
            }
        }
    }

    /// The ray parameters where `o + t d` is inside the block.
    fn clip(&self, o: [f64; 3], d: [f64; 3]) -> Option<(f64, f64)> {
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        for a in 0..3 {
            if d[a] == 0.0 {
                if o[a] < self.lo[a] || o[a] > self.hi[a] {
                    return None;
                }
                continue;
            }
            let (p, q) = ((self.lo[a] - o[a]) / d[a], (self.hi[a] - o[a]) / d[a]);
            t0 = t0.max(p.min(q));
            t1 = t1.min(p.max(q));
        }
        (t0 < t1).then_some((t0, t1))
    }
}

fn with_ramp(points: Vec<[f64; 3]>, cells: Cells) -> Grid {
    let v = points.iter().map(|p| (p[2] - Z0) / (Z1 - Z0)).collect();
    Grid {
        point_data: vec![Property::scalar("v", v)],
        points,
        topology: Topology::Unstructured(cells),
        cell_data: Vec::new(),
    }
}

/// Block A x ∈ [−1, 0], z ∈ [−0.5, 0.5]; block B x ∈ [0, 0.5], z thrown
/// up by 0.4 to [−0.1, 0.9]; y ∈ [−1, 1]. No shared vertex on x = 0.
fn faulted_blocks() -> [Block; 2] {
    [
        Block {
            lo: [-1.0, -1.0, -0.5],
            hi: [0.0, 1.0, 0.5],
            n: [4, 4, 4],
        },
        Block {
            lo: [0.0, -1.0, -0.1],
            hi: [0.5, 1.0, 0.9],
            n: [2, 4, 3],
        },
    ]
}

/// The top of the tetrahedral grid: a plane sloping down along x from Z1
/// (at x = −1) to 0.6 (at x = 1), so no slice lies in it.
fn slanted_top(x: f64) -> f64 {
    0.75 - 0.15 * x
}

/// The box [−1, 1]² × [Z0, Z1] as six tetrahedra per cube (Kuhn's split:
/// one per order of the axes, conforming), each oriented positively, its
/// columns then squeezed so that the top is [`slanted_top`].
fn tetrahedral_box() -> Grid {
    let b = Block {
        lo: [-1.0, -1.0, Z0],
        hi: [1.0, 1.0, Z1],
        n: [4, 4, 4],
    };
    let mut points = Vec::new();
    let mut hexes = Cells::default();
    b.push(&mut points, &mut hexes);
    let mut cells = Cells::default();
    // Hexahedron corners by (i, j, k) offsets: VTK order.
    let corner = |h: &[u32], o: [usize; 3]| h[[0, 1, 3, 2][o[0] + 2 * o[1]] + 4 * o[2]];
    for c in 0..hexes.len() {
        let h = hexes.cell(c);
        for perm in [
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
            [2, 1, 0],
        ] {
            let mut o = [0usize; 3];
            let mut tet = vec![corner(h, o)];
            for a in perm {
                o[a] = 1;
                tet.push(corner(h, o));
            }
            let p = |v: u32| points[v as usize];
            let e = |v: u32| [0, 1, 2].map(|a| p(v)[a] - p(tet[0])[a]);
            let (x, y, z) = (e(tet[1]), e(tet[2]), e(tet[3]));
            let det = x[0] * (y[1] * z[2] - y[2] * z[1]) - x[1] * (y[0] * z[2] - y[2] * z[0])
                + x[2] * (y[0] * z[1] - y[1] * z[0]);
            if det < 0.0 {
                tet.swap(1, 2);
            }
            cells.push(vtk_type::TETRA, &tet);
        }
    }
    for p in &mut points {
        p[2] = Z0 + (p[2] - Z0) * (slanted_top(p[0]) - Z0) / (Z1 - Z0);
    }
    with_ramp(points, cells)
}

/// The centre pixel's largest channel error against `want`, pre-integrated
/// and plain, with 5 slices seen along `dir`.
fn centre_errors(g: &Grid, dir: [f64; 3], want: [f64; 4]) -> (f64, f64) {
    let ctx = support::gpu("pre-integrated unstructured grids").expect("checked by the caller");
    let s = Structure::build(g, StructureChoice::Auto).unwrap();
    let o = RenderOptions {
        property: Some("v".into()),
        slices: 5,
        view_dir: dir,
        up: Some([0.0, 1.0, 0.0]),
        transfer: Some(support::ray::ramp_transfer()),
        unit_distance: Some(1.0),
        background: None,
        size: (33, 33),
        mode: Mode::Volume,
        ..Default::default()
    };
    let err = |pre: bool| {
        let mut r = Renderer::new(ctx).unwrap();
        r.set_preintegrated(pre);
        let img = r.render_exaggerated(g, &s, &o, 1.0).unwrap();
        let got = img.pixel(16, 16);
        (0..4)
            .map(|c| (got[c] as f64 - want[c]).abs())
            .fold(0.0, f64::max)
    };
    (err(true), err(false))
}

/// A point on the centre pixel's ray: the camera (orthographic, up +y)
/// aims at the middle of the points' extent across the view, measured
/// from the bounding-box centre (as `OrbitCamera::fit` frames a grid).
fn centre_ray_point(g: &Grid, d: [f64; 3]) -> [f64; 3] {
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let s = cross(d, [0.0, 1.0, 0.0]);
    let n = dot(s, s).sqrt();
    let s = s.map(|x| x / n);
    let u = cross(s, d);
    let (lo, hi) = g.bounds();
    let o = [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]));
    let mid = |e: [f64; 3]| {
        let (a, b) = g
            .points
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                let x = dot([0, 1, 2].map(|k| p[k] - o[k]), e);
                (a.min(x), b.max(x))
            });
        0.5 * (a + b)
    };
    let (cx, cy) = (mid(s), mid(u));
    [0, 1, 2].map(|a| o[a] + cx * s[a] + cy * u[a])
}

/// The view along `dir` at `deg` degrees from straight down, in the x–z plane.
fn down_at(deg: f64) -> [f64; 3] {
    let th = deg.to_radians();
    [th.sin(), 0.0, -th.cos()]
}

#[test]
fn rays_leave_a_faulted_block_through_its_uncovered_fault_face() {
    if support::gpu("rays_leave_a_faulted_block_through_its_uncovered_fault_face").is_none() {
        return;
    }
    let blocks = faulted_blocks();
    let mut points = Vec::new();
    let mut cells = Cells::default();
    for b in &blocks {
        b.push(&mut points, &mut cells);
    }
    let g = with_ramp(points, cells);
    let t = support::ray::ramp_transfer();
    for deg in [0.0, 35.0] {
        let d = down_at(deg);
        let centre = centre_ray_point(&g, d);
        // The centre ray's stretch in the two blocks (they touch on x = 0).
        let parts: Vec<(f64, f64)> = blocks.iter().filter_map(|b| b.clip(centre, d)).collect();
        let t0 = parts.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
        let t1 = parts.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
        let v = |t: f64| (centre[2] + t * d[2] - Z0) / (Z1 - Z0);
        let exit_x = centre[0] + t1 * d[0];
        if deg > 0.0 {
            // The ray leaves block A sideways, below block B: through A's
            // fault face where B does not cover it.
            assert!(exit_x.abs() < 1e-12, "exit at x = {exit_x}");
            assert!(centre[2] + t1 * d[2] < -0.1);
        }
        let want = integrate_linear(&t, v(t0), v(t1), t1 - t0);
        let (pre, plain) = centre_errors(&g, d, want);
        eprintln!(
            "faulted blocks {deg}°: max channel error pre-integrated {pre:.5}, plain {plain:.5}"
        );
        assert!(pre <= 2.0 / 255.0, "{deg}°: pre-integrated error {pre}");
        assert!(pre < plain / 2.0, "{deg}°: pre {pre} vs plain {plain}");
    }
}

#[test]
fn a_box_of_tetrahedra_gives_the_integral_along_the_ray() {
    if support::gpu("a_box_of_tetrahedra_gives_the_integral_along_the_ray").is_none() {
        return;
    }
    let g = tetrahedral_box();
    let t = support::ray::ramp_transfer();
    for deg in [0.0f64, 35.0] {
        let d = down_at(deg);
        let c = centre_ray_point(&g, d);
        // The centre ray enters through the slanted top, leaves at the bottom.
        let t0 = (0.75 - 0.15 * c[0] - c[2]) / (d[2] + 0.15 * d[0]);
        assert!(((c[2] + t0 * d[2]) - slanted_top(c[0] + t0 * d[0])).abs() < 1e-12);
        let t1 = (Z0 - c[2]) / d[2];
        let v = |t: f64| (c[2] + t * d[2] - Z0) / (Z1 - Z0);
        let want = integrate_linear(&t, v(t0), v(t1), t1 - t0);
        let (pre, plain) = centre_errors(&g, d, want);
        eprintln!("tetrahedra {deg}°: max channel error pre-integrated {pre:.5}, plain {plain:.5}");
        assert!(pre <= 2.0 / 255.0, "{deg}°: pre-integrated error {pre}");
        assert!(pre < plain / 2.0, "{deg}°: pre {pre} vs plain {plain}");
    }
}
