//! Per-vertex gradients of the field for iso-mode lighting (no wgpu).
//!
//! Each live cell gets the least-squares linear fit of φ over its vertices,
//! `φ ≈ φ̄ + g·(x − x̄)`: the exact gradient for a tetrahedron, and for any
//! cell the exact gradient of a linear field. Each vertex gets the mean of
//! the gradients of the live cells that share it. The emit pass (and its
//! CPU twin) interpolates these along the cut edge exactly like the
//! position, so the isosurface is shaded with the interpolated gradient
//! rather than its facet normals.

use crate::metacell::MAX_META_VERTICES;

use super::tables::GridBuffers;

/// The least-squares gradient of φ over the points `(x, φ)`, or `None`
/// when the points do not span 3D (the normal matrix is singular).
pub fn least_squares_gradient(points: &[([f64; 3], f64)]) -> Option<[f64; 3]> {
    let n = points.len() as f64;
    if points.len() < 4 {
        return None;
    }
    let mut c = [0.0; 3];
    let mut fm = 0.0;
    for (x, f) in points {
        for i in 0..3 {
            c[i] += x[i] / n;
        }
        fm += f / n;
    }
    // Normal equations A g = b with A = Σ dx dxᵀ, b = Σ dx dφ.
    let mut a = [[0.0f64; 3]; 3];
    let mut b = [0.0f64; 3];
    for (x, f) in points {
        let d = [x[0] - c[0], x[1] - c[1], x[2] - c[2]];
        for i in 0..3 {
            for j in 0..3 {
                a[i][j] += d[i] * d[j];
            }
            b[i] += d[i] * (f - fm);
        }
    }
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&a);
    let scale = (a[0][0] + a[1][1] + a[2][2]).powi(3);
    if d.is_nan() || d.abs() <= 1e-12 * scale {
        return None;
    }
    // Cramer's rule.
    let mut g = [0.0; 3];
    for (k, gk) in g.iter_mut().enumerate() {
        let mut m = a;
        for i in 0..3 {
            m[i][k] = b[i];
        }
        *gk = det(&m) / d;
    }
    Some(g)
}

/// Per vertex of `g` (indexed like `g.grid`): the mean of the least-squares
/// gradients of φ (`g.grid[v][3]`, local frame) over the live cells that
/// share the vertex; zero for vertices of no live cell. `w` is 0.
pub fn vertex_gradients(g: &GridBuffers) -> Vec<[f32; 4]> {
    let nvert = g.grid.len();
    let mut sum = vec![[0.0f64; 3]; nvert];
    let mut count = vec![0u32; nvert];
    let mut ids = [0u32; MAX_META_VERTICES];
    let mut pts = Vec::with_capacity(MAX_META_VERTICES);
    for &slot in &g.live {
        let (_, nv) = g.cell_vertices(slot, &mut ids);
        pts.clear();
        pts.extend(ids[..nv].iter().map(|&v| {
            let p = g.grid[v as usize];
            ([p[0] as f64, p[1] as f64, p[2] as f64], p[3] as f64)
        }));
        let Some(grad) = least_squares_gradient(&pts) else {
            continue;
        };
        for &v in &ids[..nv] {
            let s = &mut sum[v as usize];
            for i in 0..3 {
                s[i] += grad[i];
            }
            count[v as usize] += 1;
        }
    }
    sum.iter()
        .zip(&count)
        .map(|(s, &c)| {
            let k = if c > 0 { 1.0 / c as f64 } else { 0.0 };
            [(s[0] * k) as f32, (s[1] * k) as f32, (s[2] * k) as f32, 0.0]
        })
        .collect()
}
