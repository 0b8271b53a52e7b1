//! `Grid.render`: Python's keywords parsed into the library's render
//! request ([`crate::policy::render::RenderRequest`]), which the policy
//! validates, checks against the grid and draws as it does for the CLI's
//! `render` (the same defaults, limits, errors and image bits). The
//! adapter is chosen by `device` (`auto`: the best adapter, real GPUs
//! before software rasterisers; `gpu`: a hardware adapter only; `cpu`: a
//! software rasteriser only, e.g. Mesa's llvmpipe). Returns straight RGBA
//! as an `(H, W, 4)` array, and writes it as a PNG when given `output`.

use std::path::PathBuf;

use numpy::IntoPyArray;
use numpy::ndarray::Array3;
use pyo3::exceptions::PyUserWarning;
use pyo3::prelude::*;

use crate::gpu::context::{ContextOptions, GpuContext};
use crate::gpu::render::{RenderError, Renderer};
use crate::policy::device::{DEVICES, Device, adapters, render_adapter};
use crate::policy::render::{
    Background, CELLS, Level, MODES, PROJECTIONS, RenderRequest, Target, blank_warning, word,
};
use crate::policy::transfer::TransferChoice;
use crate::policy::{PolicyError, Refusal};
use crate::structures::StructureChoice;

use super::data::GridData;
use super::errors::{gpu_error, guard, invalid, os_error, runtime, value_error};
use super::interrupt::interruptible;
use crate::cancel::Cancel;

/// The arguments of `Grid.render`, as Python gave them.
pub struct RenderArgs<'a, 'py> {
    /// Property shown.
    pub property: Option<String>,
    /// Slice count.
    pub slices: i64,
    /// View direction.
    pub view_dir: [f64; 3],
    /// Up vector.
    pub up: Option<[f64; 3]>,
    /// `ortho` or `perspective`.
    pub projection: String,
    /// Colormap name, JSON file path, or dict `{"points": [...]}`.
    pub transfer: Option<&'a Bound<'py, PyAny>>,
    /// Unit distance of the opacities.
    pub unit_distance: Option<f64>,
    /// `(r, g, b, a)` in [0, 1], `"r,g,b,a"` or `"transparent"`.
    pub background: Option<&'a Bound<'py, PyAny>>,
    /// `(width, height)`.
    pub size: (i64, i64),
    /// `volume`, `slices` or `iso`.
    pub mode: String,
    /// Isovalues.
    pub iso: Vec<f64>,
    /// Vertical exaggeration (`None`: the grid's default).
    pub z_scale: Option<f64>,
    /// Pre-integrated volume rendering.
    pub preintegrated: bool,
    /// `auto`, `sweep` or `gpu` (`None`: the sweep).
    pub cells: Option<String>,
    /// Draw the colour legend.
    pub legend: bool,
    /// Adapter name substring.
    pub adapter: Option<String>,
    /// `auto`, `gpu` or `cpu`.
    pub device: String,
    /// PNG to write.
    pub output: Option<PathBuf>,
}

/// A refusal of the policy as a Python exception: a file that cannot be
/// read `OSError`, no adapter of the kind asked for and GPU faults
/// `RuntimeError`, anything else `ValueError`; options named by their
/// keywords.
pub fn policy_error(e: PolicyError) -> PyErr {
    let text = e.to_string();
    match &e.refusal {
        Refusal::Read { source, .. } => os_error(text, source),
        Refusal::Unavailable(_) | Refusal::Render(RenderError::Gpu(_)) => runtime(text),
        _ => invalid(text),
    }
}

/// `transfer=`: a colormap name or a path (`str` or path-like) as the CLI
/// reads it, or a dict `{"points": [...]}` as JSON.
fn transfer_of(t: Option<&Bound<'_, PyAny>>) -> PyResult<TransferChoice> {
    let Some(t) = t else {
        return Ok(TransferChoice::default());
    };
    if let Ok(s) = t.extract::<String>() {
        return Ok(TransferChoice::Named(s));
    }
    if t.hasattr("__fspath__")? {
        let p: PathBuf = t.extract()?;
        return Ok(TransferChoice::Named(p.display().to_string()));
    }
    let text: String = t
        .py()
        .import("json")?
        .call_method1("dumps", (t,))?
        .extract()?;
    Ok(TransferChoice::Json(text))
}

/// `background=`: text as the CLI reads it, or a sequence of numbers.
fn background_of(b: Option<&Bound<'_, PyAny>>) -> PyResult<Background> {
    match b {
        None => Ok(RenderRequest::default().background),
        Some(b) => match b.extract::<String>() {
            Ok(s) => Ok(Background::Text(s)),
            Err(_) => Ok(Background::Values(b.extract()?)),
        },
    }
}

/// The request of `a` (keywords parsed; nothing decided).
fn request_of(a: &RenderArgs<'_, '_>) -> PyResult<RenderRequest> {
    let e = policy_error;
    Ok(RenderRequest {
        property: a.property.clone(),
        slices: a.slices as i128,
        view_dir: a.view_dir,
        up: a.up,
        perspective: word(crate::policy::Opt::Projection, &a.projection, &PROJECTIONS)
            .map_err(e)?,
        transfer: transfer_of(a.transfer)?,
        unit_distance: a.unit_distance,
        background: background_of(a.background)?,
        size: (a.size.0 as i128, a.size.1 as i128),
        mode: word(crate::policy::Opt::Mode, &a.mode, &MODES).map_err(e)?,
        iso: a.iso.clone(),
        z_scale: a.z_scale,
        preintegrated: a.preintegrated,
        cells: a
            .cells
            .as_deref()
            .map(|c| word(crate::policy::Opt::Cells, c, &CELLS))
            .transpose()
            .map_err(e)?,
        legend: a.legend,
        target: Target::Image,
    })
}

/// Renders on the GPU without the GIL.
pub fn render<'py>(
    py: Python<'py>,
    data: &std::sync::Arc<GridData>,
    a: RenderArgs<'_, 'py>,
) -> PyResult<Bound<'py, PyAny>> {
    let plan = request_of(&a)?.resolve().map_err(policy_error)?;
    let device = word(crate::policy::Opt::Device, &a.device, &DEVICES).map_err(policy_error)?;
    if let Some(p) = &a.output
        && p.extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            != Some("png".into())
    {
        return Err(invalid(format!(
            "output {}: the image is written as .png",
            p.display()
        )));
    }
    let adapter = match device {
        Device::Auto => a.adapter,
        d => render_adapter(d, a.adapter, &py.detach(adapters)).map_err(policy_error)?,
    };
    let (w, h) = plan.options.size;
    let d = data.clone();
    let output = a.output;
    // Ctrl-C stops the render between its slicing and its drawing.
    let cancel = Cancel::new();
    let token = cancel.clone();
    let (rgba, warnings) = interruptible(py, &cancel, move || {
        guard(|| {
            let mut warnings: Vec<String> = plan
                .check_grid(&d.grid)
                .map_err(policy_error)?
                .into_iter()
                .filter(|n| n.level == Level::Warning)
                .map(|n| n.text.to_string())
                .collect();
            let b = d.structure(StructureChoice::Auto)?;
            let ctx = GpuContext::new(&ContextOptions {
                adapter,
                limits: None,
                ..Default::default()
            })
            .map_err(|e| gpu_error(&e))?;
            let mut r = Renderer::new(&ctx).map_err(render_error)?;
            r.cancel = token;
            let z_scale = plan.z_scale(&d.grid).value;
            let drawn = plan
                .draw(&mut r, &d.grid, &b.structure, z_scale)
                .map_err(render_error)?;
            if drawn.blank {
                warnings.push(blank_warning("the image").to_string());
            }
            if let Some(p) = &output {
                let png = drawn.image.png().map_err(render_error)?;
                crate::io::atomic::write_bytes(p, &png)
                    .map_err(|e| os_error(format!("cannot write {}: {e}", p.display()), &e))?;
            }
            Ok((drawn.image.rgba8(), warnings))
        })
    })?;
    for w in warnings {
        let msg = std::ffi::CString::new(crate::io::checks::escape_control(&w)).unwrap_or_default();
        PyErr::warn(py, &py.get_type::<PyUserWarning>(), &msg, 1)?;
    }
    let arr = Array3::from_shape_vec((h as usize, w as usize, 4), rgba)
        .map_err(|e| invalid(e.to_string()))?;
    Ok(arr.into_pyarray(py).into_any())
}

/// Options and pipeline refusals are `ValueError`; GPU faults `RuntimeError`.
fn render_error(e: RenderError) -> PyErr {
    match e {
        RenderError::Gpu(g) => gpu_error(&g),
        other => value_error(&other),
    }
}
