//! The lattice loop over 64-cell chunks: the sweep (ARCHITECTURE.md) on a
//! hexahedral [`Lattice`], with 64 cells handled together. A chunk is a
//! *patch* of `width × height` cells (i × j, `width` one of [`WIDTHS`],
//! `height = 64 / width`) in one layer, the width picked per block from
//! φ's change along i and j ([`patch_width`]) so that a level crosses a
//! patch in as many cells as it can: then the patch is processed at few
//! steps for many cut cells.
//!
//! A chunk is *touched* when the propagation first reaches it: a minimum in
//! it enters, or a cell across one of its faces does. Touching reads its
//! `2 · (height + 1)` vertex rows once and stores, per cell, its entry level
//! `enter = #{t_k <= lo}` (the first level with `lo < t_k`) and
//! `leave = #{t_k <= hi}`: the cell is cut exactly at the levels
//! `enter <= k < leave` (the tie rule `lo < t <= hi`, decided once with the
//! same comparisons). From then on the chunk is processed only at the steps
//! where one of its cells enters or is cut, as bytes compared with `k`
//! (SIMD): the cells that enter at k touch the chunks across their faces,
//! the cut ones go to the step's output, and the chunk schedules itself at
//! its next such step. When none is left it is done and its level bytes
//! are freed, so memory follows the sweep front, not the grid. A step's cut
//! cells go to the emitter in slot order (its weld needs it): one row of
//! patches at a time, cell row by cell row, patch by patch along i. The
//! S-CGraph's ghost column and row (never live) get no patches.
//!
//! Why every cut cell is found: every cell c with `enter(c) = j` has its
//! chunk touched by step j. By induction on the key `(lo, slot)`: a minimum's
//! chunk is touched at its entry step by the minima queue; any other cell
//! has a predecessor p across a face with `lo(p) <= lo(c)`, so
//! `enter(p) <= j`; p's chunk, touched by step `enter(p)`, is processed at
//! that step (a touched chunk is processed at every step where one of its
//! cells enters), and p, entering, touches c's chunk. A touched chunk is then
//! processed at every step where one of its cells is cut. So the cut cells
//! at level k are exactly the cells `enter <= k < leave`: the brute force's
//! set. Tests compare every level with the per-cell loop, the generic loop
//! and the brute force.

use super::index::{Divisor, LevelIndex};
use super::{CutCells, Lattice, LatticeState, LatticeSweep, emit_cut_cells};
use crate::extract::LevelMesh;
use crate::sweep::{Block, LevelStats, Minimum};

/// Chunk state: not reached yet.
const UNTOUCHED: u32 = u32::MAX;
/// Chunk state: every cell has entered and left (or never will).
const DONE: u32 = u32::MAX - 1;
/// Chunk state: reached, waiting in `pending` to be touched.
const PENDING: u32 = u32::MAX - 2;
/// Largest level count the byte-sized levels can hold.
pub(crate) const MAX_LEVELS: usize = 255;

/// The chunked loop's state, kept between sweeps for its capacity.
#[derive(Debug, Default)]
pub struct ChunkQueues {
    /// Per chunk: [`UNTOUCHED`], [`PENDING`], [`DONE`], or its record in
    /// `levels` (touched: it has a step scheduled).
    state: Vec<u32>,
    /// Records of 128 bytes: the `enter` bytes of the chunk's 64 cells, then
    /// their `leave` bytes (dead cells: 255 and 0).
    levels: Vec<u8>,
    /// Free records.
    free: Vec<u32>,
    /// Per level: the chunks scheduled at that step.
    scheduled: Vec<Vec<u32>>,
    /// Chunks reached at this step, to touch (read) in a batch, with
    /// prefetching.
    pending: Vec<u32>,
    /// Per chunk, its cut cells at this step (valid where `cut_chunks` is set).
    cut: Vec<u64>,
    /// One bit per chunk: it has cut cells at this step.
    cut_chunks: Vec<u64>,
    /// This step's cut cells, in slot order.
    slots: Vec<u32>,
    /// Per patch: [`HAS_LEFT`] … [`HAS_UP`].
    flags: Vec<u8>,
    /// The cut patches of one patch row being collected: first slot, cut
    /// cells.
    group: Vec<(u32, u64)>,
}

impl ChunkQueues {
    /// Bytes held.
    pub fn bytes(&self) -> usize {
        (self.state.capacity()
            + self.free.capacity()
            + self.slots.capacity()
            + self.pending.capacity())
            * 4
            + self.flags.capacity()
            + self.group.capacity() * 16
            + self.levels.capacity()
            + (self.cut.capacity() + self.cut_chunks.capacity()) * 8
            + self
                .scheduled
                .iter()
                .map(|q| q.capacity() * 4)
                .sum::<usize>()
    }

    /// Starts a sweep of `levels` levels over `chunks` chunks.
    fn begin(&mut self, chunks: usize, levels: usize) {
        self.state.clear();
        self.state.resize(chunks, UNTOUCHED);
        self.levels.clear();
        self.free.clear();
        if self.scheduled.len() < levels {
            self.scheduled.resize_with(levels, Vec::new);
        }
        for q in &mut self.scheduled[..levels] {
            q.clear();
        }
        self.cut.clear();
        self.cut.resize(chunks, 0);
        self.cut_chunks.clear();
        self.cut_chunks.resize(chunks.div_ceil(64), 0);
        self.pending.clear();
    }

    /// Appends the cut cells of the patches in `group` (one row of patches
    /// of `shape`, in order) to `slots` in slot order, and empties the
    /// group.
    /// Prefetches the level record of patch `w` (touched patches only:
    /// those pushed by a touch this step are processed right after it).
    #[inline(always)]
    fn prefetch_record(&self, w: u32) {
        let r = self.state[w as usize] as usize;
        if r < PENDING as usize {
            prefetch_nta(&self.levels, r * 128);
            prefetch_nta(&self.levels, r * 128 + 64);
        }
    }

    /// Step `k` (of `n`) of the touched patch `w`: records its cut cells,
    /// schedules its next step or marks it done; returns its cells that
    /// enter at this step.
    #[inline(always)]
    fn step_patch(&mut self, w: u32, k: usize, n: usize) -> u64 {
        let r = self.state[w as usize] as usize;
        let m = step_masks(&self.levels[r * 128..r * 128 + 128], k as u8);
        if m.cut != 0 {
            self.cut[w as usize] = m.cut;
            self.cut_chunks[w as usize / 64] |= 1 << (w % 64);
        }
        if (m.next as usize) < n {
            self.scheduled[m.next as usize].push(w);
        } else {
            self.state[w as usize] = DONE;
            self.free.push(r as u32);
        }
        m.new
    }

    /// Marks patch `w` pending, unless it was touched already.
    #[inline(always)]
    fn reach(&mut self, w: u32) {
        if self.state[w as usize] == UNTOUCHED {
            self.state[w as usize] = PENDING;
            self.pending.push(w);
        }
    }

    /// This step's cut cells into `slots` in slot order, from the cut
    /// patches (emptied): per patch row of a layer (the cut patches in
    /// order, grouped), row by row of cells, patch by patch.
    #[inline(always)]
    fn order_cut_cells(&mut self, patches: &Patches) {
        self.slots.clear();
        let mut group_end = 0u32;
        for x in 0..self.cut_chunks.len() {
            while self.cut_chunks[x] != 0 {
                let w = 64 * x as u32 + self.cut_chunks[x].trailing_zeros();
                self.cut_chunks[x] &= self.cut_chunks[x] - 1;
                let place = patches.place(w);
                if w >= group_end {
                    self.flush_group(patches);
                    group_end = w - place.2 + patches.columns;
                }
                self.group
                    .push((patches.first_slot_at(place), self.cut[w as usize]));
            }
        }
        self.flush_group(patches);
    }

    fn flush_group(&mut self, shape: &Patches) {
        let (width, row_bits) = (shape.width, shape.row_bits());
        let dj = shape.dj;
        let any = self.group.iter().fold(0u64, |a, g| a | g.1);
        for r in 0..shape.height {
            if any >> (width * r) & row_bits == 0 {
                continue;
            }
            for &(first, cut) in &self.group {
                let mut row = cut >> (width * r) & row_bits;
                let base = first + r * dj;
                while row != 0 {
                    self.slots.push(base + row.trailing_zeros());
                    row &= row - 1;
                }
            }
        }
        self.group.clear();
    }

    /// A free record (grown when none is).
    fn alloc(&mut self) -> u32 {
        self.free.pop().unwrap_or_else(|| {
            let r = self.levels.len() / 128;
            self.levels.resize(self.levels.len() + 128, 0);
            r as u32
        })
    }
}

/// Patch flags: it has a neighbour patch before it along i, after it along
/// i, before it along j, after it along j.
const HAS_LEFT: u8 = 1;
/// See [`HAS_LEFT`].
const HAS_RIGHT: u8 = 2;
/// See [`HAS_LEFT`].
const HAS_DOWN: u8 = 4;
/// See [`HAS_LEFT`].
const HAS_UP: u8 = 8;
/// The patch widths (cells along i) the loop is built for; the height is
/// 64 / width.
pub(crate) const WIDTHS: [u32; 4] = [8, 16, 32, 64];

/// The block's slots cut into patches of `width × height` cells (i × j,
/// 64 in all) in one layer: patch `w = (layer · rows + row) · columns +
/// column`, cell bit `width · (j mod height) + (i mod width)`. Slots outside
/// the block, and the patch cells past a row or layer end, are dead bits.
#[derive(Clone, Copy, Debug)]
struct Patches {
    /// Cells along i and rows along j.
    width: u32,
    height: u32,
    /// Slot steps along j and k.
    dj: u32,
    dk: u32,
    /// Patches per patch row (along i), patch rows per layer (along j).
    columns: u32,
    rows: u32,
    /// The block's first layer, and its slots.
    first_layer: u32,
    start: u32,
    len: u32,
    /// Patches in all.
    count: u32,
    /// Division by `columns` and by `rows`.
    by_columns: Divisor,
    by_rows: Divisor,
}

impl Patches {
    /// The patches of `width` for the block `start..start + len` of `lat`.
    /// When the lattice's last column and last row of slots hold no live
    /// cell (the S-CGraph's ghost layer), the patches stop before them.
    fn new(width: u32, lat: &Lattice, start: u32, len: u32) -> Self {
        debug_assert!(WIDTHS.contains(&width));
        let [_, dj, dk] = lat.deltas;
        let height = 64 / width;
        let npj = dk / dj;
        let (first_layer, end_layer) = (start / dk, (start + len).div_ceil(dk));
        let any_live = |slot: &dyn Fn(u32, u32) -> u32, n: u32| {
            (first_layer..end_layer).any(|k| (0..n).any(|x| lat.live.get(slot(k, x) as usize)))
        };
        let ghost_column = npj > 0 && !any_live(&|k, j| k * dk + j * dj + dj - 1, npj);
        let ghost_row = dj > 0 && !any_live(&|k, i| k * dk + (npj - 1) * dj + i, dj);
        let columns = (dj - ghost_column as u32).div_ceil(width);
        let rows = (npj - ghost_row as u32).div_ceil(height);
        let layers = end_layer - first_layer;
        Patches {
            width,
            height,
            dj,
            dk,
            columns,
            rows,
            first_layer,
            start,
            len,
            count: layers * rows * columns,
            by_columns: Divisor::new(columns.max(1)),
            by_rows: Divisor::new(rows.max(1)),
        }
    }

    /// The bits of one row of cells (the first).
    #[inline(always)]
    fn row_bits(&self) -> u64 {
        u64::MAX >> (64 - self.width)
    }

    /// The bits of the first column of cells.
    #[inline(always)]
    fn column_bits(&self) -> u64 {
        (0..self.height).fold(0, |m, r| m | 1 << (self.width * r))
    }

    /// Patch w's (layer in the block, patch row, patch column).
    #[inline(always)]
    fn place(&self, w: u32) -> (u32, u32, u32) {
        let (g, column) = self.by_columns.div_rem(w);
        let (layer, row) = self.by_rows.div_rem(g);
        (layer, row, column)
    }

    /// The slot of patch w's first cell (bit 0; it may lie outside the
    /// block).
    #[inline(always)]
    fn first_slot(&self, w: u32) -> u32 {
        self.first_slot_at(self.place(w))
    }

    /// [`Patches::first_slot`] of the patch at `(layer, row, column)`.
    #[inline(always)]
    fn first_slot_at(&self, (layer, row, column): (u32, u32, u32)) -> u32 {
        (layer + self.first_layer) * self.dk + row * self.height * self.dj + column * self.width
    }

    /// [`HAS_LEFT`] … [`HAS_UP`] of patch `w`.
    fn flags(&self, w: u32) -> u8 {
        let (_, row, column) = self.place(w);
        let flag = |has: bool, bit: u8| if has { bit } else { 0 };
        flag(column > 0, HAS_LEFT)
            | flag(column + 1 < self.columns, HAS_RIGHT)
            | flag(row > 0, HAS_DOWN)
            | flag(row + 1 < self.rows, HAS_UP)
    }

    /// The patch of slot `c` (in the block).
    #[inline(always)]
    fn of_slot(&self, c: u32) -> u32 {
        let i = c % self.dj;
        let j = c / self.dj % (self.dk / self.dj);
        let layer = c / self.dk - self.first_layer;
        (layer * self.rows + j / self.height) * self.columns + i / self.width
    }

    /// The dead bits of patch `w` (slots never swept: not live, past a row
    /// or layer end, or outside the block).
    fn dead_bits(&self, lat: &Lattice, w: u32) -> u64 {
        let place = self.place(w);
        let first = self.first_slot_at(place);
        let (_, row, column) = place;
        let row_cells = (self.dj - self.width * column).min(self.width);
        debug_assert!(row_cells > 0);
        let row_mask = u64::MAX >> (64 - row_cells);
        let rows_left = self.dk / self.dj - self.height * row;
        let mut live = 0u64;
        for r in 0..self.height.min(rows_left) {
            let c = first + r * self.dj;
            let mut bits = lat.live.word_at(c as i64) & row_mask;
            // Only the block's slots.
            let below = self.start.saturating_sub(c).min(64);
            let above = (self.start + self.len).saturating_sub(c).min(64);
            let inside = if above == 64 { !0 } else { (1u64 << above) - 1 };
            bits &= inside & (!0u64).checked_shl(below).unwrap_or(0);
            live |= bits << (self.width * r);
        }
        !live
    }
}

/// Per cell bit of a `W × 64/W` patch whose first cell's first vertex is
/// `v`, the min and max of φ over the cell's vertices. Vertices outside φ
/// (only dead cells have them) read +∞ for the min and −∞ for the max; dead
/// cells get values that the caller overwrites.
#[inline(always)]
fn patch_ranges<const W: usize>(phi: &[f32], v: i64, dj: u32, dk: u32) -> ([f32; 64], [f32; 64]) {
    let h = 64 / W;
    let (dj, dk) = (dj as i64, dk as i64);
    // The last vertex read: row h, the upper layer, column W.
    let inside = v >= 0 && v + h as i64 * dj + dk + (W as i64) < phi.len() as i64;
    // Per vertex of row r (columns 0..=W), the min and max over its two
    // layers.
    let column_range = |r: usize, mn: &mut [f32; 65], mx: &mut [f32; 65]| {
        let at = v + r as i64 * dj;
        if inside {
            let a = &phi[at as usize..][..W + 1];
            let b = &phi[(at + dk) as usize..][..W + 1];
            for q in 0..=W {
                // As the per-cell loop's min and max: a NaN is skipped (φ
                // is finite, the grid is checked, but the loops agree).
                let (x, y) = (a[q], b[q]);
                let m = if x < f32::INFINITY { x } else { f32::INFINITY };
                mn[q] = if y < m { y } else { m };
                let n = if x > f32::NEG_INFINITY {
                    x
                } else {
                    f32::NEG_INFINITY
                };
                mx[q] = if y > n { y } else { n };
            }
        } else {
            for q in 0..=W {
                let (mut m, mut n) = (f32::INFINITY, f32::NEG_INFINITY);
                for layer in [0, dk] {
                    let i = at + layer + q as i64;
                    if let Some(&x) = usize::try_from(i).ok().and_then(|i| phi.get(i)) {
                        m = if x < m { x } else { m };
                        n = if x > n { x } else { n };
                    }
                }
                mn[q] = m;
                mx[q] = n;
            }
        }
    };
    let mut lo = [0f32; 64];
    let mut hi = [0f32; 64];
    let (mut mn0, mut mx0) = ([0f32; 65], [0f32; 65]);
    let (mut mn1, mut mx1) = ([0f32; 65], [0f32; 65]);
    column_range(0, &mut mn0, &mut mx0);
    for r in 0..h {
        column_range(r + 1, &mut mn1, &mut mx1);
        let (lo, hi) = (&mut lo[W * r..W * r + W], &mut hi[W * r..W * r + W]);
        for q in 0..W {
            let x = if mn0[q] < mn0[q + 1] {
                mn0[q]
            } else {
                mn0[q + 1]
            };
            let y = if mn1[q] < mn1[q + 1] {
                mn1[q]
            } else {
                mn1[q + 1]
            };
            lo[q] = if x < y { x } else { y };
            let x = if mx0[q] > mx0[q + 1] {
                mx0[q]
            } else {
                mx0[q + 1]
            };
            let y = if mx1[q] > mx1[q + 1] {
                mx1[q]
            } else {
                mx1[q + 1]
            };
            hi[q] = if x > y { x } else { y };
        }
        std::mem::swap(&mut mn0, &mut mn1);
        std::mem::swap(&mut mx0, &mut mx1);
    }
    (lo, hi)
}

/// Fills a patch's record: per cell bit p, `enter` and `leave` from its
/// min and max (dead cells, in `dead`: 255 and 0). Returns the least
/// `enter`.
#[inline(always)]
fn fill_levels(
    rec: &mut [u8],
    lo: &[f32; 64],
    hi: &[f32; 64],
    dead: u64,
    index: &LevelIndex,
) -> u8 {
    let (enter, leave) = rec.split_at_mut(64);
    index.count_le_64(lo, enter);
    index.count_le_64(hi, leave);
    let mut least = u8::MAX;
    for p in 0..64 {
        if dead >> p & 1 == 1 {
            enter[p] = u8::MAX;
            leave[p] = 0;
        }
        least = least.min(enter[p]);
    }
    least
}

/// Prefetches the φ rows that touching the `W`-wide patch whose first
/// vertex is `v` reads (its height + 1 rows on both vertex layers).
#[inline(always)]
fn prefetch_patch<const W: usize>(phi: &[f32], v: i64, dj: u32, dk: u32) {
    for r in 0..=64 / W as u32 {
        for l in [0, dk] {
            let x = v + (r * dj + l) as i64;
            for line in (0..=W).step_by(16) {
                if x >= 0 {
                    prefetch_nta(phi, x as usize + line);
                }
            }
        }
    }
}

/// A prefetch of `s[i]` that keeps the line out of the outer caches.
#[inline(always)]
fn prefetch_nta<T>(s: &[T], i: usize) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: as for [`prefetch`]: never faults, reads nothing observable.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_NTA }>(
            s.as_ptr().wrapping_add(i) as *const i8,
        );
    }
}

/// A chunk's cells at step k, from its record.
struct StepMasks {
    /// Entering at k (`enter == k`).
    new: u64,
    /// Cut at k (`enter <= k < leave`).
    cut: u64,
    /// The next step that needs the chunk: k + 1 if a cell entered by k is
    /// still cut there, else the least `enter` above k (255: none).
    next: u8,
}

/// [`StepMasks`] of record `rec` at step `k` (< 255).
#[inline(always)]
fn step_masks(rec: &[u8], k: u8) -> StepMasks {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86_64 baseline; the loads read the
        // record's 128 bytes (unaligned).
        unsafe {
            assert!(rec.len() >= 128);
            let p = rec.as_ptr() as *const __m128i;
            let kv = _mm_set1_epi8(k as i8);
            let k1 = _mm_set1_epi8(k.wrapping_add(1) as i8);
            let (mut new, mut cut, mut cont) = (0u64, 0u64, 0u64);
            let mut least = _mm_set1_epi8(-1);
            for g in 0..4 {
                let e = _mm_loadu_si128(p.add(g));
                let l = _mm_loadu_si128(p.add(4 + g));
                // e <= k, l <= k, l <= k + 1 (unsigned, through max).
                let e_le = _mm_cmpeq_epi8(_mm_max_epu8(e, kv), kv);
                let l_le = _mm_cmpeq_epi8(_mm_max_epu8(l, kv), kv);
                let l_le1 = _mm_cmpeq_epi8(_mm_max_epu8(l, k1), k1);
                let bits = |m: __m128i| _mm_movemask_epi8(m) as u32 as u64;
                new |= bits(_mm_cmpeq_epi8(e, kv)) << (16 * g);
                cut |= bits(_mm_andnot_si128(l_le, e_le)) << (16 * g);
                cont |= bits(_mm_andnot_si128(l_le1, e_le)) << (16 * g);
                // enter above k, else 255.
                least = _mm_min_epu8(least, _mm_or_si128(e, e_le));
            }
            least = _mm_min_epu8(least, _mm_srli_si128(least, 8));
            least = _mm_min_epu8(least, _mm_srli_si128(least, 4));
            least = _mm_min_epu8(least, _mm_srli_si128(least, 2));
            least = _mm_min_epu8(least, _mm_srli_si128(least, 1));
            let least = _mm_cvtsi128_si32(least) as u8;
            let next = if cont != 0 { least.min(k + 1) } else { least };
            StepMasks { new, cut, next }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let (enter, leave) = rec.split_at(64);
        let (mut new, mut cut, mut cont, mut least) = (0u64, 0u64, 0u64, u8::MAX);
        for p in 0..64 {
            let (e, l) = (enter[p], leave[p]);
            new |= ((e == k) as u64) << p;
            cut |= ((e <= k && k < l) as u64) << p;
            cont |= ((e <= k && k + 1 < l) as u64) << p;
            if e > k {
                least = least.min(e);
            }
        }
        let next = if cont != 0 { least.min(k + 1) } else { least };
        StepMasks { new, cut, next }
    }
}

/// The patch width (cells along i; the height along j is 64 / width) that
/// makes a level cross a patch in many cells, so that each patch is
/// processed at few steps, without touches that read many short rows: the
/// least `width · |Δφ|_i + height · |Δφ|_j` (φ's change across the patch;
/// the layer's |Δφ|_k is the same for all) plus `1.25 · height · (|Δφ|_i +
/// |Δφ|_j)` for the touch. The mean |Δφ| per axis is measured on up to 4096
/// live cells spread over the block.
/// `forced` (one of [`WIDTHS`]; [`crate::sweep::SweepOptions::patch_width`])
/// overrides it, for A/B benchmarks.
pub(super) fn patch_width(
    lat: &Lattice,
    phi: &[f32],
    start: u32,
    len: u32,
    forced: Option<u32>,
) -> u32 {
    if let Some(w) = forced.filter(|w| WIDTHS.contains(w)) {
        return w;
    }
    let [di, dj, _] = lat.deltas;
    let stride = (len / 4096).max(1);
    let mut g = [0f64; 2];
    let mut c = start;
    while c < start + len {
        if lat.live.get(c as usize) {
            let v = (c - lat.base) as usize;
            let at = |d: u32| (phi[v + d as usize] - phi[v]).abs() as f64;
            g[0] += at(di);
            g[1] += at(dj);
        }
        c += stride;
    }
    // φ's change across a patch (the steps it is processed at), plus a
    // term for its touch, which reads height + 1 rows of vertices (fitted
    // to callgrind counts on warped 128³: along z, 8 wide crosses in fewer
    // steps, 16 wide touches fewer rows, and 16 runs fewer instructions).
    let cost = |w: u32| {
        let h = (64 / w) as f64;
        w as f64 * g[0] + h * g[1] + 1.25 * h * (g[0] + g[1])
    };
    WIDTHS
        .into_iter()
        .min_by(|&a, &b| cost(a).total_cmp(&cost(b)))
        .unwrap_or(16)
}

/// [`super::sweep_block_lattice`] over 64-cell patches (see the module
/// docs) of the width [`patch_width`] picks: the same cut cells per level,
/// emitted in slot order with the same polygons. Needs at most
/// [`MAX_LEVELS`] levels.
pub(crate) fn sweep_block_chunks(
    input: &LatticeSweep,
    b: &mut Block,
    minima: &[Minimum],
    levels: &[f32],
    on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
) {
    let width = patch_width(
        &input.lat,
        input.phi,
        b.start,
        b.stamps.len() as u32,
        b.options.patch_width,
    );
    sweep_block_patches(width, input, b, minima, levels, on_level);
}

/// [`sweep_block_chunks`] with patches `width` cells wide (one of
/// [`WIDTHS`]).
pub(crate) fn sweep_block_patches(
    width: u32,
    input: &LatticeSweep,
    b: &mut Block,
    minima: &[Minimum],
    levels: &[f32],
    on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
) {
    let args = (input, b, minima, levels, on_level);
    match width {
        8 => sweep_shaped::<8>(args),
        16 => sweep_shaped::<16>(args),
        32 => sweep_shaped::<32>(args),
        64 => sweep_shaped::<64>(args),
        _ => panic!("patch width {width}: not one of {WIDTHS:?}"),
    }
}

/// The arguments of [`sweep_block_chunks`].
type SweepArgs<'a, 'l, L> = (
    &'a LatticeSweep<'l>,
    &'a mut Block,
    &'a [Minimum],
    &'a [f32],
    L,
);

/// [`sweep_block_patches`] for patches `W` cells wide.
#[inline(never)]
fn sweep_shaped<const W: usize>(
    (input, b, minima, levels, mut on_level): SweepArgs<
        '_,
        '_,
        impl FnMut(usize, &LevelMesh, &LevelStats),
    >,
) {
    let LatticeSweep { ref lat, phi, .. } = *input;
    let n = levels.len();
    assert!(n <= MAX_LEVELS, "{n} levels: at most {MAX_LEVELS}");
    if n == 0 {
        return;
    }
    let start = b.start;
    let owner = super::prepare_block(input, b);
    let Block {
        stamps,
        mesh,
        lattice,
        work,
        ..
    } = b;
    let LatticeState {
        window, chunks: q, ..
    } = lattice.as_deref_mut().expect("set above");
    let len = stamps.len() as u32;
    let sh = Shaped::<W>::new(lat, phi, Patches::new(W as u32, lat, start, len), levels);
    let chunks = sh.patches.count;
    q.begin(chunks as usize, n);
    q.flags.clear();
    q.flags.extend((0..chunks).map(|w| sh.patches.flags(w)));
    let mut prev_cut = 0u64;
    let mut next_min = 0;
    for (k, &t) in levels.iter().enumerate() {
        mesh.clear();
        work.clear();
        work.append(&mut q.scheduled[k]);
        // The minima entering at this step touch their patches.
        while next_min < minima.len() && minima[next_min].lo < t {
            let c = minima[next_min].slot;
            if c.wrapping_sub(start) < len {
                q.reach(sh.patches.of_slot(c));
            }
            next_min += 1;
        }
        let mut entered = 0u64;
        let mut i = 0;
        loop {
            if i == work.len() {
                // Touch the patches reached so far; those with a cell
                // entering now join this step's work.
                if q.pending.is_empty() {
                    break;
                }
                sh.touch_pending(q, work, k);
                continue;
            }
            let w = work[i];
            if let Some(&ahead) = work.get(i + 4) {
                q.prefetch_record(ahead);
            }
            i += 1;
            let new = q.step_patch(w, k, n);
            if new != 0 {
                entered += new.count_ones() as u64;
                sh.reach_across(q, w, new);
            }
        }
        q.order_cut_cells(&sh.patches);
        let cells = CutCells {
            cut: &q.slots,
            slot_of: |c| c,
            start,
            len,
            t,
        };
        emit_cut_cells(input, cells, owner.as_ref(), mesh, window);
        let stats = LevelStats::of(mesh, entered + prev_cut);
        prev_cut = q.slots.len() as u64;
        on_level(k, mesh, &stats);
    }
}

/// What [`sweep_shaped`] reads besides its queues: the lattice, φ, the
/// block's `W`-wide patches, the level index, and the bits of a patch's
/// first and last rows and columns.
struct Shaped<'a, 'l, const W: usize> {
    lat: &'a Lattice<'l>,
    phi: &'a [f32],
    patches: Patches,
    index: LevelIndex<'a>,
    levels: usize,
    first_row: u64,
    last_row: u64,
    first_column: u64,
    last_column: u64,
}

impl<'a, 'l, const W: usize> Shaped<'a, 'l, W> {
    #[inline(always)]
    fn new(lat: &'a Lattice<'l>, phi: &'a [f32], patches: Patches, levels: &'a [f32]) -> Self {
        let (row_bits, column_bits) = (patches.row_bits(), patches.column_bits());
        Shaped {
            lat,
            phi,
            patches,
            index: LevelIndex::new(levels),
            levels: levels.len(),
            first_row: row_bits,
            last_row: row_bits << (64 - W),
            first_column: column_bits,
            last_column: column_bits << (W - 1),
        }
    }

    /// First vertex of patch w's first cell.
    #[inline(always)]
    fn first_vertex(&self, w: u32) -> i64 {
        self.patches.first_slot(w) as i64 - self.lat.base as i64
    }

    /// Touches patch w at step k: fills its record, then queues it for this
    /// step (a cell enters at k), schedules it, or marks it done.
    #[inline(always)]
    fn touch(&self, q: &mut ChunkQueues, work: &mut Vec<u32>, w: u32, k: usize) {
        let [_, dj, dk] = self.lat.deltas;
        let (lo, hi) = patch_ranges::<W>(self.phi, self.first_vertex(w), dj, dk);
        let r = q.alloc();
        let rec = &mut q.levels[r as usize * 128..r as usize * 128 + 128];
        let dead = self.patches.dead_bits(self.lat, w);
        let least = fill_levels(rec, &lo, &hi, dead, &self.index) as usize;
        debug_assert!(least >= k, "a patch is touched by its first entry step");
        q.state[w as usize] = r;
        if least == k {
            work.push(w);
        } else if least < self.levels {
            q.scheduled[least].push(w);
        } else {
            q.state[w as usize] = DONE;
            q.free.push(r);
        }
    }

    /// Touches the pending patches at step k (their rows prefetched a few
    /// patches ahead).
    #[inline(always)]
    fn touch_pending(&self, q: &mut ChunkQueues, work: &mut Vec<u32>, k: usize) {
        let [_, dj, dk] = self.lat.deltas;
        let mut pending = std::mem::take(&mut q.pending);
        for (p, &w) in pending.iter().enumerate() {
            if let Some(&ahead) = pending.get(p + 2) {
                prefetch_patch::<W>(self.phi, self.first_vertex(ahead), dj, dk);
            }
            self.touch(q, work, w, k);
        }
        pending.clear();
        q.pending = pending;
    }

    /// Reaches the patches across the faces of patch w's entering cells
    /// `new`: along i and j those at the patch's sides, along k the ones
    /// above and below.
    #[inline(always)]
    fn reach_across(&self, q: &mut ChunkQueues, w: u32, new: u64) {
        let columns = self.patches.columns;
        let layer = columns * self.patches.rows;
        let flags = q.flags[w as usize];
        if new & self.first_column != 0 && flags & HAS_LEFT != 0 {
            q.reach(w - 1);
        }
        if new & self.last_column != 0 && flags & HAS_RIGHT != 0 {
            q.reach(w + 1);
        }
        if new & self.first_row != 0 && flags & HAS_DOWN != 0 {
            q.reach(w - columns);
        }
        if new & self.last_row != 0 && flags & HAS_UP != 0 {
            q.reach(w + columns);
        }
        if w >= layer {
            q.reach(w - layer);
        }
        if w + layer < self.patches.count {
            q.reach(w + layer);
        }
    }
}
