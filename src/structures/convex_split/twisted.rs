//! Twisted cells: typed cells (hexahedra, voxels, wedges, pyramids) with a
//! quadrilateral face that crosses itself (a bow-tie,
//! [`crate::structures::quad_is_bow_tie`]). Their meta-cell polygons would
//! be wrong, so they are sliced, as Caumon et al. propose for ambiguous and
//! concave cells, through a decomposition coned from an interior point (the
//! cell's vertex mean, or when that leaves a piece flat a mean with one or
//! two vertices counted twice):
//!
//! - each bow-tie face is cut along the diagonal from its smallest global
//!   vertex id into two triangles, each coned to a tetrahedron: the face
//!   data alone choose the diagonal, so the cell across the face (twisted
//!   too: the face is the same bow-tie) cuts it alike and isosurfaces stay
//!   watertight;
//! - every other face is kept whole, the base of a pyramid (or of a
//!   tetrahedron for a triangle), so an untwisted neighbour, which slices
//!   the same face whole, meets the pieces without a crack.
//!
//! Each piece is given positive volume (a twisted cell's cones face both
//! ways); pieces of (near) zero volume are left out.

use rayon::prelude::*;

use crate::grid::{Cells, is_lower_dimensional, vtk_type};
use crate::metacell::{Catalog, VOXEL_TO_HEX};
use crate::structures::{CellClass, classify_cell, quad_is_bow_tie};
use crate::vec3::{P3, cross, dot, mean, norm, sub};

/// The typed cells (not polyhedra) that the classification calls
/// [`CellClass::SelfIntersecting`], ascending, each with its vertex ids in
/// the meta-cell's local order (a voxel's reordered as a hexahedron) and its
/// meta-cell's face loops. Hidden ones are cut too (their pieces stay
/// hidden), so that no structure counts them as left unsliced.
pub(super) fn find_twisted(cells: &Cells, points: &[P3]) -> Vec<(usize, Vec<u32>, Vec<Vec<u8>>)> {
    let mut catalog = Catalog::new();
    // Meta-cell per VTK type (few types: resolved once, read in parallel).
    let mut meta_of = [None; 256];
    for &t in &cells.types {
        let slot = &mut meta_of[t as usize];
        if slot.is_none() && t != vtk_type::POLYHEDRON && !is_lower_dimensional(t) {
            *slot = Some(catalog.for_vtk_type(t));
        }
    }
    let catalog = &catalog;
    (0..cells.len())
        .into_par_iter()
        .with_min_len(4096)
        .filter_map(|c| {
            let t = cells.types[c];
            let m = meta_of[t as usize].flatten()?;
            let meta = catalog.get(m);
            let vs = cells.cell(c);
            if meta.nv != vs.len() {
                return None;
            }
            let ids: Vec<u32> = if t == vtk_type::VOXEL {
                VOXEL_TO_HEX.iter().map(|&i| vs[i]).collect()
            } else {
                vs.to_vec()
            };
            (classify_cell(meta, &ids, points) == CellClass::SelfIntersecting)
                .then(|| (c, ids, meta.faces.clone()))
        })
        .collect()
}

/// Signed volume of a VTK tetrahedron.
fn tet_volume(p: [P3; 4]) -> f64 {
    dot(cross(sub(p[1], p[0]), sub(p[2], p[0])), sub(p[3], p[0])) / 6.0
}

/// The pieces of a twisted cell with vertex ids `ids` (local order of
/// `faces`, outward loops) and apex `apex` (new vertex id `apex_id`): per
/// piece its VTK type and ids, each of positive volume; and how many
/// pieces were flat (left out). `pos` gives every input point.
fn pieces_from(
    ids: &[u32],
    faces: &[Vec<u8>],
    apex: P3,
    apex_id: u32,
    pos: &impl Fn(u32) -> P3,
) -> (Vec<(u8, Vec<u32>)>, usize) {
    let ext = ids
        .iter()
        .map(|&v| norm(sub(pos(v), apex)))
        .fold(0.0, f64::max);
    let tiny = 1e-9 * ext * ext * ext;
    let mut out = Vec::with_capacity(2 * faces.len());
    let mut flat = 0;
    // One tetrahedron per outward triangle (a, b, c), the apex behind it;
    // 1 when it is flat (left out).
    let tet = |a: u32, b: u32, c: u32, out: &mut Vec<(u8, Vec<u32>)>| -> usize {
        let v = tet_volume([pos(a), pos(c), pos(b), apex]);
        if v > tiny {
            out.push((vtk_type::TETRA, vec![a, c, b, apex_id]));
        } else if v < -tiny {
            out.push((vtk_type::TETRA, vec![a, b, c, apex_id]));
        }
        (v.abs() <= tiny) as usize
    };
    for f in faces {
        let g: Vec<u32> = f.iter().map(|&l| ids[l as usize]).collect();
        match g[..] {
            [a, b, c] => flat += tet(a, b, c, &mut out),
            [_, _, _, _] if quad_is_bow_tie([pos(g[0]), pos(g[1]), pos(g[2]), pos(g[3])]) => {
                let i0 = (0..4).min_by_key(|&i| g[i]).unwrap_or(0);
                let at = |k: usize| g[(i0 + k) % 4];
                flat += tet(at(0), at(1), at(2), &mut out);
                flat += tet(at(0), at(2), at(3), &mut out);
            }
            [a, b, c, d] => {
                // Base reversed (inward), so the apex is on its normal's side.
                let (v1, v2) = (
                    tet_volume([pos(a), pos(c), pos(b), apex]),
                    tet_volume([pos(a), pos(d), pos(c), apex]),
                );
                let v = v1 + v2;
                // Flat, or seen edge-on (the apex between the planes of a
                // warped base's halves): another apex is tried first.
                flat += (v.abs() <= tiny || (v1.min(v2) < -tiny && v1.max(v2) > tiny)) as usize;
                if v > tiny {
                    out.push((vtk_type::PYRAMID, vec![a, d, c, b, apex_id]));
                } else if v < -tiny {
                    out.push((vtk_type::PYRAMID, vec![a, b, c, d, apex_id]));
                }
            }
            _ => {
                // Larger faces (none in the typed cells): a fan of triangles.
                for k in 1..g.len() - 1 {
                    flat += tet(g[0], g[k], g[k + 1], &mut out);
                }
            }
        }
    }
    (out, flat)
}

/// The decomposition of a twisted cell (see the module docs): its apex, the
/// input vertices whose mean it is (the vertex mean; when a piece would be
/// flat, the mean with one vertex, then two, counted twice: the first such
/// choice that leaves no piece flat, as a flat piece is never swept and
/// would open the isosurfaces), and its pieces (apex id `apex_id`).
pub(super) fn twisted_pieces(
    ids: &[u32],
    faces: &[Vec<u8>],
    apex_id: u32,
    pos: &impl Fn(u32) -> P3,
) -> (P3, Vec<u32>, Vec<(u8, Vec<u32>)>) {
    let mut best: Option<(usize, P3, Vec<u32>, Vec<(u8, Vec<u32>)>)> = None;
    let n = ids.len();
    // The vertex mean, then with one vertex counted twice, then two.
    let extras = std::iter::once(vec![])
        .chain((0..n).map(|k| vec![ids[k]]))
        .chain((0..n).flat_map(|k| (k + 1..n).map(move |l| vec![ids[k], ids[l]])));
    for extra in extras {
        let mut recipe = ids.to_vec();
        recipe.extend(extra);
        let apex = mean(recipe.iter().map(|&v| pos(v)));
        let (pieces, flat) = pieces_from(ids, faces, apex, apex_id, pos);
        if best.as_ref().is_none_or(|b| flat < b.0) {
            best = Some((flat, apex, recipe, pieces));
        }
        if flat == 0 {
            break;
        }
    }
    let (_, apex, recipe, pieces) = best.expect("at least one candidate");
    (apex, recipe, pieces)
}
