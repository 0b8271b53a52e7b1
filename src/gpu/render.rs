//! Volume rendering by slicing and isosurfaces, offscreen.
//!
//! Volume and slices modes: the grid is sliced along the world axis most
//! parallel to the view direction (`argmax |d·e_i|`); the slices' triangles
//! come from [`GpuEmitter`] and are drawn far to near with one
//! `multi_draw_indirect` over the emitter's per-level draw arguments
//! (increasing or decreasing order), blended with premultiplied "over" into
//! a float target. Opacity is per unit distance U:
//! `α' = 1 − (1 − α)^(Δ / (U |cos θ|))` with Δ the slice spacing and θ the
//! angle between the ray and the axis. Iso mode draws the isosurfaces of
//! `--iso` values opaque, lit, with a depth test.
//!
//! The slices of one (axis, slice count, property) stay on the GPU: another
//! view in the same axis cone re-renders without any compute dispatch.

use std::collections::HashMap;

use glam::Vec3;
use thiserror::Error;

use crate::field::FieldSpec;
use crate::grid::Grid;
use crate::pipeline::{LevelSpec, PipelineError, SliceRequest, vertex_property};
use crate::structures::Structure;

pub use super::camera::{FRAME_MARGIN, frame_camera};
use super::compute::emit::{GpuEmitter, emit_chunked};
use super::compute::gradient::vertex_gradients;
use super::compute::slice::{prepare, prepare_unswept};
use super::compute::tables::{Frame, slot_values};
use super::context::{GpuContext, GpuError};
use super::ijk_field::IjkField;
use super::pre_pass::{BoundaryMesh, PrePipeline};
use super::shaders;
use super::shown::{check_shown_property, property_range, shown_property};
pub use super::transfer::{
    COLORMAPS, LUT_VEC4S, Transfer, TransferError, TransferPoint, TransferSource,
};

/// Errors of rendering.
#[derive(Debug, Error)]
pub enum RenderError {
    /// The pipeline refused the request.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// The GPU failed.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// A bad option.
    #[error("{0}")]
    Options(String),
    /// A transfer function that is malformed or can only draw nothing.
    #[error(transparent)]
    Transfer(#[from] TransferError),
}

/// How to draw.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Slices with opacity corrected for spacing and angle.
    Volume,
    /// Slices with the transfer function's opacity as is.
    Slices,
    /// Opaque lit isosurfaces.
    Iso,
}

/// What to render.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Property shown (default: [`super::shown::default_property`]; without
    /// properties the slice position along the axis).
    pub property: Option<String>,
    /// Slices along the chosen axis (volume and slices modes).
    pub slices: usize,
    /// Direction the camera looks along.
    pub view_dir: [f64; 3],
    /// Up vector (default: +z, or +y when looking along z).
    pub up: Option<[f64; 3]>,
    /// Perspective (else orthographic).
    pub perspective: bool,
    /// Transfer function; `None`: viridis over the property's range.
    pub transfer: Option<Transfer>,
    /// Named colormap used when `transfer` is `None`.
    pub colormap: String,
    /// Unit distance U of the opacities (default: the mean cell size).
    pub unit_distance: Option<f64>,
    /// Background (straight RGBA); `None`: transparent.
    pub background: Option<[f32; 4]>,
    /// Image size in pixels.
    pub size: (u32, u32),
    /// Mode.
    pub mode: Mode,
    /// Isovalues (iso mode).
    pub iso: Vec<f64>,
    /// How the cut cells of the slices are found.
    pub cells: CellFinding,
}

/// How the cut cells of the slices are found before the GPU emits them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CellFinding {
    /// GPU binning on hardware GPUs, the CPU sweep on software ones
    /// (llvmpipe), where the sweep is faster.
    #[default]
    Auto,
    /// The CPU sweep (the paper's incremental sweep).
    Sweep,
    /// Span-space binning of every live cell on the GPU; the sweep still
    /// serves IJK clips, grids split into parts and frames over the
    /// device's limits.
    Gpu,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            property: None,
            slices: 200,
            view_dir: [-1.0, -0.6, -0.8],
            up: None,
            perspective: false,
            transfer: None,
            colormap: "viridis".into(),
            unit_distance: None,
            background: Some([1.0, 1.0, 1.0, 1.0]),
            size: (800, 600),
            mode: Mode::Volume,
            iso: Vec::new(),
            cells: CellFinding::Auto,
        }
    }
}

/// A rendered image: straight (un-premultiplied) RGBA, 8 bits, rows top to bottom.
#[derive(Clone, Debug)]
pub struct Image {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Premultiplied float RGBA after compositing over the background.
    pub premultiplied: Vec<[f32; 4]>,
}

impl Image {
    /// Straight RGBA, 8 bits per channel.
    pub fn rgba8(&self) -> Vec<u8> {
        let q = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
        self.premultiplied
            .iter()
            .flat_map(|p| {
                let a = p[3];
                if a <= 0.0 {
                    [0, 0, 0, 0]
                } else {
                    [q(p[0] / a), q(p[1] / a), q(p[2] / a), q(a)]
                }
            })
            .collect()
    }

    /// The premultiplied float pixel at (x, y).
    pub fn pixel(&self, x: u32, y: u32) -> [f32; 4] {
        self.premultiplied[(y * self.width + x) as usize]
    }

    /// Encodes a PNG (straight RGBA, 8 bits).
    pub fn png(&self) -> Result<Vec<u8>, RenderError> {
        let mut out = Vec::new();
        let mut enc = png::Encoder::new(&mut out, self.width, self.height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc
            .write_header()
            .map_err(|e| RenderError::Options(format!("PNG: {e}")))?;
        w.write_image_data(&self.rgba8())
            .map_err(|e| RenderError::Options(format!("PNG: {e}")))?;
        w.finish()
            .map_err(|e| RenderError::Options(format!("PNG: {e}")))?;
        Ok(out)
    }
}

/// Triangles of one (axis or iso, count, property) on the GPU: the cached
/// slices that every view in the axis's cone draws without a dispatch.
pub struct SliceSet<'c> {
    /// Level chunks (one unless the frame exceeded a storage binding), in level order.
    pub(super) chunks: Vec<GpuEmitter<'c>>,
    /// Slice spacing along the axis (volume), 0 for iso.
    pub spacing: f64,
    /// Range of the shown values.
    pub range: (f64, f64),
    /// Cut cells of all levels (the frame's entries).
    pub cut_cells: u64,
    /// Levels (slices or isovalues).
    pub levels: u32,
    /// The grid's outer surface (structured grids; pre-integrated mode).
    pub boundary: Option<BoundaryMesh>,
    /// Pre-integrated mode on an IJK grid: the shown property in index
    /// space (the slices then carry `(i, j, k)` in place of the gradient).
    pub field: Option<IjkField>,
    /// Pre-integrated mode without [`Self::field`]: why (the slabs then
    /// follow the gradient path, or plain slices for a cell property).
    pub field_fallback: Option<String>,
}

impl SliceSet<'_> {
    /// Compute dispatches issued to build these slices.
    pub fn dispatches(&self) -> u64 {
        self.chunks.iter().map(|e| e.dispatches).sum()
    }
}

/// What one [`SliceSet`] is: the cache key and the request that builds it.
#[derive(Clone, Debug)]
pub struct SliceKey {
    /// Cache key (mode, axis or isovalues, count, property).
    pub key: String,
    /// The field sliced: an axis, or the property (iso).
    pub field: FieldSpec,
    /// Levels.
    pub levels: LevelSpec,
    /// The shown property.
    pub property: Option<String>,
    /// Iso mode (gradients uploaded, no flat cell colour).
    pub iso: bool,
    /// Slicing axis (volume and slices modes).
    pub axis: usize,
    /// The attribute's gradient rides along as normals (pre-integration).
    pub attr_gradient: bool,
    /// IJK clipping: only cells with `lo ≤ i < hi` (and j, k) are drawn
    /// (IJK grids).
    pub clip: Option<[[usize; 2]; 3]>,
    /// How the cut cells are found (the slices are the same either way).
    pub cells: CellFinding,
    /// Stops the CPU sweep between levels (not part of the cache key).
    pub cancel: crate::cancel::Cancel,
}

impl SliceKey {
    /// Carries the attribute's gradient (pre-integrated volume mode).
    pub fn with_attr_gradient(mut self) -> Self {
        if !self.iso && !self.attr_gradient {
            self.attr_gradient = true;
            self.key.push_str(" +gradient");
        }
        self
    }

    /// Draws only the cells of the IJK box `clip` (cell index ranges `lo..hi`).
    pub fn with_clip(mut self, clip: Option<[[usize; 2]; 3]>) -> Self {
        if let Some(c) = clip {
            self.key.push_str(&format!(" clip {c:?}"));
        }
        self.clip = clip;
        self
    }
}

/// The slicing axis for a display-space view direction: `argmax |d·e_i|`.
pub fn slicing_axis(d: Vec3) -> usize {
    (0..3)
        .max_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs()))
        .unwrap_or(2)
}

/// The slices `o` needs along `axis` (or its isosurfaces).
pub fn slice_key(grid: &Grid, o: &RenderOptions, axis: usize) -> Result<SliceKey, RenderError> {
    let property = shown_property(grid, o);
    let (key, field, levels) = match o.mode {
        Mode::Iso => {
            let Some(p) = &property else {
                return Err(RenderError::Options(
                    "iso mode needs a point or cell property".into(),
                ));
            };
            if o.iso.is_empty() {
                return Err(RenderError::Options("iso mode needs isovalues".into()));
            }
            let mut iso = o.iso.clone();
            iso.sort_by(f64::total_cmp);
            iso.dedup();
            (
                format!("iso {p} {iso:?}"),
                FieldSpec::Property(p.clone()),
                LevelSpec::Values(iso),
            )
        }
        _ => {
            if o.slices == 0 {
                return Err(RenderError::Options(
                    "the slice count must be at least 1".into(),
                ));
            }
            (
                format!("axis {axis} {} {property:?}", o.slices),
                FieldSpec::Axis {
                    axis,
                    negative: false,
                },
                LevelSpec::Count(o.slices),
            )
        }
    };
    Ok(SliceKey {
        key,
        field,
        levels,
        property,
        iso: o.mode == Mode::Iso,
        axis,
        attr_gradient: false,
        clip: None,
        cells: o.cells,
        cancel: Default::default(),
    })
}

/// The offscreen renderer with its cache of slices.
pub struct Renderer<'c> {
    pub(super) ctx: &'c GpuContext,
    pub(super) format: wgpu::TextureFormat,
    pub(super) layout: wgpu::BindGroupLayout,
    pub(super) blend: wgpu::RenderPipeline,
    pub(super) iso: wgpu::RenderPipeline,
    /// Volume mode with pre-integrated slabs (one pass per slice).
    pub(super) pre: PrePipeline,
    pub(super) preintegrated: bool,
    pub(super) cache: HashMap<String, SliceSet<'c>>,
    /// What the cached slices were built from (see [`GridStamp`]).
    pub(super) stamp: Option<GridStamp>,
    /// Compute dispatches of evicted cache entries.
    evicted_dispatches: u64,
    /// Checked by [`Renderer::render`] before slicing and before drawing.
    pub cancel: crate::cancel::Cancel,
}

/// A cheap identity of a (grid, structure) pair: their addresses, sizes
/// and a hash of up to 64 evenly spaced points and property values. The
/// slice cache is keyed by view and property only, so a render of another
/// grid, or of the same one changed, must not reuse it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridStamp {
    addresses: [usize; 3],
    sizes: [usize; 2],
    sample: u64,
}

impl GridStamp {
    /// The stamp of `grid` with its structure `s`.
    pub fn of(grid: &Grid, s: &Structure) -> Self {
        fn mix(h: u64, x: u64) -> u64 {
            (h ^ x).wrapping_mul(0x0100_0000_01b3).rotate_left(17)
        }
        fn spaced(n: usize) -> impl Iterator<Item = usize> {
            let step = n.div_ceil(64).max(1);
            (0..n).step_by(step)
        }
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        for i in spaced(grid.points.len()) {
            for c in grid.points[i] {
                h = mix(h, c.to_bits());
            }
        }
        for p in grid.point_data.iter().chain(&grid.cell_data) {
            h = mix(h, p.name.len() as u64);
            for i in spaced(p.len()) {
                h = mix(h, p.scalar_at(i).to_bits());
            }
        }
        GridStamp {
            addresses: [
                grid as *const Grid as usize,
                grid.points.as_ptr() as usize,
                s as *const Structure as usize,
            ],
            sizes: [grid.points.len(), grid.cell_count()],
            sample: h,
        }
    }
}

pub(super) const DEPTH: wgpu::TextureFormat = super::pre_pass::DEPTH_FORMAT;

impl<'c> Renderer<'c> {
    /// Builds the render pipelines (Rgba32Float target when the adapter can
    /// blend it, else Rgba16Float).
    pub fn new(ctx: &'c GpuContext) -> Result<Self, RenderError> {
        let format = target_format(ctx)?;
        let src = shaders::render_source();
        shaders::validate("render.wgsl", &src)
            .map_err(|e| GpuError::Device(format!("invalid shader {e}")))?;
        let module = ctx
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("render.wgsl"),
                source: wgpu::ShaderSource::Wgsl(src.into()),
            });
        let layout = bind_group_layout(&ctx.device);
        let pl = ctx
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("render"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        let vertices = super::shared::out_vertex_layout();
        let normals = super::shared::normal_layout();
        let slice_buffers = [Some(vertices.clone())];
        let iso_buffers = [Some(vertices), Some(normals)];
        let make = |blend: Option<wgpu::BlendState>, depth: bool, normals: bool, fs: &str| {
            let (entry, buffers): (&str, &[Option<wgpu::VertexBufferLayout>]) = if normals {
                ("vs_iso", &iso_buffers)
            } else {
                ("vs", &slice_buffers)
            };
            ctx.device
                .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some("render"),
                    layout: Some(&pl),
                    vertex: wgpu::VertexState {
                        module: &module,
                        entry_point: Some(entry),
                        compilation_options: Default::default(),
                        buffers,
                    },
                    primitive: wgpu::PrimitiveState::default(),
                    depth_stencil: depth.then(|| wgpu::DepthStencilState {
                        format: DEPTH,
                        depth_write_enabled: Some(true),
                        depth_compare: Some(wgpu::CompareFunction::Less),
                        stencil: Default::default(),
                        bias: Default::default(),
                    }),
                    multisample: Default::default(),
                    fragment: Some(wgpu::FragmentState {
                        module: &module,
                        entry_point: Some(fs),
                        compilation_options: Default::default(),
                        targets: &[Some(wgpu::ColorTargetState {
                            format,
                            blend,
                            write_mask: wgpu::ColorWrites::ALL,
                        })],
                    }),
                    multiview_mask: None,
                    cache: None,
                })
        };
        let over = Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING);
        let blend = make(over, false, false, "fs");
        let pre = PrePipeline::new(&ctx.device, &module, &layout, format);
        let iso = make(None, true, true, "fs");
        ctx.check()?;
        Ok(Renderer {
            ctx,
            format,
            layout,
            blend,
            pre,
            iso,
            preintegrated: false,
            cache: HashMap::new(),
            stamp: None,
            evicted_dispatches: 0,
            cancel: Default::default(),
        })
    }

    /// Compute dispatches issued by this renderer so far.
    pub fn dispatches(&self) -> u64 {
        self.evicted_dispatches
            + self
                .cache
                .values()
                .flat_map(|c| &c.chunks)
                .map(|e| e.dispatches)
                .sum::<u64>()
    }

    /// The colour target format.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.format
    }

    /// Volume mode with pre-integrated transfer functions: each slab's
    /// colour and opacity come from a 2D table over its front value (the
    /// slice's) and back value (extrapolated along the ray with the
    /// attribute's gradient). Off by default.
    pub fn set_preintegrated(&mut self, on: bool) {
        self.preintegrated = on;
    }

    /// Whether volume mode is pre-integrated.
    pub fn preintegrated(&self) -> bool {
        self.preintegrated
    }

    /// The device this renderer draws with.
    pub fn ctx(&self) -> &'c GpuContext {
        self.ctx
    }

    /// The cached slices of `key`, if built.
    pub fn slices(&self, key: &str) -> Option<&SliceSet<'c>> {
        self.cache.get(key)
    }

    /// Caches `set` under `key`, replacing (evicting) every other entry:
    /// one axis cone or property at a time.
    pub fn insert(&mut self, key: &str, set: SliceSet<'c>) {
        self.clear_cache();
        self.cache.insert(key.to_string(), set);
    }

    /// Drops every cached slice set (after a grid changed in place in a
    /// way [`GridStamp`] does not sample).
    pub fn clear_cache(&mut self) {
        self.evicted_dispatches += self.cache.drain().map(|(_, c)| c.dispatches()).sum::<u64>();
    }
}

/// The colour target format: Rgba32Float when the adapter can render to it
/// and blend it, else Rgba16Float; an error naming the backend and the
/// format when the adapter cannot render to a format the renderer needs
/// (GL adapters without float colour buffers), instead of wgpu's
/// validation error when the pipelines are built.
fn target_format(ctx: &GpuContext) -> Result<wgpu::TextureFormat, GpuError> {
    use wgpu::TextureFormat::{Rgba16Float, Rgba32Float};
    let can = |f: wgpu::TextureFormat, blend: bool| {
        let ff = ctx.adapter.get_texture_format_features(f);
        ff.allowed_usages
            .contains(wgpu::TextureUsages::RENDER_ATTACHMENT)
            && (!blend
                || ff
                    .flags
                    .contains(wgpu::TextureFormatFeatureFlags::BLENDABLE))
    };
    let backend = match ctx.adapter.get_info().backend {
        wgpu::Backend::Gl => "GL".to_string(),
        b => format!("{b:?}"),
    };
    let refuse = |what: String| GpuError::Unsupported {
        adapter: ctx.name.clone(),
        why: format!(
            "the {backend} backend cannot {what} on this adapter; use the Vulkan backend (Mesa's llvmpipe where there is no GPU) or the CPU path"
        ),
    };
    for f in [
        super::pre_pass::SCALAR_FORMAT,
        super::pre_pass::BOUNDARY_FORMAT,
    ] {
        if !can(f, false) {
            return Err(refuse(format!(
                "render to {f:?} targets (the renderer's per-pixel value targets)"
            )));
        }
    }
    match (
        ctx.float32_blend && can(Rgba32Float, true),
        can(Rgba16Float, true),
    ) {
        (true, _) => Ok(Rgba32Float),
        (false, true) => Ok(Rgba16Float),
        (false, false) => Err(refuse(
            "render to and blend Rgba32Float or Rgba16Float colour targets".into(),
        )),
    }
}

/// The render pass's bindings: 0 the uniform parameters, 1 the transfer
/// LUT, 2 the pre-integrated table (both storage, read only).
fn bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let entry = |binding: u32, ty: wgpu::BufferBindingType, stages: wgpu::ShaderStages| {
        wgpu::BindGroupLayoutEntry {
            binding,
            visibility: stages,
            ty: wgpu::BindingType::Buffer {
                ty,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }
    };
    let storage = wgpu::BufferBindingType::Storage { read_only: true };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("render"),
        entries: &[
            entry(
                0,
                wgpu::BufferBindingType::Uniform,
                wgpu::ShaderStages::VERTEX_FRAGMENT,
            ),
            entry(1, storage, wgpu::ShaderStages::FRAGMENT),
            entry(2, storage, wgpu::ShaderStages::FRAGMENT),
        ],
    })
}

/// The transfer function of `o` for a property range: `o.transfer`, else
/// its named colormap over the range.
pub fn transfer_for(o: &RenderOptions, range: (f64, f64)) -> Result<Transfer, RenderError> {
    match &o.transfer {
        Some(t) => Ok(t.clone()),
        None => Transfer::named(&o.colormap, range.0, range.1).ok_or_else(|| {
            RenderError::Options(format!(
                "unknown colormap '{}' (known: {})",
                o.colormap,
                COLORMAPS.join(", ")
            ))
        }),
    }
}

/// The checks of `o` before a render, shared by every front end: the shown
/// property ([`check_shown_property`]), options the mode does not use
/// ([`check_modes`]) and the transfer function ([`check_transfer`]).
/// Returns the warnings to show.
pub fn check_options(
    grid: &Grid,
    o: &RenderOptions,
    preintegrated: bool,
) -> Result<Vec<String>, RenderError> {
    check_shown_property(grid, o)?;
    check_modes(o, preintegrated)?;
    check_transfer(grid, o)
}

/// Refuses options that the mode would silently ignore: isovalues outside
/// iso mode, pre-integration outside volume mode.
pub fn check_modes(o: &RenderOptions, preintegrated: bool) -> Result<(), RenderError> {
    let mode = format!("{:?}", o.mode).to_lowercase();
    if o.mode != Mode::Iso && !o.iso.is_empty() {
        return Err(RenderError::Options(format!(
            "isovalues are drawn only in iso mode, and the mode is {mode}: choose iso mode or leave the isovalues out"
        )));
    }
    if preintegrated && o.mode != Mode::Volume {
        return Err(RenderError::Options(format!(
            "pre-integration applies only to volume mode, and the mode is {mode}: choose volume mode or leave pre-integration off"
        )));
    }
    Ok(())
}

/// Refuses a transfer function that can only draw nothing (no points;
/// every point, or every point over the shown values' range, transparent
/// outside iso mode) and an unknown colormap; warns when the transfer
/// function lies wholly outside the shown values (see
/// [`Transfer::check`]). Returns the warnings.
pub fn check_transfer(grid: &Grid, o: &RenderOptions) -> Result<Vec<String>, RenderError> {
    let Some(t) = &o.transfer else {
        transfer_for(o, (0.0, 1.0))?;
        return Ok(Vec::new());
    };
    let property = shown_property(grid, o);
    let data = match &property {
        Some(name) => property_range(grid, name).map(|r| (r, format!("property '{name}'"))),
        None => {
            let d = Vec3::from_array(o.view_dir.map(|c| c as f32));
            let axis = slicing_axis(d);
            let (lo, hi) = grid.bounds();
            Some((
                (lo[axis], hi[axis]),
                format!("the slice positions along {}", ["x", "y", "z"][axis]),
            ))
        }
    };
    let data = data.as_ref().map(|(r, what)| (*r, what.as_str()));
    Ok(t.check(o.mode == Mode::Iso, data)?)
}

/// The unit distance of the opacities in display space: `o.unit_distance`,
/// else the mean cell size of the exaggerated bounding box.
pub fn unit_distance(grid: &Grid, o: &RenderOptions, z_scale: f64) -> Result<f64, RenderError> {
    match o.unit_distance {
        Some(u) if u > 0.0 && u.is_finite() => Ok(u),
        Some(u) => Err(RenderError::Options(format!(
            "the unit distance {u} must be positive"
        ))),
        None => Ok(mean_cell_size(grid) * z_scale.cbrt()),
    }
}

/// The range of the shown values: the cell property's (rounded to f32),
/// the vertex property's, or the level values' when no property is shown.
pub(super) fn shown_range(
    grid: &Grid,
    s: &Structure,
    property: &Option<String>,
    cell_values: Option<&[f64]>,
    level_values: &[f64],
) -> Result<(f64, f64), RenderError> {
    Ok(match (property, cell_values) {
        (_, Some(v)) => {
            let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            (lo as f32 as f64, hi as f32 as f64)
        }
        (Some(name), None) => {
            let v = vertex_property(grid, s, name)?;
            let lo = v.iter().copied().fold(f32::INFINITY, f32::min) as f64;
            let hi = v.iter().copied().fold(f32::NEG_INFINITY, f32::max) as f64;
            (lo, hi)
        }
        (None, None) => (level_values[0], level_values[level_values.len() - 1]),
    })
}

/// Sweeps and emits the slices of `k` (or its isosurfaces) on `ctx`: the
/// CPU sweep finds the cut cells, the GPU emits the triangles (S-CGraph,
/// CGraph and CP-Graph; [`super::host_slices::build_slices`] takes any
/// structure). Runs on any thread (the viewer builds a new axis's slices on
/// a worker).
pub fn emit_slices<'c>(
    ctx: &'c GpuContext,
    grid: &Grid,
    s: &Structure,
    k: &SliceKey,
) -> Result<SliceSet<'c>, RenderError> {
    let property = &k.property;
    let (req, cell_values) = slice_request(grid, k);
    let span = k.clip.is_none()
        && match k.cells {
            CellFinding::Auto => !ctx.is_software(),
            CellFinding::Sweep => false,
            CellFinding::Gpu => true,
        };
    let mut p = match span {
        true => prepare_unswept(grid, s, &req)?,
        false => prepare(grid, s, &req)?,
    };
    if let Some(v) = &cell_values {
        p.grid.attr = match s {
            Structure::SCGraph(g) => slot_values(g, v),
            Structure::CGraph(g) => slot_values(g, v),
            Structure::CpGraph(g) => slot_values(g.as_ref(), v),
            // `prepare` already refused CIEL grids.
            Structure::Ciel(_) => {
                return Err(PipelineError::Unsupported(
                    "the GPU path does not take CIEL grids".into(),
                )
                .into());
            }
        };
        p.grid.attr_per_cell = true;
    }
    // Values beyond f32 (or near its limit) clamped, so that no
    // interpolation on the GPU makes a NaN (the LUT's range is clamped alike).
    let limit = super::transfer::VALUE_LIMIT;
    for a in p.grid.attr.iter_mut() {
        *a = a.clamp(-limit, limit);
    }
    let mut cp_boundary = None;
    let (field, field_fallback) = match k.attr_gradient && !k.iso {
        true => match IjkField::new(ctx, grid, s, property.as_deref()) {
            Ok((f, ijk)) => {
                if let Structure::CpGraph(g) = s {
                    // Corner-point grids: the outer surface of the graph.
                    let t = super::boundary::graph_boundary_triangles(g.as_ref(), &ijk);
                    cp_boundary = BoundaryMesh::from_triangles(&ctx.device, &t);
                }
                p.grid.grad = ijk;
                (Some(f), None)
            }
            Err(why) => (None, Some(why)),
        },
        false => (None, None),
    };
    // Pre-integrated slabs without the index-space field need the
    // attribute's gradient (not for cell values).
    let gradient_pre =
        field.is_none() && k.attr_gradient && cell_values.is_none() && !p.grid.attr.is_empty();
    if field.is_some() {
        // The slices carry (i, j, k) in place of the gradient.
    } else if k.iso {
        p.grid.grad = vertex_gradients(&p.grid);
    } else if gradient_pre {
        // The attribute's gradient: φ's slot holds the attribute meanwhile.
        let phi: Vec<f32> = p.grid.grid.iter().map(|v| v[3]).collect();
        for (v, a) in p.grid.grid.iter_mut().zip(&p.grid.attr) {
            v[3] = *a;
        }
        p.grid.grad = vertex_gradients(&p.grid);
        for (v, f) in p.grid.grid.iter_mut().zip(phi) {
            v[3] = f;
        }
    }
    let spacing = match p.level_values.as_slice() {
        [a, b, ..] => b - a,
        _ => {
            let (lo, hi) = grid.bounds();
            hi[k.axis] - lo[k.axis]
        }
    };
    let range = shown_range(grid, s, property, cell_values.as_deref(), &p.level_values)?;
    let levels = p.level_values.len() as u32;
    let base = GpuEmitter::new(ctx, p.grid)?;
    let level_values = p.frame.levels.clone();
    let frame = p.frame;
    let swept = || match span {
        // The binning does not fit: the sweep's frame after all.
        true => Ok(prepare(grid, s, &req)?.frame),
        false => Ok(frame),
    };
    let clip = |f: &mut Frame| match k.clip {
        Some(c) => clip_entries(s, c, &mut f.entries),
        None => Ok(()),
    };
    let (chunks, cut_cells) = emit_frame(&base, (span, &level_values), swept, clip)?;
    Ok(SliceSet {
        chunks,
        spacing,
        range,
        cut_cells,
        levels,
        // Only pre-integrated frames draw the outer surface (O(cells) to find
        // on unstructured grids): built for their slices alone.
        boundary: cp_boundary.or_else(|| {
            (field.is_some() || gradient_pre)
                .then(|| BoundaryMesh::new(&ctx.device, grid, k.clip))
                .flatten()
        }),
        field,
        field_fallback,
    })
}

/// The request that `k`'s slices sweep, and the cell values that colour
/// them when the shown property is a cell property (no point property of
/// that name): then each polygon is flat with its own cell's value, and
/// the request interpolates no attribute (averaging the cell values to
/// the vertices, a volume per cell, would be thrown away).
pub(super) fn slice_request(grid: &Grid, k: &SliceKey) -> (SliceRequest, Option<Vec<f64>>) {
    let cell_values: Option<Vec<f64>> = match &k.property {
        Some(n) if !k.iso && grid.point_property(n).is_none() => grid
            .cell_property(n)
            .map(|c| (0..c.len()).map(|i| c.scalar_at(i)).collect()),
        _ => None,
    };
    let req = SliceRequest {
        field: k.field.clone(),
        levels: k.levels.clone(),
        attribute: match cell_values {
            Some(_) => None,
            None => k.property.clone(),
        },
        threads: rayon::current_num_threads(),
        brute_force: false,
        collect_mesh: false,
        sweep: crate::sweep::SweepOptions {
            cancel: k.cancel.clone(),
            ..Default::default()
        },
    };
    (req, cell_values)
}

/// The slices' emitters and their cut cells: GPU span-space binning of
/// `levels` when `span`, else (or when the binning does not fit) the CPU
/// sweep's frame from `swept`, cut down by `clip`.
fn emit_frame<'c>(
    base: &GpuEmitter<'c>,
    (span, levels): (bool, &[f32]),
    swept: impl FnOnce() -> Result<Frame, RenderError>,
    clip: impl FnOnce(&mut Frame) -> Result<(), RenderError>,
) -> Result<(Vec<GpuEmitter<'c>>, u64), RenderError> {
    if span && let Some(done) = span_space(base, levels)? {
        return Ok(done);
    }
    let mut frame = swept()?;
    clip(&mut frame)?;
    let chunks = emit_chunked(base, &frame, false)?;
    let cut_cells = frame.entries.len() as u64;
    Ok((chunks.into_iter().map(|c| c.0).collect(), cut_cells))
}

/// Every level of `levels` emitted after GPU span-space binning, in one
/// emitter, with the number of cut cells; `None` when that does not fit (a
/// grid split into parts, a frame over the device's limits).
fn span_space<'c>(
    base: &GpuEmitter<'c>,
    levels: &[f32],
) -> Result<Option<(Vec<GpuEmitter<'c>>, u64)>, GpuError> {
    let mut e = base.fork();
    match e.run_span(levels, false) {
        Ok(n) => Ok(Some((vec![e], n as u64))),
        Err(GpuError::FrameTooLarge { .. } | GpuError::Unsupported { .. }) => Ok(None),
        Err(err) => Err(err),
    }
}

/// Keeps the cut cells inside the IJK box `c` (S-CGraph grids only).
fn clip_entries(
    s: &Structure,
    c: super::boundary::IjkBox,
    entries: &mut Vec<super::shared::Entry>,
) -> Result<(), RenderError> {
    let Structure::SCGraph(g) = s else {
        return Err(RenderError::Options(
            "IJK clipping needs an IJK (structured) grid".into(),
        ));
    };
    // Slot of cell (i, j, k): i + j·npi + (k + 1)·npi·npj (see `scgraph`).
    let [npi, npj, _] = g.dims;
    entries.retain(|e| {
        let v = e.slot as usize - npi * npj;
        let ijk = [v % npi, (v / npi) % npj, v / (npi * npj)];
        (0..3).all(|a| c[a][0] <= ijk[a] && ijk[a] < c[a][1])
    });
    Ok(())
}

/// Mean cell size: the cube root of the bounding-box volume per cell
/// (the default unit distance of the opacities).
pub fn mean_cell_size(grid: &Grid) -> f64 {
    let (lo, hi) = grid.bounds();
    let v: f64 = (0..3).map(|a| (hi[a] - lo[a]).max(1e-30)).product();
    (v / grid.cell_count().max(1) as f64).cbrt()
}

pub(super) fn f16_to_f32(h: u16) -> f32 {
    let s = ((h >> 15) as u32) << 31;
    let e = (h >> 10 & 0x1f) as u32;
    let m = (h & 0x3ff) as u32;
    let bits = match (e, m) {
        (0, 0) => s,
        (0, _) => {
            // Subnormal: normalise.
            let mut e = 127 - 15 + 1;
            let mut m = m;
            while m & 0x400 == 0 {
                m <<= 1;
                e -= 1;
            }
            s | (e as u32) << 23 | (m & 0x3ff) << 13
        }
        (0x1f, _) => s | 0xff << 23 | m << 13,
        _ => s | (e + 127 - 15) << 23 | m << 13,
    };
    f32::from_bits(bits)
}
