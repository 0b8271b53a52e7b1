//! Polyhedron checks below CIEL and the convex split: face streams parsed
//! into loops, cell-local vertex ids, edge pairing (every edge used by
//! exactly two faces), consistent outward orientation, duplicate faces and
//! repeated vertices, and the convexity test by Newell normals. No I/O;
//! errors name the cell and the face ([`PolyhedronError`]).

use thiserror::Error;

use crate::structures::common::CellClass;

/// Relative tolerance of the convexity test (times the cell's extent).
pub const CONVEXITY_TOLERANCE: f64 = 1e-6;

/// "No entry" in the per-cell tables.
const NONE: u32 = u32::MAX;

/// Bad polyhedron, naming the cell and face.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum PolyhedronError {
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
}

/// A table reused from cell to cell: each slot carries the generation
/// that wrote it, so that a new generation empties the table without
/// clearing it.
#[derive(Default)]
pub(crate) struct Stamped<T> {
    pub(crate) slots: Vec<(T, u32)>,
    pub(crate) generation: u32,
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
pub(crate) struct Scratch {
    /// Face loops of the current cell (global ids), concatenated.
    pub(crate) ids: Vec<u32>,
    /// Face starts into `ids` (faces + 1).
    pub(crate) starts: Vec<u32>,
    /// Local vertex id of each half-edge's origin.
    pub(crate) lid: Vec<u32>,
    /// Next half-edge in its face.
    pub(crate) nxt: Vec<u32>,
    /// Global → local vertex id table: (global, local).
    pub(crate) table: Stamped<(u32, u32)>,
    /// Outgoing half-edges per local vertex (CSR).
    pub(crate) out_start: Vec<u32>,
    pub(crate) out: Vec<u32>,
    /// Edge pairs (local half-edges, same direction?).
    pub(crate) pairs: Vec<(u32, u32, bool)>,
    /// Local `mate_face`.
    pub(crate) mate: Vec<u32>,
    /// [`pair_edges`]' table: per unordered local edge, its first half-edge.
    pub(crate) edge_table: Stamped<u32>,
    /// Face of each local half-edge.
    pub(crate) he_face: Vec<u32>,
    /// Per local vertex, the last face seen using it.
    pub(crate) stamp: Vec<u32>,
    /// Face keys `(m, lo, hi, face)`: after [`check_cell`], one per face in
    /// the final face order.
    pub(crate) fkeys: Vec<(u32, u32, u32, u32)>,
    /// Distinct vertices of the cell, in first-appearance order.
    pub(crate) verts: Vec<u32>,
    /// Sort buffers.
    pub(crate) tmp: Vec<u32>,
    pub(crate) tmp2: Vec<u32>,
    /// [`face_keys_clash`]' table: faces.
    pub(crate) face_table: Stamped<u32>,
    /// [`repeated_position`]'s table: (coordinate hash, local vertex).
    pub(crate) point_table: Stamped<(u64, u32)>,
    pub(crate) pts: Vec<[f64; 3]>,
    /// `pts` by coordinate (the convexity test vectorises over these).
    pub(crate) xyz: [Vec<f64>; 3],
    /// Orientation propagation: per face 0 = unset, 1 = keep, 2 = flip.
    pub(crate) flip: Vec<u8>,
    pub(crate) adj_start: Vec<u32>,
    pub(crate) adj: Vec<(u32, bool)>,
    pub(crate) stack: Vec<u32>,
}

/// Parses a VTK polyhedron face stream (`nf, n0, ids.., n1, ids..`) into
/// flat face loops (`ids`, with `starts` = faces + 1 offsets). Never panics.
pub(super) fn parse_faces_into(
    cell: usize,
    stream: &[u32],
    ids: &mut Vec<u32>,
    starts: &mut Vec<u32>,
) -> Result<(), PolyhedronError> {
    let err = |why: String| PolyhedronError::FaceStream { cell, why };
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

/// Face index of local half-edge `h`.
pub(crate) fn face_of(starts: &[u32], h: u32) -> usize {
    starts.partition_point(|&s| s <= h) - 1
}

/// The smallest vertex of a loop (of at least one vertex) and its two loop
/// neighbours, sorted.
#[inline]
pub(crate) fn face_key(face: &[u32]) -> (u32, u32, u32) {
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
pub(crate) fn sorted_into(face: &[u32], out: &mut Vec<u32>) {
    out.clear();
    out.extend_from_slice(face);
    out.sort_unstable();
}

/// Cell-local vertex ids: `s.verts` (local → global, first appearance),
/// `s.lid` per half-edge and `s.nxt` (next half-edge in the face), through
/// a small open-addressing table (no sort).
pub(crate) fn local_ids(s: &mut Scratch) {
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
pub(crate) fn pair_edges(cell: usize, s: &mut Scratch) -> Result<(), PolyhedronError> {
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
pub(crate) fn pair_edges_by_lists(cell: usize, s: &mut Scratch) -> Result<(), PolyhedronError> {
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
            PolyhedronError::Open { cell, face, a, b }
        } else {
            PolyhedronError::NonManifoldEdge {
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
pub(crate) fn reverse_face(s: &mut Scratch, f: usize) {
    let (a, b) = (s.starts[f] as usize, s.starts[f + 1] as usize);
    s.ids[a..b].reverse();
}

/// Makes the faces consistent by propagation across shared edges (only
/// when some edge is used in the same direction by its two faces).
/// Returns the number of faces flipped.
pub(crate) fn orient(cell: usize, s: &mut Scratch) -> Result<usize, PolyhedronError> {
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
                        return Err(PolyhedronError::Orientation {
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

/// Checks and orients polyhedron `cell`, given by its VTK face stream, as
/// the build does (shared with [`crate::structures::convex_split`]), in
/// reused buffers: the outward loops are left in `s.ids` / `s.starts`
/// (global ids, concatenated; faces + 1 starts). Returns (class, faces
/// reversed to point outward, whether some vertex lies outside a face
/// plane by `CONVEXITY_TOLERANCE`).
pub(crate) fn polyhedron_faces_in(
    cell: usize,
    stream: &[u32],
    points: &[[f64; 3]],
    s: &mut Scratch,
) -> Result<(CellClass, usize, bool), PolyhedronError> {
    parse_faces_into(cell, stream, &mut s.ids, &mut s.starts)?;
    check_cell(cell, points, s)
}

/// Whether two faces of the loops in `s` have the same [`face_key`]
/// (through a small open-addressing table, no sort).
pub(crate) fn face_keys_clash(s: &mut Scratch) -> bool {
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
pub(crate) fn duplicate_faces_sorted(cell: usize, s: &mut Scratch) -> Result<(), PolyhedronError> {
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
                return Err(PolyhedronError::DuplicateFace {
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
pub(crate) fn repeated_position(points: &[[f64; 3]], s: &mut Scratch) -> bool {
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
pub(crate) fn repeated_in_face(
    cell: usize,
    f: usize,
    face: &[u32],
    tmp: &mut Vec<u32>,
) -> Result<(), PolyhedronError> {
    let repeated = if face.len() <= 12 {
        (1..face.len()).find_map(|i| face[..i].contains(&face[i]).then_some(face[i]))
    } else {
        sorted_into(face, tmp);
        tmp.windows(2).find(|w| w[0] == w[1]).map(|w| w[0])
    };
    match repeated {
        Some(vertex) => Err(PolyhedronError::RepeatedFaceVertex {
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
pub(crate) fn shape_checks(cell: usize, s: &mut Scratch) -> Result<(), PolyhedronError> {
    let nf = s.starts.len() - 1;
    if s.starts.windows(2).any(|w| w[1] - w[0] < 3) {
        for f in 0..nf {
            let face = &s.ids[s.starts[f] as usize..s.starts[f + 1] as usize];
            if face.len() < 3 {
                return Err(PolyhedronError::ShortFace {
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
pub(crate) fn is_non_convex(s: &mut Scratch, ext: f64) -> bool {
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
pub(crate) fn check_cell(
    cell: usize,
    points: &[[f64; 3]],
    s: &mut Scratch,
) -> Result<(CellClass, usize, bool), PolyhedronError> {
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
        return Err(PolyhedronError::Orientation {
            cell,
            face: face_of(&s.starts, h2),
        });
    }
    Ok((CellClass::Valid, flipped, non_convex))
}

#[cfg(test)]
mod tests;
