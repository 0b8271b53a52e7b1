//! CGraph: the zoo-grid cellular graph. Per cell: its meta-cell id, its
//! vertex ids and its face neighbours (`u32::MAX` = none).
//!
//! Storage is stencil-coded ([`CellStore`]): most cells of a real grid
//! repeat a few *stencils*, the vertex ids relative to the cell's first
//! vertex and the neighbour ids relative to the cell id (a hexahedral block
//! exported in IJK order has one stencil per boundary situation). Each cell
//! then costs an anchor vertex (4 B) and a stencil id (2 B); cells whose
//! stencil is rare are stored explicitly. Cells are sewn through a
//! transient vertex → incident-cells map that is dropped after the build. Slots are the input cell ids; hidden and degenerate cells stay as
//! dead slots (never swept, never anyone's neighbour).

use std::borrow::Cow;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};
use std::sync::atomic::AtomicU32;
use std::sync::atomic::Ordering::Relaxed;

use rayon::prelude::*;

use crate::cellgraph::{BitSet, CellGraph};
use crate::grid::{Grid, Topology, hex_corner_offsets};
use crate::mem::{try_filled, try_vec};
use crate::metacell::{Catalog, MAX_META_VERTICES, builtin};
use crate::structures::hex_lanes::{LANES, classify_hexes};
use crate::structures::resolve::{NON_VOLUMETRIC, resolve_cells};
use crate::structures::{CellClass, StructureError, classify_cell, is_sweepable};

/// "No neighbour" marker.
pub const NONE: u32 = u32::MAX;

/// The cellular graph of a zoo grid.
#[derive(Clone, Debug)]
pub struct CGraph {
    /// f64 origin of the rebased positions.
    pub origin: [f64; 3],
    /// Rebased f32 positions.
    pub positions: Vec<[f32; 3]>,
    /// Meta-cell catalog.
    pub catalog: Catalog,
    /// Meta id, vertex ids and neighbours of every cell.
    cells: CellStore,
    live: BitSet,
    /// Counts of cell classes (see [`crate::structures::CELL_CLASS_NAMES`]).
    pub class_counts: [usize; crate::structures::CELL_CLASS_COUNT],
    /// Cells per meta-cell id.
    pub meta_counts: Vec<usize>,
    /// Hidden cells excluded.
    pub hidden_count: usize,
    /// Number of cell faces with a neighbour (each interior face counted twice).
    pub sewn_faces: usize,
}

/// Cells per parallel task of [`classify_and_orient`].
const CLASSIFY_CHUNK: usize = 1 << 12;

/// Classes of cells `first..first + out.len()`: builtin hexahedra four at
/// a time (`hex_lanes`, the same classes), the others one by one.
fn classify_chunk(
    catalog: &Catalog,
    metas: &[u16],
    voff: &[u32],
    verts: &[u32],
    points: &[[f64; 3]],
    first: usize,
    out: &mut [CellClass],
) {
    // Cells come in IJK order and their vertices lie on four pillars far
    // apart in the point array: the points of a cell a few ahead are
    // fetched while this one is checked.
    const AHEAD: usize = 8;
    let n = metas.len();
    let ids = |c: usize| &verts[voff[c] as usize..voff[c + 1] as usize];
    let hex = catalog.get(builtin::HEXAHEDRON);
    let mut batch = [0usize; LANES];
    let mut queued = 0;
    for c in first..first + out.len() {
        if c + AHEAD < n {
            let (a, b) = (voff[c + AHEAD] as usize, voff[c + AHEAD + 1] as usize);
            for &v in verts.get(a..b).unwrap_or(&[]) {
                crate::extract::prefetch(points, v as usize);
            }
        }
        match metas[c] {
            NON_VOLUMETRIC => out[c - first] = CellClass::NonVolumetric,
            builtin::HEXAHEDRON if ids(c).len() == 8 => {
                batch[queued] = c;
                queued += 1;
                if queued == LANES {
                    let cl = classify_hexes(hex, batch.map(ids), points);
                    for (&b, cl) in batch.iter().zip(cl) {
                        out[b - first] = cl;
                    }
                    queued = 0;
                }
            }
            m => out[c - first] = classify_cell(catalog.get(m), ids(c), points),
        }
    }
    for &b in &batch[..queued] {
        out[b - first] = classify_cell(hex, ids(b), points);
    }
}

/// Classifies every cell (see [`classify_cell`]; 0D–2D cells are
/// [`CellClass::NonVolumetric`]) and orients polyhedra outward: an inverted
/// polyhedron gets the meta-cell with its faces reversed (and counts as
/// valid). Shared by the CGraph and the corner-point graph, so both see the
/// same meta-cells and classes.
pub(crate) fn classify_and_orient(
    catalog: &mut Catalog,
    metas: &mut [u16],
    voff: &[u32],
    verts: &[u32],
    points: &[[f64; 3]],
) -> Result<Vec<CellClass>, StructureError> {
    let n = metas.len();
    let cat: &Catalog = catalog;
    let mut class = try_filled(n, CellClass::NonVolumetric, "the cell classes")?;
    class
        .par_chunks_mut(CLASSIFY_CHUNK)
        .enumerate()
        .for_each(|(ch, out)| {
            classify_chunk(cat, metas, voff, verts, points, ch * CLASSIFY_CHUNK, out)
        });
    for c in 0..n {
        let mut cl = class[c];
        if cl == CellClass::Inverted && catalog.get(metas[c]).name.starts_with("polyhedron") {
            let flipped: Vec<Vec<u8>> = catalog
                .get(metas[c])
                .faces
                .iter()
                .map(|f| f.iter().rev().copied().collect())
                .collect();
            let nv = catalog.get(metas[c]).nv;
            metas[c] =
                catalog
                    .for_faces(nv, &flipped)
                    .map_err(|e| StructureError::UnsupportedCell {
                        cell: c,
                        why: format!("polyhedron: {e}"),
                    })?;
            cl = CellClass::Valid;
        }
        class[c] = cl;
    }
    Ok(class)
}

impl CGraph {
    /// Builds the CGraph of an unstructured grid (or of a structured grid,
    /// whose cells become hexahedra). `hidden` marks cells to exclude.
    pub fn build(grid: &Grid, hidden: Option<&[bool]>) -> Result<Self, StructureError> {
        let mut catalog = Catalog::new();
        let (mut metas, voff, verts) = match &grid.topology {
            Topology::Unstructured(cells) => resolve_cells(cells, &grid.points, &mut catalog)?,
            Topology::Structured { dims } => {
                let (m, o, v) = structured_as_hexes(*dims)?;
                (m, Cow::Owned(o), Cow::Owned(v))
            }
        };
        let n = metas.len();
        if metas.iter().all(|&m| m == NON_VOLUMETRIC) {
            return Err(StructureError::NoCells);
        }
        let class = classify_and_orient(&mut catalog, &mut metas, &voff, &verts, &grid.points)?;
        let mut live = BitSet::new(n);
        let mut class_counts = [0usize; crate::structures::CELL_CLASS_COUNT];
        let mut hidden_count = 0;
        for c in 0..n {
            class_counts[class[c] as usize] += 1;
            let h = hidden.is_some_and(|h| h.get(c).copied().unwrap_or(false));
            hidden_count += h as usize;
            if is_sweepable(class[c]) && !h {
                live.set(c);
            }
        }
        let (nstart, nbrs) = sew(&catalog, &metas, &voff, &verts, &live, grid.points.len());
        let sewn_faces = nbrs.iter().filter(|&&x| x != NONE).count();
        let mut meta_counts = vec![0; catalog.metas.len()];
        for &m in metas.iter().filter(|&&m| m != NON_VOLUMETRIC) {
            meta_counts[m as usize] += 1;
        }
        let cells = CellStore::build(&metas, &voff, &verts, &nstart, &nbrs);
        drop(verts);
        let positions = grid.rebased_positions()?;
        Ok(CGraph {
            origin: grid.origin(),
            positions,
            catalog,
            cells,
            live,
            class_counts,
            meta_counts,
            hidden_count,
            sewn_faces,
        })
    }

    /// Number of cells (slots).
    pub fn cell_count(&self) -> usize {
        self.cells.len()
    }

    /// Cells that the sweep will visit.
    pub fn live_cells(&self) -> usize {
        self.live.count()
    }

    /// Face neighbours of cell `c` (NONE where there is none), in face order.
    pub fn neighbours(&self, c: u32) -> Vec<u32> {
        let mut out = Vec::new();
        self.cells.neighbours(&self.catalog, c, |n| out.push(n));
        out
    }

    /// Bytes held per part of the structure.
    pub fn bytes(&self) -> Vec<(&'static str, usize)> {
        vec![
            ("positions", self.positions.len() * 12),
            ("cell_anchors", self.cells.anchor.len() * 4),
            ("cell_stencil_ids", self.cells.stencil.len() * 2),
            ("stencils", self.cells.stencil_bytes()),
            ("explicit_cells", self.cells.explicit.len() * 4),
            ("live_bits", self.live.bytes()),
            ("meta_cell_tables", self.catalog.table_bytes()),
        ]
    }
}

/// Structured grids seen as a zoo of hexahedra (for `--structure cgraph` on IJK input).
/// Its arrays are allocated fallibly.
fn structured_as_hexes(dims: [usize; 3]) -> Result<(Vec<u16>, Vec<u32>, Vec<u32>), StructureError> {
    let [npi, npj, npk] = dims;
    let n = (npi - 1) * (npj - 1) * (npk - 1);
    let slab = npi * npj;
    let mut verts = try_vec(n.saturating_mul(8), "the hexahedra's vertices")?;
    let mut offsets = try_vec(n + 1, "the hexahedra's offsets")?;
    offsets.extend((0..=n as u32).map(|c| c * 8));
    for k in 0..npk - 1 {
        for j in 0..npj - 1 {
            for i in 0..npi - 1 {
                let v0 = i + j * npi + k * slab;
                for o in hex_corner_offsets(npi, slab) {
                    verts.push((v0 + o) as u32);
                }
            }
        }
    }
    Ok((
        try_filled(n, builtin::HEXAHEDRON, "the hexahedra's types")?,
        offsets,
        verts,
    ))
}

/// The vertex → incident live cells map (CSR: `start`, `nv + 1` entries,
/// and the cells, each vertex's list in cell order), as a stable counting
/// sort over chunks of cells in parallel: per chunk its count per vertex,
/// then each chunk's first position per vertex (chunks in cell order), then
/// each chunk writes its cells there.
fn incidence(voff: &[u32], verts: &[u32], live: &BitSet, nv: usize) -> (Vec<u32>, Vec<u32>) {
    let parts = if voff.len() <= 8192 {
        1
    } else {
        rayon::current_num_threads().clamp(1, 8)
    };
    incidence_in_parts(voff, verts, live, nv, parts)
}

/// [`incidence`] over `parts` chunks of cells.
fn incidence_in_parts(
    voff: &[u32],
    verts: &[u32],
    live: &BitSet,
    nv: usize,
    parts: usize,
) -> (Vec<u32>, Vec<u32>) {
    let n = voff.len() - 1;
    let parts = parts.max(1);
    let chunk = n.div_ceil(parts).max(1);
    let cells_of = |p: usize| p * chunk..((p + 1) * chunk).min(n);
    let live_verts = |c: usize| {
        if live.get(c) {
            &verts[voff[c] as usize..voff[c + 1] as usize]
        } else {
            &[][..]
        }
    };
    // Allocated here, not in the workers (whose own malloc arenas would
    // take fresh pages).
    let mut pos: Vec<Vec<u32>> = (0..parts).map(|_| vec![0u32; nv]).collect();
    pos.par_iter_mut().enumerate().for_each(|(p, count)| {
        for c in cells_of(p) {
            for &v in live_verts(c) {
                count[v as usize] += 1;
            }
        }
    });
    let mut start = Vec::with_capacity(nv + 1);
    let mut total = 0u32;
    for v in 0..nv {
        start.push(total);
        for count in &mut pos {
            let k = count[v];
            count[v] = total;
            total += k;
        }
    }
    start.push(total);
    let inc: Vec<AtomicU32> = (0..total)
        .into_par_iter()
        .map(|_| AtomicU32::new(0))
        .collect();
    pos.into_par_iter().enumerate().for_each(|(p, mut pos)| {
        for c in cells_of(p) {
            for &v in live_verts(c) {
                inc[pos[v as usize] as usize].store(c as u32, Relaxed);
                pos[v as usize] += 1;
            }
        }
    });
    (start, inc.into_iter().map(AtomicU32::into_inner).collect())
}

/// Finds face neighbours: for each face of each live cell, the smallest
/// other live cell that has a face with exactly the same vertex set.
/// Returns per cell the start of its faces (`nstart`, `n + 1` entries) and
/// the neighbours in face order.
///
/// Each shared face is searched once: when cell `c` finds `d > c` as the
/// smallest match of its face, no cell below `c` holds that face, so `c`
/// is also `d`'s smallest match and is written into `d`'s face too, which
/// `d` then skips. Writes race only between equal values (atomics).
fn sew(
    catalog: &Catalog,
    metas: &[u16],
    voff: &[u32],
    verts: &[u32],
    live: &BitSet,
    nv: usize,
) -> (Vec<u32>, Vec<u32>) {
    let n = metas.len();
    let faces_of = |c: usize| match metas[c] {
        NON_VOLUMETRIC => &[][..],
        m => &catalog.get(m).faces[..],
    };
    let masks_of = |c: usize| match metas[c] {
        NON_VOLUMETRIC => &[][..],
        m => catalog.get(m).face_masks(),
    };
    let mut nstart = Vec::with_capacity(n + 1);
    let mut total = 0u32;
    nstart.push(0);
    for c in 0..n {
        total += faces_of(c).len() as u32;
        nstart.push(total);
    }
    // Transient vertex -> incident live cells map (CSR).
    let (start, inc) = incidence(voff, verts, live, nv);
    // The smallest live cell `d != c` holding a face with the vertex set of
    // face `f` of `c`, and that face's index.
    // Vertices of a live cell are distinct, so "same length and every
    // vertex in the set" is set equality: no sorting.
    let cells_of = |v: u32| &inc[start[v as usize] as usize..start[v as usize + 1] as usize];
    let neighbour = |c: usize, f: &[u8]| -> Option<(u32, usize)> {
        let ids = &verts[voff[c] as usize..voff[c + 1] as usize];
        let mut key = [0u32; 32];
        let k = f.len().min(32);
        for (i, &lv) in f.iter().take(k).enumerate() {
            key[i] = ids[lv as usize];
        }
        let key = &key[..k];
        // Candidates: the cells around two vertices half a loop apart (for
        // a quad, a diagonal: in a conforming grid only the two cells on
        // either side of the face hold both). The incidence lists are sorted
        // by cell, so this is a merge.
        let (mut a, mut b) = (cells_of(key[0]), cells_of(key[k / 2]));
        while let (Some(&x), Some(&y)) = (a.first(), b.first()) {
            if x < y {
                a = &a[1..];
            } else if y < x {
                b = &b[1..];
            } else {
                a = &a[1..];
                b = &b[1..];
                let d = x as usize;
                if d == c {
                    continue;
                }
                // The key's local positions in `d` (all must be there), as
                // a bit set: the face of `d` with the same set has the same
                // mask (the vertices of live cells and of faces are distinct).
                let dv = &verts[voff[d] as usize..voff[d + 1] as usize];
                let mut mask = 0u16;
                let mut all = true;
                for v in key {
                    match dv.iter().position(|w| w == v) {
                        Some(p) => mask |= 1 << (p & 15),
                        None => {
                            all = false;
                            break;
                        }
                    }
                }
                if !all {
                    continue;
                }
                if let Some(g) = masks_of(d).iter().position(|&m| m == mask) {
                    return Some((x, g));
                }
            }
        }
        None
    };
    const UNSET: u32 = NONE - 1;
    let nbrs: Vec<AtomicU32> = (0..total)
        .into_par_iter()
        .map(|_| AtomicU32::new(UNSET))
        .collect();
    const BLOCK: usize = 4096;
    (0..n.div_ceil(BLOCK)).into_par_iter().for_each(|b| {
        for c in b * BLOCK..((b + 1) * BLOCK).min(n) {
            let base = nstart[c] as usize;
            for (f, face) in faces_of(c).iter().enumerate() {
                let slot = &nbrs[base + f];
                if !live.get(c) {
                    slot.store(NONE, Relaxed);
                    continue;
                }
                if slot.load(Relaxed) != UNSET {
                    continue;
                }
                match neighbour(c, face) {
                    Some((d, g)) => {
                        slot.store(d, Relaxed);
                        if d as usize > c {
                            nbrs[nstart[d as usize] as usize + g].store(c as u32, Relaxed);
                        }
                    }
                    None => slot.store(NONE, Relaxed),
                }
            }
        }
    });
    let nbrs = nbrs.into_iter().map(AtomicU32::into_inner).collect();
    (nstart, nbrs)
}

impl CellGraph for CGraph {
    fn slot_count(&self) -> usize {
        self.cells.len()
    }
    fn is_live(&self, slot: u32) -> bool {
        self.live.get(slot as usize)
    }
    fn catalog(&self) -> &Catalog {
        &self.catalog
    }
    fn positions(&self) -> &[[f32; 3]] {
        &self.positions
    }
    #[inline(always)]
    fn cell(&self, slot: u32, out: &mut [u32; MAX_META_VERTICES]) -> (u16, usize) {
        self.cells.vertices(&self.catalog, slot, out)
    }
    #[inline(always)]
    fn for_each_neighbour(&self, slot: u32, mut f: impl FnMut(u32)) {
        self.cells.neighbours(&self.catalog, slot, |n| {
            if n != NONE {
                f(n);
            }
        });
    }
    fn source_cell(&self, slot: u32) -> u32 {
        slot
    }
}

/// Hasher for keys that are already 64-bit hashes: passes them through.
#[derive(Default)]
struct PassHasher(u64);

impl Hasher for PassHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = self.0.rotate_left(8) ^ b as u64;
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = x;
    }
}

/// Hash-map builder for [`PassHasher`].
type PassHash = BuildHasherDefault<PassHasher>;

/// Stencil id of cells stored explicitly.
const ESCAPED: u16 = u16::MAX;

/// Neighbour delta standing for [`NONE`] (no real delta reaches it: cell
/// ids are below 2³¹).
const NONE_DELTA: i32 = i32::MIN;

/// Stencil-coded cell connectivity (see the module docs).
///
/// Cell `c` with stencil `s = stencil[c] != ESCAPED` has meta
/// `stencil_meta[s]`, vertices `anchor[c] + deltas[k]` and neighbours
/// `c + deltas[nv + f]` (wrapping, `NONE_DELTA` = none) with `k`, `f`
/// running over the stencil's block of `deltas`. An escaped cell has
/// `explicit[anchor[c]..]` = meta id, vertex ids, neighbour ids.
#[derive(Clone, Debug, Default)]
pub struct CellStore {
    anchor: Vec<u32>,
    stencil: Vec<u16>,
    stencil_meta: Vec<u16>,
    stencil_start: Vec<u32>,
    deltas: Vec<i32>,
    explicit: Vec<u32>,
}

impl CellStore {
    /// Codes cells given as meta ids, vertex ids (`verts[voff[c]..voff[c+1]]`)
    /// and neighbours (`nbrs[nstart[c]..nstart[c+1]]`, in face order).
    fn build(metas: &[u16], voff: &[u32], verts: &[u32], nstart: &[u32], nbrs: &[u32]) -> Self {
        let n = metas.len();
        // A cell's key (meta, vertex deltas, neighbour deltas), streamed.
        let key_of = |c: usize| {
            let v = &verts[voff[c] as usize..voff[c + 1] as usize];
            let v0 = v.first().copied().unwrap_or(0);
            std::iter::once(metas[c] as i32)
                .chain(v.iter().map(move |&x| x.wrapping_sub(v0) as i32))
                .chain(
                    nbrs[nstart[c] as usize..nstart[c + 1] as usize]
                        .iter()
                        .map(move |&x| {
                            if x == NONE {
                                NONE_DELTA
                            } else {
                                x.wrapping_sub(c as u32) as i32
                            }
                        }),
                )
        };
        let hashes: Vec<u64> = (0..n)
            .into_par_iter()
            .map(|c| {
                if metas[c] == NON_VOLUMETRIC {
                    0
                } else {
                    key_of(c).fold(0xcbf2_9ce4_8422_2325u64, |h, x| {
                        (h ^ x as u32 as u64).wrapping_mul(0x0100_0000_01b3)
                    })
                }
            })
            .collect();
        // Count stencils (by hash: count, first cell, id), keep the most
        // frequent repeated ones. The map gives each hash an entry once;
        // every cell then keeps its entry's index (no second lookup).
        let mut entry_of: HashMap<u64, u32, PassHash> = HashMap::default();
        let mut entries: Vec<(u32, u32, u16)> = Vec::new();
        let mut cell_entry = vec![u32::MAX; n];
        for c in 0..n {
            if metas[c] != NON_VOLUMETRIC {
                let e = *entry_of.entry(hashes[c]).or_insert_with(|| {
                    entries.push((0, c as u32, ESCAPED));
                    entries.len() as u32 - 1
                }) as usize;
                entries[e].0 += 1;
                cell_entry[c] = e as u32;
            }
        }
        drop(entry_of);
        let mut common: Vec<(u32, u32, usize)> = entries
            .iter()
            .enumerate()
            .filter(|e| e.1.0 >= 2)
            .map(|(e, &(k, first, _))| (k, first, e))
            .collect();
        common.sort_unstable_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
        common.truncate(ESCAPED as usize);
        let mut store = CellStore::default();
        for (i, &(_, first, e)) in common.iter().enumerate() {
            let mut k = key_of(first as usize);
            store.stencil_meta.push(k.next().unwrap_or(0) as u16);
            store.stencil_start.push(store.deltas.len() as u32);
            store.deltas.extend(k);
            entries[e].2 = i as u16;
        }
        store.stencil_start.push(store.deltas.len() as u32);
        // Each cell's stencil, in parallel (a hash collision must not merge
        // two stencils: the key is compared); then anchors and explicit
        // cells in cell order.
        store.stencil = (0..n)
            .into_par_iter()
            .map(|c| {
                entries
                    .get(cell_entry[c] as usize)
                    .map(|e| e.2)
                    .filter(|&s| {
                        s != ESCAPED && store.stencil_meta[s as usize] == metas[c] && {
                            let (a, b) = store.block(s);
                            store.deltas[a..b].iter().copied().eq(key_of(c).skip(1))
                        }
                    })
                    .unwrap_or(ESCAPED)
            })
            .collect();
        store.anchor.reserve_exact(n);
        for c in 0..n {
            let v = &verts[voff[c] as usize..voff[c + 1] as usize];
            if store.stencil[c] != ESCAPED {
                store.anchor.push(v[0]);
            } else {
                store.anchor.push(store.explicit.len() as u32);
                store.explicit.push(metas[c] as u32);
                store.explicit.extend_from_slice(v);
                store
                    .explicit
                    .extend_from_slice(&nbrs[nstart[c] as usize..nstart[c + 1] as usize]);
            }
        }
        store.explicit.shrink_to_fit();
        store
    }

    /// Number of cells.
    fn len(&self) -> usize {
        self.stencil.len()
    }

    /// Range of stencil `s` in `deltas`.
    #[inline(always)]
    fn block(&self, s: u16) -> (usize, usize) {
        (
            self.stencil_start[s as usize] as usize,
            self.stencil_start[s as usize + 1] as usize,
        )
    }

    /// Bytes of the stencil tables.
    fn stencil_bytes(&self) -> usize {
        self.stencil_meta.len() * 2 + self.stencil_start.len() * 4 + self.deltas.len() * 4
    }

    /// Meta id and vertex ids of cell `c` (into `out`); vertex count.
    #[inline(always)]
    fn vertices(
        &self,
        catalog: &Catalog,
        c: u32,
        out: &mut [u32; MAX_META_VERTICES],
    ) -> (u16, usize) {
        let s = self.stencil[c as usize];
        let a = self.anchor[c as usize];
        if s != ESCAPED {
            let m = self.stencil_meta[s as usize];
            let nv = catalog.get(m).nv;
            let start = self.stencil_start[s as usize] as usize;
            for (o, &d) in out[..nv].iter_mut().zip(&self.deltas[start..start + nv]) {
                *o = a.wrapping_add(d as u32);
            }
            (m, nv)
        } else {
            let m = self.explicit[a as usize] as u16;
            if m == NON_VOLUMETRIC {
                return (m, 0);
            }
            let nv = catalog.get(m).nv;
            let a = a as usize + 1;
            out[..nv].copy_from_slice(&self.explicit[a..a + nv]);
            (m, nv)
        }
    }

    /// Calls `f` with each face neighbour of `c` (NONE included), in face order.
    #[inline(always)]
    fn neighbours(&self, catalog: &Catalog, c: u32, mut f: impl FnMut(u32)) {
        let s = self.stencil[c as usize];
        let a = self.anchor[c as usize];
        if s != ESCAPED {
            let m = catalog.get(self.stencil_meta[s as usize]);
            let start = self.stencil_start[s as usize] as usize + m.nv;
            for &d in &self.deltas[start..start + m.faces.len()] {
                f(if d == NONE_DELTA {
                    NONE
                } else {
                    c.wrapping_add(d as u32)
                });
            }
        } else {
            let m = self.explicit[a as usize] as u16;
            if m == NON_VOLUMETRIC {
                return;
            }
            let m = catalog.get(m);
            let a = a as usize + 1 + m.nv;
            for &n in &self.explicit[a..a + m.faces.len()] {
                f(n);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The chunked counting sort gives the sequential CSR (lists in cell
    /// order, dead cells left out) for any number of chunks.
    #[test]
    fn incidence_in_parts_equals_the_sequential_csr() {
        let (n, nv) = (5000usize, 700usize);
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = |m: usize| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % m as u64) as usize
        };
        let mut voff = vec![0u32];
        let mut verts = Vec::new();
        let mut live = BitSet::new(n);
        for c in 0..n {
            for _ in 0..4 + next(5) {
                verts.push(next(nv) as u32);
            }
            voff.push(verts.len() as u32);
            if next(10) != 0 {
                live.set(c);
            }
        }
        let mut lists = vec![Vec::new(); nv];
        for c in (0..n).filter(|&c| live.get(c)) {
            for &v in &verts[voff[c] as usize..voff[c + 1] as usize] {
                lists[v as usize].push(c as u32);
            }
        }
        for parts in [1, 2, 3, 8, 64] {
            let (start, inc) = incidence_in_parts(&voff, &verts, &live, nv, parts);
            assert_eq!(start.len(), nv + 1);
            for v in 0..nv {
                assert_eq!(
                    inc[start[v] as usize..start[v + 1] as usize],
                    lists[v][..],
                    "vertex {v}, {parts} parts"
                );
            }
            assert_eq!(start[nv] as usize, inc.len());
        }
    }
}
