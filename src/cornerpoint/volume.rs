//! Exact f64 cell volumes of any [`Grid`], equal to the corner-point
//! conversion's trilinear volumes: a hexahedron is the trilinear map of its
//! corners, a wedge, pyramid or tetrahedron the same map with corners
//! repeated (what the corner-point conversion makes of a pinched
//! hexahedron), and any other cell the volume enclosed by its faces, each
//! quadrilateral taken as the bilinear patch of its corners (the face of
//! the trilinear map) and larger faces fanned from their mean point. So a
//! grid's bulk volume is the same whether it was read as GRDECL, EGRID or
//! VTU, or built from arrays.

use rayon::prelude::*;

use super::trilinear_volume;
use crate::grid::{Grid, Topology, hex_corner_offsets, is_lower_dimensional, vtk_type};

/// Corner-point corner q (`ii + 2·jj + 4·kk`) of each typed cell, as VTK
/// vertex numbers: the cell as a trilinear hexahedron with repeated
/// corners (faces that lose two corners vanish, the others stay the cell's
/// own triangles and bilinear quadrilaterals).
fn as_hexahedron(vtk: u8) -> Option<[usize; 8]> {
    Some(match vtk {
        vtk_type::HEXAHEDRON => [0, 1, 3, 2, 4, 5, 7, 6],
        vtk_type::VOXEL => [0, 1, 2, 3, 4, 5, 6, 7],
        // Bottom (0, 1, 2), top (3, 4, 5) above it: edge 2–5 doubled.
        vtk_type::WEDGE => [0, 1, 2, 2, 3, 4, 5, 5],
        // Base (0, 1, 2, 3), apex 4.
        vtk_type::PYRAMID => [0, 1, 3, 2, 4, 4, 4, 4],
        vtk_type::TETRA => [0, 1, 2, 2, 3, 3, 3, 3],
        _ => return None,
    })
}

/// `a · (b × c)`.
#[inline]
fn det(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
        + a[2] * (b[0] * c[1] - b[1] * c[0])
}

#[inline]
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Three times the flux of `x` (relative to `o`) through the face loop
/// `f`: exact for triangles and bilinear quadrilaterals, larger loops
/// fanned from their mean point.
fn face_flux3(f: &[[f64; 3]], o: [f64; 3]) -> f64 {
    let tri = |a: [f64; 3], b: [f64; 3], c: [f64; 3]| {
        let a = sub(a, o);
        det(a, sub(b, o), sub(c, o)) / 2.0
    };
    match f.len() {
        0..=2 => 0.0,
        3 => tri(f[0], f[1], f[2]),
        4 => {
            // p(u, v) = a + b u + c v + d u v; ∫∫ p · (p_u × p_v) du dv.
            let a = sub(f[0], o);
            let b = sub(f[1], f[0]);
            let c = sub(f[3], f[0]);
            let d = [0, 1, 2].map(|k| f[0][k] - f[1][k] + f[2][k] - f[3][k]);
            det(a, b, c) + 0.5 * (det(a, b, d) + det(a, d, c)) - 0.25 * det(b, c, d)
        }
        n => {
            let mut m = [0.0; 3];
            for p in f {
                for k in 0..3 {
                    m[k] += p[k] / n as f64;
                }
            }
            (0..n).map(|i| tri(m, f[i], f[(i + 1) % n])).sum()
        }
    }
}

/// |Volume| enclosed by face loops (points `pts` of ids in the loops).
fn faces_volume<'a>(points: &[[f64; 3]], faces: impl Iterator<Item = &'a [u32]>) -> f64 {
    let mut o = None;
    let mut sum = 0.0;
    let mut loop_ = Vec::new();
    for f in faces {
        loop_.clear();
        loop_.extend(f.iter().map(|&v| points[v as usize]));
        let origin = *o.get_or_insert_with(|| loop_.first().copied().unwrap_or([0.0; 3]));
        sum += face_flux3(&loop_, origin);
    }
    (sum / 3.0).abs()
}

/// The faces of a VTK pentagonal or hexagonal prism with `n` vertices per
/// base, as consistently oriented loops of its local vertex numbers.
fn prism_faces(n: usize) -> Vec<Vec<u32>> {
    let n32 = n as u32;
    let mut f = vec![(0..n32).collect::<Vec<_>>(), (n32..2 * n32).rev().collect()];
    for i in 0..n32 {
        let j = (i + 1) % n32;
        f.push(vec![j, i, n32 + i, n32 + j]);
    }
    f
}

/// The exact |volume| of cell `c` of `grid` (0 for 0D–2D cells).
pub fn cell_volume(grid: &Grid, c: usize) -> f64 {
    let pts = &grid.points;
    match &grid.topology {
        Topology::Structured { dims } => {
            let (ni, nj) = (dims[0] - 1, dims[1] - 1);
            let (i, j, k) = (c % ni, c / ni % nj, c / (ni * nj));
            let first = i + dims[0] * (j + dims[1] * k);
            let off = hex_corner_offsets(dims[0], dims[0] * dims[1]);
            let order = [0, 1, 3, 2, 4, 5, 7, 6];
            trilinear_volume(&order.map(|l| pts[first + off[l]])).abs()
        }
        Topology::Unstructured(cells) => {
            let t = cells.types[c];
            let ids = cells.cell(c);
            if is_lower_dimensional(t) {
                return 0.0;
            }
            if let Some(order) = as_hexahedron(t) {
                return trilinear_volume(&order.map(|l| pts[ids[l] as usize])).abs();
            }
            if t == vtk_type::POLYHEDRON {
                let s = cells.faces_of(c);
                let mut i = 1;
                let faces = (0..s.first().copied().unwrap_or(0)).map(|_| {
                    let n = s[i] as usize;
                    i += 1 + n;
                    &s[i - n..i]
                });
                return faces_volume(pts, faces);
            }
            let local = prism_faces(ids.len() / 2);
            let global: Vec<Vec<u32>> = local
                .iter()
                .map(|f| f.iter().map(|&l| ids[l as usize]).collect())
                .collect();
            faces_volume(pts, global.iter().map(|f| f.as_slice()))
        }
    }
}

/// The bulk volume of `grid`: the sum of the exact volumes
/// ([`cell_volume`]) of its cells that are not hidden (`vtkGhostType`),
/// summed in cell order in fixed chunks (the same bits for any thread
/// count). For a corner-point grid it equals the conversion report's
/// bulk volume (the trilinear volumes of the kept cells).
pub fn bulk_volume(grid: &Grid) -> f64 {
    const CHUNK: usize = 4096;
    let hidden = grid.hidden_cells();
    let n = grid.cell_count();
    let parts: Vec<f64> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|b| {
            (b * CHUNK..((b + 1) * CHUNK).min(n))
                .filter(|&c| !hidden.as_ref().is_some_and(|h| h[c]))
                .map(|c| cell_volume(grid, c))
                .sum::<f64>()
        })
        .collect();
    parts.iter().sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Cells;

    /// A twisted hexahedron (non-planar faces) has the same volume as
    /// trilinear hexahedron, as a polyhedron of its six bilinear faces, and
    /// pinched (one edge doubled) as a wedge and as the hexahedron itself.
    #[test]
    fn faces_and_trilinear_volumes_agree() {
        let p: Vec<[f64; 3]> = vec![
            [0.0, 0.0, 0.0],
            [2.0, 0.1, 0.3],
            [2.2, 1.9, -0.2],
            [-0.1, 1.5, 0.1],
            [0.2, -0.1, 1.4],
            [1.8, 0.0, 1.1],
            [2.1, 2.0, 1.7],
            [0.1, 1.7, 1.2],
        ];
        let mut cells = Cells::default();
        cells.push(vtk_type::HEXAHEDRON, &[0, 1, 2, 3, 4, 5, 6, 7]);
        let faces: Vec<Vec<u32>> = [
            [0, 3, 2, 1],
            [4, 5, 6, 7],
            [0, 1, 5, 4],
            [1, 2, 6, 5],
            [2, 3, 7, 6],
            [3, 0, 4, 7],
        ]
        .iter()
        .map(|f| f.to_vec())
        .collect();
        cells.push_polyhedron(&faces);
        // Pinched: corners 3 = 2 and 7 = 6 (the edge 2–6 doubled).
        cells.push(vtk_type::HEXAHEDRON, &[0, 1, 2, 2, 4, 5, 6, 6]);
        cells.push(vtk_type::WEDGE, &[0, 1, 2, 4, 5, 6]);
        let g = Grid {
            points: p,
            topology: Topology::Unstructured(cells),
            point_data: vec![],
            cell_data: vec![],
        };
        let v: Vec<f64> = (0..4).map(|c| cell_volume(&g, c)).collect();
        assert!((v[0] - v[1]).abs() < 1e-13 * v[0], "{v:?}");
        assert!((v[2] - v[3]).abs() < 1e-13 * v[2], "{v:?}");
        assert!(v[2] < v[0] && v[2] > 0.3 * v[0], "{v:?}");
    }
}
