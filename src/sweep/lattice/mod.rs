//! The S-CGraph's fast path: the incremental sweep specialised for
//! hexahedral lattices with φ stored per vertex. The per-cell loop lives
//! here; `chunks` runs the same steps over 64-cell patches; `emit` writes a
//! level's cut cells; `weld` holds the hexahedron's tables by geometric code
//! and the weld by edge ownership.

pub(super) mod chunks;
mod emit;
mod index;
pub mod weld;
pub(in crate::sweep) mod writer;

use super::{
    Block, LevelStats, Minimum, NEVER, PREFETCH_AHEAD, radix_sort_by_slot, radix_sort_slots,
};
use crate::cellgraph::BitSet;
pub use crate::cellgraph::Lattice;
use crate::extract::{EmitContext, LevelMesh, prefetch};
use emit::{CutCells, emit_cut_cells};
use weld::EdgeOwnership;
use weld::EdgeWindow;

/// What a lattice block sweep reads besides the block and its levels: the
/// lattice, φ per vertex (at least [`Lattice::vertices`] values), the
/// emission context, and whether to weld by the mesh's hash map instead of
/// by edge ownership.
#[derive(Clone, Copy)]
pub(crate) struct LatticeSweep<'a> {
    /// The lattice.
    pub(crate) lat: Lattice<'a>,
    /// φ per vertex.
    pub(crate) phi: &'a [f32],
    /// Positions and attribute of the output.
    pub(crate) ctx: &'a EmitContext<'a>,
    /// Weld by the mesh's hash map (the lattices whose weld window would
    /// not fit always do).
    pub(crate) hash_weld: bool,
}

/// A block's lattice-loop state, made on the first lattice sweep and kept
/// between sweeps for its capacity (other structures' blocks have none).
#[derive(Debug, Default)]
pub(super) struct LatticeState {
    /// Weld table of both loops.
    window: EdgeWindow,
    /// Queues of the per-cell loop (and of the corner-point graph's loop).
    pub(in crate::sweep) cells: LatticeQueues,
    /// State of the chunked loop.
    chunks: chunks::ChunkQueues,
}

impl LatticeState {
    /// Bytes held.
    pub(super) fn bytes(&self) -> usize {
        self.window.bytes() + self.cells.bytes() + self.chunks.bytes()
    }
}

/// The lattice loop's queues, kept between sweeps for their capacity.
#[derive(Debug, Default)]
pub(in crate::sweep) struct LatticeQueues {
    /// Per level k: the cells that enter at step k (`t_{k-1} <= lo < t_k`),
    /// in the order they were found.
    pub(in crate::sweep) entering: Vec<Vec<u32>>,
    /// `A_k` in slot order, each cell packed with the last level that cuts
    /// it ([`pack_active`]).
    pub(in crate::sweep) active: Vec<u64>,
    /// The cells entering at this step that the level cuts, packed.
    pub(in crate::sweep) fresh: Vec<u64>,
    /// Scratch for sorting `fresh` and merging it into `active`.
    pub(in crate::sweep) scratch: Vec<u64>,
    /// Per block slot, one bit: dead (never swept), or found in this
    /// sweep. Reset from the lattice's live bits when a sweep starts. One
    /// bit per slot instead of the u16 stamps keeps a level's neighbour
    /// tests in cache.
    pub(in crate::sweep) seen: Vec<u64>,
}

impl LatticeQueues {
    /// Bytes held.
    pub(super) fn bytes(&self) -> usize {
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

    /// Empties the per-level queues and the active queue for `levels`,
    /// then queues each minimum at its entry level (the step where the
    /// level first passes its lo) and marks it in `seen`. Every other cell
    /// is queued by the first neighbour that enters (ARCHITECTURE.md,
    /// invariants), so each cell is queued once.
    pub(in crate::sweep) fn queue_minima(
        &mut self,
        minima: &[Minimum],
        levels: &[f32],
        start: u32,
    ) {
        let n = levels.len();
        if self.entering.len() < n {
            self.entering.resize_with(n, Vec::new);
        }
        for e in &mut self.entering[..n] {
            e.clear();
        }
        self.active.clear();
        for m in minima {
            let l = levels.partition_point(|&t| t <= m.lo);
            if l < n && set_bit(&mut self.seen, m.slot - start) {
                self.entering[l].push(m.slot);
            }
        }
    }

    /// Starts a sweep over the block of `len` slots from `start`: every
    /// slot is unseen but the dead ones (the complement of `live`).
    pub(super) fn begin_sweep(&mut self, live: &BitSet, start: u32, len: usize) {
        self.seen.clear();
        self.seen
            .extend((0..len.div_ceil(64)).map(|w| !live.word_at(start as i64 + 64 * w as i64)));
    }
}

/// Sets bit `j` of `bits`; returns whether it was clear.
#[inline(always)]
pub(in crate::sweep) fn set_bit(bits: &mut [u64], j: u32) -> bool {
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
pub(in crate::sweep) fn pack_active(slot: u32, last: usize) -> u64 {
    (slot as u64) << 32 | last as u64
}

/// [`block_minima`] on a hexahedral [`Lattice`] with φ per vertex: the same
/// minima (a cell is one when no live in-block face neighbour has a smaller
/// `(lo, slot)`), with each cell's `lo` taken from two per-layer tables of
/// 2×2 vertex minima instead of an 8-vertex gather per cell, one k-slab at
/// a time (three slabs of `lo` and two of vertex minima live at once).
pub(super) fn block_minima_lattice(lat: &Lattice, phi: &[f32], b: &Block) -> Vec<Minimum> {
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

/// The set-up both lattice loops share: checks that φ covers the lattice's
/// vertices (every live cell's vertices, and those of its live neighbours,
/// are below `lat.vertices`: this one check makes the unchecked φ reads
/// sound), creates the block's lattice state and fits its weld window.
/// Returns the edge ownership when the polygons are welded by it (`None`:
/// the hash weld).
pub(super) fn prepare_block(input: &LatticeSweep, b: &mut Block) -> Option<EdgeOwnership> {
    let lat = &input.lat;
    assert!(
        input.phi.len() >= lat.vertices,
        "φ has {} values for {} vertices",
        input.phi.len(),
        lat.vertices
    );
    let [_, dj, dk] = lat.deltas;
    let owner = EdgeOwnership::new(dj, dk / dj);
    let own_weld = owner.fits && !input.hash_weld;
    let state = b.lattice.get_or_insert_with(Default::default);
    if own_weld {
        state.window.fit(&owner);
    }
    own_weld.then_some(owner)
}

/// [`sweep_block`] specialised for a hexahedral [`Lattice`] with φ stored
/// per vertex: the same cut cells `A_k` and output (tests compare it with
/// the generic loop and the brute force), but each cell is read once, at
/// its entry level, and stays in `A` until the last level below its `hi`
/// (see [`LatticeQueues`]). Polygons are welded by edge ownership
/// ([`weld`]), or by the mesh's hash map when `hash_weld` is set
/// or the lattice's layers are too large for the weld window. Cells are
/// read in geometric vertex order (`g = i + 2j + 4k`, see
/// [`LatticeHexTable`]), so faces, neighbours and far vertices are
/// constants of the lattice.
#[inline(never)]
pub(super) fn sweep_block_lattice(
    input: &LatticeSweep,
    b: &mut Block,
    minima: &[Minimum],
    levels: &[f32],
    mut on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
) {
    let LatticeSweep { ref lat, phi, .. } = *input;
    let start = b.start;
    let [di, dj, dk] = lat.deltas;
    debug_assert_eq!(
        lat.table.geometric_offsets(),
        [0, di, dj, dj + di, dk, dk + di, dk + dj, dk + dj + di]
    );
    let owner = prepare_block(input, b);
    let Block {
        stamps,
        mesh,
        lattice,
        sort_scratch,
        ..
    } = b;
    let LatticeState {
        window, cells: q, ..
    } = lattice.as_deref_mut().expect("set above");
    let len = stamps.len() as u32;
    q.begin_sweep(lat.live, start, len as usize);
    q.queue_minima(minima, levels, start);
    let LatticeQueues {
        entering,
        active,
        fresh,
        scratch,
        seen,
        ..
    } = q;
    for (k, &t) in levels.iter().enumerate() {
        mesh.clear();
        // The cells queued for this step by earlier ones, read in slot
        // order (warped 256³: 3–5 % faster than in the order found); the
        // ones found during the step follow.
        let mut work = std::mem::take(&mut entering[k]);
        radix_sort_slots(&mut work, sort_scratch, start, len);
        fresh.clear();
        let step = CellStep {
            lat,
            phi,
            levels,
            k,
            t,
            start,
            len,
        };
        let mut i = 0;
        while i < work.len() {
            let c = work[i];
            if let Some(&ahead) = work.get(i + 2 * PREFETCH_AHEAD) {
                step.prefetch(ahead, seen);
            }
            i += 1;
            let mut queues = CellQueues {
                work: &mut work,
                entering,
                fresh,
                seen,
            };
            step.read_cell(c, &mut queues);
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
        let cells = CutCells {
            cut: active,
            slot_of: |x: u64| (x >> 32) as u32,
            start,
            len,
            t,
        };
        emit_cut_cells(input, cells, owner.as_ref(), mesh, window);
        // Visited: the cells read at this step (entries) and the queue of
        // A_{k-1} filtered by each cell's last level.
        let stats = LevelStats::of(mesh, (entered + carried) as u64);
        on_level(k, mesh, &stats);
    }
}

/// Step `k` of [`sweep_block_lattice`] in the block of `len` slots from
/// `start`: what reading a cell needs besides the queues.
struct CellStep<'a, 'l> {
    lat: &'a Lattice<'l>,
    phi: &'a [f32],
    levels: &'a [f32],
    k: usize,
    /// `levels[k]`.
    t: f32,
    start: u32,
    len: u32,
}

/// The queues a cell read at a step writes: the step's work queue, the
/// per-level entry queues, the step's cut entries and the seen bits (see
/// [`LatticeQueues`]).
struct CellQueues<'q> {
    work: &'q mut Vec<u32>,
    entering: &'q mut [Vec<u32>],
    fresh: &'q mut Vec<u64>,
    seen: &'q mut [u64],
}

impl CellStep<'_, '_> {
    /// Prefetches for the cell `ahead`, to be read a few entries later:
    /// its four φ rows, the seen words of its k neighbours (the i and j
    /// ones share or neighbour its word), and the φ rows of their far
    /// faces.
    #[inline(always)]
    fn prefetch(&self, ahead: u32, seen: &[u64]) {
        let [_, dj, dk] = self.lat.deltas;
        let v = ahead - self.lat.base;
        for r in [v, v + dj, v + dk, v + dj + dk] {
            prefetch(self.phi, r as usize);
        }
        for nb in [ahead - dk, ahead + dk] {
            prefetch(seen, nb.wrapping_sub(self.start) as usize / 64);
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
            prefetch(self.phi, r as usize);
        }
    }

    /// Reads cell `c` at its entry level `k`: queues it in `fresh` when
    /// the level cuts it (with the last level that does), and queues each
    /// new neighbour at its entry level (this step's work queue, or a
    /// later entry queue).
    #[inline(always)]
    fn read_cell(&self, c: u32, q: &mut CellQueues) {
        let CellStep {
            lat,
            phi,
            levels,
            k,
            t,
            start,
            len,
        } = *self;
        let CellQueues {
            work,
            entering,
            fresh,
            seen,
        } = q;
        let [di, dj, dk] = lat.deltas;
        // SAFETY (for `at` and `load8`): the cell is live and its
        // neighbours' far vertices are read only for a live neighbour (not
        // in `seen`, so not a never-sweep slot): all < lat.vertices <=
        // phi.len() (checked by the caller).
        let at = |v: u32| unsafe { *phi.get_unchecked(v as usize) };
        let v0 = c - lat.base;
        let f = unsafe { load8(phi, v0, dj, dk) };
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
            fresh.push(pack_active(c, last_cut_level(levels, k, hi)));
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
                    queue_at_entry(nb, lo, levels, k, work, entering);
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
}

/// Writes into `out` the cells of `carried` (`A_{k-1}`, packed by
/// [`pack_active`], in slot order) still cut at level `k`, merged in slot
/// order with `fresh` (sorted; no slot in both).
pub(in crate::sweep) fn merge_active(carried: &[u64], fresh: &[u64], k: usize, out: &mut Vec<u64>) {
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

/// min of two non-NaN values (one `minss`; φ is never NaN).
#[inline(always)]
pub(super) fn fmin(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// max of eight non-NaN values.
#[inline(always)]
pub(super) fn max8(f: &[f32; 8]) -> f32 {
    let m = |a: f32, b: f32| if a > b { a } else { b };
    m(
        m(m(f[0], f[1]), m(f[2], f[3])),
        m(m(f[4], f[5]), m(f[6], f[7])),
    )
}

/// [`code_of`] for eight values: bit q set iff `f[q] >= t`.
#[inline(always)]
pub(in crate::sweep) fn code8(f: &[f32; 8], t: f32) -> usize {
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

/// The last level from `k` on that cuts a cell whose largest φ is `hi`
/// (the cell stays active through it without being read again).
#[inline(always)]
pub(in crate::sweep) fn last_cut_level(levels: &[f32], k: usize, hi: f32) -> usize {
    let mut last = k;
    while last + 1 < levels.len() && levels[last + 1] <= hi {
        last += 1;
    }
    last
}

/// Queues a newly found neighbour `nb` whose smallest φ is `lo` at its
/// entry level: this step (`work`) when `lo` is below level `k`'s value,
/// else the first later level at or above `lo` (none past the last).
#[inline(always)]
pub(in crate::sweep) fn queue_at_entry(
    nb: u32,
    lo: f32,
    levels: &[f32],
    k: usize,
    work: &mut Vec<u32>,
    entering: &mut [Vec<u32>],
) {
    if lo < levels[k] {
        work.push(nb);
        return;
    }
    let mut l = k + 1;
    while l < levels.len() && levels[l] <= lo {
        l += 1;
    }
    if l < levels.len() {
        entering[l].push(nb);
    }
}

/// φ of the lattice cell with first vertex `v0` in geometric order
/// (`g = i + 2j + 4k`): four (i, i+1) pairs, rows `dj` and layers `dk` apart.
///
/// # Safety
/// `v0 + dj + dk + 1` must be a vertex (< `phi.len()`).
#[inline(always)]
pub(crate) unsafe fn load8(phi: &[f32], v0: u32, dj: u32, dk: u32) -> [f32; 8] {
    let p = phi.as_ptr();
    let pair = |v: u32| {
        // SAFETY: the caller guarantees v + 1 < phi.len().
        unsafe { [*p.add(v as usize), *p.add(v as usize + 1)] }
    };
    let [a, b, c, d] = [pair(v0), pair(v0 + dj), pair(v0 + dk), pair(v0 + dj + dk)];
    [a[0], a[1], b[0], b[1], c[0], c[1], d[0], d[1]]
}
