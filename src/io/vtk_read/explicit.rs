//! Grids from an explicit structured grid's arrays (PyVista's
//! `ExplicitStructuredGrid` cast to an unstructured grid): one hexahedron
//! per IJK cell, I fastest, each owning its corners. The corners are
//! welded and renumbered pillar by pillar, as the corner-point reader
//! numbers them, and the IJK layout comes along, so that `auto` builds the
//! corner-point graph as on GRDECL input.

use super::VtkReadError;
use super::arrays::{Parts, UnstructuredArrays};
use crate::grid::IjkLayout;
use crate::grid::{Grid, Property, vtk_type};

/// The (di, dj, dk) offset of each VTK hexahedron corner in its cell.
const HEX_CORNER: [[usize; 3]; 8] = [
    [0, 0, 0],
    [1, 0, 0],
    [1, 1, 0],
    [0, 1, 0],
    [0, 0, 1],
    [1, 0, 1],
    [1, 1, 1],
    [0, 1, 1],
];

/// Builds the grid of an explicit structured grid of `dims` cells (I, J,
/// K) from its unstructured arrays: every cell a hexahedron, cell `c` at
/// IJK index `c`. Coincident corners are merged (hexahedra whose corners
/// then repeat become wedges, pyramids, tetrahedra or polyhedra, or hidden
/// cells, as in [`super::grid_from_arrays`]); cells hidden by
/// `vtkGhostType` stay hidden. Returns the grid and its IJK layout.
pub fn grid_from_explicit_structured(
    a: UnstructuredArrays<'_>,
    dims: [usize; 3],
    point_data: Vec<Property>,
    cell_data: Vec<Property>,
    what: &str,
) -> Result<(Grid, IjkLayout), VtkReadError> {
    let n = dims.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d));
    if n != Some(a.celltypes.len()) || a.celltypes.len() >= u32::MAX as usize {
        return Err(VtkReadError::Unsupported {
            file: what.to_string(),
            what: format!(
                "explicit structured dims {dims:?} (cells) do not match the {} cells given",
                a.celltypes.len()
            ),
        });
    }
    let n = a.celltypes.len();
    if let Some(c) = a
        .celltypes
        .iter()
        .position(|&t| t != i64::from(vtk_type::HEXAHEDRON))
    {
        return Err(VtkReadError::Cell {
            file: what.to_string(),
            cell: c,
            msg: format!(
                "VTK cell type {}: an explicit structured grid's cells are hexahedra ({})",
                a.celltypes[c],
                vtk_type::HEXAHEDRON
            ),
        });
    }
    let mut parts = Parts::new(a, point_data, cell_data, what)?;
    if let Some(c) = (0..n).find(|&c| parts.offsets[c + 1] - parts.offsets[c] != 8) {
        return Err(VtkReadError::Cell {
            file: what.to_string(),
            cell: c,
            msg: format!(
                "a hexahedron with {} point ids (expected 8)",
                parts.offsets[c + 1] - parts.offsets[c]
            ),
        });
    }
    parts.weld();
    renumber_by_pillar(&mut parts, dims);
    orient_right_handed(&mut parts);
    // Pinched hexahedra are typed when the grid is finished.
    let grid = parts.into_grid(what)?;
    let layout = IjkLayout {
        dims,
        source_cell: (0..n as u32).collect(),
    };
    Ok((grid, layout))
}

/// VTK hexahedron faces, outward for a positive hexahedron.
const HEX_FACES: [[usize; 4]; 6] = [
    [0, 3, 2, 1],
    [4, 5, 6, 7],
    [0, 1, 5, 4],
    [1, 2, 6, 5],
    [2, 3, 7, 6],
    [3, 0, 4, 7],
];

/// Six times the signed volume of a hexahedron's triangulated surface
/// (positive for VTK's orientation).
fn hex_volume6(p: &[[f64; 3]], ids: &[i64]) -> f64 {
    let at = |l: usize| p[ids[l] as usize];
    let det = |a: [f64; 3], b: [f64; 3], c: [f64; 3]| {
        a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0])
    };
    HEX_FACES
        .iter()
        .map(|f| det(at(f[0]), at(f[1]), at(f[2])) + det(at(f[0]), at(f[2]), at(f[3])))
        .sum()
}

/// An explicit structured grid whose K runs against its I × J (depth
/// down, as corner-point grids usually are) holds inside-out hexahedra:
/// when the cells' total signed volume is negative, every cell's bottom
/// and top corners swap (as the corner-point reader orders a left-handed
/// grid's corners).
fn orient_right_handed(parts: &mut Parts) {
    let total: f64 = parts
        .conn
        .chunks_exact(8)
        .map(|ids| hex_volume6(&parts.points, ids))
        .sum();
    if total < 0.0 {
        for ids in parts.conn.chunks_exact_mut(8) {
            let (bottom, top) = ids.split_at_mut(4);
            bottom.swap_with_slice(top);
        }
    }
}

/// Renumbers the points pillar by pillar (pillar `(i, j)` of the first cell
/// corner that uses a point), then by depth layer along the pillar, so that
/// a hexahedron's ids tell its pillar corners as in a corner-point grid's
/// zoo grid. Unused points go last. Point data follows the points.
fn renumber_by_pillar(parts: &mut Parts, dims: [usize; 3]) {
    let [nx, ny, _] = dims;
    let np = parts.points.len();
    let mut key = vec![(u64::MAX, u64::MAX); np];
    for (c, ids) in parts.conn.chunks_exact(8).enumerate() {
        let (i, j, k) = (c % nx, c / nx % ny, c / (nx * ny));
        for (&v, d) in ids.iter().zip(HEX_CORNER) {
            let p = v as usize;
            if key[p].0 == u64::MAX {
                let pillar = (i + d[0]) + (nx + 1) * (j + d[1]);
                key[p] = (pillar as u64, (k + d[2]) as u64);
            }
        }
    }
    let mut order: Vec<u32> = (0..np as u32).collect();
    order.sort_unstable_by_key(|&p| (key[p as usize], p));
    let mut new_id = vec![0u32; np];
    for (new, &old) in order.iter().enumerate() {
        new_id[old as usize] = new as u32;
    }
    parts.points = order.iter().map(|&o| parts.points[o as usize]).collect();
    for prop in &mut parts.point_data {
        let k = prop.components;
        if prop.values.len() != np * k {
            continue; // refused by the grid's checks, with its name
        }
        let mut values = Vec::with_capacity(np * k);
        for &o in &order {
            let o = o as usize;
            values.extend_from_slice(&prop.values[o * k..(o + 1) * k]);
        }
        prop.values = values;
    }
    for v in &mut parts.conn {
        *v = i64::from(new_id[*v as usize]);
    }
}
