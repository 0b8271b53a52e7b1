//! Corner-point (Eclipse) grids: pillars (COORD), corner depths (ZCORN),
//! active flags (ACTNUM), MAPAXES, and their conversion into the crate's
//! zoo [`Grid`]. No I/O: the readers in `io::grdecl` and
//! `io::egrid` fill a [`CornerPointGrid`].
//!
//! Conventions:
//! * Cell `(i, j, k)` has index `i + nx·(j + ny·k)`; its corner
//!   `(ii, jj, kk) ∈ {0,1}³` has local number `ii + 2·jj + 4·kk` and its
//!   depth at ZCORN index `(2k+kk)·4·nx·ny + (2j+jj)·2·nx + (2i+ii)`.
//! * A corner lies on pillar `(i+ii, j+jj)`; its x and y are interpolated
//!   linearly along the pillar at its depth (the pillar's top point when the
//!   pillar is horizontal).
//! * World coordinates: MAPAXES (origin, a point on the Y axis, a point on
//!   the X axis) maps the grid's x, y to the map; z = −depth (elevation).
//! * Corners on the same pillar with the same depth are welded into one
//!   vertex. Corners of one cell on different pillars that coincide (within
//!   1e-9 of the cell's extent: pillars that meet or coincide) are merged
//!   too, through one union-find over the vertices, so the neighbours see the
//!   same vertex. Nothing else is welded: cells on the two sides of a fault
//!   share no vertex, and the CGraph sews only faces that match exactly.
//! * Each cell's volume is the exact volume of its trilinear hexahedron
//!   (2×2×2 Gauss quadrature of det J, which is exact: det J has degree ≤ 2
//!   in each parameter).
//! * A cell with merged corners (pinch-outs, meeting pillars) loses its
//!   repeated corners and becomes what it really is: faces with fewer than
//!   three distinct corners vanish, and a closed surface of 2 triangles + 3
//!   quads, 1 quad + 4 triangles or 4 triangles is the catalog's wedge,
//!   pyramid or tetrahedron; other closed surfaces are polyhedra. A merge
//!   that leaves a face passing twice through a corner is not applied (the
//!   cell keeps its pillar-only shape; counted). Cells of (near) zero volume
//!   are dropped and counted; cells oriented against the grid are kept and
//!   counted as inverted.

mod collapse;
mod convert;
mod shapes;
mod volume;

pub use collapse::{CollapseCounts, collapse_hexahedra};
pub use volume::{bulk_volume, cell_volume};

use rayon::prelude::*;
use thiserror::Error;

use crate::grid::{Grid, Property};

/// A corner-point grid as read from GRDECL or EGRID.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CornerPointGrid {
    /// Cells along I, J, K.
    pub dims: [usize; 3],
    /// Pillars: `6·(nx+1)·(ny+1)` numbers, `x y z` at the top then at the
    /// bottom, pillar `(pi, pj)` at `pi + (nx+1)·pj`. z is depth.
    pub coord: Vec<f64>,
    /// `8·nx·ny·nz` corner depths (see the module docs for the order).
    pub zcorn: Vec<f64>,
    /// Per cell 1 (active) or 0; `None` = all active.
    pub actnum: Option<Vec<u8>>,
    /// MAPAXES `x1 y1 x0 y0 x2 y2`: a point on the Y axis, the origin, a point on the X axis.
    pub mapaxes: Option<[f64; 6]>,
    /// MAPUNITS, as given.
    pub mapunits: Option<String>,
    /// GRIDUNIT, as given.
    pub gridunit: Option<String>,
    /// Per-cell properties, `nx·ny·nz` values each, I fastest.
    pub properties: Vec<Property>,
}

/// Errors in a corner-point grid's arrays.
#[derive(Debug, Error, PartialEq)]
pub enum CornerPointError {
    /// An array of the wrong length.
    #[error("{what} has {found} values, expected {expected} for a {dims:?} grid")]
    Length {
        /// Which array.
        what: String,
        /// Grid dims.
        dims: [usize; 3],
        /// Expected length.
        expected: usize,
        /// Found length.
        found: usize,
    },
    /// A NaN or infinite value.
    #[error("{what}[{index}] is not finite")]
    NonFinite {
        /// Which array.
        what: String,
        /// Index.
        index: usize,
    },
    /// A zero dimension, or too many cells for u32 ids.
    #[error("bad grid size {0:?}")]
    BadDims([usize; 3]),
    /// MAPAXES with coincident points.
    #[error("MAPAXES {0:?} has a zero-length axis")]
    BadMapaxes([f64; 6]),
    /// ACTNUM value other than 0/1.
    #[error("ACTNUM[{index}] = {value} is not 0 or 1")]
    BadActnum {
        /// Cell index.
        index: usize,
        /// Value.
        value: u8,
    },
    /// An array of the conversion does not fit in memory.
    #[error(transparent)]
    Memory(#[from] crate::mem::AllocError),
}

/// What the conversion to a [`Grid`] found, per class of cell.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CornerPointReport {
    /// Cells in the IJK box.
    pub cells: usize,
    /// Active cells (ACTNUM = 1).
    pub active: usize,
    /// Inactive cells (excluded).
    pub inactive: usize,
    /// Output hexahedra.
    pub hexahedra: usize,
    /// Output wedges (pinch-outs along one side).
    pub wedges: usize,
    /// Output pyramids.
    pub pyramids: usize,
    /// Output tetrahedra.
    pub tetrahedra: usize,
    /// Output polyhedra (other collapse patterns).
    pub polyhedra: usize,
    /// Active cells of (near) zero volume, dropped.
    pub zero_volume: usize,
    /// Active cells whose orientation is opposite to the grid's (kept, reported).
    pub inverted: usize,
    /// Active cells with at least one collapsed pillar edge.
    pub collapsed: usize,
    /// Kept cells with corners coinciding across pillars whose merged faces
    /// are not a valid cell (kept with their pillar-only shape, unmerged).
    pub merge_fallback: usize,
    /// Welded vertices.
    pub vertices: usize,
    /// Whether I, J, K (with K down) is a right-handed frame in world
    /// coordinates with z up (the cells' VTK order is chosen accordingly).
    pub ijk_right_handed_up: bool,
    /// Sum of the exact trilinear volumes of the kept cells (world units³).
    pub bulk_volume: f64,
    /// IJK index (`i + nx·(j + ny·k)`) of each output cell.
    pub source_cell: Vec<u32>,
}

impl CornerPointReport {
    /// `(name, count)` of each class, for `info`.
    pub fn class_counts(&self) -> Vec<(&'static str, usize)> {
        vec![
            ("active", self.active),
            ("inactive", self.inactive),
            ("hexahedra", self.hexahedra),
            ("wedges", self.wedges),
            ("pyramids", self.pyramids),
            ("tetrahedra", self.tetrahedra),
            ("polyhedra", self.polyhedra),
            ("zero_volume_dropped", self.zero_volume),
            ("inverted", self.inverted),
            ("collapsed", self.collapsed),
            ("merge_fallback", self.merge_fallback),
        ]
    }
}

/// The index of the first value of `v` that is not finite: chunks checked
/// in parallel without stopping early (so the check vectorises), then the
/// first bad chunk searched.
fn first_non_finite(v: &[f64]) -> Option<usize> {
    const CHUNK: usize = 1 << 15;
    let c = v
        .par_chunks(CHUNK)
        .position_first(|c| !c.iter().fold(true, |ok, x| ok & x.is_finite()))?;
    let i = v[c * CHUNK..].iter().position(|x| !x.is_finite())?;
    Some(c * CHUNK + i)
}

/// Signed volume of the trilinear hexahedron with corners in corner-point
/// order (`ii + 2·jj + 4·kk`): `∫ det J` over the unit cube by 2×2×2 Gauss
/// quadrature, exact for the trilinear map. Positive when (i, j, k) is a
/// right-handed frame.
pub fn trilinear_volume(c: &[[f64; 3]; 8]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked above).
        return unsafe { trilinear_volume_avx2(c) };
    }
    trilinear_lanes(c)
}

/// [`trilinear_lanes`] compiled for AVX2: four Gauss points per vector
/// (the same operations in the same order, so the same bits; Rust never
/// fuses a product and a sum).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn trilinear_volume_avx2(c: &[[f64; 3]; 8]) -> f64 {
    trilinear_lanes(c)
}

/// [`trilinear_volume`]'s quadrature with the eight Gauss points as lanes:
/// per point `det J` by the same expression, each product and sum in the
/// same order as point by point, then summed in point order (u, v, w
/// nested), so the result does not depend on how the lanes are
/// vectorised.
#[inline(always)]
fn trilinear_lanes(c: &[[f64; 3]; 8]) -> f64 {
    // Relative to corner 0 for precision far from the origin.
    let o = c[0];
    let p: [[f64; 3]; 8] =
        std::array::from_fn(|n| [c[n][0] - o[0], c[n][1] - o[1], c[n][2] - o[2]]);
    let g = 0.5 / 3f64.sqrt();
    let nodes = [0.5 - g, 0.5 + g];
    // Point l = 4·iu + 2·iv + iw.
    let u1: [f64; 8] = std::array::from_fn(|l| nodes[l >> 2]);
    let v1: [f64; 8] = std::array::from_fn(|l| nodes[l >> 1 & 1]);
    let w1: [f64; 8] = std::array::from_fn(|l| nodes[l & 1]);
    let (u0, v0, w0) = (
        u1.map(|x| 1.0 - x),
        v1.map(|x| 1.0 - x),
        w1.map(|x| 1.0 - x),
    );
    let mut du = [[0.0; 8]; 3];
    let mut dv = [[0.0; 8]; 3];
    let mut dw = [[0.0; 8]; 3];
    for a in 0..3 {
        let e = |m: usize, n: usize| p[m][a] - p[n][a];
        let (x10, x32, x54, x76) = (e(1, 0), e(3, 2), e(5, 4), e(7, 6));
        let (y20, y31, y64, y75) = (e(2, 0), e(3, 1), e(6, 4), e(7, 5));
        let (z40, z51, z62, z73) = (e(4, 0), e(5, 1), e(6, 2), e(7, 3));
        for l in 0..8 {
            du[a][l] = x10 * v0[l] * w0[l]
                + x32 * v1[l] * w0[l]
                + x54 * v0[l] * w1[l]
                + x76 * v1[l] * w1[l];
            dv[a][l] = y20 * u0[l] * w0[l]
                + y31 * u1[l] * w0[l]
                + y64 * u0[l] * w1[l]
                + y75 * u1[l] * w1[l];
            dw[a][l] = z40 * u0[l] * v0[l]
                + z51 * u1[l] * v0[l]
                + z62 * u0[l] * v1[l]
                + z73 * u1[l] * v1[l];
        }
    }
    let det: [f64; 8] = std::array::from_fn(|l| {
        du[0][l] * (dv[1][l] * dw[2][l] - dv[2][l] * dw[1][l])
            - du[1][l] * (dv[0][l] * dw[2][l] - dv[2][l] * dw[0][l])
            + du[2][l] * (dv[0][l] * dw[1][l] - dv[1][l] * dw[0][l])
    });
    let mut vol = 0.0;
    for d in det {
        vol += d;
    }
    vol / 8.0
}

impl CornerPointGrid {
    /// Number of cells in the IJK box.
    pub fn cell_count(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// Checks array lengths, finiteness and ACTNUM values. Never panics.
    pub fn validate(&self) -> Result<(), CornerPointError> {
        let [nx, ny, nz] = self.dims;
        if nx == 0
            || ny == 0
            || nz == 0
            || (nx as u128 + 1) * (ny as u128 + 1) * (2 * nz as u128) * 4 >= u32::MAX as u128
        {
            return Err(CornerPointError::BadDims(self.dims));
        }
        let n = nx * ny * nz;
        let check_len = |what: &str, expected: usize, found: usize| {
            if expected != found {
                Err(CornerPointError::Length {
                    what: what.into(),
                    dims: self.dims,
                    expected,
                    found,
                })
            } else {
                Ok(())
            }
        };
        check_len("COORD", 6 * (nx + 1) * (ny + 1), self.coord.len())?;
        check_len("ZCORN", 8 * n, self.zcorn.len())?;
        if let Some(a) = &self.actnum {
            check_len("ACTNUM", n, a.len())?;
            if let Some(i) = a.iter().position(|&x| x > 1) {
                return Err(CornerPointError::BadActnum {
                    index: i,
                    value: a[i],
                });
            }
        }
        for p in &self.properties {
            check_len(&p.name, n * p.components.max(1), p.values.len())?;
        }
        for (what, v) in [("COORD", &self.coord), ("ZCORN", &self.zcorn)] {
            if let Some(i) = first_non_finite(v) {
                return Err(CornerPointError::NonFinite {
                    what: what.into(),
                    index: i,
                });
            }
        }
        if let Some(m) = self.mapaxes {
            if let Some(i) = m.iter().position(|x| !x.is_finite()) {
                return Err(CornerPointError::NonFinite {
                    what: "MAPAXES".into(),
                    index: i,
                });
            }
            if (m[0] == m[2] && m[1] == m[3]) || (m[4] == m[2] && m[5] == m[3]) {
                return Err(CornerPointError::BadMapaxes(m));
            }
        }
        Ok(())
    }

    /// Whether cell `c` is active.
    pub fn is_active(&self, c: usize) -> bool {
        self.actnum.as_ref().is_none_or(|a| a[c] != 0)
    }

    /// ZCORN index of corner `corner` (`ii + 2jj + 4kk`) of cell (i, j, k).
    #[inline]
    pub fn zcorn_index(&self, i: usize, j: usize, k: usize, corner: usize) -> usize {
        let [nx, ny, _] = self.dims;
        let (ii, jj, kk) = (corner & 1, corner >> 1 & 1, corner >> 2);
        (2 * k + kk) * 4 * nx * ny + (2 * j + jj) * 2 * nx + 2 * i + ii
    }

    /// Index of pillar `(pi, pj)`.
    #[inline]
    fn pillar_index(&self, pi: usize, pj: usize) -> usize {
        pi + (self.dims[0] + 1) * pj
    }

    /// Grid coordinates (x, y, depth) of the point at `depth` on pillar `p`.
    #[inline]
    pub fn on_pillar(&self, p: usize, depth: f64) -> [f64; 3] {
        let c = &self.coord[6 * p..6 * p + 6];
        let dz = c[5] - c[2];
        if dz == 0.0 {
            return [c[0], c[1], depth];
        }
        let t = (depth - c[2]) / dz;
        [c[0] + t * (c[3] - c[0]), c[1] + t * (c[4] - c[1]), depth]
    }

    /// The map transform `[ox, oy, ux, uy, vx, vy]`: origin and unit X and
    /// Y axes from MAPAXES (identity without MAPAXES).
    fn transform(&self) -> [f64; 6] {
        match self.mapaxes {
            None => [0.0, 0.0, 1.0, 0.0, 0.0, 1.0],
            Some(m) => {
                let (ox, oy) = (m[2], m[3]);
                let (ax, ay) = (m[4] - ox, m[5] - oy);
                let (bx, by) = (m[0] - ox, m[1] - oy);
                let la = (ax * ax + ay * ay).sqrt();
                let lb = (bx * bx + by * by).sqrt();
                [ox, oy, ax / la, ay / la, bx / lb, by / lb]
            }
        }
    }

    #[inline(always)]
    fn apply(t: &[f64; 6], p: [f64; 3]) -> [f64; 3] {
        Self::apply_with(Self::is_identity(t), t, p)
    }

    /// Whether `t` is the identity transform (no MAPAXES).
    #[inline(always)]
    fn is_identity(t: &[f64; 6]) -> bool {
        t == &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0]
    }

    /// [`Self::apply`] with [`Self::is_identity`] of `t` known.
    #[inline(always)]
    fn apply_with(identity: bool, t: &[f64; 6], p: [f64; 3]) -> [f64; 3] {
        if identity {
            return [p[0], p[1], -p[2]];
        }
        [
            t[0] + p[0] * t[2] + p[1] * t[4],
            t[1] + p[0] * t[3] + p[1] * t[5],
            -p[2],
        ]
    }

    /// World positions of the 8 corners of cell (i, j, k), corner-point order.
    pub fn cell_corners(&self, i: usize, j: usize, k: usize) -> [[f64; 3]; 8] {
        self.corners_with(&self.transform(), i, j, k)
    }

    #[inline]
    fn corners_with(&self, t: &[f64; 6], i: usize, j: usize, k: usize) -> [[f64; 3]; 8] {
        std::array::from_fn(|c| {
            let (ii, jj) = (c & 1, c >> 1 & 1);
            let z = self.zcorn[self.zcorn_index(i, j, k, c)];
            Self::apply(t, self.on_pillar(self.pillar_index(i + ii, j + jj), z))
        })
    }

    /// Exact signed trilinear volume of cell (i, j, k) in world units³
    /// (see [`trilinear_volume`]).
    pub fn cell_volume(&self, i: usize, j: usize, k: usize) -> f64 {
        trilinear_volume(&self.cell_corners(i, j, k))
    }

    /// Converts to a zoo [`Grid`] of the active, non-degenerate cells
    /// (world f64 positions, welded vertices, cell properties restricted to
    /// the output cells) and reports the classes found. Works on a copy;
    /// [`CornerPointGrid::into_grid`] avoids holding input and output at once.
    pub fn to_grid(&self) -> Result<(Grid, CornerPointReport), CornerPointError> {
        self.clone().into_grid()
    }

    /// [`CornerPointGrid::to_grid`], consuming the corner-point arrays:
    /// ZCORN is released layer by layer (deepest first) while the cells are
    /// written, points are computed after it is gone, and the properties are
    /// restricted in place, so the conversion peaks near the larger of the
    /// input and the output instead of their sum.
    pub fn into_grid(self) -> Result<(Grid, CornerPointReport), CornerPointError> {
        self.into_grid_with(true)
    }

    /// Sum of the exact trilinear volumes of the active cells (world units³).
    pub fn bulk_volume(&self) -> f64 {
        let [nx, ny, _] = self.dims;
        (0..self.cell_count())
            .into_par_iter()
            .filter(|&c| self.is_active(c))
            .map(|c| self.cell_volume(c % nx, c / nx % ny, c / (nx * ny)).abs())
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::first_non_finite;
    use super::shapes::search_from;

    /// The point-by-point quadrature [`super::trilinear_volume`] replaced.
    fn trilinear_reference(c: &[[f64; 3]; 8]) -> f64 {
        let o = c[0];
        let p: [[f64; 3]; 8] =
            std::array::from_fn(|n| [c[n][0] - o[0], c[n][1] - o[1], c[n][2] - o[2]]);
        let g = 0.5 / 3f64.sqrt();
        let nodes = [0.5 - g, 0.5 + g];
        let mut vol = 0.0;
        for &u in &nodes {
            for &v in &nodes {
                for &w in &nodes {
                    let (u0, u1, v0, v1, w0, w1) = (1.0 - u, u, 1.0 - v, v, 1.0 - w, w);
                    let (mut du, mut dv, mut dw) = ([0.0; 3], [0.0; 3], [0.0; 3]);
                    for a in 0..3 {
                        du[a] = (p[1][a] - p[0][a]) * v0 * w0
                            + (p[3][a] - p[2][a]) * v1 * w0
                            + (p[5][a] - p[4][a]) * v0 * w1
                            + (p[7][a] - p[6][a]) * v1 * w1;
                        dv[a] = (p[2][a] - p[0][a]) * u0 * w0
                            + (p[3][a] - p[1][a]) * u1 * w0
                            + (p[6][a] - p[4][a]) * u0 * w1
                            + (p[7][a] - p[5][a]) * u1 * w1;
                        dw[a] = (p[4][a] - p[0][a]) * u0 * v0
                            + (p[5][a] - p[1][a]) * u1 * v0
                            + (p[6][a] - p[2][a]) * u0 * v1
                            + (p[7][a] - p[3][a]) * u1 * v1;
                    }
                    vol += du[0] * (dv[1] * dw[2] - dv[2] * dw[1])
                        - du[1] * (dv[0] * dw[2] - dv[2] * dw[0])
                        + du[2] * (dv[0] * dw[1] - dv[1] * dw[0]);
                }
            }
        }
        vol / 8.0
    }

    /// The lane quadrature (and its AVX2 build) gives the point-by-point
    /// one's bits on random, far-from-origin and degenerate hexahedra.
    #[test]
    fn trilinear_lanes_equal_point_by_point() {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut r = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        for t in 0..20000 {
            let (off, scale) = match t % 4 {
                0 => (0.0, 1.0),
                1 => (4.6e5, 100.0),
                2 => (-1.0e3, 1e-6),
                _ => (5.9e6, 1e4),
            };
            let mut c: [[f64; 3]; 8] = std::array::from_fn(|n| {
                let q = [(n & 1) as f64, (n >> 1 & 1) as f64, (n >> 2) as f64];
                std::array::from_fn(|a| off + scale * (q[a] + 0.6 * (r() - 0.5)))
            });
            if t % 7 == 0 {
                c[5] = c[1];
            }
            let (a, b) = (super::trilinear_volume(&c), trilinear_reference(&c));
            assert_eq!(a.to_bits(), b.to_bits(), "{c:?}");
            assert_eq!(super::trilinear_lanes(&c).to_bits(), b.to_bits());
        }
    }

    /// Bottom corners reusing the ids of the cell below give the same grid
    /// (points, cells, face streams, properties) and report (bulk volume
    /// bit for bit) as searching every corner, on generated faulted grids
    /// (faults, pinch-outs, inactive cells) and on the same grids with
    /// layers pulled apart or pinched in places (gaps, collapsed pillars).
    #[test]
    fn reused_bottom_corners_equal_searched_ones() {
        let mut cases = 0;
        for (dims, faults, seed) in [
            ([7, 5, 6], 2, 1u64),
            ([12, 9, 8], 3, 7),
            ([20, 3, 11], 1, 42),
            ([4, 4, 4], 0, 3),
        ] {
            let g = crate::generate::faulted(dims, faults, seed);
            let mut gapped = g.clone();
            let [nx, ny, nz] = dims;
            for k in 0..nz {
                for j in 0..ny {
                    for i in 0..nx {
                        for q in 0..8 {
                            let z = gapped.zcorn_index(i, j, k, q);
                            match (i * 7 + j * 3 + k * 5 + q) % 11 {
                                0 => gapped.zcorn[z] += 0.25,
                                1 if q >= 4 => gapped.zcorn[z] = gapped.zcorn[z - 4 * nx * ny],
                                _ => {}
                            }
                        }
                    }
                }
            }
            for grid in [g, gapped] {
                let a = grid.clone().into_grid_with(true);
                let b = grid.into_grid_with(false);
                match (a, b) {
                    (Ok((ga, ra)), Ok((gb, rb))) => {
                        assert_eq!(ga, gb, "{dims:?}");
                        assert_eq!(ra.bulk_volume.to_bits(), rb.bulk_volume.to_bits());
                        assert_eq!(ra, rb);
                        assert!(ga.cell_count() > 0);
                        cases += 1;
                    }
                    (a, b) => assert_eq!(a.err(), b.err(), "{dims:?}"),
                }
            }
        }
        assert!(cases >= 6, "{cases} grids converted");
    }

    /// The parallel finiteness check finds the first bad value, as a serial
    /// scan does, wherever it sits relative to the chunks.
    #[test]
    fn first_non_finite_is_the_first() {
        let n = (1 << 15) * 5 + 123;
        assert_eq!(first_non_finite(&vec![1.0; n]), None);
        for bad in [0, 1, (1 << 15) - 1, 1 << 15, 3 * (1 << 15) + 7, n - 1] {
            for x in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let mut v = vec![2.5; n];
                v[bad] = x;
                if bad + 40_000 < n {
                    v[bad + 40_000] = f64::NAN;
                }
                let serial = v.iter().position(|x| !x.is_finite());
                assert_eq!(first_non_finite(&v), serial, "at {bad}");
            }
        }
    }

    #[test]
    fn search_from_matches_partition_point() {
        let mut seed = 0x1234_5678_9abc_def0u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        for n in 0..40usize {
            let mut d: Vec<f64> = (0..n).map(|_| (next() % 50) as f64).collect();
            d.sort_by(f64::total_cmp);
            d.dedup();
            for z in -1..52 {
                let z = z as f64;
                let want = d.partition_point(|x| *x < z);
                for guess in 0..n + 3 {
                    assert_eq!(search_from(&d, z, guess), want, "{d:?} z {z} guess {guess}");
                }
            }
        }
    }
}
