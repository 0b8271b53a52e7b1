//! Index-space coordinates of a corner-point graph (no wgpu): per vertex
//! its lattice node `(i, j, k)`, and per IJK cell its input cell, for the
//! pre-integrated volume pass (`gpu::render::preintegrated::ijk_field`; its outer surface, over
//! every live cell: `gpu::render::preintegrated::boundary::graph_boundary_triangles`).
//!
//! A hexahedron in column `(i, j)`, layer `k` has its local vertex `l` on
//! pillar corner `corner_pillar[l]` and at node layer `k` or `k + 1`: the
//! side shared with the cell below in a conforming column is `k + 1`
//! (found once on the grid). A vertex on several hexahedra gets the mean
//! of their nodes (the same node unless the grid is degenerate there).
//! Vertices of no hexahedron (collapsed cells, the pieces of split cells)
//! get the centre of their input cell.

use super::CpGraph;
use crate::cellgraph::CellGraph;
use crate::metacell::{MAX_META_VERTICES, builtin};

impl CpGraph {
    /// `(i, j, k)` of the IJK cell of lattice slot `slot`.
    pub fn slot_ijk(&self, slot: u32) -> [usize; 3] {
        let npi = self.deltas[1] as usize;
        let slab = self.deltas[2] as usize;
        let s = slot as usize;
        let k = s / slab;
        [s % npi, (s % slab) / npi, k.saturating_sub(1)]
    }

    /// The lattice slots that hold an input cell, in input-cell order.
    pub fn input_slots(&self) -> Vec<u32> {
        (0..self.lattice_slots)
            .filter(|&s| self.kept.get(s as usize))
            .collect()
    }

    /// Per local hexahedron vertex: whether it lies on the cell's `k + 1`
    /// side (shared with the cell below in a conforming column); `None`
    /// when no two stacked hexahedra share a face.
    fn lower_side(&self) -> Option<[bool; 8]> {
        let mut a = [0u32; MAX_META_VERTICES];
        let mut b = [0u32; MAX_META_VERTICES];
        for s in 0..self.lattice_slots.saturating_sub(self.deltas[2]) {
            let t = s + self.deltas[2];
            let both = self.kept.get(s as usize)
                && self.kept.get(t as usize)
                && self.is_stencil_hex(s)
                && self.is_stencil_hex(t);
            if !both {
                continue;
            }
            self.cell(s, &mut a);
            self.cell(t, &mut b);
            let side: [bool; 8] = std::array::from_fn(|l| b[..8].contains(&a[l]));
            if side.iter().filter(|&&x| x).count() == 4 {
                return Some(side);
            }
        }
        None
    }

    /// Per vertex (positions order): its lattice node `(i, j, k, 0)`.
    pub fn vertex_ijk(&self) -> Vec<[f32; 4]> {
        let n = self.positions.len();
        let mut sum = vec![[0f64; 3]; n];
        let mut count = vec![0u32; n];
        let lower = self
            .lower_side()
            .unwrap_or([false, false, false, false, true, true, true, true]);
        let npi = self.deltas[1];
        let mut ids = [0u32; MAX_META_VERTICES];
        let mut add = |v: u32, p: [f64; 3]| {
            let s = &mut sum[v as usize];
            for a in 0..3 {
                s[a] += p[a];
            }
            count[v as usize] += 1;
        };
        for slot in 0..self.lattice_slots {
            if !self.kept.get(slot as usize) {
                continue;
            }
            let (m, nv) = self.cell(slot, &mut ids);
            if m != builtin::HEXAHEDRON || nv != 8 {
                continue;
            }
            let [i, j, k] = self.slot_ijk(slot);
            for l in 0..8 {
                let q = self.corner_pillar[l];
                let node = [
                    (i as u32 + q % npi) as f64,
                    (j as u32 + q / npi) as f64,
                    (k + lower[l] as usize) as f64,
                ];
                add(ids[l], node);
            }
        }
        // The rest: the centre of their input cell.
        let inputs = self.input_slots();
        for slot in 0..self.slots as u32 {
            if !self.is_live(slot) {
                continue;
            }
            let home = inputs[self.source_cell(slot) as usize];
            let [i, j, k] = self.slot_ijk(home);
            let (_, nv) = self.cell(slot, &mut ids);
            for &v in &ids[..nv] {
                if count[v as usize] == 0 {
                    sum[v as usize] = [i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5];
                    count[v as usize] = u32::MAX;
                }
            }
        }
        sum.iter()
            .zip(&count)
            .map(|(s, &c)| match c {
                0 => [0.0; 4],
                u32::MAX => [s[0] as f32, s[1] as f32, s[2] as f32, 0.0],
                c => {
                    let c = c as f64;
                    [(s[0] / c) as f32, (s[1] / c) as f32, (s[2] / c) as f32, 0.0]
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use crate::cornerpoint::CornerPointGrid;
    use crate::grid::IjkLayout;
    use crate::structures::{Structure, StructureChoice};

    /// A 3 × 2 × 4 corner-point box: pillars at x = i, y = j, layers 0.5
    /// thick (z = −depth).
    fn boxed() -> Structure {
        let dims = [3usize, 2, 4];
        let [nx, ny, nz] = dims;
        let mut coord = Vec::new();
        for pj in 0..=ny {
            for pi in 0..=nx {
                coord.extend_from_slice(&[pi as f64, pj as f64, 0.0, pi as f64, pj as f64, 2.0]);
            }
        }
        let mut zcorn = vec![0.0; 8 * nx * ny * nz];
        for (n, z) in zcorn.iter_mut().enumerate() {
            *z = 0.5 * (n / (4 * nx * ny)).div_ceil(2) as f64;
        }
        let cp = CornerPointGrid {
            dims,
            coord,
            zcorn,
            actnum: None,
            mapaxes: None,
            mapunits: None,
            gridunit: None,
            properties: Vec::new(),
        };
        let (grid, rep) = cp.into_grid().unwrap();
        let layout = IjkLayout {
            dims,
            source_cell: rep.source_cell,
        };
        Structure::build_with(&grid, StructureChoice::CpGraph, Some(&layout)).unwrap()
    }

    #[test]
    fn vertices_carry_their_lattice_node() {
        let Structure::CpGraph(g) = boxed() else {
            panic!("not a CP-Graph");
        };
        let ijk = g.vertex_ijk();
        assert_eq!(ijk.len(), g.positions.len());
        // Node (i, j, k) sits at x = i, y = j, z = −k/2 (rebased by the origin).
        let node = |p: [f32; 3]| {
            let o = g.origin;
            let w = [0, 1, 2].map(|a| p[a] as f64 + o[a]);
            [w[0], w[1], -2.0 * w[2]]
        };
        for (p, q) in g.positions.iter().zip(&ijk) {
            let n = node(*p);
            for a in 0..3 {
                assert!((q[a] as f64 - n[a]).abs() < 1e-5, "{p:?}: {q:?} vs {n:?}");
            }
        }
    }
}
