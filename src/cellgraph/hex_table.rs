//! The hexahedron's tables flattened for a lattice: polygons per
//! geometric code and the geometric edges (the S-CGraph builds one; the
//! lattice emitter, `sweep::lattice::weld`, reads it).

use crate::metacell::MetaCell;

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
    /// Per geometric code: its polygons (`polys == 0`: ambiguous).
    pub(crate) codes: Box<[CodePolygons; 256]>,
    /// Per geometric code: the cut geometric edges (bit mask).
    pub(crate) cut: Box<[u16; 256]>,
    /// Per geometric edge: offset of its lower vertex from `v0`.
    pub(crate) edge_low: [u32; 12],
    /// Per geometric edge: offset of its upper vertex from `v0`.
    pub(crate) edge_high: [u32; 12],
    /// Per meta-cell edge: its geometric edge.
    pub(crate) local_edge: Vec<u8>,
    /// Offset of each geometric vertex (ascending).
    pub(crate) goff: [u32; 8],
    /// Local vertex offsets (the meta-cell's order).
    pub(crate) offsets: [u32; 8],
    /// Geometric vertex of each local vertex.
    pub(crate) geo: [u8; 8],
}

/// The polygons of one non-ambiguous code, fixed size: every cut edge is
/// one corner of exactly one polygon (at most 12 corners and 3 polygons;
/// codes with more polygons are left to the general path).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct CodePolygons {
    /// The corners of all polygons, one after the other (geometric edges).
    pub(crate) corners: [u8; 12],
    /// Corner count of each polygon.
    pub(crate) sizes: [u8; 4],
    /// Total corner count.
    pub(crate) count: u8,
    /// Polygon count; 0 for ambiguous codes (and the two uncut codes).
    pub(crate) polys: u8,
}

/// [`edge_ends`] of every geometric edge, as a table.
pub(crate) const EDGE_ENDS: [(usize, usize); 12] = {
    let mut t = [(0, 0); 12];
    let mut e = 0;
    while e < 12 {
        t[e] = edge_ends(e);
        e += 1;
    }
    t
};

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
        let codes = (0..256usize)
            .map(|code| {
                let local = (0..8).fold(0, |l, q| l | (code >> geo[q] & 1) << q);
                let mut cp = CodePolygons::default();
                if local >= meta.code_count() || meta.config_is_ambiguous(local) {
                    return cp;
                }
                let loops: Vec<&[u8]> = meta.loops(local, 0).collect();
                let corners: usize = loops.iter().map(|l| l.len()).sum();
                if loops.len() > 3 || corners > 12 {
                    // Not a hexahedron's table (its unambiguous codes have
                    // at most two loops): take the general path.
                    return cp;
                }
                for (n, lp) in loops.iter().enumerate() {
                    cp.sizes[n] = lp.len() as u8;
                    for &e in lp.iter() {
                        let g = local_edge[e as usize];
                        cp.corners[cp.count as usize] = g;
                        cp.count += 1;
                    }
                }
                cp.polys = loops.len() as u8;
                cp
            })
            .collect::<Vec<CodePolygons>>()
            .try_into()
            .expect("256 codes");
        let cut = (0..256)
            .map(|code| {
                (0..12).fold(0u16, |m, e| {
                    let (a, b) = edge_ends(e);
                    m | (((code >> a ^ code >> b) & 1) as u16) << e
                })
            })
            .collect::<Vec<u16>>()
            .try_into()
            .expect("256 codes");
        let edge_low = std::array::from_fn(|e| goff[edge_ends(e).0]);
        let edge_high = std::array::from_fn(|e| goff[edge_ends(e).1]);
        LatticeHexTable {
            codes,
            cut,
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

    /// The point at parameter `s` along geometric edge `e` of the cell
    /// whose vertex positions start at `cell[0]` (`cell` = the positions
    /// from its first vertex to its last), with the arithmetic of
    /// [`crate::extract::LevelMesh`]'s hash-welded corners (so the same bits).
    #[inline(always)]
    pub(crate) fn point_on_edge(&self, e: usize, s: f32, cell: &[[f32; 3]]) -> [f32; 3] {
        debug_assert!(cell.len() > self.goff[7] as usize);
        // SAFETY: `cell` spans offsets 0..=goff[7] (checked by `cell_positions`)
        // and every edge end is one of the eight offsets goff[0..8].
        let (pa, pb) = unsafe {
            (
                *cell.get_unchecked(self.edge_low[e] as usize),
                *cell.get_unchecked(self.edge_high[e] as usize),
            )
        };
        [
            pa[0] + s * (pb[0] - pa[0]),
            pa[1] + s * (pb[1] - pa[1]),
            pa[2] + s * (pb[2] - pa[2]),
        ]
    }

    /// The cell's global vertex ids and φ in the meta-cell's local order.
    #[inline(always)]
    pub(crate) fn local(&self, v0: u32, f: &[f32; 8]) -> ([u32; 8], [f32; 8]) {
        (
            self.offsets.map(|o| v0 + o),
            self.geo.map(|g| f[g as usize]),
        )
    }

    /// The positions from the cell's first vertex `v0` to its last.
    #[inline(always)]
    pub(crate) fn cell_positions<'p>(&self, v0: u32, pos: &'p [[f32; 3]]) -> &'p [[f32; 3]] {
        &pos[v0 as usize..=(v0 + self.goff[7]) as usize]
    }
}
