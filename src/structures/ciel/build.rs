//! Construction of a [`Ciel`] from face lists (the paper's §4.2), linear in
//! the input and free of per-cell allocations.
//!
//! 1. Exact per-cell bounds (half-edges, faces) give each chunk of cells its
//!    part of the final arrays. Per chunk (in parallel, scratch buffers
//!    reused): face loops are read straight from the face stream (or the
//!    catalog's faces for typed cells), checked, oriented and written as
//!    half-edges with their `mate_face` offsets; each face leaves a record
//!    keyed by its smallest vertex and that vertex's two loop neighbours.
//! 2. Parts left short by cells found dead slide down in order
//!    (deterministic; nothing moves when every cell is live).
//! 3. `mate_cell`: face records are grouped by smallest vertex (a parallel
//!    stable counting sort), each group is sorted by its keys and equal keys
//!    are matched by their reversed loops (in parallel over vertex ranges).
//! 4. Vertex cycles: a half-edge is the representative of its fan (the
//!    half-edges with the same origin around one edge, linked by
//!    `mate_face`∘`mate_cell`) when it has the smallest id of the fan; the
//!    representatives are grouped per origin vertex (CSR, the same counting
//!    sort), in id order.

use rayon::prelude::*;

use super::link::{Linked, vertex_cycles};
use super::{
    CONVEXITY_TOLERANCE, Ciel, CielCounts, CielError, FIRST_IN_FACE, LAST_IN_FACE, LOOKUP_SHIFT,
    MAX_CELL_HALF_EDGES, NONE, VERTEX_MASK, structured_as_cells,
};
use crate::grid::{Cells, Grid, Topology, is_lower_dimensional, vtk_type};
use crate::metacell::{Catalog, VOXEL_TO_HEX, builtin};
use crate::structures::common::{CellClass, classify_cell, is_sweepable, split_lengths};

/// Cells per parallel task of the per-cell phase.
const CHUNK_CELLS: usize = 1024;

/// A face as seen by the cross-cell matching: its first half-edge (global),
/// its smallest vertex `m` and the two loop neighbours of `m`, sorted;
/// indexed by [`START`], [`M`], [`LO`], [`HI`] (a plain array, so that the
/// array of all faces is allocated zeroed, without a fill).
pub(super) type FaceRec = [u32; 4];
/// [`FaceRec`]'s first half-edge.
pub(super) const START: usize = 0;
/// [`FaceRec`]'s smallest vertex.
pub(super) const M: usize = 1;
/// [`FaceRec`]'s smaller neighbour of [`M`].
pub(super) const LO: usize = 2;
/// [`FaceRec`]'s larger neighbour of [`M`].
pub(super) const HI: usize = 3;

/// A table reused from cell to cell: each slot carries the generation
/// that wrote it, so that a new generation empties the table without
/// clearing it.
#[derive(Default)]
struct Stamped<T> {
    slots: Vec<(T, u32)>,
    generation: u32,
}

impl<T: Copy + Default> Stamped<T> {
    /// Starts a new generation over at least `cap` slots (a smaller table
    /// grows to `cap` exactly) and returns it.
    fn begin(&mut self, cap: usize) -> u32 {
        if self.slots.len() < cap {
            self.slots.clear();
            self.slots.resize(cap, (T::default(), 0));
            self.generation = 0;
        }
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.slots.fill((T::default(), 0));
            self.generation = 1;
        }
        self.generation
    }
}

/// Reused per-task buffers of the per-cell phase.
#[derive(Default)]
struct Scratch {
    /// Face loops of the current cell (global ids), concatenated.
    ids: Vec<u32>,
    /// Face starts into `ids` (faces + 1).
    starts: Vec<u32>,
    /// Local vertex id of each half-edge's origin.
    lid: Vec<u32>,
    /// Next half-edge in its face.
    nxt: Vec<u32>,
    /// Global → local vertex id table: (global, local).
    table: Stamped<(u32, u32)>,
    /// Outgoing half-edges per local vertex (CSR).
    out_start: Vec<u32>,
    out: Vec<u32>,
    /// Edge pairs (local half-edges, same direction?).
    pairs: Vec<(u32, u32, bool)>,
    /// Local `mate_face`.
    mate: Vec<u32>,
    /// [`pair_edges`]' table: per unordered local edge, its first half-edge.
    edge_table: Stamped<u32>,
    /// Face of each local half-edge.
    he_face: Vec<u32>,
    /// Per local vertex, the last face seen using it.
    stamp: Vec<u32>,
    /// Face keys `(m, lo, hi, face)`: after [`check_cell`], one per face in
    /// the final face order.
    fkeys: Vec<(u32, u32, u32, u32)>,
    /// Distinct vertices of the cell, in first-appearance order.
    verts: Vec<u32>,
    /// Sort buffers.
    tmp: Vec<u32>,
    tmp2: Vec<u32>,
    /// [`face_keys_clash`]' table: faces.
    face_table: Stamped<u32>,
    /// [`repeated_position`]'s table: (coordinate hash, local vertex).
    point_table: Stamped<(u64, u32)>,
    pts: Vec<[f64; 3]>,
    /// `pts` by coordinate (the convexity test vectorises over these).
    xyz: [Vec<f64>; 3],
    /// Orientation propagation: per face 0 = unset, 1 = keep, 2 = flip.
    flip: Vec<u8>,
    adj_start: Vec<u32>,
    adj: Vec<(u32, bool)>,
    stack: Vec<u32>,
}

/// What one chunk of cells produced besides the half-edges, faces and
/// cell starts it wrote into its parts of the final arrays.
#[derive(Default)]
struct ChunkOut {
    /// Half-edges and faces written.
    half_edges: usize,
    faces: usize,
    class_counts: [usize; 5],
    hidden: usize,
    flipped: usize,
    /// Live cells found non-convex.
    non_convex: Vec<u32>,
}

/// One chunk's parts of the final arrays, sized by [`cell_bounds`].
struct ChunkParts<'a> {
    /// Global id of the first half-edge of `origins`.
    base: u32,
    origins: &'a mut [u32],
    mate_face: &'a mut [i16],
    faces: &'a mut [FaceRec],
    /// The chunk's cells' first half-edges (global ids).
    cell_start: &'a mut [u32],
}

/// Parses a VTK polyhedron face stream (`nf, n0, ids.., n1, ids..`) into
/// flat face loops (`ids`, with `starts` = faces + 1 offsets). Never panics.
pub(super) fn parse_faces_into(
    cell: usize,
    stream: &[u32],
    ids: &mut Vec<u32>,
    starts: &mut Vec<u32>,
) -> Result<(), CielError> {
    let err = |why: String| CielError::FaceStream { cell, why };
    ids.clear();
    starts.clear();
    starts.push(0);
    let nf = *stream
        .first()
        .ok_or_else(|| err("empty face stream".into()))? as usize;
    if nf > stream.len() {
        return Err(err(format!(
            "{nf} faces announced in a stream of {} values",
            stream.len()
        )));
    }
    let mut p = 1usize;
    for f in 0..nf {
        let n = *stream
            .get(p)
            .ok_or_else(|| err(format!("face {f} missing")))? as usize;
        let face = stream
            .get(p + 1..p.saturating_add(1).saturating_add(n))
            .ok_or_else(|| err(format!("face {f} truncated ({n} vertices announced)")))?;
        ids.extend_from_slice(face);
        starts.push(ids.len() as u32);
        p += 1 + n;
    }
    if p != stream.len() {
        return Err(err(format!(
            "{} trailing values after {nf} faces",
            stream.len() - p
        )));
    }
    Ok(())
}

/// The catalog meta-cell of a typed volumetric cell.
fn typed_meta(t: u8, prisms: &[(u8, u16)]) -> Option<u16> {
    Some(match t {
        vtk_type::TETRA => builtin::TETRA,
        vtk_type::PYRAMID => builtin::PYRAMID,
        vtk_type::WEDGE => builtin::WEDGE,
        vtk_type::HEXAHEDRON | vtk_type::VOXEL => builtin::HEXAHEDRON,
        _ => prisms.iter().find(|p| p.0 == t)?.1,
    })
}

/// (half-edges, faces) that cell `c` writes if it is live and valid: exact
/// for every cell whose faces parse, so that chunks can write straight into
/// the final arrays (cells found dead leave a gap, closed afterwards).
fn cell_bounds(
    cells: &Cells,
    c: usize,
    catalog: &Catalog,
    prisms: &[(u8, u16)],
    hidden: Option<&[bool]>,
) -> (usize, usize) {
    let t = cells.types[c];
    if is_lower_dimensional(t) || hidden.is_some_and(|h| h.get(c).copied().unwrap_or(false)) {
        return (0, 0);
    }
    if t == vtk_type::POLYHEDRON {
        let stream = cells.faces_of(c);
        let nf = (stream.first().copied().unwrap_or(0) as usize).min(stream.len());
        return (stream.len().saturating_sub(1 + nf), nf);
    }
    match typed_meta(t, prisms) {
        Some(meta) => {
            let m = catalog.get(meta);
            (m.faces.iter().map(|f| f.len()).sum(), m.faces.len())
        }
        None => (0, 0),
    }
}

/// Writes the face loops (global ids) of cell `c` into `s.ids`/`s.starts`;
/// returns the cell's class when it is not volumetric (nothing written).
fn cell_faces(
    cells: &Cells,
    c: usize,
    catalog: &Catalog,
    prisms: &[(u8, u16)],
    points: &[[f64; 3]],
    s: &mut Scratch,
) -> Result<Option<CellClass>, CielError> {
    let t = cells.types[c];
    if is_lower_dimensional(t) {
        return Ok(Some(CellClass::NonVolumetric));
    }
    if t == vtk_type::POLYHEDRON {
        parse_faces_into(c, cells.faces_of(c), &mut s.ids, &mut s.starts)?;
        return Ok(None);
    }
    let ids = cells.cell(c);
    let Some(meta) = typed_meta(t, prisms) else {
        return Err(CielError::FaceStream {
            cell: c,
            why: format!("unsupported VTK cell type {t}"),
        });
    };
    let m = catalog.get(meta);
    let local = &mut s.tmp;
    local.clear();
    if t == vtk_type::VOXEL {
        if ids.len() != 8 {
            return Err(CielError::FaceStream {
                cell: c,
                why: "voxel without 8 vertices".into(),
            });
        }
        local.extend(VOXEL_TO_HEX.iter().map(|&i| ids[i]));
    } else {
        local.extend_from_slice(ids);
    }
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
    let class = classify_cell(m, local, points);
    if !is_sweepable(class) {
        return Ok(Some(class));
    }
    s.ids.clear();
    s.starts.clear();
    s.starts.push(0);
    for f in &m.faces {
        s.ids.extend(f.iter().map(|&l| local[l as usize]));
        s.starts.push(s.ids.len() as u32);
    }
    Ok(None)
}

/// Face index of local half-edge `h`.
fn face_of(starts: &[u32], h: u32) -> usize {
    starts.partition_point(|&s| s <= h) - 1
}

/// The smallest vertex of a loop (of at least one vertex) and its two loop
/// neighbours, sorted.
#[inline]
fn face_key(face: &[u32]) -> (u32, u32, u32) {
    let (mut p, mut low) = (0, face[0]);
    for (i, &v) in face.iter().enumerate().skip(1) {
        if v < low {
            (p, low) = (i, v);
        }
    }
    let n = face.len();
    let a = face[if p == 0 { n - 1 } else { p - 1 }];
    let b = face[if p + 1 == n { 0 } else { p + 1 }];
    (low, a.min(b), a.max(b))
}

/// Sorted copy of a loop into `out`.
fn sorted_into(face: &[u32], out: &mut Vec<u32>) {
    out.clear();
    out.extend_from_slice(face);
    out.sort_unstable();
}

/// Cell-local vertex ids: `s.verts` (local → global, first appearance),
/// `s.lid` per half-edge and `s.nxt` (next half-edge in the face), through
/// a small open-addressing table (no sort).
fn local_ids(s: &mut Scratch) {
    let n = s.ids.len();
    // Open addressing over a table that only grows; slots of earlier
    // cells are told apart by a generation instead of being cleared.
    let generation = s.table.begin((2 * n).next_power_of_two().max(256));
    let mask = s.table.slots.len() - 1;
    s.verts.clear();
    s.lid.clear();
    s.lid.resize(n, 0);
    let (ids, lid, table) = (&s.ids[..n], &mut s.lid[..n], &mut s.table.slots[..]);
    for (i, &v) in ids.iter().enumerate() {
        let mut k = (v.wrapping_mul(0x9E37_79B9) >> 7) as usize & mask;
        loop {
            let ((w, l), g) = table[k];
            if g != generation {
                let l = s.verts.len() as u32;
                table[k] = ((v, l), generation);
                lid[i] = l;
                s.verts.push(v);
                break;
            }
            if w == v {
                lid[i] = l;
                break;
            }
            k = (k + 1) & mask;
        }
    }
    s.nxt.clear();
    s.nxt.resize(n, 0);
    for w in s.starts.windows(2) {
        let (a, b) = (w[0] as usize, w[1] as usize);
        for (i, x) in s.nxt[a..b].iter_mut().enumerate() {
            *x = (a + i + 1) as u32;
        }
        s.nxt[b - 1] = a as u32;
    }
}

/// Pairs the half-edges of one cell by edge into `s.pairs` (and `s.mate`):
/// open and non-manifold edges are errors. Needs [`local_ids`]. Cells of
/// up to [`EDGE_TABLE_VERTICES`] vertices go through a table indexed by
/// (local vertex, local vertex); any edge not used exactly twice, or
/// larger cells, take the per-vertex lists of [`pair_edges_by_lists`],
/// which name the offending edge.
fn pair_edges(cell: usize, s: &mut Scratch) -> Result<(), CielError> {
    let n = s.ids.len();
    let nv = s.verts.len();
    if nv > EDGE_TABLE_VERTICES {
        return pair_edges_by_lists(cell, s);
    }
    // Per unordered local edge (lo, hi): the first half-edge seen + 1
    // (0 = none), under the current generation; a second fills `mate`.
    // Grown to this cell's need only: a fresh scratch (one per
    // `polyhedron_faces` call) must not clear the whole 128² table.
    let generation = s.edge_table.begin(nv * nv);
    s.mate.clear();
    s.mate.resize(n, NONE);
    let mut ok = true;
    {
        let (lid, nxt, mate) = (&s.lid[..n], &s.nxt[..n], &mut s.mate[..n]);
        let table = &mut s.edge_table.slots[..nv * nv];
        for h in 0..n {
            let (la, lb) = (lid[h], lid[nxt[h] as usize]);
            let (lo, hi) = if la < lb { (la, lb) } else { (lb, la) };
            let e = &mut table[lo as usize * nv + hi as usize];
            if e.1 != generation {
                *e = (h as u32, generation);
            } else {
                let g = e.0;
                if g == NONE || la == lb {
                    ok = false;
                    break;
                }
                mate[h] = g;
                mate[g as usize] = h as u32;
                e.0 = NONE; // a third half-edge on this edge is an error
            }
        }
    }
    if !ok || s.mate.contains(&NONE) {
        return pair_edges_by_lists(cell, s);
    }
    s.pairs.clear();
    s.pairs.reserve(n / 2);
    let (lid, mate) = (&s.lid[..n], &s.mate[..n]);
    s.pairs.extend(
        mate.iter()
            .enumerate()
            .filter(|&(h, &g)| g as usize > h)
            .map(|(h, &g)| (h as u32, g, lid[h] == lid[g as usize])),
    );
    Ok(())
}

/// Largest cell (distinct vertices) paired through the edge table.
const EDGE_TABLE_VERTICES: usize = 128;

/// [`pair_edges`] through per-vertex lists of outgoing half-edges.
fn pair_edges_by_lists(cell: usize, s: &mut Scratch) -> Result<(), CielError> {
    let n = s.ids.len();
    let nv = s.verts.len();
    s.out_start.clear();
    s.out_start.resize(nv + 2, 0);
    for &l in &s.lid {
        s.out_start[l as usize + 2] += 1;
    }
    for k in 2..nv + 2 {
        s.out_start[k] += s.out_start[k - 1];
    }
    s.out.clear();
    s.out.resize(n, 0);
    for (h, &l) in s.lid.iter().enumerate() {
        let k = &mut s.out_start[l as usize + 1];
        s.out[*k as usize] = h as u32;
        *k += 1;
    }
    s.pairs.clear();
    s.mate.clear();
    s.mate.resize(n, NONE);
    for h in 0..n {
        if s.mate[h] != NONE {
            continue;
        }
        let (la, lb) = (s.lid[h], s.lid[s.nxt[h] as usize]);
        // Fast path: exactly one opposite half-edge, not yet mated, and no
        // other half-edge from `la` to `lb`... the latter is checked when
        // that half-edge looks for its own mate (it would find `found`
        // already mated).
        let mut count = 1;
        let mut found = (NONE, false);
        for &g in &s.out[s.out_start[lb as usize] as usize..s.out_start[lb as usize + 1] as usize] {
            if s.lid[s.nxt[g as usize] as usize] == la {
                count += 1;
                found = (g, false);
            }
        }
        if count != 2 || s.mate[found.0 as usize] != NONE {
            // Slow path: count every half-edge on the edge, both ways.
            count = 1;
            for &g in
                &s.out[s.out_start[lb as usize] as usize..s.out_start[lb as usize + 1] as usize]
            {
                if s.lid[s.nxt[g as usize] as usize] == la {
                    count += 1;
                    found = (g, false);
                }
            }
            for &g in
                &s.out[s.out_start[la as usize] as usize..s.out_start[la as usize + 1] as usize]
            {
                if g as usize != h && s.lid[s.nxt[g as usize] as usize] == lb {
                    count += 1;
                    found = (g, true);
                }
            }
            if count == 2 && s.mate[found.0 as usize] != NONE {
                count = 3;
            }
        }
        if count == 2 {
            s.pairs.push((h as u32, found.0, found.1));
            s.mate[h] = found.0;
            s.mate[found.0 as usize] = h as u32;
            continue;
        }
        let (a, b) = (s.ids[h], s.ids[s.nxt[h] as usize]);
        let (a, b) = (a.min(b), a.max(b));
        let face = face_of(&s.starts, h as u32);
        return Err(if count == 1 {
            CielError::Open { cell, face, a, b }
        } else {
            CielError::NonManifoldEdge {
                cell,
                face,
                a,
                b,
                count,
            }
        });
    }
    Ok(())
}

/// Reverses face `f` of the scratch loops in place.
fn reverse_face(s: &mut Scratch, f: usize) {
    let (a, b) = (s.starts[f] as usize, s.starts[f + 1] as usize);
    s.ids[a..b].reverse();
}

/// Makes the faces consistent by propagation across shared edges (only
/// when some edge is used in the same direction by its two faces).
/// Returns the number of faces flipped.
fn orient(cell: usize, s: &mut Scratch) -> Result<usize, CielError> {
    if s.pairs.iter().all(|p| !p.2) {
        return Ok(0);
    }
    let nf = s.starts.len() - 1;
    s.he_face.clear();
    for (f, w) in s.starts.windows(2).enumerate() {
        s.he_face
            .extend(std::iter::repeat_n(f as u32, (w[1] - w[0]) as usize));
    }
    // Face adjacency (CSR) from the edge pairs.
    s.adj_start.clear();
    s.adj_start.resize(nf + 1, 0);
    for &(h1, h2, _) in &s.pairs {
        s.adj_start[s.he_face[h1 as usize] as usize + 1] += 1;
        s.adj_start[s.he_face[h2 as usize] as usize + 1] += 1;
    }
    for f in 0..nf {
        s.adj_start[f + 1] += s.adj_start[f];
    }
    s.adj.clear();
    s.adj.resize(s.adj_start[nf] as usize, (0, false));
    s.tmp.clear();
    s.tmp.extend_from_slice(&s.adj_start[..nf]);
    for &(h1, h2, same) in &s.pairs {
        let (f1, f2) = (s.he_face[h1 as usize], s.he_face[h2 as usize]);
        s.adj[s.tmp[f1 as usize] as usize] = (f2, same);
        s.tmp[f1 as usize] += 1;
        s.adj[s.tmp[f2 as usize] as usize] = (f1, same);
        s.tmp[f2 as usize] += 1;
    }
    s.flip.clear();
    s.flip.resize(nf, 0);
    for root in 0..nf {
        if s.flip[root] != 0 {
            continue;
        }
        s.flip[root] = 1;
        s.stack.clear();
        s.stack.push(root as u32);
        while let Some(f) = s.stack.pop() {
            let ff = s.flip[f as usize] == 2;
            for k in s.adj_start[f as usize]..s.adj_start[f as usize + 1] {
                let (g, same) = s.adj[k as usize];
                let want = if ff ^ same { 2 } else { 1 };
                match s.flip[g as usize] {
                    0 => {
                        s.flip[g as usize] = want;
                        s.stack.push(g);
                    }
                    x if x != want => {
                        return Err(CielError::Orientation {
                            cell,
                            face: (g as usize).max(f as usize),
                        });
                    }
                    _ => {}
                }
            }
        }
    }
    let mut flipped = 0;
    for f in 0..nf {
        if s.flip[f] == 2 {
            reverse_face(s, f);
            flipped += 1;
        }
    }
    Ok(flipped)
}

/// One polyhedron's checked, outward face loops (global vertex ids) and
/// its class, exactly as the build sees them (shared with
/// [`crate::structures::convex_split`]).
pub(crate) struct CellFaces {
    /// Face loops, concatenated.
    pub(crate) ids: Vec<u32>,
    /// Face starts into `ids` (faces + 1).
    pub(crate) starts: Vec<u32>,
    /// Some vertex lies outside a face plane (by `CONVEXITY_TOLERANCE`).
    pub(crate) non_convex: bool,
    /// Quality class.
    pub(crate) class: CellClass,
}

/// Checks and orients polyhedron `cell`, given by its VTK face stream, as
/// the build does.
pub(crate) fn polyhedron_faces(
    cell: usize,
    stream: &[u32],
    points: &[[f64; 3]],
) -> Result<CellFaces, CielError> {
    let mut s = Scratch::default();
    parse_faces_into(cell, stream, &mut s.ids, &mut s.starts)?;
    let (class, _, non_convex) = check_cell(cell, points, &mut s)?;
    Ok(CellFaces {
        ids: s.ids,
        starts: s.starts,
        non_convex,
        class,
    })
}

/// Whether two faces of the loops in `s` have the same [`face_key`]
/// (through a small open-addressing table, no sort).
fn face_keys_clash(s: &mut Scratch) -> bool {
    let nf = s.starts.len() - 1;
    let generation = s.face_table.begin((2 * nf).next_power_of_two().max(32));
    let mask = s.face_table.slots.len() - 1;
    s.fkeys.clear();
    for f in 0..nf {
        let (m, lo, hi) = face_key(&s.ids[s.starts[f] as usize..s.starts[f + 1] as usize]);
        s.fkeys.push((m, lo, hi, f as u32));
        let h = (m ^ lo.rotate_left(11) ^ hi.rotate_left(22)).wrapping_mul(0x9E37_79B9);
        let mut k = (h >> 7) as usize & mask;
        loop {
            let e = s.face_table.slots[k];
            if e.1 != generation {
                s.face_table.slots[k] = (f as u32, generation);
                break;
            }
            let o = s.fkeys[e.0 as usize];
            if (o.0, o.1, o.2) == (m, lo, hi) {
                return true;
            }
            k = (k + 1) & mask;
        }
    }
    false
}

/// Duplicate faces: keys sorted, then equal keys compared by vertex set;
/// the first duplicate pair in key order is the error. Leaves `s.fkeys`
/// complete, in face order.
fn duplicate_faces_sorted(cell: usize, s: &mut Scratch) -> Result<(), CielError> {
    let nf = s.starts.len() - 1;
    s.fkeys.clear();
    for f in 0..nf {
        let (m, lo, hi) = face_key(&s.ids[s.starts[f] as usize..s.starts[f + 1] as usize]);
        s.fkeys.push((m, lo, hi, f as u32));
    }
    let mut keys = s.fkeys.clone();
    keys.sort_unstable();
    for w in keys.windows(2) {
        let (a, b) = (w[0], w[1]);
        if (a.0, a.1, a.2) == (b.0, b.1, b.2) {
            let fa = &s.ids[s.starts[a.3 as usize] as usize..s.starts[a.3 as usize + 1] as usize];
            let fb = &s.ids[s.starts[b.3 as usize] as usize..s.starts[b.3 as usize + 1] as usize];
            sorted_into(fa, &mut s.tmp);
            sorted_into(fb, &mut s.tmp2);
            if s.tmp == s.tmp2 {
                return Err(CielError::DuplicateFace {
                    cell,
                    face: a.3.min(b.3) as usize,
                    other: a.3.max(b.3) as usize,
                });
            }
        }
    }
    Ok(())
}

/// Whether two distinct local vertices of `s.verts` sit at the same
/// position (bitwise-hashed coordinates, then compared with `==`).
fn repeated_position(points: &[[f64; 3]], s: &mut Scratch) -> bool {
    let cap = (2 * s.verts.len()).next_power_of_two().max(64);
    let generation = s.point_table.begin(cap);
    let mask = s.point_table.slots.len() - 1;
    for (l, &v) in s.verts.iter().enumerate() {
        let p = points[v as usize];
        let b = p.map(f64::to_bits);
        let h = b[0] ^ b[1].rotate_left(21) ^ b[2].rotate_left(42);
        let mut k = (h.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40) as usize & mask;
        loop {
            let ((eh, el), g) = s.point_table.slots[k];
            if g != generation {
                s.point_table.slots[k] = ((h, l as u32), generation);
                break;
            }
            if eh == h && points[s.verts[el as usize] as usize] == p {
                return true;
            }
            k = (k + 1) & mask;
        }
    }
    false
}

/// The error for a vertex repeated in loop `face` (face `f` of `cell`):
/// the first repeat for short loops, the smallest repeated id for long ones.
fn repeated_in_face(
    cell: usize,
    f: usize,
    face: &[u32],
    tmp: &mut Vec<u32>,
) -> Result<(), CielError> {
    let repeated = if face.len() <= 12 {
        (1..face.len()).find_map(|i| face[..i].contains(&face[i]).then_some(face[i]))
    } else {
        sorted_into(face, tmp);
        tmp.windows(2).find(|w| w[0] == w[1]).map(|w| w[0])
    };
    match repeated {
        Some(vertex) => Err(CielError::RepeatedFaceVertex {
            cell,
            face: f,
            vertex,
        }),
        None => Ok(()),
    }
}

/// Shape checks of the loops in `s`: faces of fewer than 3 vertices (then
/// the per-face scan, in face order), else repeated vertices found through
/// local ids; then duplicate faces.
#[inline]
fn shape_checks(cell: usize, s: &mut Scratch) -> Result<(), CielError> {
    let nf = s.starts.len() - 1;
    if s.starts.windows(2).any(|w| w[1] - w[0] < 3) {
        for f in 0..nf {
            let face = &s.ids[s.starts[f] as usize..s.starts[f + 1] as usize];
            if face.len() < 3 {
                return Err(CielError::ShortFace {
                    cell,
                    face: f,
                    len: face.len(),
                });
            }
            repeated_in_face(cell, f, face, &mut s.tmp)?;
        }
    }
    local_ids(s);
    s.stamp.clear();
    s.stamp.resize(s.verts.len(), NONE);
    for f in 0..nf {
        let (a, b) = (s.starts[f] as usize, s.starts[f + 1] as usize);
        for &l in &s.lid[a..b] {
            if s.stamp[l as usize] == f as u32 {
                // This face repeats a vertex: named as the per-face scan does.
                repeated_in_face(cell, f, &s.ids[a..b], &mut s.tmp)?;
            }
            s.stamp[l as usize] = f as u32;
        }
    }
    // Duplicate faces: a face key seen twice (rare: two faces sharing their
    // smallest vertex and its two neighbours) sends the cell to the sorted
    // check, which compares vertex sets and names the pair.
    if face_keys_clash(s) {
        duplicate_faces_sorted(cell, s)?;
    }
    Ok(())
}

/// Convexity: whether some vertex lies more than [`CONVEXITY_TOLERANCE`] ×
/// `ext` outside a face plane (or a face has a zero normal), on the
/// outward loops and the vertex positions (relative to the first) in `s`.
#[inline]
fn is_non_convex(s: &mut Scratch, ext: f64) -> bool {
    let mut non_convex = false;
    for (k, col) in s.xyz.iter_mut().enumerate() {
        col.clear();
        col.extend(s.pts.iter().map(|p| p[k]));
    }
    'faces: for w in s.starts.windows(2) {
        let face = &s.lid[w[0] as usize..w[1] as usize];
        let mut nrm = [0.0; 3];
        let mut c = [0.0; 3];
        for (k, &l) in face.iter().enumerate() {
            let a = s.pts[l as usize];
            let b = s.pts[face[if k + 1 == face.len() { 0 } else { k + 1 }] as usize];
            nrm[0] += (a[1] - b[1]) * (a[2] + b[2]);
            nrm[1] += (a[2] - b[2]) * (a[0] + b[0]);
            nrm[2] += (a[0] - b[0]) * (a[1] + b[1]);
            for d in 0..3 {
                c[d] += a[d];
            }
        }
        let len = (nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]).sqrt();
        if len == 0.0 {
            non_convex = true;
            break;
        }
        let inv = 1.0 / face.len() as f64;
        let d0 = (nrm[0] * c[0] + nrm[1] * c[1] + nrm[2] * c[2]) * inv;
        let tol = CONVEXITY_TOLERANCE * ext * len;
        // Counted without an early exit so that the loop vectorises.
        let [xs, ys, zs] = &s.xyz;
        let n = xs.len();
        let (ys, zs) = (&ys[..n], &zs[..n]);
        let mut outside = 0u32;
        for i in 0..n {
            outside += (nrm[0] * xs[i] + nrm[1] * ys[i] + nrm[2] * zs[i] - d0 > tol) as u32;
        }
        if outside > 0 {
            non_convex = true;
            break 'faces;
        }
    }
    non_convex
}

/// Checks and orients the loops of one cell held in `s` (see the module
/// docs of [`super`]); on success `s.ids`/`s.starts` hold the outward loops
/// and `s.mate` the local `mate_face`. Returns (class, flipped, non-convex).
fn check_cell(
    cell: usize,
    points: &[[f64; 3]],
    s: &mut Scratch,
) -> Result<(CellClass, usize, bool), CielError> {
    let nf = s.starts.len() - 1;
    shape_checks(cell, s)?;
    pair_edges(cell, s)?;
    let mut flipped = orient(cell, s)?;
    if flipped > 0 {
        local_ids(s);
    }
    // Outward: the signed volume must be positive.
    let p0 = points[s.verts[0] as usize];
    s.pts.clear();
    s.pts.extend(s.verts.iter().map(|&v| {
        let p = points[v as usize];
        [p[0] - p0[0], p[1] - p0[1], p[2] - p0[2]]
    }));
    let mut vol = 0.0;
    for w in s.starts.windows(2) {
        let face = &s.lid[w[0] as usize..w[1] as usize];
        let a = s.pts[face[0] as usize];
        let mut b = s.pts[face[1] as usize];
        for &l in &face[2..] {
            let c = s.pts[l as usize];
            vol += a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]);
            b = c;
        }
    }
    vol /= 6.0;
    let ext = s.pts.iter().fold(0.0f64, |e, p| {
        e.max(p[0].abs()).max(p[1].abs()).max(p[2].abs())
    });
    // Repeated positions (distinct ids at the same point): dead, as in the CGraph.
    if repeated_position(points, s) {
        return Ok((CellClass::RepeatedVertex, 0, false));
    }
    if vol.is_nan() || vol.abs() <= 1e-12 * ext * ext * ext {
        return Ok((CellClass::ZeroVolume, 0, false));
    }
    if vol < 0.0 {
        s.ids.reverse();
        // Reversing the whole array reverses every loop and the face order.
        let total = s.ids.len() as u32;
        let starts: Vec<u32> = s.starts.iter().rev().map(|&x| total - x).collect();
        s.starts = starts;
        s.fkeys.reverse();
        flipped = nf - flipped;
        local_ids(s);
    }
    if flipped > 0 {
        pair_edges(cell, s)?;
    }
    let non_convex = is_non_convex(s, ext);
    // mate_face: after orientation every edge is used both ways.
    if let Some(&(_, h2, _)) = s.pairs.iter().find(|p| p.2) {
        // Cannot happen after propagation; reported rather than trusted.
        return Err(CielError::Orientation {
            cell,
            face: face_of(&s.starts, h2),
        });
    }
    Ok((CellClass::Valid, flipped, non_convex))
}

/// The per-cell phase over cells `range`, written into `parts`.
#[allow(clippy::too_many_arguments)]
fn build_chunk(
    range: std::ops::Range<usize>,
    cells: &Cells,
    catalog: &Catalog,
    prisms: &[(u8, u16)],
    points: &[[f64; 3]],
    hidden: Option<&[bool]>,
    parts: ChunkParts,
) -> Result<ChunkOut, CielError> {
    let mut s = Scratch::default();
    let mut out = ChunkOut::default();
    let first = range.start;
    for c in range {
        parts.cell_start[c - first] = parts.base + out.half_edges as u32;
        let class = match cell_faces(cells, c, catalog, prisms, points, &mut s)? {
            Some(class) => class,
            None => {
                let (class, flipped, non_convex) = check_cell(c, points, &mut s)?;
                let hide = hidden.is_some_and(|h| h.get(c).copied().unwrap_or(false));
                if is_sweepable(class) && hide {
                    // Checked like any cell, then left out of the structure.
                    out.hidden += 1;
                } else if is_sweepable(class) {
                    let n = s.ids.len();
                    if n > MAX_CELL_HALF_EDGES {
                        return Err(CielError::TooLarge(format!(
                            "cell {c} has {n} half-edges (at most {MAX_CELL_HALF_EDGES} per cell)"
                        )));
                    }
                    let nf = s.starts.len() - 1;
                    let he = out.half_edges;
                    let (Some(origins), Some(mate_face), Some(faces)) = (
                        parts.origins.get_mut(he..he + n),
                        parts.mate_face.get_mut(he..he + n),
                        parts.faces.get_mut(out.faces..out.faces + nf),
                    ) else {
                        return Err(CielError::FaceStream {
                            cell: c,
                            why: "more half-edges than its face stream announces".into(),
                        });
                    };
                    out.flipped += flipped;
                    if non_convex {
                        out.non_convex.push(c as u32);
                    }
                    let base = parts.base + he as u32;
                    // (`s.fkeys` holds each face's key, in face order.)
                    let keys = s.starts.windows(2).zip(&s.fkeys);
                    for ((w, &(m, lo, hi, _)), rec) in keys.zip(faces.iter_mut()) {
                        let (a, b) = (w[0] as usize, w[1] as usize);
                        let face = &s.ids[a..b];
                        *rec = [base + a as u32, m, lo, hi];
                        origins[a..b].copy_from_slice(face);
                        origins[a] |= FIRST_IN_FACE;
                        origins[b - 1] |= LAST_IN_FACE;
                    }
                    for (i, (d, &m)) in mate_face.iter_mut().zip(&s.mate).enumerate() {
                        *d = (m as i64 - i as i64) as i16;
                    }
                    out.half_edges += n;
                    out.faces += nf;
                    out.class_counts[class as usize] += 1;
                    continue;
                }
                class
            }
        };
        out.class_counts[class as usize] += 1;
    }
    Ok(out)
}

/// The cells of the `k`-th chunk of `n` cells.
fn chunk_range(k: usize, n: usize) -> std::ops::Range<usize> {
    k * CHUNK_CELLS..((k + 1) * CHUNK_CELLS).min(n)
}

/// The per-cell phase's output: the final arrays and the counts.
struct CellPhase {
    origins: Vec<u32>,
    mate_face: Vec<i16>,
    cell_start: Vec<u32>,
    faces: Vec<FaceRec>,
    counts: CielCounts,
    non_convex_cells: Vec<u32>,
}

impl CellPhase {
    /// Per chunk of cells, in parallel, straight into the final arrays at
    /// offsets from the exact per-cell bounds (the first error in cell order
    /// wins); then the gaps closed ([`CellPhase::close_gaps`]).
    fn run(
        cells: &Cells,
        catalog: &Catalog,
        prisms: &[(u8, u16)],
        points: &[[f64; 3]],
        hidden: Option<&[bool]>,
    ) -> Result<Self, CielError> {
        let n = cells.len();
        let nchunks = n.div_ceil(CHUNK_CELLS);
        let bounds: Vec<(usize, usize)> = (0..nchunks)
            .into_par_iter()
            .map(|k| {
                chunk_range(k, n).fold((0, 0), |(h, f), c| {
                    let (ch, cf) = cell_bounds(cells, c, catalog, prisms, hidden);
                    (h + ch, f + cf)
                })
            })
            .collect();
        let he_bound: usize = bounds.iter().map(|b| b.0).sum();
        let face_bound: usize = bounds.iter().map(|b| b.1).sum();
        if he_bound >= (1usize << 31) - 1 {
            return Err(CielError::TooLarge(format!("{he_bound} half-edges")));
        }
        let mut phase = CellPhase {
            origins: vec![0u32; he_bound],
            mate_face: vec![0i16; he_bound],
            cell_start: vec![0u32; n + 1],
            faces: vec![[0; 4]; face_bound],
            counts: CielCounts::default(),
            non_convex_cells: Vec::new(),
        };
        let he_lens: Vec<usize> = bounds.iter().map(|b| b.0).collect();
        let face_lens: Vec<usize> = bounds.iter().map(|b| b.1).collect();
        let cell_lens: Vec<usize> = (0..nchunks).map(|k| chunk_range(k, n).len()).collect();
        let mut he_bases = Vec::with_capacity(nchunks);
        let mut acc = 0usize;
        for &l in &he_lens {
            he_bases.push(acc);
            acc += l;
        }
        let parts: Vec<ChunkParts> = split_lengths(&mut phase.origins, &he_lens)
            .into_iter()
            .zip(split_lengths(&mut phase.mate_face, &he_lens))
            .zip(split_lengths(&mut phase.faces, &face_lens))
            .zip(split_lengths(&mut phase.cell_start[..n], &cell_lens))
            .zip(&he_bases)
            .map(|((((o, m), f), c), &base)| ChunkParts {
                base: base as u32,
                origins: o,
                mate_face: m,
                faces: f,
                cell_start: c,
            })
            .collect();
        let chunks: Vec<Result<ChunkOut, CielError>> = parts
            .into_par_iter()
            .enumerate()
            .map(|(k, p)| build_chunk(chunk_range(k, n), cells, catalog, prisms, points, hidden, p))
            .collect();
        let chunks: Vec<ChunkOut> = chunks.into_iter().collect::<Result<_, _>>()?;
        phase.close_gaps(&chunks, &he_bases, &face_lens)?;
        phase.tally(&chunks);
        Ok(phase)
    }

    /// Closes the gaps left by cells found dead (rare): chunks slide down
    /// in order, their face and cell starts shifted with them.
    fn close_gaps(
        &mut self,
        chunks: &[ChunkOut],
        he_bases: &[usize],
        face_lens: &[usize],
    ) -> Result<(), CielError> {
        let n = self.cell_start.len() - 1;
        let mut total = 0usize;
        let mut nfaces = 0usize;
        let mut face_base = 0usize;
        for (k, ch) in chunks.iter().enumerate() {
            let (hb, fb) = (he_bases[k], face_base);
            face_base += face_lens[k];
            if hb != total || fb != nfaces {
                let shift = (hb - total) as u32;
                self.origins.copy_within(hb..hb + ch.half_edges, total);
                self.mate_face.copy_within(hb..hb + ch.half_edges, total);
                self.faces.copy_within(fb..fb + ch.faces, nfaces);
                for f in &mut self.faces[nfaces..nfaces + ch.faces] {
                    f[START] -= shift;
                }
                for s in &mut self.cell_start[chunk_range(k, n)] {
                    *s -= shift;
                }
            }
            total += ch.half_edges;
            nfaces += ch.faces;
        }
        self.origins.truncate(total);
        self.mate_face.truncate(total);
        self.faces.truncate(nfaces);
        if total == 0 {
            return Err(CielError::NoCells);
        }
        self.cell_start[n] = total as u32;
        Ok(())
    }

    /// Sums the chunks' counts and gathers their non-convex cells.
    fn tally(&mut self, chunks: &[ChunkOut]) {
        let counts = &mut self.counts;
        for ch in chunks {
            for k in 0..5 {
                counts.class_counts[k] += ch.class_counts[k];
            }
            counts.hidden += ch.hidden;
            counts.flipped_faces += ch.flipped;
            counts.non_convex += ch.non_convex.len();
            self.non_convex_cells.extend_from_slice(&ch.non_convex);
        }
        counts.faces = self.faces.len();
    }
}

/// Per block of `1 << LOOKUP_SHIFT` half-edges, the cell of its first.
fn cell_lookup(cell_start: &[u32], total: usize) -> Vec<u32> {
    let mut cell_lookup = Vec::with_capacity((total >> LOOKUP_SHIFT) + 1);
    let mut c = 0usize;
    for b in 0..=((total - 1) >> LOOKUP_SHIFT) {
        let h = (b << LOOKUP_SHIFT) as u32;
        while cell_start[c + 1] <= h {
            c += 1;
        }
        cell_lookup.push(c as u32);
    }
    cell_lookup
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
        let structured_cells;
        let cells = match &grid.topology {
            Topology::Unstructured(c) => c,
            Topology::Structured { dims } => {
                structured_cells = structured_as_cells(*dims);
                &structured_cells
            }
        };
        // Prism meta-cells only when the grid has prisms.
        let prisms: Vec<(u8, u16)> = [vtk_type::PENTAGONAL_PRISM, vtk_type::HEXAGONAL_PRISM]
            .iter()
            .filter(|&&t| cells.types.contains(&t))
            .filter_map(|&t| catalog.for_vtk_type(t).map(|m| (t, m)))
            .collect();
        let CellPhase {
            origins,
            mate_face,
            cell_start,
            faces,
            mut counts,
            non_convex_cells,
        } = CellPhase::run(cells, &catalog, &prisms, points, hidden)?;
        let total = origins.len();
        // 3. mate_cell: faces bucketed by smallest vertex (counting sort).
        let mate_cell = Linked {
            faces: &faces,
            origins: &origins,
            cell_start: &cell_start,
            total,
        }
        .mate_cells(np)?;
        drop(faces);
        counts.border_half_edges = mate_cell.par_iter().filter(|&&m| m == NONE).count();
        // 4. Vertex cycles: representatives (smallest id of each fan), CSR by origin.
        let (vertex_start, vertex_edges) = vertex_cycles(np, &origins, &mate_face, &mate_cell);
        counts.edges = vertex_edges.len() / 2;
        let cell_lookup = cell_lookup(&cell_start, total);
        Ok(Ciel {
            origin: grid.origin(),
            positions: grid.rebased_positions(),
            origins,
            mate_faces: mate_face,
            mate_cells: mate_cell,
            cell_start,
            cell_lookup,
            vertex_start,
            vertex_edges,
            non_convex_cells,
            counts,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit cube's faces, outward.
    const CUBE: [[u32; 4]; 6] = [
        [0, 3, 2, 1],
        [4, 5, 6, 7],
        [0, 1, 5, 4],
        [1, 2, 6, 5],
        [2, 3, 7, 6],
        [3, 0, 4, 7],
    ];

    /// A small deterministic generator: `next(m)` is in `0..m`.
    fn lcg(mut state: u64) -> impl FnMut(u64) -> u64 {
        move |m| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) % m
        }
    }

    /// The edge-table pairing and the per-vertex-list pairing agree on
    /// pairs, mates and errors, over cube-like cells with random face
    /// orders, flipped faces, dropped faces and extra faces.
    #[test]
    fn edge_table_pairing_matches_the_list_pairing() {
        let mut next = lcg(11);
        let mut kinds = [0usize; 2];
        for round in 0..2000 {
            let mut faces: Vec<Vec<u32>> = CUBE.iter().map(|f| f.to_vec()).collect();
            for f in faces.iter_mut() {
                if next(4) == 0 {
                    f.reverse();
                }
                let r = next(4) as usize;
                f.rotate_left(r);
            }
            match next(6) {
                0 => {
                    faces.remove(next(6) as usize);
                }
                1 => faces.push(vec![0, 1, 2 + next(6) as u32]),
                _ => {}
            }
            let k = faces.len();
            for i in 0..k {
                faces.swap(i, next(k as u64) as usize);
            }
            let mut stream = vec![faces.len() as u32];
            for f in &faces {
                stream.push(f.len() as u32);
                stream.extend(f.iter().map(|&v| v * 7 + 100));
            }
            let mut a = Scratch::default();
            parse_faces_into(0, &stream, &mut a.ids, &mut a.starts).unwrap();
            local_ids(&mut a);
            let mut b = Scratch::default();
            parse_faces_into(0, &stream, &mut b.ids, &mut b.starts).unwrap();
            local_ids(&mut b);
            let (ra, rb) = (pair_edges(0, &mut a), pair_edges_by_lists(0, &mut b));
            assert_eq!(
                ra.as_ref().map_err(|e| e.to_string()),
                rb.as_ref().map_err(|e| e.to_string()),
                "round {round}: {faces:?}"
            );
            if ra.is_ok() {
                assert_eq!(a.pairs, b.pairs, "round {round}");
                assert_eq!(a.mate, b.mate, "round {round}");
            }
            kinds[ra.is_ok() as usize] += 1;
        }
        assert!(kinds[0] > 100 && kinds[1] > 100, "{kinds:?}");
    }

    /// The shape and duplicate checks of [`check_cell`] against a plain
    /// per-face scan in face order (short face, then repeated vertex: the
    /// first repeat for loops of up to 12, the smallest repeated id beyond)
    /// and an all-pairs duplicate search, on cube-like cells with short
    /// faces, repeated vertices, long faces and duplicate faces.
    #[test]
    fn shape_checks_match_a_per_face_scan() {
        let points: Vec<[f64; 3]> = (0..40)
            .map(|i| {
                [
                    (i & 1) as f64,
                    ((i >> 1) & 1) as f64,
                    ((i >> 2) & 1) as f64 + (i >> 3) as f64 * 0.01,
                ]
            })
            .collect();
        let mut next = lcg(5);
        let mut kinds = std::collections::BTreeMap::new();
        for round in 0..4000 {
            let mut faces: Vec<Vec<u32>> = CUBE.iter().map(|f| f.to_vec()).collect();
            for _ in 0..next(3) {
                let f = next(faces.len() as u64) as usize;
                match next(5) {
                    0 => faces[f].truncate(next(3) as usize),
                    1 if !faces[f].is_empty() => {
                        let v = faces[f][next(faces[f].len() as u64) as usize];
                        let at = next(faces[f].len() as u64 + 1) as usize;
                        faces[f].insert(at, v);
                    }
                    2 => {
                        let extra = 10 + next(6) as u32;
                        faces[f].extend((0..extra).map(|i| 8 + (i + next(3) as u32 * 7) % 32));
                    }
                    3 => {
                        let mut d = faces[f].clone();
                        let r = next(d.len().max(1) as u64) as usize;
                        d.rotate_left(r);
                        if next(2) == 0 {
                            d.reverse();
                        }
                        let at = next(faces.len() as u64 + 1) as usize;
                        faces.insert(at, d);
                    }
                    _ => {
                        let g = next(faces.len() as u64) as usize;
                        faces.swap(f, g);
                    }
                }
            }
            let mut stream = vec![faces.len() as u32];
            for f in &faces {
                stream.push(f.len() as u32);
                stream.extend_from_slice(f);
            }
            let mut s = Scratch::default();
            parse_faces_into(0, &stream, &mut s.ids, &mut s.starts).unwrap();
            let got = check_cell(0, &points, &mut s);
            // Reference: the per-face scan, then duplicates.
            let mut want = None;
            for (f, face) in faces.iter().enumerate() {
                if face.len() < 3 {
                    want = Some(CielError::ShortFace {
                        cell: 0,
                        face: f,
                        len: face.len(),
                    });
                    break;
                }
                let repeated = if face.len() <= 12 {
                    (1..face.len()).find_map(|i| face[..i].contains(&face[i]).then_some(face[i]))
                } else {
                    let mut t = face.clone();
                    t.sort_unstable();
                    t.windows(2).find(|w| w[0] == w[1]).map(|w| w[0])
                };
                if let Some(vertex) = repeated {
                    want = Some(CielError::RepeatedFaceVertex {
                        cell: 0,
                        face: f,
                        vertex,
                    });
                    break;
                }
            }
            let set = |f: &Vec<u32>| {
                let mut t = f.clone();
                t.sort_unstable();
                t
            };
            let dup = (0..faces.len())
                .any(|i| (i + 1..faces.len()).any(|j| set(&faces[i]) == set(&faces[j])));
            let kind = match (&want, &got) {
                (Some(w), Err(e)) => {
                    assert_eq!(e, w, "round {round}: {faces:?}");
                    "shape"
                }
                (Some(w), Ok(_)) => panic!("round {round}: {w} missed: {faces:?}"),
                (None, Err(CielError::DuplicateFace { face, other, .. })) => {
                    assert!(face < other, "round {round}");
                    assert_eq!(set(&faces[*face]), set(&faces[*other]), "round {round}");
                    "duplicate"
                }
                (None, r) => {
                    assert!(
                        !dup || r.is_err(),
                        "round {round}: duplicate missed: {faces:?}"
                    );
                    "other"
                }
            };
            *kinds.entry(kind).or_insert(0usize) += 1;
        }
        assert!(
            kinds.values().all(|&k| k > 100) && kinds.len() == 3,
            "{kinds:?}"
        );
    }
}
