//! The incremental sweep over any [`CellGraph`]: two queues
//! (active and swept), per-cell step stamps, minima sorted by `(lo, id)` and
//! cached per axis direction, output into a caller-owned [`LevelMesh`].

use rayon::prelude::*;

use crate::extract::{CutCell, EmitContext, LevelMesh, code_of, emit_cell, intersects};
use crate::field::ScalarField;
use crate::metacell::MAX_META_VERTICES;

mod cp_loop;
mod cp_table;
mod cp_weld;
pub mod lattice;

pub use crate::cellgraph::{CellGraph, NEVER, Stamp, cell_lo};
pub use crate::extract::LevelStats;
pub use lattice::Lattice;
use lattice::{LatticeState, LatticeSweep, block_minima_lattice, chunks, sweep_block_lattice};

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

/// How many work-queue entries ahead [`CellGraph::prefetch_cell`] is issued.
pub(crate) const PREFETCH_AHEAD: usize = 2;

/// A minimum: a cell with no predecessor, with its `lo`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Minimum {
    /// min φ over the cell.
    pub lo: f32,
    /// Slot.
    pub slot: u32,
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
    /// Per cell, the `lo` that the last minima search computed, and that
    /// search's cache slot: a graph with its own loop reads a neighbour's
    /// `lo` here instead of decoding the neighbour (see
    /// [`block_minima`]).
    lows: Option<(usize, Vec<f32>)>,
    /// The block's reusable output buffer.
    pub mesh: LevelMesh,
    /// State of the lattice loops (S-CGraph blocks only).
    lattice: Option<Box<LatticeState>>,
    /// The sweeper's loop choices for the current sweep.
    options: SweepOptions,
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
            + self.lows.as_ref().map_or(0, |(_, l)| l.capacity() * 4)
            + self.mesh.capacity_bytes()
            + self.lattice.as_ref().map_or(0, |l| l.bytes())
    }
}

/// Choices of the sweep's lattice loops, for A/B benchmarks (the defaults
/// pick by themselves; the output does not depend on them), and the run's
/// cancellation token.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SweepOptions {
    /// Run the per-cell lattice loop instead of the chunked one.
    pub per_cell_loop: bool,
    /// Force the chunked loop's patch width (8, 16, 32 or 64; other values
    /// are ignored) instead of choosing it from φ.
    pub patch_width: Option<u32>,
    /// Checked after every level by [`crate::pipeline::slice`], which
    /// then stops with `Interrupted` (the default token never cancels).
    pub cancel: crate::cancel::Cancel,
}

/// Runs sweeps over a [`CellGraph`], split into spatial blocks (one per thread).
pub struct Sweeper<'g, G: CellGraph> {
    graph: &'g G,
    /// Blocks, each swept independently.
    pub blocks: Vec<Block>,
    /// Loop choices (defaults choose by themselves).
    pub options: SweepOptions,
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
                lows: None,
                mesh: LevelMesh::default(),
                lattice: None,
                options: SweepOptions::default(),
            })
            .collect();
        Sweeper {
            graph,
            blocks,
            options: SweepOptions::default(),
        }
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
                    let (minima, lows) = block_minima(g, field, b);
                    b.minima_cache[slot] = Some(minima);
                    b.lows = lows.map(|l| (slot, l));
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
        let options = &self.options;
        self.blocks
            .par_iter_mut()
            .map(|b| {
                let mut acc = make_acc();
                let minima = match b.minima_cache[slot].take() {
                    Some(m) => m,
                    None => {
                        let (minima, lows) = block_minima(g, field, b);
                        b.lows = lows.map(|l| (slot, l));
                        minima
                    }
                };
                b.options = options.clone();
                let lows = match b.lows.take() {
                    Some((s, l)) if s == slot => Some(l),
                    _ => None,
                };
                let input = BlockInput {
                    minima: &minima,
                    lows: lows.as_deref(),
                    levels,
                    ctx,
                };
                sweep_block(g, field, b, input, |k, mesh, st| {
                    on_level(&mut acc, k, mesh, st)
                });
                b.lows = lows.map(|l| (slot, l));
                if axis_slot.is_some() {
                    b.minima_cache[slot] = Some(minima);
                }
                acc
            })
            .collect()
    }
}

/// Sorted minima of one block: cells with no predecessor among the block's
/// cells; with them, for a graph with its own loop, every cell's `lo`
/// (which the search computes anyway, and which that loop reads instead of
/// decoding a neighbour).
fn block_minima<G: CellGraph, F: ScalarField>(
    g: &G,
    f: &F,
    b: &Block,
) -> (Vec<Minimum>, Option<Vec<f32>>) {
    if let (Some(lat), Some(phi)) = (g.lattice(), f.values()) {
        return (block_minima_lattice(&lat, phi, b), None);
    }
    let (minima, lo) = block_minima_generic(g, f, b);
    (minima, g.own_loop().is_some().then_some(lo))
}

/// [`block_minima`] for any graph: each cell's `lo` from [`cell_lo`], then
/// its in-block neighbours compared.
fn block_minima_generic<G: CellGraph, F: ScalarField>(
    g: &G,
    f: &F,
    b: &Block,
) -> (Vec<Minimum>, Vec<f32>) {
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
    (out, lo)
}

/// What one block's sweep reads besides the graph and the field.
#[derive(Clone, Copy)]
struct BlockInput<'a> {
    /// The block's sorted minima.
    minima: &'a [Minimum],
    /// Per cell of the block, its `lo` for this field, when the minima
    /// search kept it.
    lows: Option<&'a [f32]>,
    /// The levels.
    levels: &'a [f32],
    /// What emission reads.
    ctx: &'a EmitContext<'a>,
}

#[inline(never)]
fn sweep_block<G: CellGraph, F: ScalarField>(
    g: &G,
    f: &F,
    b: &mut Block,
    input: BlockInput,
    mut on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
) {
    let BlockInput {
        minima,
        levels,
        ctx,
        ..
    } = input;
    if let Some(cp) = g
        .own_loop()
        .and_then(|a| a.downcast_ref::<crate::structures::cpgraph::CpGraph>())
    {
        cp_loop::sweep_block_cp(cp, f, b, input, on_level);
        return;
    }
    if let (Some(lat), Some(phi)) = (g.lattice(), f.values()) {
        let input = LatticeSweep {
            lat,
            phi,
            ctx,
            hash_weld: false,
        };
        if b.options.per_cell_loop || levels.len() > chunks::MAX_LEVELS {
            sweep_block_lattice(&input, b, minima, levels, on_level);
        } else {
            chunks::sweep_block_chunks(&input, b, minima, levels, on_level);
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
                let cell = CutCell {
                    gids: &ids[..n],
                    phi: &phi[..n],
                    t,
                    code: code_of(&phi[..n], t),
                    slot: c,
                };
                emit_cell(catalog.get(m), &cell, ctx, &mut b.mesh);
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

/// Sorts `slots` (all in `start..start + len`) ascending with an LSD radix
/// sort over `slot - start` ([`radix_sort_by_slot`]).
pub(crate) fn radix_sort_slots(slots: &mut Vec<u32>, scratch: &mut Vec<u32>, start: u32, len: u32) {
    radix_sort_by_slot(slots, scratch, start, len, |c| c);
}

/// Sorts `items` by `slot(item)` (all in `start..start + len`, distinct)
/// with an LSD radix sort over `slot - start`, in as few passes of at most
/// 13-bit digits as the key range needs (two for up to 2²⁶ slots);
/// `scratch` is reused. Short lists take a comparison sort.
pub(crate) fn radix_sort_by_slot<T: Copy + Default>(
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

#[cfg(test)]
mod tests;
