//! `stratasweep.Grid`: a loaded grid, its structures built on first use
//! (one per `structure=` choice, kept), `info()`, `slice()`, `save()`.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use serde_json::Value;

use crate::field::FieldSpec;
use crate::grid::{Grid, Topology};
use crate::pipeline::{LevelSpec, SliceRequest, slice};
use crate::report::{InfoContext, flatten_by_cell, info_json, stats_json};
use crate::structures::cpgraph::IjkLayout;
use crate::structures::{Structure, StructureChoice};

use super::errors::{guard, value_error, write_error};
use super::slices::{PySlices, SliceData};

/// A structure and the seconds it took to build.
pub struct Built {
    /// The structure.
    pub structure: Structure,
    /// Build seconds.
    pub build_s: f64,
}

/// The grid behind a Python `Grid`, shared with the calls that run without the GIL.
pub struct GridData {
    /// The grid.
    pub grid: Grid,
    /// Its name (file path or generator).
    pub name: String,
    /// Corner-point load report, when loaded from GRDECL/EGRID.
    pub cornerpoint: Option<Value>,
    /// Seconds to load or make it.
    pub load_s: f64,
    /// The IJK layout of corner-point input (`auto` then builds the
    /// corner-point graph, as the CLI does).
    pub ijk: Option<IjkLayout>,
    /// Structures built so far, by choice name.
    structures: Mutex<HashMap<&'static str, Arc<Built>>>,
}

impl GridData {
    /// Wraps a grid.
    pub fn new(grid: Grid, name: String, cornerpoint: Option<Value>, load_s: f64) -> Self {
        GridData {
            grid,
            name,
            cornerpoint,
            load_s,
            ijk: None,
            structures: Mutex::default(),
        }
    }

    /// The same grid with its corner-point IJK layout.
    pub fn with_layout(mut self, ijk: Option<IjkLayout>) -> Self {
        self.ijk = ijk;
        self
    }

    /// The structure for `choice` (brute force uses the auto structure),
    /// built on first use and kept. Call without the GIL.
    pub fn structure(&self, choice: StructureChoice) -> PyResult<Arc<Built>> {
        let key = match choice {
            StructureChoice::Auto | StructureChoice::BruteForce => "auto",
            StructureChoice::CGraph => "cgraph",
            StructureChoice::SCGraph => "scgraph",
            StructureChoice::Ciel => "ciel",
            StructureChoice::CpGraph => "cpgraph",
        };
        let mut map = self.structures.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(b) = map.get(key) {
            return Ok(b.clone());
        }
        let t = Instant::now();
        let structure =
            Structure::build_with(&self.grid, choice, self.ijk.as_ref()).map_err(|e| {
                PyValueError::new_err(format!("cannot build a structure for {}: {e}", self.name))
            })?;
        let b = Arc::new(Built {
            structure,
            build_s: t.elapsed().as_secs_f64(),
        });
        map.insert(key, b.clone());
        Ok(b)
    }
}

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

/// Parses `structure=`.
pub fn structure_choice(s: &str) -> PyResult<StructureChoice> {
    Ok(match s {
        "auto" => StructureChoice::Auto,
        "cgraph" => StructureChoice::CGraph,
        "scgraph" => StructureChoice::SCGraph,
        "ciel" => StructureChoice::Ciel,
        "cpgraph" => StructureChoice::CpGraph,
        "bruteforce" => StructureChoice::BruteForce,
        _ => {
            return Err(PyValueError::new_err(format!(
                "structure '{s}': expected auto, cgraph, scgraph, ciel, cpgraph or bruteforce"
            )));
        }
    })
}

fn parse_axis(s: &str) -> PyResult<FieldSpec> {
    let (negative, a) = match s.strip_prefix('-') {
        Some(r) => (true, r),
        None => (false, s.strip_prefix('+').unwrap_or(s)),
    };
    let axis = match a {
        "x" | "X" => 0,
        "y" | "Y" => 1,
        "z" | "Z" => 2,
        _ => {
            return Err(PyValueError::new_err(format!(
                "axis '{s}': expected x, y, z, -x, -y or -z"
            )));
        }
    };
    Ok(FieldSpec::Axis { axis, negative })
}

/// The field of `slice()`: exactly one of axis, normal or property.
fn field_of(
    axis: Option<&str>,
    normal: Option<[f64; 3]>,
    property: Option<&str>,
) -> PyResult<FieldSpec> {
    match (axis, normal, property) {
        (Some(a), None, None) => parse_axis(a),
        (None, Some(n), None) => {
            if n.iter().any(|c| !c.is_finite()) {
                return Err(PyValueError::new_err(format!(
                    "normal {n:?}: expected three finite numbers"
                )));
            }
            if n.iter().all(|&c| c == 0.0) {
                return Err(PyValueError::new_err("normal must not be zero"));
            }
            Ok(FieldSpec::Normal(n))
        }
        (None, None, Some(p)) => Ok(FieldSpec::Property(p.to_string())),
        _ => Err(PyValueError::new_err(
            "give exactly one of axis, normal or property",
        )),
    }
}

/// The levels of `slice()`: exactly one of count or values.
fn levels_of(count: Option<i64>, values: Option<Vec<f64>>) -> PyResult<LevelSpec> {
    match (count, values) {
        (Some(k), None) => {
            if k < 1 {
                return Err(PyValueError::new_err("count must be at least 1"));
            }
            Ok(LevelSpec::Count(k as usize))
        }
        (None, Some(v)) => {
            if v.len() > 10_000_000 {
                return Err(PyValueError::new_err(format!(
                    "values has {} levels; that is too many",
                    v.len()
                )));
            }
            // Empty, non-finite and non-increasing values are refused by
            // the pipeline with the level's index.
            Ok(LevelSpec::Values(v))
        }
        _ => Err(PyValueError::new_err("give exactly one of count or values")),
    }
}

/// A dict from JSON (through Python's json module: the same types).
pub fn to_dict<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).map_err(|e| value_error(&e))?;
    py.import("json")?.call_method1("loads", (text,))
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

    /// The structure `structure="auto"` builds: `scgraph`, `cgraph` or `ciel`.
    #[getter]
    fn structure(&self, py: Python<'_>) -> PyResult<&'static str> {
        let d = self.data.clone();
        py.detach(|| guard(|| Ok(d.structure(StructureChoice::Auto)?.structure.name())))
    }

    /// Slices or contours the grid with the incremental sweep.
    #[pyo3(signature = (axis=None, normal=None, property=None, count=None, values=None,
                        attribute=None, at="vertices", threads=None, structure="auto", mesh=true))]
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
        threads: Option<usize>,
        structure: &str,
        mesh: bool,
    ) -> PyResult<PySlices> {
        let field = field_of(axis.as_deref(), normal, property.as_deref())?;
        let levels = levels_of(count, values)?;
        let choice = structure_choice(structure)?;
        let threads = threads.unwrap_or(1);
        if threads == 0 {
            return Err(PyValueError::new_err("threads must be at least 1"));
        }
        let flat = match at {
            "vertices" => None,
            "cells" => {
                let name = attribute.clone().or(property.clone());
                match name
                    .as_deref()
                    .and_then(|n| self.data.grid.cell_property(n))
                {
                    Some(p) => Some((0..p.len()).map(|i| p.scalar_at(i)).collect::<Vec<f64>>()),
                    None => {
                        return Err(PyValueError::new_err(
                            "at='cells' needs a cell property named by attribute or property",
                        ));
                    }
                }
            }
            _ => {
                return Err(PyValueError::new_err(format!(
                    "at '{at}': expected 'vertices' or 'cells'"
                )));
            }
        };
        let req = SliceRequest {
            field: field.clone(),
            levels,
            attribute,
            threads,
            brute_force: choice == StructureChoice::BruteForce,
            collect_mesh: mesh,
            sweep: Default::default(),
        };
        let d = self.data.clone();
        let out = py.detach(move || {
            guard(|| {
                let b = d.structure(choice)?;
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .map_err(|e| value_error(&e))?;
                let noop = |_: usize| {};
                let r = pool
                    .install(|| slice(&d.grid, &b.structure, &req, &noop))
                    .map_err(|e| PyValueError::new_err(format!("cannot slice {}: {e}", d.name)))?;
                let stats = stats_json(
                    &r,
                    &b.structure,
                    &d.grid,
                    d.load_s,
                    b.build_s,
                    &d.name,
                    &field,
                );
                let mut m = r.mesh.unwrap_or_default();
                if let Some(vals) = &flat {
                    m = flatten_by_cell(&m, vals);
                }
                Ok(SliceData {
                    mesh: m,
                    stats,
                    has_mesh: mesh,
                })
            })
        })?;
        Ok(PySlices::new(out))
    }

    /// Volume-renders (or draws isosurfaces of) the grid into an
    /// `(H, W, 4)` uint8 straight-RGBA array.
    #[pyo3(signature = (property=None, slices=200, view_dir=(-1.0, -0.6, -0.8), up=None,
                        projection="ortho", transfer=None, unit_distance=None,
                        background=None, size=(800, 600), mode="volume", iso=None,
                        adapter=None, device="auto"))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        property: Option<String>,
        slices: usize,
        view_dir: (f64, f64, f64),
        up: Option<(f64, f64, f64)>,
        projection: &str,
        transfer: Option<&Bound<'py, PyAny>>,
        unit_distance: Option<f64>,
        background: Option<&Bound<'py, PyAny>>,
        size: (u32, u32),
        mode: &str,
        iso: Option<Vec<f64>>,
        adapter: Option<String>,
        device: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let args = super::render::RenderArgs {
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
            adapter,
            device: device.to_string(),
        };
        super::render::render(py, &self.data, args)
    }

    /// Writes the grid as VTK XML: `.vts` for a curvilinear grid, `.vtu`
    /// otherwise (generated corner-point grids are written as their zoo grid).
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        let want = crate::io::writers::grid_extension(&self.data.grid);
        if path.extension().and_then(|e| e.to_str()) != Some(want) {
            return Err(PyValueError::new_err(format!(
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
