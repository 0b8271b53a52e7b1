//! Grids from in-memory arrays in VTK's layout (what PyVista holds): an
//! unstructured grid's padded cell array (`n, id0, …, n, …`, a polyhedron's
//! entry being its legacy face stream `nf, n0, ids…, n1, ids…`) with one
//! VTK type per cell, or a structured grid's point dims. Checked as the
//! file readers check (ids in range, counts, finite points); errors name
//! `what` (e.g. `from_arrays`) in place of a file.

use std::collections::HashMap;

use super::VtkReadError;
use super::common::{PolyFaces, build_cells, finish};
use crate::grid::{Grid, Property, Topology, vtk_type};
use crate::mem::try_vec;

/// An unstructured grid in VTK's arrays.
#[derive(Clone, Copy, Debug)]
pub struct UnstructuredArrays<'a> {
    /// Points, `x y z` each.
    pub points: &'a [[f64; 3]],
    /// Padded cells: per cell its count, then its ids (or face stream).
    pub cells: &'a [i64],
    /// VTK type per cell.
    pub celltypes: &'a [i64],
}

/// Builds an unstructured grid from VTK's arrays with its properties. With
/// `merge_points`, exactly coincident points become one (grids whose cells
/// each own their corners, as an explicit structured grid's; point data
/// keeps the first merged point's values). With or without it, a
/// hexahedron whose corners coincide (repeated ids, or points repeated at
/// one position) is typed as the corner-point conversion types a pinched
/// cell: a wedge, pyramid, tetrahedron or polyhedron, or hidden
/// (`vtkGhostType`) when no volume is left
/// ([`crate::cornerpoint::collapse_hexahedra`]).
pub fn grid_from_arrays(
    a: UnstructuredArrays<'_>,
    point_data: Vec<Property>,
    cell_data: Vec<Property>,
    merge_points: bool,
    what: &str,
) -> Result<Grid, VtkReadError> {
    let mut parts = Parts::new(a, point_data, cell_data, what)?;
    if merge_points {
        parts.weld();
    }
    parts.into_grid(what)
}

/// An unstructured grid's arrays being assembled: VTK's padded cell array
/// turned into offsets and a compact connectivity.
pub(super) struct Parts {
    /// Points.
    pub points: Vec<[f64; 3]>,
    /// VTK type per cell.
    pub types: Vec<i64>,
    /// Per cell, where its ids start in `conn` (one more entry at the end).
    pub offsets: Vec<usize>,
    /// Point ids (or polyhedron face streams), cell after cell.
    pub conn: Vec<i64>,
    /// Point properties.
    pub point_data: Vec<Property>,
    /// Cell properties.
    pub cell_data: Vec<Property>,
}

impl Parts {
    /// Unpads the cell array and checks its counts and point ids.
    pub(super) fn new(
        a: UnstructuredArrays<'_>,
        point_data: Vec<Property>,
        cell_data: Vec<Property>,
        what: &str,
    ) -> Result<Self, VtkReadError> {
        let n = a.celltypes.len();
        let bad = |cell: usize, msg: String| VtkReadError::Cell {
            file: what.to_string(),
            cell,
            msg,
        };
        let memory = |source| VtkReadError::Memory {
            file: what.to_string(),
            source,
        };
        let mut offsets: Vec<usize> = try_vec(n + 1, "the cell offsets").map_err(memory)?;
        let mut conn: Vec<i64> =
            try_vec(a.cells.len().saturating_sub(n), "the cell connectivity").map_err(memory)?;
        offsets.push(0usize);
        let mut pos = 0usize;
        for c in 0..n {
            let Some(&k) = a.cells.get(pos) else {
                return Err(bad(
                    c,
                    format!("the cell array ends before cell {c} of {n}"),
                ));
            };
            let k = usize::try_from(k).map_err(|_| bad(c, format!("negative point count {k}")))?;
            let ids = a.cells.get(pos + 1..pos + 1 + k).ok_or_else(|| {
                bad(
                    c,
                    format!("point count {k} runs past the end of the cell array"),
                )
            })?;
            conn.extend_from_slice(ids);
            offsets.push(conn.len());
            pos += 1 + k;
        }
        if pos != a.cells.len() {
            return Err(VtkReadError::Cell {
                file: what.to_string(),
                cell: n,
                msg: format!(
                    "{} values left in the cell array after {n} cells (celltypes has {n} entries)",
                    a.cells.len() - pos
                ),
            });
        }
        let np = a.points.len() as i64;
        if let Some(c) = (0..n).find(|&c| {
            a.celltypes[c] != i64::from(vtk_type::POLYHEDRON)
                && conn[offsets[c]..offsets[c + 1]]
                    .iter()
                    .any(|&v| v < 0 || v >= np)
        }) {
            let v = conn[offsets[c]..offsets[c + 1]]
                .iter()
                .find(|&&v| v < 0 || v >= np)
                .copied()
                .unwrap_or(0);
            return Err(bad(
                c,
                format!("point id {v} is out of range ({np} points)"),
            ));
        }
        let mut points = try_vec(a.points.len(), "the points").map_err(memory)?;
        points.extend_from_slice(a.points);
        let mut types = try_vec(n, "the cell types").map_err(memory)?;
        types.extend_from_slice(a.celltypes);
        Ok(Parts {
            points,
            types,
            offsets,
            conn,
            point_data,
            cell_data,
        })
    }

    /// Merges exactly coincident points (point data: the first one's values).
    pub(super) fn weld(&mut self) {
        let (p, remap) = weld(&self.points);
        let old = std::mem::replace(&mut self.points, p);
        for v in self.conn.iter_mut() {
            if let Ok(i) = usize::try_from(*v)
                && i < remap.len()
            {
                *v = i64::from(remap[i]);
            }
        }
        let mut first = vec![u32::MAX; self.points.len()];
        for (i, &r) in remap.iter().enumerate().rev() {
            first[r as usize] = i as u32;
        }
        for prop in &mut self.point_data {
            let k = prop.components;
            if prop.values.len() != old.len() * k {
                continue; // refused by the grid's checks, with its name
            }
            let mut values = Vec::with_capacity(first.len() * k);
            for &i in &first {
                let i = i as usize;
                values.extend_from_slice(&prop.values[i * k..(i + 1) * k]);
            }
            prop.values = values;
        }
    }

    /// The checked grid.
    pub(super) fn into_grid(self, what: &str) -> Result<Grid, VtkReadError> {
        let cells = build_cells(
            &self.types,
            &self.offsets,
            &self.conn,
            PolyFaces::<i64>::InConnectivity,
            what,
        )?;
        finish(
            Grid {
                points: self.points,
                topology: Topology::Unstructured(cells),
                point_data: self.point_data,
                cell_data: self.cell_data,
            },
            what,
        )
    }
}

/// Builds a structured (curvilinear) grid from its point dims and points
/// (I fastest, then J, then K).
pub fn grid_from_structured(
    dims: [usize; 3],
    points: Vec<[f64; 3]>,
    point_data: Vec<Property>,
    cell_data: Vec<Property>,
    what: &str,
) -> Result<Grid, VtkReadError> {
    finish(
        Grid {
            points,
            topology: Topology::Structured { dims },
            point_data,
            cell_data,
        },
        what,
    )
}

/// Exactly coincident points merged, in first-use order: the new points
/// and the new id of every old point.
fn weld(points: &[[f64; 3]]) -> (Vec<[f64; 3]>, Vec<u32>) {
    let key = |p: &[f64; 3]| p.map(|c| if c == 0.0 { 0 } else { c.to_bits() });
    let mut seen: HashMap<[u64; 3], u32> = HashMap::with_capacity(points.len() / 4);
    let mut out = Vec::new();
    let remap = points
        .iter()
        .map(|p| {
            *seen.entry(key(p)).or_insert_with(|| {
                out.push(*p);
                (out.len() - 1) as u32
            })
        })
        .collect();
    (out, remap)
}

#[cfg(test)]
mod tests {
    use super::*;

    const CUBE: [[f64; 3]; 8] = [
        [0., 0., 0.],
        [1., 0., 0.],
        [1., 1., 0.],
        [0., 1., 0.],
        [0., 0., 1.],
        [1., 0., 1.],
        [1., 1., 1.],
        [0., 1., 1.],
    ];

    /// A hexahedron whose cells own their corners: welded, a cube stays a
    /// hexahedron; one whose top edge collapses becomes a wedge (as the
    /// corner-point conversion types it); a flat one is hidden. Without
    /// welding, the coincident corners are merged per cell alike. Bad
    /// arrays name the cell.
    #[test]
    fn padded_cells_merge_and_collapse() {
        // Cell 0: the cube; cell 1: a wedge as a hexahedron with corners 6,7
        // equal to 5,4 (top face collapsed to an edge); cell 2: flat.
        let mut pts: Vec<[f64; 3]> = CUBE.to_vec();
        let wedge = [
            [2., 0., 0.],
            [3., 0., 0.],
            [3., 1., 0.],
            [2., 1., 0.],
            [2., 0., 1.],
            [3., 0., 1.],
            [3., 0., 1.],
            [2., 0., 1.],
        ];
        pts.extend(wedge);
        let flat = [[5., 0., 0.], [6., 0., 0.], [6., 1., 0.], [5., 1., 0.]];
        pts.extend(flat);
        pts.extend(flat);
        let mut cells = Vec::new();
        for c in 0..3i64 {
            cells.push(8);
            cells.extend((0..8).map(|k| 8 * c + k));
        }
        let types = [12i64; 3];
        let a = UnstructuredArrays {
            points: &pts,
            cells: &cells,
            celltypes: &types,
        };
        let g = grid_from_arrays(a, vec![], vec![], true, "t").unwrap();
        // 8 + 6 + 4 distinct points.
        assert_eq!(g.points.len(), 18);
        let Topology::Unstructured(c) = &g.topology else {
            panic!("unstructured expected")
        };
        assert_eq!(c.types, vec![12, 13, 12]);
        assert_eq!(g.hidden_cells().unwrap(), vec![false, false, true]);
        let welded = g;
        // Without welding, the same cells (the points stay 24).
        let g = grid_from_arrays(a, vec![], vec![], false, "t").unwrap();
        assert_eq!(g.points.len(), 24);
        let Topology::Unstructured(c) = &g.topology else {
            panic!("unstructured expected")
        };
        assert_eq!(c.types, vec![12, 13, 12]);
        assert_eq!(g.hidden_cells().unwrap(), vec![false, false, true]);
        let pos = |g: &Grid, c: usize| -> Vec<[f64; 3]> {
            let Topology::Unstructured(cells) = &g.topology else {
                unreachable!()
            };
            cells
                .cell(c)
                .iter()
                .map(|&v| g.points[v as usize])
                .collect()
        };
        assert_eq!(pos(&g, 1), pos(&welded, 1));
        // Errors name the cell.
        let short = UnstructuredArrays {
            points: &pts,
            cells: &cells[..20],
            celltypes: &types,
        };
        let e = grid_from_arrays(short, vec![], vec![], false, "t").unwrap_err();
        assert!(e.to_string().contains("runs past the end"), "{e}");
        let mut bad = cells.clone();
        bad[3] = 99;
        let a = UnstructuredArrays {
            points: &pts,
            cells: &bad,
            celltypes: &types,
        };
        let e = grid_from_arrays(a, vec![], vec![], false, "t").unwrap_err();
        assert!(e.to_string().contains("point id 99 is out of range"), "{e}");
    }
}
