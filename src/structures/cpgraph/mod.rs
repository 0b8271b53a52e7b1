//! CP-Graph: the corner-point graph, the S-CGraph generalised to
//! corner-point (Eclipse) grids. Cells live in the *slots* of their IJK
//! lattice, with the S-CGraph's ghost layer (slot of cell (i, j, k):
//! `i + npi·(j + npj·(k + 1))`, `npi = nx + 1`, `npj = ny + 1`), so the six
//! face neighbours are `slot ± 1, ± npi, ± npi·npj` and need no bounds
//! check. Inactive, dropped and hidden cells are dead slots.
//!
//! Vertex ids are the grid's own (welded per pillar by depth, so corners
//! shared across a conforming face are one vertex). A hexahedron keeps an
//! anchor and a *stencil* id: each id is `base[pillar] + anchor +
//! stencil[l]`, so a stencil holds depth-index differences (the grid numbers
//! vertices pillar by pillar), and a few tens of thousands of stencils cover
//! the hexahedra of a faulted million-cell grid (at most 65 535; further
//! ones are stored explicitly). Collapsed cells (wedges, pyramids,
//! tetrahedra, polyhedra) and the convex pieces of split non-convex
//! polyhedra keep their meta-cell and ids explicitly; pieces live in slots
//! after the lattice, without neighbours (each is its own minimum when
//! nothing earlier reaches it). The input cell of a lattice slot is its
//! rank among the slots that hold one.
//!
//! Neighbours come from IJK, not from a vertex → cells map: two live
//! lattice cells adjacent in IJK are *linked* when they share a vertex (one
//! bit per slot and direction). A face with throw (a fault), a collapsed
//! face (pinch-out) or a face of a collapsed cell is an *exception face*;
//! it stays linked when the cells still share a vertex, else the sweep
//! finds the far side from another neighbour or as an extra minimum (see
//! the completeness argument in `sweep/cp_loop.rs`).

use crate::cellgraph::BitSet;
use crate::cellgraph::CellGraph;
use crate::metacell::{Catalog, MAX_META_VERTICES, builtin};
use crate::structures::convex_split::SplitMap;

mod build;
mod ijk;

/// Stencil id of a cell stored explicitly (collapsed cells, pieces, rare
/// stencils).
const EXPLICIT: u16 = u16::MAX;

/// Exact division of u32 values by a fixed divisor (Lemire: multiply by
/// `⌈2⁶⁴ / d⌉`, keep the high 64 bits of the 128-bit product).
#[derive(Clone, Copy, Debug)]
struct Divisor {
    m: u64,
}

impl Divisor {
    fn new(d: u32) -> Self {
        Divisor {
            m: (u64::MAX / d.max(1) as u64).wrapping_add(1),
        }
    }
    #[inline(always)]
    fn quotient(self, n: u32) -> u32 {
        ((self.m as u128 * n as u128) >> 64) as u32
    }
}

/// Counts found while building a [`CpGraph`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CpCounts {
    /// IJK faces between two kept cells (each counted once).
    pub faces: usize,
    /// Those whose two hexahedra share the face's four vertices.
    pub conforming_faces: usize,
    /// The others: faults with throw, pinch-outs, collapsed or split cells.
    pub exception_faces: usize,
    /// Exception faces whose cells still share a vertex (kept as links).
    pub linked_exceptions: usize,
    /// Distinct hexahedron stencils.
    pub stencils: usize,
    /// Hexahedra stored through a stencil.
    pub stencil_cells: usize,
    /// Cells stored explicitly (collapsed cells, pieces, rare stencils).
    pub explicit_cells: usize,
    /// Pieces of split non-convex polyhedra (slots after the lattice).
    pub pieces: usize,
    /// Live input cells (the pieces of a split cell count once).
    pub live_input_cells: usize,
}

/// The corner-point graph.
#[derive(Clone, Debug)]
pub struct CpGraph {
    /// f64 origin of the rebased positions.
    pub origin: [f64; 3],
    /// Rebased f32 positions (the grid's vertices, then the split's new ones).
    pub positions: Vec<[f32; 3]>,
    /// Meta-cell catalog.
    pub catalog: Catalog,
    /// Cells along I, J, K.
    pub dims: [usize; 3],
    /// Slot steps along i, j, k: `1, npi, npi·npj`.
    pub deltas: [u32; 3],
    /// Slots of the lattice (ghost layers included); pieces follow.
    pub lattice_slots: u32,
    live: BitSet,
    /// Per lattice slot: holds an input cell (live or not, split or not).
    /// The input cell of a lattice slot is its rank here: input cells are
    /// the kept IJK cells in IJK order, and slots follow IJK order.
    kept: BitSet,
    /// Per 64-slot word of `kept`: the set bits before it.
    kept_rank: Vec<u32>,
    /// Per piece slot (after the lattice): its input cell.
    piece_cell: Vec<u32>,
    /// Slots in all (lattice and pieces).
    slots: usize,
    /// Per slot: first vertex id (stencil cells) or index into `explicit`.
    anchor: Vec<u32>,
    /// Per slot: stencil id, or [`EXPLICIT`].
    stencil: Vec<u16>,
    /// Per stencil: the eight vertex ids relative to the first (wrapping),
    /// each less its pillar's base.
    stencils: Vec<[u32; 8]>,
    /// Per pillar (`i + npi·j`): the base its vertex ids are coded from.
    base: Vec<u32>,
    /// Per local hexahedron vertex: its pillar's offset from the column's.
    corner_pillar: [u32; 8],
    /// Division by `npi·npj` (slot → pillar).
    slab_div: Divisor,
    /// Explicit cells: meta id, vertex count, ids.
    explicit: Vec<u32>,
    /// Per slot, bit `d` (−i, +i, −j, +j, −k, +k): linked to that neighbour.
    links: Vec<u8>,
    /// Counts of cell classes (see [`crate::structures::CELL_CLASS_NAMES`]).
    pub class_counts: [usize; crate::structures::CELL_CLASS_COUNT],
    /// Cells per meta-cell id.
    pub meta_counts: Vec<usize>,
    /// Hidden cells excluded.
    pub hidden_count: usize,
    /// Face and storage counts.
    pub counts: CpCounts,
    /// The split of non-convex polyhedra the graph was built on.
    pub map: Option<SplitMap>,
}

impl CpGraph {
    /// Live (swept) input cells; the pieces of a split cell count once.
    pub fn live_cells(&self) -> usize {
        self.counts.live_input_cells
    }

    /// Bytes held per part of the structure.
    pub fn bytes(&self) -> Vec<(&'static str, usize)> {
        vec![
            ("positions", self.positions.len() * 12),
            (
                "kept_bits_and_ranks",
                self.kept.bytes() + self.kept_rank.len() * 4,
            ),
            ("piece_input_cells", self.piece_cell.len() * 4),
            ("slot_anchors", self.anchor.len() * 4),
            ("slot_stencil_ids", self.stencil.len() * 2),
            ("slot_links", self.links.len()),
            ("stencils", self.stencils.len() * 32),
            ("pillar_bases", self.base.len() * 4),
            ("explicit_cells", self.explicit.len() * 4),
            ("live_bits", self.live.bytes()),
            ("meta_cell_tables", self.catalog.table_bytes()),
        ]
    }

    /// Linked neighbours of `slot`, as bits (−i, +i, −j, +j, −k, +k).
    pub fn link_bits(&self, slot: u32) -> u8 {
        self.links[slot as usize]
    }

    /// The column (pillar `i + npi·j`) of lattice slot `slot`.
    #[inline(always)]
    fn column(&self, slot: u32) -> u32 {
        slot - self.slab_div.quotient(slot) * self.deltas[2]
    }

    /// Local vertex `l` of the stencil hexahedron with stencil `st` and
    /// anchor `a` in column `p`.
    #[inline(always)]
    fn stencil_vertex(&self, st: &[u32; 8], a: u32, p: u32, l: usize) -> u32 {
        let b = self.base[(p + self.corner_pillar[l]) as usize];
        b.wrapping_add(a).wrapping_add(st[l])
    }

    /// Hints the CPU to fetch the slot's stencil id, anchor and links.
    #[inline(always)]
    pub(crate) fn prefetch_slot(&self, slot: u32) {
        crate::extract::prefetch(&self.stencil, slot as usize);
        crate::extract::prefetch(&self.anchor, slot as usize);
        crate::extract::prefetch(&self.links, slot as usize);
    }

    /// Hints the CPU to fetch what decoding `slot` reads after its own
    /// entries (prefetched first by [`CpGraph::prefetch_slot`]): φ of a
    /// stencil hexahedron's vertices (through `phi`), or an explicit
    /// cell's row.
    #[inline(always)]
    pub(crate) fn prefetch_decode(&self, slot: u32, phi: &[f32]) {
        let s = self.stencil[slot as usize];
        let a = self.anchor[slot as usize];
        if s != EXPLICIT {
            let (st, p) = (&self.stencils[s as usize], self.column(slot));
            // Vertex l + 4 follows vertex l on its pillar: the first four
            // name the cache lines.
            for l in 0..4 {
                crate::extract::prefetch(phi, self.stencil_vertex(st, a, p, l) as usize);
            }
        } else {
            crate::extract::prefetch(&self.explicit, a as usize);
        }
    }

    /// Whether the slot holds a hexahedron stored through a stencil.
    #[inline(always)]
    pub(crate) fn is_stencil_hex(&self, slot: u32) -> bool {
        self.stencil[slot as usize] != EXPLICIT
    }
}

impl CellGraph for CpGraph {
    fn slot_count(&self) -> usize {
        self.slots
    }
    #[inline(always)]
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
        let s = self.stencil[slot as usize];
        let a = self.anchor[slot as usize];
        if s != EXPLICIT {
            let (st, p) = (&self.stencils[s as usize], self.column(slot));
            for (l, o) in out[..8].iter_mut().enumerate() {
                *o = self.stencil_vertex(st, a, p, l);
            }
            return (builtin::HEXAHEDRON, 8);
        }
        let e = a as usize;
        let (m, n) = (self.explicit[e] as u16, self.explicit[e + 1] as usize);
        out[..n].copy_from_slice(&self.explicit[e + 2..e + 2 + n]);
        (m, n)
    }
    #[inline(always)]
    fn for_each_neighbour(&self, slot: u32, mut f: impl FnMut(u32)) {
        let mut bits = self.links[slot as usize];
        while bits != 0 {
            let d = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let delta = self.deltas[d / 2];
            f(if d & 1 == 1 {
                slot + delta
            } else {
                slot - delta
            });
        }
    }
    fn source_cell(&self, slot: u32) -> u32 {
        if slot >= self.lattice_slots {
            return self.piece_cell[(slot - self.lattice_slots) as usize];
        }
        let w = slot as usize / 64;
        let below = self.kept.word_at(64 * w as i64) & ((1u64 << (slot % 64)) - 1);
        self.kept_rank[w] + below.count_ones()
    }
    fn own_loop(&self) -> Option<&(dyn std::any::Any + Send + Sync)> {
        Some(self)
    }
}
