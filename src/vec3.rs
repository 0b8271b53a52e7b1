//! Small f64 vector helpers on `[f64; 3]` shared by the convex split and
//! the Voronoi generator (plain arrays, the same arithmetic everywhere),
//! and the bow-tie test on a quadrilateral that the cell checks, the split
//! and the grid generators share.

/// A point or vector in f64.
pub(crate) type P3 = [f64; 3];

/// a − b.
#[inline]
pub(crate) fn sub(a: P3, b: P3) -> P3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// a + b.
#[inline]
pub(crate) fn add(a: P3, b: P3) -> P3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// a · s.
#[inline]
pub(crate) fn scale(a: P3, s: f64) -> P3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// a · b.
#[inline]
pub(crate) fn dot(a: P3, b: P3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// a × b.
#[inline]
pub(crate) fn cross(a: P3, b: P3) -> P3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// |a|.
#[inline]
pub(crate) fn norm(a: P3) -> f64 {
    dot(a, a).sqrt()
}

/// The mean of the points (NaN for none).
#[inline]
pub(crate) fn mean(pts: impl ExactSizeIterator<Item = P3>) -> P3 {
    let n = pts.len() as f64;
    let mut m = [0.0; 3];
    for p in pts {
        m = add(m, p);
    }
    scale(m, 1.0 / n)
}

/// True when the quadrilateral `a b c d` crosses itself (a bow-tie): split
/// along either diagonal, its two triangles face opposite ways. A convex or
/// concave (but simple) quadrilateral, planar or mildly warped, has at
/// least one diagonal whose triangles agree; a collapsed one (zero-area
/// triangles) is not flagged here.
#[inline(always)]
pub fn quad_is_bow_tie(q: [[f64; 3]; 4]) -> bool {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |u: [f64; 3], v: [f64; 3]| {
        [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ]
    };
    let dot = |u: [f64; 3], v: [f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let normal = |a: usize, b: usize, c: usize| cross(sub(q[b], q[a]), sub(q[c], q[a]));
    // Opposite beyond rounding: cos < -1e-6 between non-zero normals.
    let opposite = |n: [f64; 3], m: [f64; 3]| {
        let d = dot(n, m);
        d < 0.0 && d * d > 1e-12 * dot(n, n) * dot(m, m)
    };
    opposite(normal(0, 1, 2), normal(0, 2, 3)) && opposite(normal(1, 2, 3), normal(1, 3, 0))
}
