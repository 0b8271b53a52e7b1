//! The grid model: world positions (f64), cells (structured IJK or an
//! unstructured zoo of typed / explicitly faced cells) and named properties.
//!
//! This module does no I/O: readers in [`crate::io`] fill a [`Grid`], and the
//! sweep structures ([`crate::structures::cgraph`], [`crate::structures::scgraph`]) are built from it.

use thiserror::Error;

/// VTK cell type ids understood by stratasweep.
pub mod vtk_type {
    /// Tetrahedron.
    pub const TETRA: u8 = 10;
    /// Voxel (axis-aligned hexahedron with VTK's voxel vertex order).
    pub const VOXEL: u8 = 11;
    /// Hexahedron.
    pub const HEXAHEDRON: u8 = 12;
    /// Wedge (triangular prism).
    pub const WEDGE: u8 = 13;
    /// Pyramid.
    pub const PYRAMID: u8 = 14;
    /// Pentagonal prism.
    pub const PENTAGONAL_PRISM: u8 = 15;
    /// Hexagonal prism.
    pub const HEXAGONAL_PRISM: u8 = 16;
    /// Polyhedron given by explicit faces.
    pub const POLYHEDRON: u8 = 42;
}

/// The bit of VTK's `vtkGhostType` cell array that marks a hidden cell.
pub const GHOST_HIDDEN_CELL: u8 = 32;

/// A named scalar (or multi-component) property, per vertex or per cell.
#[derive(Clone, Debug, PartialEq)]
pub struct Property {
    /// Name as found in the input (e.g. `PORO`, `f`).
    pub name: String,
    /// Number of components per tuple (1 for scalars).
    pub components: usize,
    /// Tuples stored contiguously, `components` values each.
    pub values: Vec<f64>,
}

impl Property {
    /// A scalar property.
    pub fn scalar(name: impl Into<String>, values: Vec<f64>) -> Self {
        Property {
            name: name.into(),
            components: 1,
            values,
        }
    }
    /// Number of tuples.
    pub fn len(&self) -> usize {
        self.values.len() / self.components.max(1)
    }
    /// True when there are no tuples.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }
    /// Scalar value of tuple `i`: the component itself, or the Euclidean
    /// magnitude for multi-component properties.
    pub fn scalar_at(&self, i: usize) -> f64 {
        if self.components == 1 {
            self.values[i]
        } else {
            let t = &self.values[i * self.components..(i + 1) * self.components];
            t.iter().map(|v| v * v).sum::<f64>().sqrt()
        }
    }
}

/// Unstructured cells in VTK's flat layout.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cells {
    /// VTK cell type id per cell (see [`vtk_type`]).
    pub types: Vec<u8>,
    /// `offsets[c]..offsets[c+1]` indexes `connectivity` for cell `c` (len = cells + 1).
    pub offsets: Vec<u32>,
    /// Global point ids of every cell, concatenated.
    pub connectivity: Vec<u32>,
    /// Per cell, `face_offsets[c]..face_offsets[c+1]` indexes `face_stream`
    /// (empty range for cells that are not polyhedra). Empty vector when the
    /// grid has no polyhedra.
    pub face_offsets: Vec<u32>,
    /// VTK legacy face stream per polyhedron: `nf, n0, ids.., n1, ids.., ...`
    /// with global point ids.
    pub face_stream: Vec<u32>,
}

impl Cells {
    /// Number of cells.
    pub fn len(&self) -> usize {
        self.types.len()
    }
    /// True when there are no cells.
    pub fn is_empty(&self) -> bool {
        self.types.is_empty()
    }
    /// Point ids of cell `c`.
    pub fn cell(&self, c: usize) -> &[u32] {
        &self.connectivity[self.offsets[c] as usize..self.offsets[c + 1] as usize]
    }
    /// Face stream of polyhedron `c` (empty for typed cells).
    pub fn faces_of(&self, c: usize) -> &[u32] {
        if self.face_offsets.is_empty() {
            return &[];
        }
        &self.face_stream[self.face_offsets[c] as usize..self.face_offsets[c + 1] as usize]
    }
    /// Append a typed (non-polyhedral) cell.
    pub fn push(&mut self, vtk_type: u8, ids: &[u32]) {
        if self.offsets.is_empty() {
            self.offsets.push(0);
        }
        self.types.push(vtk_type);
        self.connectivity.extend_from_slice(ids);
        self.offsets.push(self.connectivity.len() as u32);
        if !self.face_offsets.is_empty() {
            self.face_offsets.push(self.face_stream.len() as u32);
        }
    }
    /// Append a polyhedron given by its faces (each an ordered loop of global ids).
    pub fn push_polyhedron(&mut self, faces: &[Vec<u32>]) {
        if self.offsets.is_empty() {
            self.offsets.push(0);
        }
        if self.face_offsets.is_empty() {
            self.face_offsets = vec![0; self.types.len() + 1];
        }
        let mut ids: Vec<u32> = faces.iter().flatten().copied().collect();
        ids.sort_unstable();
        ids.dedup();
        self.types.push(vtk_type::POLYHEDRON);
        self.connectivity.extend_from_slice(&ids);
        self.offsets.push(self.connectivity.len() as u32);
        self.face_stream.push(faces.len() as u32);
        for f in faces {
            self.face_stream.push(f.len() as u32);
            self.face_stream.extend_from_slice(f);
        }
        self.face_offsets.push(self.face_stream.len() as u32);
    }
}

/// How the cells of a grid are given.
#[derive(Clone, Debug, PartialEq)]
pub enum Topology {
    /// Curvilinear IJK hexahedra; `dims` are the point counts along I, J, K
    /// and points are stored I fastest, then J, then K.
    Structured {
        /// Point counts along I, J, K.
        dims: [usize; 3],
    },
    /// An unstructured (zoo or polyhedral) grid.
    Unstructured(Cells),
}

/// Where the cells of an unstructured grid sit in an IJK box (a corner-point
/// grid's, whose dead cells it drops): what
/// [`crate::cornerpoint::CornerPointGrid::into_grid`] and the readers report
/// beside the [`Grid`], and what the CP-Graph
/// ([`crate::structures::cpgraph`]) is built on.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IjkLayout {
    /// Cells along I, J, K.
    pub dims: [usize; 3],
    /// Per grid cell, its IJK index `i + nx·(j + ny·k)` (increasing).
    pub source_cell: Vec<u32>,
}

/// A grid: geometry, topology and properties.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// World positions, read as f64.
    pub points: Vec<[f64; 3]>,
    /// Cells.
    pub topology: Topology,
    /// Per-vertex properties.
    pub point_data: Vec<Property>,
    /// Per-cell properties.
    pub cell_data: Vec<Property>,
}

/// Errors found while validating a grid.
#[derive(Debug, Error, PartialEq)]
pub enum GridError {
    /// The grid has no points or no cells.
    #[error("empty grid: {points} points, {cells} cells")]
    Empty {
        /// Point count.
        points: usize,
        /// Cell count.
        cells: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("point {point} has a non-finite coordinate {coord:?}")]
    NonFinitePoint {
        /// Point index.
        point: usize,
        /// The offending coordinates.
        coord: [f64; 3],
    },
    /// A cell references a point that does not exist.
    #[error("cell {cell} references point {point}, but the grid has {points} points")]
    MissingVertex {
        /// Cell index.
        cell: usize,
        /// Referenced point id.
        point: u64,
        /// Point count.
        points: usize,
    },
    /// A cell type that stratasweep does not know.
    #[error("cell {cell} has unsupported VTK cell type {vtk_type}")]
    UnknownCellType {
        /// Cell index.
        cell: usize,
        /// VTK type id.
        vtk_type: u8,
    },
    /// A typed cell with the wrong number of vertices.
    #[error("cell {cell} of VTK type {vtk_type} has {found} vertices, expected {expected}")]
    WrongVertexCount {
        /// Cell index.
        cell: usize,
        /// VTK type id.
        vtk_type: u8,
        /// Expected count.
        expected: usize,
        /// Found count.
        found: usize,
    },
    /// A structured grid whose dims do not match the point count.
    #[error("structured dims {dims:?} need {expected} points, found {found}")]
    DimsMismatch {
        /// Point dims.
        dims: [usize; 3],
        /// Expected point count.
        expected: usize,
        /// Found point count.
        found: usize,
    },
    /// A property with the wrong number of tuples.
    #[error("{kind} property '{name}' has {found} tuples, expected {expected}")]
    PropertyLength {
        /// "point" or "cell".
        kind: &'static str,
        /// Property name.
        name: String,
        /// Expected tuples.
        expected: usize,
        /// Found tuples.
        found: usize,
    },
    /// A property value is NaN or infinite.
    #[error("{kind} property '{name}' has a non-finite value at {index}")]
    NonFiniteProperty {
        /// "point" or "cell".
        kind: &'static str,
        /// Property name.
        name: String,
        /// Tuple index.
        index: usize,
    },
    /// A polyhedron whose face stream is malformed.
    #[error("polyhedron cell {cell}: {why}")]
    BadPolyhedron {
        /// Cell index.
        cell: usize,
        /// What is wrong.
        why: String,
    },
    /// A `vtkGhostType` cell array with more than one component: VTK's
    /// ghost flags are one value per cell, and reading a multi-component
    /// array flat would hide the wrong cells.
    #[error(
        "cell array 'vtkGhostType' has {components} components; VTK's ghost array has one value per cell (bit 32 = hidden), so the hidden cells cannot be told"
    )]
    GhostComponents {
        /// Its component count.
        components: usize,
    },
    /// Too many points or cells for u32 ids.
    #[error("grid too large: {what} = {count} exceeds u32 ids")]
    TooLarge {
        /// What overflowed.
        what: &'static str,
        /// The count.
        count: usize,
    },
}

/// Number of points of a VTK typed cell, or `None` for variable types.
pub fn vertex_count_of(vtk_type: u8) -> Option<usize> {
    use vtk_type::*;
    Some(match vtk_type {
        TETRA => 4,
        VOXEL | HEXAHEDRON => 8,
        WEDGE => 6,
        PYRAMID => 5,
        PENTAGONAL_PRISM => 10,
        HEXAGONAL_PRISM => 12,
        _ => return None,
    })
}

/// Offsets from its first vertex of the eight corners of a lattice
/// hexahedron (VTK order) in an IJK point grid with `npi` points per row and
/// `slab` per layer.
pub fn hex_corner_offsets(npi: usize, slab: usize) -> [usize; 8] {
    [
        0,
        1,
        1 + npi,
        npi,
        slab,
        slab + 1,
        slab + 1 + npi,
        slab + npi,
    ]
}

/// True for VTK's linear 0D/1D/2D cell types (vertex, poly-vertex, line,
/// poly-line, triangle, triangle strip, polygon, pixel, quad). They have no
/// volume: grids may carry them (boundary patches), and the sweep skips them.
pub fn is_lower_dimensional(vtk_type: u8) -> bool {
    (1..=9).contains(&vtk_type)
}

impl Grid {
    /// Number of cells.
    pub fn cell_count(&self) -> usize {
        match &self.topology {
            Topology::Structured { dims } => {
                dims[0].saturating_sub(1) * dims[1].saturating_sub(1) * dims[2].saturating_sub(1)
            }
            Topology::Unstructured(c) => c.len(),
        }
    }

    /// Axis-aligned bounding box `(min, max)` of the points.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        bounds_of(&self.points)
    }

    /// The f64 origin the sweep structures rebase positions to: the bounding-box centre.
    pub fn origin(&self) -> [f64; 3] {
        origin_of(&self.points)
    }

    /// Positions as f32 relative to [`Grid::origin`], allocated fallibly.
    pub fn rebased_positions(&self) -> Result<Vec<[f32; 3]>, crate::mem::AllocError> {
        rebased(&self.points, self.origin())
    }

    /// Looks up a point property by name: the property of that exact
    /// name, else the only one whose name differs in case alone (Eclipse
    /// keywords are upper case; `poro` finds `PORO`).
    pub fn point_property(&self, name: &str) -> Option<&Property> {
        find_property(&self.point_data, name)
    }

    /// Looks up a cell property by name (as [`Grid::point_property`]).
    pub fn cell_property(&self, name: &str) -> Option<&Property> {
        find_property(&self.cell_data, name)
    }

    /// Per-cell hidden flags from VTK's `vtkGhostType` (bit 32), if present.
    /// The array has one component per cell ([`Grid::validate`] refuses
    /// others); should an unvalidated grid hold more, component 0 is read.
    pub fn hidden_cells(&self) -> Option<Vec<bool>> {
        let g = self.cell_property("vtkGhostType")?;
        let k = g.components.max(1);
        Some(
            (0..g.len())
                .map(|i| (g.values[i * k] as u64 as u8) & GHOST_HIDDEN_CELL != 0)
                .collect(),
        )
    }

    /// Checks counts, ids, finiteness and cell types. Never panics.
    pub fn validate(&self) -> Result<(), GridError> {
        let np = self.points.len();
        let nc = self.cell_count();
        if np == 0 || nc == 0 {
            return Err(GridError::Empty {
                points: np,
                cells: nc,
            });
        }
        if np >= u32::MAX as usize {
            return Err(GridError::TooLarge {
                what: "points",
                count: np,
            });
        }
        if nc >= u32::MAX as usize {
            return Err(GridError::TooLarge {
                what: "cells",
                count: nc,
            });
        }
        if let Some((i, p)) = self
            .points
            .iter()
            .enumerate()
            .find(|(_, p)| !p.iter().all(|v| v.is_finite()))
        {
            return Err(GridError::NonFinitePoint {
                point: i,
                coord: *p,
            });
        }
        match &self.topology {
            Topology::Structured { dims } => {
                let expected = dims[0] * dims[1] * dims[2];
                if expected != np {
                    return Err(GridError::DimsMismatch {
                        dims: *dims,
                        expected,
                        found: np,
                    });
                }
            }
            Topology::Unstructured(cells) => validate_cells(cells, np)?,
        }
        for (kind, props, n) in [
            ("point", &self.point_data, np),
            ("cell", &self.cell_data, nc),
        ] {
            for p in props {
                if p.len() != n || p.values.len() % p.components.max(1) != 0 {
                    return Err(GridError::PropertyLength {
                        kind,
                        name: p.name.clone(),
                        expected: n,
                        found: p.len(),
                    });
                }
                if kind == "cell" && p.name == "vtkGhostType" && p.components > 1 {
                    return Err(GridError::GhostComponents {
                        components: p.components,
                    });
                }
                if let Some(i) = p.values.iter().position(|v| !v.is_finite()) {
                    return Err(GridError::NonFiniteProperty {
                        kind,
                        name: p.name.clone(),
                        index: i / p.components.max(1),
                    });
                }
            }
        }
        Ok(())
    }
}

fn validate_cells(cells: &Cells, np: usize) -> Result<(), GridError> {
    let nc = cells.len();
    if cells.offsets.len() != nc + 1 || cells.offsets[nc] as usize != cells.connectivity.len() {
        return Err(GridError::BadPolyhedron {
            cell: 0,
            why: "inconsistent cell offsets".into(),
        });
    }
    // One pass over each id array: when its largest value names a point,
    // every id does and the per-cell searches are skipped (the face-stream
    // counts are included, so this can only send a valid grid the slow way).
    let np32 = np as u32; // np < u32::MAX was checked by the caller
    let below_np = |v: &[u32]| {
        // Eight independent lanes so that the loop vectorises.
        let mut lanes = [0u32; 8];
        let mut chunks = v.chunks_exact(8);
        for ch in &mut chunks {
            for k in 0..8 {
                lanes[k] |= (ch[k] >= np32) as u32;
            }
        }
        lanes.iter().all(|&l| l == 0) && chunks.remainder().iter().all(|&x| x < np32)
    };
    let ids_ok = below_np(&cells.connectivity);
    let faces_ok = below_np(&cells.face_stream);
    for c in 0..nc {
        let t = cells.types[c];
        let (a, b) = (cells.offsets[c] as usize, cells.offsets[c + 1] as usize);
        if a > b {
            return Err(GridError::BadPolyhedron {
                cell: c,
                why: "decreasing cell offsets".into(),
            });
        }
        let ids = &cells.connectivity[a..b];
        let bad = if ids_ok {
            None
        } else {
            ids.iter().find(|&&v| v as usize >= np)
        };
        if let Some(&bad) = bad {
            return Err(GridError::MissingVertex {
                cell: c,
                point: bad as u64,
                points: np,
            });
        }
        if t == vtk_type::POLYHEDRON {
            validate_face_stream(c, cells.faces_of(c), np, !faces_ok)?;
        } else if let Some(n) = vertex_count_of(t) {
            if ids.len() != n {
                return Err(GridError::WrongVertexCount {
                    cell: c,
                    vtk_type: t,
                    expected: n,
                    found: ids.len(),
                });
            }
        } else if !is_lower_dimensional(t) {
            return Err(GridError::UnknownCellType {
                cell: c,
                vtk_type: t,
            });
        }
    }
    Ok(())
}

/// Checks the face stream of polyhedron `cell`; point ids are checked
/// against `np` only when `check_ids`.
fn validate_face_stream(
    cell: usize,
    s: &[u32],
    np: usize,
    check_ids: bool,
) -> Result<(), GridError> {
    let bad = |why: String| GridError::BadPolyhedron { cell, why };
    let Some((&nf, mut rest)) = s.split_first() else {
        return Err(bad("no face stream".into()));
    };
    if nf < 4 {
        return Err(bad(format!("{nf} faces, a polyhedron needs at least 4")));
    }
    for f in 0..nf {
        let Some((&n, r)) = rest.split_first() else {
            return Err(bad(format!("face stream ends before face {f}")));
        };
        if n < 3 {
            return Err(bad(format!("face {f} has {n} vertices, needs at least 3")));
        }
        if r.len() < n as usize {
            return Err(bad(format!("face {f} is truncated")));
        }
        let bad_id = if check_ids {
            r[..n as usize].iter().find(|&&v| v as usize >= np)
        } else {
            None
        };
        if let Some(&v) = bad_id {
            return Err(bad(format!(
                "face {f} references point {v}, but the grid has {np} points"
            )));
        }
        rest = &r[n as usize..];
    }
    if !rest.is_empty() {
        return Err(bad(format!(
            "{} trailing values after {nf} faces",
            rest.len()
        )));
    }
    Ok(())
}

/// Lower and upper corners of the bounding box of `points` (see [`Grid::bounds`]).
pub fn bounds_of(points: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}

/// The bounding-box centre of `points` (see [`Grid::origin`]).
pub fn origin_of(points: &[[f64; 3]]) -> [f64; 3] {
    let (lo, hi) = bounds_of(points);
    [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]))
}

/// `points` as f32 relative to `o` (see [`Grid::rebased_positions`]), in
/// parallel (each point on its own, so the same bits on any thread count).
/// The array is allocated first, fallibly (as "the f32 positions").
pub fn rebased(points: &[[f64; 3]], o: [f64; 3]) -> Result<Vec<[f32; 3]>, crate::mem::AllocError> {
    use rayon::prelude::*;
    let mut out = crate::mem::try_vec(points.len(), "the f32 positions")?;
    out.par_extend(points.par_iter().map(|p| {
        [
            (p[0] - o[0]) as f32,
            (p[1] - o[1]) as f32,
            (p[2] - o[2]) as f32,
        ]
    }));
    Ok(out)
}

/// The property named `name`, else the only one named so up to case.
fn find_property<'a>(props: &'a [Property], name: &str) -> Option<&'a Property> {
    props.iter().find(|p| p.name == name).or_else(|| {
        let mut same = props.iter().filter(|p| p.name.eq_ignore_ascii_case(name));
        let first = same.next()?;
        same.next().is_none().then_some(first)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tet_grid(faces: &[Vec<u32>], typed: &[u32]) -> Grid {
        let mut cells = Cells::default();
        cells.push(vtk_type::TETRA, typed);
        cells.push_polyhedron(faces);
        Grid {
            points: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            topology: Topology::Unstructured(cells),
            point_data: Vec::new(),
            cell_data: Vec::new(),
        }
    }

    /// Point ids past the grid are named, in the connectivity and in a
    /// polyhedron's face stream alike (the one-pass range check only
    /// skips the per-cell search when every id is in range).
    #[test]
    fn out_of_range_ids_are_named() {
        let tet = |d: u32| vec![vec![0, 2, 1], vec![0, 1, d], vec![1, 2, d], vec![2, 0, d]];
        assert!(tet_grid(&tet(3), &[0, 1, 2, 3]).validate().is_ok());
        let e = tet_grid(&tet(3), &[0, 1, 2, 9]).validate().unwrap_err();
        assert!(
            matches!(
                e,
                GridError::MissingVertex {
                    cell: 0,
                    point: 9,
                    points: 4
                }
            ),
            "{e}"
        );
        let e = tet_grid(&tet(7), &[0, 1, 2, 3])
            .validate()
            .unwrap_err()
            .to_string();
        assert!(e.contains("cell 1 references point 7"), "{e}");
        // A face stream naming a point its connectivity does not.
        let mut g = tet_grid(&tet(3), &[0, 1, 2, 3]);
        if let Topology::Unstructured(c) = &mut g.topology {
            let n = c.face_stream.len();
            c.face_stream[n - 1] = 8;
        }
        let e = g.validate().unwrap_err().to_string();
        assert!(
            e.contains("cell 1") && e.contains("references point 8"),
            "{e}"
        );
    }
}
