//! S-CGraph: a curvilinear IJK hexahedral grid with implicit connectivity.
//!
//! Cells are addressed by *slots*: the slot of cell (i, j, k) is the index of
//! its first vertex `i + j·npi + k·npi·npj`, shifted by one slab
//! (`npi·npj`). Slots whose i = ni, j = nj, k = nk or k = −1 are the ghost
//! layer: they exist only in the stamp array, marked never-sweep, so the six
//! neighbours `slot ± 1, ± npi, ± npi·npj` need no bounds checks.

use crate::grid::{Grid, Topology, hex_corner_offsets};
use crate::metacell::{Catalog, MAX_META_VERTICES, builtin};
use rayon::prelude::*;

use crate::cellgraph::{BitSet, CellGraph, Lattice, LatticeHexTable};
use crate::extract::{EmitContext, prefetch};
use crate::field::ScalarField;
use crate::structures::{CellClass, StructureError, classify_cell, is_sweepable};

/// The structured cellular graph.
#[derive(Clone, Debug)]
pub struct SCGraph {
    /// Point counts along I, J, K.
    pub dims: [usize; 3],
    /// f64 origin of the rebased positions.
    pub origin: [f64; 3],
    /// Rebased f32 positions, I fastest.
    pub positions: Vec<[f32; 3]>,
    /// Per slot: set for live cells; clear for ghosts and hidden or
    /// degenerate cells.
    live: BitSet,
    /// Per slot: live, and so are its 18 face and edge neighbours (the
    /// lattice emitter then needs no per-neighbour check to weld).
    surrounded: BitSet,
    /// Counts of cell classes (see [`crate::structures::CELL_CLASS_NAMES`]).
    pub class_counts: [usize; crate::structures::CELL_CLASS_COUNT],
    /// The IJK frame is left-handed; cells are read with K reversed.
    pub left_handed: bool,
    catalog: Catalog,
    offsets: [u32; 8],
    /// Per neighbour direction (−i, +i, −j, +j, −k, +k): the local vertices
    /// of the face shared with that neighbour.
    faces: [[u8; 4]; 6],
    /// The hexahedron's tables flattened for `offsets`.
    table: LatticeHexTable,
}

impl SCGraph {
    /// Builds the S-CGraph of a structured grid. `hidden` marks cells to exclude.
    pub fn build(grid: &Grid, hidden: Option<&[bool]>) -> Result<Self, StructureError> {
        let Topology::Structured { dims } = grid.topology else {
            return Err(StructureError::NotStructured);
        };
        if dims.iter().any(|&d| d < 2) {
            return Err(StructureError::NoCells);
        }
        let [npi, npj, npk] = dims;
        let slots = npi * npj * (npk + 1);
        if slots >= u32::MAX as usize {
            return Err(StructureError::TooLarge { count: slots });
        }
        let origin = grid.origin();
        let positions = grid.rebased_positions()?;
        let slab = npi * npj;
        let mut offsets = hex_corner_offsets(npi, slab).map(|o| o as u32);
        let catalog = Catalog::new();
        let mut live = BitSet::new(slots);
        let mut class_counts = [0usize; crate::structures::CELL_CLASS_COUNT];
        let hex = catalog.get(builtin::HEXAHEDRON);
        let (nci, ncj, nck) = (npi - 1, npj - 1, npk - 1);
        let classify_all = |offsets: [u32; 8]| -> Result<Vec<CellClass>, StructureError> {
            let mut out = crate::mem::try_vec(nci * ncj * nck, "the cell classes")?;
            (0..nci * ncj * nck)
                .into_par_iter()
                .map(|cid| {
                    let (i, j, k) = (cid % nci, (cid / nci) % ncj, cid / (nci * ncj));
                    let v0 = (i + j * npi + k * slab) as u32;
                    classify_cell(hex, &offsets.map(|o| v0 + o), &grid.points)
                })
                .collect_into_vec(&mut out);
            Ok(out)
        };
        let mut classes = classify_all(offsets)?;
        // A left-handed IJK grid gives mirrored hexahedra: read the cells
        // with K reversed (top face first) so they come out positive.
        let inverted = classes
            .iter()
            .filter(|&&c| c == CellClass::Inverted)
            .count();
        let left_handed = inverted * 2 > classes.len();
        if left_handed {
            offsets = [4, 5, 6, 7, 0, 1, 2, 3].map(|i| offsets[i]);
            classes = classify_all(offsets)?;
        }
        for (cid, &class) in classes.iter().enumerate() {
            class_counts[class as usize] += 1;
            let hidden_cell = hidden.is_some_and(|h| h.get(cid).copied().unwrap_or(false));
            if is_sweepable(class) && !hidden_cell {
                let (i, j, k) = (cid % nci, (cid / nci) % ncj, cid / (nci * ncj));
                live.set(i + j * npi + k * slab + slab);
            }
        }
        // Lattice bits (i, j, k) of each local vertex, from its offset.
        let mut faces = [[0u8; 4]; 6];
        let mut fill = [0usize; 6];
        for (l, &o) in offsets.iter().enumerate() {
            let o = o as usize;
            let bits = [o % npi, (o % slab) / npi, o / slab];
            for (axis, &bit) in bits.iter().enumerate() {
                let dir = 2 * axis + bit;
                faces[dir][fill[dir]] = l as u8;
                fill[dir] += 1;
            }
        }
        let table = LatticeHexTable::new(catalog.get(builtin::HEXAHEDRON), &offsets);
        let (si, sj, sk) = (1i64, npi as i64, slab as i64);
        let mut steps = Vec::with_capacity(18);
        for z in -1..=1i64 {
            for y in -1..=1i64 {
                for x in -1..=1i64 {
                    let nonzero = (x != 0) as u8 + (y != 0) as u8 + (z != 0) as u8;
                    if (1..=2).contains(&nonzero) {
                        steps.push(x * si + y * sj + z * sk);
                    }
                }
            }
        }
        let surrounded = live.with_all_set_at(&steps);
        Ok(SCGraph {
            table,
            surrounded,
            faces,
            dims,
            origin,
            positions,
            live,
            class_counts,
            left_handed,
            catalog,
            offsets,
        })
    }

    /// Bytes held by the structure: positions (12 B/vertex) and the live bit set.
    pub fn bytes(&self) -> Vec<(&'static str, usize)> {
        vec![
            ("positions", self.positions.len() * 12),
            ("live_bits", self.live.bytes()),
            ("surrounded_bits", self.surrounded.bytes()),
        ]
    }

    /// Cells that the sweep will visit.
    pub fn live_cells(&self) -> usize {
        self.live.count()
    }
}

impl CellGraph for SCGraph {
    fn slot_count(&self) -> usize {
        self.dims[0] * self.dims[1] * (self.dims[2] + 1)
    }
    fn is_live(&self, slot: u32) -> bool {
        self.live.get(slot as usize)
    }
    fn catalog(&self) -> &Catalog {
        &self.catalog
    }
    fn positions(&self) -> &[[f32; 3]] {
        &self.positions
    }
    #[inline(always)]
    fn cell(&self, slot: u32, out: &mut [u32; MAX_META_VERTICES]) -> (u16, usize) {
        let v0 = slot - (self.dims[0] * self.dims[1]) as u32;
        for i in 0..8 {
            out[i] = v0 + self.offsets[i];
        }
        (builtin::HEXAHEDRON, 8)
    }
    #[inline(always)]
    fn for_each_neighbour(&self, slot: u32, mut f: impl FnMut(u32)) {
        let di = 1u32;
        let dj = self.dims[0] as u32;
        let dk = (self.dims[0] * self.dims[1]) as u32;
        f(slot - di);
        f(slot + di);
        f(slot - dj);
        f(slot + dj);
        f(slot - dk);
        f(slot + dk);
    }
    /// Hexahedron fast path: a neighbour shares a face (4 vertices) with
    /// `slot`, so only its 4 far vertices are evaluated.
    #[inline(always)]
    fn scan_neighbours<F: ScalarField>(
        &self,
        f: &F,
        slot: u32,
        ids: &[u32; MAX_META_VERTICES],
        phi: &[f32; MAX_META_VERTICES],
        mut want: impl FnMut(u32) -> bool,
        mut found: impl FnMut(u32, f32),
    ) {
        let deltas = [
            1u32,
            self.dims[0] as u32,
            (self.dims[0] * self.dims[1]) as u32,
        ];
        for (dir, face) in self.faces.iter().enumerate() {
            let delta = deltas[dir / 2];
            let up = dir & 1 == 1;
            let nb = if up { slot + delta } else { slot - delta };
            if want(nb) {
                let mut lo = f32::INFINITY;
                for &l in face {
                    let l = l as usize;
                    // The far vertex of the neighbour across this face
                    // vertex; it exists because `want` only accepts live
                    // neighbours.
                    let v = if up { ids[l] + delta } else { ids[l] - delta };
                    lo = lo.min(phi[l]).min(f.phi(v));
                }
                found(nb, lo);
            }
        }
    }
    /// Prefetches the cell's 4 vertex rows (positions and attribute) and
    /// the far rows of its ±j and ±k neighbours (±i share the cell's rows).
    #[inline(always)]
    fn prefetch_cell(&self, slot: u32, ctx: &EmitContext) {
        let [npi, npj, _] = self.dims;
        let slab = npi * npj;
        let v0 = slot as usize - slab;
        // Rows (j, k) relative to the cell: its own 2×2, then the neighbours'.
        let rows: [(isize, isize); 8] = [
            (0, 0),
            (1, 0),
            (0, 1),
            (1, 1),
            (-1, 0),
            (2, 0),
            (0, -1),
            (0, 2),
        ];
        for (dj, dk) in rows {
            let v = v0.wrapping_add((dj * npi as isize + dk * slab as isize) as usize);
            prefetch(&self.positions, v);
            let own_row = (0..=1).contains(&dj) && (0..=1).contains(&dk);
            if let (true, Some(a)) = (own_row, ctx.attribute) {
                prefetch(a, v);
            }
        }
    }
    fn lattice(&self) -> Option<Lattice<'_>> {
        let slab = (self.dims[0] * self.dims[1]) as u32;
        Some(Lattice {
            vertices: self.positions.len(),
            base: slab,
            deltas: [1, self.dims[0] as u32, slab],
            live: &self.live,
            surrounded: &self.surrounded,
            meta: self.catalog.get(builtin::HEXAHEDRON),
            table: &self.table,
        })
    }
    /// Every vertex of an IJK grid belongs to a cell, so when no cell is
    /// hidden or degenerate the range is that of all vertices (one pass over
    /// φ, in parallel, instead of eight reads per cell).
    fn phi_range_if_all_live<F: ScalarField>(&self, f: &F) -> Option<(f32, f32)> {
        let [npi, npj, npk] = self.dims;
        if self.live.count() != (npi - 1) * (npj - 1) * (npk - 1) {
            return None;
        }
        let n = self.positions.len();
        let range = |(a, b): (f32, f32), p: f32| (a.min(p), b.max(p));
        let merge = |(a, b): (f32, f32), (c, d): (f32, f32)| (a.min(c), b.max(d));
        let empty = (f32::INFINITY, f32::NEG_INFINITY);
        let (lo, hi) = match f.values() {
            Some(phi) => phi[..n]
                .par_chunks(1 << 16)
                .map(|c| c.iter().fold(empty, |r, &p| range(r, p)))
                .reduce(|| empty, merge),
            None => (0..n as u32)
                .into_par_iter()
                .fold(|| empty, |r, v| range(r, f.phi(v)))
                .reduce(|| empty, merge),
        };
        (lo <= hi).then_some((lo, hi))
    }
    fn source_cell(&self, slot: u32) -> u32 {
        let [npi, npj, _] = self.dims;
        let v = slot as usize - npi * npj;
        let (i, j, k) = (v % npi, (v / npi) % npj, v / (npi * npj));
        (i + (npi - 1) * (j + (npj - 1) * k)) as u32
    }
    fn blocks(&self, n: usize) -> Vec<(u32, u32)> {
        // Whole k-slabs per block.
        let slab = (self.dims[0] * self.dims[1]) as u64;
        let slabs = self.slot_count() as u64 / slab;
        let n = (n.max(1) as u64).min(slabs);
        (0..n)
            .map(|b| {
                (
                    (slabs * b / n * slab) as u32,
                    (slabs * (b + 1) / n * slab) as u32,
                )
            })
            .collect()
    }
}
