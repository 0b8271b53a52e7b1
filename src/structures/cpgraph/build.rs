//! Building a [`CpGraph`]: slots from the IJK layout, hexahedra coded by
//! stencil, collapsed cells and pieces explicit, links between IJK
//! neighbours that share a vertex. No vertex → cells map: a face is checked
//! by comparing the two cells' vertex ids.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use rayon::prelude::*;

use super::{CpCounts, CpGraph, EXPLICIT, IjkLayout};
use crate::grid::{Grid, Topology};
use crate::metacell::{Catalog, MAX_META_VERTICES, builtin};
use crate::structures::cgraph::{NON_VOLUMETRIC, classify_and_orient, resolve_cells};
use crate::structures::convex_split::SplitMap;
use crate::structures::{BitSet, StructureError, is_sweepable};
use crate::sweep::CellGraph;

/// A multiply-rotate hasher for the stencil table's `[u32; 8]` keys.
#[derive(Default)]
struct StencilHasher(u64);

impl Hasher for StencilHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
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

/// Per-slot arrays being filled.
struct Slots {
    kept: BitSet,
    piece_cell: Vec<u32>,
    anchor: Vec<u32>,
    stencil: Vec<u16>,
    live: BitSet,
}

impl CpGraph {
    /// Builds the corner-point graph of `grid` (a corner-point grid's zoo
    /// grid, or its split: then `map` is the split and `layout` describes
    /// the input cells). `hidden` marks the (split) grid's cells to exclude.
    pub fn build(
        grid: &Grid,
        hidden: Option<&[bool]>,
        map: Option<SplitMap>,
        layout: &IjkLayout,
    ) -> Result<Self, StructureError> {
        let Topology::Unstructured(cells) = &grid.topology else {
            return Err(StructureError::UnsupportedCell {
                cell: 0,
                why: "the corner-point graph needs a corner-point grid's cells".into(),
            });
        };
        let [nx, ny, nz] = layout.dims;
        let ijk_cells = nx * ny * nz;
        if ijk_cells == 0 {
            return Err(StructureError::NoCells);
        }
        let (npi, npj) = (nx + 1, ny + 1);
        let slab = npi * npj;
        let lattice = slab * (nz + 2);
        let input_cells = map.as_ref().map_or(cells.len(), |m| m.input_cells);
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
        let mut catalog = Catalog::new();
        let (mut metas, voff, verts) = resolve_cells(cells, &grid.points, &mut catalog)?;
        let class = classify_and_orient(&mut catalog, &mut metas, &voff, &verts, &grid.points)?;
        let n = metas.len();
        let source = |c: usize| map.as_ref().map_or(c, |m| m.source[c] as usize);
        let is_split = |src: usize| map.as_ref().is_some_and(|m| m.is_split[src]);
        let pieces = (0..n).filter(|&c| is_split(source(c))).count();
        let total = lattice + pieces;
        if total >= u32::MAX as usize {
            return Err(StructureError::TooLarge { count: total });
        }
        let mut s = Slots {
            kept: BitSet::new(lattice),
            piece_cell: Vec::with_capacity(pieces),
            anchor: vec![0; total],
            stencil: vec![EXPLICIT; total],
            live: BitSet::new(total),
        };
        let mut class_counts = [0usize; crate::structures::CELL_CLASS_COUNT];
        let mut meta_counts = vec![0usize; catalog.metas.len()];
        let mut hidden_count = 0;
        let mut counts = CpCounts::default();
        let mut stencil_ids = StencilMap::default();
        let mut stencils: Vec<[u32; 8]> = Vec::new();
        let mut explicit: Vec<u32> = Vec::new();
        // Pillar-relative coding: a hexahedron's local vertex l lies on
        // pillar corner `corner[l]` of its column (0: (i, j), 1: (i+1, j),
        // 2: (i, j+1), 3: (i+1, j+1)); ids are numbered pillar by pillar, so
        // the ranks of a cell's ids tell the corners. Each id is coded as
        // `base[pillar] + anchor + stencil[l]`, so a stencil holds depth
        // index differences, not pillar sizes (exact for any ids).
        let home_of = |c: usize| {
            let ijk = layout.source_cell[source(c)] as usize;
            let (i, j, k) = (ijk % nx, ijk / nx % ny, ijk / (nx * ny));
            i + npi * (j + npj * (k + 1))
        };
        let hex_ids = |c: usize| -> Option<&[u32]> {
            let ids = &verts[voff[c] as usize..voff[c + 1] as usize];
            let ok = metas[c] == builtin::HEXAHEDRON && ids.len() == 8 && !is_split(source(c));
            ok.then_some(ids)
        };
        let corner = (0..n)
            .find_map(|c| hex_ids(c).map(pillar_corners))
            .unwrap_or([0, 1, 3, 2, 0, 1, 3, 2]);
        let pillar_step = [0, 1, npi as u32, npi as u32 + 1];
        let corner_pillar = corner.map(|q| pillar_step[q as usize]);
        let mut base = vec![u32::MAX; slab];
        for c in 0..n {
            if let Some(ids) = hex_ids(c) {
                let p = home_of(c) % slab;
                for l in 0..8 {
                    let b = &mut base[p + corner_pillar[l] as usize];
                    *b = (*b).min(ids[l]);
                }
            }
        }
        let mut next_piece = lattice;
        let mut last_live_src = usize::MAX;
        for c in 0..n {
            let src = source(c);
            let ijk = layout.source_cell[src] as usize;
            let (i, j, k) = (ijk % nx, ijk / nx % ny, ijk / (nx * ny));
            let home = i + npi * (j + npj * (k + 1));
            let slot = if is_split(src) {
                s.kept.set(home);
                s.piece_cell.push(src as u32);
                next_piece += 1;
                next_piece - 1
            } else {
                home
            };
            if slot == home {
                s.kept.set(home);
            }
            class_counts[class[c] as usize] += 1;
            if metas[c] != NON_VOLUMETRIC {
                meta_counts[metas[c] as usize] += 1;
            }
            let h = hidden.is_some_and(|h| h.get(c).copied().unwrap_or(false));
            hidden_count += h as usize;
            if !is_sweepable(class[c]) || h {
                continue;
            }
            s.live.set(slot);
            if src != last_live_src {
                counts.live_input_cells += 1;
                last_live_src = src;
            }
            let ids = &verts[voff[c] as usize..voff[c + 1] as usize];
            if metas[c] == builtin::HEXAHEDRON && ids.len() == 8 {
                let p = slot % slab;
                let rel: [u32; 8] = std::array::from_fn(|l| {
                    ids[l].wrapping_sub(base[p + corner_pillar[l] as usize])
                });
                let anchor = rel[0];
                let rel = rel.map(|r| r.wrapping_sub(anchor));
                let id = match stencil_ids.get(&rel) {
                    Some(&id) => Some(id),
                    None if stencils.len() < EXPLICIT as usize => {
                        let id = stencils.len() as u16;
                        stencils.push(rel);
                        stencil_ids.insert(rel, id);
                        Some(id)
                    }
                    None => None,
                };
                if let Some(id) = id {
                    s.anchor[slot] = anchor;
                    s.stencil[slot] = id;
                    counts.stencil_cells += 1;
                    continue;
                }
            }
            s.anchor[slot] = explicit.len() as u32;
            explicit.push(metas[c] as u32);
            explicit.push(ids.len() as u32);
            explicit.extend_from_slice(ids);
            counts.explicit_cells += 1;
        }
        drop((verts, voff, metas, class));
        counts.stencils = stencils.len();
        counts.pieces = pieces;
        let mut g = CpGraph {
            origin: grid.origin(),
            positions: Vec::new(),
            catalog,
            dims: layout.dims,
            deltas: [1, npi as u32, slab as u32],
            lattice_slots: lattice as u32,
            live: s.live,
            kept_rank: rank_words(&s.kept, lattice),
            kept: s.kept,
            piece_cell: s.piece_cell,
            slots: total,
            anchor: s.anchor,
            stencil: s.stencil,
            stencils,
            base,
            corner_pillar,
            slab_div: super::Divisor::new(slab as u32),
            explicit,
            links: Vec::new(),
            class_counts,
            meta_counts,
            hidden_count,
            counts,
            map,
        };
        g.link();
        g.positions = grid.rebased_positions();
        Ok(g)
    }

    /// Links IJK neighbours that share a vertex and counts the faces.
    fn link(&mut self) {
        let lattice = self.lattice_slots as usize;
        let mut links = vec![0u8; self.slots];
        let g = &*self;
        let sums = links[..lattice]
            .par_chunks_mut(1 << 14)
            .enumerate()
            .map(|(ch, out)| {
                let mut sums = [0usize; 4];
                let (mut a, mut b) = ([0u32; MAX_META_VERTICES], [0u32; MAX_META_VERTICES]);
                for (x, o) in out.iter_mut().enumerate() {
                    let slot = ((ch << 14) + x) as u32;
                    if !g.kept.get(slot as usize) {
                        continue;
                    }
                    let live = g.live.get(slot as usize);
                    let na = if live { g.cell(slot, &mut a).1 } else { 0 };
                    for d in 0..6 {
                        let delta = g.deltas[d / 2];
                        let nb = if d & 1 == 1 {
                            slot + delta
                        } else {
                            slot.wrapping_sub(delta)
                        };
                        if nb as usize >= lattice || !g.kept.get(nb as usize) {
                            continue;
                        }
                        let both = live && g.live.get(nb as usize);
                        let common = if both {
                            let nn = g.cell(nb, &mut b).1;
                            let mut k = 0;
                            for &v in &a[..na] {
                                k += b[..nn].contains(&v) as usize;
                            }
                            k
                        } else {
                            0
                        };
                        if common > 0 {
                            *o |= 1 << d;
                        }
                        if d & 1 == 1 {
                            // Each face once, from its lower slot.
                            sums[0] += 1;
                            let conforming =
                                common == 4 && g.is_stencil_hex(slot) && g.is_stencil_hex(nb);
                            if conforming {
                                sums[1] += 1;
                            } else {
                                sums[2] += 1;
                                sums[3] += (common > 0) as usize;
                            }
                        }
                    }
                }
                sums
            })
            .reduce(
                || [0; 4],
                |x, y| [x[0] + y[0], x[1] + y[1], x[2] + y[2], x[3] + y[3]],
            );
        self.counts.faces = sums[0];
        self.counts.conforming_faces = sums[1];
        self.counts.exception_faces = sums[2];
        self.counts.linked_exceptions = sums[3];
        self.links = links;
    }
}
