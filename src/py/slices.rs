//! `stratasweep.Slices`: the welded output of one `Grid.slice` call as
//! numpy arrays in VTK's polygon layout, its statistics, PyVista and files.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::exceptions::PyImportError;
use pyo3::prelude::*;
use serde_json::Value;

use crate::mesh::PolyMesh;

use super::data::to_dict;
use super::errors::{guard, invalid, runtime, write_error};

/// `n` items for the array `what`, allocated fallibly (`MemoryError`
/// naming it when the memory is not there).
fn room<T>(n: usize, what: &str) -> PyResult<Vec<T>> {
    crate::mem::try_vec(n, what).map_err(|e| runtime(e.to_string()))
}

/// What a slicing call returns.
pub struct SliceData {
    /// The welded polygons (empty when `mesh=False`).
    pub mesh: PolyMesh,
    /// The `--stats` report.
    pub stats: Value,
    /// Whether the mesh was gathered.
    pub has_mesh: bool,
}

/// The polygons of one `Grid.slice` call: every level's cut, welded by
/// grid edge, with the interpolated attribute, level and source cell.
#[pyclass(name = "Slices", module = "stratasweep", frozen)]
pub struct PySlices {
    data: SliceData,
}

impl PySlices {
    /// Wraps a result.
    pub fn new(data: SliceData) -> Self {
        PySlices { data }
    }

    fn mesh(&self) -> PyResult<&PolyMesh> {
        if !self.data.has_mesh {
            return Err(invalid(
                "this slice was made with mesh=False: statistics only",
            ));
        }
        Ok(&self.data.mesh)
    }
}

#[pymethods]
impl PySlices {
    /// `(n, 3)` float64 vertex positions in world coordinates.
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let m = self.mesh()?;
        let mut flat: Vec<f64> = room(m.positions.len() * 3, "Slices.points")?;
        flat.extend((0..m.positions.len()).flat_map(|v| m.world_position(v)));
        let a = Array2::from_shape_vec((m.positions.len(), 3), flat)
            .map_err(|e| invalid(e.to_string()))?;
        Ok(a.into_pyarray(py))
    }

    /// Polygon offsets into `connectivity` (int64, one more than polygons, from 0).
    #[getter]
    fn offsets<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let m = self.mesh()?;
        let mut v: Vec<i64> = room(m.poly_offsets.len(), "Slices.offsets")?;
        v.extend(m.poly_offsets.iter().map(|&o| i64::from(o)));
        Ok(PyArray1::from_vec(py, v))
    }

    /// Vertex ids of every polygon, concatenated (int64).
    #[getter]
    fn connectivity<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let m = self.mesh()?;
        let mut v: Vec<i64> = room(m.poly_indices.len(), "Slices.connectivity")?;
        v.extend(m.poly_indices.iter().map(|&o| i64::from(o)));
        Ok(PyArray1::from_vec(py, v))
    }

    /// The interpolated attribute per vertex (float32).
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f32>>> {
        Ok(PyArray1::from_slice(py, &self.mesh()?.values))
    }

    /// The level index of every polygon (uint32).
    #[getter]
    fn level<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<u32>>> {
        Ok(PyArray1::from_slice(py, &self.mesh()?.poly_level))
    }

    /// The source cell (input numbering) of every polygon (uint32).
    #[getter]
    fn cell<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<u32>>> {
        Ok(PyArray1::from_slice(py, &self.mesh()?.poly_cell))
    }

    /// The world value of every level (float64).
    #[getter]
    fn level_values<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let v: Vec<f64> = self.data.stats["slices"]
            .as_array()
            .map(|a| {
                a.iter()
                    .map(|s| s["value"].as_f64().unwrap_or(f64::NAN))
                    .collect()
            })
            .unwrap_or_default();
        PyArray1::from_vec(py, v)
    }

    /// Name of the interpolated attribute carried in `values`.
    #[getter]
    fn attribute(&self) -> String {
        self.data.stats["attribute"]
            .as_str()
            .unwrap_or("")
            .to_string()
    }

    /// Number of polygons.
    #[getter]
    fn n_polygons(&self) -> usize {
        self.data.mesh.polygon_count()
    }

    /// The same dict as `stratasweep slice --stats`.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_dict(py, &self.data.stats)
    }

    /// Writes the polygons: `.ply` (binary) or `.vtp` (VTK XML PolyData).
    fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
        let m = self.mesh()?;
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let ply = match ext.as_deref() {
            Some("ply") => true,
            Some("vtp") => false,
            _ => {
                return Err(invalid(format!(
                    "{}: the output must end in .ply or .vtp",
                    path.display()
                )));
            }
        };
        py.detach(|| {
            guard(|| {
                if ply {
                    crate::io::writers::write_ply(&path, m)
                } else {
                    crate::io::writers::write_vtp(&path, m)
                }
                .map_err(write_error)
            })
        })
    }

    /// A `pyvista.PolyData` of the polygons with point array named after
    /// the attribute and cell arrays `level`, `level_value` and `cell`.
    fn to_pyvista<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let m = self.mesh()?;
        let pv = py.import("pyvista").map_err(|e| {
            PyImportError::new_err(format!(
                "Slices.to_pyvista() needs PyVista: pip install pyvista ({e})"
            ))
        })?;
        let mut faces = room(
            m.poly_indices.len() + m.polygon_count(),
            "the PolyData's faces",
        )?;
        for p in 0..m.polygon_count() {
            let poly = m.polygon(p);
            faces.push(poly.len() as i64);
            faces.extend(poly.iter().map(|&i| i64::from(i)));
        }
        let mesh = pv
            .getattr("PolyData")?
            .call1((self.points(py)?, PyArray1::from_vec(py, faces)))?;
        let name = if m.property_name.is_empty() {
            "values".to_string()
        } else {
            m.property_name.clone()
        };
        mesh.getattr("point_data")?
            .set_item(name, self.values(py)?)?;
        let cd = mesh.getattr("cell_data")?;
        cd.set_item("level", self.level(py)?)?;
        let mut lv: Vec<f64> = room(m.poly_level.len(), "the PolyData's level values")?;
        lv.extend(
            m.poly_level
                .iter()
                .map(|&l| m.level_values.get(l as usize).copied().unwrap_or(f64::NAN)),
        );
        cd.set_item("level_value", PyArray1::from_vec(py, lv))?;
        cd.set_item("cell", self.cell(py)?)?;
        Ok(mesh)
    }

    fn __len__(&self) -> usize {
        self.data.mesh.polygon_count()
    }

    fn __repr__(&self) -> String {
        let t = &self.data.stats["totals"];
        format!(
            "<stratasweep.Slices: {} levels, {} polygons, {} cut cells, area {}>",
            self.data.stats["slices"].as_array().map_or(0, |a| a.len()),
            t["polygons"],
            t["cells"],
            t["area"]
        )
    }
}
