//! Drawing cached slices into a target: the per-frame parameters, the
//! uniform/LUT bindings, the render pass (full count, or every n-th slice
//! while the camera moves) and the offscreen read-back. `render` and the
//! viewer both draw through [`Renderer::encode_slices`]: one renderer, two
//! targets.

use wgpu::util::DeviceExt;

use super::camera::OrbitCamera;
use super::compute::emit::GpuEmitter;
use super::pre_pass::{PreDraw, SUB_SLABS, ScalarTargets, encode_pre};
use super::preintegrate::{PRE_SIZE, preintegrated_table};
use super::render::{DEPTH, Image, Mode, RenderError, Renderer, SliceSet, Transfer};
use super::shared::{ARGS_WORDS, ControlLayout, RenderParams};

/// What one frame draws: camera, slicing axis, unit distance and mode.
#[derive(Clone, Copy, Debug)]
pub struct FrameSetup {
    /// The camera (display space, with its z-scale).
    pub camera: OrbitCamera,
    /// Slicing axis of the drawn slices.
    pub axis: usize,
    /// Unit distance of the opacities (display space).
    pub unit: f64,
    /// Mode.
    pub mode: Mode,
    /// Level of detail: draw every `lod`-th slice, opacity corrected for
    /// the `lod` times wider spacing (1: every slice).
    pub lod: u32,
    /// Volume mode with pre-integrated slabs (the slices must carry the
    /// attribute's gradient).
    pub preintegrated: bool,
}

impl FrameSetup {
    /// The shader parameters for slices `set` and a transfer LUT over `[vlo, vhi]`.
    pub fn params(&self, set: &SliceSet, vlo: f64, vhi: f64) -> RenderParams {
        let cam = &self.camera;
        let d = cam.dir;
        let eye = cam.eye();
        let mut axis_v = [0f32; 4];
        axis_v[self.axis] = 1.0;
        let zs = if self.axis == 2 {
            cam.z_scale as f64
        } else {
            1.0
        };
        let slab = set.spacing * zs * self.lod.max(1) as f64;
        let mode = match self.mode {
            Mode::Volume => 0,
            Mode::Slices => 1,
            Mode::Iso => 2,
        };
        RenderParams {
            view_proj: cam.view_proj().to_cols_array_2d(),
            eye: [eye.x, eye.y, eye.z, 1.0],
            view_dir: [d.x, d.y, d.z, 0.0],
            axis: axis_v,
            value_lo: vlo as f32,
            value_hi: vhi as f32,
            spacing_over_unit: (slab / self.unit) as f32,
            perspective: cam.perspective as u32,
            mode,
            z_scale: cam.z_scale,
            slab: if self.uses_pre(set) { slab as f32 } else { 0.0 },
            field_mode: match &set.field {
                Some(f) if self.uses_pre(set) => f.kind.mode(),
                _ => 0,
            },
        }
    }
}

impl FrameSetup {
    /// Whether this frame draws `set` pre-integrated (volume mode; the
    /// slices must carry the attribute's gradient, else plain).
    pub fn uses_pre(&self, set: &SliceSet) -> bool {
        self.preintegrated
            && self.mode == Mode::Volume
            && set.chunks.first().is_some_and(|e| e.has_normals())
    }
}

/// The uniform parameters, transfer LUT and pre-integrated table of the
/// render pass, bound once and rewritten per frame.
pub struct DrawBindings {
    params: wgpu::Buffer,
    lut: wgpu::Buffer,
    pre: wgpu::Buffer,
    group: wgpu::BindGroup,
    /// The (slab ratio bits, LUT) the table was last built for.
    pre_for: std::sync::Mutex<Option<(u32, Vec<[f32; 4]>)>>,
}

impl DrawBindings {
    /// Writes this frame's parameters and the transfer function's LUT,
    /// and the pre-integrated table when the frame uses it and its slab
    /// ratio or transfer changed. `transfer` is the one the LUT was made
    /// from, restricted to the LUT's range ([`Transfer::over`]).
    pub fn write(
        &self,
        queue: &wgpu::Queue,
        params: &RenderParams,
        transfer: &Transfer,
        lut: &[[f32; 4]],
    ) {
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(params));
        queue.write_buffer(&self.lut, 0, bytemuck::cast_slice(lut));
        if params.slab > 0.0 {
            // A sub-slab along the view direction: 1/cos thicker than on
            // the axis (exact for orthographic views; `fs_pre` corrects
            // the opacity of perspective rays relative to this one).
            let r = params.spacing_over_unit / view_cos(params) / SUB_SLABS as f32;
            let key = (r.to_bits(), lut.to_vec());
            let mut memo = self.pre_for.lock().unwrap_or_else(|p| p.into_inner());
            if memo.as_ref() != Some(&key) {
                let t = preintegrated_table(transfer, r as f64);
                queue.write_buffer(&self.pre, 0, bytemuck::cast_slice(&t));
                *memo = Some(key);
            }
        }
    }
}

/// |cos| of the angle between the view direction and the slicing axis
/// (at least 1e-3, as `view_cos` in `wgsl/render.wgsl`).
fn view_cos(p: &RenderParams) -> f32 {
    let d: f32 = (0..3).map(|i| p.view_dir[i] * p.axis[i]).sum();
    d.abs().max(1e-3)
}

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
        let lut = zeros("lut", super::render::LUT_VEC4S * 16);
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
        let all = sets.iter().flat_map(|s| &s.chunks);
        let chunks: Vec<&GpuEmitter> = if reverse {
            all.rev().collect()
        } else {
            all.collect()
        };
        let mut first_level = 0u32;
        for e in chunks {
            let k = e.level_count;
            let (Some(vb), Some(cb), true) =
                (e.vertex_buffer(), e.control_buffer(), e.triangles > 0)
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
                        super::render::f16_to_f32(u16::from_le_bytes([row[o], row[o + 1]]))
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
