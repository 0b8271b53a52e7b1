//! CIEL (circular incident edge lists, Caumon et al. 2005 §4): a half-edge
//! structure for arbitrary polyhedral grids, and its edge-based sweep.
//!
//! # Layout
//!
//! Every live cell owns a contiguous range of half-edges
//! (`cell_start[c]..cell_start[c+1]`), and inside it every face is a
//! contiguous loop, oriented outward. A [`HalfEdge`] is 16 bytes, four u32:
//!
//! - `origin`: the global vertex id, with two flag bits ([`FIRST_IN_FACE`],
//!   [`LAST_IN_FACE`]) from which `next_around_face` / `prev_around_face`
//!   are derived (no stored link);
//! - `mate_face`: the same edge in the same cell, in the adjacent face
//!   (opposite direction);
//! - `mate_cell`: the same edge and face in the adjacent cell (opposite
//!   direction), [`NONE`] on the border;
//! - `next_around_vertex`: on one half-edge per *edge* (per fan of
//!   half-edges linked by `mate_face`/`mate_cell`, with origin `v`), the
//!   next such half-edge around `v`: a cyclic list; [`NONE`] on the others.
//!
//! The cell of a half-edge is found from a coarse lookup table (one u32 per
//! 64 half-edges) and a short forward scan of `cell_start`.
//!
//! # Construction (§4.2), linear in the input
//!
//! Per cell (in parallel): face loops are read, faces with fewer than three
//! vertices, repeated vertices, duplicate faces, open or non-manifold edges
//! are rejected with an error naming the cell and face; faces are oriented
//! consistently by propagation across shared edges, then outward by the sign
//! of the volume; `mate_face` pairs the two half-edges of each cell edge
//! (a sort of the cell's own edges). Across cells, faces are bucketed by
//! their smallest vertex (a counting sort, so no scan around high-valence
//! vertices) and matched by their sorted vertex lists to set `mate_cell`.
//! Last, each fan of half-edges keeps one representative per endpoint in
//! that vertex's `next_around_vertex` cycle.
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

use rayon::prelude::*;
use thiserror::Error;

use crate::extract::{EmitContext, LevelMesh, face_above_connected, intersects};
use crate::field::ScalarField;
use crate::grid::{Cells, Grid, Topology, is_lower_dimensional, vtk_type};
use crate::metacell::{Catalog, VOXEL_TO_HEX, builtin};
use crate::structure::{BitSet, CellClass, StructureError, classify_cell, is_sweepable};
use crate::sweep::LevelStats;

/// "No half-edge" marker.
pub const NONE: u32 = u32::MAX;
/// Flag bit in [`HalfEdge::origin`]: the half-edge is the last of its face loop.
pub const LAST_IN_FACE: u32 = 1 << 31;
/// Flag bit in [`HalfEdge::origin`]: the half-edge is the first of its face loop.
pub const FIRST_IN_FACE: u32 = 1 << 30;
/// Mask of the vertex id in [`HalfEdge::origin`].
pub const VERTEX_MASK: u32 = FIRST_IN_FACE - 1;
/// log2 of the number of half-edges per entry of the cell lookup table.
const LOOKUP_SHIFT: u32 = 6;
/// Relative tolerance of the convexity test (times the cell's extent).
pub const CONVEXITY_TOLERANCE: f64 = 1e-6;

/// One half-edge: 16 bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct HalfEdge {
    /// Origin vertex id, or-ed with [`FIRST_IN_FACE`] / [`LAST_IN_FACE`].
    pub origin: u32,
    /// The same edge of the same cell in the adjacent face.
    pub mate_face: u32,
    /// The same edge and face in the adjacent cell ([`NONE`] on the border).
    pub mate_cell: u32,
    /// Next representative half-edge around the origin vertex, or [`NONE`].
    pub next_around_vertex: u32,
}

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
    /// Too many vertices or half-edges for the u32 layout.
    #[error("grid too large for CIEL: {0}")]
    TooLarge(String),
    /// Every cell is dead (hidden, degenerate or lower-dimensional).
    #[error("the grid has no volumetric cells")]
    NoCells,
}

impl From<CielError> for StructureError {
    fn from(e: CielError) -> Self {
        match e {
            CielError::NoCells => StructureError::NoCells,
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
    /// Counts of cell classes (see [`crate::structure::CELL_CLASS_NAMES`]).
    pub class_counts: [usize; 5],
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
    /// Half-edges, grouped by cell, then by face.
    pub half_edges: Vec<HalfEdge>,
    /// Per cell (grid numbering), its first half-edge; `cells + 1` entries.
    /// Dead cells have an empty range.
    pub cell_start: Vec<u32>,
    /// Cell of half-edge `i << LOOKUP_SHIFT`.
    cell_lookup: Vec<u32>,
    /// Per vertex, one representative half-edge of its cycle ([`NONE`] if isolated).
    pub vertex_edge: Vec<u32>,
    /// Build counts.
    pub counts: CielCounts,
}

/// One cell's oriented face loops, as built in the per-cell phase
/// (shared with [`crate::convex_split`]).
pub(crate) struct CellFaces {
    /// Face loops (global ids), concatenated.
    pub(crate) ids: Vec<u32>,
    /// Face starts into `ids` (faces + 1).
    pub(crate) starts: Vec<u32>,
    /// Local `mate_face` (indices into `ids`).
    mate: Vec<u32>,
    flipped: usize,
    pub(crate) non_convex: bool,
    pub(crate) class: CellClass,
}

impl CellFaces {
    fn dead(class: CellClass) -> Self {
        CellFaces {
            ids: Vec::new(),
            starts: vec![0],
            mate: Vec::new(),
            flipped: 0,
            non_convex: false,
            class,
        }
    }
}

/// Parses a VTK polyhedron face stream (`nf, n0, ids.., n1, ids..`) into
/// face loops. Never panics: malformed streams are errors naming the cell.
pub fn parse_face_stream(cell: usize, stream: &[u32]) -> Result<Vec<Vec<u32>>, CielError> {
    let err = |why: String| CielError::FaceStream { cell, why };
    let nf = *stream
        .first()
        .ok_or_else(|| err("empty face stream".into()))? as usize;
    if nf > stream.len() {
        return Err(err(format!(
            "{nf} faces announced in a stream of {} values",
            stream.len()
        )));
    }
    let mut faces = Vec::with_capacity(nf);
    let mut p = 1usize;
    for f in 0..nf {
        let n = *stream
            .get(p)
            .ok_or_else(|| err(format!("face {f} missing")))? as usize;
        let ids = stream
            .get(p + 1..p.saturating_add(1).saturating_add(n))
            .ok_or_else(|| err(format!("face {f} truncated ({n} vertices announced)")))?;
        faces.push(ids.to_vec());
        p += 1 + n;
    }
    if p != stream.len() {
        return Err(err(format!(
            "{} trailing values after {nf} faces",
            stream.len() - p
        )));
    }
    Ok(faces)
}

/// Orients and checks the faces of one cell (see the module docs).
pub(crate) fn build_cell(
    cell: usize,
    faces: Vec<Vec<u32>>,
    points: &[[f64; 3]],
) -> Result<CellFaces, CielError> {
    // Shape checks.
    for (f, face) in faces.iter().enumerate() {
        if face.len() < 3 {
            return Err(CielError::ShortFace {
                cell,
                face: f,
                len: face.len(),
            });
        }
        let mut s = face.clone();
        s.sort_unstable();
        if let Some(w) = s.windows(2).find(|w| w[0] == w[1]) {
            return Err(CielError::RepeatedFaceVertex {
                cell,
                face: f,
                vertex: w[0],
            });
        }
    }
    // Duplicate faces: sorted vertex lists.
    let mut sorted: Vec<(Vec<u32>, usize)> = faces
        .iter()
        .enumerate()
        .map(|(f, face)| {
            let mut s = face.clone();
            s.sort_unstable();
            (s, f)
        })
        .collect();
    sorted.sort_unstable();
    if let Some(w) = sorted.windows(2).find(|w| w[0].0 == w[1].0) {
        return Err(CielError::DuplicateFace {
            cell,
            face: w[0].1.min(w[1].1),
            other: w[0].1.max(w[1].1),
        });
    }
    // Edges: (min, max, half-edge, forward?) sorted; each key exactly twice.
    let edge_list = |faces: &[Vec<u32>]| {
        let mut e: Vec<(u32, u32, u32, u32)> = Vec::new();
        let mut base = 0u32;
        for face in faces {
            for i in 0..face.len() {
                let (a, b) = (face[i], face[(i + 1) % face.len()]);
                e.push((a.min(b), a.max(b), base + i as u32, (a < b) as u32));
            }
            base += face.len() as u32;
        }
        e.sort_unstable();
        e
    };
    let face_of_he = |faces: &[Vec<u32>], mut h: u32| -> usize {
        for (f, face) in faces.iter().enumerate() {
            if (h as usize) < face.len() {
                return f;
            }
            h -= face.len() as u32;
        }
        0
    };
    let edges = edge_list(&faces);
    let mut i = 0;
    let mut pairs: Vec<(u32, u32, bool)> = Vec::with_capacity(edges.len() / 2);
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 && edges[j].1 == edges[i].1 {
            j += 1;
        }
        let (a, b) = (edges[i].0, edges[i].1);
        let face = face_of_he(&faces, edges[i].2);
        match j - i {
            1 => return Err(CielError::Open { cell, face, a, b }),
            2 => pairs.push((edges[i].2, edges[i + 1].2, edges[i].3 == edges[i + 1].3)),
            count => {
                return Err(CielError::NonManifoldEdge {
                    cell,
                    face,
                    a,
                    b,
                    count,
                });
            }
        }
        i = j;
    }
    // Orientation by propagation: flip[g] = flip[f] xor same_direction.
    let nf = faces.len();
    let mut he_face = Vec::with_capacity(edges.len());
    for (f, face) in faces.iter().enumerate() {
        he_face.extend(std::iter::repeat_n(f as u32, face.len()));
    }
    let mut adj: Vec<Vec<(u32, bool)>> = vec![Vec::new(); nf];
    for &(h1, h2, same) in &pairs {
        let (f1, f2) = (he_face[h1 as usize], he_face[h2 as usize]);
        adj[f1 as usize].push((f2, same));
        adj[f2 as usize].push((f1, same));
    }
    let mut flip: Vec<Option<bool>> = vec![None; nf];
    let mut stack = Vec::new();
    for root in 0..nf {
        if flip[root].is_some() {
            continue;
        }
        flip[root] = Some(false);
        stack.push(root);
        while let Some(f) = stack.pop() {
            let ff = flip[f].unwrap_or(false);
            for &(g, same) in &adj[f] {
                let want = ff ^ same;
                match flip[g as usize] {
                    None => {
                        flip[g as usize] = Some(want);
                        stack.push(g as usize);
                    }
                    Some(x) if x != want => {
                        return Err(CielError::Orientation {
                            cell,
                            face: (g as usize).max(f),
                        });
                    }
                    _ => {}
                }
            }
        }
    }
    let mut faces = faces;
    for (f, face) in faces.iter_mut().enumerate() {
        if flip[f] == Some(true) {
            face.reverse();
        }
    }
    // Outward: the signed volume must be positive.
    let mut verts: Vec<u32> = faces.iter().flatten().copied().collect();
    verts.sort_unstable();
    verts.dedup();
    let p0 = points[verts[0] as usize];
    let rel = |v: u32| {
        let p = points[v as usize];
        [p[0] - p0[0], p[1] - p0[1], p[2] - p0[2]]
    };
    let mut vol = 0.0;
    for face in &faces {
        let a = rel(face[0]);
        for i in 1..face.len() - 1 {
            let (b, c) = (rel(face[i]), rel(face[i + 1]));
            vol += a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]);
        }
    }
    vol /= 6.0;
    let mut ext = 0.0f64;
    for &v in &verts {
        let p = rel(v);
        ext = ext.max(p[0].abs()).max(p[1].abs()).max(p[2].abs());
    }
    // Repeated positions (distinct ids at the same point): dead, as in the CGraph.
    let mut by_pos: Vec<[u64; 3]> = verts
        .iter()
        .map(|&v| points[v as usize].map(f64::to_bits))
        .collect();
    by_pos.sort_unstable();
    if by_pos.windows(2).any(|w| w[0] == w[1]) {
        return Ok(CellFaces::dead(CellClass::RepeatedVertex));
    }
    if vol.is_nan() || vol.abs() <= 1e-12 * ext * ext * ext {
        return Ok(CellFaces::dead(CellClass::ZeroVolume));
    }
    let mut flipped = flip.iter().filter(|f| **f == Some(true)).count();
    if vol < 0.0 {
        for face in faces.iter_mut() {
            face.reverse();
        }
        flipped = nf - flipped;
    }
    // Convexity: every vertex on the inner side of every face plane.
    let non_convex = !crate::convex_split::is_convex(&faces, &verts, rel, ext);
    // Final loops and mate_face.
    let mut ids = Vec::with_capacity(edges.len());
    let mut starts = Vec::with_capacity(nf + 1);
    starts.push(0u32);
    for face in &faces {
        ids.extend_from_slice(face);
        starts.push(ids.len() as u32);
    }
    let edges = edge_list(&faces);
    let mut mate = vec![NONE; ids.len()];
    for w in edges.chunks_exact(2) {
        if w[0].3 == w[1].3 {
            // Cannot happen after propagation; reported rather than trusted.
            return Err(CielError::Orientation {
                cell,
                face: face_of_he(&faces, w[1].2),
            });
        }
        mate[w[0].2 as usize] = w[1].2;
        mate[w[1].2 as usize] = w[0].2;
    }
    Ok(CellFaces {
        ids,
        starts,
        mate,
        flipped,
        non_convex,
        class: CellClass::Valid,
    })
}

/// Face loops (global ids) of cell `c`, or its class when it is not volumetric.
fn cell_faces(
    cells: &Cells,
    c: usize,
    catalog: &Catalog,
    prisms: &[(u8, u16)],
    points: &[[f64; 3]],
) -> Result<Result<Vec<Vec<u32>>, CellClass>, CielError> {
    let t = cells.types[c];
    if is_lower_dimensional(t) {
        return Ok(Err(CellClass::NonVolumetric));
    }
    if t == vtk_type::POLYHEDRON {
        return parse_face_stream(c, cells.faces_of(c)).map(Ok);
    }
    let ids = cells.cell(c);
    let meta = match t {
        vtk_type::TETRA => builtin::TETRA,
        vtk_type::PYRAMID => builtin::PYRAMID,
        vtk_type::WEDGE => builtin::WEDGE,
        vtk_type::HEXAHEDRON | vtk_type::VOXEL => builtin::HEXAHEDRON,
        _ => match prisms.iter().find(|p| p.0 == t) {
            Some(p) => p.1,
            None => {
                return Err(CielError::FaceStream {
                    cell: c,
                    why: format!("unsupported VTK cell type {t}"),
                });
            }
        },
    };
    let m = catalog.get(meta);
    let local: Vec<u32> = if t == vtk_type::VOXEL {
        if ids.len() != 8 {
            return Err(CielError::FaceStream {
                cell: c,
                why: "voxel without 8 vertices".into(),
            });
        }
        VOXEL_TO_HEX.iter().map(|&i| ids[i]).collect()
    } else {
        ids.to_vec()
    };
    if local.len() != m.nv {
        return Err(CielError::FaceStream {
            cell: c,
            why: format!(
                "{} vertices for a cell of type {t} ({} expected)",
                local.len(),
                m.nv
            ),
        });
    }
    // Typed cells: classified exactly as the CGraph does.
    let class = classify_cell(m, &local, points);
    if !is_sweepable(class) {
        return Ok(Err(class));
    }
    Ok(Ok(m
        .faces
        .iter()
        .map(|f| f.iter().map(|&l| local[l as usize]).collect())
        .collect()))
}

/// Fingerprint of a sorted vertex list.
fn fingerprint(sorted: &[u32]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for &v in sorted {
        h = (h ^ v as u64).wrapping_mul(0x0000_0100_0000_01b3);
        h ^= h >> 29;
    }
    h ^ sorted.len() as u64
}

impl Ciel {
    /// Builds the CIEL of a grid (structured grids become hexahedra).
    /// `hidden` marks cells to exclude.
    pub fn build(grid: &Grid, hidden: Option<&[bool]>) -> Result<Self, CielError> {
        let points = &grid.points;
        let np = points.len();
        if np >= VERTEX_MASK as usize {
            return Err(CielError::TooLarge(format!("{np} vertices")));
        }
        let mut catalog = Catalog::new();
        let prisms: Vec<(u8, u16)> = [vtk_type::PENTAGONAL_PRISM, vtk_type::HEXAGONAL_PRISM]
            .iter()
            .filter_map(|&t| catalog.for_vtk_type(t).map(|m| (t, m)))
            .collect();
        let structured_cells;
        let cells = match &grid.topology {
            Topology::Unstructured(c) => c,
            Topology::Structured { dims } => {
                structured_cells = structured_as_cells(*dims);
                &structured_cells
            }
        };
        let n = cells.len();
        let is_hidden = |c: usize| hidden.is_some_and(|h| h.get(c).copied().unwrap_or(false));
        let per_cell: Vec<CellFaces> = (0..n)
            .into_par_iter()
            .map(|c| {
                let faces = match cell_faces(cells, c, &catalog, &prisms, points)? {
                    Ok(f) => f,
                    Err(class) => return Ok(CellFaces::dead(class)),
                };
                let mut cf = build_cell(c, faces, points)?;
                if is_hidden(c) && is_sweepable(cf.class) {
                    // Checked like any cell, then left out of the structure.
                    cf.ids.clear();
                    cf.starts.truncate(1);
                    cf.mate.clear();
                    cf.non_convex = false;
                    cf.flipped = 0;
                }
                Ok(cf)
            })
            .collect::<Result<_, CielError>>()?;
        let mut counts = CielCounts::default();
        let total: usize = per_cell.iter().map(|c| c.ids.len()).sum();
        if total >= (1usize << 31) - 1 {
            return Err(CielError::TooLarge(format!("{total} half-edges")));
        }
        if total == 0 {
            return Err(CielError::NoCells);
        }
        // Concatenate: half-edges, cell starts, faces (transient).
        let mut half_edges = Vec::with_capacity(total);
        let mut cell_start = Vec::with_capacity(n + 1);
        let mut face_start: Vec<u32> = Vec::new();
        let mut face_cell: Vec<u32> = Vec::new();
        let mut face_local: Vec<u32> = Vec::new();
        for (c, cf) in per_cell.iter().enumerate() {
            let base = half_edges.len() as u32;
            cell_start.push(base);
            counts.class_counts[cf.class as usize] += 1;
            if is_sweepable(cf.class) && is_hidden(c) {
                counts.hidden += 1;
            }
            counts.flipped_faces += cf.flipped;
            counts.non_convex += cf.non_convex as usize;
            for (f, w) in cf.starts.windows(2).enumerate() {
                face_start.push(base + w[0]);
                face_cell.push(c as u32);
                face_local.push(f as u32);
                for i in w[0]..w[1] {
                    let mut origin = cf.ids[i as usize];
                    if i == w[0] {
                        origin |= FIRST_IN_FACE;
                    }
                    if i + 1 == w[1] {
                        origin |= LAST_IN_FACE;
                    }
                    half_edges.push(HalfEdge {
                        origin,
                        mate_face: base + cf.mate[i as usize],
                        mate_cell: NONE,
                        next_around_vertex: NONE,
                    });
                }
            }
        }
        cell_start.push(half_edges.len() as u32);
        drop(per_cell);
        let nfaces = face_start.len();
        face_start.push(half_edges.len() as u32);
        counts.faces = nfaces;
        // mate_cell: faces bucketed by their smallest vertex (counting sort).
        let org = |h: u32| half_edges[h as usize].origin & VERTEX_MASK;
        let face_min = |f: usize| {
            (face_start[f]..face_start[f + 1])
                .map(org)
                .min()
                .unwrap_or(0)
        };
        let mins: Vec<u32> = (0..nfaces).map(face_min).collect();
        let mut bstart = vec![0u32; np + 1];
        for &m in &mins {
            bstart[m as usize + 1] += 1;
        }
        for i in 0..np {
            bstart[i + 1] += bstart[i];
        }
        let mut fill = bstart.clone();
        let mut bucket = vec![0u32; nfaces];
        for (f, &m) in mins.iter().enumerate() {
            bucket[fill[m as usize] as usize] = f as u32;
            fill[m as usize] += 1;
        }
        drop(fill);
        drop(mins);
        let sorted_ids = |f: u32, out: &mut Vec<u32>| {
            out.clear();
            out.extend((face_start[f as usize]..face_start[f as usize + 1]).map(org));
            out.sort_unstable();
        };
        let mut links: Vec<(u32, u32)> = Vec::new();
        let mut keyed: Vec<(u64, u32)> = Vec::new();
        let (mut sa, mut sb) = (Vec::new(), Vec::new());
        let bad = |f: u32, why: String| CielError::BadSharedFace {
            cell: face_cell[f as usize] as usize,
            face: face_local[f as usize] as usize,
            why,
        };
        for v in 0..np {
            let b = &bucket[bstart[v] as usize..bstart[v + 1] as usize];
            if b.len() < 2 {
                continue;
            }
            keyed.clear();
            for &f in b {
                sorted_ids(f, &mut sa);
                keyed.push((fingerprint(&sa), f));
            }
            keyed.sort_unstable();
            let mut i = 0;
            while i < keyed.len() {
                let mut j = i + 1;
                sorted_ids(keyed[i].1, &mut sa);
                while j < keyed.len() && keyed[j].0 == keyed[i].0 {
                    sorted_ids(keyed[j].1, &mut sb);
                    if sa != sb {
                        break;
                    }
                    j += 1;
                }
                match j - i {
                    1 => {}
                    2 => links.push((keyed[i].1, keyed[i + 1].1)),
                    k => {
                        return Err(bad(keyed[i].1, format!("face shared by {k} cells")));
                    }
                }
                i = j;
            }
        }
        drop(bucket);
        drop(bstart);
        let mut mates: Vec<(u32, u32)> = Vec::with_capacity(total / 2);
        for (f, g) in links {
            let (fs, fe) = (face_start[f as usize], face_start[f as usize + 1]);
            let (gs, ge) = (face_start[g as usize], face_start[g as usize + 1]);
            let len = fe - fs;
            if face_cell[f as usize] == face_cell[g as usize] {
                return Err(CielError::DuplicateFace {
                    cell: face_cell[f as usize] as usize,
                    face: face_local[f as usize] as usize,
                    other: face_local[g as usize] as usize,
                });
            }
            let v0 = org(fs);
            let Some(j0) = (gs..ge).position(|h| org(h) == v0) else {
                return Err(bad(f, "shared face mismatch".into()));
            };
            let j0 = j0 as u32;
            // Reversed: g[j0 - i] == f[i]; half-edge f_i (f[i] → f[i+1]) mates
            // g's half-edge from f[i+1] to f[i], at position j0 - i - 1.
            for i in 0..len {
                let gi = gs + (j0 + 2 * len - i - 1) % len;
                let fi = fs + i;
                let fnext = org(fs + (i + 1) % len);
                let gnext = org(gs + (j0 + 2 * len - i) % len);
                if org(gi) != fnext || gnext != org(fi) {
                    return Err(bad(
                        f,
                        format!(
                            "shared with cell {} (face {}) in the same direction or another vertex order",
                            face_cell[g as usize], face_local[g as usize]
                        ),
                    ));
                }
                mates.push((fi, gi));
            }
        }
        for (fi, gi) in mates {
            half_edges[fi as usize].mate_cell = gi;
            half_edges[gi as usize].mate_cell = fi;
        }
        drop(face_start);
        drop(face_cell);
        drop(face_local);
        counts.border_half_edges = half_edges.iter().filter(|h| h.mate_cell == NONE).count();
        // next_around_vertex: one representative per fan and endpoint.
        let mut seen = BitSet::new(total);
        let mut vertex_edge = vec![NONE; np];
        let mut tail = vec![NONE; np];
        let mut reps = 0usize;
        for h in 0..total as u32 {
            if seen.get(h as usize) {
                continue;
            }
            // σ(x) = mate_cell(mate_face(x)) keeps the origin; walk both ways.
            seen.set(h as usize);
            let mut x = h;
            let mut guard = 0usize;
            loop {
                let y = half_edges[half_edges[x as usize].mate_face as usize].mate_cell;
                if y == NONE || y == h || guard > total {
                    break;
                }
                seen.set(y as usize);
                x = y;
                guard += 1;
            }
            let mut x = h;
            loop {
                let mc = half_edges[x as usize].mate_cell;
                if mc == NONE || guard > total {
                    break;
                }
                let y = half_edges[mc as usize].mate_face;
                if y == h || seen.get(y as usize) {
                    break;
                }
                seen.set(y as usize);
                x = y;
                guard += 1;
            }
            let v = (half_edges[h as usize].origin & VERTEX_MASK) as usize;
            half_edges[h as usize].next_around_vertex = vertex_edge[v];
            if tail[v] == NONE {
                tail[v] = h;
            }
            vertex_edge[v] = h;
            reps += 1;
        }
        for v in 0..np {
            if tail[v] != NONE {
                half_edges[tail[v] as usize].next_around_vertex = vertex_edge[v];
            }
        }
        drop(tail);
        counts.edges = reps / 2;
        let mut cell_lookup = Vec::with_capacity((total >> LOOKUP_SHIFT) + 1);
        let mut c = 0usize;
        for b in 0..=((total - 1) >> LOOKUP_SHIFT) {
            let h = (b << LOOKUP_SHIFT) as u32;
            while cell_start[c + 1] <= h {
                c += 1;
            }
            cell_lookup.push(c as u32);
        }
        Ok(Ciel {
            origin: grid.origin(),
            positions: grid.rebased_positions(),
            half_edges,
            cell_start,
            cell_lookup,
            vertex_edge,
            counts,
        })
    }

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

    /// Origin vertex of half-edge `h`.
    #[inline(always)]
    pub fn org(&self, h: u32) -> u32 {
        self.half_edges[h as usize].origin & VERTEX_MASK
    }

    /// The next half-edge around `h`'s face (derived from the face flags).
    #[inline(always)]
    pub fn next_around_face(&self, h: u32) -> u32 {
        if self.half_edges[h as usize].origin & LAST_IN_FACE == 0 {
            return h + 1;
        }
        let mut x = h;
        while self.half_edges[x as usize].origin & FIRST_IN_FACE == 0 {
            x -= 1;
        }
        x
    }

    /// The previous half-edge around `h`'s face.
    #[inline(always)]
    pub fn prev_around_face(&self, h: u32) -> u32 {
        if self.half_edges[h as usize].origin & FIRST_IN_FACE == 0 {
            return h - 1;
        }
        let mut x = h;
        while self.half_edges[x as usize].origin & LAST_IN_FACE == 0 {
            x += 1;
        }
        x
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

    /// Half-edges of cell `c`.
    pub fn cell_half_edges(&self, c: u32) -> std::ops::Range<u32> {
        self.cell_start[c as usize]..self.cell_start[c as usize + 1]
    }

    /// Calls `f` with the representative half-edges around vertex `v`
    /// (origin `v`, one per edge), following `next_around_vertex`.
    #[inline(always)]
    pub fn for_each_around_vertex(&self, v: u32, mut f: impl FnMut(u32)) {
        let h0 = self.vertex_edge[v as usize];
        if h0 == NONE {
            return;
        }
        let mut h = h0;
        let mut guard = 0;
        loop {
            f(h);
            h = self.half_edges[h as usize].next_around_vertex;
            guard += 1;
            if h == h0 || h == NONE || guard > self.half_edges.len() {
                break;
            }
        }
    }

    /// Calls `f` with the cell of every half-edge of the fan of `h` (all
    /// cells around that edge, each once for a manifold fan).
    #[inline(always)]
    pub fn for_each_cell_around_edge(&self, h: u32, mut f: impl FnMut(u32)) {
        let he = &self.half_edges;
        let limit = he.len();
        let mut x = h;
        let mut n = 0;
        loop {
            f(x);
            let y = he[he[x as usize].mate_face as usize].mate_cell;
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
            let mc = he[x as usize].mate_cell;
            if mc == NONE || n > limit {
                return;
            }
            x = he[mc as usize].mate_face;
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
            if self.half_edges[h as usize].origin & LAST_IN_FACE != 0 {
                out.push(std::mem::take(&mut face));
            }
        }
        out
    }

    /// Bytes per part of the structure.
    pub fn bytes(&self) -> Vec<(&'static str, usize)> {
        vec![
            ("positions", self.positions.len() * 12),
            (
                "half_edges",
                self.half_edges.len() * std::mem::size_of::<HalfEdge>(),
            ),
            ("vertex_edges", self.vertex_edge.len() * 4),
            ("cell_starts", self.cell_start.len() * 4),
            ("cell_lookup", self.cell_lookup.len() * 4),
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
            while self.half_edges[x as usize].origin & LAST_IN_FACE == 0 {
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
        let mean = cell_values.iter().sum::<f64>() / cell_values.len().max(1) as f64;
        sum.iter()
            .zip(&wsum)
            .map(|(&s, &w)| if w > 0.0 { (s / w) as f32 } else { mean as f32 })
            .collect()
    }

    /// Min and max of φ over the vertices of live cells.
    pub fn live_range<F: ScalarField>(&self, f: &F) -> Option<(f32, f32)> {
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        for (v, &h) in self.vertex_edge.iter().enumerate() {
            if h != NONE {
                let p = f.phi(v as u32);
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        (lo <= hi).then_some((lo, hi))
    }

    /// Draws the polygons of cell `c` at level `t` into `mesh` (the cell
    /// must be cut: `lo < t ≤ hi`), by turning around its faces.
    /// `scratch` is reused across calls.
    #[inline]
    pub fn draw_cell<F: ScalarField>(
        &self,
        f: &F,
        c: u32,
        t: f32,
        ctx: &EmitContext,
        scratch: &mut DrawScratch,
        mesh: &mut LevelMesh,
    ) {
        let r = self.cell_half_edges(c);
        let s = r.start;
        let n = (r.end - r.start) as usize;
        let he = &self.half_edges[r.start as usize..r.end as usize];
        // Per half-edge (local index): origin φ and the local next in its face.
        let DrawScratch { used, phi, next } = scratch;
        used.clear();
        used.resize(n, false);
        phi.clear();
        next.clear();
        let mut face_start = 0u32;
        for (i, e) in he.iter().enumerate() {
            phi.push(f.phi(e.origin & VERTEX_MASK));
            if e.origin & FIRST_IN_FACE != 0 {
                face_start = i as u32;
            }
            next.push(if e.origin & LAST_IN_FACE != 0 {
                face_start
            } else {
                i as u32 + 1
            });
        }
        mesh.cut_cells += 1;
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
                let nx = next[cur] as usize;
                let (a, b) = (he[cur].origin & VERTEX_MASK, he[nx].origin & VERTEX_MASK);
                if corners > 0 && corners.is_multiple_of(32) {
                    // Keeps the weld map within its load limit for long polygons.
                    mesh.reserve_corners(32);
                }
                let (fa, fb) = (phi[cur], phi[nx]);
                if a < b {
                    mesh.corner(a, b, fa, fb, t, ctx);
                } else {
                    mesh.corner(b, a, fb, fa, t, ctx);
                }
                corners += 1;
                let exit = exit_in_face(he, phi, next, cur, t);
                let nxt = (he[exit].mate_face - s) as usize;
                if nxt == h || corners > n {
                    break;
                }
                cur = nxt;
            }
            mesh.end_polygon(start, c);
        }
    }
}

/// Scratch space of [`Ciel::draw_cell`]: per half-edge of the cell, a
/// used flag, the origin's φ and the local next-in-face index.
#[derive(Clone, Debug, Default)]
pub struct DrawScratch {
    used: Vec<bool>,
    phi: Vec<f32>,
    next: Vec<u32>,
}

/// The local half-edge through which the polygon leaves the face of `cur`
/// (an up-crossing half-edge: origin below, destination above; its
/// `mate_face` enters the next face from above to below).
#[inline(always)]
fn exit_in_face(he: &[HalfEdge], phi: &[f32], next: &[u32], cur: usize, t: f32) -> usize {
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
            gids[k] = he[x].origin & VERTEX_MASK;
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
                let ids = [
                    0,
                    1,
                    1 + npi,
                    npi,
                    slab,
                    slab + 1,
                    slab + 1 + npi,
                    slab + npi,
                ]
                .map(|o| (v0 + o) as u32);
                cells.push(vtk_type::HEXAHEDRON, &ids);
            }
        }
    }
    cells
}

/// Is vertex `a`'s key `(φ, id)` below `b`'s?
#[inline(always)]
fn key_below(fa: f32, a: u32, fb: f32, b: u32) -> bool {
    fa < fb || (fa == fb && a < b)
}

/// Sweep state over a [`Ciel`]: the two edge queues, vertex and cell stamps, minima.
pub struct CielSweeper<'c> {
    ciel: &'c Ciel,
    /// Per cell: the last level stamp it was drawn at.
    cell_stamp: Vec<u32>,
    /// Vertices passed in this sweep.
    passed: BitSet,
    work: Vec<u32>,
    active: Vec<u32>,
    minima: Vec<u32>,
    scratch: DrawScratch,
    stamp: u32,
}

impl<'c> CielSweeper<'c> {
    /// New sweep state for `ciel`.
    pub fn new(ciel: &'c Ciel) -> Self {
        CielSweeper {
            ciel,
            cell_stamp: vec![0; ciel.cell_count()],
            passed: BitSet::new(ciel.positions.len()),
            work: Vec::new(),
            active: Vec::new(),
            minima: Vec::new(),
            scratch: DrawScratch::default(),
            stamp: 0,
        }
    }

    /// Finds the minima (vertices with no lower neighbour, by key (φ, id)),
    /// sorted by key; returns their count.
    pub fn prepare_minima<F: ScalarField>(&mut self, f: &F) -> usize {
        let c = self.ciel;
        let mut m: Vec<u32> = (0..c.positions.len() as u32)
            .into_par_iter()
            .filter(|&v| {
                if c.vertex_edge[v as usize] == NONE {
                    return false;
                }
                let fv = f.phi(v);
                let mut min = true;
                c.for_each_around_vertex(v, |h| {
                    let w = c.dest(h);
                    if key_below(f.phi(w), w, fv, v) {
                        min = false;
                    }
                });
                min
            })
            .collect();
        m.sort_unstable_by(|&a, &b| f.phi(a).total_cmp(&f.phi(b)).then(a.cmp(&b)));
        self.minima = m;
        self.minima.len()
    }

    /// Bytes of sweep state.
    pub fn state_bytes(&self) -> usize {
        self.cell_stamp.len() * 4
            + self.passed.bytes()
            + (self.work.capacity() + self.active.capacity() + self.minima.capacity()) * 4
            + self.scratch.used.capacity() * 9
    }

    /// Sweeps `levels` (increasing, local frame); calls `on_level` with each
    /// level's mesh and statistics (`visited` counts the edges popped).
    /// [`CielSweeper::prepare_minima`] must have been called with `f`.
    pub fn sweep<F: ScalarField>(
        &mut self,
        f: &F,
        levels: &[f32],
        ctx: &EmitContext,
        mesh: &mut LevelMesh,
        mut on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
    ) {
        let c = self.ciel;
        self.passed = BitSet::new(c.positions.len());
        self.active.clear();
        let mut next_min = 0;
        for (k, &t) in levels.iter().enumerate() {
            mesh.clear();
            self.stamp = self.stamp.wrapping_add(1);
            if self.stamp == 0 {
                self.cell_stamp.fill(0);
                self.stamp = 1;
            }
            std::mem::swap(&mut self.work, &mut self.active);
            self.active.clear();
            // Minima passed by this level.
            while next_min < self.minima.len() && f.phi(self.minima[next_min]) < t {
                let v = self.minima[next_min];
                next_min += 1;
                Self::pass(c, f, &mut self.passed, &mut self.work, v);
            }
            let mut i = 0;
            while i < self.work.len() {
                let h = self.work[i];
                i += 1;
                let b = c.dest(h);
                if f.phi(b) >= t {
                    self.active.push(h);
                } else {
                    Self::pass(c, f, &mut self.passed, &mut self.work, b);
                }
            }
            let visited = self.work.len() as u64;
            self.work.clear();
            // Draw the cells around the active edges, once each.
            for &h in &self.active {
                c.for_each_cell_around_edge(h, |x| {
                    let cell = c.cell_of(x);
                    if self.cell_stamp[cell as usize] != self.stamp {
                        self.cell_stamp[cell as usize] = self.stamp;
                        c.draw_cell(f, cell, t, ctx, &mut self.scratch, mesh);
                    }
                });
            }
            let st = LevelStats::of(mesh, visited);
            on_level(k, mesh, &st);
        }
    }

    /// Passes vertex `v` (φ(v) < t): pushes its upward edges, once per sweep.
    #[inline(always)]
    fn pass<F: ScalarField>(c: &Ciel, f: &F, passed: &mut BitSet, work: &mut Vec<u32>, v: u32) {
        if passed.get(v as usize) {
            return;
        }
        passed.set(v as usize);
        let fv = f.phi(v);
        c.for_each_around_vertex(v, |h| {
            let w = c.dest(h);
            if key_below(fv, v, f.phi(w), w) {
                work.push(h);
            }
        });
    }
}

/// The reference over a [`Ciel`]: every live cell against every level with
/// the same tie rule and the same drawing code.
pub fn brute_force<F: ScalarField>(
    c: &Ciel,
    f: &F,
    levels: &[f32],
    ctx: &EmitContext,
    mesh: &mut LevelMesh,
    mut on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
) {
    let live: Vec<(u32, f32, f32)> = (0..c.cell_count() as u32)
        .filter(|&x| c.is_live(x))
        .map(|x| {
            let mut lo = f32::INFINITY;
            let mut hi = f32::NEG_INFINITY;
            for h in c.cell_half_edges(x) {
                let p = f.phi(c.org(h));
                lo = lo.min(p);
                hi = hi.max(p);
            }
            (x, lo, hi)
        })
        .collect();
    let mut scratch = DrawScratch::default();
    for (k, &t) in levels.iter().enumerate() {
        mesh.clear();
        for &(x, lo, hi) in &live {
            if intersects(lo, hi, t) {
                c.draw_cell(f, x, t, ctx, &mut scratch, mesh);
            }
        }
        let st = LevelStats::of(mesh, live.len() as u64);
        on_level(k, mesh, &st);
    }
}
