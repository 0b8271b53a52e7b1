//! The state behind a Python `Grid`: the grid, its name and load report,
//! its IJK layout, and the structures built so far (shared with the calls
//! that run without the GIL); and JSON → dict.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use pyo3::prelude::*;
use serde_json::Value;

use crate::grid::Grid;
use crate::grid::IjkLayout;
use crate::structures::{Structure, StructureChoice};

use super::errors::{invalid, value_error};

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
        let structure = Structure::build_with(&self.grid, choice, self.ijk.as_ref())
            .map_err(|e| invalid(format!("cannot build a structure for {}: {e}", self.name)))?;
        let b = Arc::new(Built {
            structure,
            build_s: t.elapsed().as_secs_f64(),
        });
        map.insert(key, b.clone());
        Ok(b)
    }
}

/// A dict from JSON (through Python's json module: the same types).
pub fn to_dict<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).map_err(|e| value_error(&e))?;
    py.import("json")?.call_method1("loads", (text,))
}
