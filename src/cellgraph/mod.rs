//! What the sweep walks: the [`CellGraph`] trait that every structure
//! implements, the per-cell [`Stamp`], the hexahedral [`Lattice`] layout
//! (with its [`LatticeHexTable`]) and the [`BitSet`]. Below both
//! `structures` (which implement it) and `sweep` (which runs on it).

mod bitset;
pub mod hex_table;

pub use bitset::BitSet;
pub use hex_table::LatticeHexTable;

use crate::extract::{EmitContext, prefetch};
use crate::field::ScalarField;
use crate::metacell::{Catalog, MAX_META_VERTICES, MetaCell};

/// Per-cell step stamp. 16 bits keep the S-CGraph within 20 bytes per
/// vertex; the stamps are reset once every 65 534 levels.
pub type Stamp = u16;

/// Stamp value of slots that are never swept: ghosts, hidden and degenerate cells.
pub const NEVER: Stamp = Stamp::MAX;

/// A cell graph the sweep can walk. Cells live in *slots*; some slots may be
/// ghosts (S-CGraph's border layer) or dead cells (hidden, degenerate).
pub trait CellGraph: Sync {
    /// Number of slots (length of the stamp array).
    fn slot_count(&self) -> usize;
    /// True for slots holding a cell to sweep; false for ghost/hidden/degenerate slots.
    fn is_live(&self, slot: u32) -> bool;
    /// Initial stamps: 0 for live cells, [`NEVER`] for the rest.
    fn initial_stamps(&self) -> Vec<Stamp> {
        (0..self.slot_count() as u32)
            .map(|s| if self.is_live(s) { 0 } else { NEVER })
            .collect()
    }
    /// The catalog of meta-cells.
    fn catalog(&self) -> &Catalog;
    /// Rebased vertex positions.
    fn positions(&self) -> &[[f32; 3]];
    /// Meta-cell id and global vertex ids (local order) of the cell in `slot`;
    /// returns the vertex count written into `out`.
    fn cell(&self, slot: u32, out: &mut [u32; MAX_META_VERTICES]) -> (u16, usize);
    /// Calls `f` with every face-neighbour slot of `slot` (ghost slots included).
    fn for_each_neighbour(&self, slot: u32, f: impl FnMut(u32));
    /// Visits the face neighbours of `slot` in [`CellGraph::for_each_neighbour`]
    /// order: for each neighbour `nb` with `want(nb)` true, calls
    /// `found(nb, lo)` where `lo` is the minimum of φ over `nb`'s vertices.
    /// `want` must return false for ghost and dead slots.
    ///
    /// `ids` and `phi` hold `slot`'s vertex ids (as written by
    /// [`CellGraph::cell`]) and their φ values; implementations may reuse
    /// them for the vertices a neighbour shares with `slot`.
    #[inline(always)]
    fn scan_neighbours<F: ScalarField>(
        &self,
        f: &F,
        slot: u32,
        ids: &[u32; MAX_META_VERTICES],
        phi: &[f32; MAX_META_VERTICES],
        mut want: impl FnMut(u32) -> bool,
        mut found: impl FnMut(u32, f32),
    ) where
        Self: Sized,
    {
        let _ = (ids, phi);
        self.for_each_neighbour(slot, |nb| {
            if want(nb) {
                found(nb, cell_lo(self, f, nb));
            }
        });
    }
    /// Prefetch hint, issued some cells ahead of processing `slot`: fetches
    /// what the sweep will read for it (vertex positions and attribute; the
    /// S-CGraph adds its neighbours' far vertices). Never changes results.
    #[inline(always)]
    fn prefetch_cell(&self, slot: u32, ctx: &EmitContext) {
        let mut ids = [0u32; MAX_META_VERTICES];
        let (_, n) = self.cell(slot, &mut ids);
        for &v in &ids[..n] {
            prefetch(ctx.positions, v as usize);
            if let Some(a) = ctx.attribute {
                prefetch(a, v as usize);
            }
        }
    }
    /// Id of the cell in `slot` in the input grid's numbering.
    fn source_cell(&self, slot: u32) -> u32;
    /// The range (min, max) of φ over the vertices of live cells, when the
    /// structure can tell it without a scan of every cell: when every cell
    /// is live and every vertex belongs to a cell, it is the range over all
    /// vertices. `None`: the caller scans the live cells.
    fn phi_range_if_all_live<F: ScalarField>(&self, f: &F) -> Option<(f32, f32)>
    where
        Self: Sized,
    {
        let _ = f;
        None
    }
    /// The lattice layout when every cell is a hexahedron with vertex ids
    /// `slot - base + offsets[local]` (the S-CGraph): the sweep then runs a
    /// specialised loop ([`Lattice`]). `None` for general graphs.
    fn lattice(&self) -> Option<Lattice<'_>> {
        None
    }
    /// A structure with a sweep loop of its own (the corner-point graph:
    /// `sweep/cp_loop.rs`) returns itself here; the sweep downcasts it to
    /// the types whose loops it knows. Type-erased so that this trait, below
    /// every structure, names none of them.
    fn own_loop(&self) -> Option<&(dyn std::any::Any + Send + Sync)> {
        None
    }
    /// Splits `0..slot_count` into at most `n` contiguous, roughly equal,
    /// spatially coherent ranges for parallel sweeping.
    fn blocks(&self, n: usize) -> Vec<(u32, u32)> {
        let total = self.slot_count() as u64;
        let n = n.max(1) as u64;
        (0..n)
            .map(|b| ((total * b / n) as u32, (total * (b + 1) / n) as u32))
            .filter(|r| r.0 < r.1)
            .collect()
    }
}

/// Minimum of φ over the vertices of `slot`.
#[inline(always)]
pub fn cell_lo<G: CellGraph + ?Sized, F: ScalarField>(g: &G, f: &F, slot: u32) -> f32 {
    let mut ids = [0u32; MAX_META_VERTICES];
    let (_, n) = g.cell(slot, &mut ids);
    let mut lo = f32::INFINITY;
    for &v in &ids[..n] {
        lo = lo.min(f.phi(v));
    }
    lo
}

/// An implicit hexahedral lattice, for the specialised sweep loop: cell
/// `slot` has first vertex `v0 = slot - base`, vertices
/// `v0 + {0, di} + {0, dj} + {0, dk}` (`deltas = [di, dj, dk]`, with
/// `di = 1`) and face neighbours `slot ± deltas[axis]`. Neighbour slots
/// outside the grid are dead (never-sweep) slots, so no bounds checks.
#[derive(Clone, Copy, Debug)]
pub struct Lattice<'a> {
    /// Vertex count: every live cell's vertex ids are below it.
    pub vertices: usize,
    /// Slot of the cell whose first vertex is 0.
    pub base: u32,
    /// Slot (and vertex id) steps along i, j, k.
    pub deltas: [u32; 3],
    /// Per slot: live (the never-sweep slots are the others).
    pub live: &'a BitSet,
    /// Per slot: live, and so are its 18 face and edge neighbours.
    pub surrounded: &'a BitSet,
    /// The hexahedron's meta-cell.
    pub meta: &'a MetaCell,
    /// Its tables flattened for the lattice's offsets.
    pub table: &'a LatticeHexTable,
}
