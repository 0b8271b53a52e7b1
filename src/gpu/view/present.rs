//! The viewer's present pass (`wgsl/present.wgsl`): the renderer's float
//! target composited over the background into a window surface (or any
//! 8-bit target), straight RGBA like `render`'s PNG.

use crate::gpu::context::{GpuContext, GpuError};
use crate::gpu::render::camera::OrbitCamera;
use crate::gpu::render::renderer::OffscreenTarget;
use crate::gpu::shaders::{self, PRESENT};

use super::outline::box_edges;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct PresentParams {
    background: [f32; 4],
    offset: [f32; 4],
}

/// Composites a float scene target over a background into `format` targets.
pub struct Compositor {
    pipeline: wgpu::RenderPipeline,
    /// Outline lines: hidden edges (under the scene), visible edges.
    lines: [wgpu::RenderPipeline; 2],
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
}

impl Compositor {
    /// Builds the pass for output `format` (a non-sRGB format shows the
    /// same bytes as `render`'s PNG).
    pub fn new(ctx: &GpuContext, format: wgpu::TextureFormat) -> Result<Self, GpuError> {
        shaders::validate("present.wgsl", PRESENT)
            .map_err(|e| GpuError::Device(format!("invalid shader {e}")))?;
        let dev = &ctx.device;
        let module = dev.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("present.wgsl"),
            source: wgpu::ShaderSource::Wgsl(PRESENT.into()),
        });
        let layout = dev.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("present"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let pl = dev.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("present"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = dev.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("present"),
            layout: Some(&pl),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        let lines = ["fs_line_back", "fs_line_front"]
            .map(|fs| line_pipeline(dev, &module, &pl, format, fs));
        let params = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("present params"),
            size: std::mem::size_of::<PresentParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        ctx.check()?;
        Ok(Compositor {
            pipeline,
            lines,
            layout,
            params,
        })
    }

    /// Records the pass: `scene` over `background` (straight RGBA; `None`:
    /// transparent) into `out`, cleared first.
    pub fn encode(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &OffscreenTarget,
        out: &wgpu::TextureView,
        background: Option<[f32; 4]>,
    ) {
        let b = background.unwrap_or([0.0; 4]);
        let p = PresentParams {
            background: [b[0] * b[3], b[1] * b[3], b[2] * b[3], b[3]],
            offset: [0.0; 4],
        };
        ctx.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&p));
        let group = self.group(ctx, scene);
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("present"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: out,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.draw(0..3, 0..1);
    }

    /// Draws the outline box of `cam` over the presented image `out` (after
    /// [`Self::encode`]): the edges the box hides under the scene, the
    /// others over it.
    pub fn encode_outline(
        &self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        scene: &OffscreenTarget,
        out: &wgpu::TextureView,
        cam: &OrbitCamera,
    ) {
        use wgpu::util::DeviceExt;
        let (hidden, shown) = box_edges(cam, [0.35, 0.35, 0.35, 0.8]);
        let group = self.group(ctx, scene);
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("outline"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: out,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &group, &[]);
        for (pipeline, v) in self.lines.iter().zip([hidden, shown]) {
            if v.is_empty() {
                continue;
            }
            let buf = ctx
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("outline"),
                    contents: bytemuck::cast_slice(&v),
                    usage: wgpu::BufferUsages::VERTEX,
                });
            pass.set_pipeline(pipeline);
            pass.set_vertex_buffer(0, buf.slice(..));
            pass.draw(0..v.len() as u32, 0..1);
        }
    }

    fn group(&self, ctx: &GpuContext, scene: &OffscreenTarget) -> wgpu::BindGroup {
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("present"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&scene.view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: self.params.as_entire_binding(),
                },
            ],
        })
    }
}

/// The outline's line pipeline with fragment entry `fs`, blended over.
fn line_pipeline(
    dev: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    format: wgpu::TextureFormat,
    fs: &str,
) -> wgpu::RenderPipeline {
    let attrs = wgpu::vertex_attr_array![0 => Float32x4, 1 => Float32x4];
    dev.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(fs),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_line"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: 32,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &attrs,
            })],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::LineList,
            ..Default::default()
        },
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(fs),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format,
                blend: Some(wgpu::BlendState::ALPHA_BLENDING),
                write_mask: wgpu::ColorWrites::COLOR,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}
