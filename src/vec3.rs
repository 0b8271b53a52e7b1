//! Small f64 vector helpers on `[f64; 3]` shared by the convex split and
//! the Voronoi generator (plain arrays, the same arithmetic everywhere).

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
