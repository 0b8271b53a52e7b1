//! GPU emission: the grid and catalog in storage buffers, then per frame
//! the count, scan and emit passes (`wgsl/count.wgsl`, `wgsl/scan.wgsl`,
//! `wgsl/emit.wgsl`). Triangles land in per-level regions of one vertex
//! buffer whose capacity follows the frame's exact triangle total (read
//! back after the scan), and one `DrawIndirectArgs` per level (both
//! orders) sits in the control buffer for the render pass.

use std::time::Instant;

use wgpu::util::DeviceExt;

use super::context::{GpuContext, GpuError};
use super::frame::FrameOutput;
use super::shaders;
use super::shared::{ControlLayout, EmitParams, OutVertex};
use super::tables::{Frame, GridBuffers, dispatch_size, emit_params};

/// Storage buffers bound by the compute passes (bindings 1..=12).
pub const STORAGE_BINDINGS: u32 = 12;

/// Bytes per output triangle in the normals buffer (3 corners × `vec4<f32>`).
const NORMAL_BYTES_PER_TRIANGLE: u64 = 48;

/// Seconds spent in the phases of the last frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct EmitTimings {
    /// Uploading levels and entries.
    pub upload: f64,
    /// Count + scan, including the read-back of the total.
    pub count: f64,
    /// Emit pass until the device finished.
    pub emit: f64,
    /// Level chunks the frame was split into (1 when it fit; 0 unset).
    pub chunks: usize,
}

/// A growable GPU buffer.
struct Grow {
    buf: wgpu::Buffer,
    cap: u64,
}

/// The GPU emitter of one grid and field.
pub struct GpuEmitter<'c> {
    ctx: &'c GpuContext,
    layout: wgpu::BindGroupLayout,
    count: wgpu::ComputePipeline,
    scan: wgpu::ComputePipeline,
    emit: wgpu::ComputePipeline,
    bin_count: wgpu::ComputePipeline,
    bin_fill: wgpu::ComputePipeline,
    live: wgpu::Buffer,
    grid: std::sync::Arc<GridBuffers>,
    params: wgpu::Buffer,
    tables: wgpu::Buffer,
    grid_buf: wgpu::Buffer,
    attr: wgpu::Buffer,
    cells: wgpu::Buffer,
    grad: wgpu::Buffer,
    entries: Option<Grow>,
    levels: Option<Grow>,
    control: Option<Grow>,
    vertices: Option<Grow>,
    areas: Option<Grow>,
    normals: Option<Grow>,
    /// Compute dispatches issued so far (count, scan and emit each count one
    /// per `dispatch_workgroups` call).
    pub dispatches: u64,
    /// Level count of the last frame.
    pub level_count: u32,
    /// Triangles of the last frame.
    pub triangles: u32,
    /// Timings of the last frame.
    pub timings: EmitTimings,
}

fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn init_buffer(
    ctx: &GpuContext,
    label: &str,
    data: &[u8],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    let mut v = data.to_vec();
    // At least one element of the widest array type (`vec4<f32>`).
    v.resize(v.len().max(16).div_ceil(4) * 4, 0);
    ctx.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: &v,
            usage,
        })
}

/// Creates a compute pipeline after validating its WGSL with naga.
fn pipeline(
    ctx: &GpuContext,
    layout: &wgpu::PipelineLayout,
    name: &str,
    src: String,
    entry: &str,
) -> Result<wgpu::ComputePipeline, GpuError> {
    shaders::validate(name, &src).map_err(|e| GpuError::Device(format!("invalid shader {e}")))?;
    let module = ctx
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(name),
            source: wgpu::ShaderSource::Wgsl(src.into()),
        });
    Ok(ctx
        .device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(name),
            layout: Some(layout),
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        }))
}

impl<'c> GpuEmitter<'c> {
    /// Uploads the grid side and builds the pipelines.
    pub fn new(ctx: &'c GpuContext, grid: GridBuffers) -> Result<Self, GpuError> {
        if ctx.limits.max_storage_buffers_per_shader_stage < STORAGE_BINDINGS {
            return Err(GpuError::Unsupported {
                adapter: ctx.name.clone(),
                why: format!(
                    "{STORAGE_BINDINGS} storage buffers per stage needed, {} allowed",
                    ctx.limits.max_storage_buffers_per_shader_stage
                ),
            });
        }
        ctx.check_storage(
            "the grid vertices (position + φ)",
            grid.grid.len() as u64 * 16,
        )?;
        ctx.check_storage("the zoo cells", grid.cells.len() as u64 * 4)?;
        ctx.check_storage("the vertex attribute", grid.attr.len() as u64 * 4)?;
        ctx.check_storage("the meta-cell tables", grid.tables.len() as u64 * 4)?;
        ctx.check_storage("the vertex gradients", grid.grad.len() as u64 * 16)?;
        let mut entries = vec![wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }];
        for b in 1..=STORAGE_BINDINGS {
            entries.push(storage_entry(b, !matches!(b, 5..=8 | 12)));
        }
        let layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("emit"),
                entries: &entries,
            });
        let pl = ctx
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("emit"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        let f64d = ctx.shader_f64;
        let count = pipeline(
            ctx,
            &pl,
            "count.wgsl",
            shaders::compute_source(shaders::COUNT, f64d),
            "count",
        )?;
        let scan = pipeline(
            ctx,
            &pl,
            "scan.wgsl",
            shaders::compute_source(shaders::SCAN, f64d),
            "scan",
        )?;
        let emit = pipeline(
            ctx,
            &pl,
            "emit.wgsl",
            shaders::compute_source(shaders::EMIT, f64d),
            "emit",
        )?;
        let bin_src = shaders::compute_source(shaders::BIN, f64d);
        let bin_count = pipeline(ctx, &pl, "bin.wgsl", bin_src.clone(), "bin_count")?;
        let bin_fill = pipeline(ctx, &pl, "bin.wgsl", bin_src, "bin_fill")?;
        ctx.check_storage("the live cell list", grid.live.len() as u64 * 4)?;
        let st = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let live = init_buffer(ctx, "live", bytemuck::cast_slice(&grid.live), st);
        let params = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("params"),
            size: std::mem::size_of::<EmitParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let tables = init_buffer(ctx, "tables", bytemuck::cast_slice(&grid.tables), st);
        let grid_buf = init_buffer(ctx, "grid", bytemuck::cast_slice(&grid.grid), st);
        let attr = init_buffer(ctx, "attr", bytemuck::cast_slice(&grid.attr), st);
        let cells = init_buffer(ctx, "cells", bytemuck::cast_slice(&grid.cells), st);
        let grad = init_buffer(ctx, "grad", bytemuck::cast_slice(&grid.grad), st);
        ctx.check()?;
        Ok(GpuEmitter {
            ctx,
            layout,
            count,
            scan,
            emit,
            bin_count,
            bin_fill,
            live,
            grid: std::sync::Arc::new(grid),
            params,
            tables,
            grid_buf,
            attr,
            cells,
            grad,
            entries: None,
            levels: None,
            control: None,
            vertices: None,
            areas: None,
            normals: None,
            dispatches: 0,
            level_count: 0,
            triangles: 0,
            timings: EmitTimings::default(),
        })
    }

    /// An emitter sharing this one's grid buffers and pipelines, with its
    /// own frame buffers (for the chunks of a frame too large for one).
    pub fn fork(&self) -> Self {
        GpuEmitter {
            ctx: self.ctx,
            layout: self.layout.clone(),
            count: self.count.clone(),
            scan: self.scan.clone(),
            emit: self.emit.clone(),
            bin_count: self.bin_count.clone(),
            bin_fill: self.bin_fill.clone(),
            live: self.live.clone(),
            grid: self.grid.clone(),
            params: self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("params"),
                size: std::mem::size_of::<EmitParams>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            tables: self.tables.clone(),
            grid_buf: self.grid_buf.clone(),
            attr: self.attr.clone(),
            cells: self.cells.clone(),
            grad: self.grad.clone(),
            entries: None,
            levels: None,
            control: None,
            vertices: None,
            areas: None,
            normals: None,
            dispatches: 0,
            level_count: 0,
            triangles: 0,
            timings: EmitTimings::default(),
        }
    }

    /// The grid-side host buffers.
    pub fn grid(&self) -> &GridBuffers {
        &self.grid
    }

    fn ensure(
        ctx: &GpuContext,
        slot: &mut Option<Grow>,
        what: &str,
        bytes: u64,
        usage: wgpu::BufferUsages,
    ) -> Result<(), GpuError> {
        let bytes = bytes.max(16).div_ceil(16) * 16;
        ctx.check_storage(what, bytes).map_err(|e| match e {
            GpuError::TooLarge {
                what, bytes, limit, ..
            } => GpuError::FrameTooLarge { what, bytes, limit },
            e => e,
        })?;
        if slot.as_ref().is_none_or(|g| g.cap < bytes) {
            let cap = (bytes + bytes / 4)
                .min(ctx.limits.max_storage_buffer_binding_size)
                .min(ctx.limits.max_buffer_size)
                .max(bytes)
                / 4
                * 4;
            *slot = Some(Grow {
                buf: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(what),
                    size: cap,
                    usage,
                    mapped_at_creation: false,
                }),
                cap,
            });
        }
        Ok(())
    }

    fn bind_group(&self) -> wgpu::BindGroup {
        fn b(g: &Option<Grow>) -> wgpu::BindingResource<'_> {
            g.as_ref().expect("allocated").buf.as_entire_binding()
        }
        let bufs = [
            self.params.as_entire_binding(),
            self.tables.as_entire_binding(),
            self.grid_buf.as_entire_binding(),
            self.attr.as_entire_binding(),
            self.cells.as_entire_binding(),
            b(&self.entries),
            b(&self.control),
            b(&self.vertices),
            b(&self.areas),
            b(&self.levels),
            self.live.as_entire_binding(),
            self.grad.as_entire_binding(),
            b(&self.normals),
        ];
        let entries: Vec<wgpu::BindGroupEntry> = bufs
            .into_iter()
            .enumerate()
            .map(|(i, resource)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource,
            })
            .collect();
        self.ctx
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("emit"),
                layout: &self.layout,
                entries: &entries,
            })
    }

    fn dispatch(
        &mut self,
        enc: &mut wgpu::CommandEncoder,
        bg: &wgpu::BindGroup,
        pipe: &wgpu::ComputePipeline,
        groups: (u32, u32),
    ) {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: None,
            timestamp_writes: None,
        });
        pass.set_pipeline(pipe);
        pass.set_bind_group(0, bg, &[]);
        pass.dispatch_workgroups(groups.0, groups.1, 1);
        self.dispatches += 1;
    }

    /// Runs one frame on the GPU: uploads the levels and entries, counts,
    /// scans, sizes the vertex buffer to the exact total and emits. The
    /// triangles and draw arguments stay on the GPU ([`Self::vertex_buffer`],
    /// [`Self::control_buffer`]); [`Self::read_output`] fetches them.
    pub fn run(&mut self, frame: &Frame, write_areas: bool) -> Result<(), GpuError> {
        let ctx = self.ctx;
        let t0 = Instant::now();
        let k = frame.levels.len() as u32;
        let lay = ControlLayout { k };
        self.prepare(frame.entries.len() as u64 * 8, &frame.levels, lay)?;
        let q = &ctx.queue;
        if !frame.entries.is_empty() {
            q.write_buffer(
                &self.entries.as_ref().expect("allocated").buf,
                0,
                bytemuck::cast_slice(&frame.entries),
            );
        }
        let groups = dispatch_size(
            frame.entries.len() as u32,
            ctx.limits.max_compute_workgroups_per_dimension,
        );
        let p = emit_params(&self.grid, frame, 0, write_areas, groups.0);
        q.write_buffer(&self.params, 0, bytemuck::bytes_of(&p));
        let control = self.control.as_ref().expect("allocated").buf.clone();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&control, 0, None);
        let bg = self.bind_group();
        ctx.wait()?;
        let t1 = Instant::now();
        self.dispatch(&mut enc, &bg, &self.count.clone(), groups);
        self.dispatch(&mut enc, &bg, &self.scan.clone(), (1, 1));
        q.submit([enc.finish()]);
        self.size_and_emit(p, groups, &control, lay, write_areas, [t0, t1])?;
        Ok(())
    }

    /// Makes every buffer of a run exist (entries of `entry_bytes`, the
    /// levels, the control block of `lay`; outputs at their minimum until
    /// [`Self::size_and_emit`] sizes them) and uploads the level values.
    fn prepare(
        &mut self,
        entry_bytes: u64,
        levels: &[f32],
        lay: ControlLayout,
    ) -> Result<(), GpuError> {
        let ctx = self.ctx;
        let st = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        Self::ensure(
            ctx,
            &mut self.entries,
            "the frame's (cell, level) entries",
            entry_bytes,
            st,
        )?;
        Self::ensure(
            ctx,
            &mut self.levels,
            "the level values",
            levels.len() as u64 * 4,
            st,
        )?;
        Self::ensure(
            ctx,
            &mut self.control,
            "the draw arguments and counters",
            lay.words() as u64 * 4,
            st | wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_SRC,
        )?;
        let vst = st | wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_SRC;
        Self::ensure(ctx, &mut self.vertices, "the output triangles", 48, vst)?;
        Self::ensure(
            ctx,
            &mut self.areas,
            "the per-triangle areas",
            4,
            st | wgpu::BufferUsages::COPY_SRC,
        )?;
        Self::ensure(ctx, &mut self.normals, "the output normals", 16, vst)?;
        if !levels.is_empty() {
            ctx.queue.write_buffer(
                &self.levels.as_ref().expect("allocated").buf,
                0,
                bytemuck::cast_slice(levels),
            );
        }
        Ok(())
    }

    /// After the count and scan passes: reads the frame's triangle total,
    /// sizes the outputs to it exactly, runs the emit pass and records the
    /// timings (`times` = start, end of upload).
    #[allow(clippy::too_many_arguments)]
    fn size_and_emit(
        &mut self,
        mut p: EmitParams,
        groups: (u32, u32),
        control: &wgpu::Buffer,
        lay: ControlLayout,
        write_areas: bool,
        times: [Instant; 2],
    ) -> Result<(), GpuError> {
        let ctx = self.ctx;
        let q = &ctx.queue;
        let st = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let vst = st | wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_SRC;
        let total = self.read_words(control, lay.total() as u64 * 4, 1)?[0];
        let t2 = Instant::now();
        Self::ensure(
            ctx,
            &mut self.vertices,
            "the output triangles",
            total as u64 * 48,
            vst,
        )?;
        Self::ensure(
            ctx,
            &mut self.areas,
            "the per-triangle areas",
            if write_areas { total as u64 * 4 } else { 4 },
            st | wgpu::BufferUsages::COPY_SRC,
        )?;
        if !self.grid.grad.is_empty() {
            Self::ensure(
                ctx,
                &mut self.normals,
                "the output normals",
                total as u64 * NORMAL_BYTES_PER_TRIANGLE,
                vst,
            )?;
        }
        p.triangle_capacity = total;
        q.write_buffer(&self.params, 0, bytemuck::bytes_of(&p));
        let bg = self.bind_group();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.dispatch(&mut enc, &bg, &self.emit.clone(), groups);
        q.submit([enc.finish()]);
        ctx.wait()?;
        let t3 = Instant::now();
        self.level_count = lay.k;
        self.triangles = total;
        self.timings = EmitTimings {
            upload: (times[1] - times[0]).as_secs_f64(),
            count: (t2 - times[1]).as_secs_f64(),
            emit: (t3 - t2).as_secs_f64(),
            chunks: 1,
        };
        Ok(())
    }

    fn read_words(
        &self,
        buf: &wgpu::Buffer,
        offset: u64,
        words: u64,
    ) -> Result<Vec<u32>, GpuError> {
        let staging = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback words"),
            size: words * 4,
            usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(buf, offset, &staging, 0, words * 4);
        self.ctx.queue.submit([enc.finish()]);
        let bytes = self.ctx.read_buffer(&staging, words * 4)?;
        Ok(bytemuck::pod_collect_to_vec(&bytes))
    }

    /// The vertex buffer ([`OutVertex`] per triangle corner).
    pub fn vertex_buffer(&self) -> Option<&wgpu::Buffer> {
        self.vertices.as_ref().map(|g| &g.buf)
    }

    /// The normals buffer (one `vec4<f32>` gradient per triangle corner,
    /// parallel to [`Self::vertex_buffer`]); written only when the grid
    /// buffers carry gradients.
    pub fn normal_buffer(&self) -> Option<&wgpu::Buffer> {
        self.normals.as_ref().map(|g| &g.buf)
    }

    /// True when the emit pass writes normals (the grid carries gradients).
    pub fn has_normals(&self) -> bool {
        !self.grid.grad.is_empty()
    }

    /// The control buffer (draw arguments in both orders, then counters).
    pub fn control_buffer(&self) -> Option<&wgpu::Buffer> {
        self.control.as_ref().map(|g| &g.buf)
    }

    /// Reads the last frame's control words, triangles and (if written) areas.
    pub fn read_output(&self, with_areas: bool) -> Result<FrameOutput, GpuError> {
        let (Some(c), Some(v), Some(a)) = (&self.control, &self.vertices, &self.areas) else {
            return Ok(FrameOutput::default());
        };
        let lay = ControlLayout {
            k: self.level_count,
        };
        let control: Vec<u32> =
            bytemuck::pod_collect_to_vec(&self.ctx.read_buffer(&c.buf, lay.words() as u64 * 4)?);
        let n = self.triangles as u64;
        let vertices: Vec<OutVertex> =
            bytemuck::pod_collect_to_vec(&self.ctx.read_buffer(&v.buf, n * 48)?);
        let areas: Vec<f32> = if with_areas {
            bytemuck::pod_collect_to_vec(&self.ctx.read_buffer(&a.buf, n * 4)?)
        } else {
            Vec::new()
        };
        let normals: Vec<[f32; 4]> = match &self.normals {
            Some(nb) if self.has_normals() && n > 0 => bytemuck::pod_collect_to_vec(
                &self
                    .ctx
                    .read_buffer(&nb.buf, n * NORMAL_BYTES_PER_TRIANGLE)?,
            ),
            _ => Vec::new(),
        };
        Ok(FrameOutput {
            k: self.level_count,
            control,
            vertices,
            areas,
            normals,
        })
    }
}

/// Runs `frame` on `base` (a fresh fork of it), splitting it into level
/// ranges while one range's buffers exceed the storage binding limit.
/// Returns the emitters that hold the chunks' output, in level order, each
/// with its first level. A single level too large is an error.
pub fn emit_chunked<'c>(
    base: &GpuEmitter<'c>,
    frame: &Frame,
    write_areas: bool,
) -> Result<Vec<(GpuEmitter<'c>, u32)>, GpuError> {
    let mut out = Vec::new();
    let mut todo = vec![(0usize, frame.levels.len())];
    while let Some((a, b)) = todo.pop() {
        let sub = frame.level_range(a, b);
        let mut e = base.fork();
        match e.run(&sub, write_areas) {
            Ok(()) => out.push((e, a as u32)),
            Err(GpuError::FrameTooLarge { .. }) if b - a > 1 => {
                let m = (a + b) / 2;
                // Popped last-in first-out: the lower half first.
                todo.push((m, b));
                todo.push((a, m));
            }
            Err(e) => return Err(e),
        }
    }
    Ok(out)
}

impl GpuEmitter<'_> {
    /// The GPU-only span-space frame: bins every live cell into
    /// the levels it spans on the GPU (`wgsl/bin.wgsl`), then counts, scans
    /// and emits as [`GpuEmitter::run`]. No CPU sweep; returns the number
    /// of (cell, level) entries. `timings.upload` covers the binning.
    pub fn run_span(&mut self, levels: &[f32], write_areas: bool) -> Result<u32, GpuError> {
        let ctx = self.ctx;
        let t0 = Instant::now();
        let k = levels.len() as u32;
        let lay = ControlLayout { k };
        let st = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        self.prepare(8, levels, lay)?;
        let q = &ctx.queue;
        let maxx = ctx.limits.max_compute_workgroups_per_dimension;
        let live_groups = dispatch_size(self.grid.live.len() as u32, maxx);
        let empty = Frame {
            levels: levels.to_vec(),
            ..Default::default()
        };
        let mut p = emit_params(&self.grid, &empty, 0, write_areas, live_groups.0);
        p.live_count = self.grid.live.len() as u32;
        q.write_buffer(&self.params, 0, bytemuck::bytes_of(&p));
        let control = self.control.as_ref().expect("allocated").buf.clone();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&control, 0, None);
        let bg = self.bind_group();
        self.dispatch(&mut enc, &bg, &self.bin_count.clone(), live_groups);
        q.submit([enc.finish()]);
        let n = self.read_words(&control, lay.bin_total() as u64 * 4, 1)?[0];
        Self::ensure(
            ctx,
            &mut self.entries,
            "the frame's (cell, level) entries",
            n as u64 * 8,
            st,
        )?;
        p.entry_count = n;
        q.write_buffer(&self.params, 0, bytemuck::bytes_of(&p));
        let bg = self.bind_group();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.dispatch(&mut enc, &bg, &self.bin_fill.clone(), live_groups);
        q.submit([enc.finish()]);
        let t1 = Instant::now();
        // Count, scan and emit over the binned entries.
        let groups = dispatch_size(n, maxx);
        p.row_width = groups.0 * super::shared::WORKGROUP;
        q.write_buffer(&self.params, 0, bytemuck::bytes_of(&p));
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.dispatch(&mut enc, &bg, &self.count.clone(), groups);
        self.dispatch(&mut enc, &bg, &self.scan.clone(), (1, 1));
        q.submit([enc.finish()]);
        self.size_and_emit(p, groups, &control, lay, write_areas, [t0, t1])?;
        Ok(n)
    }
}
