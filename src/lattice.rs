//! Polygon emission for the hexahedral lattice (the S-CGraph's cells), with
//! welding by *edge ownership* instead of a hash map.
//!
//! The sweep emits a level's cut cells in slot order. Every cut grid edge
//! belongs to the polygons of all the live cells around it, and the first
//! of them in slot order (the edge's *owner*) creates its vertex; the later
//! ones read it back from an [`EdgeWindow`], a direct-mapped table indexed
//! by the edge's lower vertex modulo a power of two larger than any slot
//! distance between two cells that share an edge. Whether a cell owns an
//! edge depends only on which of its nine lower-slot edge neighbours are
//! live, so a cell's owned edges are one table lookup, and no lookup can
//! miss or hit a stale entry: an edge that is cut has a cut, live, earlier
//! owner in the same level, and no other edge reaches its window entry
//! between the owner's write and the last read.

use crate::extract::{EmitContext, LevelMesh, code_of, decide_faces, norm2_of};
use crate::metacell::MetaCell;

/// The nine neighbours `(di, dj, dk)` multiples of a lattice cell that share
/// at least an edge with it and come before it in slot order (slot steps
/// `1 < dj < dk`, so "before" is lexicographic on (k, j, i)).
pub const LOWER_NEIGHBOURS: [[i32; 3]; 9] = [
    [-1, 0, 0],
    [0, -1, 0],
    [0, 0, -1],
    [-1, -1, 0],
    [1, -1, 0],
    [-1, 0, -1],
    [1, 0, -1],
    [0, -1, -1],
    [0, 1, -1],
];

/// Slot offsets (wrapping) of the [`LOWER_NEIGHBOURS`] for slot steps `deltas`.
pub fn lower_neighbour_steps(deltas: [u32; 3]) -> [u32; 9] {
    LOWER_NEIGHBOURS.map(|o| {
        (0..3).fold(0u32, |s, a| {
            s.wrapping_add((o[a] as u32).wrapping_mul(deltas[a]))
        })
    })
}

/// Geometric vertices (`g = i + 2j + 4k`) at the ends of geometric edge
/// `e = 4·axis + q`, where q's two bits place the edge along the other two
/// axes (lower axis first). The first end is the lower one.
pub const fn edge_ends(e: usize) -> (usize, usize) {
    let d = e / 4;
    let q = e % 4;
    let (a1, a2) = match d {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let lo = (q & 1) << a1 | (q >> 1) << a2;
    (lo, lo | 1 << d)
}

/// Per-level weld table of the lattice emitter: the output vertex of each
/// cut edge, at `axis·W + (lower vertex mod W)`. Never cleared: ownership
/// guarantees every read was written earlier in the same level (see the
/// module docs).
#[derive(Clone, Debug, Default)]
pub struct EdgeWindow {
    ids: Vec<u32>,
    mask: u32,
}

impl EdgeWindow {
    /// Sizes the window for slot steps `deltas` (W = the smallest power of
    /// two above `deltas[1] + deltas[2]`). Keeps the table when it fits.
    pub fn fit(&mut self, deltas: [u32; 3]) {
        let w = (deltas[1] as u64 + deltas[2] as u64 + 1).next_power_of_two();
        let w = w.min(1 << 31) as usize;
        if self.ids.len() != 3 * w {
            self.ids = vec![0; 3 * w];
            self.mask = (w - 1) as u32;
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.ids.capacity() * 4
    }
}

/// The hexahedron's tables flattened for a lattice (S-CGraph) where every
/// cell's vertex ids are `v0 + offsets[local]`. The tables are indexed in
/// *geometric* vertex order: vertex `g = i + 2j + 4k` of the cell is the one
/// with the g-th smallest offset, so φ loads as four (i, i+1) pairs and
/// the code needs no permutation. Edges are geometric too (see
/// [`edge_ends`]): the lower end of an edge has the smaller global id in
/// every cell. Codes with an ambiguous face take the meta-cell's loops
/// (with the face decider), mapped onto the same geometric edges.
#[derive(Clone, Debug)]
pub struct LatticeHexTable {
    /// Per geometric code: start of its polygons in `polys`, or `u16::MAX`
    /// when ambiguous.
    start: Vec<u16>,
    /// Per code: polygon count, then per polygon its corner count and
    /// corners (geometric edge ids).
    polys: Vec<u8>,
    /// Per geometric code: the cut geometric edges (bit mask).
    cut: Vec<u16>,
    /// Per set of live lower neighbours (bit n = [`LOWER_NEIGHBOURS`]`[n]`
    /// live): the edges the cell owns.
    own: Vec<u16>,
    /// Per geometric edge: offset of its lower vertex from `v0`.
    edge_low: [u32; 12],
    /// Per geometric edge: offset of its upper vertex from `v0`.
    edge_high: [u32; 12],
    /// Per meta-cell edge: its geometric edge.
    local_edge: Vec<u8>,
    /// Offset of each geometric vertex (ascending).
    goff: [u32; 8],
    /// Local vertex offsets (the meta-cell's order).
    offsets: [u32; 8],
    /// Geometric vertex of each local vertex.
    geo: [u8; 8],
}

impl LatticeHexTable {
    /// Flattens the tables of hexahedron `meta` for vertex offsets `offsets`
    /// (eight distinct values of the form `i + j·npi + k·slab`).
    pub fn new(meta: &MetaCell, offsets: &[u32; 8]) -> Self {
        let mut goff = *offsets;
        goff.sort_unstable();
        let geo = offsets.map(|o| goff.iter().position(|&g| g == o).unwrap_or(0) as u8);
        let geo_edge = |a: usize, b: usize| -> u8 {
            let (a, b) = (a.min(b), a.max(b));
            (0..12).find(|&e| edge_ends(e) == (a, b)).unwrap_or(0) as u8
        };
        let local_edge: Vec<u8> = meta
            .edges
            .iter()
            .map(|&[la, lb]| geo_edge(geo[la as usize] as usize, geo[lb as usize] as usize))
            .collect();
        let mut start = vec![u16::MAX; 256];
        let mut polys = Vec::new();
        for (code, st) in start.iter_mut().enumerate() {
            let local = (0..8).fold(0, |l, q| l | (code >> geo[q] & 1) << q);
            if local >= meta.code_count() || meta.config_is_ambiguous(local) {
                continue;
            }
            *st = polys.len() as u16;
            let loops: Vec<&[u8]> = meta.loops(local, 0).collect();
            polys.push(loops.len() as u8);
            for lp in loops {
                polys.push(lp.len() as u8);
                polys.extend(lp.iter().map(|&e| local_edge[e as usize]));
            }
        }
        let cut = (0..256)
            .map(|code| {
                (0..12).fold(0u16, |m, e| {
                    let (a, b) = edge_ends(e);
                    m | (((code >> a ^ code >> b) & 1) as u16) << e
                })
            })
            .collect();
        // The cells around edge e: along its axis the same cell, along each
        // other axis the cell at its position bit or the one before.
        let own = (0..512u32)
            .map(|live| {
                (0..12).fold(0u16, |m, e| {
                    let d = e / 4;
                    let (lo, _) = edge_ends(e);
                    let bit = |a: usize| (lo >> a & 1) as i32;
                    let mut owned = true;
                    for (n, o) in LOWER_NEIGHBOURS.iter().enumerate() {
                        let around = o[d] == 0
                            && (0..3)
                                .filter(|&a| a != d)
                                .all(|a| o[a] == bit(a) || o[a] == bit(a) - 1);
                        if around && live >> n & 1 == 1 {
                            owned = false;
                        }
                    }
                    m | (owned as u16) << e
                })
            })
            .collect();
        let edge_low = std::array::from_fn(|e| goff[edge_ends(e).0]);
        let edge_high = std::array::from_fn(|e| goff[edge_ends(e).1]);
        LatticeHexTable {
            start,
            polys,
            cut,
            own,
            edge_low,
            edge_high,
            local_edge,
            goff,
            offsets: *offsets,
            geo,
        }
    }

    /// Offsets of the geometric vertices `g = i + 2j + 4k` (ascending).
    pub fn geometric_offsets(&self) -> [u32; 8] {
        self.goff
    }

    /// Emits the polygons of the cut cell `slot` with first vertex `v0`, φ
    /// `f` and code `code` in geometric order, the same polygons in the
    /// same order as [`crate::extract::emit_cell`]. `live` has bit n set
    /// when [`LOWER_NEIGHBOURS`]`[n]` is a live cell of the same sweep
    /// block; the cell creates the vertices of the cut edges it owns and
    /// reads the others from `win`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn emit(
        &self,
        meta: &MetaCell,
        v0: u32,
        f: &[f32; 8],
        t: f32,
        code: usize,
        live: u32,
        slot: u32,
        ctx: &EmitContext,
        mesh: &mut LevelMesh,
        win: &mut EdgeWindow,
    ) {
        let code = code & 255;
        let cut = self.cut[code] as u32;
        // Where t crosses each cut edge, indexed by geometric edge.
        let mut pts = [[0f32; 3]; 12];
        let mut frac = [0f32; 12];
        let mut m = cut;
        while m != 0 {
            let e = m.trailing_zeros() as usize;
            m &= m - 1;
            let (a, b) = edge_ends(e);
            let s = (t - f[a]) / (f[b] - f[a]);
            let pa = ctx.positions[(v0 + self.edge_low[e]) as usize];
            let pb = ctx.positions[(v0 + self.edge_high[e]) as usize];
            pts[e] = [
                pa[0] + s * (pb[0] - pa[0]),
                pa[1] + s * (pb[1] - pa[1]),
                pa[2] + s * (pb[2] - pa[2]),
            ];
            frac[e] = s;
        }
        let wmask = win.mask;
        let wi =
            |e: usize| ((v0 + self.edge_low[e]) & wmask) as usize + (e / 4) * (wmask as usize + 1);
        let mut own = cut & self.own[live as usize & 511] as u32;
        while own != 0 {
            let e = own.trailing_zeros() as usize;
            own &= own - 1;
            let (ga, gb) = (v0 + self.edge_low[e], v0 + self.edge_high[e]);
            let value = match ctx.attribute {
                Some(a) => a[ga as usize] + frac[e] * (a[gb as usize] - a[ga as usize]),
                None => t,
            };
            let vi = mesh.push_welded_vertex((ga as u64) << 32 | gb as u64, pts[e], value);
            win.ids[wi(e)] = vi;
        }
        mesh.cut_cells += 1;
        let s = self.start[code];
        if s == u16::MAX {
            self.emit_ambiguous(meta, v0, f, t, slot, &pts, mesh, win);
            return;
        }
        let polys = &self.polys[s as usize..];
        let mut p = 1;
        let mut ids = [0u32; 12];
        for _ in 0..polys[0] {
            let n = polys[p] as usize;
            let corners = &polys[p + 1..p + 1 + n];
            for (id, &e) in ids.iter_mut().zip(corners) {
                *id = win.ids[wi(e as usize)];
            }
            let norm2 = norm2_of(n, |i| pts[corners[i] as usize].map(f64::from));
            mesh.push_polygon(&ids[..n], norm2, slot);
            p += 1 + n;
        }
    }

    /// The loops of an ambiguous code: the meta-cell's (in its local
    /// order, with the face decider), corners mapped to geometric edges.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn emit_ambiguous(
        &self,
        meta: &MetaCell,
        v0: u32,
        f: &[f32; 8],
        t: f32,
        slot: u32,
        pts: &[[f32; 3]; 12],
        mesh: &mut LevelMesh,
        win: &EdgeWindow,
    ) {
        let gids = self.offsets.map(|o| v0 + o);
        let phi = self.geo.map(|g| f[g as usize]);
        let code = code_of(&phi, t);
        let outcome = if meta.ambiguous_faces[code] != 0 {
            decide_faces(meta, &gids, &phi, t, code)
        } else {
            0
        };
        let mut ids = [0u32; 12];
        for lp in meta.loops(code, outcome) {
            let n = lp.len().min(12);
            let corner = |i: usize| self.local_edge[lp[i] as usize] as usize;
            for (i, id) in ids.iter_mut().enumerate().take(n) {
                let e = corner(i);
                *id = win.ids[((v0 + self.edge_low[e]) & win.mask) as usize
                    + (e / 4) * (win.mask as usize + 1)];
            }
            let norm2 = norm2_of(n, |i| pts[corner(i)].map(f64::from));
            mesh.push_polygon(&ids[..n], norm2, slot);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{LOWER_NEIGHBOURS, edge_ends};

    /// Every geometric edge joins two vertices one bit apart, each edge once.
    #[test]
    fn geometric_edges_are_the_twelve_cube_edges() {
        let mut seen = std::collections::HashSet::new();
        for e in 0..12 {
            let (a, b) = edge_ends(e);
            assert_eq!(a ^ b, 1 << (e / 4), "edge {e}");
            assert!(a < b);
            assert!(seen.insert((a, b)));
        }
    }

    /// The lower neighbours are exactly the cells that share an edge or a
    /// face with the cell and come first in (k, j, i) order.
    #[test]
    fn lower_neighbours_are_the_earlier_edge_neighbours() {
        let mut want = Vec::new();
        for z in -1i32..=1 {
            for y in -1i32..=1 {
                for x in -1i32..=1 {
                    let nonzero = [x, y, z].iter().filter(|&&c| c != 0).count();
                    if (1..=2).contains(&nonzero) && (z, y, x) < (0, 0, 0) {
                        want.push([x, y, z]);
                    }
                }
            }
        }
        let mut got = LOWER_NEIGHBOURS.to_vec();
        got.sort();
        want.sort();
        assert_eq!(got, want);
    }
}
