//! Hexahedra classified four at a time, one per vector lane: the checks
//! that decide most cells (repeated vertex, the bow-tie screen, the
//! filtered volume) by the same operations in the same order as
//! [`classify_cell`], so each lane gets the scalar bits; a lane that is not
//! clearly valid or inverted goes through [`classify_cell`] itself.

use super::common::{CellClass, class_far_from_zero, classify_cell};
use crate::metacell::MetaCell;

/// Cells per batch.
pub(crate) const LANES: usize = 4;

/// The builtin hexahedron's faces ([`crate::metacell::HEXAHEDRON_FACES`]),
/// copied into fixed-size arrays at compile time so that the lanes' loops
/// unroll.
const HEX_FACES: [[u8; 4]; 6] = {
    let faces = crate::metacell::HEXAHEDRON_FACES;
    let mut out = [[0u8; 4]; 6];
    let mut f = 0;
    while f < 6 {
        let mut i = 0;
        while i < 4 {
            out[f][i] = faces[f][i];
            i += 1;
        }
        f += 1;
    }
    out
};

/// The vertex pairs `a < b` of a hexahedron, in `classify_fixed`'s order.
const PAIRS: [(usize, usize); 28] = {
    let mut out = [(0, 0); 28];
    let (mut a, mut k) = (0, 0);
    while a < 8 {
        let mut b = a + 1;
        while b < 8 {
            out[k] = (a, b);
            k += 1;
            b += 1;
        }
        a += 1;
    }
    out
};

/// One value per lane.
type V = [f64; LANES];
/// A point per lane (coordinate, lane).
type P = [V; 3];

/// The classes of four hexahedra of meta-cell `meta` (the builtin
/// hexahedron's faces; any other meta-cell goes cell by cell), each with its eight vertex ids: exactly
/// [`classify_cell`]'s.
pub(crate) fn classify_hexes(
    meta: &MetaCell,
    ids: [&[u32]; LANES],
    points: &[[f64; 3]],
) -> [CellClass; LANES] {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked above).
        return unsafe { classify_hexes_avx2(meta, ids, points) };
    }
    classify_lanes(meta, ids, points)
}

/// [`classify_lanes`] compiled for AVX2 (four lanes per vector; Rust never
/// fuses a product and a sum, so the bits do not change).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn classify_hexes_avx2(
    meta: &MetaCell,
    ids: [&[u32]; LANES],
    points: &[[f64; 3]],
) -> [CellClass; LANES] {
    classify_lanes(meta, ids, points)
}

#[inline(always)]
fn sub(a: &P, b: &P) -> P {
    std::array::from_fn(|k| std::array::from_fn(|l| a[k][l] - b[k][l]))
}

#[inline(always)]
fn add(a: &P, b: &P) -> P {
    std::array::from_fn(|k| std::array::from_fn(|l| a[k][l] + b[k][l]))
}

/// `vec3::cross` per lane.
#[inline(always)]
fn cross(u: &P, v: &P) -> P {
    let c = |i: usize, j: usize| -> V {
        std::array::from_fn(|l| u[i][l] * v[j][l] - u[j][l] * v[i][l])
    };
    [c(1, 2), c(2, 0), c(0, 1)]
}

/// `vec3::dot` per lane.
#[inline(always)]
fn dot(u: &P, v: &P) -> V {
    std::array::from_fn(|l| u[0][l] * v[0][l] + u[1][l] * v[1][l] + u[2][l] * v[2][l])
}

/// The lanes' classes. Per lane, as `classify_fixed::<8>`: the repeated
/// vertex test (exact); of the bow-tie test only its first condition (the
/// triangles 0 1 2 and 0 2 3 of a face facing away from each other,
/// `dot < 0`), which every bow-tie meets, as a screen; then the relative
/// coordinates, the extent and `six_volume_filter`'s hexahedron sum.
/// Lanes with a repeated vertex, a screened face or a volume near zero
/// take [`classify_cell`].
#[inline(always)]
fn classify_lanes(
    meta: &MetaCell,
    ids: [&[u32]; LANES],
    points: &[[f64; 3]],
) -> [CellClass; LANES] {
    let scalar = |l: usize| classify_cell(meta, ids[l], points);
    if meta.hex_faces() != Some(&HEX_FACES) || ids.iter().any(|i| i.len() != 8) {
        return std::array::from_fn(scalar);
    }
    let mut p: [P; 8] = [[[0.0; LANES]; 3]; 8];
    let mut id = [[0u32; LANES]; 8];
    for (l, cell) in ids.iter().enumerate() {
        for (v, &x) in cell.iter().enumerate() {
            let q = points[x as usize];
            id[v][l] = x;
            for a in 0..3 {
                p[v][a][l] = q[a];
            }
        }
    }
    let mut odd = [false; LANES];
    for (a, b) in PAIRS {
        let (pa, pb) = (&p[a], &p[b]);
        for l in 0..LANES {
            odd[l] |= (id[a][l] == id[b][l])
                | ((pa[0][l] == pb[0][l]) & (pa[1][l] == pb[1][l]) & (pa[2][l] == pb[2][l]));
        }
    }
    for f in HEX_FACES {
        let q = f.map(|v| &p[v as usize]);
        let (e1, e2, e3) = (sub(q[1], q[0]), sub(q[2], q[0]), sub(q[3], q[0]));
        let d = dot(&cross(&e1, &e2), &cross(&e2, &e3));
        for l in 0..LANES {
            odd[l] |= d[l] < 0.0;
        }
    }
    let p0 = p[0];
    let mut ext: P = [[0.0; LANES]; 3];
    for v in &mut p {
        *v = sub(v, &p0);
        for a in 0..3 {
            for l in 0..LANES {
                let x = v[a][l].abs();
                if x > ext[a][l] {
                    ext[a][l] = x;
                }
            }
        }
    }
    let mut six: V = [0.0; LANES];
    for f in HEX_FACES {
        let q = f.map(|v| &p[v as usize]);
        let s = cross(&sub(q[2], q[0]), &sub(q[3], q[1]));
        let sum = add(&add(q[0], q[1]), &add(q[2], q[3]));
        let d = dot(&sum, &s);
        for l in 0..LANES {
            six[l] += 0.25 * d[l];
        }
    }
    std::array::from_fn(|l| {
        let e = ext[0][l].max(ext[1][l]).max(ext[2][l]);
        match (odd[l], class_far_from_zero(six[l], e)) {
            (false, Some(class)) => class,
            _ => scalar(l),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metacell::{Catalog, builtin};

    /// Four at a time gives [`classify_cell`]'s class on random hexahedra:
    /// valid, inverted (mirrored), flat, with repeated vertices (same id or
    /// same point), with swapped vertices (bow-ties) and far from the origin.
    #[test]
    fn lanes_equal_cell_by_cell() {
        let cat = Catalog::new();
        let hex = cat.get(builtin::HEXAHEDRON);
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let mut r = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut points: Vec<[f64; 3]> = Vec::new();
        let mut cells: Vec<Vec<u32>> = Vec::new();
        for t in 0..4000 {
            let (off, scale) = [(0.0, 1.0), (4.6e5, 50.0), (-3.0, 1e-7), (5.9e6, 1e3)][t % 4];
            let flat = t % 11 == 0;
            let base = points.len() as u32;
            for n in 0..8 {
                // VTK order: the bottom quad counterclockwise, then the top.
                let q = [
                    ((n + 1) >> 1 & 1) as f64,
                    (n >> 1 & 1) as f64,
                    (n >> 2) as f64,
                ];
                let z = if flat { 0.0 } else { q[2] };
                let jitter = if t % 3 == 0 { 0.9 } else { 0.2 };
                points.push([
                    off + scale * (q[0] + jitter * (r() - 0.5)),
                    off + scale * (q[1] + jitter * (r() - 0.5)),
                    off + scale * (z + if flat { 0.0 } else { jitter * (r() - 0.5) }),
                ]);
            }
            let mut ids: Vec<u32> = (base..base + 8).collect();
            match t % 13 {
                1 => ids.swap(0, 1),
                2 => ids[5] = ids[1],
                3 => points[base as usize + 6] = points[base as usize + 2],
                4 => ids.swap(2, 3),
                5 => ids = [4, 5, 6, 7, 0, 1, 2, 3].map(|k| base + k).to_vec(),
                _ => {}
            }
            cells.push(ids);
        }
        let mut classes = [0usize; 6];
        for quad in cells.chunks_exact(LANES) {
            let ids: [&[u32]; LANES] = std::array::from_fn(|l| &quad[l][..]);
            let got = classify_hexes(hex, ids, &points);
            assert_eq!(got, classify_lanes(hex, ids, &points));
            for l in 0..LANES {
                let want = classify_cell(hex, ids[l], &points);
                assert_eq!(got[l], want, "{:?}", ids[l]);
                classes[want as usize] += 1;
            }
        }
        // Valid, inverted, zero volume, repeated vertex, self-intersecting.
        for c in [0, 1, 2, 3, 5] {
            assert!(classes[c] > 0, "{classes:?}");
        }
    }
}
