//! Hexahedra whose corners coincide, in any [`Grid`] (VTK files, arrays
//! from Python): merged and typed exactly as the corner-point conversion
//! types its cells ([`super::shapes::shape_of`]), so a pinched cell read
//! from a `.vtu` or an `UnstructuredGrid` is the wedge, pyramid,
//! tetrahedron or polyhedron the GRDECL path makes of it.

use rayon::prelude::*;

use super::shapes::{Shape, VTK_ORDER_RIGHT, shape_of};
use crate::grid::{Cells, GHOST_HIDDEN_CELL, Grid, Property, Topology, vtk_type};

/// What [`collapse_hexahedra`] did, per class of hexahedron.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CollapseCounts {
    /// Hexahedra with coincident corners typed as wedges, pyramids or
    /// tetrahedra.
    pub typed: usize,
    /// Hexahedra with coincident corners written as polyhedra.
    pub polyhedra: usize,
    /// Hexahedra whose corners coincide so that fewer than four faces
    /// remain (no volume): hidden (`vtkGhostType`), as the corner-point
    /// conversion drops them.
    pub flat: usize,
    /// Hexahedra whose merged faces are not a closed, oriented surface
    /// (a face through a corner twice): kept as they are, and classed by
    /// the sweep structures.
    pub unmerged: usize,
}

/// The merge pattern of a VTK hexahedron with point ids `ids` (corner-point
/// numbering, see [`shape_of`]): corner `a` maps to the first corner `b < a`
/// with the same id or a position within `1e-9` of the cell's extent in
/// every coordinate (the tolerance the corner-point conversion merges
/// corners on different pillars with). `None` when all eight are distinct.
fn merge_pattern(points: &[[f64; 3]], ids: &[u32]) -> Option<[u8; 8]> {
    // Corner-point corner q is VTK vertex VTK_ORDER_RIGHT[q] (self-inverse).
    let id = |q: usize| ids[VTK_ORDER_RIGHT[q]];
    let p = |q: usize| points[id(q) as usize];
    let p0 = p(0);
    let mut ext = 0.0f64;
    for q in 1..8 {
        for a in 0..3 {
            ext = ext.max((p(q)[a] - p0[a]).abs());
        }
    }
    let tol = 1e-9 * ext;
    let mut rep = [0u8; 8];
    let mut merged = false;
    for a in 0..8 {
        rep[a] = a as u8;
        for b in 0..a {
            if rep[b] as usize != b {
                continue;
            }
            let (pa, pb) = (p(a), p(b));
            if id(a) == id(b) || (0..3).all(|d| (pa[d] - pb[d]).abs() <= tol) {
                rep[a] = b as u8;
                merged = true;
                break;
            }
        }
    }
    merged.then_some(rep)
}

/// Types every hexahedron of `grid` whose corners coincide (repeated point
/// ids, or points the file repeats at one position): the merged cell
/// becomes a wedge, pyramid, tetrahedron or outward polyhedron as
/// [`shape_of`] classifies it for corner-point cells, its merged corners
/// taking the id of the first. Fewer than four faces left: the cell is
/// hidden (no volume). A merge whose faces are not a closed oriented
/// surface leaves the hexahedron as it is. Cell ids, points and
/// properties are unchanged (a `vtkGhostType` array is added when a flat
/// cell needs one).
pub fn collapse_hexahedra(grid: &mut Grid) -> CollapseCounts {
    let mut counts = CollapseCounts::default();
    let Topology::Unstructured(cells) = &grid.topology else {
        return counts;
    };
    let points = &grid.points;
    let todo: Vec<(usize, [u8; 8])> = (0..cells.len())
        .into_par_iter()
        .filter_map(|c| {
            let ids = cells.cell(c);
            if cells.types[c] != vtk_type::HEXAHEDRON || ids.len() != 8 {
                return None;
            }
            merge_pattern(points, ids).map(|r| (c, r))
        })
        .collect();
    if todo.is_empty() {
        return counts;
    }
    let mut out = Cells::default();
    let mut flat = Vec::new();
    let mut next = todo.iter().peekable();
    for c in 0..cells.len() {
        let ids = cells.cell(c);
        let (merged, shape) = match next.peek() {
            Some((t, rep)) if *t == c => {
                next.next();
                (true, shape_of(rep, &VTK_ORDER_RIGHT))
            }
            _ => (false, None),
        };
        // Corner-point corner q's point id.
        let cp = |q: u8| ids[VTK_ORDER_RIGHT[q as usize]];
        match shape {
            Some(Shape::Typed(t, local)) => {
                counts.typed += 1;
                let v: Vec<u32> = local.iter().map(|&q| cp(q)).collect();
                out.push(t, &v);
            }
            Some(Shape::Poly(faces)) => {
                counts.polyhedra += 1;
                let f: Vec<Vec<u32>> = faces
                    .iter()
                    .map(|l| l.iter().map(|&q| cp(q)).collect())
                    .collect();
                out.push_polyhedron(&f);
            }
            Some(Shape::Flat) => {
                counts.flat += 1;
                flat.push(c);
                out.push(cells.types[c], ids);
            }
            None => {
                counts.unmerged += usize::from(merged);
                copy_cell(cells, c, &mut out);
            }
        }
    }
    grid.topology = Topology::Unstructured(out);
    if !flat.is_empty() {
        hide(&mut grid.cell_data, &flat, grid_cells(&grid.topology));
    }
    counts
}

/// Number of cells of an unstructured topology.
fn grid_cells(t: &Topology) -> usize {
    match t {
        Topology::Unstructured(c) => c.len(),
        Topology::Structured { .. } => 0,
    }
}

/// Appends cell `c` of `cells` to `out` unchanged.
fn copy_cell(cells: &Cells, c: usize, out: &mut Cells) {
    if cells.types[c] != vtk_type::POLYHEDRON {
        out.push(cells.types[c], cells.cell(c));
        return;
    }
    let s = cells.faces_of(c);
    let mut faces = Vec::new();
    let mut i = 1;
    for _ in 0..s.first().copied().unwrap_or(0) {
        let n = s[i] as usize;
        faces.push(s[i + 1..i + 1 + n].to_vec());
        i += 1 + n;
    }
    out.push_polyhedron(&faces);
}

/// Sets the hidden bit of `vtkGhostType` (component 0) for the cells
/// `hidden` of `n`, adding the array when there is none.
fn hide(cell_data: &mut Vec<Property>, hidden: &[usize], n: usize) {
    let i = match cell_data.iter().position(|p| p.name == "vtkGhostType") {
        Some(i) => i,
        None => {
            cell_data.push(Property::scalar("vtkGhostType", vec![0.0; n]));
            cell_data.len() - 1
        }
    };
    let g = &mut cell_data[i];
    let k = g.components.max(1);
    for &c in hidden {
        if let Some(v) = g.values.get_mut(c * k) {
            *v = f64::from(*v as u8 | GHOST_HIDDEN_CELL);
        }
    }
}
