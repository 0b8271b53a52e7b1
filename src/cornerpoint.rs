//! Corner-point (Eclipse) grids: pillars (COORD), corner depths (ZCORN),
//! active flags (ACTNUM), MAPAXES, and their conversion into the crate's
//! zoo [`Grid`] (DESIGN §7). No I/O: the readers in `io::grdecl` and
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
//!   vertex; nothing else is. So cells on the two sides of a fault share no
//!   vertex, and the CGraph sews only faces that match exactly.
//! * Each cell's volume is the exact volume of its trilinear hexahedron
//!   (2×2×2 Gauss quadrature of det J, which is exact: det J has degree ≤ 2
//!   in each parameter).
//! * A cell with collapsed pillar edges (pinch-outs) loses its repeated
//!   corners and becomes what it really is: a wedge (two adjacent edges
//!   collapsed), or a polyhedron for other patterns; faces with fewer than
//!   three distinct corners vanish. Cells of (near) zero volume are dropped.

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
    /// Fewer than four faces or a malformed face: no volume.
    Flat,
}

/// Classifies a cell from which pillar edges are collapsed (bit `p` for
/// pillar corner `p = ii + 2·jj`: the corners `p` and `p + 4` coincide),
/// given the VTK order in use.
fn shape_of(collapsed: u8, order: &[usize; 8]) -> Shape {
    if collapsed == 0 {
        return Shape::Typed(
            vtk_type::HEXAHEDRON,
            order.iter().map(|&c| c as u8).collect(),
        );
    }
    // Representative corner of each corner: the shallower one of a collapsed pair.
    let rep = |c: u8| -> u8 {
        if c >= 4 && collapsed >> (c - 4) & 1 == 1 {
            c - 4
        } else {
            c
        }
    };
    let mut faces: Vec<Vec<u8>> = Vec::new();
    for f in HEXAHEDRON_FACES {
        let mut loop_: Vec<u8> = f.iter().map(|&l| rep(order[l as usize] as u8)).collect();
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
            return Shape::Flat;
        }
        faces.push(loop_);
    }
    if faces.len() < 4 {
        return Shape::Flat;
    }
    let mut verts: Vec<u8> = faces.iter().flatten().copied().collect();
    verts.sort_unstable();
    verts.dedup();
    let tris: Vec<&Vec<u8>> = faces.iter().filter(|f| f.len() == 3).collect();
    let quads: Vec<&Vec<u8>> = faces.iter().filter(|f| f.len() == 4).collect();
    let other = |f: &[&Vec<u8>]| -> Vec<u8> {
        verts
            .iter()
            .copied()
            .filter(|v| !f.iter().any(|x| x.contains(v)))
            .collect()
    };
    let has_edge = |a: u8, b: u8| {
        faces.iter().any(|f| {
            (0..f.len()).any(|i| {
                let (x, y) = (f[i], f[(i + 1) % f.len()]);
                (x == a && y == b) || (x == b && y == a)
            })
        })
    };
    match (verts.len(), tris.len(), quads.len()) {
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
            let apex = other(&[q]);
            Shape::Typed(vtk_type::PYRAMID, vec![q[0], q[3], q[2], q[1], apex[0]])
        }
        (4, 4, 0) => {
            let t = tris[0];
            let apex = other(&[t]);
            Shape::Typed(vtk_type::TETRA, vec![t[0], t[2], t[1], apex[0]])
        }
        (n, _, _) if n <= MAX_META_VERTICES => Shape::Poly(faces),
        _ => Shape::Flat,
    }
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
    /// the output cells) and reports the classes found.
    pub fn to_grid(&self) -> Result<(Grid, CornerPointReport), CornerPointError> {
        self.validate()?;
        let [nx, ny, nz] = self.dims;
        let n = nx * ny * nz;
        // Pass 1 (parallel): signed volume, extent and collapse pattern.
        let tr = self.transform();
        let per_cell: Vec<(f64, f64, u8)> = (0..n)
            .into_par_iter()
            .map(|c| {
                if !self.is_active(c) {
                    return (0.0, 0.0, 0);
                }
                let (i, j, k) = (c % nx, c / nx % ny, c / (nx * ny));
                let corners = self.corners_with(&tr, i, j, k);
                let mut ext = 0.0f64;
                for q in &corners {
                    for a in 0..3 {
                        ext = ext.max((q[a] - corners[0][a]).abs());
                    }
                }
                let mut m = 0u8;
                for p in 0..4 {
                    if self.zcorn[self.zcorn_index(i, j, k, p)]
                        == self.zcorn[self.zcorn_index(i, j, k, p + 4)]
                    {
                        m |= 1 << p;
                    }
                }
                (trilinear_volume(&corners), ext, m)
            })
            .collect();
        let total: f64 = per_cell.iter().map(|x| x.0).sum();
        let left = total <= 0.0;
        let order = if left {
            &VTK_ORDER_LEFT
        } else {
            &VTK_ORDER_RIGHT
        };
        let sign = if left { -1.0 } else { 1.0 };
        // Shapes per collapse pattern (16 patterns).
        let shapes: Vec<Shape> = (0..16u8).map(|m| shape_of(m, order)).collect();
        let mut rep = CornerPointReport {
            cells: n,
            ijk_right_handed_up: !left,
            ..Default::default()
        };
        // Pass 2: classify; keep[c] = collapse pattern + 1 (0 = dropped).
        let mut keep = vec![0u8; n];
        for c in 0..n {
            if !self.is_active(c) {
                rep.inactive += 1;
                continue;
            }
            rep.active += 1;
            let (vol, ext, m) = per_cell[c];
            if m != 0 {
                rep.collapsed += 1;
            }
            let v = vol * sign;
            if matches!(shapes[m as usize], Shape::Flat) || v.abs() <= 1e-12 * ext * ext * ext {
                rep.zero_volume += 1;
                continue;
            }
            if v < 0.0 {
                rep.inverted += 1;
            }
            rep.bulk_volume += v.abs();
            keep[c] = m + 1;
        }
        // Pass 3: weld corners per pillar (sorted unique depths of kept cells).
        let npx = nx + 1;
        let npil = npx * (ny + 1);
        let per_pillar: Vec<Vec<f64>> = (0..npil)
            .into_par_iter()
            .map(|p| {
                let (pi, pj) = (p % npx, p / npx);
                let mut d = Vec::new();
                for (ci, ii) in [(pi.wrapping_sub(1), 1usize), (pi, 0)] {
                    for (cj, jj) in [(pj.wrapping_sub(1), 1usize), (pj, 0)] {
                        if ci >= nx || cj >= ny {
                            continue;
                        }
                        for k in 0..nz {
                            let c = ci + nx * (cj + ny * k);
                            if keep[c] == 0 {
                                continue;
                            }
                            for kk in 0..2 {
                                d.push(
                                    self.zcorn[self.zcorn_index(ci, cj, k, ii + 2 * jj + 4 * kk)],
                                );
                            }
                        }
                    }
                }
                d.sort_unstable_by(|a, b| a.total_cmp(b));
                d.dedup();
                d
            })
            .collect();
        let mut start = Vec::with_capacity(npil + 1);
        let mut acc = 0usize;
        for d in &per_pillar {
            start.push(acc);
            acc += d.len();
        }
        start.push(acc);
        if acc >= u32::MAX as usize {
            return Err(CornerPointError::BadDims(self.dims));
        }
        drop(per_cell);
        let mut points = Vec::with_capacity(acc);
        for (p, d) in per_pillar.iter().enumerate() {
            for &z in d {
                points.push(Self::apply(&tr, self.on_pillar(p, z)));
            }
        }
        rep.vertices = acc;
        let vid = |i: usize, j: usize, k: usize, corner: usize| -> u32 {
            let (ii, jj) = (corner & 1, corner >> 1 & 1);
            let p = self.pillar_index(i + ii, j + jj);
            let z = self.zcorn[self.zcorn_index(i, j, k, corner)];
            let d = &per_pillar[p];
            let l = d.partition_point(|x| x.total_cmp(&z).is_lt());
            (start[p] + l) as u32
        };
        // Pass 4: cells.
        let kept = keep.iter().filter(|&&m| m != 0).count();
        let mut cells = Cells {
            types: Vec::with_capacity(kept),
            offsets: Vec::with_capacity(kept + 1),
            connectivity: Vec::with_capacity(kept * 8),
            ..Default::default()
        };
        cells.offsets.push(0);
        let mut source = Vec::with_capacity(kept);
        let mut ids = Vec::with_capacity(8);
        let mut faces: Vec<Vec<u32>> = Vec::new();
        for c in 0..n {
            if keep[c] == 0 {
                continue;
            }
            let (i, j, k) = (c % nx, c / nx % ny, c / (nx * ny));
            let w: [u32; 8] = std::array::from_fn(|q| vid(i, j, k, q));
            match &shapes[(keep[c] - 1) as usize] {
                Shape::Typed(t, local) => {
                    ids.clear();
                    ids.extend(local.iter().map(|&l| w[l as usize]));
                    cells.push(*t, &ids);
                    match *t {
                        vtk_type::HEXAHEDRON => rep.hexahedra += 1,
                        vtk_type::WEDGE => rep.wedges += 1,
                        vtk_type::PYRAMID => rep.pyramids += 1,
                        _ => rep.tetrahedra += 1,
                    }
                }
                Shape::Poly(f) => {
                    faces.clear();
                    faces.extend(f.iter().map(|l| l.iter().map(|&x| w[x as usize]).collect()));
                    cells.push_polyhedron(&faces);
                    rep.polyhedra += 1;
                }
                // Flat cells were dropped in pass 2.
                Shape::Flat => continue,
            }
            source.push(c as u32);
        }
        let cell_data = self
            .properties
            .iter()
            .map(|p| {
                let k = p.components.max(1);
                let mut v = Vec::with_capacity(source.len() * k);
                for &s in &source {
                    v.extend_from_slice(&p.values[s as usize * k..(s as usize + 1) * k]);
                }
                Property {
                    name: p.name.clone(),
                    components: k,
                    values: v,
                }
            })
            .collect();
        rep.source_cell = source;
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
