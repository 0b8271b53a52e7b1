//! CIEL (circular incident edge lists, Caumon et al. 2005 §4): a half-edge
//! structure for arbitrary polyhedral grids, and its edge-based sweep.
//!
//! # Layout
//!
//! Every live cell owns a contiguous range of half-edges
//! (`cell_start[c]..cell_start[c+1]`), and inside it every face is a
//! contiguous loop, oriented outward. A half-edge takes 10 bytes in three
//! flat arrays (structure of arrays):
//!
//! - `origins` (u32): the global vertex id, with two flag bits
//!   ([`FIRST_IN_FACE`], [`LAST_IN_FACE`]) from which `next_around_face` /
//!   `prev_around_face` are derived (no stored link);
//! - `mate_faces` (i16): the offset from the half-edge to the same edge in
//!   the same cell, in the adjacent face (opposite direction); a cell holds
//!   at most [`MAX_CELL_HALF_EDGES`] half-edges;
//! - `mate_cells` (u32): the same edge and face in the adjacent cell
//!   (opposite direction), [`NONE`] on the border.
//!
//! `next_around_vertex` is derived too: the representatives (one half-edge
//! per *edge* and endpoint: per fan of half-edges linked by
//! `mate_face`/`mate_cell` with origin `v`, the one with the smallest id)
//! are stored per vertex, CSR style (`vertex_start`, `vertex_edges`); the
//! cyclic next of a representative is the following entry of its vertex's
//! list. That is 8 bytes per edge instead of 4 bytes per half-edge.
//!
//! The cell of a half-edge is found from a coarse lookup table (one u32 per
//! 64 half-edges) and a short forward scan of `cell_start`.
//!
//! # Construction (§4.2), linear in the input
//!
//! See `build`: per chunk of cells in parallel, face loops are read,
//! faces with fewer than three vertices, repeated vertices, duplicate faces,
//! open or non-manifold edges are rejected with an error naming the cell and
//! face; faces are oriented consistently by propagation across shared
//! edges, then outward by the sign of the volume; `mate_face` pairs the two
//! half-edges of each cell edge (a sort of the cell's own edges). Across
//! cells, faces are bucketed by their smallest vertex (a counting sort, so
//! no scan around high-valence vertices) and matched by their reversed
//! loops to set `mate_cell`. Last, each fan of half-edges keeps one
//! representative per endpoint in that vertex's cycle.
//!
//! # Sweep
//!
//! Elements are edges `(a, b)` with key(a) < key(b), key = (φ, id). An edge
//! is active at `t` iff φ(a) < t ≤ φ(b). Two FIFO queues carry the active
//! edges from level to level; when the sweep passes a vertex (φ < t) the
//! upward edges around it are pushed. A cell is cut at `t` (`lo < t ≤ hi`)
//! iff one of its edges is active, so the cells around the active edges
//! (reached by `mate_face`/`mate_cell`, each drawn once per level thanks to
//! a step stamp) are exactly the brute-force set. Polygons are traced by
//! turning around the faces; ambiguous faces are decided by
//! [`face_above_connected`] like every other structure.

use thiserror::Error;

use crate::extract::{EmitContext, LevelMesh, face_above_connected, prefetch};
use crate::field::ScalarField;
use crate::grid::{Cells, hex_corner_offsets, vtk_type};
use crate::structures::StructureError;
use crate::structures::polyhedron::{PolyhedronError, parse_faces_into};

mod build;
mod link;
mod sweep;

pub use sweep::{CielSweeper, brute_force, minima};

/// "No half-edge" marker.
pub const NONE: u32 = u32::MAX;
/// Flag bit of an origin: the half-edge is the last of its face loop.
pub const LAST_IN_FACE: u32 = 1 << 31;
/// Flag bit of an origin: the half-edge is the first of its face loop.
pub const FIRST_IN_FACE: u32 = 1 << 30;
/// Mask of the vertex id in an origin.
pub const VERTEX_MASK: u32 = FIRST_IN_FACE - 1;
/// Most half-edges in one cell (`mate_face` is an i16 offset).
pub const MAX_CELL_HALF_EDGES: usize = 1 << 15;
/// Bytes per half-edge: origin (u32), `mate_face` offset (i16), `mate_cell` (u32).
pub const BYTES_PER_HALF_EDGE: usize = 10;
/// log2 of the number of half-edges per entry of the cell lookup table.
pub(crate) const LOOKUP_SHIFT: u32 = 6;
pub use crate::structures::polyhedron::CONVEXITY_TOLERANCE;

/// Bad polyhedral input, naming the cell and face.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum CielError {
    /// The face stream of a polyhedron is malformed.
    #[error("cell {cell}: bad face stream: {why}")]
    FaceStream {
        /// Cell id.
        cell: usize,
        /// What is wrong.
        why: String,
    },
    /// A face with fewer than three vertices.
    #[error("cell {cell}, face {face}: {len} vertices (a face needs at least 3)")]
    ShortFace {
        /// Cell id.
        cell: usize,
        /// Face index within the cell.
        face: usize,
        /// Its vertex count.
        len: usize,
    },
    /// A face that visits a vertex twice.
    #[error("cell {cell}, face {face}: vertex {vertex} appears twice in the face")]
    RepeatedFaceVertex {
        /// Cell id.
        cell: usize,
        /// Face index.
        face: usize,
        /// Vertex id.
        vertex: u32,
    },
    /// Two faces of a cell with the same vertex set.
    #[error("cell {cell}: faces {face} and {other} are duplicates")]
    DuplicateFace {
        /// Cell id.
        cell: usize,
        /// Face index.
        face: usize,
        /// The other face.
        other: usize,
    },
    /// A face edge that no other face of the cell shares.
    #[error("cell {cell}, face {face}: edge {a}-{b} has no mate (open polyhedron)")]
    Open {
        /// Cell id.
        cell: usize,
        /// Face index.
        face: usize,
        /// Edge endpoint.
        a: u32,
        /// Edge endpoint.
        b: u32,
    },
    /// A face edge shared by more than two faces of the cell.
    #[error("cell {cell}, face {face}: edge {a}-{b} is shared by {count} faces (non-manifold)")]
    NonManifoldEdge {
        /// Cell id.
        cell: usize,
        /// Face index.
        face: usize,
        /// Edge endpoint.
        a: u32,
        /// Edge endpoint.
        b: u32,
        /// Number of faces using it.
        count: usize,
    },
    /// Faces that cannot be oriented consistently (non-orientable surface).
    #[error("cell {cell}, face {face}: inconsistent orientation (cannot orient the faces)")]
    Orientation {
        /// Cell id.
        cell: usize,
        /// Face index.
        face: usize,
    },
    /// A face shared by more than two cells, or shared with the same
    /// direction or another vertex order by two cells.
    #[error("cell {cell}, face {face}: {why}")]
    BadSharedFace {
        /// Cell id.
        cell: usize,
        /// Face index.
        face: usize,
        /// What is wrong.
        why: String,
    },
    /// An array of the structure did not fit in memory.
    #[error(transparent)]
    Memory(#[from] crate::mem::AllocError),
    /// Too many vertices or half-edges for the u32 layout.
    #[error("grid too large for CIEL: {0}")]
    TooLarge(String),
    /// Every cell is dead (hidden, degenerate or lower-dimensional).
    #[error("the grid has no volumetric cells")]
    NoCells,
}

impl From<PolyhedronError> for CielError {
    fn from(e: PolyhedronError) -> Self {
        match e {
            PolyhedronError::FaceStream { cell, why } => CielError::FaceStream { cell, why },
            PolyhedronError::ShortFace { cell, face, len } => {
                CielError::ShortFace { cell, face, len }
            }
            PolyhedronError::RepeatedFaceVertex { cell, face, vertex } => {
                CielError::RepeatedFaceVertex { cell, face, vertex }
            }
            PolyhedronError::DuplicateFace { cell, face, other } => {
                CielError::DuplicateFace { cell, face, other }
            }
            PolyhedronError::Open { cell, face, a, b } => CielError::Open { cell, face, a, b },
            PolyhedronError::NonManifoldEdge {
                cell,
                face,
                a,
                b,
                count,
            } => CielError::NonManifoldEdge {
                cell,
                face,
                a,
                b,
                count,
            },
            PolyhedronError::Orientation { cell, face } => CielError::Orientation { cell, face },
        }
    }
}

impl From<CielError> for StructureError {
    fn from(e: CielError) -> Self {
        match e {
            CielError::NoCells => StructureError::NoCells,
            CielError::Memory(e) => StructureError::Memory(e),
            CielError::FaceStream { cell, .. }
            | CielError::ShortFace { cell, .. }
            | CielError::RepeatedFaceVertex { cell, .. }
            | CielError::DuplicateFace { cell, .. }
            | CielError::Open { cell, .. }
            | CielError::NonManifoldEdge { cell, .. }
            | CielError::Orientation { cell, .. }
            | CielError::BadSharedFace { cell, .. } => StructureError::UnsupportedCell {
                cell,
                why: format!("CIEL: {e}"),
            },
            CielError::TooLarge(_) => StructureError::TooLarge { count: usize::MAX },
        }
    }
}

/// Counts gathered while building, reported by `info`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CielCounts {
    /// Faces of live cells.
    pub faces: usize,
    /// Input faces whose orientation was reversed (to make them outward and consistent).
    pub flipped_faces: usize,
    /// Live cells that are not convex (or have non-planar faces), within
    /// [`CONVEXITY_TOLERANCE`].
    pub non_convex: usize,
    /// Half-edges on the grid border (no `mate_cell`).
    pub border_half_edges: usize,
    /// Edges (fans), i.e. representatives in the vertex cycles / 2.
    pub edges: usize,
    /// Counts of cell classes (see [`crate::structures::CELL_CLASS_NAMES`]).
    pub class_counts: [usize; crate::structures::CELL_CLASS_COUNT],
    /// Hidden cells excluded.
    pub hidden: usize,
}

/// The CIEL half-edge structure of a grid.
#[derive(Clone, Debug)]
pub struct Ciel {
    /// f64 origin of the rebased positions.
    pub origin: [f64; 3],
    /// Rebased f32 positions (one per grid point).
    pub positions: Vec<[f32; 3]>,
    /// Per half-edge (grouped by cell, then by face): origin vertex id,
    /// or-ed with [`FIRST_IN_FACE`] / [`LAST_IN_FACE`].
    origins: Vec<u32>,
    /// Per half-edge: offset to its `mate_face`.
    mate_faces: Vec<i16>,
    /// Per half-edge: its `mate_cell` ([`NONE`] on the border).
    mate_cells: Vec<u32>,
    /// Per cell (grid numbering), its first half-edge; `cells + 1` entries.
    /// Dead cells have an empty range.
    pub cell_start: Vec<u32>,
    /// Cell of half-edge `i << LOOKUP_SHIFT`.
    cell_lookup: Vec<u32>,
    /// Per vertex, its range of `vertex_edges` (`vertices + 1` entries).
    vertex_start: Vec<u32>,
    /// Representative half-edges (one per edge and endpoint), grouped by
    /// origin vertex, increasing ids within a vertex.
    vertex_edges: Vec<u32>,
    /// Live cells found non-convex (increasing ids; usually empty).
    non_convex_cells: Vec<u32>,
    /// Build counts.
    pub counts: CielCounts,
}

/// Parses a VTK polyhedron face stream (`nf, n0, ids.., n1, ids..`) into
/// face loops. Never panics: malformed streams are errors naming the cell.
pub fn parse_face_stream(cell: usize, stream: &[u32]) -> Result<Vec<Vec<u32>>, CielError> {
    let (mut ids, mut starts) = (Vec::new(), Vec::new());
    parse_faces_into(cell, stream, &mut ids, &mut starts)?;
    Ok(starts
        .windows(2)
        .map(|w| ids[w[0] as usize..w[1] as usize].to_vec())
        .collect())
}

impl Ciel {
    /// Number of cells (grid numbering, dead cells included).
    pub fn cell_count(&self) -> usize {
        self.cell_start.len() - 1
    }

    /// Cells with half-edges (swept).
    pub fn live_cells(&self) -> usize {
        self.cell_start.windows(2).filter(|w| w[0] < w[1]).count()
    }

    /// Is cell `c` live?
    #[inline]
    pub fn is_live(&self, c: u32) -> bool {
        self.cell_start[c as usize] < self.cell_start[c as usize + 1]
    }

    /// Number of half-edges.
    pub fn half_edge_count(&self) -> usize {
        self.origins.len()
    }

    /// Raw origin word of half-edge `h` (vertex id and face flags).
    #[inline(always)]
    pub fn origin_word(&self, h: u32) -> u32 {
        self.origins[h as usize]
    }

    /// Origin vertex of half-edge `h`.
    #[inline(always)]
    pub fn org(&self, h: u32) -> u32 {
        self.origins[h as usize] & VERTEX_MASK
    }

    /// The next half-edge around `h`'s face (derived from the face flags).
    #[inline(always)]
    pub fn next_around_face(&self, h: u32) -> u32 {
        if self.origins[h as usize] & LAST_IN_FACE == 0 {
            return h + 1;
        }
        let mut x = h;
        while self.origins[x as usize] & FIRST_IN_FACE == 0 {
            x -= 1;
        }
        x
    }

    /// The previous half-edge around `h`'s face.
    #[inline(always)]
    pub fn prev_around_face(&self, h: u32) -> u32 {
        if self.origins[h as usize] & FIRST_IN_FACE == 0 {
            return h - 1;
        }
        let mut x = h;
        while self.origins[x as usize] & LAST_IN_FACE == 0 {
            x += 1;
        }
        x
    }

    /// The same edge of the same cell in the adjacent face (opposite direction).
    #[inline(always)]
    pub fn mate_face(&self, h: u32) -> u32 {
        (h as i32 + self.mate_faces[h as usize] as i32) as u32
    }

    /// The same edge and face in the adjacent cell (opposite direction),
    /// [`NONE`] on the border.
    #[inline(always)]
    pub fn mate_cell(&self, h: u32) -> u32 {
        self.mate_cells[h as usize]
    }

    /// The next representative half-edge around `org(h)` (cyclic), or
    /// [`NONE`] when `h` is not its fan's representative.
    pub fn next_around_vertex(&self, h: u32) -> u32 {
        let list = self.around_vertex(self.org(h));
        match list.iter().position(|&x| x == h) {
            Some(i) => list[(i + 1) % list.len()],
            None => NONE,
        }
    }

    /// The representative half-edges around vertex `v` (origin `v`, one
    /// per edge), in `next_around_vertex` order.
    #[inline(always)]
    pub fn around_vertex(&self, v: u32) -> &[u32] {
        let (a, b) = (
            self.vertex_start[v as usize],
            self.vertex_start[v as usize + 1],
        );
        &self.vertex_edges[a as usize..b as usize]
    }

    /// Destination vertex of half-edge `h`.
    #[inline(always)]
    pub fn dest(&self, h: u32) -> u32 {
        self.org(self.next_around_face(h))
    }

    /// Cell holding half-edge `h`.
    #[inline(always)]
    pub fn cell_of(&self, h: u32) -> u32 {
        let mut c = self.cell_lookup[(h >> LOOKUP_SHIFT) as usize] as usize;
        while self.cell_start[c + 1] <= h {
            c += 1;
        }
        c as u32
    }

    /// Live cells found non-convex by the build (increasing ids), within
    /// [`CONVEXITY_TOLERANCE`].
    pub fn non_convex_cells(&self) -> &[u32] {
        &self.non_convex_cells
    }

    /// Half-edges of cell `c`.
    pub fn cell_half_edges(&self, c: u32) -> std::ops::Range<u32> {
        self.cell_start[c as usize]..self.cell_start[c as usize + 1]
    }

    /// Calls `f` with every half-edge of the fan of `h` (one per cell
    /// around that edge, each once for a manifold fan).
    #[inline(always)]
    pub fn for_each_cell_around_edge(&self, h: u32, mut f: impl FnMut(u32)) {
        let limit = self.origins.len();
        let mut x = h;
        let mut n = 0;
        loop {
            f(x);
            let y = self.mate_cells[self.mate_face(x) as usize];
            n += 1;
            if y == h || n > limit {
                return;
            }
            if y == NONE {
                break;
            }
            x = y;
        }
        // Border: walk the other way from h.
        let mut x = h;
        loop {
            let mc = self.mate_cells[x as usize];
            if mc == NONE || n > limit {
                return;
            }
            x = self.mate_face(mc);
            f(x);
            n += 1;
        }
    }

    /// The face loops of live cell `c` as stored: oriented outward and
    /// consistently (global vertex ids), e.g. to write a repaired grid.
    pub fn faces_of(&self, c: u32) -> Vec<Vec<u32>> {
        let mut out = Vec::new();
        let mut face = Vec::new();
        for h in self.cell_half_edges(c) {
            face.push(self.org(h));
            if self.origins[h as usize] & LAST_IN_FACE != 0 {
                out.push(std::mem::take(&mut face));
            }
        }
        out
    }

    /// Bytes per part of the structure.
    pub fn bytes(&self) -> Vec<(&'static str, usize)> {
        vec![
            ("positions", self.positions.len() * 12),
            ("half_edges", self.origins.len() * BYTES_PER_HALF_EDGE),
            (
                "vertex_edges",
                (self.vertex_start.len() + self.vertex_edges.len()) * 4,
            ),
            ("cell_starts", self.cell_start.len() * 4),
            ("cell_lookup", self.cell_lookup.len() * 4),
            ("non_convex_cells", self.non_convex_cells.len() * 4),
        ]
    }

    /// Volume of live cell `c` (from its rebased positions).
    pub fn cell_volume(&self, c: u32) -> f64 {
        let r = self.cell_half_edges(c);
        if r.is_empty() {
            return 0.0;
        }
        let p = |v: u32| self.positions[v as usize].map(f64::from);
        let p0 = p(self.org(r.start));
        let rel = |v: u32| {
            let q = p(v);
            [q[0] - p0[0], q[1] - p0[1], q[2] - p0[2]]
        };
        let mut vol = 0.0;
        let mut h = r.start;
        while h < r.end {
            // One face: from its first half-edge to the one flagged last.
            let a = rel(self.org(h));
            let mut x = h + 1;
            while self.origins[x as usize] & LAST_IN_FACE == 0 {
                let (b, cc) = (rel(self.org(x)), rel(self.org(x + 1)));
                vol += a[0] * (b[1] * cc[2] - b[2] * cc[1]) - a[1] * (b[0] * cc[2] - b[2] * cc[0])
                    + a[2] * (b[0] * cc[1] - b[1] * cc[0]);
                x += 1;
            }
            h = x + 1;
        }
        vol / 6.0
    }

    /// Volume-weighted average of per-cell values at the vertices (over the
    /// live cells); vertices of no live cell get the mean value.
    pub fn cell_to_vertex(&self, cell_values: &[f64]) -> Vec<f32> {
        let nv = self.positions.len();
        let mut sum = vec![0.0f64; nv];
        let mut wsum = vec![0.0f64; nv];
        let mut verts = Vec::new();
        for c in 0..self.cell_count() as u32 {
            let Some(&val) = cell_values.get(c as usize) else {
                continue;
            };
            if !self.is_live(c) {
                continue;
            }
            let vol = self.cell_volume(c).abs();
            verts.clear();
            verts.extend(self.cell_half_edges(c).map(|h| self.org(h)));
            verts.sort_unstable();
            verts.dedup();
            for &v in &verts {
                sum[v as usize] += vol * val;
                wsum[v as usize] += vol;
            }
        }
        crate::properties::weighted_means(&sum, &wsum, cell_values)
    }

    /// Min and max of φ over the vertices of live cells.
    pub fn live_range<F: ScalarField>(&self, f: &F) -> Option<(f32, f32)> {
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        for (v, w) in self.vertex_start.windows(2).enumerate() {
            if w[0] < w[1] {
                let p = f.phi(v as u32);
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        (lo <= hi).then_some((lo, hi))
    }

    /// Draws the polygons of cell `c` at level `t` into `mesh` (the cell
    /// must be cut: `lo < t ≤ hi`), by turning around its faces, and calls
    /// `crossed(h)` with the entry half-edge `h` of every face the polygons
    /// cross (so `mate_cell(h)` is a cut neighbour). `scratch` is reused.
    #[inline]
    pub fn draw_cell<F: ScalarField>(
        &self,
        lv: &DrawLevel<F>,
        c: u32,
        scratch: &mut DrawScratch,
        mesh: &mut LevelMesh,
        mut crossed: impl FnMut(u32),
    ) {
        let (f, t, ctx) = (lv.f, lv.t, lv.ctx);
        const ABOVE: u8 = 1;
        const USED: u8 = 4;
        let r = self.cell_half_edges(c);
        let n = (r.end - r.start) as usize;
        let he = &self.origins[r.start as usize..r.end as usize];
        let mf = &self.mate_faces[r.start as usize..r.end as usize];
        // The trace reads a few mate_face offsets and (through `crossed`)
        // mate_cell entries of this cell: fetch their lines while the first
        // pass runs.
        for i in (r.start as usize..r.end as usize).step_by(32) {
            prefetch(&self.mate_faces, i);
        }
        for i in (r.start as usize..r.end as usize).step_by(16) {
            prefetch(&self.mate_cells, i);
        }
        mesh.cut_cells += 1;
        let DrawScratch {
            flags,
            wrap,
            loops,
            loop_ends,
            ..
        } = scratch;
        if flags.len() < n {
            flags.resize(n, 0);
            wrap.resize(n, 0);
        }
        let (flags, wrap) = (&mut flags[..n], &mut wrap[..n]);
        // Per half-edge: is its origin above? Per face: its first
        // half-edge, kept at its last half-edge (for next-in-face).
        let mut fs = 0u32;
        for i in 0..n {
            let e = he[i];
            flags[i] = (f.phi(e & VERTEX_MASK) >= t) as u8;
            if e & FIRST_IN_FACE != 0 {
                fs = i as u32;
            }
            if e & LAST_IN_FACE != 0 {
                wrap[i] = fs;
            }
        }
        let next = |i: usize| {
            if he[i] & LAST_IN_FACE == 0 {
                i + 1
            } else {
                wrap[i] as usize
            }
        };
        // Trace the loops first (entry half-edges, from above to below);
        // a face with more than two crossings sends the cell to the
        // general path before anything is emitted.
        loops.clear();
        loop_ends.clear();
        for h in 0..n {
            if flags[h] != ABOVE || flags[next(h)] & ABOVE != 0 {
                continue;
            }
            let mut cur = h;
            loop {
                flags[cur] |= USED;
                loops.push(cur as u32);
                // The exit x (below → above) ends the below arc after cur;
                // the above arc back to cur must hold no other crossing.
                let mut x = next(cur);
                let mut xn = next(x);
                while flags[xn] & ABOVE == 0 {
                    x = xn;
                    xn = next(xn);
                }
                let mut y = xn;
                while y != cur {
                    if flags[y] & ABOVE == 0 {
                        self.draw_cell_general(lv, c, scratch, mesh, &mut crossed);
                        return;
                    }
                    y = next(y);
                }
                let nxt = (x as isize + mf[x] as isize) as usize;
                if nxt == h || loops.len() > n {
                    break;
                }
                cur = nxt;
            }
            loop_ends.push(loops.len() as u32);
        }
        let mut a0 = 0usize;
        for &end in loop_ends.iter() {
            let start = mesh.begin_polygon();
            for (k, &cur) in loops[a0..end as usize].iter().enumerate() {
                let cur = cur as usize;
                crossed(r.start + cur as u32);
                if k > 0 && k.is_multiple_of(32) {
                    // Keeps the weld map within its load limit for long polygons.
                    mesh.reserve_corners(32);
                }
                let (a, b) = (he[cur] & VERTEX_MASK, he[next(cur)] & VERTEX_MASK);
                corner(mesh, (a, f.phi(a)), (b, f.phi(b)), t, ctx);
            }
            mesh.end_polygon(start, c);
            a0 = end as usize;
        }
    }

    /// [`Ciel::draw_cell`] for a level of a planar field, from a known entry
    /// half-edge `seed` of cell `c` (origin above `t`, destination below):
    /// traces the polygon face by face and reads only the faces it crosses,
    /// where [`Ciel::draw_cell`] reads every half-edge of the cell twice. A
    /// convex cell cut by a plane has one polygon, so the traced loop is the
    /// cell's whole cut; a face with more than two crossings (a plane
    /// through a non-planar face) or a seed that is not an entry sends the
    /// cell to the full path. Emits the same polygon, from the same first
    /// corner, as [`Ciel::draw_cell`].
    #[inline]
    pub fn draw_cell_from<F: ScalarField>(
        &self,
        lv: &DrawLevel<F>,
        c: u32,
        seed: u32,
        scratch: &mut DrawScratch,
        mesh: &mut LevelMesh,
        mut crossed: impl FnMut(u32),
    ) {
        let (f, t, ctx) = (lv.f, lv.t, lv.ctx);
        let r = self.cell_half_edges(c);
        let (s, e) = (r.start as usize, r.end as usize);
        let he = &self.origins[s..e];
        let mf = &self.mate_faces[s..e];
        for i in (s..e).step_by(16) {
            prefetch(&self.origins, i);
        }
        for i in (s..e).step_by(32) {
            prefetch(&self.mate_faces, i);
        }
        for i in (s..e).step_by(16) {
            prefetch(&self.mate_cells, i);
        }
        let n = e - s;
        let above = |i: usize| f.phi(he[i] & VERTEX_MASK) >= t;
        // The face of local half-edge `i`: its first and last half-edges.
        let face_of = |i: usize| {
            let (mut a, mut b) = (i, i);
            while he[a] & FIRST_IN_FACE == 0 {
                a -= 1;
            }
            while he[b] & LAST_IN_FACE == 0 {
                b += 1;
            }
            (a, b)
        };
        let h0 = seed.wrapping_sub(r.start) as usize;
        let ok_seed = h0 < n && {
            let (a, b) = face_of(h0);
            above(h0) && !above(if h0 == b { a } else { h0 + 1 })
        };
        if !ok_seed {
            self.draw_cell(lv, c, scratch, mesh, crossed);
            return;
        }
        mesh.cut_cells += 1;
        let DrawScratch { loops, dests, .. } = scratch;
        loops.clear();
        dests.clear();
        let mut cur = h0;
        loop {
            let (a, b) = face_of(cur);
            let next = |i: usize| if i == b { a } else { i + 1 };
            loops.push(cur as u32);
            let d = next(cur);
            dests.push(d as u32);
            // The below arc runs from dest(cur) to the exit x (origin
            // below, destination above); the above arc back to cur must
            // hold no other crossing.
            let mut x = d;
            let mut xn = next(x);
            while !above(xn) {
                x = xn;
                xn = next(xn);
            }
            let mut y = xn;
            while y != cur {
                y = next(y);
                if y != cur && !above(y) {
                    self.draw_cell_general(lv, c, scratch, mesh, &mut crossed);
                    return;
                }
            }
            let nxt = (x as isize + mf[x] as isize) as usize;
            if nxt == h0 {
                break;
            }
            if loops.len() > n {
                self.draw_cell_general(lv, c, scratch, mesh, &mut crossed);
                return;
            }
            cur = nxt;
        }
        // Start at the smallest entry, as the full path does.
        let k0 = (0..loops.len()).min_by_key(|&k| loops[k]).unwrap_or(0);
        let m = loops.len();
        let start = mesh.begin_polygon();
        for j in 0..m {
            let k = (k0 + j) % m;
            let (cur, d) = (loops[k] as usize, dests[k] as usize);
            crossed(r.start + cur as u32);
            if j > 0 && j.is_multiple_of(32) {
                mesh.reserve_corners(32);
            }
            let (va, vb) = (he[cur] & VERTEX_MASK, he[d] & VERTEX_MASK);
            corner(mesh, (va, f.phi(va)), (vb, f.phi(vb)), t, ctx);
        }
        mesh.end_polygon(start, c);
    }

    /// [`Ciel::draw_cell`] for cells with an ambiguous face (more than two
    /// crossings): faces decided by [`face_above_connected`].
    #[cold]
    fn draw_cell_general<F: ScalarField>(
        &self,
        lv: &DrawLevel<F>,
        c: u32,
        scratch: &mut DrawScratch,
        mesh: &mut LevelMesh,
        crossed: &mut impl FnMut(u32),
    ) {
        let (f, t, ctx) = (lv.f, lv.t, lv.ctx);
        let r = self.cell_half_edges(c);
        let n = (r.end - r.start) as usize;
        let he = &self.origins[r.start as usize..r.end as usize];
        let mf = &self.mate_faces[r.start as usize..r.end as usize];
        // Per half-edge (local index): origin φ and the local next in its face.
        let DrawScratch {
            used, phi, next, ..
        } = scratch;
        used.clear();
        used.resize(n, false);
        phi.clear();
        next.clear();
        let mut face_start = 0u32;
        for (i, &e) in he.iter().enumerate() {
            phi.push(f.phi(e & VERTEX_MASK));
            if e & FIRST_IN_FACE != 0 {
                face_start = i as u32;
            }
            next.push(if e & LAST_IN_FACE != 0 {
                face_start
            } else {
                i as u32 + 1
            });
        }
        for h in 0..n {
            if used[h] {
                continue;
            }
            // Entry half-edges go from above to below.
            let (org_above, dst_above) = (phi[h] >= t, phi[next[h] as usize] >= t);
            if !org_above || dst_above {
                continue;
            }
            let start = mesh.begin_polygon();
            let mut cur = h;
            let mut corners = 0usize;
            loop {
                used[cur] = true;
                crossed(r.start + cur as u32);
                let nx = next[cur] as usize;
                let (a, b) = (he[cur] & VERTEX_MASK, he[nx] & VERTEX_MASK);
                if corners > 0 && corners.is_multiple_of(32) {
                    // Keeps the weld map within its load limit for long polygons.
                    mesh.reserve_corners(32);
                }
                corner(mesh, (a, phi[cur]), (b, phi[nx]), t, ctx);
                corners += 1;
                let exit = exit_in_face(he, phi, next, cur, t);
                let nxt = (exit as isize + mf[exit] as isize) as usize;
                if nxt == h || corners > n {
                    break;
                }
                cur = nxt;
            }
            mesh.end_polygon(start, c);
        }
    }
}

/// A level as the CIEL draws its cut cells: the field, the level value and
/// the emission context.
pub struct DrawLevel<'a, F> {
    /// φ.
    pub f: &'a F,
    /// The level.
    pub t: f32,
    /// Positions and attribute of the output.
    pub ctx: &'a EmitContext<'a>,
}

impl DrawScratch {
    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.phi.capacity() * 4
            + self.flags.capacity()
            + (self.wrap.capacity()
                + self.loops.capacity()
                + self.loop_ends.capacity()
                + self.dests.capacity())
                * 4
            + self.used.capacity()
            + self.next.capacity() * 4
    }
}

/// The polygon corner on edge `a`–`b` (vertex ids with their φ),
/// interpolated from the smaller id to the larger, welded by the edge.
#[inline(always)]
fn corner(mesh: &mut LevelMesh, a: (u32, f32), b: (u32, f32), t: f32, ctx: &EmitContext) {
    if a.0 < b.0 {
        mesh.corner(a.0, b.0, a.1, b.1, t, ctx);
    } else {
        mesh.corner(b.0, a.0, b.1, a.1, t, ctx);
    }
}

/// Scratch space of [`Ciel::draw_cell`]: per half-edge of the cell, the
/// origin's φ, side/crossing/used flags, the face start (at last
/// half-edges); the general path's used flags and next-in-face indices.
#[derive(Clone, Debug, Default)]
pub struct DrawScratch {
    phi: Vec<f32>,
    flags: Vec<u8>,
    wrap: Vec<u32>,
    loops: Vec<u32>,
    loop_ends: Vec<u32>,
    dests: Vec<u32>,
    used: Vec<bool>,
    next: Vec<u32>,
}

/// The local half-edge through which the polygon leaves the face of `cur`
/// (an up-crossing half-edge: origin below, destination above; its
/// `mate_face` enters the next face from above to below).
#[inline(always)]
fn exit_in_face(he: &[u32], phi: &[f32], next: &[u32], cur: usize, t: f32) -> usize {
    let above = |i: usize| phi[i] >= t;
    // Walk forward over the below arc to the next up-crossing, counting
    // the face's crossings.
    let mut x = next[cur] as usize;
    let mut prev_above = false; // dest(cur) is below
    let mut first_up = usize::MAX;
    let mut crossings = 1usize;
    loop {
        let xn = next[x] as usize;
        let a_next = above(xn);
        if a_next != prev_above {
            crossings += 1;
            if first_up == usize::MAX {
                first_up = x;
            }
        }
        prev_above = a_next;
        x = xn;
        if x == cur {
            break;
        }
    }
    if crossings <= 2 {
        return first_up;
    }
    // Ambiguous face: decide from the face's own values and ids.
    let mut vals = [0f32; 32];
    let mut gids = [0u32; 32];
    let mut k = 0;
    let mut x = cur;
    loop {
        if k < 32 {
            gids[k] = he[x] & VERTEX_MASK;
            vals[k] = phi[x];
            k += 1;
        }
        x = next[x] as usize;
        if x == cur {
            break;
        }
    }
    if face_above_connected(&vals[..k], &gids[..k], t) {
        // Above arcs connected: cut off the below arc after cur.
        first_up
    } else {
        // Cut off the above arc that ends at org(cur): walk backward to
        // the up-crossing before it.
        let prev = |i: usize| {
            let mut p = i;
            while next[p] as usize != i {
                p = next[p] as usize;
            }
            p
        };
        let mut p = prev(cur);
        while !above(next[p] as usize) || above(p) {
            p = prev(p);
        }
        p
    }
}

/// Structured grids seen as unstructured hexahedra.
fn structured_as_cells(dims: [usize; 3]) -> Cells {
    let [npi, npj, npk] = dims;
    let slab = npi * npj;
    let mut cells = Cells::default();
    for k in 0..npk.saturating_sub(1) {
        for j in 0..npj.saturating_sub(1) {
            for i in 0..npi.saturating_sub(1) {
                let v0 = i + j * npi + k * slab;
                let ids = hex_corner_offsets(npi, slab).map(|o| (v0 + o) as u32);
                cells.push(vtk_type::HEXAHEDRON, &ids);
            }
        }
    }
    cells
}
