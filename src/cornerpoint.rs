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

use rayon::prelude::*;
use thiserror::Error;

use crate::grid::{Cells, Grid, Property, Topology, vtk_type};
use crate::metacell::{HEXAHEDRON_FACES, MAX_META_VERTICES};

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

/// Signed volume of the trilinear hexahedron with corners in corner-point
/// order (`ii + 2·jj + 4·kk`): `∫ det J` over the unit cube by 2×2×2 Gauss
/// quadrature, exact for the trilinear map. Positive when (i, j, k) is a
/// right-handed frame.
pub fn trilinear_volume(c: &[[f64; 3]; 8]) -> f64 {
    // Relative to corner 0 for precision far from the origin.
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
                let mut du = [0.0; 3];
                let mut dv = [0.0; 3];
                let mut dw = [0.0; 3];
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
                let det = du[0] * (dv[1] * dw[2] - dv[2] * dw[1])
                    - du[1] * (dv[0] * dw[2] - dv[2] * dw[0])
                    + du[2] * (dv[0] * dw[1] - dv[1] * dw[0]);
                vol += det;
            }
        }
    }
    vol / 8.0
}

/// Corner-point corner numbers of VTK's hexahedron vertices when the
/// (i, j, k) frame is left-handed in world space (the usual case: i east,
/// j north, k down): VTK's bottom face is the k+1 (deeper) layer.
const VTK_ORDER_LEFT: [usize; 8] = [4, 5, 7, 6, 0, 1, 3, 2];
/// The same when (i, j, k) is right-handed (e.g. j south).
const VTK_ORDER_RIGHT: [usize; 8] = [0, 1, 3, 2, 4, 5, 7, 6];

/// Shape of one cell after merging its coincident corners.
#[derive(Clone, Debug, PartialEq)]
enum Shape {
    /// VTK typed cell: type and local corner numbers (corner-point numbering).
    Typed(u8, Vec<u8>),
    /// Polyhedron: outward faces as loops of corner numbers.
    Poly(Vec<Vec<u8>>),
    /// Fewer than four faces: no volume.
    Flat,
}

/// The merge pattern of a cell whose only coincident corners are on
/// collapsed pillar edges (bit `p` of `collapsed` for pillar corner
/// `p = ii + 2·jj`: corners `p` and `p + 4` coincide).
fn pillar_pattern(collapsed: u8) -> [u8; 8] {
    std::array::from_fn(|c| {
        if c >= 4 && collapsed >> (c - 4) & 1 == 1 {
            (c - 4) as u8
        } else {
            c as u8
        }
    })
}

/// Classifies a cell from its merge pattern (`rep[c]`: the smallest corner
/// coinciding with corner `c`, corner-point numbering), given the VTK order
/// in use. The faces are the hexahedron's with merged corners removed;
/// faces left with fewer than three corners vanish. 8 distinct corners give
/// a hexahedron; a closed surface of 2 triangles and 3 quads, of 4
/// triangles and 1 quad, or of 4 triangles gives a wedge, a pyramid or a
/// tetrahedron; other closed surfaces a polyhedron. `None` when the merged
/// faces are not a closed, consistently oriented surface (a face passing
/// twice through a corner, an edge used twice in one direction).
fn shape_of(rep: &[u8; 8], order: &[usize; 8]) -> Option<Shape> {
    if rep.iter().enumerate().all(|(c, &r)| r as usize == c) {
        return Some(Shape::Typed(
            vtk_type::HEXAHEDRON,
            order.iter().map(|&c| c as u8).collect(),
        ));
    }
    let mut faces: Vec<Vec<u8>> = Vec::new();
    for f in HEXAHEDRON_FACES {
        let mut loop_: Vec<u8> = f.iter().map(|&l| rep[order[l as usize]]).collect();
        loop_.dedup();
        while loop_.len() > 1 && loop_.first() == loop_.last() {
            loop_.pop();
        }
        if loop_.len() < 3 {
            continue;
        }
        let mut s = loop_.clone();
        s.sort_unstable();
        if s.windows(2).any(|w| w[0] == w[1]) {
            return None;
        }
        faces.push(loop_);
    }
    if faces.len() < 4 {
        return Some(Shape::Flat);
    }
    // Closed and consistently oriented: each directed edge once, with its reverse.
    let mut directed: Vec<(u8, u8)> = faces
        .iter()
        .flat_map(|f| (0..f.len()).map(move |i| (f[i], f[(i + 1) % f.len()])))
        .collect();
    directed.sort_unstable();
    if directed.windows(2).any(|w| w[0] == w[1])
        || directed
            .iter()
            .any(|&(a, b)| directed.binary_search(&(b, a)).is_err())
    {
        return None;
    }
    let mut verts: Vec<u8> = faces.iter().flatten().copied().collect();
    verts.sort_unstable();
    verts.dedup();
    let tris: Vec<&Vec<u8>> = faces.iter().filter(|f| f.len() == 3).collect();
    let quads: Vec<&Vec<u8>> = faces.iter().filter(|f| f.len() == 4).collect();
    let not_on =
        |f: &[u8]| -> Vec<u8> { verts.iter().copied().filter(|v| !f.contains(v)).collect() };
    let has_edge = |a: u8, b: u8| directed.binary_search(&(a, b)).is_ok();
    Some(match (verts.len(), tris.len(), quads.len()) {
        (6, 2, 3) => {
            // VTK wedge: face (0, 2, 1) outward, (3, 4, 5) outward,
            // vertex i+3 joined to vertex i.
            let t = tris[0];
            let (p0, p2, p1) = (t[0], t[1], t[2]);
            let u = tris[1];
            let partner = |p: u8| u.iter().copied().find(|&q| has_edge(p, q));
            match (partner(p0), partner(p1), partner(p2)) {
                (Some(a), Some(b), Some(c)) if a != b && b != c && a != c => {
                    Shape::Typed(vtk_type::WEDGE, vec![p0, p1, p2, a, b, c])
                }
                _ => Shape::Poly(faces),
            }
        }
        (5, 4, 1) => {
            // VTK pyramid: base (0, 3, 2, 1) outward, apex 4.
            let q = quads[0];
            let apex = not_on(q);
            Shape::Typed(vtk_type::PYRAMID, vec![q[0], q[3], q[2], q[1], apex[0]])
        }
        (4, 4, 0) => {
            // VTK tetra: (0, 2, 1) outward, apex 3.
            let t = tris[0];
            let apex = not_on(t);
            Shape::Typed(vtk_type::TETRA, vec![t[0], t[2], t[1], apex[0]])
        }
        (n, _, _) if n <= MAX_META_VERTICES => Shape::Poly(faces),
        _ => return None,
    })
}

/// Per-cell code of the conversion's first pass: bits 0–3 the collapsed
/// pillar edges, then the flags below.
const CODE_ACTIVE: u8 = 0x80;
/// (Near) zero volume, or a flat merge pattern: dropped.
const CODE_ZERO: u8 = 0x40;
/// Negative signed trilinear volume.
const CODE_NEG: u8 = 0x20;
/// Corners on different pillars coincide (merged through the side list).
const CODE_CROSS: u8 = 0x10;

/// Whether a first-pass code is a kept cell.
#[inline(always)]
fn kept(code: u8) -> bool {
    code & (CODE_ACTIVE | CODE_ZERO) == CODE_ACTIVE
}

/// A cell whose corners coincide across pillars.
struct CrossCell {
    /// IJK index.
    cell: usize,
    /// Merge pattern (see [`shape_of`]).
    rep: [u8; 8],
    /// |trilinear volume|.
    volume: f64,
}

/// The merge pattern of a cell (see [`shape_of`]) when corners on
/// different pillars coincide (within `tol` in every coordinate), else
/// `None`. Corners on the same pillar merge only at equal depths, as the
/// welding does.
fn cross_pattern(corners: &[[f64; 3]; 8], z: &[f64; 8], tol: f64) -> Option<[u8; 8]> {
    let mut rep = [0u8; 8];
    let mut cross = false;
    for a in 0..8 {
        rep[a] = a as u8;
        for b in 0..a {
            if rep[b] as usize != b {
                continue;
            }
            let same = if a ^ b == 4 {
                z[a] == z[b]
            } else {
                (0..3).all(|d| (corners[a][d] - corners[b][d]).abs() <= tol)
            };
            if same {
                rep[a] = b as u8;
                cross |= a ^ b != 4;
                break;
            }
        }
    }
    cross.then_some(rep)
}

/// Splits `v` into consecutive pieces of the lengths `start[i+1] - start[i]`.
fn split_by<'a, T>(mut v: &'a mut [T], start: &[usize]) -> Vec<&'a mut [T]> {
    let mut out = Vec::with_capacity(start.len().saturating_sub(1));
    for w in start.windows(2) {
        let (a, b) = std::mem::take(&mut v).split_at_mut(w[1] - w[0]);
        out.push(a);
        v = b;
    }
    out
}

/// Index of the first element of the sorted `d` not below `z` (total
/// order), searched by galloping from `guess`.
fn search_from(d: &[f64], z: f64, guess: usize) -> usize {
    let below = |x: &f64| x.total_cmp(&z).is_lt();
    let n = d.len();
    if n == 0 {
        return 0;
    }
    let g = guess.min(n - 1);
    let (mut lo, mut hi, mut step) = (g, g, 1);
    if below(&d[g]) {
        // Answer in (g, n]: d[..lo] below z.
        lo = g + 1;
        hi = lo;
        while hi < n && below(&d[hi]) {
            lo = hi + 1;
            hi += step;
            step *= 2;
        }
        hi = hi.min(n);
    } else {
        // Answer in [0, g]: d[hi] not below z.
        while lo > 0 {
            lo = hi.saturating_sub(step);
            if below(&d[lo]) {
                break;
            }
            hi = lo;
            step *= 2;
        }
    }
    lo + d[lo..hi].partition_point(below)
}

/// Union-find root with path halving.
fn find(parent: &mut [u32], mut v: u32) -> u32 {
    while parent[v as usize] != v {
        let p = parent[parent[v as usize] as usize];
        parent[v as usize] = p;
        v = p;
    }
    v
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
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
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
        if t == &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0] {
            return [p[0], p[1], -p[2]];
        }
        [
            t[0] + p[0] * t[2] + p[1] * t[4],
            t[1] + p[0] * t[3] + p[1] * t[5],
            -p[2],
        ]
    }

    /// World position (MAPAXES applied, z = −depth) of grid coordinates.
    #[inline]
    pub fn to_world(&self, p: [f64; 3]) -> [f64; 3] {
        Self::apply(&self.transform(), p)
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

    /// [`CornerPointGrid::into_grid`]; `reuse_below` lets a cell's bottom
    /// corners take the ids found for the top corners of the cell below
    /// instead of searching the pillar (same ids: tested against `false`).
    fn into_grid_with(
        mut self,
        reuse_below: bool,
    ) -> Result<(Grid, CornerPointReport), CornerPointError> {
        self.validate()?;
        let [nx, ny, nz] = self.dims;
        let n = nx * ny * nz;
        let nrows = ny * nz;
        let tr = self.transform();
        let mut zcorn = std::mem::take(&mut self.zcorn);
        let this = &self;
        // Pass 1 (parallel over IJ rows): per cell a code (collapsed pillar
        // edges and flags), per row the signed volume and the |volume| of
        // its kept cells, and the cells whose corners coincide across pillars.
        let flat_pillar: [bool; 16] = std::array::from_fn(|m| {
            matches!(
                shape_of(&pillar_pattern(m as u8), &VTK_ORDER_LEFT),
                Some(Shape::Flat)
            )
        });
        let mut codes = vec![0u8; n];
        let rows: Vec<(f64, f64, Vec<CrossCell>)> = codes
            .par_chunks_mut(nx)
            .enumerate()
            .map(|(row, out)| {
                let (j, k) = (row % ny, row / ny);
                let (mut signed, mut kept_abs, mut cross) = (0.0, 0.0, Vec::new());
                for (i, code) in out.iter_mut().enumerate() {
                    let c = i + nx * row;
                    if !this.is_active(c) {
                        continue;
                    }
                    let z: [f64; 8] = std::array::from_fn(|q| zcorn[this.zcorn_index(i, j, k, q)]);
                    let corners: [[f64; 3]; 8] = std::array::from_fn(|q| {
                        let p = this.pillar_index(i + (q & 1), j + (q >> 1 & 1));
                        Self::apply(&tr, this.on_pillar(p, z[q]))
                    });
                    let mut ext = 0.0f64;
                    for q in &corners[1..] {
                        for a in 0..3 {
                            ext = ext.max((q[a] - corners[0][a]).abs());
                        }
                    }
                    let mut m = 0u8;
                    for p in 0..4 {
                        if z[p] == z[p + 4] {
                            m |= 1 << p;
                        }
                    }
                    let vol = trilinear_volume(&corners);
                    let mut cd = CODE_ACTIVE | m;
                    if vol < 0.0 {
                        cd |= CODE_NEG;
                    }
                    signed += vol;
                    if flat_pillar[m as usize] || vol.abs() <= 1e-12 * ext * ext * ext {
                        cd |= CODE_ZERO;
                    } else if let Some(rep) = cross_pattern(&corners, &z, 1e-9 * ext) {
                        cd |= CODE_CROSS;
                        cross.push(CrossCell {
                            cell: c,
                            rep,
                            volume: vol.abs(),
                        });
                    } else {
                        kept_abs += vol.abs();
                    }
                    *code = cd;
                }
                (signed, kept_abs, cross)
            })
            .collect();
        let total: f64 = rows.iter().map(|r| r.0).sum();
        let left = total <= 0.0;
        let order = if left {
            &VTK_ORDER_LEFT
        } else {
            &VTK_ORDER_RIGHT
        };
        // Pillar-only patterns always give a closed surface (or a flat one).
        let shapes: Vec<Shape> = (0..16u8)
            .map(|m| shape_of(&pillar_pattern(m), order).unwrap_or(Shape::Flat))
            .collect();
        let mut rep = CornerPointReport {
            cells: n,
            ijk_right_handed_up: !left,
            bulk_volume: rows.iter().map(|r| r.1).sum(),
            ..Default::default()
        };
        // Cross-pillar merges that give a valid shape keep it; the others
        // (a face through a corner twice, an open surface) keep their
        // pillar-only shape and their unmerged vertices.
        let mut cross_shapes: Vec<([u8; 8], Shape)> = Vec::new();
        let mut cross_cells: Vec<(usize, usize)> = Vec::new();
        for cc in rows.into_iter().flat_map(|r| r.2) {
            rep.bulk_volume += cc.volume;
            let s = match cross_shapes.iter().position(|(r, _)| *r == cc.rep) {
                Some(s) => s,
                None => match shape_of(&cc.rep, order) {
                    Some(Shape::Flat) | None => {
                        rep.merge_fallback += 1;
                        continue;
                    }
                    Some(shape) => {
                        cross_shapes.push((cc.rep, shape));
                        cross_shapes.len() - 1
                    }
                },
            };
            cross_cells.push((cc.cell, s));
        }
        // The shape of a kept cell and whether it uses merged vertices.
        let shape_at = |c: usize, code: u8| -> (&Shape, bool) {
            if code & CODE_CROSS != 0
                && let Ok(x) = cross_cells.binary_search_by_key(&c, |e| e.0)
            {
                return (&cross_shapes[cross_cells[x].1].1, true);
            }
            (&shapes[(code & 15) as usize], false)
        };
        // Pass 2 (parallel over rows): class counts and output sizes per row.
        let counts: Vec<[usize; 11]> = codes
            .par_chunks(nx)
            .enumerate()
            .map(|(row, cs)| {
                // cells, connectivity, face stream, hex, wedge, pyramid, tetra,
                // polyhedra, inverted, active, collapsed.
                let mut r = [0usize; 11];
                for (i, &code) in cs.iter().enumerate() {
                    if code & CODE_ACTIVE == 0 {
                        continue;
                    }
                    r[9] += 1;
                    if code & 15 != 0 {
                        r[10] += 1;
                    }
                    if !kept(code) {
                        continue;
                    }
                    r[0] += 1;
                    if (code & CODE_NEG != 0) != left {
                        r[8] += 1;
                    }
                    match shape_at(i + nx * row, code).0 {
                        Shape::Typed(t, ids) => {
                            r[1] += ids.len();
                            r[match *t {
                                vtk_type::HEXAHEDRON => 3,
                                vtk_type::WEDGE => 4,
                                vtk_type::PYRAMID => 5,
                                _ => 6,
                            }] += 1;
                        }
                        Shape::Poly(f) => {
                            let mut v: Vec<u8> = f.iter().flatten().copied().collect();
                            v.sort_unstable();
                            v.dedup();
                            r[1] += v.len();
                            r[2] += 1 + f.iter().map(|l| 1 + l.len()).sum::<usize>();
                            r[7] += 1;
                        }
                        Shape::Flat => {}
                    }
                }
                r
            })
            .collect();
        let mut cell_start = Vec::with_capacity(nrows + 1);
        let mut conn_start = Vec::with_capacity(nrows + 1);
        let mut face_start = Vec::with_capacity(nrows + 1);
        let mut acc = [0usize; 11];
        for r in &counts {
            cell_start.push(acc[0]);
            conn_start.push(acc[1]);
            face_start.push(acc[2]);
            for (a, b) in acc.iter_mut().zip(r) {
                *a += b;
            }
        }
        cell_start.push(acc[0]);
        conn_start.push(acc[1]);
        face_start.push(acc[2]);
        drop(counts);
        let kept_cells = acc[0];
        if acc[1] >= u32::MAX as usize || acc[2] >= u32::MAX as usize {
            return Err(CornerPointError::BadDims(self.dims));
        }
        rep.active = acc[9];
        rep.inactive = n - acc[9];
        rep.collapsed = acc[10];
        rep.zero_volume = acc[9] - kept_cells;
        rep.inverted = acc[8];
        (
            rep.hexahedra,
            rep.wedges,
            rep.pyramids,
            rep.tetrahedra,
            rep.polyhedra,
        ) = (acc[3], acc[4], acc[5], acc[6], acc[7]);
        // Pass 3: weld corners per pillar (sorted unique depths of kept
        // cells), in parallel over rows of pillars so that ZCORN is read
        // row by row; per pillar row one vector of its pillars' depths.
        let npx = nx + 1;
        let npil = npx * (ny + 1);
        let row_depths: Vec<(Vec<f64>, Vec<u32>)> = (0..=ny)
            .into_par_iter()
            .map(|pj| {
                // One scratch block of 8·nz depths per pillar (4 cells ×
                // top and bottom per layer), sorted and deduplicated in place.
                let per = 8 * nz;
                let mut scratch = vec![0.0f64; per * npx];
                let mut len = vec![0usize; npx];
                for k in 0..nz {
                    for kk in 0..2 {
                        for (cj, jj) in [(pj.wrapping_sub(1), 1usize), (pj, 0)] {
                            if cj >= ny {
                                continue;
                            }
                            let row = &codes[nx * (cj + ny * k)..][..nx];
                            let z0 = this.zcorn_index(0, cj, k, 2 * jj + 4 * kk);
                            let zrow = &zcorn[z0..z0 + 2 * nx];
                            for (i, &code) in row.iter().enumerate() {
                                if kept(code) {
                                    scratch[per * i + len[i]] = zrow[2 * i];
                                    len[i] += 1;
                                    scratch[per * (i + 1) + len[i + 1]] = zrow[2 * i + 1];
                                    len[i + 1] += 1;
                                }
                            }
                        }
                    }
                }
                let mut flat = Vec::new();
                let mut lens = Vec::with_capacity(npx);
                for (p, &l) in len.iter().enumerate() {
                    let d = &mut scratch[per * p..per * p + l];
                    // Runs in layer order: the stable sort merges them.
                    d.sort_by(|a, b| a.total_cmp(b));
                    let before = flat.len();
                    for &z in d.iter() {
                        if flat.len() == before || flat.last() != Some(&z) {
                            flat.push(z);
                        }
                    }
                    lens.push((flat.len() - before) as u32);
                }
                flat.shrink_to_fit();
                (flat, lens)
            })
            .collect();
        let mut start = Vec::with_capacity(npil + 1);
        let mut nv = 0usize;
        for (_, lens) in &row_depths {
            for &l in lens {
                start.push(nv);
                nv += l as usize;
            }
        }
        start.push(nv);
        if nv >= u32::MAX as usize {
            return Err(CornerPointError::BadDims(self.dims));
        }
        // The depths of pillar `p` (ids `start[p]..start[p + 1]`).
        let depths = |p: usize| -> &[f64] {
            let base = start[p - p % npx];
            &row_depths[p / npx].0[start[p] - base..start[p + 1] - base]
        };
        let vid = |zcorn: &[f64], i: usize, j: usize, k: usize, corner: usize| -> u32 {
            let (pi, pj) = (i + (corner & 1), j + (corner >> 1 & 1));
            let p = pi + npx * pj;
            let base = start[npx * pj];
            let d = &row_depths[pj].0[start[p] - base..start[p + 1] - base];
            let z = zcorn[this.zcorn_index(i, j, k, corner)];
            // Layer k's corners sit near index k·len/(nz+1) of a pillar.
            let guess = (k + (corner >> 2)) * d.len() / (nz + 1);
            (start[p] + search_from(d, z, guess)) as u32
        };
        // Cross-pillar merges: union the coincident vertices (smallest id wins).
        let canon: Option<Vec<u32>> = (!cross_cells.is_empty()).then(|| {
            let mut parent: Vec<u32> = (0..nv as u32).collect();
            for &(c, s) in &cross_cells {
                let (i, j, k) = (c % nx, c / nx % ny, c / (nx * ny));
                let r = &cross_shapes[s].0;
                for q in 0..8 {
                    let (a, b) = (vid(&zcorn, i, j, k, q), vid(&zcorn, i, j, k, r[q] as usize));
                    let (a, b) = (find(&mut parent, a), find(&mut parent, b));
                    parent[a.max(b) as usize] = a.min(b);
                }
            }
            for v in 0..nv as u32 {
                parent[v as usize] = find(&mut parent, v);
            }
            parent
        });
        // Pass 4: cells, deepest layer first, each layer's rows in parallel;
        // ZCORN shrinks behind.
        let mut types = vec![0u8; kept_cells];
        let mut offsets = vec![0u32; kept_cells + 1];
        let mut connectivity = vec![0u32; acc[1]];
        let mut source = vec![0u32; kept_cells];
        let mut face_offsets = if acc[2] > 0 {
            vec![0u32; kept_cells + 1]
        } else {
            Vec::new()
        };
        let mut face_stream = vec![0u32; acc[2]];
        // Per row, per i: the depths (bits) and ids of the top corners of
        // the last kept cell of that column in a deeper layer. A vertex id
        // depends only on the pillar and the depth, so a bottom corner at
        // the same depth on the same pillar reuses it (no search); the
        // NaN bits of the start never match a depth.
        let mut below: Vec<Vec<([u64; 4], [u32; 4])>> = vec![vec![([u64::MAX; 4], [0; 4]); nx]; ny];
        for k in (0..nz).rev() {
            let rs = k * ny..(k + 1) * ny + 1;
            let (c0, c1) = (cell_start[k * ny], cell_start[(k + 1) * ny]);
            let t = split_by(&mut types[c0..c1], &cell_start[rs.clone()]);
            let o = split_by(&mut offsets[c0 + 1..c1 + 1], &cell_start[rs.clone()]);
            let s = split_by(&mut source[c0..c1], &cell_start[rs.clone()]);
            let fo = if face_offsets.is_empty() {
                (0..ny).map(|_| &mut [][..]).collect()
            } else {
                split_by(&mut face_offsets[c0 + 1..c1 + 1], &cell_start[rs.clone()])
            };
            let cn = split_by(
                &mut connectivity[conn_start[k * ny]..conn_start[(k + 1) * ny]],
                &conn_start[rs.clone()],
            );
            let fs = split_by(
                &mut face_stream[face_start[k * ny]..face_start[(k + 1) * ny]],
                &face_start[rs.clone()],
            );
            let jobs: Vec<_> = t
                .into_iter()
                .zip(o)
                .zip(s)
                .zip(fo)
                .zip(cn.into_iter().zip(fs))
                .zip(below.iter_mut())
                .enumerate()
                .collect();
            let zc = &zcorn[..];
            jobs.into_par_iter()
                .for_each(|(j, (((((t, o), s), fo), (cn, fs)), below))| {
                    let row = j + ny * k;
                    let (mut x, mut ce, mut fe) = (0usize, 0usize, 0usize);
                    let mut ids: Vec<u32> = Vec::with_capacity(8);
                    // The previous kept cell of the row: its corner depths
                    // and vertex ids (a corner on the shared pillar at the
                    // same depth is the same vertex).
                    let mut prev: Option<(usize, [f64; 8], [u32; 8])> = None;
                    for i in 0..nx {
                        let c = i + nx * row;
                        let code = codes[c];
                        if !kept(code) {
                            continue;
                        }
                        let (shape, merged) = shape_at(c, code);
                        let z: [f64; 8] = std::array::from_fn(|q| zc[this.zcorn_index(i, j, k, q)]);
                        let (bz, bw) = &mut below[i];
                        let raw: [u32; 8] = std::array::from_fn(|q| match prev {
                            Some((pi, pz, pw))
                                if pi + 1 == i && q & 1 == 0 && pz[q + 1] == z[q] =>
                            {
                                pw[q + 1]
                            }
                            _ if reuse_below && q >= 4 && bz[q - 4] == z[q].to_bits() => bw[q - 4],
                            _ => vid(zc, i, j, k, q),
                        });
                        prev = Some((i, z, raw));
                        (*bz, *bw) = (
                            std::array::from_fn(|q| z[q].to_bits()),
                            std::array::from_fn(|q| raw[q]),
                        );
                        let mut w = raw;
                        if let (Some(cm), true) = (&canon, merged || code & CODE_CROSS == 0) {
                            w = w.map(|v| cm[v as usize]);
                        }
                        match shape {
                            Shape::Typed(ty, local) => {
                                t[x] = *ty;
                                for &l in local {
                                    cn[ce] = w[l as usize];
                                    ce += 1;
                                }
                            }
                            Shape::Poly(f) => {
                                t[x] = vtk_type::POLYHEDRON;
                                ids.clear();
                                ids.extend(f.iter().flatten().map(|&l| w[l as usize]));
                                ids.sort_unstable();
                                ids.dedup();
                                cn[ce..ce + ids.len()].copy_from_slice(&ids);
                                ce += ids.len();
                                fs[fe] = f.len() as u32;
                                fe += 1;
                                for l in f {
                                    fs[fe] = l.len() as u32;
                                    fe += 1;
                                    for &q in l {
                                        fs[fe] = w[q as usize];
                                        fe += 1;
                                    }
                                }
                            }
                            Shape::Flat => unreachable!("flat cells are not kept"),
                        }
                        o[x] = (conn_start[row] + ce) as u32;
                        if !fo.is_empty() {
                            fo[x] = (face_start[row] + fe) as u32;
                        }
                        s[x] = c as u32;
                        x += 1;
                    }
                });
            zcorn.truncate(8 * nx * ny * k);
            if zcorn.capacity() - zcorn.len() >= 1 << 17 {
                zcorn.shrink_to_fit();
            }
        }
        drop(zcorn);
        drop(codes);
        // Points, after ZCORN is gone.
        let mut points = vec![[0.0f64; 3]; nv];
        split_by(&mut points, &start)
            .into_par_iter()
            .enumerate()
            .for_each(|(p, out)| {
                for (o, &z) in out.iter_mut().zip(depths(p)) {
                    *o = Self::apply(&tr, this.on_pillar(p, z));
                }
            });
        drop(row_depths);
        // Vertices merged away: renumber the used ones, keeping their order.
        if canon.is_some() {
            let mut new_id = vec![u32::MAX; nv];
            for &v in &connectivity {
                new_id[v as usize] = 0;
            }
            let mut next = 0u32;
            for (v, id) in new_id.iter_mut().enumerate() {
                if *id == 0 {
                    *id = next;
                    points[next as usize] = points[v];
                    next += 1;
                }
            }
            points.truncate(next as usize);
            points.shrink_to_fit();
            for v in &mut connectivity {
                *v = new_id[*v as usize];
            }
            let mut f = 0;
            while f < face_stream.len() {
                let nf = face_stream[f] as usize;
                f += 1;
                for _ in 0..nf {
                    let len = face_stream[f] as usize;
                    for v in &mut face_stream[f + 1..f + 1 + len] {
                        *v = new_id[*v as usize];
                    }
                    f += 1 + len;
                }
            }
        }
        rep.vertices = points.len();
        // Properties restricted to the kept cells, in place (source ascends).
        let mut cell_data = std::mem::take(&mut self.properties);
        for p in &mut cell_data {
            let k = p.components.max(1);
            p.components = k;
            for (o, &s) in source.iter().enumerate() {
                let s = s as usize;
                p.values.copy_within(s * k..(s + 1) * k, o * k);
            }
            p.values.truncate(source.len() * k);
            p.values.shrink_to_fit();
        }
        rep.source_cell = source;
        let cells = Cells {
            types,
            offsets,
            connectivity,
            face_offsets,
            face_stream,
        };
        Ok((
            Grid {
                points,
                topology: Topology::Unstructured(cells),
                point_data: Vec::new(),
                cell_data,
            },
            rep,
        ))
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
    use super::search_from;

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
