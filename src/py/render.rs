//! `Grid.render`: the offscreen renderer on an adapter chosen by `device`
//! (`auto`: the best adapter, real GPUs before software rasterisers;
//! `gpu`: a hardware adapter only; `cpu`: a software rasteriser only, e.g.
//! Mesa's llvmpipe), returning straight RGBA as an `(H, W, 4)` array.

use numpy::IntoPyArray;
use numpy::ndarray::Array3;
use pyo3::exceptions::PyUserWarning;
use pyo3::prelude::*;

use crate::gpu::context::{ContextOptions, GpuContext};
use crate::gpu::render::checks::check_options;
use crate::gpu::render::{
    CellFinding, Mode, RenderError, RenderOptions, Renderer, Transfer, TransferSource,
};
use crate::structures::StructureChoice;

use super::data::GridData;
use super::errors::{gpu_error, guard, invalid, runtime, value_error};
use super::interrupt::{interruptible, limit_error};
use crate::cancel::Cancel;
use crate::limits;

/// An adapter as wgpu lists it.
pub struct AdapterInfo {
    /// Name with backend, as `GpuContext` names it.
    pub name: String,
    /// Backend (`Vulkan`, `Gl`, ...).
    pub backend: String,
    /// `DiscreteGpu`, `IntegratedGpu`, `VirtualGpu`, `Cpu` or `Other`.
    pub device_type: String,
}

/// The adapters a render would choose among: the primary backends', or
/// GL's when they have none.
pub fn list_adapters() -> Vec<AdapterInfo> {
    crate::gpu::context::list_adapters(None)
        .into_iter()
        .map(|i| AdapterInfo {
            name: format!("{} ({:?})", i.name, i.backend),
            backend: format!("{:?}", i.backend),
            device_type: format!("{:?}", i.device_type),
        })
        .collect()
}

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
    /// `(r, g, b, a)` in [0, 1] or `"transparent"`.
    pub background: Option<&'a Bound<'py, PyAny>>,
    /// `(width, height)`.
    pub size: (i64, i64),
    /// `volume`, `slices` or `iso`.
    pub mode: String,
    /// Isovalues.
    pub iso: Vec<f64>,
    /// Adapter name substring.
    pub adapter: Option<String>,
    /// `auto`, `gpu` or `cpu`.
    pub device: String,
}

/// The transfer function of `transfer=`: a colormap name, a path ending
/// in `.json`, or a dict `{"points": [...]}` (anything else refused, as on
/// the command line).
fn transfer_of(t: Option<&Bound<'_, PyAny>>) -> PyResult<(Option<Transfer>, String)> {
    let Some(t) = t else {
        return Ok((None, "viridis".into()));
    };
    if let Ok(s) = t.extract::<String>() {
        let path = match TransferSource::parse(&s).map_err(|e| value_error(&e))? {
            TransferSource::Colormap(name) => return Ok((None, name)),
            TransferSource::File(path) => path,
        };
        let text = std::fs::read(&path).map_err(|e| {
            super::errors::os_error(format!("cannot read the transfer function {path}: {e}"), &e)
        })?;
        let text = String::from_utf8_lossy(&text);
        let tf = Transfer::from_json(&text).map_err(|e| invalid(format!("in {path}: {e}")))?;
        return Ok((Some(tf), String::new()));
    }
    let text: String = t
        .py()
        .import("json")?
        .call_method1("dumps", (t,))?
        .extract()?;
    let tf = Transfer::from_json(&text).map_err(|e| value_error(&e))?;
    Ok((Some(tf), String::new()))
}

fn background_of(b: Option<&Bound<'_, PyAny>>) -> PyResult<Option<[f32; 4]>> {
    let Some(b) = b else {
        return Ok(Some([1.0; 4]));
    };
    if let Ok(s) = b.extract::<String>() {
        if s.eq_ignore_ascii_case("transparent") {
            return Ok(None);
        }
        return Err(invalid(format!(
            "background '{s}': expected (r, g, b, a) in [0, 1] or 'transparent'"
        )));
    }
    let v: Vec<f32> = b.extract()?;
    if v.len() != 4 || v.iter().any(|c| !(0.0..=1.0).contains(c)) {
        return Err(invalid(format!(
            "background {v:?}: expected four values in [0, 1] (r, g, b, a) or 'transparent'"
        )));
    }
    Ok(Some([v[0], v[1], v[2], v[3]]))
}

/// The adapter name to ask for: `device` narrows the choice to hardware
/// (`gpu`) or software (`cpu`) adapters; `auto` leaves it to `GpuContext`.
fn adapter_for(device: &str, adapter: Option<String>) -> PyResult<Option<String>> {
    let want_software = match device {
        "auto" => return Ok(adapter),
        "gpu" => false,
        "cpu" => true,
        _ => {
            return Err(invalid(format!(
                "device '{device}': expected 'auto', 'gpu' or 'cpu'"
            )));
        }
    };
    let all = list_adapters();
    let found = all.iter().find(|a| {
        (a.device_type == "Cpu") == want_software
            && adapter
                .as_ref()
                .is_none_or(|w| a.name.to_lowercase().contains(&w.to_lowercase()))
    });
    match found {
        Some(a) => Ok(Some(a.name.clone())),
        None => Err(runtime(format!(
            "device='{device}': no {} adapter{} among [{}]; device='auto' takes any adapter{}",
            if want_software {
                "software (CPU)"
            } else {
                "hardware GPU"
            },
            adapter
                .map(|w| format!(" matching '{w}'"))
                .unwrap_or_default(),
            all.iter()
                .map(|a| format!("{} [{}]", a.name, a.device_type))
                .collect::<Vec<_>>()
                .join(", "),
            if want_software {
                " (install Mesa's software Vulkan: apt install mesa-vulkan-drivers)"
            } else {
                ""
            },
        ))),
    }
}

/// Renders on the GPU without the GIL.
pub fn render<'py>(
    py: Python<'py>,
    data: &std::sync::Arc<GridData>,
    a: RenderArgs<'_, 'py>,
) -> PyResult<Bound<'py, PyAny>> {
    let (transfer, colormap) = transfer_of(a.transfer)?;
    let background = background_of(a.background)?;
    let mode = match a.mode.as_str() {
        "volume" => Mode::Volume,
        "slices" => Mode::Slices,
        "iso" => Mode::Iso,
        m => {
            return Err(invalid(format!(
                "mode '{m}': expected 'volume', 'slices' or 'iso'"
            )));
        }
    };
    if mode == Mode::Iso && a.iso.is_empty() {
        return Err(invalid("mode='iso' needs iso values"));
    }
    let perspective = match a.projection.as_str() {
        "ortho" => false,
        "perspective" => true,
        p => {
            return Err(invalid(format!(
                "projection '{p}': expected 'ortho' or 'perspective'"
            )));
        }
    };
    // The library's limits, as the CLI's `--slices`, `--size` and `--iso`.
    let slices = limits::check_slices(a.slices).map_err(limit_error)?;
    let (w, h) = (
        limits::check_image_side(a.size.0).map_err(limit_error)?,
        limits::check_image_side(a.size.1).map_err(limit_error)?,
    );
    limits::check_isovalues(a.iso.len()).map_err(limit_error)?;
    let opts = RenderOptions {
        property: a.property,
        slices,
        view_dir: a.view_dir,
        up: a.up,
        perspective,
        transfer,
        colormap,
        unit_distance: a.unit_distance,
        background,
        size: (w, h),
        mode,
        iso: a.iso,
        // The same image bits on every run, as the CLI's `render`.
        cells: CellFinding::Sweep,
    };
    let adapter = adapter_for(&a.device, a.adapter)?;
    let d = data.clone();
    // Ctrl-C stops the render between its slicing and its drawing.
    let cancel = Cancel::new();
    let token = cancel.clone();
    let (rgba, warnings) = interruptible(py, &cancel, move || {
        guard(|| {
            // The CLI's checks: a transfer function that draws nothing is
            // refused, one outside the data warned about.
            let warnings = check_options(&d.grid, &opts, false).map_err(render_error)?;
            let b = d.structure(StructureChoice::Auto)?;
            let ctx = GpuContext::new(&ContextOptions {
                adapter,
                limits: None,
                ..Default::default()
            })
            .map_err(|e| gpu_error(&e))?;
            let mut r = Renderer::new(&ctx).map_err(render_error)?;
            r.cancel = token;
            let img = r
                .render(&d.grid, &b.structure, &opts)
                .map_err(render_error)?;
            Ok((img.rgba8(), warnings))
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
