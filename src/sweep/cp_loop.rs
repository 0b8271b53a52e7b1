//! The sweep loop of the corner-point graph ([`CpGraph`]): the lattice
//! loop's *entry levels* on explicit vertex ids. Each live cell is read
//! once per sweep, at its entry level `L(lo)` (the first k with
//! `lo < t_k`); a cut cell stays in `A` with the last level that cuts it
//! packed beside its slot, so later steps keep it without reading φ. A
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

use super::cp_weld::CpWeld;
use super::lattice::{LatticeQueues, merge_active, pack_active, set_bit};
use super::{Block, LevelStats, Minimum, PREFETCH_AHEAD, radix_sort_by_slot, radix_sort_slots};
use crate::extract::{EmitContext, LevelMesh, code_of, prefetch};
use crate::field::ScalarField;
use crate::metacell::MAX_META_VERTICES;
use crate::structures::cpgraph::CpGraph;
use crate::sweep::CellGraph;

/// The corner-point graph's sweep of one block (see the module docs).
#[inline(never)]
pub(super) fn sweep_block_cp<F: ScalarField>(
    g: &CpGraph,
    f: &F,
    b: &mut Block,
    minima: &[Minimum],
    levels: &[f32],
    ctx: &EmitContext,
    mut on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
) {
    let start = b.start;
    let n = levels.len();
    let Block {
        stamps,
        mesh,
        lattice,
        sort_scratch,
        ..
    } = b;
    let q = &mut lattice.get_or_insert_with(Default::default).cells;
    let len = stamps.len() as u32;
    // Dead slots are seen from the start (the stamps hold NEVER there).
    q.seen.clear();
    q.seen.resize((len as usize).div_ceil(64), 0);
    for (j, &s) in stamps.iter().enumerate() {
        if s == super::NEVER {
            q.seen[j / 64] |= 1 << (j % 64);
        }
    }
    q.queue_minima(minima, levels, start);
    let LatticeQueues {
        entering,
        active,
        fresh,
        scratch,
        seen,
    } = q;
    let mut ids = [0u32; MAX_META_VERTICES];
    let mut nb_ids = [0u32; MAX_META_VERTICES];
    let mut phi = [0f32; MAX_META_VERTICES];
    let [nx, ny, _] = g.dims;
    let mut weld = CpWeld::new(g.positions.len(), (nx + 1) * (ny + 1), nx + 1);
    for (k, &t) in levels.iter().enumerate() {
        mesh.clear();
        weld.next_level();
        let mut work = std::mem::take(&mut entering[k]);
        radix_sort_slots(&mut work, sort_scratch, start, len);
        fresh.clear();
        let mut i = 0;
        while i < work.len() {
            let c = work[i];
            if let Some(&ahead) = work.get(i + PREFETCH_AHEAD) {
                g.prefetch_cell(ahead, ctx);
            }
            i += 1;
            let (_, nv) = g.cell(c, &mut ids);
            let mut hi = f32::NEG_INFINITY;
            for &v in &ids[..nv] {
                hi = hi.max(f.phi(v));
            }
            if t <= hi {
                let mut last = k;
                while last + 1 < n && levels[last + 1] <= hi {
                    last += 1;
                }
                fresh.push(pack_active(c, last));
            }
            g.for_each_neighbour(c, |nb| {
                let j = nb.wrapping_sub(start);
                if j < len && set_bit(seen, j) {
                    let (_, nn) = g.cell(nb, &mut nb_ids);
                    let mut lo = f32::INFINITY;
                    for &v in &nb_ids[..nn] {
                        lo = lo.min(f.phi(v));
                    }
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
            });
        }
        let entered = work.len();
        work.clear();
        entering[k] = work;
        radix_sort_by_slot(fresh, scratch, start, len, |x| (x >> 32) as u32);
        let carried = active.len();
        merge_active(active, fresh, k, scratch);
        std::mem::swap(active, scratch);
        // The level's polygons, in slot order.
        let catalog = g.catalog();
        for (x, &e) in active.iter().enumerate() {
            if let Some(&ahead) = active.get(x + 2 * PREFETCH_AHEAD) {
                // The rows the cell ahead reads: positions, attribute, φ
                // and its vertices' weld entries.
                let (_, na) = g.cell((ahead >> 32) as u32, &mut nb_ids);
                for &v in &nb_ids[..na] {
                    prefetch(ctx.positions, v as usize);
                    if let Some(a) = ctx.attribute {
                        prefetch(a, v as usize);
                    }
                    if let Some(values) = f.values() {
                        prefetch(values, v as usize);
                    }
                    weld.prefetch(v);
                }
            }
            let c = (e >> 32) as u32;
            let (m, nv) = g.cell(c, &mut ids);
            for l in 0..nv {
                phi[l] = f.phi(ids[l]);
            }
            let code = code_of(&phi[..nv], t);
            weld.emit_cell(
                catalog.get(m),
                &ids[..nv],
                &phi[..nv],
                t,
                code,
                c,
                ctx,
                mesh,
            );
        }
        let stats = LevelStats::of(mesh, (entered + carried) as u64);
        on_level(k, mesh, &stats);
    }
}
