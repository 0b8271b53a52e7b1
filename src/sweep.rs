//! The incremental sweep (DESIGN §3) over any [`CellGraph`]: two queues
//! (active and swept), per-cell step stamps, minima sorted by `(lo, id)` and
//! cached per axis direction, output into a caller-owned [`LevelMesh`].

use rayon::prelude::*;

use crate::extract::{EmitContext, HexWriter, LevelMesh, code_of, emit_cell, intersects, prefetch};
use crate::field::ScalarField;
use crate::lattice::{EdgeOwnership, EdgeWindow, LatticeHexTable};
use crate::metacell::{Catalog, MAX_META_VERTICES, MetaCell};
use crate::structure::BitSet;

mod chunks;
mod cp_loop;

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
    /// The corner-point graph, when this is one: the sweep then runs its
    /// own loop (`sweep/cp_loop.rs`).
    fn cpgraph(&self) -> Option<&crate::cpgraph::CpGraph> {
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

/// Minimum of φ over the vertices of `slot`, with the vertex φ values in `phi`.
#[inline(always)]
fn load_phi<G: CellGraph, F: ScalarField>(
    g: &G,
    f: &F,
    slot: u32,
    ids: &mut [u32; MAX_META_VERTICES],
    phi: &mut [f32; MAX_META_VERTICES],
) -> (u16, usize, f32, f32) {
    let (m, n) = g.cell(slot, ids);
    let mut lo = f32::INFINITY;
    let mut hi = f32::NEG_INFINITY;
    for i in 0..n {
        let p = f.phi(ids[i]);
        phi[i] = p;
        lo = lo.min(p);
        hi = hi.max(p);
    }
    (m, n, lo, hi)
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

/// How many work-queue entries ahead [`CellGraph::prefetch_cell`] is issued.
const PREFETCH_AHEAD: usize = 2;

/// A minimum: a cell with no predecessor, with its `lo`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Minimum {
    /// min φ over the cell.
    pub lo: f32,
    /// Slot.
    pub slot: u32,
}

/// Per-level statistics of one sweep step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LevelStats {
    /// Intersected cells.
    pub cells: u64,
    /// Cells popped from the work queue (intersected + swept).
    pub visited: u64,
    /// Polygons emitted.
    pub polygons: u64,
    /// Triangles of their fan triangulation.
    pub triangles: u64,
    /// Total area.
    pub area: f64,
}

impl LevelStats {
    /// The figures of one level's output `mesh`, with `visited` cells popped.
    pub fn of(mesh: &LevelMesh, visited: u64) -> Self {
        LevelStats {
            cells: mesh.cut_cells as u64,
            visited,
            polygons: mesh.polygon_count() as u64,
            triangles: mesh.accumulated_triangles() as u64,
            area: mesh.accumulated_area(),
        }
    }
    /// Adds another block's figures.
    pub fn add(&mut self, o: &LevelStats) {
        self.cells += o.cells;
        self.visited += o.visited;
        self.polygons += o.polygons;
        self.triangles += o.triangles;
        self.area += o.area;
    }
}

/// One spatial block's sweep state: its slot range, stamps, the two queues,
/// its cached minima and its reusable output buffer.
#[derive(Debug)]
pub struct Block {
    start: u32,
    stamps: Vec<Stamp>,
    step: Stamp,
    /// Stamp of the cells swept out in the current sweep (`hi` below the
    /// level of the step that popped them): never cut again, skipped by
    /// the neighbour scans. Every step of the sweep is below it.
    done: Stamp,
    work: Vec<u32>,
    active: Vec<u32>,
    /// Scratch for [`radix_sort_slots`].
    sort_scratch: Vec<u32>,
    minima_cache: [Option<Vec<Minimum>>; 6],
    /// The block's reusable output buffer.
    pub mesh: LevelMesh,
    /// Weld table of the lattice loop.
    window: EdgeWindow,
    /// Queues of the lattice loop.
    lattice: LatticeQueues,
    /// State of the chunked lattice loop.
    chunked: chunks::ChunkQueues,
}

/// The lattice loop's queues, kept between sweeps for their capacity.
#[derive(Debug, Default)]
struct LatticeQueues {
    /// Per level k: the cells that enter at step k (`t_{k-1} <= lo < t_k`),
    /// in the order they were found.
    entering: Vec<Vec<u32>>,
    /// `A_k` in slot order, each cell packed with the last level that cuts
    /// it ([`pack_active`]).
    active: Vec<u64>,
    /// The cells entering at this step that the level cuts, packed.
    fresh: Vec<u64>,
    /// Scratch for sorting `fresh` and merging it into `active`.
    scratch: Vec<u64>,
    /// Per block slot, one bit: dead (never swept), or found in this
    /// sweep. Reset from the lattice's live bits when a sweep starts. One
    /// bit per slot instead of the u16 stamps keeps a level's neighbour
    /// tests in cache.
    seen: Vec<u64>,
}

impl LatticeQueues {
    /// Bytes held.
    fn bytes(&self) -> usize {
        self.entering
            .iter()
            .map(|q| q.capacity() * 4)
            .sum::<usize>()
            + (self.active.capacity()
                + self.fresh.capacity()
                + self.scratch.capacity()
                + self.seen.capacity())
                * 8
    }

    /// Starts a sweep over the block of `len` slots from `start`: every
    /// slot is unseen but the dead ones (the complement of `live`).
    fn begin_sweep(&mut self, live: &BitSet, start: u32, len: usize) {
        self.seen.clear();
        self.seen
            .extend((0..len.div_ceil(64)).map(|w| !live.word_at(start as i64 + 64 * w as i64)));
    }
}

/// Sets bit `j` of `bits`; returns whether it was clear.
#[inline(always)]
fn set_bit(bits: &mut [u64], j: u32) -> bool {
    let w = &mut bits[j as usize / 64];
    let m = 1u64 << (j % 64);
    let was_clear = *w & m == 0;
    *w |= m;
    was_clear
}

/// A cell of the lattice loop's active queue: its slot in the high half
/// (so sorting by value sorts by slot), the last level index that cuts it
/// in the low half.
#[inline(always)]
fn pack_active(slot: u32, last: usize) -> u64 {
    (slot as u64) << 32 | last as u64
}

impl Block {
    /// Starts a sweep of `levels` levels: picks the stamp that marks cells
    /// swept out for good (above every step of this sweep, below every
    /// step of the next), restarting the stamps when they run out.
    fn begin_sweep(&mut self, levels: usize) {
        // Steps start above the last sweep's swept-out mark, so that no
        // cell it swept out looks examined at a step of this one.
        self.step = self.step.max(self.done);
        if self.step as usize + levels + 2 >= NEVER as usize {
            for s in self.stamps.iter_mut().filter(|s| **s != NEVER) {
                *s = 0;
            }
            self.step = 0;
        }
        self.done = (self.step as usize + levels + 1).min(NEVER as usize - 1) as Stamp;
    }

    /// Starts the step of level `t`: the work queue becomes `A_{k-1}` plus
    /// the minima with `lo < t` (advancing `next_min`), all stamped with the
    /// returned step; the active queue and the output buffer are emptied.
    fn begin_level(&mut self, minima: &[Minimum], next_min: &mut usize, t: f32) -> Stamp {
        if self.step + 1 >= self.done {
            // Out of stamps within one sweep (more than 65 532 levels):
            // restart the steps, keeping the swept-out marks.
            let done = self.done;
            for s in self
                .stamps
                .iter_mut()
                .filter(|s| **s != NEVER && **s != done)
            {
                *s = 0;
            }
            self.step = 0;
        }
        self.step += 1;
        let step = self.step;
        let start = self.start;
        // The work queue starts with A_{k-1}...
        std::mem::swap(&mut self.work, &mut self.active);
        self.active.clear();
        // Stamp A_{k-1} now: those cells are already queued, and as their
        // lo < t_{k-1} no neighbour scan would push them again, so stamping
        // them only spares the scans from recomputing their lo.
        for &c in &self.work {
            self.stamps[(c - start) as usize] = step;
        }
        // ...plus the minima with t_{k-1} <= lo < t_k.
        while *next_min < minima.len() && minima[*next_min].lo < t {
            let m = minima[*next_min];
            self.stamps[(m.slot - start) as usize] = step;
            self.work.push(m.slot);
            *next_min += 1;
        }
        self.mesh.clear();
        step
    }

    /// Bytes of sweep state (stamps, queues, minima, output buffer).
    pub fn bytes(&self) -> usize {
        self.stamps.len() * std::mem::size_of::<Stamp>()
            + (self.work.capacity() + self.active.capacity() + self.sort_scratch.capacity()) * 4
            + self
                .minima_cache
                .iter()
                .flatten()
                .map(|m| m.capacity() * 8)
                .sum::<usize>()
            + self.mesh.capacity_bytes()
            + self.window.bytes()
            + self.lattice.bytes()
            + self.chunked.bytes()
    }
}

/// Runs sweeps over a [`CellGraph`], split into spatial blocks (one per thread).
pub struct Sweeper<'g, G: CellGraph> {
    graph: &'g G,
    /// Blocks, each swept independently.
    pub blocks: Vec<Block>,
}

impl<'g, G: CellGraph> Sweeper<'g, G> {
    /// A sweeper with `threads` blocks (1 = the plain single-threaded sweep).
    pub fn new(graph: &'g G, threads: usize) -> Self {
        let init = graph.initial_stamps();
        let blocks = graph
            .blocks(threads)
            .into_iter()
            .map(|(a, b)| Block {
                start: a,
                stamps: init[a as usize..b as usize].to_vec(),
                step: 0,
                done: 0,
                work: Vec::new(),
                active: Vec::new(),
                sort_scratch: Vec::new(),
                minima_cache: Default::default(),
                mesh: LevelMesh::default(),
                window: EdgeWindow::default(),
                lattice: LatticeQueues::default(),
                chunked: Default::default(),
            })
            .collect();
        Sweeper { graph, blocks }
    }

    /// Bytes of sweep state over all blocks.
    pub fn state_bytes(&self) -> usize {
        self.blocks.iter().map(Block::bytes).sum()
    }

    /// Computes (or fetches from the per-axis cache, when `axis_slot` is given)
    /// the sorted minima of every block. Returns the total count.
    pub fn prepare_minima<F: ScalarField>(&mut self, field: &F, axis_slot: Option<usize>) -> usize {
        let g = self.graph;
        self.blocks
            .par_iter_mut()
            .map(|b| {
                let slot = axis_slot.unwrap_or(0);
                if axis_slot.is_none() || b.minima_cache[slot].is_none() {
                    b.minima_cache[slot] = Some(block_minima(g, field, b));
                }
                b.minima_cache[slot].as_ref().map_or(0, Vec::len)
            })
            .sum()
    }

    /// Sweeps all `levels` (strictly increasing, local frame). For every block
    /// and level, `on_level(block, level, &mesh, &stats)` is called with the
    /// block's reused output buffer; `make_acc` builds one accumulator per
    /// block, returned in block order. Call [`Sweeper::prepare_minima`] first
    /// with the same field (and `axis_slot`).
    pub fn sweep<F, A, M, L>(
        &mut self,
        field: &F,
        axis_slot: Option<usize>,
        levels: &[f32],
        ctx: &EmitContext,
        make_acc: M,
        on_level: L,
    ) -> Vec<A>
    where
        F: ScalarField,
        A: Send,
        M: Fn() -> A + Sync,
        L: Fn(&mut A, usize, &LevelMesh, &LevelStats) + Sync,
    {
        let g = self.graph;
        let slot = axis_slot.unwrap_or(0);
        self.blocks
            .par_iter_mut()
            .map(|b| {
                let mut acc = make_acc();
                let minima = b.minima_cache[slot]
                    .take()
                    .unwrap_or_else(|| block_minima(g, field, b));
                sweep_block(g, field, b, &minima, levels, ctx, |k, mesh, st| {
                    on_level(&mut acc, k, mesh, st)
                });
                if axis_slot.is_some() {
                    b.minima_cache[slot] = Some(minima);
                }
                acc
            })
            .collect()
    }
}

/// Sorted minima of one block: cells with no predecessor among the block's cells.
fn block_minima<G: CellGraph, F: ScalarField>(g: &G, f: &F, b: &Block) -> Vec<Minimum> {
    if let (Some(lat), Some(phi)) = (g.lattice(), f.values()) {
        return block_minima_lattice(&lat, phi, b);
    }
    block_minima_generic(g, f, b)
}

/// [`block_minima`] for any graph: each cell's `lo` from [`cell_lo`], then
/// its in-block neighbours compared.
fn block_minima_generic<G: CellGraph, F: ScalarField>(g: &G, f: &F, b: &Block) -> Vec<Minimum> {
    let len = b.stamps.len() as u32;
    let lo: Vec<f32> = (0..len)
        .map(|i| {
            if b.stamps[i as usize] == NEVER {
                f32::INFINITY
            } else {
                cell_lo(g, f, b.start + i)
            }
        })
        .collect();
    let mut out = Vec::new();
    for i in 0..len {
        if b.stamps[i as usize] == NEVER {
            continue;
        }
        let key = (lo[i as usize], i);
        let mut has_pred = false;
        g.for_each_neighbour(b.start + i, |n| {
            let j = n.wrapping_sub(b.start);
            if j < len && b.stamps[j as usize] != NEVER {
                let nk = (lo[j as usize], j);
                if nk.0 < key.0 || (nk.0 == key.0 && nk.1 < key.1) {
                    has_pred = true;
                }
            }
        });
        if !has_pred {
            out.push(Minimum {
                lo: key.0,
                slot: b.start + i,
            });
        }
    }
    out.sort_unstable_by(|a, b| a.lo.total_cmp(&b.lo).then(a.slot.cmp(&b.slot)));
    out
}

/// [`block_minima`] on a hexahedral [`Lattice`] with φ per vertex: the same
/// minima (a cell is one when no live in-block face neighbour has a smaller
/// `(lo, slot)`), with each cell's `lo` taken from two per-layer tables of
/// 2×2 vertex minima instead of an 8-vertex gather per cell, one k-slab at
/// a time (three slabs of `lo` and two of vertex minima live at once).
fn block_minima_lattice(lat: &Lattice, phi: &[f32], b: &Block) -> Vec<Minimum> {
    let npi = lat.deltas[1] as usize;
    let slab = lat.deltas[2] as usize;
    let layers = lat.vertices / slab;
    let start = b.start as usize;
    let (first, count) = (start / slab, b.stamps.len() / slab);
    debug_assert!(start.is_multiple_of(slab) && b.stamps.len().is_multiple_of(slab));
    // Dead and out-of-block slots hold NaN: every comparison with NaN is
    // false, so they are never predecessors.
    let nan = f32::NAN;
    // Vertex layer `kk`: per vertex, the min over its 2×2 (i, j) square
    // (only where that square is a cell's face; other entries are unused).
    let quad = |kk: usize, q: &mut Vec<f32>| {
        q.clear();
        q.resize(slab, nan);
        if kk < layers && slab > npi + 1 {
            let p = &phi[kk * slab..(kk + 1) * slab];
            for x in 0..slab - npi - 1 {
                q[x] = fmin(fmin(p[x], p[x + 1]), fmin(p[x + npi], p[x + npi + 1]));
            }
        }
    };
    // lo of every slot of slot-slab `z` (its cells lie on vertex layers
    // z - 1 and z, whose square minima are `below` and `above`).
    let lo_of = |z: usize, below: &[f32], above: &[f32], out: &mut Vec<f32>| {
        out.clear();
        out.resize(slab, nan);
        if z < first || z >= first + count {
            return;
        }
        let st = &b.stamps[(z - first) * slab..(z - first + 1) * slab];
        for x in 0..slab {
            if st[x] != NEVER {
                out[x] = fmin(below[x], above[x]);
            }
        }
    };
    let (mut q_below, mut q_above) = (Vec::new(), Vec::new());
    let (mut prev, mut cur, mut next) = (Vec::new(), Vec::new(), Vec::new());
    // Slot-slab z's cells sit on vertex layer z - 1 (the slot of the cell
    // with first vertex v is v + slab).
    quad(first.wrapping_sub(1), &mut q_below);
    quad(first, &mut q_above);
    lo_of(first.wrapping_sub(1), &[], &[], &mut prev);
    lo_of(first, &q_below, &q_above, &mut cur);
    let mut out = Vec::new();
    for z in first..first + count {
        std::mem::swap(&mut q_below, &mut q_above);
        quad(z + 1, &mut q_above);
        lo_of(z + 1, &q_below, &q_above, &mut next);
        let st = &b.stamps[(z - first) * slab..(z - first + 1) * slab];
        for x in 0..slab {
            if st[x] == NEVER {
                continue;
            }
            let l = cur[x];
            // Lower slots win ties (<=), higher ones need a strictly smaller lo.
            let pred = (x > 0 && cur[x - 1] <= l)
                | (x + 1 < slab && cur[x + 1] < l)
                | (x >= npi && cur[x - npi] <= l)
                | (x + npi < slab && cur[x + npi] < l)
                | (prev[x] <= l)
                | (next[x] < l);
            if !pred {
                out.push(Minimum {
                    lo: l,
                    slot: (z * slab + x) as u32,
                });
            }
        }
        std::mem::swap(&mut prev, &mut cur);
        std::mem::swap(&mut cur, &mut next);
    }
    out.sort_unstable_by(|a, b| a.lo.total_cmp(&b.lo).then(a.slot.cmp(&b.slot)));
    out
}

#[inline(never)]
fn sweep_block<G: CellGraph, F: ScalarField>(
    g: &G,
    f: &F,
    b: &mut Block,
    minima: &[Minimum],
    levels: &[f32],
    ctx: &EmitContext,
    mut on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
) {
    if let Some(cp) = g.cpgraph() {
        cp_loop::sweep_block_cp(cp, f, b, minima, levels, ctx, on_level);
        return;
    }
    if let (Some(lat), Some(phi)) = (g.lattice(), f.values()) {
        if std::env::var_os("STRATASWEEP_CELL_LOOP").is_some() || levels.len() > chunks::MAX_LEVELS
        {
            sweep_block_lattice(&lat, phi, b, minima, levels, ctx, false, on_level);
        } else {
            chunks::sweep_block_chunks(&lat, phi, b, minima, levels, ctx, false, on_level);
        }
        return;
    }
    let catalog = g.catalog();
    let start = b.start;
    let len = b.stamps.len() as u32;
    b.work.clear();
    b.active.clear();
    b.begin_sweep(levels.len());
    let done = b.done;
    let mut next_min = 0;
    let mut t_prev = f32::NEG_INFINITY;
    let mut ids = [0u32; MAX_META_VERTICES];
    let mut phi = [0f32; MAX_META_VERTICES];
    for (k, &t) in levels.iter().enumerate() {
        let step = b.begin_level(minima, &mut next_min, t);
        let mut i = 0;
        while i < b.work.len() {
            let c = b.work[i];
            if let Some(&ahead) = b.work.get(i + PREFETCH_AHEAD) {
                g.prefetch_cell(ahead, ctx);
            }
            i += 1;
            let (m, n, lo, hi) = load_phi(g, f, c, &mut ids, &mut phi);
            debug_assert!(lo < t, "queued cells have lo below the level");
            if !intersects(lo, hi, t) {
                // hi < t: swept out for good.
                b.stamps[(c - start) as usize] = done;
            } else {
                b.active.push(c);
                let code = code_of(&phi[..n], t);
                emit_cell(
                    catalog.get(m),
                    &ids[..n],
                    &phi[..n],
                    t,
                    code,
                    c,
                    ctx,
                    &mut b.mesh,
                );
            }
            let stamps = &mut b.stamps;
            let work = &mut b.work;
            g.scan_neighbours(
                f,
                c,
                &ids,
                &phi,
                |nb| {
                    let j = nb.wrapping_sub(start);
                    // Stamp every neighbour examined, pushed or not: whether it
                    // belongs to this step depends only on its own lo, so each
                    // cell's lo is evaluated at most once per step.
                    if j < len && stamps[j as usize] < step {
                        stamps[j as usize] = step;
                        true
                    } else {
                        false
                    }
                },
                |nb, lo_n| {
                    if lo_n >= t_prev && lo_n < t {
                        work.push(nb);
                    }
                },
            );
        }
        let stats = LevelStats::of(&b.mesh, b.work.len() as u64);
        on_level(k, &b.mesh, &stats);
        // As in the lattice loop: the next step visits A_k in slot order.
        radix_sort_slots(&mut b.active, &mut b.sort_scratch, start, len);
        t_prev = t;
    }
}

/// φ of the lattice cell with first vertex `v0` in geometric order
/// (`g = i + 2j + 4k`): four (i, i+1) pairs, rows `dj` and layers `dk` apart.
///
/// # Safety
/// `v0 + dj + dk + 1` must be a vertex (< `phi.len()`).
#[inline(always)]
unsafe fn load8(phi: &[f32], v0: u32, dj: u32, dk: u32) -> [f32; 8] {
    let p = phi.as_ptr();
    let pair = |v: u32| {
        // SAFETY: the caller guarantees v + 1 < phi.len().
        unsafe { [*p.add(v as usize), *p.add(v as usize + 1)] }
    };
    let [a, b, c, d] = [pair(v0), pair(v0 + dj), pair(v0 + dk), pair(v0 + dj + dk)];
    [a[0], a[1], b[0], b[1], c[0], c[1], d[0], d[1]]
}

/// [`sweep_block`] specialised for a hexahedral [`Lattice`] with φ stored
/// per vertex: the same cut cells `A_k` and output (tests compare it with
/// the generic loop and the brute force), but each cell is read once, at
/// its entry level, and stays in `A` until the last level below its `hi`
/// (see [`LatticeQueues`]). Polygons are welded by edge ownership
/// ([`crate::lattice`]), or by the mesh's hash map when `hash_weld` is set
/// or the lattice's layers are too large for the weld window. Cells are
/// read in geometric vertex order (`g = i + 2j + 4k`, see
/// [`LatticeHexTable`]), so faces, neighbours and far vertices are
/// constants of the lattice.
#[inline(never)]
fn sweep_block_lattice(
    lat: &Lattice,
    phi: &[f32],
    b: &mut Block,
    minima: &[Minimum],
    levels: &[f32],
    ctx: &EmitContext,
    hash_weld: bool,
    mut on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
) {
    let start = b.start;
    let [di, dj, dk] = lat.deltas;
    debug_assert_eq!(
        lat.table.geometric_offsets(),
        [0, di, dj, dj + di, dk, dk + di, dk + dj, dk + dj + di]
    );
    // Every live cell's vertices, and those of its live neighbours, are
    // below `lat.vertices`: this one check makes the unchecked φ reads
    // below sound.
    assert!(
        phi.len() >= lat.vertices,
        "φ has {} values for {} vertices",
        phi.len(),
        lat.vertices
    );
    // SAFETY (for `at` and `cell`): callers pass vertex ids of a live cell,
    // or of a live neighbour (not in `seen`, so not a never-sweep slot),
    // all < lat.vertices.
    let at = |v: u32| unsafe { *phi.get_unchecked(v as usize) };
    let cell = |c: u32| unsafe { load8(phi, c - lat.base, dj, dk) };
    let owner = EdgeOwnership::new(dj, dk / dj);
    let own_weld = owner.fits && !hash_weld;
    if own_weld {
        b.window.fit(&owner);
    }
    let n = levels.len();
    let Block {
        stamps,
        mesh,
        window,
        lattice: q,
        sort_scratch,
        ..
    } = b;
    let len = stamps.len() as u32;
    q.begin_sweep(lat.live, start, len as usize);
    let LatticeQueues {
        entering,
        active,
        fresh,
        scratch,
        seen,
        ..
    } = q;
    if entering.len() < n {
        entering.resize_with(n, Vec::new);
    }
    for e in &mut entering[..n] {
        e.clear();
    }
    active.clear();
    // Each cell is queued once, at the step where the level first passes
    // its lo: the minima now, every other cell by the first neighbour
    // that enters (see ARCHITECTURE.md, "entry levels"). A cell is marked
    // in `seen` when it is queued.
    for m in minima {
        let l = levels.partition_point(|&t| t <= m.lo);
        if l < n && set_bit(seen, m.slot - start) {
            entering[l].push(m.slot);
        }
    }
    for (k, &t) in levels.iter().enumerate() {
        mesh.clear();
        // The cells queued for this step by earlier ones, read in slot
        // order (warped 256³: 3–5 % faster than in the order found); the
        // ones found during the step follow.
        let mut work = std::mem::take(&mut entering[k]);
        radix_sort_slots(&mut work, sort_scratch, start, len);
        fresh.clear();
        let mut i = 0;
        while i < work.len() {
            let c = work[i];
            if let Some(&ahead) = work.get(i + 2 * PREFETCH_AHEAD) {
                // The four φ rows of the cell four entries ahead, the seen
                // words of its k neighbours (the i and j ones share or
                // neighbour its word), and the φ rows of their far faces.
                let v = ahead - lat.base;
                for r in [v, v + dj, v + dk, v + dj + dk] {
                    prefetch(phi, r as usize);
                }
                for nb in [ahead - dk, ahead + dk] {
                    prefetch(seen, nb.wrapping_sub(start) as usize / 64);
                }
                for r in [
                    v.wrapping_sub(dk),
                    (v + dj).wrapping_sub(dk),
                    v + 2 * dk,
                    v + dj + 2 * dk,
                    v.wrapping_sub(dj),
                    (v + dk).wrapping_sub(dj),
                    v + 2 * dj,
                    v + 2 * dj + dk,
                ] {
                    prefetch(phi, r as usize);
                }
            }
            i += 1;
            let v0 = c - lat.base;
            let f = cell(c);
            // Per (i, j) column the min over k; then each face's min.
            let col = [0, 1, 2, 3].map(|q| fmin(f[q], f[q + 4]));
            let face = [
                fmin(col[0], col[2]),
                fmin(col[1], col[3]),
                fmin(col[0], col[1]),
                fmin(col[2], col[3]),
                fmin(fmin(f[0], f[1]), fmin(f[2], f[3])),
                fmin(fmin(f[4], f[5]), fmin(f[6], f[7])),
            ];
            let hi = max8(&f);
            debug_assert!(
                fmin(face[4], face[5]) < t && (k == 0 || fmin(face[4], face[5]) >= levels[k - 1]),
                "a cell is read at its entry level"
            );
            if t <= hi {
                // Cut from this level through every level up to hi: the
                // cell stays in A until then without being read again.
                let mut last = k;
                while last + 1 < n && levels[last + 1] <= hi {
                    last += 1;
                }
                fresh.push(pack_active(c, last));
            }
            // The six neighbours, unrolled. A new one is queued at its
            // entry level: this step when the shared face dips below t,
            // else from its lo (the min of the shared face and of its 4
            // far vertices `far + {0, e1, e2, e1 + e2}`). Its lo is at
            // least t_{k-1}: every cell with a lower lo was found by the
            // end of the previous step.
            macro_rules! visit {
                ($nb:expr, $face:expr, $far:expr, $e1:expr, $e2:expr) => {{
                    let nb: u32 = $nb;
                    let shared = face[$face];
                    let j = nb.wrapping_sub(start);
                    if j < len && set_bit(seen, j) {
                        let far: u32 = $far;
                        let lo = if shared < t {
                            shared
                        } else {
                            fmin(
                                shared,
                                fmin(
                                    fmin(at(far), at(far + $e1)),
                                    fmin(at(far + $e2), at(far + $e1 + $e2)),
                                ),
                            )
                        };
                        if lo < t {
                            work.push(nb);
                        } else {
                            let mut l = k + 1;
                            while l < n && levels[l] <= lo {
                                l += 1;
                            }
                            if l < n {
                                entering[l].push(nb);
                            }
                        }
                    }
                }};
            }
            visit!(c - di, 0, v0.wrapping_sub(di), dj, dk);
            visit!(c + di, 1, v0 + 2 * di, dj, dk);
            visit!(c - dj, 2, v0.wrapping_sub(dj), di, dk);
            visit!(c + dj, 3, v0 + 2 * dj, di, dk);
            visit!(c - dk, 4, v0.wrapping_sub(dk), di, dj);
            visit!(c + dk, 5, v0 + 2 * dk, di, dj);
        }
        let entered = work.len();
        work.clear();
        entering[k] = work;
        // A_k in slot order: the cells of A_{k-1} still cut (already in
        // order) merged with this step's cut entries (sorted). This level's
        // polygons are emitted in that order (the weld by ownership needs
        // it, and consecutive cells share cache lines of φ, positions and
        // the weld window).
        radix_sort_by_slot(fresh, scratch, start, len, |x| (x >> 32) as u32);
        let carried = active.len();
        merge_active(active, fresh, k, scratch);
        std::mem::swap(active, scratch);
        let slot_of = |x: u64| (x >> 32) as u32;
        let weld = own_weld.then_some(&owner);
        emit_cut_cells(
            lat, phi, active, slot_of, start, len, t, ctx, weld, mesh, window,
        );
        // Visited: the cells read at this step (entries) and the queue of
        // A_{k-1} filtered by each cell's last level.
        let stats = LevelStats::of(mesh, (entered + carried) as u64);
        on_level(k, mesh, &stats);
    }
}

/// Emits level `t`'s polygons of a block's cut cells `cut` (slots
/// `slot_of(x)`, ascending; the block has `len` slots from `start`) into
/// `mesh`, welded by edge ownership through `window` when `owner` is given,
/// else by the mesh's hash map. With [`EmitContext::cells_only`] it records
/// only the cells.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn emit_cut_cells<T: Copy>(
    lat: &Lattice,
    phi: &[f32],
    cut: &[T],
    slot_of: impl Fn(T) -> u32,
    start: u32,
    len: u32,
    t: f32,
    ctx: &EmitContext,
    owner: Option<&EdgeOwnership>,
    mesh: &mut LevelMesh,
    window: &mut EdgeWindow,
) {
    let [di, dj, dk] = lat.deltas;
    if ctx.cells_only {
        mesh.cells.extend(cut.iter().map(|&x| slot_of(x)));
        mesh.cut_cells = cut.len() as u32;
        return;
    }
    // The vertex rows (φ, positions and attribute) of the cell some
    // entries ahead of the n-th.
    let prefetch_ahead = |n: usize| {
        if let Some(&ahead) = cut.get(n + 4 * PREFETCH_AHEAD) {
            let v = slot_of(ahead) - lat.base;
            for r in [v, v + dj, v + dk, v + dj + dk] {
                prefetch(phi, r as usize);
                prefetch(ctx.positions, r as usize);
                if let Some(a) = ctx.attribute {
                    prefetch(a, r as usize);
                }
            }
        }
    };
    // SAFETY (for `load`): `c` is a live cell, whose vertices are <
    // lat.vertices <= phi.len() (checked by the callers).
    let load = |c: u32| unsafe { load8(phi, c - lat.base, dj, dk) };
    let Some(owner) = owner else {
        for (n, &x) in cut.iter().enumerate() {
            prefetch_ahead(n);
            let c = slot_of(x);
            let f = load(c);
            lat.table
                .emit_hashed(lat.meta, c - lat.base, &f, t, c, ctx, mesh);
        }
        return;
    };
    // The emitter reads the attribute of the cells' vertices unchecked.
    assert!(
        ctx.attribute.is_none_or(|a| a.len() >= lat.vertices),
        "the attribute has fewer values than the lattice has vertices"
    );
    // Every lower neighbour is within this many slots.
    let reach = dk + dj + di;
    // Which earlier edge neighbours of cell c are live cells of this block
    // (they own the edges they share with it): all of them for a
    // surrounded cell away from the block's ends.
    let live_lower = |c: u32| {
        let inner = c.wrapping_sub(start).wrapping_sub(reach) < len.saturating_sub(2 * reach);
        if inner && lat.surrounded.get(c as usize) {
            511
        } else {
            let mut live = 0u32;
            for (n, &step) in owner.lower_steps.iter().enumerate() {
                let j = c.wrapping_add(step).wrapping_sub(start);
                let alive = j < len && lat.live.get(c.wrapping_add(step) as usize);
                live |= (alive as u32) << n;
            }
            live
        }
    };
    // Batches of cells written without capacity checks; a cell with an
    // ambiguous face ends its batch and is written through the mesh.
    let mut n = 0;
    while n < cut.len() {
        let batch = (cut.len() - n).min(1024);
        let mut out = HexWriter::new(mesh, batch);
        let end = n + batch;
        let mut ambiguous = None;
        while n < end {
            prefetch_ahead(n);
            let c = slot_of(cut[n]);
            n += 1;
            let f = load(c);
            let code = code8(&f, t);
            let live = live_lower(c);
            let v0 = c - lat.base;
            if !lat
                .table
                .emit(v0, &f, t, code, owner, live, c, ctx, &mut out, window)
            {
                ambiguous = Some((c, f, code, live));
                break;
            }
        }
        drop(out);
        if let Some((c, f, code, live)) = ambiguous {
            lat.table.emit_ambiguous(
                lat.meta,
                c - lat.base,
                &f,
                t,
                code,
                live,
                owner,
                c,
                ctx,
                mesh,
                window,
            );
        }
    }
}

/// Writes into `out` the cells of `carried` (`A_{k-1}`, packed by
/// [`pack_active`], in slot order) still cut at level `k`, merged in slot
/// order with `fresh` (sorted; no slot in both).
fn merge_active(carried: &[u64], fresh: &[u64], k: usize, out: &mut Vec<u64>) {
    out.clear();
    out.reserve(carried.len() + fresh.len());
    let mut f = fresh.iter().copied().peekable();
    for &a in carried {
        if (a as u32 as usize) < k {
            continue;
        }
        while let Some(&b) = f.peek() {
            if b > a {
                break;
            }
            out.push(b);
            f.next();
        }
        out.push(a);
    }
    out.extend(f);
}

/// Sorts `slots` (all in `start..start + len`) ascending with an LSD radix
/// sort over `slot - start` ([`radix_sort_by_slot`]).
fn radix_sort_slots(slots: &mut Vec<u32>, scratch: &mut Vec<u32>, start: u32, len: u32) {
    radix_sort_by_slot(slots, scratch, start, len, |c| c);
}

/// Sorts `items` by `slot(item)` (all in `start..start + len`, distinct)
/// with an LSD radix sort over `slot - start`, in as few passes of at most
/// 13-bit digits as the key range needs (two for up to 2²⁶ slots);
/// `scratch` is reused. Short lists take a comparison sort.
fn radix_sort_by_slot<T: Copy + Default>(
    items: &mut Vec<T>,
    scratch: &mut Vec<T>,
    start: u32,
    len: u32,
    slot: impl Fn(T) -> u32,
) {
    const MAX_BITS: u32 = 13;
    if items.len() < 2 {
        return;
    }
    if items.len() < 1024 {
        items.sort_unstable_by_key(|&x| slot(x));
        return;
    }
    let key_bits = 32 - len.saturating_sub(1).leading_zeros();
    let passes = key_bits.div_ceil(MAX_BITS).max(1);
    let bits = key_bits.div_ceil(passes);
    let mask = (1usize << bits) - 1;
    scratch.clear();
    scratch.resize(items.len(), T::default());
    let mut buckets = [0u32; 1 << MAX_BITS];
    let count = &mut buckets[..1 << bits];
    let mut shift = 0;
    while shift < key_bits {
        count.fill(0);
        for &c in items.iter() {
            count[((slot(c) - start) >> shift) as usize & mask] += 1;
        }
        let mut sum = 0;
        for n in count.iter_mut() {
            let here = *n;
            *n = sum;
            sum += here;
        }
        for &c in items.iter() {
            let d = ((slot(c) - start) >> shift) as usize & mask;
            scratch[count[d] as usize] = c;
            count[d] += 1;
        }
        std::mem::swap(items, scratch);
        shift += bits;
    }
}

/// min of two non-NaN values (one `minss`; φ is never NaN).
#[inline(always)]
fn fmin(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// max of eight non-NaN values.
#[inline(always)]
fn max8(f: &[f32; 8]) -> f32 {
    let m = |a: f32, b: f32| if a > b { a } else { b };
    m(
        m(m(f[0], f[1]), m(f[2], f[3])),
        m(m(f[4], f[5]), m(f[6], f[7])),
    )
}

/// [`code_of`] for eight values: bit q set iff `f[q] >= t`.
#[inline(always)]
fn code8(f: &[f32; 8], t: f32) -> usize {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE is part of the x86_64 baseline; the loads read the
        // 8 floats of `f` (unaligned loads).
        unsafe {
            let tt = _mm_set1_ps(t);
            let a = _mm_loadu_ps(f.as_ptr());
            let b = _mm_loadu_ps(f.as_ptr().add(4));
            let ma = _mm_movemask_ps(_mm_cmpge_ps(a, tt)) as usize;
            let mb = _mm_movemask_ps(_mm_cmpge_ps(b, tt)) as usize;
            ma | mb << 4
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    code_of(f, t)
}

#[cfg(test)]
mod tests {
    use super::{Sweeper, block_minima_generic, block_minima_lattice, radix_sort_slots};
    use crate::field::VertexField;
    use crate::grid::{Grid, Property, Topology};
    use crate::scgraph::SCGraph;
    use crate::sweep::CellGraph;

    /// A xorshift32 generator from `seed` (non-zero).
    fn xorshift(mut x: u32) -> impl FnMut() -> u32 {
        move || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        }
    }

    /// An IJK grid of unit cubes with `n` cells per axis, about `holes` %
    /// of them hidden at random; its S-CGraph, vertex counts and hidden flags.
    fn unit_lattice(
        n: [usize; 3],
        holes: u32,
        rnd: &mut impl FnMut() -> u32,
    ) -> (SCGraph, [usize; 3], Vec<bool>) {
        let dims = [n[0] + 1, n[1] + 1, n[2] + 1];
        let np = dims.iter().product::<usize>();
        let points = (0..np)
            .map(|v| {
                let (i, j, k) = (v % dims[0], v / dims[0] % dims[1], v / (dims[0] * dims[1]));
                [i as f64, j as f64, k as f64]
            })
            .collect();
        let grid = Grid {
            points,
            topology: Topology::Structured { dims },
            point_data: vec![Property::scalar("f", vec![0.0; np])],
            cell_data: Vec::new(),
        };
        let hidden: Vec<bool> = (0..n.iter().product::<usize>())
            .map(|_| rnd() % 100 < holes)
            .collect();
        (SCGraph::build(&grid, Some(&hidden)).unwrap(), dims, hidden)
    }

    /// The emission context of `g` with attribute `attr`.
    fn attribute_ctx<'a>(g: &'a SCGraph, attr: &'a [f32]) -> crate::extract::EmitContext<'a> {
        crate::extract::EmitContext {
            positions: g.positions(),
            attribute: Some(attr),
            cells_only: false,
        }
    }

    /// The lattice minima equal the generic ones (same cells, same lo, same
    /// order) on random IJK grids with holes and many ties (φ in steps of
    /// 0.5), with 1 to 4 blocks.
    #[test]
    fn lattice_minima_match_generic() {
        let mut rnd = xorshift(0x9E37_79B9_u32);
        for (n, holes) in [
            ([1, 1, 1], 0),
            ([5, 4, 3], 0),
            ([7, 6, 9], 10),
            ([12, 3, 5], 40),
        ] {
            let (g, dims, hidden) = unit_lattice(n, holes, &mut rnd);
            let np = dims.iter().product::<usize>();
            let phi: Vec<f32> = (0..np).map(|_| (rnd() % 9) as f32 * 0.5 - 2.0).collect();
            let f = VertexField { values: &phi };
            let lat = g.lattice().unwrap();
            for threads in 1..=4 {
                let sw = Sweeper::new(&g, threads);
                let mut total = 0;
                for b in &sw.blocks {
                    let want = block_minima_generic(&g, &f, b);
                    let got = block_minima_lattice(&lat, &phi, b);
                    assert_eq!(got, want, "dims {dims:?} holes {holes}% threads {threads}");
                    total += want.len();
                }
                assert!(
                    total > 0 || hidden.iter().all(|&h| h),
                    "no minima: {dims:?}"
                );
            }
        }
    }

    /// The lattice loops' hash-weld fallback (for layers too large for the
    /// ownership window), per cell and chunked, gives the same indexed
    /// meshes as the ownership weld: the same polygons as lists of grid
    /// edges, one vertex per edge.
    #[test]
    fn lattice_hash_weld_fallback_equals_the_ownership_weld() {
        use crate::extract::EmitContext;
        let mut rnd = xorshift(0x2545_F491_u32);
        for (n, holes) in [([6, 5, 4], 0), ([7, 6, 9], 15)] {
            let (g, dims, _) = unit_lattice(n, holes, &mut rnd);
            let np = dims.iter().product::<usize>();
            let phi: Vec<f32> = (0..np).map(|_| (rnd() % 17) as f32 * 0.25 - 2.0).collect();
            let f = VertexField { values: &phi };
            let lat = g.lattice().unwrap();
            let ctx = EmitContext {
                positions: g.positions(),
                attribute: None,
                cells_only: false,
            };
            let levels: Vec<f32> = (0..15).map(|l| l as f32 * 0.25 - 1.9).collect();
            let run = |hash_weld: bool, chunked: bool| {
                let mut sw = Sweeper::new(&g, 2);
                let mut out = vec![Vec::new(); levels.len()];
                for b in &mut sw.blocks {
                    let minima = super::block_minima(&g, &f, b);
                    let on_level = |k: usize, mesh: &super::LevelMesh, _: &super::LevelStats| {
                        let mut keys = mesh.edge_keys.clone();
                        keys.sort_unstable();
                        keys.dedup();
                        assert_eq!(keys.len(), mesh.edge_keys.len(), "an edge welded twice");
                        for p in 0..mesh.polygon_count() {
                            let ids = &mesh.indices
                                [mesh.offsets[p] as usize..mesh.offsets[p + 1] as usize];
                            let corners: Vec<u64> =
                                ids.iter().map(|&i| mesh.edge_keys[i as usize]).collect();
                            out[k].push((mesh.cells[p], corners));
                        }
                    };
                    if chunked {
                        super::chunks::sweep_block_chunks(
                            &lat, &phi, b, &minima, &levels, &ctx, hash_weld, on_level,
                        );
                    } else {
                        super::sweep_block_lattice(
                            &lat, &phi, b, &minima, &levels, &ctx, hash_weld, on_level,
                        );
                    }
                }
                for l in &mut out {
                    l.sort();
                }
                out
            };
            let owned = run(false, false);
            assert!(owned.iter().map(Vec::len).sum::<usize>() > 0, "nothing cut");
            for chunked in [false, true] {
                assert_eq!(
                    run(true, chunked),
                    owned,
                    "dims {dims:?} holes {holes}% chunked {chunked}"
                );
            }
        }
    }

    /// The batched, unchecked writes of the lattice emitter
    /// (`extract::HexWriter`) give, level by level, the hash-welded path's
    /// output: the same polygons in the same order, each corner with the
    /// same grid edge, position bits and attribute bits, and running sums
    /// (area, triangles, cut cells) equal to the ones recomputed from the
    /// mesh. Levels cut more cells than one batch (1024), and a noisy φ
    /// puts cells with ambiguous faces (which end a batch) among them.
    #[test]
    fn batched_emission_equals_the_hash_weld() {
        let mut rnd = xorshift(0x68E3_1DA4_u32);
        let (g, dims, _) = unit_lattice([50, 44, 5], 3, &mut rnd);
        let np = dims.iter().product::<usize>();
        // Layers of φ near k, with noise that makes faces ambiguous.
        let phi: Vec<f32> = (0..np)
            .map(|v| (v / (dims[0] * dims[1])) as f32 + (rnd() % 64) as f32 / 80.0 - 0.4)
            .collect();
        let attr: Vec<f32> = (0..np).map(|_| (rnd() % 1000) as f32 * 0.001).collect();
        let f = VertexField { values: &phi };
        let lat = g.lattice().unwrap();
        let ctx = attribute_ctx(&g, &attr);
        let levels: Vec<f32> = (0..9).map(|l| l as f32 * 0.55 + 0.2).collect();
        // Per level: the polygons (cell, corners as edge key, position and
        // attribute bits), cut cells and the running sums.
        type Corner = (u64, [u32; 3], u32);
        type Level = (Vec<(u32, Vec<Corner>)>, u32, u64, usize);
        let run = |hash_weld: bool| -> Vec<Level> {
            let mut sw = Sweeper::new(&g, 1);
            let mut out = vec![Default::default(); levels.len()];
            let b = &mut sw.blocks[0];
            let minima = super::block_minima(&g, &f, b);
            let on_level = |k: usize, mesh: &super::LevelMesh, _: &super::LevelStats| {
                let polys = (0..mesh.polygon_count())
                    .map(|p| {
                        let ids =
                            &mesh.indices[mesh.offsets[p] as usize..mesh.offsets[p + 1] as usize];
                        let corners = ids
                            .iter()
                            .map(|&i| {
                                let i = i as usize;
                                (
                                    mesh.edge_keys[i],
                                    mesh.positions[i].map(f32::to_bits),
                                    mesh.values[i].to_bits(),
                                )
                            })
                            .collect();
                        (mesh.cells[p], corners)
                    })
                    .collect();
                assert_eq!(mesh.accumulated_area().to_bits(), mesh.area().to_bits());
                assert_eq!(mesh.accumulated_triangles(), mesh.triangle_count());
                out[k] = (
                    polys,
                    mesh.cut_cells,
                    mesh.accumulated_area().to_bits(),
                    mesh.accumulated_triangles(),
                );
            };
            super::chunks::sweep_block_chunks(
                &lat, &phi, b, &minima, &levels, &ctx, hash_weld, on_level,
            );
            out
        };
        let batched = run(false);
        assert!(
            batched.iter().any(|l| l.1 > 1024),
            "no level fills a batch: {:?}",
            batched.iter().map(|l| l.1).collect::<Vec<_>>()
        );
        // Cells with a face whose corners alternate above and below.
        let faces = [
            [0, 2, 6, 4],
            [1, 3, 7, 5],
            [0, 1, 5, 4],
            [2, 3, 7, 6],
            [0, 1, 3, 2],
            [4, 5, 7, 6],
        ];
        let [_, dj, dk] = lat.deltas;
        let ambiguous: usize = batched
            .iter()
            .zip(&levels)
            .map(|(l, &t)| {
                let mut cells: Vec<u32> = l.0.iter().map(|p| p.0).collect();
                cells.dedup();
                cells
                    .iter()
                    .filter(|&&c| {
                        let f = unsafe { super::load8(&phi, c - lat.base, dj, dk) };
                        faces.iter().any(|q| {
                            let a = q.map(|v| f[v] >= t);
                            a[0] == a[2] && a[1] == a[3] && a[0] != a[1]
                        })
                    })
                    .count()
            })
            .sum();
        assert!(
            ambiguous > 10,
            "only {ambiguous} cells with an ambiguous face"
        );
        assert_eq!(run(true), batched);
    }

    /// The chunked lattice loop gives, level by level, the same output as
    /// the per-cell loop: the same cut cells in the same order, the same
    /// indexed polygons, areas and visited counts. Random IJK grids with
    /// holes, φ in steps that put many vertices exactly on levels, 1 to 3
    /// blocks, and rows shorter and longer than a chunk.
    #[test]
    fn chunked_loop_equals_the_cell_loop() {
        let mut rnd = xorshift(0x6A09_E667_u32);
        // Ramps along ±i, ±j and ±k (φ from -2 to 2 across the grid) make
        // the sweep cross chunk ends along i, rows and layers, both ways, as
        // its only way on.
        for (n, holes, (axis, ramp)) in [
            ([1, 1, 1], 0, (0, 0.0)),
            ([6, 5, 4], 0, (0, 0.0)),
            ([7, 6, 9], 15, (0, 0.0)),
            ([70, 3, 4], 10, (0, 0.0)),
            ([130, 2, 3], 0, (0, 0.0)),
            ([9, 8, 7], 60, (0, 0.0)),
            ([200, 1, 1], 0, (0, -1.0)),
            ([200, 1, 1], 0, (0, 1.0)),
            ([150, 2, 1], 5, (0, -1.0)),
            ([70, 40, 1], 0, (1, -1.0)),
            ([300, 12, 1], 0, (1, -1.0)),
            ([300, 12, 1], 0, (1, 1.0)),
            ([150, 1, 12], 0, (2, -1.0)),
            ([150, 1, 12], 3, (2, 1.0)),
            ([300, 12, 2], 35, (1, -1.0)),
            ([300, 12, 2], 35, (1, 1.0)),
            ([150, 2, 12], 35, (2, -1.0)),
            ([150, 2, 12], 35, (2, 1.0)),
            // Several patch rows and columns of every width.
            ([20, 37, 5], 0, (1, -1.0)),
            ([21, 35, 5], 10, (2, 1.0)),
            ([70, 19, 3], 5, (0, 1.0)),
            ([13, 70, 2], 0, (0, -1.0)),
        ] {
            let (g, dims, _) = unit_lattice(n, holes, &mut rnd);
            let np = dims.iter().product::<usize>();
            let phi: Vec<f32> = (0..np)
                .map(|v| {
                    let ijk = [v % dims[0], v / dims[0] % dims[1], v / (dims[0] * dims[1])];
                    if ramp == 0.0 {
                        (rnd() % 17) as f32 * 0.25 - 2.0
                    } else {
                        ramp * (ijk[axis] as f32 / dims[axis] as f32 * 4.0 - 2.0)
                    }
                })
                .collect();
            let attr: Vec<f32> = (0..np).map(|_| (rnd() % 1000) as f32 * 0.01).collect();
            let f = VertexField { values: &phi };
            let lat = g.lattice().unwrap();
            let ctx = attribute_ctx(&g, &attr);
            // Levels on and between the φ steps, some outside the range;
            // evenly spaced and not.
            let even: Vec<f32> = (0..23).map(|l| l as f32 * 0.25 - 2.6).collect();
            let uneven: Vec<f32> = (0..12).map(|l| (l * l) as f32 * 0.04 - 2.1).collect();
            for (levels, threads) in [(&even, 1), (&even, 2), (&even, 3), (&uneven, 2)] {
                let run = |width: Option<u32>| {
                    let mut sw = Sweeper::new(&g, threads);
                    let mut out = Vec::new();
                    for b in &mut sw.blocks {
                        let minima = super::block_minima(&g, &f, b);
                        let mut on_level =
                            |k: usize, mesh: &super::LevelMesh, st: &super::LevelStats| {
                                out.push((
                                    k,
                                    mesh.cells.clone(),
                                    mesh.offsets.clone(),
                                    mesh.indices.clone(),
                                    mesh.edge_keys.clone(),
                                    mesh.values.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                                    st.visited,
                                    st.area.to_bits(),
                                ));
                            };
                        let (lat, phi) = (&lat, &phi[..]);
                        match width {
                            Some(w) => super::chunks::sweep_block_patches(
                                w,
                                lat,
                                phi,
                                b,
                                &minima,
                                levels,
                                &ctx,
                                false,
                                &mut on_level,
                            ),
                            None => super::sweep_block_lattice(
                                lat,
                                phi,
                                b,
                                &minima,
                                levels,
                                &ctx,
                                false,
                                &mut on_level,
                            ),
                        }
                    }
                    out
                };
                let cells = run(None);
                assert!(
                    cells.iter().map(|o| o.1.len()).sum::<usize>() > 0 || holes > 50,
                    "nothing cut: {dims:?}"
                );
                for width in super::chunks::WIDTHS {
                    assert_eq!(
                        run(Some(width)),
                        cells,
                        "dims {dims:?} holes {holes}% threads {threads} patch width {width}"
                    );
                }
            }
        }
    }

    /// One sweeper reused for many sweeps (different level counts, fields
    /// and directions, on the lattice and the generic loop) cuts the same
    /// cells as a fresh sweeper every time: stamps of an earlier sweep
    /// (steps and swept-out marks) never hide a cell from a later one.
    #[test]
    fn a_reused_sweeper_cuts_what_a_fresh_one_cuts() {
        use crate::extract::EmitContext;
        use crate::field::ScalarField;
        /// φ per vertex without the array: takes the generic loop.
        struct Opaque<'a>(&'a [f32]);
        impl ScalarField for Opaque<'_> {
            fn phi(&self, v: u32) -> f32 {
                self.0[v as usize]
            }
        }
        let mut rnd = xorshift(0x1234_5679_u32);
        let (g, dims, _) = unit_lattice([6, 7, 5], 10, &mut rnd);
        let np = dims.iter().product::<usize>();
        let ctx = EmitContext {
            positions: g.positions(),
            attribute: None,
            cells_only: true,
        };
        let cells = |sw: &mut Sweeper<SCGraph>, phi: &[f32], generic: bool, levels: &[f32]| {
            let mut out = if generic {
                let f = Opaque(phi);
                sw.prepare_minima(&f, None);
                sw.sweep(&f, None, levels, &ctx, Vec::new, |acc, k, m, _| {
                    acc.extend(m.cells.iter().map(|&c| (k, c)))
                })
            } else {
                let f = VertexField { values: phi };
                sw.prepare_minima(&f, None);
                sw.sweep(&f, None, levels, &ctx, Vec::new, |acc, k, m, _| {
                    acc.extend(m.cells.iter().map(|&c| (k, c)))
                })
            }
            .concat();
            out.sort_unstable();
            out
        };
        for threads in [1, 2] {
            let mut reused = Sweeper::new(&g, threads);
            for round in 0..12 {
                let phi: Vec<f32> = (0..np).map(|_| (rnd() % 64) as f32 * 0.125).collect();
                let n = 1 + (rnd() % 40) as usize;
                // The first level lies above many cells' lo, so that step
                // pushes cells that the last sweep swept out.
                let first = 0.5 + (rnd() % 32) as f32 * 0.125;
                let levels: Vec<f32> = (0..n).map(|l| first + l as f32 * 4.0 / n as f32).collect();
                let generic = round % 3 == 2;
                let want = cells(&mut Sweeper::new(&g, threads), &phi, generic, &levels);
                assert!(!want.is_empty());
                let got = cells(&mut reused, &phi, generic, &levels);
                if got != want {
                    let missed: Vec<_> = want.iter().filter(|c| !got.contains(c)).take(5).collect();
                    panic!(
                        "threads {threads} round {round}: {} cut cells, want {}; missed (level, cell) {missed:?}",
                        got.len(),
                        want.len()
                    );
                }
            }
        }
    }

    /// The radix sort against the standard sort: empty, one element,
    /// duplicates, keys spanning 1, 2 and 3 digits, and a non-zero start.
    #[test]
    fn radix_sort_matches_std_sort() {
        let mut scratch = Vec::new();
        let mut rnd = xorshift(0x2545_f491);
        for (n, len, start) in [
            (0usize, 10u32, 0u32),
            (1, 10, 5),
            (100, 7, 3),
            (5000, 2000, 100),
            (5000, 3_000_000, 17),
            (20000, 4_000_000_000, 1),
        ] {
            let mut v: Vec<u32> = (0..n).map(|_| start + rnd() % len).collect();
            let mut want = v.clone();
            want.sort_unstable();
            radix_sort_slots(&mut v, &mut scratch, start, len);
            assert_eq!(v, want, "n={n} len={len} start={start}");
        }
    }
}
