//! Volume rendering by slicing (DESIGN §5) and isosurfaces, offscreen.
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

use glam::{Mat4, Vec3};
use serde::Deserialize;
use thiserror::Error;

use crate::field::FieldSpec;
use crate::grid::Grid;
use crate::pipeline::{LevelSpec, PipelineError, SliceRequest, Structure, vertex_property};

use super::context::{GpuContext, GpuError};
use super::emit::{GpuEmitter, emit_chunked};
use super::gradient::vertex_gradients;
use super::shaders;
use super::shared::{ARGS_WORDS, ControlLayout, OutVertex, RenderParams};
use super::slice::prepare;
use super::tables::slot_values;

/// Entries of the transfer-function lookup table (`LUT_SIZE` in `wgsl/render.wgsl`).
pub const LUT_SIZE: usize = 256;

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

/// One control point of a transfer function.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
pub struct TransferPoint {
    /// Property value.
    pub value: f64,
    /// Straight RGB in [0, 1].
    pub color: [f32; 3],
    /// Opacity per unit distance in [0, 1].
    pub opacity: f32,
}

/// A piecewise-linear transfer function (clamped outside its points).
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct Transfer {
    /// Control points, sorted by value.
    pub points: Vec<TransferPoint>,
}

/// (position in [0, 1], RGB) anchors of the named colormaps.
fn colormap(name: &str) -> Option<Vec<(f64, [f32; 3])>> {
    let hex = |h: u32| {
        [
            (h >> 16 & 255) as f32 / 255.0,
            (h >> 8 & 255) as f32 / 255.0,
            (h & 255) as f32 / 255.0,
        ]
    };
    let anchors = |c: &[u32]| {
        c.iter()
            .enumerate()
            .map(|(i, &h)| (i as f64 / (c.len() - 1) as f64, hex(h)))
            .collect()
    };
    Some(match name {
        "viridis" => anchors(&[0x440154, 0x3b528b, 0x21918c, 0x5ec962, 0xfde725]),
        "magma" => anchors(&[0x000004, 0x51127c, 0xb73779, 0xfc8961, 0xfcfdbf]),
        "coolwarm" => anchors(&[0x3b4cc0, 0x8db0fe, 0xdddddd, 0xf49a7b, 0xb40426]),
        "greys" => anchors(&[0xffffff, 0x000000]),
        _ => return None,
    })
}

/// Names accepted by [`Transfer::named`].
pub const COLORMAPS: [&str; 4] = ["viridis", "magma", "coolwarm", "greys"];

impl Transfer {
    /// A named colormap over `[lo, hi]` with opacity rising linearly from 0 to 1.
    pub fn named(name: &str, lo: f64, hi: f64) -> Option<Self> {
        let a = colormap(name)?;
        Some(Transfer {
            points: a
                .into_iter()
                .map(|(x, color)| TransferPoint {
                    value: lo + x * (hi - lo),
                    color,
                    opacity: x as f32,
                })
                .collect(),
        })
    }

    /// Parses `{"points":[{"value":v,"color":[r,g,b],"opacity":a},...]}`.
    pub fn from_json(text: &str) -> Result<Self, RenderError> {
        let mut t: Transfer = serde_json::from_str(text)
            .map_err(|e| RenderError::Options(format!("transfer function JSON: {e}")))?;
        for p in &t.points {
            let ok = p.value.is_finite()
                && p.color.iter().all(|c| (0.0..=1.0).contains(c))
                && (0.0..=1.0).contains(&p.opacity);
            if !ok {
                return Err(RenderError::Options(format!(
                    "transfer point {p:?}: value must be finite, color and opacity in [0, 1]"
                )));
            }
        }
        t.points.sort_by(|a, b| a.value.total_cmp(&b.value));
        Ok(t)
    }

    /// RGBA at `v` (straight colour), clamped outside the points;
    /// transparent black when there are no points.
    pub fn eval(&self, v: f64) -> [f32; 4] {
        let p = &self.points;
        let rgba = |q: &TransferPoint| [q.color[0], q.color[1], q.color[2], q.opacity];
        match p.len() {
            0 => [0.0; 4],
            _ if v <= p[0].value => rgba(&p[0]),
            _ if v >= p[p.len() - 1].value => rgba(&p[p.len() - 1]),
            _ => {
                let i = p.windows(2).position(|w| v <= w[1].value).unwrap_or(0);
                let (a, b) = (&p[i], &p[i + 1]);
                let f = if b.value > a.value {
                    ((v - a.value) / (b.value - a.value)) as f32
                } else {
                    1.0
                };
                let (x, y) = (rgba(a), rgba(b));
                std::array::from_fn(|c| x[c] + f * (y[c] - x[c]))
            }
        }
    }

    /// Its lookup table over its own value range: (`LUT_SIZE` RGBA, lo, hi).
    pub fn lut(&self) -> (Vec<[f32; 4]>, f64, f64) {
        let (lo, hi) = match (self.points.first(), self.points.last()) {
            (Some(a), Some(b)) => (a.value, b.value),
            _ => (0.0, 1.0),
        };
        let lut = (0..LUT_SIZE)
            .map(|i| self.eval(lo + (hi - lo) * i as f64 / (LUT_SIZE - 1) as f64))
            .collect();
        (lut, lo, hi)
    }
}

/// What to render.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Property shown (default: the grid's first point property).
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

/// Triangles of one (axis or iso, count, property) on the GPU.
struct Cached<'c> {
    /// Level chunks (one unless the frame exceeded a storage binding), in level order.
    chunks: Vec<GpuEmitter<'c>>,
    /// Slice spacing along the axis (volume), 0 for iso.
    spacing: f64,
    /// Range of the shown values.
    range: (f64, f64),
}

/// The offscreen renderer with its cache of slices.
pub struct Renderer<'c> {
    ctx: &'c GpuContext,
    format: wgpu::TextureFormat,
    layout: wgpu::BindGroupLayout,
    blend: wgpu::RenderPipeline,
    iso: wgpu::RenderPipeline,
    cache: HashMap<String, Cached<'c>>,
    /// Compute dispatches of evicted cache entries.
    evicted_dispatches: u64,
}

const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

impl<'c> Renderer<'c> {
    /// Builds the render pipelines (Rgba32Float target when the adapter can
    /// blend it, else Rgba16Float).
    pub fn new(ctx: &'c GpuContext) -> Result<Self, RenderError> {
        let format = if ctx.float32_blend {
            wgpu::TextureFormat::Rgba32Float
        } else {
            wgpu::TextureFormat::Rgba16Float
        };
        let src = shaders::render_source();
        shaders::validate("render.wgsl", &src)
            .map_err(|e| GpuError::Device(format!("invalid shader {e}")))?;
        let module = ctx
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("render.wgsl"),
                source: wgpu::ShaderSource::Wgsl(src.into()),
            });
        let layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("render"),
                entries: &[
                    wgpu::BindGroupLayoutEntry {
                        binding: 0,
                        visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                        ty: wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Uniform,
                            has_dynamic_offset: false,
                            min_binding_size: None,
                        },
                        count: None,
                    },
                    wgpu::BindGroupLayoutEntry {
                        binding: 1,
                        visibility: wgpu::ShaderStages::FRAGMENT,
                        ty: wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Storage { read_only: true },
                            has_dynamic_offset: false,
                            min_binding_size: None,
                        },
                        count: None,
                    },
                ],
            });
        let pl = ctx
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("render"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        let attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32];
        let normal_attrs = wgpu::vertex_attr_array![2 => Float32x3];
        let vertices = wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<OutVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &attrs,
        };
        // The emit pass's normals: one vec4<f32> per corner.
        let normals = wgpu::VertexBufferLayout {
            array_stride: 16,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &normal_attrs,
        };
        let slice_buffers = [Some(vertices.clone())];
        let iso_buffers = [Some(vertices), Some(normals)];
        let make = |blend: Option<wgpu::BlendState>, depth: bool| {
            let (entry, buffers): (&str, &[Option<wgpu::VertexBufferLayout>]) = if depth {
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
                        entry_point: Some("fs"),
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
        let blend = make(Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING), false);
        let iso = make(None, true);
        ctx.check()?;
        Ok(Renderer {
            ctx,
            format,
            layout,
            blend,
            iso,
            cache: HashMap::new(),
            evicted_dispatches: 0,
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

    /// Renders `grid` (with its built structure `s`).
    pub fn render(
        &mut self,
        grid: &Grid,
        s: &Structure,
        o: &RenderOptions,
    ) -> Result<Image, RenderError> {
        let d = Vec3::from_array(o.view_dir.map(|c| c as f32));
        if !d.is_finite() || d.length() <= 0.0 {
            return Err(RenderError::Options(
                "--view-dir must be a non-zero vector".into(),
            ));
        }
        let d = d.normalize();
        let (w, h) = o.size;
        if w == 0
            || h == 0
            || w > self.ctx.limits.max_texture_dimension_2d
            || h > self.ctx.limits.max_texture_dimension_2d
        {
            return Err(RenderError::Options(format!(
                "--size {w}x{h}: each side must be 1..={}",
                self.ctx.limits.max_texture_dimension_2d
            )));
        }
        let property = o
            .property
            .clone()
            .or_else(|| grid.point_data.first().map(|p| p.name.clone()))
            .or_else(|| grid.cell_data.first().map(|p| p.name.clone()));
        let axis = (0..3)
            .max_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs()))
            .unwrap_or(2);
        let (key, field, levels) = match o.mode {
            Mode::Iso => {
                let Some(p) = &property else {
                    return Err(RenderError::Options(
                        "iso mode needs a point or cell property".into(),
                    ));
                };
                if o.iso.is_empty() {
                    return Err(RenderError::Options("iso mode needs --iso VALUES".into()));
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
                    return Err(RenderError::Options("--slices must be at least 1".into()));
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
        if !self.cache.contains_key(&key) {
            let req = SliceRequest {
                field,
                levels,
                attribute: property.clone(),
                threads: rayon::current_num_threads(),
                brute_force: false,
                collect_mesh: false,
            };
            let mut p = prepare(grid, s, &req)?;
            // A cell property (no point property of that name) colours
            // each slice polygon flat with its own cell's value.
            let cell_values: Option<Vec<f64>> = match &property {
                Some(n) if o.mode != Mode::Iso && grid.point_property(n).is_none() => grid
                    .cell_property(n)
                    .map(|c| (0..c.len()).map(|i| c.scalar_at(i)).collect()),
                _ => None,
            };
            if let Some(v) = &cell_values {
                p.grid.attr = match s {
                    Structure::SCGraph(g) => slot_values(g, v),
                    Structure::CGraph(g) => slot_values(g, v),
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
            if o.mode == Mode::Iso {
                p.grid.grad = vertex_gradients(&p.grid);
            }
            let spacing = match p.level_values.as_slice() {
                [a, b, ..] => b - a,
                _ => {
                    let (lo, hi) = grid.bounds();
                    hi[axis] - lo[axis]
                }
            };
            let range = match (&property, &cell_values) {
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
                (None, None) => {
                    let l = &p.level_values;
                    (l[0], l[l.len() - 1])
                }
            };
            let base = GpuEmitter::new(self.ctx, p.grid)?;
            let chunks = emit_chunked(&base, &p.frame, false)?
                .into_iter()
                .map(|c| c.0)
                .collect();
            // Keep one entry: another axis cone or property replaces it.
            self.evicted_dispatches += self
                .cache
                .drain()
                .flat_map(|(_, c)| c.chunks)
                .map(|e| e.dispatches)
                .sum::<u64>();
            self.cache.insert(
                key.clone(),
                Cached {
                    chunks,
                    spacing,
                    range,
                },
            );
        }
        let c = &self.cache[&key];
        let transfer = match &o.transfer {
            Some(t) => t.clone(),
            None => Transfer::named(&o.colormap, c.range.0, c.range.1).ok_or_else(|| {
                RenderError::Options(format!(
                    "unknown colormap '{}' (known: {COLORMAPS:?})",
                    o.colormap
                ))
            })?,
        };
        let unit = match o.unit_distance {
            Some(u) if u > 0.0 && u.is_finite() => u,
            Some(u) => {
                return Err(RenderError::Options(format!(
                    "--unit-distance {u} must be positive"
                )));
            }
            None => mean_cell_size(grid),
        };
        self.draw(grid, c, &transfer, d, axis, unit, o)
    }

    #[allow(clippy::too_many_arguments)]
    fn draw(
        &self,
        grid: &Grid,
        c: &Cached,
        transfer: &Transfer,
        d: Vec3,
        axis: usize,
        unit: f64,
        o: &RenderOptions,
    ) -> Result<Image, RenderError> {
        let ctx = self.ctx;
        let (w, h) = o.size;
        let (lo, hi) = grid.bounds();
        let ext = Vec3::new(
            (hi[0] - lo[0]) as f32,
            (hi[1] - lo[1]) as f32,
            (hi[2] - lo[2]) as f32,
        );
        let up = match o.up {
            Some(u) => Vec3::from_array(u.map(|c| c as f32)),
            None if d.z.abs() > 0.99 => Vec3::Y,
            None => Vec3::Z,
        };
        if up.cross(d).length() < 1e-6 {
            return Err(RenderError::Options(
                "--up must not be parallel to --view-dir".into(),
            ));
        }
        let aspect = w as f32 / h as f32;
        let (view_proj, eye) = frame_camera(
            &grid.points,
            grid.origin(),
            ext,
            d,
            up,
            aspect,
            o.perspective,
        );
        let mut axis_v = [0f32; 4];
        axis_v[axis] = 1.0;
        let (lut, vlo, vhi) = transfer.lut();
        let mode = match o.mode {
            Mode::Volume => 0,
            Mode::Slices => 1,
            Mode::Iso => 2,
        };
        let params = RenderParams {
            view_proj: view_proj.to_cols_array_2d(),
            eye: [eye.x, eye.y, eye.z, 1.0],
            view_dir: [d.x, d.y, d.z, 0.0],
            axis: axis_v,
            value_lo: vlo as f32,
            value_hi: vhi as f32,
            spacing_over_unit: (c.spacing / unit) as f32,
            perspective: o.perspective as u32,
            mode,
            ..Default::default()
        };
        use wgpu::util::DeviceExt;
        let ub = ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("render params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM,
            });
        let lb = ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("lut"),
                contents: bytemuck::cast_slice(&lut),
                usage: wgpu::BufferUsages::STORAGE,
            });
        let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("render"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: ub.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: lb.as_entire_binding(),
                },
            ],
        });
        let size = wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        };
        let target = ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("target"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: self.format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let tv = target.create_view(&Default::default());
        let depth = (o.mode == Mode::Iso).then(|| {
            ctx.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("depth"),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: DEPTH,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            })
        });
        let dv = depth.as_ref().map(|t| t.create_view(&Default::default()));
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("slices"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &tv,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: dv.as_ref().map(|v| {
                    wgpu::RenderPassDepthStencilAttachment {
                        view: v,
                        depth_ops: Some(wgpu::Operations {
                            load: wgpu::LoadOp::Clear(1.0),
                            store: wgpu::StoreOp::Discard,
                        }),
                        stencil_ops: None,
                    }
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(if o.mode == Mode::Iso {
                &self.iso
            } else {
                &self.blend
            });
            pass.set_bind_group(0, &bg, &[]);
            // Levels increase along +axis: looking toward +axis, the far
            // slices are the high ones, so draw in decreasing order.
            let reverse = d[axis] > 0.0 && o.mode != Mode::Iso;
            let chunks: Vec<&GpuEmitter> = if reverse {
                c.chunks.iter().rev().collect()
            } else {
                c.chunks.iter().collect()
            };
            for e in chunks {
                let k = e.level_count;
                if let (Some(vb), Some(cb), true) =
                    (e.vertex_buffer(), e.control_buffer(), e.triangles > 0)
                {
                    pass.set_vertex_buffer(0, vb.slice(..));
                    if o.mode == Mode::Iso {
                        match e.normal_buffer() {
                            Some(nb) if e.has_normals() => pass.set_vertex_buffer(1, nb.slice(..)),
                            _ => {
                                return Err(RenderError::Options(
                                    "iso mode: the slices carry no normals".into(),
                                ));
                            }
                        }
                    }
                    let lay = ControlLayout { k };
                    let first = if reverse {
                        lay.args_rev()
                    } else {
                        lay.args_fwd()
                    };
                    debug_assert_eq!(lay.args_rev(), ARGS_WORDS * k);
                    pass.multi_draw_indirect(cb, first as u64 * 4, k);
                }
            }
        }
        let bpr = (w * 16).div_ceil(256) * 256;
        let texel = if self.format == wgpu::TextureFormat::Rgba32Float {
            16
        } else {
            8
        };
        let bpr = if texel == 16 {
            bpr
        } else {
            (w * 8).div_ceil(256) * 256
        };
        let rb = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("image"),
            size: bpr as u64 * h as u64,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &target,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &rb,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(bpr),
                    rows_per_image: Some(h),
                },
            },
            size,
        );
        ctx.queue.submit([enc.finish()]);
        let bytes = ctx.read_buffer(&rb, bpr as u64 * h as u64)?;
        let bg_p = o
            .background
            .map_or([0.0; 4], |b| [b[0] * b[3], b[1] * b[3], b[2] * b[3], b[3]]);
        let mut px = Vec::with_capacity((w * h) as usize);
        for y in 0..h as usize {
            let row = &bytes[y * bpr as usize..];
            for x in 0..w as usize {
                let c: [f32; 4] = if texel == 16 {
                    std::array::from_fn(|i| {
                        let o = x * 16 + 4 * i;
                        f32::from_le_bytes([row[o], row[o + 1], row[o + 2], row[o + 3]])
                    })
                } else {
                    std::array::from_fn(|i| {
                        let o = x * 8 + 2 * i;
                        f16_to_f32(u16::from_le_bytes([row[o], row[o + 1]]))
                    })
                };
                let t = 1.0 - c[3];
                px.push(std::array::from_fn(|i| c[i] + t * bg_p[i]));
            }
        }
        Ok(Image {
            width: w,
            height: h,
            premultiplied: px,
        })
    }
}

/// Margin around the projected grid: the window is 5 % wider (or taller)
/// than the side of the projected points that limits the fit.
pub const FRAME_MARGIN: f32 = 1.05;

/// Extents of the points in view coordinates: (min, max) along the right
/// vector `s` and the up vector `u`, and the perspective eye distance that
/// fits every point in a window of half-slopes `tx`, `ty`.
fn view_extents(
    points: &[[f64; 3]],
    origin: [f64; 3],
    s: Vec3,
    u: Vec3,
    d: Vec3,
    tx: f32,
    ty: f32,
) -> [f32; 5] {
    use rayon::prelude::*;
    let init = || {
        [
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NEG_INFINITY,
        ]
    };
    points
        .par_iter()
        .fold(init, |mut acc, p| {
            let q = Vec3::new(
                (p[0] - origin[0]) as f32,
                (p[1] - origin[1]) as f32,
                (p[2] - origin[2]) as f32,
            );
            let (x, y) = (q.dot(s), q.dot(u));
            acc[0] = acc[0].min(x);
            acc[1] = acc[1].max(x);
            acc[2] = acc[2].min(y);
            acc[3] = acc[3].max(y);
            // depth = dist + q·d must reach |x|·m / tx and |y|·m / ty.
            let dist = (x.abs() * FRAME_MARGIN / tx).max(y.abs() * FRAME_MARGIN / ty) - q.dot(d);
            acc[4] = acc[4].max(dist);
            acc
        })
        .reduce(init, |a, b| {
            [
                a[0].min(b[0]),
                a[1].max(b[1]),
                a[2].min(b[2]),
                a[3].max(b[3]),
                a[4].max(b[4]),
            ]
        })
}

/// The camera that frames a grid tightly: its `points` (world), rebased to
/// `origin` (the bounding-box centre, the local frame's origin), with
/// bounding-box extents `ext`, seen along the unit vector `d` with `up`.
/// Returns the world (local frame) → clip matrix and the eye position.
///
/// Orthographic: the window is the projected points' extent, centred on
/// it, widened to the image aspect and enlarged by [`FRAME_MARGIN`] (so a
/// rotated grid fills the image, not its axis-aligned box). Perspective
/// (30° field of view across the smaller image side, looking at the
/// bounding-box centre): the eye is placed at the smallest distance at
/// which every point projects inside the window. Without points the
/// bounding box's corners are framed.
pub fn frame_camera(
    points: &[[f64; 3]],
    origin: [f64; 3],
    ext: Vec3,
    d: Vec3,
    up: Vec3,
    aspect: f32,
    perspective: bool,
) -> (Mat4, Vec3) {
    let r = (0.5 * ext.length()).max(1e-6);
    let s = d.cross(up).normalize();
    let u = s.cross(d);
    let fov = 30f32.to_radians();
    let fov_y = if aspect >= 1.0 {
        fov
    } else {
        2.0 * ((0.5 * fov).tan() / aspect).atan()
    };
    let ty = (0.5 * fov_y).tan();
    let tx = ty * aspect;
    let corners: Vec<[f64; 3]>;
    let pts = if points.is_empty() {
        corners = (0..8)
            .map(|i| {
                let sign = |b: usize| if i >> b & 1 == 1 { 0.5 } else { -0.5 };
                let c = ext * Vec3::new(sign(0), sign(1), sign(2));
                [0, 1, 2].map(|a| origin[a] + c[a] as f64)
            })
            .collect();
        &corners[..]
    } else {
        points
    };
    let [x0, x1, y0, y1, fit] = view_extents(pts, origin, s, u, d, tx, ty);
    let tiny = 1e-6 * r;
    if perspective {
        // The eye stays outside the bounding sphere's depth.
        let hz = (0..8)
            .map(|i| {
                let sign = |b: usize| if i >> b & 1 == 1 { 0.5 } else { -0.5 };
                (ext * Vec3::new(sign(0), sign(1), sign(2))).dot(d).abs()
            })
            .fold(tiny, f32::max);
        let dist = fit.max(1.05 * hz + tiny);
        let eye = -d * dist;
        let view = look_at_rh(eye, Vec3::ZERO, up);
        let near = (0.9 * (dist - hz)).max(1e-3 * r);
        let far = 1.1 * (dist + hz);
        (perspective_rh(fov_y, aspect, near, far) * view, eye)
    } else {
        let eye = -d * (3.0 * r);
        let view = look_at_rh(eye, Vec3::ZERO, up);
        let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
        let (hx, hy) = ((0.5 * (x1 - x0)).max(tiny), (0.5 * (y1 - y0)).max(tiny));
        let (hw, hh) = if hx > hy * aspect {
            (hx * FRAME_MARGIN, hx * FRAME_MARGIN / aspect)
        } else {
            (hy * FRAME_MARGIN * aspect, hy * FRAME_MARGIN)
        };
        let proj = orthographic_rh(cx - hw, cx + hw, cy - hh, cy + hh, 1.5 * r, 4.5 * r);
        (proj * view, eye)
    }
}

/// Right-handed view matrix looking from `eye` at `at`.
fn look_at_rh(eye: Vec3, at: Vec3, up: Vec3) -> Mat4 {
    let f = (at - eye).normalize();
    let s = f.cross(up).normalize();
    let u = s.cross(f);
    Mat4::from_cols(
        glam::Vec4::new(s.x, u.x, -f.x, 0.0),
        glam::Vec4::new(s.y, u.y, -f.y, 0.0),
        glam::Vec4::new(s.z, u.z, -f.z, 0.0),
        glam::Vec4::new(-s.dot(eye), -u.dot(eye), f.dot(eye), 1.0),
    )
}

/// Right-handed perspective projection to wgpu clip space (depth 0..1).
fn perspective_rh(fov_y: f32, aspect: f32, near: f32, far: f32) -> Mat4 {
    let h = 1.0 / (0.5 * fov_y).tan();
    let r = far / (near - far);
    Mat4::from_cols(
        glam::Vec4::new(h / aspect, 0.0, 0.0, 0.0),
        glam::Vec4::new(0.0, h, 0.0, 0.0),
        glam::Vec4::new(0.0, 0.0, r, -1.0),
        glam::Vec4::new(0.0, 0.0, r * near, 0.0),
    )
}

/// Right-handed orthographic projection to wgpu clip space (depth 0..1).
fn orthographic_rh(l: f32, r: f32, b: f32, t: f32, near: f32, far: f32) -> Mat4 {
    let rl = 1.0 / (r - l);
    let tb = 1.0 / (t - b);
    let nf = 1.0 / (near - far);
    Mat4::from_cols(
        glam::Vec4::new(2.0 * rl, 0.0, 0.0, 0.0),
        glam::Vec4::new(0.0, 2.0 * tb, 0.0, 0.0),
        glam::Vec4::new(0.0, 0.0, nf, 0.0),
        glam::Vec4::new(-(l + r) * rl, -(t + b) * tb, near * nf, 1.0),
    )
}

/// Mean cell size: the cube root of the bounding-box volume per cell
/// (the default unit distance of the opacities).
pub fn mean_cell_size(grid: &Grid) -> f64 {
    let (lo, hi) = grid.bounds();
    let v: f64 = (0..3).map(|a| (hi[a] - lo[a]).max(1e-30)).product();
    (v / grid.cell_count().max(1) as f64).cbrt()
}

fn f16_to_f32(h: u16) -> f32 {
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
