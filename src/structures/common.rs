//! Pieces shared by the sweep structures: build errors, cell quality
//! classification and a compact live-cell bit set.

use thiserror::Error;

use crate::metacell::{MAX_META_VERTICES, MetaCell};

/// Errors building a sweep structure from a grid.
#[derive(Debug, Error, PartialEq)]
pub enum StructureError {
    /// S-CGraph needs a structured grid.
    #[error(
        "S-CGraph needs a structured (IJK) grid; this one is unstructured (use the CGraph structure)"
    )]
    NotStructured,
    /// No cells at all.
    #[error("the grid has no cells")]
    NoCells,
    /// Too many slots for u32 ids.
    #[error("grid too large: {count} slots exceed u32 ids")]
    TooLarge {
        /// Slot count.
        count: usize,
    },
    /// An array of the structure did not fit in memory.
    #[error(transparent)]
    Memory(#[from] crate::mem::AllocError),
    /// A cell type the catalog cannot take.
    #[error("cell {cell}: {why}")]
    UnsupportedCell {
        /// Cell id.
        cell: usize,
        /// Why.
        why: String,
    },
}

/// Quality class of a cell, as reported by `info`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum CellClass {
    /// Positive volume.
    Valid = 0,
    /// Negative volume (vertex order mirrored): sliced, but reported.
    Inverted = 1,
    /// (Near) zero volume: skipped.
    ZeroVolume = 2,
    /// Two vertices of the cell coincide (same id or same position): skipped.
    RepeatedVertex = 3,
    /// A 0D/1D/2D cell (point, line, triangle, quad, ...): skipped.
    NonVolumetric = 4,
    /// A quadrilateral face crosses itself (a bow-tie: two vertices
    /// swapped), so the cell's polygons would be wrong: skipped.
    SelfIntersecting = 5,
}

/// How many [`CellClass`] variants there are.
pub const CELL_CLASS_COUNT: usize = 6;

/// Names of the [`CellClass`] variants, in order.
pub const CELL_CLASS_NAMES: [&str; CELL_CLASS_COUNT] = [
    "valid",
    "inverted",
    "zero_volume",
    "repeated_vertex",
    "non_volumetric",
    "self_intersecting",
];

/// The bow-tie test on a quadrilateral (pure geometry, with the vector
/// helpers below `grid`, where the generators use it too).
pub use crate::vec3::quad_is_bow_tie;

/// Classifies one cell from its global vertex ids (local order) and the f64
/// points. A vertex list that fits no meta-cell (empty, or longer than
/// [`MAX_META_VERTICES`]) is [`CellClass::NonVolumetric`].
pub fn classify_cell(meta: &MetaCell, ids: &[u32], points: &[[f64; 3]]) -> CellClass {
    match ids.len() {
        8 => classify_fixed::<8>(meta, ids, points),
        4 => classify_fixed::<4>(meta, ids, points),
        5 => classify_fixed::<5>(meta, ids, points),
        6 => classify_fixed::<6>(meta, ids, points),
        n if n == 0 || n > MAX_META_VERTICES => CellClass::NonVolumetric,
        _ => classify_fixed::<MAX_META_VERTICES>(meta, ids, points),
    }
}

/// [`classify_cell`] for `0 < ids.len() <= N <= MAX_META_VERTICES`, each
/// point read once; `N` = the exact count unrolls every loop.
#[inline(always)]
fn classify_fixed<const N: usize>(meta: &MetaCell, ids: &[u32], points: &[[f64; 3]]) -> CellClass {
    let n = ids.len().min(N);
    let mut local = [[0.0f64; 3]; MAX_META_VERTICES];
    for (l, &v) in local[..n].iter_mut().zip(ids) {
        *l = points[v as usize];
    }
    // Repeated vertex: same id or equal points, over all pairs.
    let mut repeated = false;
    for a in 0..n {
        for b in a + 1..n {
            let (pa, pb) = (local[a], local[b]);
            repeated |=
                (ids[a] == ids[b]) | ((pa[0] == pb[0]) & (pa[1] == pb[1]) & (pa[2] == pb[2]));
        }
    }
    if repeated {
        return CellClass::RepeatedVertex;
    }
    for f in &meta.faces {
        if let [a, b, c, d] = f[..]
            && quad_is_bow_tie([
                local[a as usize],
                local[b as usize],
                local[c as usize],
                local[d as usize],
            ])
        {
            return CellClass::SelfIntersecting;
        }
    }
    let p0 = local[0];
    // Extent: largest |coordinate| from p0 (a plain maximum skips NaN just
    // as f64::max does, and max is order-free without NaN).
    let mut ext = [0.0f64; 3];
    for l in &mut local[..n] {
        *l = [l[0] - p0[0], l[1] - p0[1], l[2] - p0[2]];
        for a in 0..3 {
            let x = l[a].abs();
            if x > ext[a] {
                ext[a] = x;
            }
        }
    }
    let ext = ext[0].max(ext[1]).max(ext[2]);
    if let Some(class) = class_far_from_zero(meta.six_volume_filter(&local), ext) {
        return class;
    }
    class_of_volume(meta.signed_volume_of(&mut local), ext)
}

/// The class of a cell whose filtered six-fold volume `six`
/// ([`MetaCell::six_volume_filter`], coordinates within `ext` of the first
/// vertex) is far from zero, without the exact volume. Both volumes lie
/// within about 1e-11·ext³ of the true one (at most 12 vertices, rounding
/// at 2⁻⁵³ per operation), so beyond 1e-6·ext³ they have the same sign and
/// the exact one is far above [`class_of_volume`]'s zero threshold: the
/// same class. `None` near zero, for NaN, or with `ext` where ext³ could
/// leave the normal range: the exact volume decides.
#[inline(always)]
pub(crate) fn class_far_from_zero(six: f64, ext: f64) -> Option<CellClass> {
    let far = six.abs() > 1e-6 * ext * ext * ext && (1e-90..=1e90).contains(&ext);
    match (far, six < 0.0) {
        (false, _) => None,
        (true, true) => Some(CellClass::Inverted),
        (true, false) => Some(CellClass::Valid),
    }
}

/// Class of a cell of signed volume `vol` and extent `ext` from its first vertex.
fn class_of_volume(vol: f64, ext: f64) -> CellClass {
    if vol.is_nan() || vol.abs() <= 1e-12 * ext * ext * ext {
        CellClass::ZeroVolume
    } else if vol < 0.0 {
        CellClass::Inverted
    } else {
        CellClass::Valid
    }
}

/// Whether a class is swept.
pub fn is_sweepable(c: CellClass) -> bool {
    matches!(c, CellClass::Valid | CellClass::Inverted)
}

pub use crate::cellgraph::BitSet;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metacell::{Catalog, builtin};

    /// The class from the exact volume alone (no filter).
    fn exact_class(meta: &MetaCell, pts: &[[f64; 3]]) -> CellClass {
        let mut local = [[0.0f64; 3]; MAX_META_VERTICES];
        let p0 = pts[0];
        let mut ext = 0.0f64;
        for (l, p) in local.iter_mut().zip(pts) {
            *l = [p[0] - p0[0], p[1] - p0[1], p[2] - p0[2]];
            ext = l.iter().fold(ext, |e, x| e.max(x.abs()));
        }
        class_of_volume(meta.signed_volume_of(&mut local), ext)
    }

    /// Unit corners of each built-in type, warped, flattened towards zero
    /// volume, mirrored and moved far from the origin: the filtered class
    /// is the exact one, on both sides of the filter's margin.
    #[test]
    fn filtered_class_equals_the_exact_class() {
        let catalog = Catalog::new();
        let corners: [(u16, &[[f64; 3]]); 4] = [
            (
                builtin::TETRA,
                &[[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]],
            ),
            (
                builtin::PYRAMID,
                &[
                    [0., 0., 0.],
                    [1., 0., 0.],
                    [1., 1., 0.],
                    [0., 1., 0.],
                    [0.5, 0.5, 1.],
                ],
            ),
            (
                builtin::WEDGE,
                &[
                    [0., 0., 0.],
                    [0., 1., 0.],
                    [1., 0., 0.],
                    [0., 0., 1.],
                    [0., 1., 1.],
                    [1., 0., 1.],
                ],
            ),
            (
                builtin::HEXAHEDRON,
                &[
                    [0., 0., 0.],
                    [1., 0., 0.],
                    [1., 1., 0.],
                    [0., 1., 0.],
                    [0., 0., 1.],
                    [1., 0., 1.],
                    [1., 1., 1.],
                    [0., 1., 1.],
                ],
            ),
        ];
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut seen = [0usize; CELL_CLASS_COUNT];
        for (m, unit) in corners {
            let meta = catalog.get(m);
            let ids: Vec<u32> = (0..unit.len() as u32).collect();
            for trial in 0..4000 {
                let flat = [1.0, 1e-3, 1e-6, 2e-7, 1e-7, 1e-9, 1e-12, 0.0][trial % 8];
                let (warp, sign) = (0.3 * rnd().abs(), if trial % 3 == 0 { -1.0 } else { 1.0 });
                let far = [4.6e5, 5.9e6, -1.6e3];
                let pts: Vec<[f64; 3]> = unit
                    .iter()
                    .map(|p| {
                        let z = p[2] * flat * sign + warp * flat * rnd();
                        [
                            far[0] + 50.0 * (p[0] + warp * rnd()),
                            far[1] + 50.0 * (p[1] + warp * rnd()),
                            far[2] + 50.0 * z,
                        ]
                    })
                    .collect();
                let got = classify_cell(meta, &ids, &pts);
                if matches!(
                    got,
                    CellClass::Valid | CellClass::Inverted | CellClass::ZeroVolume
                ) {
                    assert_eq!(got, exact_class(meta, &pts), "{} {pts:?}", meta.name);
                }
                seen[got as usize] += 1;
            }
        }
        for c in [CellClass::Valid, CellClass::Inverted, CellClass::ZeroVolume] {
            assert!(seen[c as usize] > 100, "{seen:?}");
        }
    }
}
