//! The corner-point graph's weld: a direct-mapped table indexed by a cut
//! edge's lower vertex id and a class of its id difference, in front of
//! the mesh's hash map.
//!
//! A corner-point grid numbers its vertices pillar by pillar, so from the
//! lower end `ga` of an edge `ga`–`gb` the grid's edges go down the same
//! pillar (small `gb − ga`), to the next pillar along i (about one
//! pillar's vertex count) or along j (about a row of pillars' count): one
//! entry per (`ga`, class) welds almost every edge without hashing. The
//! class is a function of the key alone, and the first edge that reaches
//! an entry in a level holds it for the whole level; every other edge that
//! maps there (pinch-outs and faults give a vertex two edges of one class,
//! pieces of split polyhedra have diagonals) is welded by the hash map
//! every time it is met. So each edge has one home per level and the
//! output is exactly the hash map's: same vertices, created in the same
//! order.

use super::cp_table::{CodeRow, ROW_EDGES};
use super::lattice::writer::HexWriter;
use crate::extract::{EmitContext, LevelMesh, decide_faces, prefetch};
use crate::metacell::MetaCell;

/// Output vertex indices must fit in the entries' low bits.
const VAL_BITS: u32 = 24;
const VAL_MASK: u32 = (1 << VAL_BITS) - 1;

/// Room of [`CpWeld::emit_row`]'s per-edge arrays: a power of two at least
/// [`ROW_EDGES`], so that an edge index is kept in range by a mask (`&`)
/// instead of a remainder by 12 (about seven instructions per corner).
const ROW_ROOM: usize = ROW_EDGES.next_power_of_two();

/// The weld table of one sweep block (see the module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct CpWeld {
    /// Per vertex id and class: `generation << 24 | output vertex`
    /// (generation 0: empty).
    entries: Vec<u32>,
    /// Current generation (1..=255).
    gen_: u32,
    /// Id differences below this are pillar edges (class 0).
    t1: u32,
    /// Id differences below this (and at least `t1`) are i edges (class
    /// 1); the others class 2.
    t2: u32,
}

impl CpWeld {
    /// A table for `vertices` vertex ids on `pillars` pillars in rows of
    /// `row` pillars.
    pub(crate) fn new(vertices: usize, pillars: usize, row: usize) -> Self {
        let m = (vertices / pillars.max(1)).max(1) as u64;
        let t1 = (m / 2).max(1);
        let t2 = (row as u64 * m / 2).max(t1 + 1);
        CpWeld {
            entries: vec![0; 3 * vertices],
            gen_: 0,
            t1: t1.min(u32::MAX as u64) as u32,
            t2: t2.min(u32::MAX as u64) as u32,
        }
    }

    /// Starts a level: every entry becomes empty.
    pub(crate) fn next_level(&mut self) {
        self.gen_ += 1;
        if self.gen_ > 255 {
            self.entries.fill(0);
            self.gen_ = 1;
        }
    }

    /// Hints the CPU to fetch the entries of edges whose lower end is `v`.
    #[inline(always)]
    pub(crate) fn prefetch(&self, v: u32) {
        prefetch(&self.entries, 3 * v as usize);
    }

    /// Entry of edge `ga`–`gb` (`ga < gb`, both vertex ids of the table).
    #[inline(always)]
    fn entry(&self, ga: u32, gb: u32) -> usize {
        let d = gb - ga;
        let class = (d >= self.t1) as usize + (d >= self.t2) as usize;
        3 * ga as usize + class
    }

    /// Adds the polygon corner where level `t` crosses grid edge `ga`–`gb`
    /// (`ga < gb`, φ values `fa`, `fb`): the vertex of the edge's entry, a
    /// new vertex when the entry is empty, else the hash map's.
    #[inline(always)]
    fn corner(
        &mut self,
        mesh: &mut LevelMesh,
        (ga, gb): (u32, u32),
        (fa, fb): (f32, f32),
        t: f32,
        ctx: &EmitContext,
    ) {
        let key = (ga as u64) << 32 | gb as u64;
        let i = self.entry(ga, gb);
        let e = self.entries[i];
        if e >> VAL_BITS == self.gen_ {
            let v = e & VAL_MASK;
            if mesh.edge_keys[v as usize] == key {
                mesh.indices.push(v);
                return;
            }
        } else {
            let v = mesh.positions.len() as u32;
            if v <= VAL_MASK {
                self.entries[i] = self.gen_ << VAL_BITS | v;
                push_vertex(mesh, key, (ga, gb), (fa, fb), t, ctx);
                mesh.indices.push(v);
                return;
            }
        }
        mesh.corner(ga, gb, fa, fb, t, ctx);
    }

    /// Emits the polygons of one intersected cell, as
    /// [`crate::extract::emit_cell`] does (same polygons, corners and
    /// vertices, in the same order), welded through this table.
    #[inline(always)]
    pub(crate) fn emit_cell(&mut self, cell: &CutCell, ctx: &EmitContext, mesh: &mut LevelMesh) {
        let CutCell {
            meta,
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
            let start = mesh.begin_polygon();
            for &e in lp {
                let [la, lb] = meta.edges[e as usize];
                let (la, lb) = (la as usize, lb as usize);
                if gids[la] < gids[lb] {
                    self.corner(mesh, (gids[la], gids[lb]), (phi[la], phi[lb]), t, ctx);
                } else {
                    self.corner(mesh, (gids[lb], gids[la]), (phi[lb], phi[la]), t, ctx);
                }
            }
            mesh.end_polygon(start, slot);
        }
    }
}

/// A cut cell of at most eight vertices as [`CpWeld::emit_row`] takes it.
#[derive(Clone, Copy)]
pub(crate) struct RowCell<'a> {
    /// Vertex ids in the meta-cell's local order.
    pub ids: &'a [u32; 8],
    /// φ at those vertices.
    pub phi: &'a [f32; 8],
    /// The level.
    pub t: f32,
    /// The cell's slot (recorded with its polygons).
    pub slot: u32,
}

impl CpWeld {
    /// Emits the polygons of a tabled cut cell (`row`, see
    /// [`super::cp_table`]) through `out`: the same polygons, corners and
    /// vertices as [`CpWeld::emit_cell`], edge after edge as it goes: each
    /// cut edge's vertex its entry's, or new when the entry is empty (the
    /// edge claims it); an edge whose entry holds another edge is welded by
    /// the mesh's hash map. Returns false, having written nothing, when
    /// the level's vertex indices could outgrow the entries: then call
    /// [`CpWeld::emit_cell`].
    #[inline(always)]
    pub(crate) fn emit_row(
        &mut self,
        row: &CodeRow,
        cell: RowCell,
        ctx: &EmitContext,
        out: &mut HexWriter,
    ) -> bool {
        let RowCell { ids, phi, t, slot } = cell;
        if out.vertices() + ROW_EDGES > VAL_MASK as usize {
            return false;
        }
        out.begin_cell();
        let n = (row.edges as usize).min(ROW_EDGES);
        let mut vert = [0u32; ROW_ROOM];
        // The vertex of cut edge `j`; a macro, so that each unrolled copy
        // below is a branch of its own for the predictor.
        macro_rules! edge {
            ($j:expr) => {{
                let j: usize = $j;
                // Local ids are below 8 (`& 7` lets the compiler drop the
                // checks).
                let [la, lb] = row.ends[j];
                let (la, lb) = (la as usize & 7, lb as usize & 7);
                // The lower id's end first, swapped without a branch (the
                // order is a coin toss per edge: a branch mispredicts).
                let swap = ((ids[la] > ids[lb]) as usize).wrapping_neg() & (la ^ lb);
                let (la, lb) = (la ^ swap, lb ^ swap);
                let (ga, gb, fa, fb) = (ids[la], ids[lb], phi[la], phi[lb]);
                let key = (ga as u64) << 32 | gb as u64;
                let i = self.entry(ga, gb);
                let e = self.entries[i];
                vert[j & (ROW_ROOM - 1)] = 'v: {
                    if e >> VAL_BITS == self.gen_ {
                        let v = e & VAL_MASK;
                        if out.key(v) == key {
                            break 'v v;
                        }
                        let (h, new) = out.hashed(key);
                        if !new {
                            break 'v h;
                        }
                    }
                    let (p, value) = edge_point(ctx, (ga, gb), (fa, fb), t);
                    let nv = out.vertex(key, p, value);
                    if e >> VAL_BITS != self.gen_ {
                        self.entries[i] = self.gen_ << VAL_BITS | nv;
                    }
                    nv
                };
            }};
        }
        // A row has at least three edges (see `cp_table`): the loop over
        // them unrolled for the common counts (3 to 6), whose exit branch
        // mispredicted about once per cell.
        debug_assert!(n >= 3);
        edge!(0);
        edge!(1);
        edge!(2);
        if n > 3 {
            edge!(3);
            if n > 4 {
                edge!(4);
                if n > 5 {
                    edge!(5);
                    for j in 6..n {
                        edge!(j);
                    }
                }
            }
        }
        let mut first = 0;
        for &m in &row.sizes[..row.polys as usize] {
            let m = m as usize;
            let corners = &row.corners[first..first + m];
            out.polygon(m, |i| vert[corners[i] as usize & (ROW_ROOM - 1)], slot);
            first += m;
        }
        true
    }
}

/// One cut cell as the weld emits it.
#[derive(Clone, Copy)]
pub(crate) struct CutCell<'a> {
    /// Its meta-cell.
    pub meta: &'a MetaCell,
    /// Vertex ids in the meta-cell's local order.
    pub gids: &'a [u32],
    /// φ at those vertices.
    pub phi: &'a [f32],
    /// The level.
    pub t: f32,
    /// [`crate::extract::code_of`] of `phi` at `t`.
    pub code: usize,
    /// The cell's slot (recorded with its polygons).
    pub slot: u32,
}

/// Appends the vertex where level `t` crosses grid edge `ga`–`gb` (`ga <
/// gb`), with the arithmetic of the mesh's own corners (so the same bits).
#[inline(always)]
fn push_vertex(
    mesh: &mut LevelMesh,
    key: u64,
    (ga, gb): (u32, u32),
    (fa, fb): (f32, f32),
    t: f32,
    ctx: &EmitContext,
) {
    let (p, value) = edge_point(ctx, (ga, gb), (fa, fb), t);
    mesh.positions.push(p);
    mesh.values.push(value);
    mesh.edge_keys.push(key);
}

/// The point where level `t` crosses grid edge `ga`–`gb` (φ `fa`, `fb`)
/// and the attribute there (`t` without one), with the arithmetic of the
/// mesh's own corners (so the same bits).
#[inline(always)]
fn edge_point(
    ctx: &EmitContext,
    (ga, gb): (u32, u32),
    (fa, fb): (f32, f32),
    t: f32,
) -> ([f32; 3], f32) {
    let s = (t - fa) / (fb - fa);
    let pa = ctx.positions[ga as usize];
    let pb = ctx.positions[gb as usize];
    let p = [
        pa[0] + s * (pb[0] - pa[0]),
        pa[1] + s * (pb[1] - pa[1]),
        pa[2] + s * (pb[2] - pa[2]),
    ];
    let value = match ctx.attribute {
        Some(a) => a[ga as usize] + s * (a[gb as usize] - a[ga as usize]),
        None => t,
    };
    (p, value)
}
