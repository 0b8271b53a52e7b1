//! Python bindings (cargo feature `python`; `pip install .` builds them
//! with maturin as `stratasweep._native`, wrapped by the pure-Python
//! package in `src/py/stratasweep/`). Every call that loads, builds,
//! sweeps, renders or writes releases the GIL; every error becomes a
//! Python exception ([`errors`]), and a panic a `RuntimeError`.

mod errors;
mod grid;
mod render;
mod slices;

use std::path::PathBuf;
use std::time::Instant;

use numpy::{PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::grid::{Grid, Property};
use crate::io::vtk_read::{UnstructuredArrays, grid_from_arrays, grid_from_structured};

pub use errors::{guard, value_error};
pub use grid::{GridData, PyGrid};
pub use slices::PySlices;

/// `stratasweep.load(path)`: any grid file the CLI reads.
#[pyfunction]
fn load(py: Python<'_>, path: PathBuf) -> PyResult<PyGrid> {
    let data = py.detach(|| {
        guard(|| {
            let t = Instant::now();
            let l = crate::io::load(&path).map_err(errors::load_error)?;
            Ok(GridData::new(
                l.grid,
                path.display().to_string(),
                l.cornerpoint,
                t.elapsed().as_secs_f64(),
            )
            .with_layout(l.ijk))
        })
    })?;
    Ok(PyGrid::from(data))
}

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
            return Err(PyValueError::new_err(format!(
                "{kind} property '{name}': expected a float64 array of shape (n,) or (n, k)"
            )));
        };
        if values.len() != n * components {
            return Err(PyValueError::new_err(format!(
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
        return Err(PyValueError::new_err(format!(
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
fn from_arrays(
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
fn from_structured(
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

fn check_dims(dims: [usize; 3]) -> PyResult<()> {
    if dims.contains(&0) {
        return Err(PyValueError::new_err(format!(
            "dims {dims:?}: expected three positive integers"
        )));
    }
    if dims.iter().map(|&d| (d + 1) as u128).product::<u128>() >= u32::MAX as u128 / 2 {
        return Err(PyValueError::new_err(format!(
            "dims {dims:?}: too many points"
        )));
    }
    Ok(())
}

fn check_cells(cells: usize, max: usize) -> PyResult<()> {
    if cells == 0 || cells > max {
        return Err(PyValueError::new_err(format!(
            "cells must be between 1 and {max}, got {cells}"
        )));
    }
    Ok(())
}

fn generated(py: Python<'_>, name: String, f: impl FnOnce() -> Grid + Send) -> PyResult<PyGrid> {
    let data = py.detach(|| {
        guard(|| {
            let t = Instant::now();
            let g = f();
            Ok(GridData::new(g, name, None, t.elapsed().as_secs_f64()))
        })
    })?;
    Ok(PyGrid::from(data))
}

/// A warped curvilinear grid carrying the Marschner–Lobb signal `f`.
#[pyfunction]
#[pyo3(signature = (dims, seed=1))]
fn generate_warped(py: Python<'_>, dims: [usize; 3], seed: u64) -> PyResult<PyGrid> {
    check_dims(dims)?;
    let name = format!("warped {}x{}x{}", dims[0], dims[1], dims[2]);
    generated(py, name, move || crate::generate::warped(dims, seed))
}

/// A conforming tet/pyramid/wedge/hex grid with a point property `f`.
#[pyfunction]
#[pyo3(signature = (cells, seed=1))]
fn generate_zoo(py: Python<'_>, cells: usize, seed: u64) -> PyResult<PyGrid> {
    check_cells(cells, 200_000_000)?;
    generated(py, format!("zoo {cells}"), move || {
        crate::generate::zoo(cells, seed)
    })
}

/// A clipped 3D Voronoi grid (VTK polyhedra) with a point property `f`.
#[pyfunction]
#[pyo3(signature = (cells, seed=1))]
fn generate_voronoi(py: Python<'_>, cells: usize, seed: u64) -> PyResult<PyGrid> {
    check_cells(cells, 50_000_000)?;
    generated(py, format!("voronoi {cells}"), move || {
        crate::voronoi::voronoi(cells, seed)
    })
}

fn faulted_cp(
    dims: [usize; 3],
    faults: usize,
    fault_dip: Option<f64>,
    seed: u64,
) -> PyResult<crate::cornerpoint::CornerPointGrid> {
    check_dims(dims)?;
    if faults > 1000 {
        return Err(PyValueError::new_err("faults must be at most 1000"));
    }
    if let Some(d) = fault_dip
        && !(crate::generate::MIN_FAULT_DIP..=90.0).contains(&d)
    {
        return Err(PyValueError::new_err(format!(
            "fault_dip {d} is outside [{}, 90] degrees",
            crate::generate::MIN_FAULT_DIP
        )));
    }
    Ok(crate::generate::faulted_with_dip(
        dims, faults, fault_dip, seed,
    ))
}

/// A faulted corner-point reservoir converted to a zoo grid (faults
/// unsewn, pinch-outs as wedges/pyramids/tetrahedra, inactive cells out).
#[pyfunction]
#[pyo3(signature = (dims, faults=3, fault_dip=None, seed=1))]
fn generate_faulted(
    py: Python<'_>,
    dims: [usize; 3],
    faults: usize,
    fault_dip: Option<f64>,
    seed: u64,
) -> PyResult<PyGrid> {
    let cp = faulted_cp(dims, faults, fault_dip, seed)?;
    let name = format!("faulted {}x{}x{}", dims[0], dims[1], dims[2]);
    let data = py.detach(|| {
        guard(|| {
            let t = Instant::now();
            let (g, _) = cp.into_grid().map_err(|e| value_error(&e))?;
            Ok(GridData::new(g, name, None, t.elapsed().as_secs_f64()))
        })
    })?;
    Ok(PyGrid::from(data))
}

/// The corners of the generated faulted model as an explicit structured
/// grid holds them: `(corners, actnum, cell_data)` with corners of shape
/// `(8·nc, 3)` over the doubled lattice `(2·ni, 2·nj, 2·nk)`, I fastest.
#[pyfunction]
#[pyo3(signature = (dims, faults=3, fault_dip=None, seed=1))]
fn faulted_corners<'py>(
    py: Python<'py>,
    dims: [usize; 3],
    faults: usize,
    fault_dip: Option<f64>,
    seed: u64,
) -> PyResult<(
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<u8>>,
    Bound<'py, PyDict>,
)> {
    let cp = faulted_cp(dims, faults, fault_dip, seed)?;
    let [ni, nj, nk] = dims;
    let (corners, actnum) = py.detach(|| {
        let mut c = vec![0.0f64; 8 * ni * nj * nk * 3];
        let (w, h) = (2 * ni, 2 * nj);
        for k in 0..nk {
            for j in 0..nj {
                for i in 0..ni {
                    for (q, p) in cp.cell_corners(i, j, k).iter().enumerate() {
                        let (a, b, d) = (q & 1, q >> 1 & 1, q >> 2);
                        let at = ((2 * k + d) * h + 2 * j + b) * w + 2 * i + a;
                        c[3 * at..3 * at + 3].copy_from_slice(p);
                    }
                }
            }
        }
        let act: Vec<u8> = (0..ni * nj * nk).map(|c| cp.is_active(c) as u8).collect();
        (c, act)
    });
    let n = corners.len() / 3;
    let corners = numpy::ndarray::Array2::from_shape_vec((n, 3), corners)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let cd = PyDict::new(py);
    for p in &cp.properties {
        cd.set_item(&p.name, PyArray1::from_slice(py, &p.values))?;
    }
    Ok((
        numpy::IntoPyArray::into_pyarray(corners, py),
        PyArray1::from_vec(py, actnum),
        cd,
    ))
}

/// The GPU adapters wgpu finds: dicts of `name`, `backend`, `device_type`.
#[pyfunction]
fn adapters(py: Python<'_>) -> PyResult<Vec<Py<PyDict>>> {
    let list = py.detach(render::list_adapters);
    list.into_iter()
        .map(|a| {
            let d = PyDict::new(py);
            d.set_item("name", &a.name)?;
            d.set_item("backend", &a.backend)?;
            d.set_item("device_type", &a.device_type)?;
            Ok(d.unbind())
        })
        .collect()
}

/// The native part of the `stratasweep` Python package.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyGrid>()?;
    m.add_class::<PySlices>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(from_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(from_structured, m)?)?;
    m.add_function(wrap_pyfunction!(generate_warped, m)?)?;
    m.add_function(wrap_pyfunction!(generate_zoo, m)?)?;
    m.add_function(wrap_pyfunction!(generate_voronoi, m)?)?;
    m.add_function(wrap_pyfunction!(generate_faulted, m)?)?;
    m.add_function(wrap_pyfunction!(faulted_corners, m)?)?;
    m.add_function(wrap_pyfunction!(adapters, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
