//! Polygon extraction for one cell at one level, shared by every structure
//! and by the brute-force reference, plus the reusable per-level output
//! buffer ([`LevelMesh`]) that welds polygon vertices by grid edge.

use crate::metacell::MetaCell;

/// Is cell with extremes `lo`/`hi` intersected at `t`? The one tie rule used
/// everywhere: `lo < t ≤ hi`.
#[inline(always)]
pub fn intersects(lo: f32, hi: f32, t: f32) -> bool {
    lo < t && t <= hi
}

/// Open-addressing map from a grid edge key to an output vertex index that
/// keeps its capacity across [`EdgeMap::clear`].
#[derive(Clone, Debug, Default)]
pub struct EdgeMap {
    keys: Vec<u64>,
    vals: Vec<u32>,
    len: usize,
    shift: u32,
}

const EMPTY: u64 = u64::MAX;

impl EdgeMap {
    /// Removes all entries, keeping the capacity. O(capacity).
    pub fn clear(&mut self) {
        if self.len > 0 {
            self.keys.fill(EMPTY);
            self.len = 0;
        }
    }

    /// Bytes held.
    pub fn capacity_bytes(&self) -> usize {
        self.keys.capacity() * 8 + self.vals.capacity() * 4
    }

    #[inline(always)]
    fn slot(&self, key: u64) -> usize {
        (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> self.shift) as usize
    }

    fn grow(&mut self) {
        let cap = (self.keys.len() * 2).max(1024);
        let old_k = std::mem::replace(&mut self.keys, vec![EMPTY; cap]);
        let old_v = std::mem::replace(&mut self.vals, vec![0; cap]);
        self.shift = 64 - cap.trailing_zeros();
        for (k, v) in old_k.into_iter().zip(old_v) {
            if k != EMPTY {
                let mask = self.keys.len() - 1;
                let mut s = self.slot(k);
                while self.keys[s] != EMPTY {
                    s = (s + 1) & mask;
                }
                self.keys[s] = k;
                self.vals[s] = v;
            }
        }
    }

    /// Returns the value for `key`, inserting `make()` when absent; the bool
    /// tells whether it was inserted.
    #[inline(always)]
    pub fn get_or_insert(&mut self, key: u64, value_if_new: u32) -> (u32, bool) {
        if (self.len + 1) * 2 > self.keys.len() {
            self.grow();
        }
        let mask = self.keys.len() - 1;
        let mut s = self.slot(key);
        loop {
            let k = self.keys[s];
            if k == key {
                return (self.vals[s], false);
            }
            if k == EMPTY {
                self.keys[s] = key;
                self.vals[s] = value_if_new;
                self.len += 1;
                return (value_if_new, true);
            }
            s = (s + 1) & mask;
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
    /// Source cell (structure slot) of each polygon.
    pub cells: Vec<u32>,
    /// Number of intersected cells emitted.
    pub cut_cells: u32,
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
    let p0 = pos[ids[0] as usize].map(f64::from);
    let mut n = [0.0f64; 3];
    for w in ids[1..].windows(2) {
        let a = pos[w[0] as usize].map(f64::from);
        let b = pos[w[1] as usize].map(f64::from);
        let u = [a[0] - p0[0], a[1] - p0[1], a[2] - p0[2]];
        let v = [b[0] - p0[0], b[1] - p0[1], b[2] - p0[2]];
        n[0] += u[1] * v[2] - u[2] * v[1];
        n[1] += u[2] * v[0] - u[0] * v[2];
        n[2] += u[0] * v[1] - u[1] * v[0];
    }
    0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
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
}

/// Emits the polygons of one intersected cell into `mesh`.
///
/// `gids` are the cell's global vertex ids in local order and `phi` their
/// field values; `code` must be [`code_of`] of `phi` at `t`.
#[inline]
pub fn emit_cell(
    meta: &MetaCell,
    gids: &[u32],
    phi: &[f32],
    t: f32,
    code: usize,
    slot: u32,
    ctx: &EmitContext,
    mesh: &mut LevelMesh,
) {
    let mut outcome = 0u32;
    let mut mask = meta.ambiguous_faces[code];
    if mask != 0 {
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
    }
    mesh.cut_cells += 1;
    for lp in meta.loops(code, outcome) {
        for &e in lp {
            let [la, lb] = meta.edges[e as usize];
            let (mut ga, mut gb) = (gids[la as usize], gids[lb as usize]);
            let (mut fa, mut fb) = (phi[la as usize], phi[lb as usize]);
            if ga > gb {
                std::mem::swap(&mut ga, &mut gb);
                std::mem::swap(&mut fa, &mut fb);
            }
            let key = (ga as u64) << 32 | gb as u64;
            let (vi, new) = mesh.weld.get_or_insert(key, mesh.positions.len() as u32);
            if new {
                let s = (t - fa) / (fb - fa);
                let pa = ctx.positions[ga as usize];
                let pb = ctx.positions[gb as usize];
                mesh.positions.push([
                    pa[0] + s * (pb[0] - pa[0]),
                    pa[1] + s * (pb[1] - pa[1]),
                    pa[2] + s * (pb[2] - pa[2]),
                ]);
                mesh.values.push(match ctx.attribute {
                    Some(a) => a[ga as usize] + s * (a[gb as usize] - a[ga as usize]),
                    None => t,
                });
                mesh.edge_keys.push(key);
            }
            mesh.indices.push(vi);
        }
        mesh.offsets.push(mesh.indices.len() as u32);
        mesh.cells.push(slot);
    }
}
