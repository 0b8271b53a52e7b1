//! The pre-integrated volume pass: slabs between consecutive slices.
//!
//! The slab behind slice `k` runs from slice `k` to the next slice along
//! the ray. Its back value is not extrapolated: the slices are drawn far to
//! near, one render pass per slice, and each pass also writes its slice's
//! value and derivative along the ray into a scalar target (`Rg32Float`)
//! that the next (nearer) pass reads at the same pixel, two targets
//! ping-ponged. A ray through a pixel is the same ray at every slice
//! (orthographic and perspective alike), so the pixel's texel in the far
//! slice's target is the back end of this pixel's slab. Inside the slab the
//! value follows the cubic Hermite curve of the two ends' values and
//! derivatives (the attribute's gradient rides on the slices as normals),
//! composited as `SUB_SLABS` sub-slabs, each from the pre-integrated table
//! ([`super::table`]) built for a sub-slab. Where no far slice
//! covers the pixel, half a slab extrapolated along the derivative. Every
//! pass also writes the nearest slice so far into a third target; a last
//! full-screen pass puts the half slab in front of the nearest slice over
//! the image, so each slice stands for the slab centred on it, as in the
//! plain mode.
//!
//! On IJK grids ([`super::ijk_field`]) the slices carry `(i, j, k)` instead
//! of the gradient, the scalar targets hold `(i, j, k, ray distance)` and
//! the outer surface's targets `(ray distance, i, j, k)`: each slab, the
//! segment from the entry to the nearest slice, the one from the farthest
//! slice to the exit, and whole rays that meet no slice are marched
//! through the property's 3D texture in index space (group 2).

use crate::gpu::compute::emit::GpuEmitter;
use crate::gpu::context::GpuError;
use crate::gpu::shaders;
use crate::gpu::shared::{ARGS_WORDS, ControlLayout};

/// Format of the per-slice scalar targets: (value, its derivative along
/// the ray per display unit, the ray distance, 1).
pub const SCALAR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// Format of the entry and exit targets: (ray distance, the point's
/// `(i, j, k)` on IJK grids).
pub const BOUNDARY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// Sub-slabs per slab (`SUB_SLABS` in `wgsl/shared/pre.wgsl`): the table is
/// built for slabs `1 / SUB_SLABS` of the slice spacing thick.
pub const SUB_SLABS: u32 = 4;

/// The scalar targets' clear value: "no slice covers this pixel"
/// (`NO_VALUE` in `wgsl/shared/pre.wgsl`).
pub const NO_VALUE: f64 = -3.0e38;

/// The pre-integrated pipelines and the layout of their texture binding.
pub struct PrePipeline {
    /// Three colour targets: the accumulation target (premultiplied
    /// "over"), the slice's scalars and the nearest slice's (no blending).
    pub pipeline: wgpu::RenderPipeline,
    /// The segment in front of the nearest slice, full screen, "over".
    pub front: wgpu::RenderPipeline,
    /// The grid's outer surface: nearest (`[0]`) and farthest (`[1]`) ray
    /// distance per pixel.
    pub boundary: [wgpu::RenderPipeline; 2],
    /// Group 1: a slice scalar target, an entry or exit target and the
    /// other one (read by the front pass only).
    pub far_layout: wgpu::BindGroupLayout,
    /// Group 2: the index-space field ([`super::ijk_field`]).
    pub field_layout: wgpu::BindGroupLayout,
    /// The field bound when a frame has none (never read).
    empty_field: wgpu::TextureView,
    /// The field's trilinear sampler.
    sampler: wgpu::Sampler,
}

impl PrePipeline {
    /// Builds the slab, front and outer-surface passes over group 0
    /// `params` (the render pass's parameters, LUT and table), the
    /// far-slice group and the field group.
    pub fn new(
        device: &wgpu::Device,
        params: &wgpu::BindGroupLayout,
        format: wgpu::TextureFormat,
    ) -> Result<Self, GpuError> {
        let module = |name, pass| shaders::module(device, name, &shaders::pre_source(pass));
        let slab = module("pre_slab.wgsl", shaders::PRE_SLAB)?;
        let front = module("pre_front.wgsl", shaders::PRE_FRONT)?;
        let surface = module("pre_surface.wgsl", shaders::PRE_SURFACE)?;
        let far_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("far slice"),
            entries: &[texture_entry(0), texture_entry(1), texture_entry(2)],
        });
        let field_layout = super::ijk_field::field_layout(device);
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("pre-integrated"),
            bind_group_layouts: &[Some(params), Some(&far_layout), Some(&field_layout)],
            immediate_size: 0,
        });
        let vertices = crate::gpu::shared::out_vertex_layout();
        let normals = crate::gpu::shared::normal_layout();
        let over = Some(wgpu::ColorTargetState {
            format,
            blend: Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
            write_mask: wgpu::ColorWrites::ALL,
        });
        let scalar = Some(wgpu::ColorTargetState {
            format: SCALAR_FORMAT,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        });
        let make = |module: &wgpu::ShaderModule,
                    vs: &str,
                    fs: &str,
                    buffers: &[Option<wgpu::VertexBufferLayout>],
                    targets| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(fs),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets,
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let slice_targets = [over.clone(), scalar.clone(), scalar];
        let front_targets = [over];
        let pipeline = make(
            &slab,
            "vs_iso",
            "fs_pre",
            &[Some(vertices), Some(normals)],
            &slice_targets,
        );
        let front = make(&front, "vs_full", "fs_front", &[], &front_targets);
        let boundary = [true, false].map(|near| boundary_pipeline(device, &surface, params, near));
        Ok(PrePipeline {
            pipeline,
            front,
            boundary,
            far_layout,
            field_layout,
            empty_field: super::ijk_field::empty_field(device),
            sampler: super::ijk_field::field_sampler(device),
        })
    }
}

fn texture_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

/// The outer surface drawn with a depth test keeping the nearest (`near`)
/// or farthest fragment, writing its ray distance.
fn boundary_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    params: &wgpu::BindGroupLayout,
    near: bool,
) -> wgpu::RenderPipeline {
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("grid surface"),
        bind_group_layouts: &[Some(params)],
        immediate_size: 0,
    });
    let attrs = wgpu::vertex_attr_array![0 => Float32x3, 2 => Float32x3];
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("grid surface"),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_boundary"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: 24,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &attrs,
            })],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(true),
            depth_compare: Some(if near {
                wgpu::CompareFunction::Less
            } else {
                wgpu::CompareFunction::Greater
            }),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_boundary"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format: BOUNDARY_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// The depth format of the boundary passes (the offscreen target's depth).
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// A grid's outer surface on the GPU ([`super::boundary`]).
pub struct BoundaryMesh {
    buffer: wgpu::Buffer,
    vertices: u32,
}

impl BoundaryMesh {
    /// Uploads the outer surface of `grid`'s cells (those in the IJK box
    /// `clip` if given); `None` when there is no cell.
    pub fn new(
        device: &wgpu::Device,
        grid: &crate::grid::Grid,
        clip: Option<super::boundary::IjkBox>,
    ) -> Option<Self> {
        Self::from_triangles(device, &super::boundary::boundary_triangles_in(grid, clip)?)
    }

    /// Uploads triangles of (position, `(i, j, k)`) corners; `None` when empty.
    pub fn from_triangles(device: &wgpu::Device, t: &[[f32; 6]]) -> Option<Self> {
        use wgpu::util::DeviceExt;
        if t.is_empty() {
            return None;
        }
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("grid surface"),
            contents: bytemuck::cast_slice(t),
            usage: wgpu::BufferUsages::VERTEX,
        });
        Some(BoundaryMesh {
            buffer,
            vertices: t.len() as u32,
        })
    }
}

/// The pass's scalar targets of one size and the bind groups that read
/// them: two ping-ponged per-slice targets, the nearest slice's, and the
/// rays' entry and exit distances.
pub struct ScalarTargets {
    /// Slice 0, slice 1, nearest.
    views: [wgpu::TextureView; 3],
    /// Entry, exit.
    bounds: [wgpu::TextureView; 2],
    /// Slice 0 + exit, slice 1 + exit, nearest + entry (each + the other).
    groups: [wgpu::BindGroup; 3],
}

impl ScalarTargets {
    /// The targets of `size` for `pre`'s texture bindings.
    pub fn new(device: &wgpu::Device, pre: &PrePipeline, size: (u32, u32)) -> Self {
        let make = |label: &str, format| {
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d {
                        width: size.0,
                        height: size.1,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                        | wgpu::TextureUsages::TEXTURE_BINDING,
                    view_formats: &[],
                })
                .create_view(&Default::default())
        };
        let views =
            ["slice scalars 0", "slice scalars 1", "nearest slice"].map(|l| make(l, SCALAR_FORMAT));
        let bounds = ["ray entry", "ray exit"].map(|l| make(l, BOUNDARY_FORMAT));
        let group = |s: &wgpu::TextureView, b: &wgpu::TextureView, other: &wgpu::TextureView| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("pre-integrated scalars"),
                layout: &pre.far_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(s),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(b),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::TextureView(other),
                    },
                ],
            })
        };
        let groups = [
            group(&views[0], &bounds[1], &bounds[0]),
            group(&views[1], &bounds[1], &bounds[0]),
            group(&views[2], &bounds[0], &bounds[1]),
        ];
        ScalarTargets {
            views,
            bounds,
            groups,
        }
    }
}

/// One pre-integrated frame's draw: where and what.
pub struct PreDraw<'a> {
    /// The accumulation target (already cleared).
    pub color: &'a wgpu::TextureView,
    /// The scalar targets of the same size.
    pub scalars: &'a ScalarTargets,
    /// Group 0 (parameters, LUT, table).
    pub params: &'a wgpu::BindGroup,
    /// The pipeline.
    pub pre: &'a PrePipeline,
    /// Level chunks, in level order.
    pub chunks: &'a [GpuEmitter<'a>],
    /// Draw the levels in decreasing order (looking toward +axis).
    pub reverse: bool,
    /// Draw every `lod`-th level (by global level index).
    pub lod: u32,
    /// The grid's outer surface, if extracted.
    pub boundary: Option<&'a BoundaryMesh>,
    /// The index-space field, on IJK grids.
    pub field: Option<&'a super::ijk_field::IjkField>,
    /// The device (the field's bind group).
    pub device: &'a wgpu::Device,
    /// A depth target of the same size.
    pub depth: &'a wgpu::TextureView,
}

/// The drawn levels far to near: (chunk, level in chunk).
fn far_to_near(chunks: &[GpuEmitter], reverse: bool, lod: u32) -> Vec<(usize, u32)> {
    let mut all = Vec::new();
    let mut first = 0u32;
    for (c, e) in chunks.iter().enumerate() {
        for l in 0..e.level_count {
            if (first + l).is_multiple_of(lod.max(1)) {
                all.push((c, l));
            }
        }
        first += e.level_count;
    }
    if reverse {
        all.reverse();
    }
    all
}

/// Records one render pass per drawn slice, far to near, each reading the
/// previous (farther) slice's scalar target and writing its own, then the
/// front pass.
pub fn encode_pre(enc: &mut wgpu::CommandEncoder, d: &PreDraw) {
    // The first pass reads a target that holds no slice; nothing is nearest yet.
    clear(enc, &d.scalars.views[1]);
    clear(enc, &d.scalars.views[2]);
    for (i, b) in d.scalars.bounds.iter().enumerate() {
        encode_boundary(enc, d, i, b);
    }
    let field = d.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("ijk field"),
        layout: &d.pre.field_layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(
                    d.field.map_or(&d.pre.empty_field, |f| &f.view),
                ),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::Sampler(&d.pre.sampler),
            },
        ],
    });
    let mut write = 0usize;
    for (c, l) in far_to_near(d.chunks, d.reverse, d.lod) {
        let e = &d.chunks[c];
        let (Some(vb), Some(nb), Some(cb), true) = (
            e.vertex_buffer(),
            e.normal_buffer(),
            e.control_buffer(),
            e.triangles > 0 && e.has_normals(),
        ) else {
            continue;
        };
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("pre-integrated slice"),
            color_attachments: &[
                Some(load_attachment(d.color)),
                Some(scalar_attachment(&d.scalars.views[write])),
                Some(load_attachment(&d.scalars.views[2])),
            ],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&d.pre.pipeline);
        pass.set_bind_group(0, d.params, &[]);
        pass.set_bind_group(1, &d.scalars.groups[1 - write], &[]);
        pass.set_bind_group(2, &field, &[]);
        pass.set_vertex_buffer(0, vb.slice(..));
        pass.set_vertex_buffer(1, nb.slice(..));
        let word = ControlLayout { k: e.level_count }.args_fwd() + l * ARGS_WORDS;
        pass.draw_indirect(cb, word as u64 * 4);
        drop(pass);
        write = 1 - write;
    }
    let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("pre-integrated front"),
        color_attachments: &[Some(load_attachment(d.color))],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(&d.pre.front);
    pass.set_bind_group(0, d.params, &[]);
    pass.set_bind_group(1, &d.scalars.groups[2], &[]);
    pass.set_bind_group(2, &field, &[]);
    pass.draw(0..3, 0..1);
}

/// Clears `view` to [`NO_VALUE`] and draws the outer surface's nearest
/// (`which` 0) or farthest (1) ray distance into it.
fn encode_boundary(
    enc: &mut wgpu::CommandEncoder,
    d: &PreDraw,
    which: usize,
    view: &wgpu::TextureView,
) {
    let Some(mesh) = d.boundary else {
        clear(enc, view);
        return;
    };
    let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("grid surface"),
        color_attachments: &[Some(scalar_attachment(view))],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: d.depth,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Clear(if which == 0 { 1.0 } else { 0.0 }),
                store: wgpu::StoreOp::Discard,
            }),
            stencil_ops: None,
        }),
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(&d.pre.boundary[which]);
    pass.set_bind_group(0, d.params, &[]);
    pass.set_vertex_buffer(0, mesh.buffer.slice(..));
    pass.draw(0..mesh.vertices, 0..1);
}

/// An attachment drawn over (loaded, stored).
fn load_attachment(view: &wgpu::TextureView) -> wgpu::RenderPassColorAttachment<'_> {
    wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Load,
            store: wgpu::StoreOp::Store,
        },
    }
}

/// A scalar target attachment cleared to [`NO_VALUE`].
fn scalar_attachment(view: &wgpu::TextureView) -> wgpu::RenderPassColorAttachment<'_> {
    wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Clear(wgpu::Color {
                r: NO_VALUE,
                g: 0.0,
                b: 0.0,
                a: 0.0,
            }),
            store: wgpu::StoreOp::Store,
        },
    }
}

/// Clears a scalar target to [`NO_VALUE`].
fn clear(enc: &mut wgpu::CommandEncoder, view: &wgpu::TextureView) {
    enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("clear slice values"),
        color_attachments: &[Some(scalar_attachment(view))],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    });
}
