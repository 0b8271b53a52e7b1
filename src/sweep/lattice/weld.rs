//! Polygon emission for the hexahedral lattice (the S-CGraph's cells), with
//! welding by *edge ownership* instead of a hash map.
//!
//! The sweep emits a level's cut cells in slot order. Every cut grid edge
//! belongs to the polygons of all the live cells around it, and the first
//! of them in slot order (the edge's *owner*) creates its vertex; the later
//! ones read it back from an [`EdgeWindow`], a direct-mapped table indexed
//! by the edge's lower vertex modulo a power of two larger than any slot
//! distance between two cells that share an edge along that axis (a row
//! and a cell for k edges, so their section stays small). Whether a cell owns an
//! edge depends only on which of its nine lower-slot edge neighbours are
//! live, so a cell's owned edges are one table lookup, and no lookup can
//! miss or hit a stale entry: an edge that is cut has a cut, live, earlier
//! owner in the same level, and no other edge reaches its window entry
//! between the owner's write and the last read.

use super::writer::HexWriter;
use crate::cellgraph::hex_table::EDGE_ENDS;
pub use crate::cellgraph::hex_table::{LatticeHexTable, edge_ends};
use crate::extract::{CutCell, EmitContext, LevelMesh, code_of, decide_faces, emit_cell};
use crate::metacell::MetaCell;

/// Largest [`EdgeWindow`] length W per axis (the table holds at most 4W u32s:
/// 256 MiB at this limit).
pub const MAX_WINDOW: u64 = 1 << 24;

/// Which edges a lattice cell owns, and where their vertices go in the
/// [`EdgeWindow`], for slot steps `[1, npi, npi·npj]`.
#[derive(Clone, Debug)]
pub struct EdgeOwnership {
    /// The window fits in [`MAX_WINDOW`] entries per axis. When it does not
    /// (layers of more than ~2²³ slots), the tables below are truncated and
    /// must not be used: weld with the hash map instead.
    pub fits: bool,
    /// The nine cells that share a face or an edge with a cell and come
    /// before it in slot order, as (i, j, k) offsets.
    pub lower: [[i32; 3]; 9],
    /// Slot steps (wrapping) of the `lower` neighbours.
    pub lower_steps: [u32; 9],
    /// Per set of live lower neighbours (bit n = `lower[n]` live): the
    /// edges the cell owns.
    own: Box<[u16; 512]>,
    /// Entries of the whole table (the three sections, padded to a power
    /// of two).
    table_len: usize,
    /// Per geometric edge (padded to 16): the slot step from the cell to
    /// its lower vertex's cell (the vertex offset in the lattice), then
    /// `W_axis − 1`, where the window length W_axis is a power of two
    /// above the slot span of the cells around an edge along that axis
    /// (`npi + 1` for k edges, about a layer for the others), then where
    /// its axis's section starts (k edges first, so their small, busy
    /// section shares no cache lines with the others).
    window_edges: [[u32; 4]; 16],
}

impl EdgeOwnership {
    /// The tables for a lattice whose rows hold `npi` slots and whose
    /// layers `npi·npj`.
    pub fn new(npi: u32, npj: u32) -> Self {
        let step = [1u32, npi, npi * npj];
        let slot_of = |o: [i32; 3]| (0..3).map(|a| o[a] as i64 * step[a] as i64).sum::<i64>();
        let mut lower = [[0i32; 3]; 9];
        let mut n = 0;
        for z in -1..=1 {
            for y in -1..=1 {
                for x in -1..=1 {
                    let o = [x, y, z];
                    let nonzero = o.iter().filter(|&&c| c != 0).count();
                    if (1..=2).contains(&nonzero) && slot_of(o) < 0 && n < 9 {
                        lower[n] = o;
                        n += 1;
                    }
                }
            }
        }
        let own = (0..512u32)
            .map(|live| {
                (0..12).fold(0u16, |m, e| {
                    let d = e / 4;
                    let (lo, _) = edge_ends(e);
                    let bit = |a: usize| (lo >> a & 1) as i32;
                    // The cells around edge e: along its axis this cell's
                    // position, along each other axis the cell at the
                    // edge's position bit or the one before.
                    let shared = |o: &[i32; 3]| {
                        o[d] == 0
                            && (0..3)
                                .filter(|&a| a != d)
                                .all(|a| o[a] == bit(a) || o[a] == bit(a) - 1)
                    };
                    let owned = !lower
                        .iter()
                        .enumerate()
                        .any(|(n, o)| shared(o) && live >> n & 1 == 1);
                    m | (owned as u16) << e
                })
            })
            .collect::<Vec<u16>>()
            .try_into()
            .expect("512 entries");
        let low_offset: [u32; 12] = std::array::from_fn(|e| {
            let lo = edge_ends(e).0;
            (0..3).map(|a| (lo >> a & 1) as u32 * step[a]).sum()
        });
        // The cells around an edge along axis d differ by at most one step
        // along each of the other two axes: their slots span the sum of
        // those two steps. At most 2^32 each (slab < 2^32); `fits` says
        // whether the windows are small enough to allocate (else the
        // caller welds by hash).
        let want: [u64; 3] = std::array::from_fn(|d| {
            let span: u64 = (0..3).filter(|&a| a != d).map(|a| step[a] as u64).sum();
            (span + 1).next_power_of_two()
        });
        let fits = want.iter().all(|&w| w <= MAX_WINDOW);
        let windows = want.map(|w| w.min(MAX_WINDOW) as u32);
        // Sections in the order k, i, j.
        let base = [windows[2], windows[2] + windows[0], 0];
        let table_len = windows
            .iter()
            .map(|&w| w as usize)
            .sum::<usize>()
            .next_power_of_two();
        let mask: [u32; 12] = std::array::from_fn(|e| windows[e / 4] - 1);
        let axis_base: [u32; 12] = std::array::from_fn(|e| base[e / 4]);
        let window_edges = std::array::from_fn(|e| {
            if e < 12 {
                [low_offset[e], mask[e], axis_base[e], 0]
            } else {
                [0; 4]
            }
        });
        EdgeOwnership {
            fits,
            lower,
            lower_steps: lower.map(|o| slot_of(o) as i32 as u32),
            own,
            table_len,
            window_edges,
        }
    }

    /// Window slot of geometric edge `e` of the cell in slot `c`: the
    /// start of its axis's section plus the slot of the edge's lower
    /// vertex mod W_axis.
    #[inline(always)]
    pub fn slot_of(&self, e: usize, c: u32) -> usize {
        let [off, mask, base, _] = self.window_edges[e & 15];
        ((c.wrapping_add(off) & mask) + base) as usize
    }
}

/// Per-level weld table of the lattice emitter: the output vertex of each
/// cut edge, in its axis's section at (slot of its lower vertex mod W_axis)
/// ([`EdgeOwnership::slot_of`]). Never cleared: ownership
/// guarantees every read was written earlier in the same level (see the
/// module docs).
#[derive(Clone, Debug)]
pub struct EdgeWindow {
    /// Never empty; its length is a power of two.
    ids: Vec<u32>,
    /// `ids.len() − 1`, so `i & last` is always in bounds; slots are
    /// always in range (see [`EdgeOwnership::slot_of`]), the mask only
    /// makes the unchecked indexing sound.
    last: usize,
}

impl Default for EdgeWindow {
    fn default() -> Self {
        EdgeWindow {
            ids: vec![0],
            last: 0,
        }
    }
}

impl EdgeWindow {
    /// Sizes the window for `owner`. Keeps the table when it fits.
    pub fn fit(&mut self, owner: &EdgeOwnership) {
        // Three axis sections, padded to a power of two.
        let n = owner.table_len;
        debug_assert!(n.is_power_of_two());
        if self.ids.len() != n {
            self.ids = vec![0; n];
            self.last = n - 1;
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.ids.capacity() * 4
    }

    /// The vertex recorded at window slot `i` (from [`EdgeOwnership::slot_of`]).
    #[inline(always)]
    fn get(&self, i: usize) -> u32 {
        // SAFETY: `last` is `ids.len() − 1` (set with `ids` by `fit`), so
        // `i & last < ids.len()`.
        unsafe { *self.ids.get_unchecked(i & self.last) }
    }

    /// Records vertex `v` at window slot `i`.
    #[inline(always)]
    fn set(&mut self, i: usize, v: u32) {
        // SAFETY: as in `get`.
        unsafe { *self.ids.get_unchecked_mut(i & self.last) = v }
    }
}

/// The lattice emitter's use of the tables: polygons welded by edge
/// ownership, or by the mesh's hash map.
impl LatticeHexTable {
    /// Creates the vertices where level `lv.t` crosses the cut edges in
    /// `own` of `cell` (positions from [`EmitContext::positions`], see
    /// [`LatticeHexTable::point_on_edge`]) and records them in the window.
    /// The attribute, when given, holds every vertex of the cell.
    #[inline(always)]
    fn create_owned(
        &self,
        mut own: u32,
        lv: &HexLevel,
        cell: &HexCell,
        out: &mut HexWriter,
        win: &mut EdgeWindow,
    ) {
        let HexCell { v0, f, slot, .. } = *cell;
        let (t, ctx, owner) = (lv.t, lv.ctx, lv.owner);
        let cell = self.cell_positions(v0, ctx.positions);
        while own != 0 {
            let e = own.trailing_zeros() as usize & 15;
            own &= own - 1;
            // SAFETY: e < 12 (own holds edge bits only) and the edge tables
            // have 12 entries.
            let (lo, hi, (a, b)) = unsafe {
                (
                    *self.edge_low.get_unchecked(e),
                    *self.edge_high.get_unchecked(e),
                    *EDGE_ENDS.get_unchecked(e),
                )
            };
            let (ga, gb) = (v0 + lo, v0 + hi);
            // SAFETY: a, b < 8.
            let (fa, fb) = unsafe { (*f.get_unchecked(a), *f.get_unchecked(b)) };
            let s = (t - fa) / (fb - fa);
            let value = match ctx.attribute {
                // SAFETY: the attribute holds the cell's vertices ga < gb
                // (checked once by the sweep: it has a value per vertex).
                Some(attr) => unsafe {
                    let (xa, xb) = (
                        *attr.get_unchecked(ga as usize),
                        *attr.get_unchecked(gb as usize),
                    );
                    xa + s * (xb - xa)
                },
                None => t,
            };
            let p = self.point_on_edge(e, s, cell);
            let vi = out.vertex((ga as u64) << 32 | gb as u64, p, value);
            win.set(owner.slot_of(e, slot), vi);
        }
    }

    /// Emits the polygons of the cut cell `cell` at level `lv` in geometric
    /// order, the same polygons in the same order as
    /// [`crate::extract::emit_cell`]. Cells are emitted in slot order; the
    /// cell creates the vertices of the cut edges it owns (by
    /// [`HexCell::live`]) and reads the others from `win` (sized by
    /// [`EdgeWindow::fit`] for `lv.owner`). Returns false, having written
    /// nothing, when the code has an ambiguous face: then call
    /// [`LatticeHexTable::emit_ambiguous`].
    #[inline(always)]
    pub(crate) fn emit(
        &self,
        lv: &HexLevel,
        cell: &HexCell,
        out: &mut HexWriter,
        win: &mut EdgeWindow,
    ) -> bool {
        let owner = lv.owner;
        let code = cell.code & 255;
        let own = self.cut[code] as u32 & owner.own[cell.live as usize & 511] as u32;
        let cp = &self.codes[code];
        if cp.polys == 0 {
            return false;
        }
        out.begin_cell();
        self.create_owned(own, lv, cell, out, win);
        let slot = cell.slot;
        let mut first = 0;
        // At most 3 polygons (`LatticeHexTable::new`), so the mask keeps
        // the count and proves `p < 4` to the compiler.
        debug_assert!(cp.polys <= 3);
        for p in 0..(cp.polys as usize & 3) {
            let m = cp.sizes[p] as usize;
            debug_assert!(first + m <= 12);
            // SAFETY: a code's polygons have 12 corners in all (every cut
            // edge once), so first + i < 12; corners are edges (< 12).
            out.polygon(
                m,
                |i| unsafe {
                    let e = *cp.corners.get_unchecked(first + i) as usize;
                    win.get(owner.slot_of(e, slot))
                },
                slot,
            );
            first += m;
        }
        true
    }

    /// The same polygons as `LatticeHexTable::emit` for the cell with first
    /// vertex `v0`, φ `f` (geometric order) and slot `slot` at level `t`,
    /// welded by the mesh's hash map ([`crate::extract::emit_cell`] in the
    /// meta-cell's local order), for lattices whose weld window would not
    /// fit.
    pub fn emit_hashed(
        &self,
        meta: &MetaCell,
        (v0, f, slot): (u32, &[f32; 8], u32),
        t: f32,
        ctx: &EmitContext,
        mesh: &mut LevelMesh,
    ) {
        let (ids, phi) = self.local(v0, f);
        let cell = CutCell {
            gids: &ids,
            phi: &phi,
            t,
            code: code_of(&phi, t),
            slot,
        };
        emit_cell(meta, &cell, ctx, mesh);
    }

    /// [`LatticeHexTable::emit`] for a cell whose code is ambiguous: the
    /// meta-cell's loops (in its local order, with the face decider),
    /// corners mapped to geometric edges.
    #[inline(never)]
    pub(crate) fn emit_ambiguous(
        &self,
        meta: &MetaCell,
        lv: &HexLevel,
        cell: &HexCell,
        mesh: &mut LevelMesh,
        win: &mut EdgeWindow,
    ) {
        let (t, owner, slot) = (lv.t, lv.owner, cell.slot);
        let code = cell.code & 255;
        let own = self.cut[code] as u32 & owner.own[cell.live as usize & 511] as u32;
        let mut out = HexWriter::new(mesh, 1);
        out.begin_cell();
        self.create_owned(own, lv, cell, &mut out, win);
        drop(out);
        let (gids, phi) = self.local(cell.v0, &cell.f);
        let local_code = code_of(&phi, t);
        let outcome = if meta.ambiguous_faces[local_code] != 0 {
            decide_faces(meta, &gids, &phi, t, local_code)
        } else {
            0
        };
        for lp in meta.loops(local_code, outcome) {
            let corner = |i: usize| self.local_edge[lp[i] as usize] as usize;
            let start = mesh.indices.len();
            mesh.indices
                .extend((0..lp.len()).map(|i| win.get(owner.slot_of(corner(i), slot))));
            mesh.end_polygon(start, slot);
        }
    }
}

/// A level as the lattice emitter welds it by edge ownership: the level
/// value, the sweep's emission context and the ownership tables.
pub(crate) struct HexLevel<'a> {
    /// The level.
    pub(crate) t: f32,
    /// Positions and attribute.
    pub(crate) ctx: &'a EmitContext<'a>,
    /// Which edges a cell owns, and their window entries.
    pub(crate) owner: &'a EdgeOwnership,
}

/// A cut lattice cell as the emitter reads it.
#[derive(Clone, Copy)]
pub(crate) struct HexCell {
    /// First vertex.
    pub(crate) v0: u32,
    /// φ at its vertices in geometric order.
    pub(crate) f: [f32; 8],
    /// Geometric code at the level (bit q set iff `f[q] >= t`).
    pub(crate) code: usize,
    /// Bit n set when `owner.lower[n]` is a live cell of the same sweep
    /// block (see [`EdgeOwnership`]).
    pub(crate) live: u32,
    /// Slot.
    pub(crate) slot: u32,
}

#[cfg(test)]
mod tests {
    use super::{EdgeOwnership, edge_ends};

    /// Every geometric edge joins two vertices one bit apart, each edge once.
    #[test]
    fn geometric_edges_are_the_twelve_cube_edges() {
        let mut seen = std::collections::HashSet::new();
        for e in 0..12 {
            let (a, b) = edge_ends(e);
            assert_eq!(a ^ b, 1 << (e / 4), "edge {e}");
            assert!(a < b);
            assert!(seen.insert((a, b)));
        }
    }

    /// The lower neighbours are exactly the cells that share an edge or a
    /// face with the cell and come before it in slot order, and their slot
    /// steps are their offsets'.
    #[test]
    fn lower_neighbours_are_the_earlier_edge_neighbours() {
        let (npi, npj) = (7u32, 5u32);
        let o = EdgeOwnership::new(npi, npj);
        let mut want = Vec::new();
        for z in -1i32..=1 {
            for y in -1i32..=1 {
                for x in -1i32..=1 {
                    let nonzero = [x, y, z].iter().filter(|&&c| c != 0).count();
                    if (1..=2).contains(&nonzero) && (z, y, x) < (0, 0, 0) {
                        want.push([x, y, z]);
                    }
                }
            }
        }
        let mut got = o.lower.to_vec();
        got.sort();
        want.sort();
        assert_eq!(got, want);
        let c = 3 * npi * npj + 2 * npi + 3;
        for (n, off) in o.lower.iter().enumerate() {
            let nb = (c as i32 + off[0] + off[1] * npi as i32 + off[2] * (npi * npj) as i32) as u32;
            assert_eq!(c.wrapping_add(o.lower_steps[n]), nb);
        }
    }

    /// The window spans more slots than the cells around any edge, and
    /// layers too large for it are flagged (the sweep then welds by hash).
    #[test]
    fn window_covers_the_edge_span_or_is_flagged() {
        let o = EdgeOwnership::new(258, 258);
        assert!(o.fits);
        let windows = [0, 1, 2].map(|d| o.window_edges[4 * d][1] + 1);
        // Along i and j the cells around an edge span a layer and a row
        // (or a cell); along k a row and a cell.
        assert!(windows[0] as u64 > 258 + 258 * 258);
        assert!(windows[1] as u64 > 1 + 258 * 258);
        assert!(windows[2] as u64 > 1 + 258);
        assert!(windows.iter().all(|w| w.is_power_of_two()));
        // The three sections are disjoint and inside the table.
        let mut used = vec![false; o.table_len];
        for (e, w) in (0..12).map(|e| (e, windows[e / 4])) {
            if e % 4 == 0 {
                for x in 0..w {
                    let i = o.slot_of(e, x.wrapping_sub(o.window_edges[e][0]));
                    assert!(!used[i], "edge {e}: window entry {i} shared");
                    used[i] = true;
                }
            }
        }
        let big = EdgeOwnership::new(20_000, 20_000);
        assert!(!big.fits);
    }
}
