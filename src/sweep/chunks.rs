//! The lattice loop over 64-cell chunks: the sweep of DESIGN §3 on a
//! hexahedral [`Lattice`], with 64 consecutive slots (a run along i) handled
//! together.
//!
//! A chunk is *touched* when the propagation first reaches it: a minimum in
//! it enters, or a cell across one of its faces does. Touching reads its
//! four vertex rows once and stores, per cell, its entry level
//! `enter = #{t_k <= lo}` (the first level with `lo < t_k`) and
//! `leave = #{t_k <= hi}`: the cell is cut exactly at the levels
//! `enter <= k < leave` (the tie rule `lo < t <= hi`, decided once with the
//! same comparisons). From then on the chunk is processed only at the steps
//! where one of its cells enters or is cut, as bytes compared with `k`
//! (SIMD): the cells that enter at k touch the chunks across their faces,
//! the cut ones go to the step's output, and the chunk schedules itself at
//! its next such step. When none is left it is done and its level bytes
//! are freed, so memory follows the sweep front, not the grid.
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

use super::{Block, EmitContext, Lattice, LevelMesh, LevelStats, Minimum, emit_cut_cells};
use crate::lattice::EdgeOwnership;

/// Chunk state: not reached yet.
const UNTOUCHED: u32 = u32::MAX;
/// Chunk state: every cell has entered and left (or never will).
const DONE: u32 = u32::MAX - 1;
/// Chunk state: reached, waiting in `pending` to be touched.
const PENDING: u32 = u32::MAX - 2;
/// Largest level count the byte-sized levels can hold.
pub(super) const MAX_LEVELS: usize = 255;

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
}

impl ChunkQueues {
    /// Bytes held.
    pub fn bytes(&self) -> usize {
        (self.state.capacity()
            + self.free.capacity()
            + self.slots.capacity()
            + self.pending.capacity())
            * 4
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

    /// A free record (grown when none is).
    fn alloc(&mut self) -> u32 {
        self.free.pop().unwrap_or_else(|| {
            let r = self.levels.len() / 128;
            self.levels.resize(self.levels.len() + 128, 0);
            r as u32
        })
    }
}

/// `#{t in levels : t <= x}` (the index of the first level above x), for
/// ascending levels, 64 values at a time: a guess from the levels' mean
/// spacing (vectorised), moved by at most one level and checked against
/// the levels around it; values whose check fails (unevenly spaced levels)
/// take a binary search.
struct LevelIndex<'a> {
    levels: &'a [f32],
    /// The levels between −∞ and +∞ sentinels: the count c of x has
    /// `padded[c] <= x < padded[c + 1]`.
    padded: Vec<f32>,
    first: f32,
    inv_step: f32,
}

impl<'a> LevelIndex<'a> {
    fn new(levels: &'a [f32]) -> Self {
        let n = levels.len();
        let span = levels[n - 1] - levels[0];
        let inv_step = if n > 1 && span > 0.0 && ((n - 1) as f32 / span).is_finite() {
            (n - 1) as f32 / span
        } else {
            0.0
        };
        let mut padded = Vec::with_capacity(n + 2);
        padded.push(f32::NEG_INFINITY);
        padded.extend_from_slice(levels);
        padded.push(f32::INFINITY);
        LevelIndex {
            levels,
            padded,
            first: levels[0],
            inv_step,
        }
    }

    /// `out[p]` = the count of `xs[p]` (finite values, or ±∞).
    #[inline(always)]
    fn count_le_64(&self, xs: &[f32; 64], out: &mut [u8]) {
        let n = self.levels.len();
        let nf = n as f32;
        let mut guess = [0u32; 64];
        for (g, &x) in guess.iter_mut().zip(xs) {
            // f32::max/min drop a NaN ((±∞ − ±∞)·0): the guess is then 0.
            let y = ((x - self.first) * self.inv_step + 1.0).max(0.0).min(nf);
            // SAFETY: y is finite and in 0..=n (< 256).
            *g = unsafe { y.to_int_unchecked::<u32>() };
        }
        let p = &self.padded[..];
        debug_assert_eq!(p.len(), n + 2);
        let mut all_ok = true;
        for ((o, &x), &g) in out.iter_mut().zip(xs).zip(&guess) {
            let mut c = g as usize;
            // SAFETY: c <= n, so c + 1 <= n + 1 < p.len(); after the moves
            // c stays in 0..=n (p[n + 1] = +∞ is only <= x = +∞, then c is
            // clamped; p[0] = −∞ is never > x).
            unsafe {
                c += (*p.get_unchecked(c + 1) <= x) as usize;
                c = c.min(n);
                c -= (*p.get_unchecked(c) > x) as usize;
                all_ok &= *p.get_unchecked(c) <= x && (x < *p.get_unchecked(c + 1) || c == n);
            }
            *o = c as u8;
        }
        if !all_ok {
            for (o, &x) in out.iter_mut().zip(xs) {
                *o = self.levels.partition_point(|&t| t <= x) as u8;
            }
        }
    }
}

/// Per column q of a chunk (vertices `v + q + {0, dj, dk, dj + dk}`,
/// q in 0..65), the min and max of φ. Vertices outside φ (only dead cells
/// have them) read +∞ for the min and −∞ for the max.
#[inline(always)]
fn column_ranges(phi: &[f32], v: i64, dj: u32, dk: u32) -> ([f32; 65], [f32; 65]) {
    let rows = [0, dj as i64, dk as i64, (dj + dk) as i64];
    let mut mn = [f32::INFINITY; 65];
    let mut mx = [f32::NEG_INFINITY; 65];
    if v >= 0 && v + (dj + dk) as i64 + 65 <= phi.len() as i64 {
        for r in rows {
            let row = &phi[(v + r) as usize..(v + r) as usize + 65];
            for q in 0..65 {
                mn[q] = if row[q] < mn[q] { row[q] } else { mn[q] };
                mx[q] = if row[q] > mx[q] { row[q] } else { mx[q] };
            }
        }
    } else {
        for r in rows {
            for q in 0..65 {
                if let Some(&x) = usize::try_from(v + r + q as i64)
                    .ok()
                    .and_then(|i| phi.get(i))
                {
                    mn[q] = mn[q].min(x);
                    mx[q] = mx[q].max(x);
                }
            }
        }
    }
    (mn, mx)
}

/// Fills a chunk's record: per cell p, `enter` and `leave` from its min and
/// max over the columns p and p + 1 (dead cells, in `dead`: 255 and 0).
/// Returns the least `enter`.
#[inline(always)]
fn fill_levels(
    rec: &mut [u8],
    mn: &[f32; 65],
    mx: &[f32; 65],
    dead: u64,
    index: &LevelIndex,
) -> u8 {
    let lo: [f32; 64] = std::array::from_fn(|p| if mn[p] < mn[p + 1] { mn[p] } else { mn[p + 1] });
    let hi: [f32; 64] = std::array::from_fn(|p| if mx[p] > mx[p + 1] { mx[p] } else { mx[p + 1] });
    let (enter, leave) = rec.split_at_mut(64);
    index.count_le_64(&lo, enter);
    index.count_le_64(&hi, leave);
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

/// The dead slots (never swept) of chunk `w`, and the bits past the block.
#[inline(always)]
fn dead_bits(lat: &Lattice, start: u32, len: u32, w: u32) -> u64 {
    let first = 64 * w;
    let past = if len - first < 64 {
        !0u64 << (len - first)
    } else {
        0
    };
    !lat.live.word_at(start as i64 + first as i64) | past
}

/// Whether the chunked loop should beat the per-cell one for φ on this
/// block: unless φ changes much faster along i (along a chunk) than along
/// j or k. Then each level crosses a chunk in a few cells only, and the
/// chunk is processed at many steps for few cut cells (warped 256³ swept
/// along x: 1.06 s chunked against 0.91 s per cell; along y and z the
/// chunked loop is 9–24 % faster). Measured on up to 4096 live cells
/// spread over the block: the mean |Δφ| along i against the larger of
/// those along j and k.
pub(super) fn chunks_pay_off(lat: &Lattice, phi: &[f32], start: u32, len: u32) -> bool {
    let [di, dj, dk] = lat.deltas;
    let stride = (len / 4096).max(1);
    let mut g = [0f64; 3];
    let mut c = start;
    while c < start + len {
        if lat.live.get(c as usize) {
            let v = (c - lat.base) as usize;
            let at = |d: u32| (phi[v + d as usize] - phi[v]).abs() as f64;
            g[0] += at(di);
            g[1] += at(dj);
            g[2] += at(dk);
        }
        c += stride;
    }
    g[0] <= 0.6 * g[1].max(g[2])
}

/// [`super::sweep_block_lattice`] over 64-cell chunks (see the module
/// docs): the same cut cells per level, emitted in slot order with the
/// same polygons. Needs at most [`MAX_LEVELS`] levels.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub(super) fn sweep_block_chunks(
    lat: &Lattice,
    phi: &[f32],
    b: &mut Block,
    minima: &[Minimum],
    levels: &[f32],
    ctx: &EmitContext,
    hash_weld: bool,
    mut on_level: impl FnMut(usize, &LevelMesh, &LevelStats),
) {
    let n = levels.len();
    assert!(n <= MAX_LEVELS, "{n} levels: at most {MAX_LEVELS}");
    if n == 0 {
        return;
    }
    let start = b.start;
    let [_, dj, dk] = lat.deltas;
    assert!(
        phi.len() >= lat.vertices,
        "φ has {} values for {} vertices",
        phi.len(),
        lat.vertices
    );
    let owner = EdgeOwnership::new(dj, dk / dj);
    let own_weld = owner.fits && !hash_weld;
    if own_weld {
        b.window.fit(&owner);
    }
    let index = LevelIndex::new(levels);
    let Block {
        stamps,
        mesh,
        window,
        chunked: q,
        work,
        ..
    } = b;
    let len = stamps.len() as u32;
    let chunks = len.div_ceil(64) as i64;
    q.begin(chunks as usize, n);
    // First vertex of chunk w's first cell.
    let first_vertex = |w: u32| (start as i64 + 64 * w as i64) - lat.base as i64;
    // Face steps to the neighbour rows and layers: (chunks, bits).
    let steps = [dj, dk].map(|d| ((d / 64) as i64, d % 64));
    // Touches chunk w at step k: fills its record, then queues it for this
    // step (a cell enters at k), schedules it, or marks it done.
    let touch = |q: &mut ChunkQueues, work: &mut Vec<u32>, w: u32, k: usize| {
        let (mn, mx) = column_ranges(phi, first_vertex(w), dj, dk);
        let r = q.alloc();
        let rec = &mut q.levels[r as usize * 128..r as usize * 128 + 128];
        let least = fill_levels(rec, &mn, &mx, dead_bits(lat, start, len, w), &index) as usize;
        debug_assert!(least >= k, "a chunk is touched by its first entry step");
        q.state[w as usize] = r;
        if least == k {
            work.push(w);
        } else if least < n {
            q.scheduled[least].push(w);
        } else {
            q.state[w as usize] = DONE;
            q.free.push(r);
        }
    };
    let mut prev_cut = 0u64;
    let mut next_min = 0;
    for (k, &t) in levels.iter().enumerate() {
        mesh.clear();
        work.clear();
        work.append(&mut q.scheduled[k]);
        // The minima entering at this step touch their chunks.
        while next_min < minima.len() && minima[next_min].lo < t {
            let j = minima[next_min].slot.wrapping_sub(start);
            if j < len && q.state[(j / 64) as usize] == UNTOUCHED {
                q.state[(j / 64) as usize] = PENDING;
                q.pending.push(j / 64);
            }
            next_min += 1;
        }
        let mut entered = 0u64;
        let mut i = 0;
        loop {
            if i == work.len() {
                // Touch the chunks reached so far (their rows prefetched a
                // few chunks ahead); those with a cell entering now join
                // this step's work.
                if q.pending.is_empty() {
                    break;
                }
                let mut pending = std::mem::take(&mut q.pending);
                for (p, &w) in pending.iter().enumerate() {
                    if let Some(&ahead) = pending.get(p + 2) {
                        let v = first_vertex(ahead);
                        for r in [0, dj, dk, dj + dk] {
                            for line in [0, 16, 32, 48, 64] {
                                let x = v + (r + line) as i64;
                                if x >= 0 {
                                    prefetch_nta(phi, x as usize);
                                }
                            }
                        }
                    }
                    touch(q, work, w, k);
                }
                pending.clear();
                q.pending = pending;
                continue;
            }
            let w = work[i];
            if let Some(&ahead) = work.get(i + 4) {
                // Its level record (touched chunks only: those pushed by a
                // touch this step are processed right after it).
                let r = q.state[ahead as usize] as usize;
                if r < PENDING as usize {
                    prefetch_nta(&q.levels, r * 128);
                    prefetch_nta(&q.levels, r * 128 + 64);
                }
            }
            i += 1;
            let r = q.state[w as usize] as usize;
            let m = step_masks(&q.levels[r * 128..r * 128 + 128], k as u8);
            if m.cut != 0 {
                q.cut[w as usize] = m.cut;
                q.cut_chunks[w as usize / 64] |= 1 << (w % 64);
            }
            if (m.next as usize) < n {
                q.scheduled[m.next as usize].push(w);
            } else {
                q.state[w as usize] = DONE;
                q.free.push(r as u32);
            }
            let new = m.new;
            if new == 0 {
                continue;
            }
            entered += new.count_ones() as u64;
            // The chunks across the faces of the entering cells: along i
            // the chunk's ends, across rows and layers the one or two
            // chunks that the shifted cells land in.
            let w64 = w as i64;
            let reach = |c: i64, bits: u64, q: &mut ChunkQueues| {
                if bits != 0 && (0..chunks).contains(&c) && q.state[c as usize] == UNTOUCHED {
                    q.state[c as usize] = PENDING;
                    q.pending.push(c as u32);
                }
            };
            reach(w64 - 1, new & 1, q);
            reach(w64 + 1, new >> 63, q);
            for (qd, o) in steps {
                if o == 0 {
                    reach(w64 + qd, new, q);
                    reach(w64 - qd, new, q);
                } else {
                    reach(w64 + qd, new << o, q);
                    reach(w64 + qd + 1, new >> (64 - o), q);
                    reach(w64 - qd, new >> o, q);
                    reach(w64 - qd - 1, new << (64 - o), q);
                }
            }
        }
        // This step's cut cells in slot order: the cut chunks in order.
        q.slots.clear();
        for (x, word) in q.cut_chunks.iter_mut().enumerate() {
            while *word != 0 {
                let w = 64 * x as u32 + word.trailing_zeros();
                *word &= *word - 1;
                let base = start + 64 * w;
                let mut cut = q.cut[w as usize];
                while cut != 0 {
                    q.slots.push(base + cut.trailing_zeros());
                    cut &= cut - 1;
                }
            }
        }
        let weld = own_weld.then_some(&owner);
        emit_cut_cells(
            lat,
            phi,
            &q.slots,
            |c| c,
            start,
            len,
            t,
            ctx,
            weld,
            mesh,
            window,
        );
        let stats = LevelStats::of(mesh, entered + prev_cut);
        prev_cut = q.slots.len() as u64;
        on_level(k, mesh, &stats);
    }
}

#[cfg(test)]
mod tests {
    use super::LevelIndex;

    /// The batched level index equals a binary search over the levels, for
    /// evenly and unevenly spaced levels, values on, between and outside
    /// the levels, and ±∞.
    #[test]
    fn level_index_equals_the_binary_search() {
        let mut x = 0x1234_5678u32;
        let mut rnd = move || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        let even: Vec<f32> = (0..200).map(|k| -3.7 + k as f32 * 0.031).collect();
        let uneven: Vec<f32> = (0..50).map(|k| (k * k) as f32 * 0.01 - 2.0).collect();
        let single = vec![0.5f32];
        let tight: Vec<f32> = (0..255).map(|k| 1000.0 + k as f32 * 0.000_1).collect();
        for levels in [even, uneven, single, tight] {
            let index = LevelIndex::new(&levels);
            for round in 0..200 {
                let xs: [f32; 64] = std::array::from_fn(|p| match (round + p) % 5 {
                    // A level itself, or its neighbours in f32.
                    0 => levels[rnd() as usize % levels.len()],
                    1 => f32::from_bits(levels[rnd() as usize % levels.len()].to_bits() + 1),
                    2 => f32::from_bits(levels[rnd() as usize % levels.len()].to_bits() - 1),
                    3 if p % 17 == 0 => [f32::INFINITY, f32::NEG_INFINITY][p % 2],
                    _ => {
                        let (a, b) = (levels[0], levels[levels.len() - 1]);
                        a - 1.0 + (b - a + 2.0) * (rnd() % 10_000) as f32 / 10_000.0
                    }
                });
                let mut got = [0u8; 64];
                index.count_le_64(&xs, &mut got);
                for (p, &x) in xs.iter().enumerate() {
                    let want = levels.partition_point(|&t| t <= x);
                    assert_eq!(
                        got[p] as usize,
                        want,
                        "x = {x} among {} levels",
                        levels.len()
                    );
                }
            }
        }
    }
}
