//! Grids from in-memory arrays: `from_arrays` (PyVista's `UnstructuredGrid`
//! layout), `from_structured` (a `StructuredGrid`: point dims, I fastest)
//! and `from_explicit_structured` (an `ExplicitStructuredGrid` cast to its
//! hexahedra, with the IJK layout, so `auto` sweeps it on the corner-point
//! graph as GRDECL input).

use std::time::Instant;

use numpy::{PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::grid::Property;
use crate::io::vtk_read::{
    UnstructuredArrays, grid_from_arrays, grid_from_explicit_structured, grid_from_structured,
};

use super::data::GridData;
use super::errors::{guard, invalid, value_error};
use super::grid::PyGrid;

/// Named float64 arrays (a dict of 1-D or 2-D arrays) as properties.
fn properties(d: Option<&Bound<'_, PyDict>>, n: usize, kind: &str) -> PyResult<Vec<Property>> {
    let mut out = Vec::new();
    let Some(d) = d else { return Ok(out) };
    for (k, v) in d.iter() {
        let name: String = k.extract()?;
        let (values, components) = if let Ok(a) = v.extract::<PyReadonlyArray1<'_, f64>>() {
            (a.as_slice()?.to_vec(), 1)
        } else if let Ok(a) = v.extract::<PyReadonlyArray2<'_, f64>>() {
            let c = a.shape()[1].max(1);
            (a.as_array().iter().copied().collect(), c)
        } else {
            return Err(invalid(format!(
                "{kind} property '{name}': expected a float64 array of shape (n,) or (n, k)"
            )));
        };
        if values.len() != n * components {
            return Err(invalid(format!(
                "{kind} property '{name}' has {} tuples, expected {n} (one per {kind})",
                values.len() / components
            )));
        }
        out.push(Property {
            name,
            components,
            values,
        });
    }
    Ok(out)
}

fn points_of(a: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<[f64; 3]>> {
    if a.shape()[1] != 3 {
        return Err(invalid(format!(
            "points must have shape (n, 3), found {:?}",
            a.shape()
        )));
    }
    let v = a.as_array();
    Ok(v.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect())
}

/// `from_arrays`: an unstructured grid in PyVista's layout (padded cells,
/// one VTK type per cell, (n, 3) points).
#[pyfunction]
#[pyo3(signature = (points, cells, celltypes, point_data=None, cell_data=None, merge_points=false))]
pub fn from_arrays(
    py: Python<'_>,
    points: PyReadonlyArray2<'_, f64>,
    cells: PyReadonlyArray1<'_, i64>,
    celltypes: PyReadonlyArray1<'_, i64>,
    point_data: Option<&Bound<'_, PyDict>>,
    cell_data: Option<&Bound<'_, PyDict>>,
    merge_points: bool,
) -> PyResult<PyGrid> {
    let pts = points_of(&points)?;
    let pd = properties(point_data, pts.len(), "point")?;
    let cd = properties(cell_data, celltypes.len(), "cell")?;
    let (cells, types) = (cells.as_slice()?, celltypes.as_slice()?);
    let data = py.detach(|| {
        guard(|| {
            let t = Instant::now();
            let a = UnstructuredArrays {
                points: &pts,
                cells,
                celltypes: types,
            };
            let g = grid_from_arrays(a, pd, cd, merge_points, "from_arrays")
                .map_err(|e| value_error(&e))?;
            Ok(GridData::new(
                g,
                "from_arrays".into(),
                None,
                t.elapsed().as_secs_f64(),
            ))
        })
    })?;
    Ok(PyGrid::from(data))
}

/// `from_structured`: a curvilinear grid from point dims and points (I fastest).
#[pyfunction]
#[pyo3(signature = (dims, points, point_data=None, cell_data=None))]
pub fn from_structured(
    py: Python<'_>,
    dims: [usize; 3],
    points: PyReadonlyArray2<'_, f64>,
    point_data: Option<&Bound<'_, PyDict>>,
    cell_data: Option<&Bound<'_, PyDict>>,
) -> PyResult<PyGrid> {
    let pts = points_of(&points)?;
    let nc: usize = dims.iter().map(|d| d.saturating_sub(1)).product();
    let pd = properties(point_data, pts.len(), "point")?;
    let cd = properties(cell_data, nc, "cell")?;
    let data = py.detach(|| {
        guard(|| {
            let g = grid_from_structured(dims, pts, pd, cd, "from_structured")
                .map_err(|e| value_error(&e))?;
            Ok(GridData::new(g, "from_structured".into(), None, 0.0))
        })
    })?;
    Ok(PyGrid::from(data))
}

/// `from_explicit_structured`: an explicit structured grid of `dims` cells
/// from its hexahedra in PyVista's unstructured layout (cell `c` at IJK
/// index `c`, I fastest); corners welded, pinched cells as polyhedra,
/// `vtkGhostType` hidden cells kept hidden, IJK layout attached.
#[pyfunction]
#[pyo3(signature = (dims, points, cells, celltypes, point_data=None, cell_data=None))]
pub fn from_explicit_structured(
    py: Python<'_>,
    dims: [usize; 3],
    points: PyReadonlyArray2<'_, f64>,
    cells: PyReadonlyArray1<'_, i64>,
    celltypes: PyReadonlyArray1<'_, i64>,
    point_data: Option<&Bound<'_, PyDict>>,
    cell_data: Option<&Bound<'_, PyDict>>,
) -> PyResult<PyGrid> {
    let pts = points_of(&points)?;
    let pd = properties(point_data, pts.len(), "point")?;
    let cd = properties(cell_data, celltypes.len(), "cell")?;
    let (cells, types) = (cells.as_slice()?, celltypes.as_slice()?);
    let data = py.detach(|| {
        guard(|| {
            let t = Instant::now();
            let a = UnstructuredArrays {
                points: &pts,
                cells,
                celltypes: types,
            };
            let (g, ijk) = grid_from_explicit_structured(a, dims, pd, cd, "from_pyvista")
                .map_err(|e| value_error(&e))?;
            Ok(
                GridData::new(g, "from_pyvista".into(), None, t.elapsed().as_secs_f64())
                    .with_layout(Some(ijk)),
            )
        })
    })?;
    Ok(PyGrid::from(data))
}
