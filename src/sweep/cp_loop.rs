//! The sweep loop of the corner-point graph ([`CpGraph`]): the lattice
//! loop's *entry levels* on explicit vertex ids. Each live cell is read
//! once per sweep, at its entry level `L(lo)` (the first k with
//! `lo < t_k`); a cut cell stays in `A` as a [`Cut`] record: the last
//! level that cuts it packed beside its slot, its meta-cell, vertex ids
//! and φ, so later steps neither read φ nor decode the cell again. A
//! level's cut cells are emitted in slot order through the catalog
//! (welded by [`CpWeld`], the hash map only for the edges it cannot place).
//!
//! Completeness. Call `p` a predecessor of `c` when they are linked and
//! `(lo_p, p) < (lo_c, c)`; a minimum has none (minima are computed on the
//! same links, within the block). Claim: every live cell `c` with
//! `L(lo_c) < K` is read exactly at step `L(lo_c)`. Induction on
//! `(lo, slot)`: a minimum is queued at `L(lo)` when the sweep starts; any
//! other cell has a predecessor `p`, read at `L(lo_p) ≤ L(lo_c)`, which
//! marks `c` seen and queues it at `L(lo_c)` (this step when `lo_c < t`),
//! unless someone marked it earlier, which queued it at the same level:
//! a cell is first seen at a step `≤ L(lo_c)`, when its `lo` is computed
//! exactly from its own vertices. So the cells read at step k are exactly
//! those with `t_{k-1} ≤ lo < t_k`, and `A_k` = {cells with `lo < t_k ≤
//! hi`}, the brute force's set. Nothing here uses the geometry of a link:
//! the argument holds for any symmetric relation, so faults, pinch-outs
//! and collapsed cells need no exception lists; a missing link only adds a
//! minimum. (The generic loop needs more: a cell swept out for good stops
//! propagating, so its links must join cells whose φ ranges overlap, which
//! sharing a vertex guarantees; hence links only between cells that share
//! a vertex.)

use super::cp_table::CodeTable;
use super::cp_weld::{CpWeld, CutCell, RowCell};
use super::lattice::writer::HexWriter;
use super::lattice::{LatticeQueues, code8, pack_active, set_bit};
use super::{Block, BlockInput, LevelStats, PREFETCH_AHEAD, radix_sort_by_slot, radix_sort_slots};
use crate::cellgraph::CellGraph;
use crate::extract::{EmitContext, LevelMesh, code_of, prefetch};
use crate::field::ScalarField;
use crate::metacell::{MAX_META_VERTICES, builtin};
use crate::structures::cpgraph::CpGraph;

/// Vertices a [`Cut`] record holds; cells with more (explicit polyhedron
/// pieces) are decoded again when emitted.
const CUT_VERTICES: usize = 8;

/// How many work-queue entries ahead [`CpSweep::enter`] fetches what
/// decoding a slot reads; its own entries are fetched twice as far ahead.
const ENTER_AHEAD: usize = 8;

/// Cut cells per batch of the emitter's writer.
const EMIT_BATCH: usize = 1024;

/// A cell of the active list `A`: `pack_active(slot, last)` (sorting by it
/// sorts by slot), its meta-cell, vertex count, and (up to
/// [`CUT_VERTICES`]) vertex ids and φ, read once when the cell entered.
#[derive(Clone, Copy, Debug, Default)]
struct Cut {
    key: u64,
    meta: u16,
    n: u16,
    ids: [u32; CUT_VERTICES],
    phi: [f32; CUT_VERTICES],
}

impl Cut {
    #[inline(always)]
    fn slot(&self) -> u32 {
        (self.key >> 32) as u32
    }
    #[inline(always)]
    fn last(&self) -> usize {
        self.key as u32 as usize
    }
}

/// One block's sweep over the CP-Graph: the graph, the field, the levels
/// and the block's slot range.
struct CpSweep<'a, F> {
    g: &'a CpGraph,
    f: &'a F,
    levels: &'a [f32],
    ctx: &'a EmitContext<'a>,
    /// Per cell of the block, its `lo` (from the minima search), when kept.
    lows: Option<&'a [f32]>,
    start: u32,
    len: u32,
    /// Rows of the meta-cells the emitter tables.
    table: CodeTable,
    /// The levels, then [`LEVEL_WINDOW`] NaNs (see [`next_above`]).
    padded: Vec<f32>,
}

/// The active list and its per-level buffers.
#[derive(Default)]
struct Active {
    /// `A`, in slot order.
    cuts: Vec<Cut>,
    /// Cells that entered this level and are cut by it, in the order
    /// they were read: those of the step's sorted work list, then those
    /// queued during the step.
    fresh: Vec<Cut>,
    /// How many of `fresh` come from the sorted work list (so are in slot
    /// order): most of them (on f50 about one cell in forty is queued
    /// during its own step).
    sorted: usize,
    /// The rest of `fresh`, sorted by slot (see [`Active::merge`]).
    tail: Vec<Cut>,
    scratch: Vec<Cut>,
}

impl Active {
    /// `A_k`: the carried cells still cut at level `k`, merged with the
    /// fresh ones (a slot is in at most one of the two). Only the fresh
    /// cells past `sorted` are sorted (moved to `tail`); the merge takes
    /// the sorted part and the tail as two runs.
    fn merge(&mut self, k: usize, start: u32, len: u32) {
        self.tail.clear();
        self.tail.extend_from_slice(&self.fresh[self.sorted..]);
        self.fresh.truncate(self.sorted);
        radix_sort_by_slot(&mut self.tail, &mut self.scratch, start, len, |c| c.slot());
        let out = &mut self.scratch;
        out.clear();
        out.reserve(self.cuts.len() + self.fresh.len() + self.tail.len());
        let (fresh, tail) = (&self.fresh[..], &self.tail[..]);
        let (mut j, mut jt) = (0, 0);
        // The key of a run's next cell (none: above every key).
        let key_at = |run: &[Cut], j: usize| run.get(j).map_or(u64::MAX, |b: &Cut| b.key);
        let (mut next, mut next_t) = (key_at(fresh, 0), key_at(tail, 0));
        let dst = out.as_mut_ptr();
        let mut n = 0;
        for a in &self.cuts {
            while next.min(next_t) < a.key {
                // The smaller key of the two runs (the tail is empty at
                // most levels: then this branch is always taken).
                if next < next_t {
                    // SAFETY: at most `cuts.len() + fresh.len() +
                    // tail.len()` records are kept, and each write goes at
                    // `n`, below that (reserved).
                    unsafe { dst.add(n).write(fresh[j]) };
                    j += 1;
                    next = key_at(fresh, j);
                } else {
                    // SAFETY: as above.
                    unsafe { dst.add(n).write(tail[jt]) };
                    jt += 1;
                    next_t = key_at(tail, jt);
                }
                n += 1;
            }
            // Written whether kept or not (no branch): a dropped record is
            // overwritten by the next.
            // SAFETY: as above (`n` counts the records kept so far, and
            // this one is still to come in that bound).
            unsafe { dst.add(n).write(*a) };
            n += (a.last() >= k) as usize;
        }
        // SAFETY: the first `n` records were written.
        unsafe { out.set_len(n) };
        while j < fresh.len() && jt < tail.len() {
            if fresh[j].key < tail[jt].key {
                out.push(fresh[j]);
                j += 1;
            } else {
                out.push(tail[jt]);
                jt += 1;
            }
        }
        out.extend_from_slice(&fresh[j..]);
        out.extend_from_slice(&tail[jt..]);
        std::mem::swap(&mut self.cuts, out);
    }
}

/// The corner-point graph's sweep of one block (see the module docs).
#[inline(never)]
pub(super) fn sweep_block_cp<F: ScalarField>(
    g: &CpGraph,
    f: &F,
    b: &mut Block,
    input: BlockInput,
    mut on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
) {
    let BlockInput {
        minima,
        lows,
        levels,
        ctx,
    } = input;
    let sw = CpSweep {
        g,
        f,
        levels,
        ctx,
        lows,
        start: b.start,
        len: b.stamps.len() as u32,
        table: CodeTable::new(g.catalog(), |id| {
            g.meta_counts.get(id).is_some_and(|&n| n > 0)
        }),
        padded: levels
            .iter()
            .copied()
            .chain([f32::NAN; LEVEL_WINDOW])
            .collect(),
    };
    let Block {
        stamps,
        mesh,
        lattice,
        sort_scratch,
        ..
    } = b;
    let q = &mut lattice.get_or_insert_with(Default::default).cells;
    // Dead slots are seen from the start (the stamps hold NEVER there).
    q.seen.clear();
    q.seen.resize((sw.len as usize).div_ceil(64), 0);
    for (j, &s) in stamps.iter().enumerate() {
        if s == super::NEVER {
            q.seen[j / 64] |= 1 << (j % 64);
        }
    }
    q.queue_minima(minima, levels, sw.start);
    let [nx, ny, _] = g.dims;
    let mut weld = CpWeld::new(g.positions.len(), (nx + 1) * (ny + 1), nx + 1);
    let mut active = Active::default();
    for (k, &t) in levels.iter().enumerate() {
        mesh.clear();
        weld.next_level();
        let mut work = std::mem::take(&mut q.entering[k]);
        radix_sort_slots(&mut work, sort_scratch, sw.start, sw.len);
        active.fresh.clear();
        active.sorted = sw.enter(k, &mut work, q, &mut active.fresh);
        let entered = work.len();
        work.clear();
        q.entering[k] = work;
        let carried = active.cuts.len();
        active.merge(k, sw.start, sw.len);
        sw.emit(t, &active.cuts, &mut weld, mesh);
        let stats = LevelStats::of(mesh, (entered + carried) as u64);
        on_level(k, mesh, &stats);
    }
}

impl<F: ScalarField> CpSweep<'_, F> {
    /// Reads the cells entering at level `k` (and those its neighbours
    /// queue at `k` on the way): each cut one becomes a [`Cut`] in
    /// `fresh`; each unseen linked neighbour is queued at its entry level
    /// (its `lo` read from the minima search's when kept, else decoded).
    /// Returns how many of `fresh` come from the work list's first
    /// (sorted) part, before the cells queued during the step.
    fn enter(
        &self,
        k: usize,
        work: &mut Vec<u32>,
        q: &mut LatticeQueues,
        fresh: &mut Vec<Cut>,
    ) -> usize {
        let (g, f, levels) = (self.g, self.f, self.levels);
        let t = levels[k];
        let LatticeQueues { entering, seen, .. } = q;
        let mut ids = [0u32; MAX_META_VERTICES];
        let phi_values = f.values();
        let sorted_work = work.len();
        let mut sorted = None;
        let mut i = 0;
        while i < work.len() {
            if i == sorted_work {
                sorted = Some(fresh.len());
            }
            let c = work[i];
            // Two-stage look-ahead: the slot's own entries far ahead, then
            // (once they are in cache) what decoding it reads next.
            if let Some(&far) = work.get(i + 2 * ENTER_AHEAD) {
                g.prefetch_slot(far);
            }
            if let (Some(&near), Some(phi)) = (work.get(i + ENTER_AHEAD), phi_values) {
                g.prefetch_decode(near, phi);
                // The kept lo of its j and k neighbours (its i neighbours
                // share its line).
                if let Some(lows) = self.lows {
                    let j = near.wrapping_sub(self.start) as usize;
                    let [_, dj, dk] = g.deltas;
                    for d in [dj as usize, dk as usize] {
                        prefetch(lows, j.wrapping_add(d));
                        prefetch(lows, j.wrapping_sub(d));
                    }
                }
            }
            i += 1;
            let (m, nv) = g.cell(c, &mut ids);
            let (mut cut, hi) = read_cut(f, m, &ids, nv);
            if t <= hi {
                // The last level that cuts it: the last at or below hi.
                let last = next_above(&self.padded, k, hi) - 1;
                cut.key = pack_active(c, last);
                fresh.push(cut);
            }
            // The linked neighbours in `for_each_neighbour`'s order,
            // unrolled: each direction's branches (linked, seen) are
            // predicted on their own.
            let links = g.link_bits(c);
            let [di, dj, dk] = g.deltas;
            macro_rules! visit {
                ($bit:expr, $nb:expr) => {
                    if links & (1 << $bit) != 0 {
                        let nb: u32 = $nb;
                        let j = nb.wrapping_sub(self.start);
                        if j < self.len && set_bit(seen, j) {
                            let lo = match self.lows {
                                Some(lows) => lows[j as usize],
                                None => decoded_lo(g, f, nb),
                            };
                            // This step when lo is below level k, else the
                            // first later level above lo (none past the
                            // last).
                            if lo < t {
                                work.push(nb);
                            } else {
                                let l = next_above(&self.padded, k, lo);
                                if l < levels.len() {
                                    entering[l].push(nb);
                                }
                            }
                        }
                    }
                };
            }
            visit!(0, c - di);
            visit!(1, c + di);
            visit!(2, c - dj);
            visit!(3, c + dj);
            visit!(4, c - dk);
            visit!(5, c + dk);
        }
        sorted.unwrap_or(fresh.len())
    }

    /// Emits the polygons of the level `t`'s cut cells, in slot order:
    /// cells with a [`CodeTable`] row in batches written without capacity
    /// checks, the others one by one through the catalog.
    fn emit(&self, t: f32, cuts: &[Cut], weld: &mut CpWeld, mesh: &mut LevelMesh) {
        let ctx = self.ctx;
        if ctx.cells_only {
            mesh.cut_cells += cuts.len() as u32;
            mesh.cells.extend(cuts.iter().map(Cut::slot));
            return;
        }
        let mut x = 0;
        while x < cuts.len() {
            let end = cuts.len().min(x + EMIT_BATCH);
            let mut out = HexWriter::new(mesh, end - x);
            let mut slow = None;
            while x < end {
                if let Some(ahead) = cuts.get(x + 2 * PREFETCH_AHEAD) {
                    prefetch_rows(ahead, ctx, weld);
                }
                let cut = &cuts[x];
                x += 1;
                let nv = cut.n as usize;
                if nv <= CUT_VERTICES {
                    // Unused φ entries are masked off the code.
                    let code = code8(&cut.phi, t) & ((1 << nv) - 1);
                    if let Some(row) = self.table.row(cut.meta, code) {
                        let cell = RowCell {
                            ids: &cut.ids,
                            phi: &cut.phi,
                            t,
                            slot: cut.slot(),
                        };
                        if weld.emit_row(row, cell, ctx, &mut out) {
                            continue;
                        }
                    }
                }
                slow = Some(cut);
                break;
            }
            drop(out);
            if let Some(cut) = slow {
                self.emit_one(t, cut, weld, mesh);
            }
        }
    }

    /// Emits one cut cell through the catalog (and the hash map where the
    /// weld table cannot place an edge).
    #[inline(never)]
    fn emit_one(&self, t: f32, cut: &Cut, weld: &mut CpWeld, mesh: &mut LevelMesh) {
        let mut ids = [0u32; MAX_META_VERTICES];
        let mut phi = [0f32; MAX_META_VERTICES];
        let nv = cut.n as usize;
        let (gids, phi) = if nv <= CUT_VERTICES {
            (&cut.ids[..nv], &cut.phi[..nv])
        } else {
            self.g.cell(cut.slot(), &mut ids);
            for l in 0..nv {
                phi[l] = self.f.phi(ids[l]);
            }
            (&ids[..nv], &phi[..nv])
        };
        let cell = CutCell {
            meta: self.g.catalog().get(cut.meta),
            gids,
            phi,
            t,
            code: code_of(phi, t),
            slot: cut.slot(),
        };
        weld.emit_cell(&cell, self.ctx, mesh);
    }
}

/// The smallest φ of the vertices of cell `nb`, decoded (when the minima
/// search kept no `lo` per cell).
#[inline(never)]
fn decoded_lo<F: ScalarField>(g: &CpGraph, f: &F, nb: u32) -> f32 {
    let mut ids = [0u32; MAX_META_VERTICES];
    let (_, n) = g.cell(nb, &mut ids);
    ids[..n]
        .iter()
        .fold(f32::INFINITY, |lo, &v| lo.min(f.phi(v)))
}

/// Levels [`next_above`] compares at a time, without a branch.
const LEVEL_WINDOW: usize = 4;

/// The first level index after `k` whose level is above `x` (the level
/// count when none), for strictly increasing levels given as `padded`:
/// them, then [`LEVEL_WINDOW`] NaNs (never at or below anything). The
/// levels at or below `x` are a prefix of each window, so counting them
/// moves as a loop over the levels would, with one well-predicted branch
/// per window instead of one per level (a cell spans a few levels, and the
/// loop's exit mispredicted about once per cell).
#[inline(always)]
fn next_above(padded: &[f32], k: usize, x: f32) -> usize {
    let mut l = k + 1;
    loop {
        let w = &padded[l..l + LEVEL_WINDOW];
        let c: usize = w.iter().map(|&level| (level <= x) as usize).sum();
        l += c;
        if c < LEVEL_WINDOW {
            return l;
        }
    }
}

/// The [`Cut`] record (key 0) of a cell of meta-cell `m` with the `nv`
/// vertex ids `ids`, and its largest φ. Eight vertices (hexahedra, the
/// common case) take a fixed-size path that the compiler unrolls.
#[inline(always)]
fn read_cut<F: ScalarField>(
    f: &F,
    m: u16,
    ids: &[u32; MAX_META_VERTICES],
    nv: usize,
) -> (Cut, f32) {
    let mut cut = Cut {
        meta: m,
        n: nv as u16,
        ..Default::default()
    };
    let mut hi = f32::NEG_INFINITY;
    if nv == CUT_VERTICES {
        let mut head = [0u32; CUT_VERTICES];
        head.copy_from_slice(&ids[..CUT_VERTICES]);
        cut.ids = head;
        cut.phi = head.map(|v| f.phi(v));
        for p in cut.phi {
            hi = hi.max(p);
        }
        return (cut, hi);
    }
    for (l, &v) in ids[..nv].iter().enumerate() {
        let p = f.phi(v);
        hi = hi.max(p);
        if l < CUT_VERTICES {
            cut.ids[l] = v;
            cut.phi[l] = p;
        }
    }
    (cut, hi)
}

/// Hints the CPU to fetch the rows the cut cell `ahead` will read: its
/// vertices' positions, attribute and weld entries. A hexahedron's vertex
/// `l + 4` follows vertex `l` on the same pillar (its rows mostly in the
/// same cache lines), so only its first four are fetched.
#[inline(always)]
fn prefetch_rows(ahead: &Cut, ctx: &EmitContext, weld: &CpWeld) {
    let fetch = |v: u32| {
        prefetch(ctx.positions, v as usize);
        if let Some(a) = ctx.attribute {
            prefetch(a, v as usize);
        }
        weld.prefetch(v);
    };
    if ahead.meta == builtin::HEXAHEDRON {
        // A fixed count: the loop is unrolled.
        let [a, b, c, d, ..] = ahead.ids;
        [a, b, c, d].into_iter().for_each(fetch);
    } else {
        let n = (ahead.n as usize).min(CUT_VERTICES);
        ahead.ids[..n].iter().copied().for_each(fetch);
    }
}
