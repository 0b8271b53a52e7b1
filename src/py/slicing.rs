//! `Grid.slice`: its arguments (the CLI's rules: exactly one of axis,
//! normal or property, exactly one of count or values) and the sweep,
//! run without the GIL on the structure the grid keeps; `device` chosen by
//! the policy as for the CLI's `slice --device`
//! ([`crate::policy::device`]: `cpu`: the CPU sweep emits; `gpu`: the CPU
//! sweep finds the cut cells and the GPU emits, statistics only; `auto`:
//! the GPU when an adapter exists and the request allows it, else the CPU).

use std::sync::Arc;

use pyo3::prelude::*;

use crate::cancel::Cancel;
use crate::field::FieldSpec;
use crate::gpu::compute::slice::{Emitter, GpuSliceError, slice_on};
use crate::gpu::context::{ContextOptions, GpuContext};
use crate::limits;
use crate::pipeline::{LevelSpec, SliceRequest, SliceResult, slice as sweep};
use crate::policy::Opt;
use crate::policy::device::{DEVICES, Device, falls_back, slice_device, slice_device_on};
use crate::policy::render::word;
use crate::report::{flatten_by_cell, stats_json};
use crate::structures::{Structure, StructureChoice};
use crate::sweep::SweepOptions;

use super::data::GridData;
use super::errors::{gpu_error, guard, invalid, runtime, value_error};
use super::interrupt::{interruptible, limit_error, warn_all};
use super::render::policy_error;
use super::slices::{PySlices, SliceData};

/// The arguments of `Grid.slice`, as Python gave them.
pub struct SliceArgs {
    /// Axis name (`x`, `-z`, ...).
    pub axis: Option<String>,
    /// Plane normal.
    pub normal: Option<[f64; 3]>,
    /// Property whose isosurfaces are cut.
    pub property: Option<String>,
    /// Number of evenly spaced levels.
    pub count: Option<i64>,
    /// Explicit level values.
    pub values: Option<Vec<f64>>,
    /// Property interpolated onto the polygons.
    pub attribute: Option<String>,
    /// `vertices` or `cells`.
    pub at: String,
    /// Worker threads (default 1).
    pub threads: Option<i64>,
    /// Structure choice name.
    pub structure: String,
    /// Whether to gather the welded polygons.
    pub mesh: bool,
    /// `cpu`, `gpu` or `auto`.
    pub device: String,
    /// GPU adapter name (substring).
    pub adapter: Option<String>,
}

/// The GPU to emit on, for the device the policy chose on the built
/// structure: `None` runs the CPU path (`cpu`; `auto` without an adapter).
fn open_gpu(device: Device, adapter: &Option<String>) -> PyResult<Option<GpuContext>> {
    let opts = ContextOptions {
        adapter: adapter.clone(),
        limits: None,
        ..Default::default()
    };
    match device {
        Device::Cpu => Ok(None),
        _ => match GpuContext::new(&opts) {
            Ok(c) => Ok(Some(c)),
            Err(e) if falls_back(device, &e) => Ok(None),
            Err(e) => Err(gpu_error(&e)),
        },
    }
}

/// The sweep with GPU emission (statistics only).
fn slice_gpu(
    ctx: &GpuContext,
    d: &GridData,
    s: &Structure,
    req: &SliceRequest,
) -> PyResult<SliceResult> {
    match slice_on(Emitter::Gpu(ctx), &d.grid, s, req) {
        Ok((r, _)) => Ok(r),
        Err(GpuSliceError::Pipeline(e)) => Err(invalid(format!("cannot slice {}: {e}", d.name))),
        Err(GpuSliceError::Gpu(e)) => Err(runtime(format!(
            "cannot slice {} on the GPU ({}): {e}",
            d.name, ctx.name
        ))),
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
            return Err(invalid(format!(
                "structure '{s}': expected auto, cgraph, scgraph, ciel, cpgraph or bruteforce"
            )));
        }
    })
}

fn parse_axis(s: &str) -> PyResult<FieldSpec> {
    FieldSpec::parse_axis(s)
        .ok_or_else(|| invalid(format!("axis '{s}': expected x, y, z, -x, -y or -z")))
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
                return Err(invalid(format!(
                    "normal {n:?}: expected three finite numbers"
                )));
            }
            if n.iter().all(|&c| c == 0.0) {
                return Err(invalid("normal must not be zero"));
            }
            Ok(FieldSpec::Normal(n))
        }
        (None, None, Some(p)) => Ok(FieldSpec::Property(p.to_string())),
        _ => Err(invalid("give exactly one of axis, normal or property")),
    }
}

/// The levels of `slice()`: exactly one of count or values, within the
/// library's limits (as the CLI's `--count` and `--values`).
fn levels_of(count: Option<i64>, values: Option<Vec<f64>>) -> PyResult<LevelSpec> {
    match (count, values) {
        (Some(k), None) => Ok(LevelSpec::Count(
            limits::check_count(k).map_err(limit_error)?,
        )),
        (None, Some(v)) => {
            limits::check_values(v.len() as f64).map_err(limit_error)?;
            // Empty, non-finite and non-increasing values are refused by
            // the pipeline with the level's index.
            Ok(LevelSpec::Values(v))
        }
        _ => Err(invalid("give exactly one of count or values")),
    }
}

/// The cell values `at="cells"` spreads over each polygon, or `None` for
/// `at="vertices"`.
fn flat_values(d: &GridData, at: &str, name: Option<&str>) -> PyResult<Option<Vec<f64>>> {
    match at {
        "vertices" => Ok(None),
        "cells" => match name.and_then(|n| d.grid.cell_property(n)) {
            Some(p) => Ok(Some((0..p.len()).map(|i| p.scalar_at(i)).collect())),
            None => Err(invalid(
                "at='cells' needs a cell property named by attribute or property",
            )),
        },
        _ => Err(invalid(format!(
            "at '{at}': expected 'vertices' or 'cells'"
        ))),
    }
}

/// Runs `Grid.slice` on `d`.
pub fn slice(py: Python<'_>, d: &Arc<GridData>, a: SliceArgs) -> PyResult<PySlices> {
    let field = field_of(a.axis.as_deref(), a.normal, a.property.as_deref())?;
    let levels = levels_of(a.count, a.values)?;
    let choice = structure_choice(&a.structure)?;
    let threads = limits::check_threads(a.threads.unwrap_or(1)).map_err(limit_error)?;
    let flat = flat_values(d, &a.at, a.attribute.as_deref().or(a.property.as_deref()))?;
    let mesh = a.mesh;
    let device = word(Opt::Device, &a.device, &DEVICES).map_err(policy_error)?;
    let device = slice_device(device, mesh, choice).map_err(policy_error)?;
    let cancel = Cancel::new();
    let adapter = a.adapter;
    let req = SliceRequest {
        field: field.clone(),
        levels,
        attribute: a.attribute,
        threads,
        brute_force: choice == StructureChoice::BruteForce,
        collect_mesh: mesh,
        sweep: SweepOptions {
            cancel: cancel.clone(),
            ..Default::default()
        },
    };
    let d = d.clone();
    let out = interruptible(py, &cancel, move || {
        guard(|| {
            let b = d.structure(choice)?;
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .map_err(|e| value_error(&e))?;
            let noop = |_: usize| {};
            let device = slice_device_on(device, &b.structure).map_err(policy_error)?;
            let r = match open_gpu(device, &adapter)? {
                Some(ctx) => pool.install(|| slice_gpu(&ctx, &d, &b.structure, &req))?,
                None => pool
                    .install(|| sweep(&d.grid, &b.structure, &req, &noop))
                    .map_err(|e| invalid(format!("cannot slice {}: {e}", d.name)))?,
            };
            let warnings = r.warnings.clone();
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
            let data = SliceData {
                mesh: m,
                stats,
                has_mesh: mesh,
            };
            Ok((data, warnings))
        })
    })?;
    warn_all(py, &out.1)?;
    Ok(PySlices::new(out.0))
}
