//! Polygon extraction for one cell at one level, shared by every structure
//! and by the brute-force reference, plus the reusable per-level output
//! buffer ([`LevelMesh`]) that welds polygon vertices by grid edge.

use crate::metacell::MetaCell;

/// Hints the CPU to fetch the cache line holding `s[i]` (harmless when `i`
/// is out of bounds; no effect on targets without a prefetch instruction).
#[inline(always)]
pub fn prefetch<T>(s: &[T], i: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: SSE is part of the x86_64 baseline, so the intrinsic's
        // target feature is always present. A prefetch never faults and
        // reads nothing observable, so the address need not be valid: it
        // is formed with `wrapping_add` (no bounds check, no UB).
        unsafe {
            std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                s.as_ptr().wrapping_add(i) as *const i8,
            );
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (s, i);
}

/// Is cell with extremes `lo`/`hi` intersected at `t`? The one tie rule used
/// everywhere: `lo < t ≤ hi`.
#[inline(always)]
pub fn intersects(lo: f32, hi: f32, t: f32) -> bool {
    lo < t && t <= hi
}

/// One slot of an [`EdgeMap`]: the value and a tag (generation in the high
/// 16 bits, 16 bits of the key's hash in the low ones).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(8))]
struct Entry {
    val: u32,
    tag: u32,
}

/// Open-addressing map (linear probing, load ≤ 3/8) from a grid edge key to
/// an output vertex index that keeps its capacity across [`EdgeMap::clear`].
///
/// Slots are 8 bytes: the value and a tag. The full key is not stored: it
/// is the output vertex's own edge key (`keys[val]`, the `edge_keys` of
/// the [`LevelMesh`]), compared only when the 16 hash bits in the tag
/// match. Clearing bumps the 16-bit generation instead of rewriting the
/// table (rewritten once every 65 535 clears).
#[derive(Clone, Debug, Default)]
pub struct EdgeMap {
    entries: Vec<Entry>,
    len: usize,
    mask: usize,
    /// Current generation (1..=65535 once the table exists).
    gen_: u32,
}

impl EdgeMap {
    /// Removes all entries, keeping the capacity. O(1) (O(capacity) once
    /// every 65 535 calls).
    pub fn clear(&mut self) {
        if self.len > 0 {
            self.len = 0;
            self.gen_ += 1;
            if self.gen_ > 0xFFFF {
                self.entries.fill(Entry::default());
                self.gen_ = 1;
            }
        }
    }

    /// Bytes held.
    pub fn capacity_bytes(&self) -> usize {
        self.entries.capacity() * std::mem::size_of::<Entry>()
    }

    /// Home slot and 16 tag bits of `key` (`min_id << 32 | max_id`).
    ///
    /// Edges with the same id difference whose smaller ids agree but for
    /// the low 3 bits share one 8-slot run (the Fibonacci hash of the
    /// pair picks the run; the low bits place the edge inside it), so
    /// cells emitted in id order probe a few cache lines over and over
    /// instead of a random line per corner. The tag holds hash bits above
    /// the run's and the 3 low bits.
    #[inline(always)]
    fn home(key: u64, mask: usize) -> (usize, u32) {
        let ga = (key >> 32) as u32;
        let run = (ga >> 3) as u64 | ((key as u32).wrapping_sub(ga) as u64) << 32;
        let h = run.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let low = (ga & 7) as usize;
        (
            ((h >> 32) as usize & mask & !7) | low,
            (h >> 16) as u32 & 0xFFF8 | low as u32,
        )
    }

    #[cold]
    fn grow(&mut self, keys: &[u64]) {
        let cap = (self.entries.len() * 2).max(1024);
        let old = std::mem::replace(&mut self.entries, vec![Entry::default(); cap]);
        let old_gen = self.gen_;
        self.gen_ = 1;
        self.mask = cap - 1;
        for e in old.into_iter().filter(|e| e.tag >> 16 == old_gen) {
            let (mut s, _) = Self::home(keys[e.val as usize], self.mask);
            while self.entries[s].tag >> 16 == self.gen_ {
                s = (s + 1) & self.mask;
            }
            self.entries[s] = Entry {
                val: e.val,
                tag: self.gen_ << 16 | (e.tag & 0xFFFF),
            };
        }
    }

    /// Makes room for `extra` more entries within the load limit, so that
    /// the next `extra` inserts need no check; `keys` as in
    /// `EdgeMap::get_or_insert`.
    #[inline(always)]
    pub fn reserve(&mut self, extra: usize, keys: &[u64]) {
        while (self.len + extra) * 8 > self.entries.len() * 3 {
            self.grow(keys);
        }
    }

    /// Returns the value for `key`, inserting `value_if_new` when absent; the
    /// bool tells whether it was inserted. `keys[v]` must be the key of
    /// every value `v` inserted since the last clear (the caller appends
    /// `key` at `value_if_new` after an insert). Call [`EdgeMap::reserve`]
    /// first.
    #[inline(always)]
    pub(crate) fn get_or_insert(
        &mut self,
        key: u64,
        value_if_new: u32,
        keys: &[u64],
    ) -> (u32, bool) {
        debug_assert!((self.len + 1) * 8 <= self.entries.len() * 3);
        let (mut s, bits) = Self::home(key, self.mask);
        let cur = self.gen_;
        let tag = cur << 16 | bits;
        loop {
            let e = self.entries[s];
            if e.tag >> 16 != cur {
                self.entries[s] = Entry {
                    val: value_if_new,
                    tag,
                };
                self.len += 1;
                return (value_if_new, true);
            }
            if e.tag == tag && keys[e.val as usize] == key {
                return (e.val, false);
            }
            s = (s + 1) & self.mask;
        }
    }
}

/// The polygons of one level from one sweep (or one block of it): indexed,
/// welded by grid edge, each with its source cell. Caller-owned and reused:
/// [`LevelMesh::clear`] keeps every capacity, so a sweep allocates nothing
/// per level once warmed up.
#[derive(Clone, Debug, Default)]
pub struct LevelMesh {
    /// Vertex positions (local frame).
    pub positions: Vec<[f32; 3]>,
    /// Interpolated attribute per vertex.
    pub values: Vec<f32>,
    /// Grid edge key (`min_id << 32 | max_id`) of each vertex.
    pub edge_keys: Vec<u64>,
    /// Polygon ranges into `indices` (starts with 0).
    pub offsets: Vec<u32>,
    /// Vertex indices of the polygons.
    pub indices: Vec<u32>,
    /// Source cell (structure slot) of each polygon (of each cut cell when
    /// [`EmitContext::cells_only`]).
    pub cells: Vec<u32>,
    /// Number of intersected cells emitted.
    pub cut_cells: u32,
    /// Sum of the polygon areas (half the root of each [`polygon_norm2`]),
    /// added up while emitting so that the area needs no second pass over
    /// the indices.
    pub(crate) area: f64,
    /// Running count of fan triangles.
    pub(crate) triangle_sum: usize,
    weld: EdgeMap,
}

impl LevelMesh {
    /// Empties the buffer, keeping capacity.
    pub fn clear(&mut self) {
        self.positions.clear();
        self.values.clear();
        self.edge_keys.clear();
        self.offsets.clear();
        self.offsets.push(0);
        self.indices.clear();
        self.cells.clear();
        self.cut_cells = 0;
        self.area = 0.0;
        self.triangle_sum = 0;
        self.weld.clear();
    }
    /// Number of polygons.
    pub fn polygon_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
    /// Number of triangles of a fan triangulation.
    pub fn triangle_count(&self) -> usize {
        self.offsets
            .windows(2)
            .map(|w| (w[1] - w[0]) as usize - 2)
            .sum()
    }
    /// Total polygon area (f64).
    pub fn area(&self) -> f64 {
        self.offsets
            .windows(2)
            .map(|w| polygon_area(&self.indices[w[0] as usize..w[1] as usize], &self.positions))
            .sum()
    }
    /// [`LevelMesh::area`] as summed while emitting: the same per-polygon
    /// values added in the same order, without re-reading indices and
    /// positions.
    #[inline]
    pub fn accumulated_area(&self) -> f64 {
        self.area
    }
    /// [`LevelMesh::triangle_count`], accumulated while emitting.
    #[inline]
    pub fn accumulated_triangles(&self) -> usize {
        self.triangle_sum
    }
    /// Emits one loop (edge ids `lp` of `edges`) as a polygon of the cut
    /// cell `cell`, welding its vertices by grid edge.
    #[inline(always)]
    fn emit_loop(&mut self, edges: &[[u8; 2]], lp: &[u8], cell: &CutCell, ctx: &EmitContext) {
        let CutCell { gids, phi, t, .. } = *cell;
        let start = self.begin_polygon();
        for &e in lp {
            let [la, lb] = edges[e as usize];
            let (la, lb) = (la as usize, lb as usize);
            if gids[la] < gids[lb] {
                self.corner(gids[la], gids[lb], phi[la], phi[lb], t, ctx);
            } else {
                self.corner(gids[lb], gids[la], phi[lb], phi[la], t, ctx);
            }
        }
        self.end_polygon(start, cell.slot);
    }
    /// Starts a polygon; returns the token for [`LevelMesh::end_polygon`].
    #[inline(always)]
    pub(crate) fn begin_polygon(&mut self) -> usize {
        // A polygon has at most one corner per cell edge (≤ 32 for the
        // catalog's cells).
        self.weld.reserve(32, &self.edge_keys);
        self.indices.len()
    }
    /// Adds the polygon corner where level `t` crosses grid edge `ga`–`gb`
    /// (`ga < gb`, φ values `fa`, `fb`), welded by the edge.
    #[inline(always)]
    pub(crate) fn corner(&mut self, ga: u32, gb: u32, fa: f32, fb: f32, t: f32, ctx: &EmitContext) {
        let key = (ga as u64) << 32 | gb as u64;
        let (vi, new) = self
            .weld
            .get_or_insert(key, self.positions.len() as u32, &self.edge_keys);
        if new {
            self.push_vertex(ga, gb, fa, fb, t, ctx);
        }
        self.indices.push(vi);
    }
    /// Makes room in the weld map for `n` more corners of the current
    /// polygon ([`LevelMesh::begin_polygon`] reserves 32): for structures
    /// whose polygons can be longer (CIEL).
    #[inline(always)]
    pub(crate) fn reserve_corners(&mut self, n: usize) {
        self.weld.reserve(n, &self.edge_keys);
    }
    /// The hash map that welds the corners by grid edge (for writers that
    /// append past the vectors' lengths, such as
    /// the sweep's `HexWriter`).
    #[inline(always)]
    pub(crate) fn edge_map(&mut self) -> &mut EdgeMap {
        &mut self.weld
    }
    /// Closes the polygon begun at `start` (from [`LevelMesh::begin_polygon`])
    /// with source cell `slot`.
    #[inline(always)]
    pub(crate) fn end_polygon(&mut self, start: usize, slot: u32) {
        let end = self.indices.len();
        self.offsets.push(end as u32);
        self.cells.push(slot);
        self.triangle_sum += end - start - 2;
        self.area += 0.5 * polygon_norm2(&self.indices[start..end], &self.positions).sqrt();
    }
    /// Appends the vertex where the level `t` crosses grid edge `ga`–`gb`
    /// (`ga < gb`, with φ values `fa`, `fb`), keyed by the edge.
    #[inline(always)]
    fn push_vertex(&mut self, ga: u32, gb: u32, fa: f32, fb: f32, t: f32, ctx: &EmitContext) {
        let key = (ga as u64) << 32 | gb as u64;
        let s = (t - fa) / (fb - fa);
        let pa = ctx.positions[ga as usize];
        let pb = ctx.positions[gb as usize];
        self.positions.push([
            pa[0] + s * (pb[0] - pa[0]),
            pa[1] + s * (pb[1] - pa[1]),
            pa[2] + s * (pb[2] - pa[2]),
        ]);
        self.values.push(match ctx.attribute {
            Some(a) => a[ga as usize] + s * (a[gb as usize] - a[ga as usize]),
            None => t,
        });
        self.edge_keys.push(key);
    }
    /// Bytes held by the buffers.
    pub fn capacity_bytes(&self) -> usize {
        self.positions.capacity() * 12
            + self.values.capacity() * 4
            + self.edge_keys.capacity() * 8
            + (self.offsets.capacity() + self.indices.capacity() + self.cells.capacity()) * 4
            + self.weld.capacity_bytes()
    }
}

/// Area of a planar polygon (f64), by the norm of the summed fan cross products.
pub fn polygon_area(ids: &[u32], pos: &[[f32; 3]]) -> f64 {
    0.5 * polygon_norm2(ids, pos).sqrt()
}

/// Squared norm of the summed fan cross products of a polygon (f64):
/// [`polygon_area`] is `0.5 * polygon_norm2(..).sqrt()`. Quads use the
/// equal cross product of their diagonals (one product instead of two).
#[inline(always)]
pub fn polygon_norm2(ids: &[u32], pos: &[[f32; 3]]) -> f64 {
    norm2_of(ids.len(), |i| pos[ids[i] as usize].map(f64::from))
}

/// [`polygon_norm2`] of the `n`-corner polygon whose corner i is at `p(i)`.
#[inline(always)]
pub(crate) fn norm2_of(n: usize, p: impl Fn(usize) -> [f64; 3]) -> f64 {
    let cross = |u: [f64; 3], v: [f64; 3]| {
        [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ]
    };
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let n = if n == 4 {
        cross(sub(p(2), p(0)), sub(p(3), p(1)))
    } else {
        let p0 = p(0);
        let mut acc = [0.0f64; 3];
        let mut a = sub(p(1), p0);
        for i in 2..n {
            let b = sub(p(i), p0);
            let c = cross(a, b);
            acc = [acc[0] + c[0], acc[1] + c[1], acc[2] + c[2]];
            a = b;
        }
        acc
    };
    n[0] * n[0] + n[1] * n[1] + n[2] * n[2]
}

/// Face decider for an ambiguous face: `true` when the above-level arcs are
/// connected across the face. It depends only on the face's own vertices
/// (values and global ids), evaluated in an order-independent way, so both
/// cells sharing the face decide identically (watertight isosurfaces).
///
/// Quads use the bilinear saddle value; larger faces the mean value. Exact
/// ties go to the side of the vertex with the smallest global id.
pub fn face_above_connected(vals: &[f32], gids: &[u32], t: f32) -> bool {
    let t64 = t as f64;
    let verdict = if vals.len() == 4 {
        // Diagonal pairs: (0,2) and (1,3); one pair is above.
        let (a, c, b, d) = if vals[0] >= t {
            (0, 2, 1, 3)
        } else {
            (1, 3, 0, 2)
        };
        let (fa, fc, fb, fd) = (
            vals[a] as f64,
            vals[c] as f64,
            vals[b] as f64,
            vals[d] as f64,
        );
        let num = fa * fc - fb * fd;
        let den = (fa + fc) - (fb + fd);
        num.partial_cmp(&(t64 * den))
    } else {
        let mut order: [(u32, f32); 32] = [(0, 0.0); 32];
        let n = vals.len().min(32);
        for i in 0..n {
            order[i] = (gids[i], vals[i]);
        }
        order[..n].sort_unstable_by_key(|e| e.0);
        let sum: f64 = order[..n].iter().map(|e| e.1 as f64).sum();
        (sum / n as f64).partial_cmp(&t64)
    };
    match verdict {
        Some(std::cmp::Ordering::Greater) => true,
        Some(std::cmp::Ordering::Less) => false,
        _ => {
            let i = (0..gids.len()).min_by_key(|&i| gids[i]).unwrap_or(0);
            vals[i] >= t
        }
    }
}

/// Configuration code and extremes of a cell from its vertex φ values.
#[inline(always)]
pub fn code_of(phi: &[f32], t: f32) -> usize {
    let mut code = 0usize;
    for (i, &p) in phi.iter().enumerate() {
        code |= ((p >= t) as usize) << i;
    }
    code
}

/// Inputs shared by every cell emitted in one sweep.
#[derive(Clone, Copy)]
pub struct EmitContext<'a> {
    /// Rebased vertex positions.
    pub positions: &'a [[f32; 3]],
    /// Attribute interpolated onto the polygons (`None`: the level value).
    pub attribute: Option<&'a [f32]>,
    /// Record only the cut cells (one `cells` entry each, no polygons):
    /// for consumers that emit elsewhere, such as the GPU.
    pub cells_only: bool,
}

/// One intersected cell at a level, as [`emit_cell`] takes it.
#[derive(Clone, Copy)]
pub struct CutCell<'a> {
    /// The cell's global vertex ids in local order.
    pub gids: &'a [u32],
    /// Their field values.
    pub phi: &'a [f32],
    /// The level.
    pub t: f32,
    /// [`code_of`] of `phi` at `t`.
    pub code: usize,
    /// The cell's slot (recorded with its polygons).
    pub slot: u32,
}

/// Emits the polygons of the intersected cell `cell` (of meta-cell `meta`)
/// into `mesh`.
#[inline]
pub fn emit_cell(meta: &MetaCell, cell: &CutCell, ctx: &EmitContext, mesh: &mut LevelMesh) {
    let CutCell {
        gids,
        phi,
        t,
        code,
        slot,
    } = *cell;
    if ctx.cells_only {
        mesh.cut_cells += 1;
        mesh.cells.push(slot);
        return;
    }
    let outcome = if meta.ambiguous_faces[code] != 0 {
        decide_faces(meta, gids, phi, t, code)
    } else {
        0
    };
    mesh.cut_cells += 1;
    for lp in meta.loops(code, outcome) {
        mesh.emit_loop(&meta.edges, lp, cell, ctx);
    }
}

/// Decider bits of the ambiguous faces of `code` (one bit per ambiguous
/// face, in increasing face order).
#[inline(never)]
pub(crate) fn decide_faces(meta: &MetaCell, gids: &[u32], phi: &[f32], t: f32, code: usize) -> u32 {
    let mut outcome = 0u32;
    let mut mask = meta.ambiguous_faces[code];
    let mut bit = 0;
    while mask != 0 {
        let f = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        let face = &meta.faces[f];
        let mut fv = [0f32; 32];
        let mut fg = [0u32; 32];
        let n = face.len().min(32);
        for (i, &lv) in face.iter().take(n).enumerate() {
            fv[i] = phi[lv as usize];
            fg[i] = gids[lv as usize];
        }
        if face_above_connected(&fv[..n], &fg[..n], t) {
            outcome |= 1 << bit;
        }
        bit += 1;
    }
    outcome
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
