//! The outer surface of a structured grid as triangles (no wgpu): the six
//! faces of its IJK point lattice in the local frame (positions relative to
//! [`Grid::origin`], z not exaggerated). The pre-integrated volume pass
//! draws it to find where each ray enters and leaves the grid.

use crate::grid::{Grid, Topology};

/// Triangle corners of the grid's outer surface, three per triangle, each
/// its position then its index coordinate `(i, j, k)`, or `None` for
/// unstructured grids (their outer surface is not extracted).
pub fn boundary_triangles(grid: &Grid) -> Option<Vec<[f32; 6]>> {
    let Topology::Structured { dims } = grid.topology else {
        return None;
    };
    if dims.iter().any(|&n| n < 2) {
        return None;
    }
    let o = grid.origin();
    let at = |i: usize, j: usize, k: usize| {
        let p = grid.points[i + dims[0] * (j + dims[1] * k)];
        let x = [0, 1, 2].map(|a| (p[a] - o[a]) as f32);
        [x[0], x[1], x[2], i as f32, j as f32, k as f32]
    };
    let mut out = Vec::new();
    // Each outer face: fix axis `a` at 0 or its last index; walk the other two.
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        for side in [0, dims[a] - 1] {
            for u in 0..dims[b] - 1 {
                for v in 0..dims[c] - 1 {
                    let p = |du: usize, dv: usize| {
                        let mut ijk = [0; 3];
                        ijk[a] = side;
                        ijk[b] = u + du;
                        ijk[c] = v + dv;
                        at(ijk[0], ijk[1], ijk[2])
                    };
                    let q = [p(0, 0), p(1, 0), p(1, 1), p(0, 1)];
                    out.extend_from_slice(&[q[0], q[1], q[2], q[0], q[2], q[3]]);
                }
            }
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube(n: usize) -> Grid {
        let mut points = Vec::new();
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    points.push([i as f64, j as f64, k as f64]);
                }
            }
        }
        Grid {
            points,
            topology: Topology::Structured { dims: [n; 3] },
            point_data: Vec::new(),
            cell_data: Vec::new(),
        }
    }

    #[test]
    fn the_outer_surface_of_a_cube_covers_its_six_faces_once() {
        let n = 5;
        let t = boundary_triangles(&cube(n)).expect("structured");
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
        // The triangles' areas add up to the box's surface, 6 (n−1)².
        let area: f32 = t
            .chunks(3)
            .map(|c| {
                let (a, b, d) = (c[0], c[1], c[2]);
                let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                let v = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
                let x = [
                    u[1] * v[2] - u[2] * v[1],
                    u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0],
                ];
                0.5 * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
            })
            .sum();
        assert!((area - 6.0 * 16.0).abs() < 1e-3, "{area}");
    }
}
