//! Building a [`CpGraph`]: slots from the IJK layout, hexahedra coded by
//! stencil, collapsed cells and pieces explicit, links between IJK
//! neighbours that share a vertex. No vertex → cells map: a face is checked
//! by comparing the two cells' vertex ids.

use std::borrow::Cow;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use rayon::prelude::*;

use super::{CpCounts, CpGraph, EXPLICIT};
use crate::grid::IjkLayout;
use crate::grid::{Cells, Grid, Topology, origin_of, rebased};
use crate::mem::try_filled;
use crate::metacell::{Catalog, builtin};
use crate::structures::cgraph::classify_and_orient;
use crate::structures::convex_split::{SplitMap, SplitPieces};
use crate::structures::resolve::NON_VOLUMETRIC;
use crate::structures::resolve::{Resolver, resolve_cells};
use crate::structures::{BitSet, CellClass, StructureError, is_sweepable};

/// A multiply-rotate hasher for the stencil table's `[u32; 8]` keys.
#[derive(Default)]
struct StencilHasher(u64);

impl Hasher for StencilHasher {
    /// The high half folded in: the table's buckets read the low bits,
    /// which a product takes from the low bits of its operand only.
    fn finish(&self) -> u64 {
        self.0 ^ (self.0 >> 32)
    }
    /// A `[u32; 8]` key arrives as one 32-byte slice: one round per
    /// 8 bytes (the stencil ids follow insertion order, not the hash).
    fn write(&mut self, bytes: &[u8]) {
        let mut chunks = bytes.chunks_exact(8);
        for c in &mut chunks {
            let x = u64::from_le_bytes(c.try_into().expect("8 bytes"));
            self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x517c_c1b7_2722_0a95);
        }
        for &b in chunks.remainder() {
            self.write_u32(b as u32);
        }
    }
    #[inline]
    fn write_u32(&mut self, x: u32) {
        self.0 = (self.0.rotate_left(5) ^ x as u64).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
    #[inline]
    fn write_usize(&mut self, x: usize) {
        self.write_u32(x as u32);
    }
}

type StencilMap = HashMap<[u32; 8], u16, BuildHasherDefault<StencilHasher>>;

/// The pillar corner (0–3, see `CpGraph::build`) of each local vertex of a
/// hexahedron with ids numbered pillar by pillar: the two smallest ids are
/// on corner 0, the next two on corner 1, and so on.
fn pillar_corners(ids: &[u32]) -> [u8; 8] {
    std::array::from_fn(|l| (ids.iter().filter(|&&v| v < ids[l]).count() / 2) as u8)
}

/// Per 64-slot word of `bits` (of `len` bits), the set bits before it.
fn rank_words(bits: &BitSet, len: usize) -> Vec<u32> {
    let mut acc = 0u32;
    (0..len.div_ceil(64))
        .map(|w| {
            let r = acc;
            acc += bits.word_at(64 * w as i64).count_ones();
            r
        })
        .collect()
}

/// A bad layout: not the grid's, or two cells in one IJK slot.
fn layout_error(cell: usize, why: String) -> StructureError {
    StructureError::UnsupportedCell { cell, why }
}

/// The IJK box of a layout and its slot lattice (ghost layers included).
#[derive(Clone, Copy)]
struct Shape {
    dims: [usize; 3],
    npi: usize,
    slab: usize,
    lattice: usize,
}

impl Shape {
    /// The shape of `layout`, checked against a grid of `input_cells`
    /// input cells: one IJK index per cell, increasing, inside the box.
    fn of(layout: &IjkLayout, input_cells: usize) -> Result<Self, StructureError> {
        let [nx, ny, nz] = layout.dims;
        let ijk_cells = nx * ny * nz;
        if ijk_cells == 0 {
            return Err(StructureError::NoCells);
        }
        if layout.source_cell.len() != input_cells {
            return Err(layout_error(
                0,
                format!(
                    "IJK layout has {} cells, the grid {input_cells}",
                    layout.source_cell.len()
                ),
            ));
        }
        for (c, w) in layout.source_cell.windows(2).enumerate() {
            if w[0] >= w[1] {
                return Err(layout_error(c + 1, "IJK indices not increasing".into()));
            }
        }
        if let Some(&last) = layout.source_cell.last()
            && last as usize >= ijk_cells
        {
            return Err(layout_error(
                input_cells - 1,
                format!("IJK index {last} outside {:?}", layout.dims),
            ));
        }
        let (npi, npj) = (nx + 1, ny + 1);
        let slab = npi * npj;
        Ok(Shape {
            dims: layout.dims,
            npi,
            slab,
            lattice: slab * (nz + 2),
        })
    }

    /// Per input cell (IJK indices `source_cell`, increasing): its lattice
    /// slot and its column (pillar `i + npi·j`). Consecutive indices in
    /// one row are stepped to without a division.
    fn homes(&self, source_cell: &[u32]) -> Vec<[u32; 2]> {
        let [nx, ny, _] = self.dims;
        let (mut at, mut i, mut j, mut k) = (0usize, 0usize, 0usize, 0usize);
        source_cell
            .iter()
            .map(|&ijk| {
                let ijk = ijk as usize;
                if ijk >= at && ijk - at < nx - i {
                    i += ijk - at;
                } else {
                    (i, j, k) = (ijk % nx, ijk / nx % ny, ijk / (nx * ny));
                }
                at = ijk;
                let col = i + self.npi * j;
                [(col + self.slab * (k + 1)) as u32, col as u32]
            })
            .collect()
    }
}

/// The (split) grid's cells as the catalog resolves and classifies them,
/// with where each comes from.
struct Resolved<'a> {
    metas: Vec<u16>,
    voff: Cow<'a, [u32]>,
    verts: Cow<'a, [u32]>,
    class: Vec<CellClass>,
    map: Option<&'a SplitMap>,
    /// Per input cell: [`Shape::homes`].
    homes: Vec<[u32; 2]>,
}

impl Resolved<'_> {
    /// The input cell of (split) cell `c`.
    fn source(&self, c: usize) -> usize {
        self.map.map_or(c, |m| m.source[c] as usize)
    }
    /// Whether input cell `src` was split into pieces.
    fn is_split(&self, src: usize) -> bool {
        self.map.is_some_and(|m| m.is_split[src])
    }
    /// The vertex ids of cell `c`.
    fn ids(&self, c: usize) -> &[u32] {
        &self.verts[self.voff[c] as usize..self.voff[c + 1] as usize]
    }
    /// The ids of cell `c` when it is an unsplit hexahedron.
    fn hex_ids(&self, c: usize) -> Option<&[u32]> {
        let ids = self.ids(c);
        let ok = self.metas[c] == builtin::HEXAHEDRON
            && ids.len() == 8
            && !self.is_split(self.source(c));
        ok.then_some(ids)
    }
    /// The lattice slot of cell `c`'s input cell.
    fn home(&self, c: usize) -> usize {
        self.homes[self.source(c)][0] as usize
    }
    /// The column (pillar `i + npi·j`) of cell `c`'s input cell.
    fn column(&self, c: usize) -> usize {
        self.homes[self.source(c)][1] as usize
    }
}

/// Pillar-relative coding of hexahedra: local vertex l lies on pillar
/// corner `corner[l]` of its column (0: (i, j), 1: (i+1, j), 2: (i, j+1),
/// 3: (i+1, j+1)); ids are numbered pillar by pillar, so the ranks of a
/// cell's ids tell the corners. Each id is coded as
/// `base[pillar] + anchor + stencil[l]`, so a stencil holds depth index
/// differences, not pillar sizes (exact for any ids).
struct Coder {
    /// Per local vertex: its pillar's offset from the column's.
    corner_pillar: [u32; 8],
    /// Per pillar: the smallest id of a hexahedron corner on it.
    base: Vec<u32>,
    ids: StencilMap,
    stencils: Vec<[u32; 8]>,
}

impl Coder {
    fn new(r: &Resolved, shape: &Shape) -> Self {
        let n = r.metas.len();
        let corner = (0..n)
            .find_map(|c| r.hex_ids(c).map(pillar_corners))
            .unwrap_or([0, 1, 3, 2, 0, 1, 3, 2]);
        let npi = shape.npi as u32;
        let pillar_step = [0, 1, npi, npi + 1];
        let corner_pillar = corner.map(|q| pillar_step[q as usize]);
        let mut base = vec![u32::MAX; shape.slab];
        for c in 0..n {
            if let Some(ids) = r.hex_ids(c) {
                let p = r.column(c);
                for l in 0..8 {
                    let b = &mut base[p + corner_pillar[l] as usize];
                    *b = (*b).min(ids[l]);
                }
            }
        }
        Coder {
            corner_pillar,
            base,
            ids: StencilMap::default(),
            stencils: Vec::new(),
        }
    }

    /// The anchor and stencil id of a hexahedron with `ids` in column
    /// `p`; `None` when the stencil table is full.
    fn code(&mut self, p: usize, ids: &[u32]) -> Option<(u32, u16)> {
        let rel: [u32; 8] = std::array::from_fn(|l| {
            ids[l].wrapping_sub(self.base[p + self.corner_pillar[l] as usize])
        });
        let anchor = rel[0];
        let rel = rel.map(|r| r.wrapping_sub(anchor));
        let id = match self.ids.get(&rel) {
            Some(&id) => id,
            None if self.stencils.len() < EXPLICIT as usize => {
                let id = self.stencils.len() as u16;
                self.stencils.push(rel);
                self.ids.insert(rel, id);
                id
            }
            None => return None,
        };
        Some((anchor, id))
    }
}

/// Per-slot arrays being filled, with the counts found on the way.
struct Slots {
    kept: BitSet,
    piece_cell: Vec<u32>,
    anchor: Vec<u32>,
    stencil: Vec<u16>,
    live: BitSet,
    explicit: Vec<u32>,
    class_counts: [usize; crate::structures::CELL_CLASS_COUNT],
    meta_counts: Vec<usize>,
    hidden_count: usize,
    counts: CpCounts,
}

impl Slots {
    /// Places every (split) cell in its slot: lattice cells at home,
    /// pieces after the lattice; live hexahedra through a stencil, other
    /// live cells explicit.
    fn fill(
        r: &Resolved,
        shape: &Shape,
        coder: &mut Coder,
        hidden: Option<&[bool]>,
        metas: usize,
    ) -> Result<Self, StructureError> {
        let n = r.metas.len();
        let pieces = (0..n).filter(|&c| r.is_split(r.source(c))).count();
        let total = shape.lattice + pieces;
        let mut s = Slots {
            kept: BitSet::new(shape.lattice),
            piece_cell: Vec::with_capacity(pieces),
            anchor: try_filled(total, 0, "the corner-point graph's slot anchors")?,
            stencil: try_filled(total, EXPLICIT, "the corner-point graph's slot stencils")?,
            live: BitSet::new(total),
            explicit: Vec::new(),
            class_counts: [0; crate::structures::CELL_CLASS_COUNT],
            meta_counts: vec![0; metas],
            hidden_count: 0,
            counts: CpCounts {
                pieces,
                ..Default::default()
            },
        };
        let mut next_piece = shape.lattice;
        let mut last_live_src = usize::MAX;
        for c in 0..n {
            let src = r.source(c);
            let home = r.home(c);
            s.kept.set(home);
            let slot = if r.is_split(src) {
                s.piece_cell.push(src as u32);
                next_piece += 1;
                next_piece - 1
            } else {
                home
            };
            s.class_counts[r.class[c] as usize] += 1;
            if r.metas[c] != NON_VOLUMETRIC {
                s.meta_counts[r.metas[c] as usize] += 1;
            }
            let h = hidden.is_some_and(|h| h.get(src).copied().unwrap_or(false));
            s.hidden_count += h as usize;
            if !is_sweepable(r.class[c]) || h {
                continue;
            }
            s.live.set(slot);
            if src != last_live_src {
                s.counts.live_input_cells += 1;
                last_live_src = src;
            }
            let col = if slot == home {
                r.column(c)
            } else {
                slot % shape.slab
            };
            s.place(r, coder, c, slot, col);
        }
        s.counts.stencils = coder.stencils.len();
        Ok(s)
    }

    /// Stores live cell `c` in `slot` (of column `col`): by stencil when
    /// it is a hexahedron and the table takes it, else explicitly.
    fn place(&mut self, r: &Resolved, coder: &mut Coder, c: usize, slot: usize, col: usize) {
        let ids = r.ids(c);
        if r.metas[c] == builtin::HEXAHEDRON
            && ids.len() == 8
            && let Some((anchor, id)) = coder.code(col, ids)
        {
            self.anchor[slot] = anchor;
            self.stencil[slot] = id;
            self.counts.stencil_cells += 1;
            return;
        }
        self.anchor[slot] = self.explicit.len() as u32;
        self.explicit.push(r.metas[c] as u32);
        self.explicit.push(ids.len() as u32);
        self.explicit.extend_from_slice(ids);
        self.counts.explicit_cells += 1;
    }
}

impl CpGraph {
    /// Builds the corner-point graph of `grid` (a corner-point grid's zoo
    /// grid; `layout` describes its cells). With `split`, its non-convex
    /// polyhedra are replaced by the split's pieces: the cells that are not
    /// split are read from `grid`, the pieces and the new vertices from
    /// `split`. `hidden` marks `grid`'s cells to exclude.
    pub fn build(
        grid: &Grid,
        hidden: Option<&[bool]>,
        split: Option<SplitPieces>,
        layout: &IjkLayout,
    ) -> Result<Self, StructureError> {
        let Topology::Unstructured(cells) = &grid.topology else {
            return Err(StructureError::UnsupportedCell {
                cell: 0,
                why: "the corner-point graph needs a corner-point grid's cells".into(),
            });
        };
        let shape = Shape::of(layout, cells.len())?;
        let mut catalog = Catalog::new();
        let (points, map) = match split {
            Some(sp) => (Cow::Owned(sp.points), Some((sp.map, sp.cells))),
            None => (Cow::Borrowed(&grid.points[..]), None),
        };
        let (mut metas, voff, verts) = match &map {
            Some((m, pieces)) => resolve_split(cells, pieces, m, &points, &mut catalog)?,
            None => resolve_cells(cells, &points, &mut catalog)?,
        };
        let class = classify_and_orient(&mut catalog, &mut metas, &voff, &verts, &points)?;
        let map = map.map(|(m, _)| m);
        let r = Resolved {
            metas,
            voff,
            verts,
            class,
            map: map.as_ref(),
            homes: shape.homes(&layout.source_cell),
        };
        let pieces = (0..r.metas.len())
            .filter(|&c| r.is_split(r.source(c)))
            .count();
        let total = shape.lattice + pieces;
        if total >= u32::MAX as usize {
            return Err(StructureError::TooLarge { count: total });
        }
        let mut coder = Coder::new(&r, &shape);
        let s = Slots::fill(&r, &shape, &mut coder, hidden, catalog.metas.len())?;
        let (links, sums) = link(&r, &shape, &s, total)?;
        drop(r);
        let counts = CpCounts {
            faces: sums[0],
            conforming_faces: sums[1],
            exception_faces: sums[2],
            linked_exceptions: sums[3],
            ..s.counts
        };
        let mut g = CpGraph {
            origin: origin_of(&points),
            positions: Vec::new(),
            catalog,
            dims: layout.dims,
            deltas: [1, shape.npi as u32, shape.slab as u32],
            lattice_slots: shape.lattice as u32,
            live: s.live,
            kept_rank: rank_words(&s.kept, shape.lattice),
            kept: s.kept,
            piece_cell: s.piece_cell,
            slots: total,
            anchor: s.anchor,
            stencil: s.stencil,
            stencils: coder.stencils,
            base: coder.base,
            corner_pillar: coder.corner_pillar,
            slab_div: super::Divisor::new(shape.slab as u32),
            explicit: s.explicit,
            links,
            class_counts: s.class_counts,
            meta_counts: s.meta_counts,
            hidden_count: s.hidden_count,
            counts,
            map,
        };
        g.positions = rebased(&points, g.origin)?;
        Ok(g)
    }
}

/// Meta ids, vertex offsets and vertex ids of resolved cells.
type ResolvedCells<'a> = (Vec<u16>, Cow<'a, [u32]>, Cow<'a, [u32]>);

/// [`resolve_cells`] of the split grid without building it: output cell
/// `o` is input cell `map.source[o]`, or the next of the `pieces` when
/// that cell is split.
fn resolve_split<'a>(
    cells: &Cells,
    pieces: &Cells,
    map: &SplitMap,
    points: &[[f64; 3]],
    catalog: &mut Catalog,
) -> Result<ResolvedCells<'a>, StructureError> {
    let n = map.source.len();
    let conn = cells.connectivity.len() + pieces.connectivity.len();
    let mut r = Resolver::new(n, conn);
    let (mut o, mut next) = (0, 0);
    while o < n {
        let src = map.source[o] as usize;
        if map.is_split[src] {
            let (t, ids, faces) = (pieces.types[next], pieces.cell(next), pieces.faces_of(next));
            r.push(catalog, points, o, t, ids, faces)?;
            (o, next) = (o + 1, next + 1);
            continue;
        }
        // A run of cells that are not split (consecutive input cells).
        let mut end = o + 1;
        while end < n
            && map.source[end] as usize == src + (end - o)
            && !map.is_split[src + (end - o)]
        {
            end += 1;
        }
        r.push_run(catalog, points, cells, (src, src + end - o), o)?;
        o = end;
    }
    let (metas, voff, verts) = r.finish();
    Ok((metas, Cow::Owned(voff), Cow::Owned(verts)))
}

/// Per lattice slot, the (split) cell placed there: only read at live
/// slots, which always hold one.
fn cells_at(r: &Resolved, lattice: usize) -> Result<Vec<u32>, StructureError> {
    let mut at = try_filled(
        lattice,
        u32::MAX,
        "the corner-point graph's cell of each slot",
    )?;
    for c in 0..r.metas.len() {
        if !r.is_split(r.source(c)) {
            at[r.home(c)] = c as u32;
        }
    }
    Ok(at)
}

/// Links IJK neighbours that share a vertex and counts the faces (faces,
/// conforming, exception, linked exception). Each face is checked once,
/// from its lower slot (the +i, +j, +k bits); the −i, −j, −k bits are then
/// copied from the neighbour's, since two cells share a vertex or not
/// whichever side asks. The cells' ids are read from the (split) grid's
/// connectivity, slot by slot in order, rather than decoded through the
/// stencil table, which is read at random.
fn link(
    r: &Resolved,
    shape: &Shape,
    s: &Slots,
    slots: usize,
) -> Result<(Vec<u8>, [usize; 4]), StructureError> {
    let lattice = shape.lattice;
    let at = cells_at(r, lattice)?;
    let mut up = try_filled(lattice, 0u8, "the corner-point graph's upward links")?;
    let deltas = [1, shape.npi, shape.slab];
    let sums = up
        .par_chunks_mut(1 << 14)
        .enumerate()
        .map(|(ch, out)| {
            let mut sums = [0usize; 4];
            for (x, o) in out.iter_mut().enumerate() {
                *o = link_up(r, &at, s, &deltas, (ch << 14) + x, &mut sums);
            }
            sums
        })
        .reduce(
            || [0; 4],
            |x, y| [x[0] + y[0], x[1] + y[1], x[2] + y[2], x[3] + y[3]],
        );
    let mut links = try_filled(slots, 0u8, "the corner-point graph's links")?;
    links[..lattice]
        .par_chunks_mut(1 << 14)
        .enumerate()
        .for_each(|(ch, out)| {
            for (x, o) in out.iter_mut().enumerate() {
                let slot = (ch << 14) + x;
                let mut bits = up[slot];
                for (k, &delta) in deltas.iter().enumerate() {
                    if let Some(nb) = slot.checked_sub(delta) {
                        bits |= ((up[nb] >> (2 * k + 1)) & 1) << (2 * k);
                    }
                }
                *o = bits;
            }
        });
    Ok((links, sums))
}

/// The +i, +j, +k link bits of lattice `slot` (a neighbour that shares a
/// vertex), adding its faces to `sums` (see [`link`]); `at` from
/// [`cells_at`].
#[inline]
fn link_up(
    r: &Resolved,
    at: &[u32],
    s: &Slots,
    deltas: &[usize; 3],
    slot: usize,
    sums: &mut [usize; 4],
) -> u8 {
    if !s.kept.get(slot) {
        return 0;
    }
    let live = s.live.get(slot);
    let a = if live { r.ids(at[slot] as usize) } else { &[] };
    let stencil_hex = |x: usize| s.stencil[x] != EXPLICIT;
    let mut bits = 0u8;
    for (k, &delta) in deltas.iter().enumerate() {
        let nb = slot + delta;
        if nb >= at.len() || !s.kept.get(nb) {
            continue;
        }
        let common = if live && s.live.get(nb) {
            shared_vertices(a, r.ids(at[nb] as usize))
        } else {
            0
        };
        bits |= ((common > 0) as u8) << (2 * k + 1);
        sums[0] += 1;
        if common == 4 && stencil_hex(slot) && stencil_hex(nb) {
            sums[1] += 1;
        } else {
            sums[2] += 1;
            sums[3] += (common > 0) as usize;
        }
    }
    bits
}

/// How many ids of `a` occur in `b` (a live cell's ids are distinct, so
/// two hexahedra take the unrolled 8 × 8 count).
#[inline(always)]
fn shared_vertices(a: &[u32], b: &[u32]) -> usize {
    if let (Ok(a), Ok(b)) = (<&[u32; 8]>::try_from(a), <&[u32; 8]>::try_from(b)) {
        let mut k = 0;
        for &v in a {
            for &w in b {
                k += (v == w) as usize;
            }
        }
        return k;
    }
    a.iter().filter(|v| b.contains(v)).count()
}
