//! Python bindings (cargo feature `python`; `pip install .` builds them
//! with maturin as `stratasweep._native`, wrapped by the pure-Python
//! package in `src/py/stratasweep/`). Every call that loads, builds,
//! sweeps, renders or writes releases the GIL; every error becomes a
//! Python exception ([`errors`]), and a panic a `RuntimeError`.

mod arrays;
mod data;
mod errors;
mod grid;
mod interrupt;
mod render;
mod slices;
mod slicing;

use std::path::PathBuf;
use std::time::Instant;

use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::grid::Grid;
use crate::grid::IjkLayout;

pub use data::GridData;
pub use errors::{guard, invalid, value_error};
pub use grid::PyGrid;
pub use slices::PySlices;

/// `stratasweep.load(path)`: any grid file the CLI reads.
#[pyfunction]
fn load(py: Python<'_>, path: PathBuf) -> PyResult<PyGrid> {
    let (data, warnings) = py.detach(|| {
        guard(|| {
            let t = Instant::now();
            let l = crate::io::load(&path).map_err(errors::load_error)?;
            let data = GridData::new(
                l.grid,
                path.display().to_string(),
                l.cornerpoint,
                t.elapsed().as_secs_f64(),
            )
            .with_layout(l.ijk);
            Ok((data, l.warnings))
        })
    })?;
    // The load's warnings (an EGRID without its INIT, skipped local grids,
    // ...) as Python warnings, as the CLI prints them.
    for w in warnings {
        let msg = std::ffi::CString::new(w.replace('\0', " ")).unwrap_or_default();
        PyErr::warn(
            py,
            &py.get_type::<pyo3::exceptions::PyUserWarning>(),
            &msg,
            1,
        )?;
    }
    Ok(PyGrid::from(data))
}

fn check_dims(dims: [usize; 3]) -> PyResult<()> {
    if dims.contains(&0) {
        return Err(invalid(format!(
            "dims {dims:?}: expected three positive integers"
        )));
    }
    if dims.iter().map(|&d| (d + 1) as u128).product::<u128>() >= u32::MAX as u128 / 2 {
        return Err(invalid(format!("dims {dims:?}: too many points")));
    }
    Ok(())
}

fn check_cells(cells: usize, max: usize) -> PyResult<()> {
    if cells == 0 || cells > max {
        return Err(invalid(format!(
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
        return Err(invalid("faults must be at most 1000"));
    }
    if let Some(d) = fault_dip
        && !(crate::generate::MIN_FAULT_DIP..=90.0).contains(&d)
    {
        return Err(invalid(format!(
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
            let dims = cp.dims;
            let (g, rep) = cp.into_grid().map_err(|e| value_error(&e))?;
            let ijk = IjkLayout {
                dims,
                source_cell: rep.source_cell,
            };
            Ok(GridData::new(g, name, None, t.elapsed().as_secs_f64()).with_layout(Some(ijk)))
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
        .map_err(|e| invalid(e.to_string()))?;
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
    let list = py.detach(crate::policy::device::adapters);
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
    m.add_function(wrap_pyfunction!(arrays::from_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::from_structured, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::from_explicit_structured, m)?)?;
    m.add_function(wrap_pyfunction!(generate_warped, m)?)?;
    m.add_function(wrap_pyfunction!(generate_zoo, m)?)?;
    m.add_function(wrap_pyfunction!(generate_voronoi, m)?)?;
    m.add_function(wrap_pyfunction!(generate_faulted, m)?)?;
    m.add_function(wrap_pyfunction!(faulted_corners, m)?)?;
    m.add_function(wrap_pyfunction!(adapters, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
