//! `stratasweep.Grid`: a loaded grid, its structures built on first use
//! (one per `structure=` choice, kept), `info()`, `slice()`, `save()`.

use std::sync::Arc;

use pyo3::prelude::*;

use crate::grid::Topology;
use crate::report::{InfoContext, info_json};
use crate::structures::StructureChoice;

use super::data::{GridData, to_dict};
use super::errors::{guard, invalid, write_error};
use super::render::{RenderArgs, render};
use super::slices::PySlices;
use super::slicing::{self, SliceArgs, structure_choice};

/// A grid: load one with `stratasweep.load(path)`, make one with
/// `stratasweep.generate.*`, or bring one with `from_arrays`/`from_pyvista`.
#[pyclass(name = "Grid", module = "stratasweep", frozen)]
pub struct PyGrid {
    /// The shared grid.
    pub data: Arc<GridData>,
}

impl From<GridData> for PyGrid {
    fn from(d: GridData) -> Self {
        PyGrid { data: Arc::new(d) }
    }
}

#[pymethods]
impl PyGrid {
    /// The same content as `stratasweep info --json` (builds the structure
    /// chosen by `structure`, default auto, on first use).
    #[pyo3(signature = (structure="auto"))]
    fn info<'py>(&self, py: Python<'py>, structure: &str) -> PyResult<Bound<'py, PyAny>> {
        let choice = structure_choice(structure)?;
        let d = self.data.clone();
        let v = py.detach(|| {
            guard(|| {
                let b = d.structure(choice)?;
                Ok(info_json(
                    &d.grid,
                    &b.structure,
                    &InfoContext {
                        name: d.name.clone(),
                        cornerpoint: d.cornerpoint.clone(),
                        load_s: d.load_s,
                        build_s: b.build_s,
                        ..Default::default()
                    },
                ))
            })
        })?;
        to_dict(py, &v)
    }

    /// Names of the point (vertex) properties.
    #[getter]
    fn point_properties(&self) -> Vec<String> {
        self.data
            .grid
            .point_data
            .iter()
            .map(|p| p.name.clone())
            .collect()
    }

    /// Names of the cell properties.
    #[getter]
    fn cell_properties(&self) -> Vec<String> {
        self.data
            .grid
            .cell_data
            .iter()
            .map(|p| p.name.clone())
            .collect()
    }

    /// `(xmin, xmax, ymin, ymax, zmin, zmax)`, as PyVista's `bounds`.
    #[getter]
    fn bounds(&self) -> (f64, f64, f64, f64, f64, f64) {
        let (lo, hi) = self.data.grid.bounds();
        (lo[0], hi[0], lo[1], hi[1], lo[2], hi[2])
    }

    /// Number of cells (hidden ones included).
    #[getter]
    fn n_cells(&self) -> usize {
        self.data.grid.cell_count()
    }

    /// Number of points.
    #[getter]
    fn n_points(&self) -> usize {
        self.data.grid.points.len()
    }

    /// The structure `structure="auto"` builds: `scgraph`, `cpgraph`, `cgraph` or `ciel`.
    #[getter]
    fn structure(&self, py: Python<'_>) -> PyResult<&'static str> {
        let d = self.data.clone();
        py.detach(|| guard(|| Ok(d.structure(StructureChoice::Auto)?.structure.name())))
    }

    /// Slices or contours the grid with the incremental sweep (`device`:
    /// `cpu`, `gpu` or `auto`, as the CLI's `slice --device`).
    // The keyword arguments are the Python API (one per CLI option); the
    // body hands them on as one `SliceArgs`.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (axis=None, normal=None, property=None, count=None, values=None,
                        attribute=None, at="vertices", threads=None, structure="auto", mesh=true,
                        device="cpu", adapter=None))]
    fn slice(
        &self,
        py: Python<'_>,
        axis: Option<String>,
        normal: Option<[f64; 3]>,
        property: Option<String>,
        count: Option<i64>,
        values: Option<Vec<f64>>,
        attribute: Option<String>,
        at: &str,
        threads: Option<i64>,
        structure: &str,
        mesh: bool,
        device: &str,
        adapter: Option<String>,
    ) -> PyResult<PySlices> {
        let args = SliceArgs {
            axis,
            normal,
            property,
            count,
            values,
            attribute,
            at: at.to_string(),
            threads,
            structure: structure.to_string(),
            mesh,
            device: device.to_string(),
            adapter,
        };
        slicing::slice(py, &self.data, args)
    }

    /// The vertical exaggeration `render` uses when given no `z_scale`
    /// (the CLI's default: 1 for grids at least a quarter as high as
    /// wide, else 2, 5, 10, 20, ...).
    #[getter]
    fn default_z_scale(&self) -> f64 {
        crate::policy::render::grid_z_scale(&self.data.grid)
    }

    /// Volume-renders (or draws isosurfaces of) the grid into an
    /// `(H, W, 4)` uint8 straight-RGBA array: every option of the CLI's
    /// `render`, with its defaults and errors (`output`: also write the
    /// PNG, as `render -o`).
    #[pyo3(signature = (property=None, slices=200, view_dir=(-1.0, -0.6, -0.8), up=None,
                        projection="ortho", transfer=None, unit_distance=None,
                        background=None, size=(800, 600), mode="volume", iso=None,
                        z_scale=None, preintegrated=false, cells=None, legend=false,
                        adapter=None, device="auto", output=None))]
    // The keyword arguments are the Python API (one per render option);
    // the body hands them on as one `RenderArgs`.
    #[allow(clippy::too_many_arguments)]
    fn render<'py>(
        &self,
        py: Python<'py>,
        property: Option<String>,
        slices: i64,
        view_dir: (f64, f64, f64),
        up: Option<(f64, f64, f64)>,
        projection: &str,
        transfer: Option<&Bound<'py, PyAny>>,
        unit_distance: Option<f64>,
        background: Option<&Bound<'py, PyAny>>,
        size: (i64, i64),
        mode: &str,
        iso: Option<Vec<f64>>,
        z_scale: Option<f64>,
        preintegrated: bool,
        cells: Option<String>,
        legend: bool,
        adapter: Option<String>,
        device: &str,
        output: Option<std::path::PathBuf>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let args = RenderArgs {
            property,
            slices,
            view_dir: [view_dir.0, view_dir.1, view_dir.2],
            up: up.map(|u| [u.0, u.1, u.2]),
            projection: projection.to_string(),
            transfer,
            unit_distance,
            background,
            size,
            mode: mode.to_string(),
            iso: iso.unwrap_or_default(),
            z_scale,
            preintegrated,
            cells,
            legend,
            adapter,
            device: device.to_string(),
            output,
        };
        render(py, &self.data, args)
    }

    /// Writes the grid as VTK XML: `.vts` for a curvilinear grid, `.vtu`
    /// otherwise (generated corner-point grids are written as their zoo grid).
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        let want = crate::io::writers::grid_extension(&self.data.grid);
        if path.extension().and_then(|e| e.to_str()) != Some(want) {
            return Err(invalid(format!(
                "{}: this grid is written as .{want}",
                path.display()
            )));
        }
        let d = self.data.clone();
        py.detach(|| {
            guard(|| crate::io::writers::write_vtk_xml_grid(&path, &d.grid).map_err(write_error))
        })
    }

    fn __repr__(&self) -> String {
        let g = &self.data.grid;
        let kind = match g.topology {
            Topology::Structured { .. } => "structured",
            Topology::Unstructured(_) => "unstructured",
        };
        format!(
            "<stratasweep.Grid '{}': {} {} cells, {} points, point properties {:?}, cell properties {:?}>",
            self.data.name,
            g.cell_count(),
            kind,
            g.points.len(),
            self.point_properties(),
            self.cell_properties()
        )
    }
}
