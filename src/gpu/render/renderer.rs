//! The [`Renderer`]: its pipelines, its cache of slices and every way it
//! draws them, offscreen ([`Renderer::render`] slices, or reuses the cached
//! slices of, the axis the view needs, fits `render`'s camera and reads one
//! image back) or into the viewer's target ([`Renderer::encode_sets`]): one
//! renderer, two targets.
//!
//! Volume and slices modes: the grid is sliced along the world axis most
//! parallel to the view direction (`argmax |d·e_i|`); the slices' triangles
//! come from [`GpuEmitter`] and are drawn far to near with one
//! `multi_draw_indirect` over the emitter's per-level draw arguments
//! (increasing or decreasing order), blended with premultiplied "over" into
//! a float target. Opacity is per unit distance U:
//! `α' = 1 − (1 − α)^(Δ / (U |cos θ|))` with Δ the slice spacing and θ the
//! angle between the ray and the axis. Iso mode draws the isosurfaces of
//! the isovalues opaque, lit, with a depth test.

use std::collections::HashMap;

use glam::Vec3;
use wgpu::util::DeviceExt;

use crate::gpu::compute::emit::GpuEmitter;
use crate::gpu::context::{GpuContext, GpuError};
use crate::gpu::shaders;
use crate::gpu::shared::{ARGS_WORDS, ControlLayout, RenderParams};
use crate::grid::Grid;
use crate::pipeline::PipelineError;
use crate::structures::Structure;

use super::camera::{fit_camera, slicing_axis};
use super::checks::check_transfer;
use super::error::RenderError;
use super::frame_setup::{DrawBindings, FrameSetup};
use super::host_slices::build_slices;
use super::image::{Image, f16_to_f32};
use super::options::{Mode, RenderOptions, transfer_for, unit_distance};
use super::preintegrated::pass::{
    BOUNDARY_FORMAT, DEPTH_FORMAT, PreDraw, PrePipeline, SCALAR_FORMAT, ScalarTargets, encode_pre,
};
use super::preintegrated::table::PRE_SIZE;
use super::shown::check_shown_property;
use super::slice_cache::{GridStamp, SliceId, SliceSet, slice_key};
use super::transfer::{LUT_VEC4S, Transfer};

/// The offscreen renderer with its cache of slices.
pub struct Renderer<'c> {
    ctx: &'c GpuContext,
    format: wgpu::TextureFormat,
    layout: wgpu::BindGroupLayout,
    blend: wgpu::RenderPipeline,
    iso: wgpu::RenderPipeline,
    /// Volume mode with pre-integrated slabs (one pass per slice).
    pre: PrePipeline,
    preintegrated: bool,
    cache: HashMap<SliceId, SliceSet<'c>>,
    /// What the cached slices were built from (see [`GridStamp`]).
    stamp: Option<GridStamp>,
    /// Compute dispatches of evicted cache entries.
    evicted_dispatches: u64,
    /// Checked by [`Renderer::render`] before slicing and before drawing.
    pub cancel: crate::cancel::Cancel,
}

/// The depth format of the iso pass and of the outer surface's passes.
pub(super) const DEPTH: wgpu::TextureFormat = DEPTH_FORMAT;

/// A float colour target (and a depth target for iso mode) of one size.
pub struct OffscreenTarget {
    /// The colour texture (the renderer's format).
    pub color: wgpu::Texture,
    /// Its view.
    pub view: wgpu::TextureView,
    /// Depth view.
    pub depth: wgpu::TextureView,
    /// Size in pixels.
    pub size: (u32, u32),
    /// The per-slice scalar targets of the pre-integrated pass.
    pub scalars: ScalarTargets,
}

impl<'c> Renderer<'c> {
    /// Builds the render pipelines (Rgba32Float target when the adapter can
    /// blend it, else Rgba16Float).
    pub fn new(ctx: &'c GpuContext) -> Result<Self, RenderError> {
        let format = target_format(ctx)?;
        let src = shaders::render_source(shaders::SLICES);
        let module = shaders::module(&ctx.device, "slices.wgsl", &src)?;
        let layout = bind_group_layout(&ctx.device);
        let pl = ctx
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("render"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        let vertices = crate::gpu::shared::out_vertex_layout();
        let normals = crate::gpu::shared::normal_layout();
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
        let pre = PrePipeline::new(&ctx.device, &layout, format)?;
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
    pub fn slices(&self, key: &SliceId) -> Option<&SliceSet<'c>> {
        self.cache.get(key)
    }

    /// Caches `set` under `key`, replacing (evicting) every other entry:
    /// one axis cone or property at a time.
    pub fn insert(&mut self, key: &SliceId, set: SliceSet<'c>) {
        self.clear_cache();
        self.cache.insert(key.clone(), set);
    }

    /// Drops every cached slice set (after a grid changed in place in a
    /// way [`GridStamp`] does not sample).
    pub fn clear_cache(&mut self) {
        self.evicted_dispatches += self.cache.drain().map(|(_, c)| c.dispatches()).sum::<u64>();
    }

    /// Renders `grid` (with its built structure `s`).
    pub fn render(
        &mut self,
        grid: &Grid,
        s: &Structure,
        o: &RenderOptions,
    ) -> Result<Image, RenderError> {
        self.render_exaggerated(grid, s, o, 1.0)
    }

    /// Renders `grid` with its z multiplied by `z_scale` for display
    /// (vertical exaggeration; opacities and the unit distance are taken
    /// in that display space).
    pub fn render_exaggerated(
        &mut self,
        grid: &Grid,
        s: &Structure,
        o: &RenderOptions,
        z_scale: f64,
    ) -> Result<Image, RenderError> {
        let d = Vec3::from_array(o.view_dir.map(|c| c as f32));
        if !d.is_finite() || d.length() <= 0.0 {
            return Err(RenderError::Options(
                "the view direction must be a non-zero vector".into(),
            ));
        }
        if !(z_scale.is_finite() && z_scale > 0.0) {
            return Err(RenderError::Options(format!(
                "the z-scale {z_scale} must be positive"
            )));
        }
        let d = d.normalize();
        let (w, h) = o.size;
        if w == 0
            || h == 0
            || w > self.ctx.limits.max_texture_dimension_2d
            || h > self.ctx.limits.max_texture_dimension_2d
        {
            return Err(RenderError::Options(format!(
                "image size {w}x{h}: each side must be 1..={}",
                self.ctx.limits.max_texture_dimension_2d
            )));
        }
        let stamp = GridStamp::of(grid, s);
        if self.stamp != Some(stamp) {
            // Another grid or structure: its slices are not these.
            self.clear_cache();
            self.stamp = Some(stamp);
        }
        check_shown_property(grid, o)?;
        check_transfer(grid, o)?;
        let axis = slicing_axis(d);
        let mut k = slice_key(grid, o, axis)?;
        // The sweep stops between levels when the render is cancelled.
        k.cancel = self.cancel.clone();
        if self.preintegrated && o.mode == Mode::Volume {
            k = k.with_attr_gradient();
        }
        let stop = |c: &crate::cancel::Cancel| c.check().map_err(PipelineError::from);
        if !self.cache.contains_key(&k.key) {
            stop(&self.cancel)?;
            let set = build_slices(self.ctx, grid, s, &k)?;
            self.insert(&k.key, set);
        }
        let c = &self.cache[&k.key];
        let transfer = transfer_for(o, c.range)?;
        let unit = unit_distance(grid, o, z_scale)?;
        let cam = fit_camera(grid, o, z_scale)?;
        let frame = FrameSetup {
            camera: cam,
            axis,
            unit,
            mode: o.mode,
            lod: 1,
            preintegrated: self.preintegrated,
        };
        stop(&self.cancel)?;
        self.draw_image(c, &transfer, &frame, o.size, o.background)
    }

    /// Uniform and LUT buffers with their bind group.
    pub fn bindings(&self) -> DrawBindings {
        let dev = &self.ctx.device;
        let params = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("render params"),
            size: std::mem::size_of::<RenderParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let zeros = |label: &str, bytes: usize| {
            dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: &vec![0u8; bytes],
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            })
        };
        let lut = zeros("lut", LUT_VEC4S * 16);
        let pre = zeros("pre-integrated table", PRE_SIZE * PRE_SIZE * 16);
        let group = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("render"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: lut.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: pre.as_entire_binding(),
                },
            ],
        });
        DrawBindings {
            params,
            lut,
            pre,
            group,
            pre_for: Default::default(),
        }
    }

    /// A colour (+ depth) target of `size`, readable back.
    pub fn target(&self, size: (u32, u32)) -> OffscreenTarget {
        let dev = &self.ctx.device;
        let extent = wgpu::Extent3d {
            width: size.0,
            height: size.1,
            depth_or_array_layers: 1,
        };
        let color = dev.create_texture(&wgpu::TextureDescriptor {
            label: Some("target"),
            size: extent,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: self.format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let depth = dev.create_texture(&wgpu::TextureDescriptor {
            label: Some("depth"),
            size: extent,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: DEPTH,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        });
        OffscreenTarget {
            scalars: ScalarTargets::new(dev, &self.pre, size),
            view: color.create_view(&Default::default()),
            depth: depth.create_view(&Default::default()),
            color,
            size,
        }
    }

    /// Records the pass that clears `target` to transparent and draws `set`
    /// far to near (volume, slices) or depth-tested (iso) with `bindings`.
    pub fn encode_slices(
        &self,
        enc: &mut wgpu::CommandEncoder,
        target: &OffscreenTarget,
        set: &SliceSet,
        bindings: &DrawBindings,
        frame: &FrameSetup,
    ) -> Result<(), RenderError> {
        self.encode_sets(enc, target, &[set], bindings, frame)
    }

    /// [`Self::encode_slices`] over several sets in one pass, in order (the
    /// viewer's isosurfaces, one set per isovalue); the pre-integrated
    /// path draws the first set only.
    pub fn encode_sets(
        &self,
        enc: &mut wgpu::CommandEncoder,
        target: &OffscreenTarget,
        sets: &[&SliceSet],
        bindings: &DrawBindings,
        frame: &FrameSetup,
    ) -> Result<(), RenderError> {
        let Some(&set) = sets.first() else {
            return Err(RenderError::Options("no slices to draw".into()));
        };
        let iso = frame.mode == Mode::Iso;
        let pre = frame.uses_pre(set);
        // Levels increase along +axis: looking toward +axis, the far
        // slices are the high ones, so draw in decreasing order.
        let reverse = frame.camera.dir[frame.axis] > 0.0 && !iso;
        let lod = if iso { 1 } else { frame.lod.max(1) };
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("slices"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &target.view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: iso.then_some(wgpu::RenderPassDepthStencilAttachment {
                view: &target.depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        if pre {
            // The pass above only cleared the target; one pass per slice.
            drop(pass);
            encode_pre(
                enc,
                &PreDraw {
                    color: &target.view,
                    scalars: &target.scalars,
                    params: &bindings.group,
                    pre: &self.pre,
                    chunks: &set.chunks,
                    reverse,
                    lod,
                    boundary: set.boundary.as_ref(),
                    field: set.field.as_ref(),
                    device: &self.ctx.device,
                    depth: &target.depth,
                },
            );
            return Ok(());
        }
        pass.set_pipeline(if iso { &self.iso } else { &self.blend });
        pass.set_bind_group(0, &bindings.group, &[]);
        draw_chunks(&mut pass, sets, iso, reverse, lod)
    }

    /// Draws `set` into a new offscreen target of `size` and reads it back,
    /// composited over `background` (straight RGBA; `None`: transparent).
    pub fn draw_image(
        &self,
        set: &SliceSet,
        transfer: &Transfer,
        frame: &FrameSetup,
        size: (u32, u32),
        background: Option<[f32; 4]>,
    ) -> Result<Image, RenderError> {
        let ctx = self.ctx;
        let (lut, vlo, vhi) = transfer.lut(set.range.0, set.range.1);
        let bindings = self.bindings();
        let over = transfer.over(vlo, vhi);
        bindings.write(&ctx.queue, &frame.params(set, vlo, vhi), &over, &lut);
        let target = self.target(size);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.encode_slices(&mut enc, &target, set, &bindings, frame)?;
        ctx.queue.submit([enc.finish()]);
        self.read_image(&target, background)
    }

    /// Reads `target` back, composited over `background`.
    pub fn read_image(
        &self,
        target: &OffscreenTarget,
        background: Option<[f32; 4]>,
    ) -> Result<Image, RenderError> {
        let ctx = self.ctx;
        let (w, h) = target.size;
        let texel: u32 = if self.format == wgpu::TextureFormat::Rgba32Float {
            16
        } else {
            8
        };
        let bpr = (w * texel).div_ceil(256) * 256;
        let rb = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("image"),
            size: bpr as u64 * h as u64,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &target.color,
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
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        ctx.queue.submit([enc.finish()]);
        let bytes = ctx.read_buffer(&rb, bpr as u64 * h as u64)?;
        let bg_p = background.map_or([0.0; 4], |b| [b[0] * b[3], b[1] * b[3], b[2] * b[3], b[3]]);
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

/// Draws the level chunks of `sets` into `pass` (its pipeline and group 0
/// set): in one indirect multi-draw per chunk, or every `lod`-th level (by
/// global level index), in `reverse` level order when looking toward +axis;
/// iso mode binds the slices' normals.
fn draw_chunks(
    pass: &mut wgpu::RenderPass,
    sets: &[&SliceSet],
    iso: bool,
    reverse: bool,
    lod: u32,
) -> Result<(), RenderError> {
    let all = sets.iter().flat_map(|s| &s.chunks);
    let chunks: Vec<&GpuEmitter> = if reverse {
        all.rev().collect()
    } else {
        all.collect()
    };
    let mut first_level = 0u32;
    for e in chunks {
        let k = e.level_count;
        let (Some(vb), Some(cb), true) = (e.vertex_buffer(), e.control_buffer(), e.triangles > 0)
        else {
            first_level += k;
            continue;
        };
        pass.set_vertex_buffer(0, vb.slice(..));
        if iso {
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
        if lod == 1 {
            let first = if reverse {
                lay.args_rev()
            } else {
                lay.args_fwd()
            };
            pass.multi_draw_indirect(cb, first as u64 * 4, k);
        } else {
            // Every lod-th level (by global level index), far to near.
            let order: Vec<u32> = if reverse {
                (0..k).rev().collect()
            } else {
                (0..k).collect()
            };
            for l in order {
                if (first_level + l).is_multiple_of(lod) {
                    let word = lay.args_fwd() + l * ARGS_WORDS;
                    pass.draw_indirect(cb, word as u64 * 4);
                }
            }
        }
        first_level += k;
    }
    Ok(())
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
    for f in [SCALAR_FORMAT, BOUNDARY_FORMAT] {
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
