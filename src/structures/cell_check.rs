//! Ids of self-intersecting cells (a quadrilateral face that crosses
//! itself: [`crate::structures::quad_is_bow_tie`]), so that `info` can name
//! them; the structures count them as [`crate::structures::CellClass::SelfIntersecting`]
//! and never sweep them.

use crate::grid::{Grid, Topology, hex_corner_offsets, vtk_type};
use crate::metacell::{Catalog, VOXEL_TO_HEX};
use crate::structures::polyhedron::{Scratch, polyhedron_faces_in};
use crate::structures::quad_is_bow_tie;

/// The first `limit` cells (input ids, ascending) with a bow-tie face,
/// and how many there are in all. Typed cells and lattice hexahedra are
/// checked; polyhedra (general faces) are not.
pub fn self_intersecting_cells(grid: &Grid, limit: usize) -> (Vec<usize>, usize) {
    let mut catalog = Catalog::new();
    let mut ids = Vec::new();
    let mut total = 0;
    let mut check = |c: usize, vs: &[u32], faces: &[Vec<u8>]| {
        let bad = faces.iter().any(|f| match f[..] {
            [a, b, d, e] => {
                let p = |k: u8| grid.points[vs[k as usize] as usize];
                quad_is_bow_tie([p(a), p(b), p(d), p(e)])
            }
            _ => false,
        });
        if bad {
            total += 1;
            if ids.len() < limit {
                ids.push(c);
            }
        }
    };
    match &grid.topology {
        Topology::Structured { dims } => {
            let [npi, npj, npk] = *dims;
            let off = hex_corner_offsets(npi, npi * npj);
            let hex = &catalog.get(crate::metacell::builtin::HEXAHEDRON).faces;
            let (nci, ncj, nck) = (npi - 1, npj - 1, npk - 1);
            for cid in 0..nci * ncj * nck {
                let (i, j, k) = (cid % nci, (cid / nci) % ncj, cid / (nci * ncj));
                let v0 = i + j * npi + k * npi * npj;
                check(cid, &off.map(|o| (v0 + o) as u32), hex);
            }
        }
        Topology::Unstructured(cells) => {
            for c in 0..cells.len() {
                let vs = cells.cell(c);
                let Some(m) = catalog.for_vtk_type(cells.types[c]) else {
                    continue;
                };
                let meta = catalog.get(m);
                if meta.nv != vs.len() {
                    continue;
                }
                if cells.types[c] == vtk_type::VOXEL {
                    // Voxels list their corners in another order.
                    check(c, &VOXEL_TO_HEX.map(|i| vs[i]), &meta.faces);
                } else {
                    check(c, vs, &meta.faces);
                }
            }
        }
    }
    (ids, total)
}

/// Polyhedra whose faces were not all given outward: the structures
/// reverse those loops (orientation propagated across the cell's edges,
/// then by the volume sign) before sweeping, and `info` says so. Returns the
/// first `limit` such cells (input ids, ascending), how many there are, and
/// how many faces were reversed in all. Polyhedra the checks refuse (open,
/// non-manifold) are left to the build's own error.
pub fn reoriented_polyhedra(grid: &Grid, limit: usize) -> (Vec<usize>, usize, usize) {
    let Topology::Unstructured(cells) = &grid.topology else {
        return (Vec::new(), 0, 0);
    };
    let (mut ids, mut total, mut faces) = (Vec::new(), 0, 0);
    let mut s = Scratch::default();
    for c in 0..cells.len() {
        if cells.types[c] != vtk_type::POLYHEDRON {
            continue;
        }
        let stream = cells.faces_of(c);
        let Ok((_, flipped, _)) = polyhedron_faces_in(c, stream, &grid.points, &mut s) else {
            continue;
        };
        if flipped > 0 {
            total += 1;
            faces += flipped;
            if ids.len() < limit {
                ids.push(c);
            }
        }
    }
    (ids, total, faces)
}
