//! GPU emission: the grid and catalog in storage buffers, then per frame
//! the count, scan and emit passes (`wgsl/count.wgsl`, `wgsl/scan.wgsl`,
//! `wgsl/emit.wgsl`). Triangles land in per-level regions of one vertex
//! buffer whose capacity follows the frame's exact triangle total (read
//! back after the scan), and one `DrawIndirectArgs` per level (both
//! orders) sits in the control buffer for the render pass.

use std::time::Instant;

use wgpu::util::DeviceExt;

use super::frame::FrameOutput;
use super::grid_parts::{GridPart, split_frame, split_grid};
use super::tables::{Frame, GridBuffers, dispatch_size, emit_params};
use crate::gpu::context::{GpuContext, GpuError};
use crate::gpu::shaders;
use crate::gpu::shared::{ControlLayout, EmitParams, OutVertex};

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
    /// Grid parts bound in turn (1 when the grid fit one storage binding).
    pub grid_parts: usize,
}

/// One grid part's parameters and dispatch size within a frame.
struct PartRun {
    p: EmitParams,
    groups: (u32, u32),
}

/// A growable GPU buffer.
struct Grow {
    buf: wgpu::Buffer,
    cap: u64,
}

/// One grid part's buffers on the device (see [`super::grid_parts`]).
struct PartGpu {
    host: GridPart,
    grid_buf: wgpu::Buffer,
    attr: wgpu::Buffer,
    cells: wgpu::Buffer,
    grad: wgpu::Buffer,
    live: wgpu::Buffer,
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
    /// The grid parts (one unless the grid exceeds a storage binding).
    parts: std::sync::Arc<Vec<PartGpu>>,
    /// Per part: the frame parameters (the parts differ in entries and layout).
    params: Vec<wgpu::Buffer>,
    tables: wgpu::Buffer,
    /// Per part: the frame's entries with the part's local slots.
    entries: Vec<Option<Grow>>,
    /// The normals buffer holds host-made normals ([`Self::from_output`]).
    host_normals: bool,
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

/// Bytes one grid-part buffer may hold: one storage binding and one
/// buffer, rounded down to 16 bytes.
fn part_budget(ctx: &GpuContext) -> u64 {
    ctx.limits
        .max_storage_buffer_binding_size
        .min(ctx.limits.max_buffer_size)
        / 16
        * 16
}

fn params_buffer(ctx: &GpuContext) -> wgpu::Buffer {
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("params"),
        size: std::mem::size_of::<EmitParams>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// The bind group layout of the compute passes (uniform 0, storage 1..=12).
fn compute_layout(ctx: &GpuContext) -> wgpu::BindGroupLayout {
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
    ctx.device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("emit"),
            entries: &entries,
        })
}

/// Uploads one grid part (out of memory is an error, not a panic).
fn upload_part(ctx: &GpuContext, host: GridPart) -> Result<PartGpu, GpuError> {
    let st = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
    let g = &host.buffers;
    let bytes = super::grid_parts::largest_buffer(g);
    for (what, n) in [
        ("the grid vertices (position + φ)", g.grid.len() as u64 * 16),
        ("the zoo cells", g.cells.len() as u64 * 4),
        ("the vertex attribute", g.attr.len() as u64 * 4),
        ("the vertex gradients", g.grad.len() as u64 * 16),
        ("the live cell list", g.live.len() as u64 * 4),
    ] {
        ctx.check_storage(what, n)?;
    }
    let up = |label: &str, data: &[u8]| init_buffer(ctx, label, data, st);
    let (grid_buf, attr, cells, grad, live) = ctx.allocate(
        &format!("the grid buffers ({} bytes in the largest)", bytes),
        || {
            (
                up("grid", bytemuck::cast_slice(&g.grid)),
                up("attr", bytemuck::cast_slice(&g.attr)),
                up("cells", bytemuck::cast_slice(&g.cells)),
                up("grad", bytemuck::cast_slice(&g.grad)),
                up("live", bytemuck::cast_slice(&g.live)),
            )
        },
    )?;
    Ok(PartGpu {
        host,
        grid_buf,
        attr,
        cells,
        grad,
        live,
    })
}

impl<'c> GpuEmitter<'c> {
    /// Uploads the grid side and builds the pipelines. A grid whose
    /// buffers exceed one storage binding is split into parts
    /// ([`super::grid_parts`]), each bound in turn.
    pub fn new(ctx: &'c GpuContext, grid: GridBuffers) -> Result<Self, GpuError> {
        Self::with_part_budget(ctx, grid, None)
    }

    /// As [`Self::new`], with grid parts of at most `max_part_bytes` per
    /// buffer when given (below the device's own limit: tests force a
    /// small grid into several parts with it).
    pub fn with_part_budget(
        ctx: &'c GpuContext,
        grid: GridBuffers,
        max_part_bytes: Option<u64>,
    ) -> Result<Self, GpuError> {
        if ctx.limits.max_storage_buffers_per_shader_stage < STORAGE_BINDINGS {
            return Err(GpuError::Unsupported {
                adapter: ctx.name.clone(),
                why: format!(
                    "{STORAGE_BINDINGS} storage buffers per stage needed, {} allowed",
                    ctx.limits.max_storage_buffers_per_shader_stage
                ),
            });
        }
        ctx.check_storage("the meta-cell tables", grid.tables.len() as u64 * 4)?;
        let layout = compute_layout(ctx);
        let pl = ctx
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("emit"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        let f64d = ctx.shader_f64;
        let src = |s| shaders::compute_source(s, f64d);
        let count = pipeline(ctx, &pl, "count.wgsl", src(shaders::COUNT), "count")?;
        let scan = pipeline(ctx, &pl, "scan.wgsl", src(shaders::SCAN), "scan")?;
        let emit = pipeline(ctx, &pl, "emit.wgsl", src(shaders::EMIT), "emit")?;
        let bin_count = pipeline(ctx, &pl, "bin.wgsl", src(shaders::BIN), "bin_count")?;
        let bin_fill = pipeline(ctx, &pl, "bin.wgsl", src(shaders::BIN), "bin_fill")?;
        let budget = part_budget(ctx).min(max_part_bytes.unwrap_or(u64::MAX) / 16 * 16);
        let parts = split_grid(grid, budget).map_err(|e| GpuError::TooLarge {
            what: format!("cell (slot {}) alone", e.slot),
            bytes: e.bytes,
            limit: e.budget,
            kind: "storage binding",
            adapter: ctx.name.clone(),
        })?;
        let st = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let tables = ctx.allocate("the meta-cell tables", || {
            let b = &parts[0].buffers;
            init_buffer(ctx, "tables", bytemuck::cast_slice(&b.tables), st)
        })?;
        let parts = parts
            .into_iter()
            .map(|host| upload_part(ctx, host))
            .collect::<Result<Vec<_>, _>>()?;
        let n = parts.len();
        ctx.check()?;
        Ok(GpuEmitter {
            ctx,
            layout,
            count,
            scan,
            emit,
            bin_count,
            bin_fill,
            parts: std::sync::Arc::new(parts),
            params: (0..n).map(|_| params_buffer(ctx)).collect(),
            tables,
            entries: (0..n).map(|_| None).collect(),
            host_normals: false,
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
        let n = self.parts.len();
        GpuEmitter {
            ctx: self.ctx,
            layout: self.layout.clone(),
            count: self.count.clone(),
            scan: self.scan.clone(),
            emit: self.emit.clone(),
            bin_count: self.bin_count.clone(),
            bin_fill: self.bin_fill.clone(),
            parts: self.parts.clone(),
            params: (0..n).map(|_| params_buffer(self.ctx)).collect(),
            tables: self.tables.clone(),
            entries: (0..n).map(|_| None).collect(),
            host_normals: false,
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

    /// An emitter whose output was made on the host (the CPU sweep's
    /// polygons of a grid the GPU tables cannot express, see
    /// `gpu::render::host_slices`): `out`'s triangles and control words
    /// uploaded as if the passes had written them; with `normals`, `out`'s
    /// per-corner normals (zero when it has none: the render pass then
    /// shades with the facet normal).
    pub fn from_output(
        ctx: &'c GpuContext,
        out: &FrameOutput,
        normals: bool,
    ) -> Result<Self, GpuError> {
        let mut e = Self::new(ctx, GridBuffers::default())?;
        e.upload_output(out, normals)?;
        Ok(e)
    }

    /// Replaces this emitter's output by `out` (see [`Self::from_output`];
    /// a [`Self::fork`] of a host emitter shares its pipelines).
    pub fn upload_output(&mut self, out: &FrameOutput, normals: bool) -> Result<(), GpuError> {
        let ctx = self.ctx;
        let st = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let vst = st | wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_SRC;
        let lay = ControlLayout { k: out.k };
        self.prepare(&[], lay)?;
        let n = out.vertices.len() as u64 / 3;
        let upload = |slot: &mut Option<Grow>, what: &str, data: &[u8], usage| {
            Self::ensure(ctx, slot, what, data.len() as u64, usage)?;
            if !data.is_empty() {
                let buf = &slot.as_ref().expect("allocated").buf;
                ctx.queue.write_buffer(buf, 0, data);
            }
            Ok::<(), GpuError>(())
        };
        upload(
            &mut self.vertices,
            "the host triangles",
            bytemuck::cast_slice(&out.vertices),
            vst,
        )?;
        upload(
            &mut self.control,
            "the draw arguments and counters",
            bytemuck::cast_slice(&out.control),
            st | wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_SRC,
        )?;
        if normals {
            let zeros;
            let data: &[u8] = if out.normals.len() == out.vertices.len() {
                bytemuck::cast_slice(&out.normals)
            } else {
                zeros = vec![0u8; (n * NORMAL_BYTES_PER_TRIANGLE) as usize];
                &zeros
            };
            upload(&mut self.normals, "the host normals", data, vst)?;
        }
        ctx.wait()?;
        self.host_normals = normals;
        self.level_count = out.k;
        self.triangles = n as u32;
        Ok(())
    }

    /// Grid parts bound in turn (1 unless the grid exceeds a storage binding).
    pub fn grid_parts(&self) -> usize {
        self.parts.len()
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
            // Free the old buffer before asking for the larger one.
            *slot = None;
            let buf = ctx.allocate(&format!("{what} ({cap} bytes)"), || {
                ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(what),
                    size: cap,
                    usage,
                    mapped_at_creation: false,
                })
            })?;
            *slot = Some(Grow { buf, cap });
        }
        Ok(())
    }

    /// The bind group of grid part `i` with this emitter's frame buffers.
    fn bind_group(&self, i: usize) -> wgpu::BindGroup {
        fn b(g: &Option<Grow>) -> wgpu::BindingResource<'_> {
            g.as_ref().expect("allocated").buf.as_entire_binding()
        }
        let part = &self.parts[i];
        let bufs = [
            self.params[i].as_entire_binding(),
            self.tables.as_entire_binding(),
            part.grid_buf.as_entire_binding(),
            part.attr.as_entire_binding(),
            part.cells.as_entire_binding(),
            b(&self.entries[i]),
            b(&self.control),
            b(&self.vertices),
            b(&self.areas),
            b(&self.levels),
            part.live.as_entire_binding(),
            part.grad.as_entire_binding(),
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

    /// Runs one frame on the GPU: uploads the levels and entries, counts
    /// (once per grid part, into the same counters), scans, sizes the
    /// vertex buffer to the exact total and emits (once per part, into
    /// the same level regions). The triangles and draw arguments stay on
    /// the GPU ([`Self::vertex_buffer`], [`Self::control_buffer`]);
    /// [`Self::read_output`] fetches them.
    pub fn run(&mut self, frame: &Frame, write_areas: bool) -> Result<(), GpuError> {
        let ctx = self.ctx;
        let t0 = Instant::now();
        let k = frame.levels.len() as u32;
        let lay = ControlLayout { k };
        self.prepare(&frame.levels, lay)?;
        let split;
        let subs: &[Frame] = if self.parts.len() == 1 {
            std::slice::from_ref(frame)
        } else {
            let ranges: Vec<(u32, u32)> = self
                .parts
                .iter()
                .map(|p| (p.host.slot_lo, p.host.slot_hi))
                .collect();
            split = split_frame(&ranges, frame);
            &split
        };
        let maxx = ctx.limits.max_compute_workgroups_per_dimension;
        let mut runs = Vec::with_capacity(subs.len());
        for (i, sub) in subs.iter().enumerate() {
            Self::ensure(
                ctx,
                &mut self.entries[i],
                "the frame's (cell, level) entries",
                sub.entries.len() as u64 * 8,
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            )?;
            if !sub.entries.is_empty() {
                ctx.queue.write_buffer(
                    &self.entries[i].as_ref().expect("allocated").buf,
                    0,
                    bytemuck::cast_slice(&sub.entries),
                );
            }
            let groups = dispatch_size(sub.entries.len() as u32, maxx);
            let p = emit_params(&self.parts[i].host.buffers, sub, 0, write_areas, groups.0);
            ctx.queue
                .write_buffer(&self.params[i], 0, bytemuck::bytes_of(&p));
            runs.push(PartRun { p, groups });
        }
        let control = self.control.as_ref().expect("allocated").buf.clone();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&control, 0, None);
        ctx.wait()?;
        let t1 = Instant::now();
        for (i, r) in runs.iter().enumerate() {
            if r.p.entry_count > 0 || i == 0 {
                let bg = self.bind_group(i);
                self.dispatch(&mut enc, &bg, &self.count.clone(), r.groups);
            }
        }
        let bg = self.bind_group(0);
        self.dispatch(&mut enc, &bg, &self.scan.clone(), (1, 1));
        ctx.queue.submit([enc.finish()]);
        self.size_and_emit(&mut runs, &control, lay, write_areas, [t0, t1])?;
        Ok(())
    }

    /// Makes the levels, the control block of `lay` and the outputs exist
    /// (outputs at their minimum until [`Self::size_and_emit`] sizes them)
    /// and uploads the level values.
    fn prepare(&mut self, levels: &[f32], lay: ControlLayout) -> Result<(), GpuError> {
        let ctx = self.ctx;
        let st = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
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
        for e in &mut self.entries {
            Self::ensure(ctx, e, "the frame's (cell, level) entries", 8, st)?;
        }
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
    /// sizes the outputs to it exactly, runs the emit pass of every part
    /// with entries and records the timings (`times` = start, end of upload).
    fn size_and_emit(
        &mut self,
        runs: &mut [PartRun],
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
        if self.has_normals() {
            Self::ensure(
                ctx,
                &mut self.normals,
                "the output normals",
                total as u64 * NORMAL_BYTES_PER_TRIANGLE,
                vst,
            )?;
        }
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        for (i, r) in runs.iter_mut().enumerate() {
            if r.p.entry_count == 0 {
                continue;
            }
            r.p.triangle_capacity = total;
            q.write_buffer(&self.params[i], 0, bytemuck::bytes_of(&r.p));
            let bg = self.bind_group(i);
            self.dispatch(&mut enc, &bg, &self.emit.clone(), r.groups);
        }
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
            grid_parts: self.parts.len(),
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
        self.host_normals || !self.parts[0].host.buffers.grad.is_empty()
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
        if self.parts.len() > 1 {
            return Err(GpuError::Unsupported {
                adapter: ctx.name.clone(),
                why: format!(
                    "span-space binning on a grid split into {} parts (over one storage binding)",
                    self.parts.len()
                ),
            });
        }
        let t0 = Instant::now();
        let k = levels.len() as u32;
        let lay = ControlLayout { k };
        let st = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        self.prepare(levels, lay)?;
        let q = &ctx.queue;
        let maxx = ctx.limits.max_compute_workgroups_per_dimension;
        let live_len = self.parts[0].host.buffers.live.len() as u32;
        let live_groups = dispatch_size(live_len, maxx);
        let empty = Frame {
            levels: levels.to_vec(),
            ..Default::default()
        };
        let mut p = emit_params(
            &self.parts[0].host.buffers,
            &empty,
            0,
            write_areas,
            live_groups.0,
        );
        p.live_count = live_len;
        q.write_buffer(&self.params[0], 0, bytemuck::bytes_of(&p));
        let control = self.control.as_ref().expect("allocated").buf.clone();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&control, 0, None);
        let bg = self.bind_group(0);
        self.dispatch(&mut enc, &bg, &self.bin_count.clone(), live_groups);
        q.submit([enc.finish()]);
        let n = self.read_words(&control, lay.bin_total() as u64 * 4, 1)?[0];
        Self::ensure(
            ctx,
            &mut self.entries[0],
            "the frame's (cell, level) entries",
            n as u64 * 8,
            st,
        )?;
        p.entry_count = n;
        q.write_buffer(&self.params[0], 0, bytemuck::bytes_of(&p));
        let bg = self.bind_group(0);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.dispatch(&mut enc, &bg, &self.bin_fill.clone(), live_groups);
        q.submit([enc.finish()]);
        let t1 = Instant::now();
        // Count, scan and emit over the binned entries.
        let groups = dispatch_size(n, maxx);
        p.row_width = groups.0 * crate::gpu::shared::WORKGROUP;
        q.write_buffer(&self.params[0], 0, bytemuck::bytes_of(&p));
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        self.dispatch(&mut enc, &bg, &self.count.clone(), groups);
        self.dispatch(&mut enc, &bg, &self.scan.clone(), (1, 1));
        q.submit([enc.finish()]);
        let mut runs = [PartRun { p, groups }];
        self.size_and_emit(&mut runs, &control, lay, write_areas, [t0, t1])?;
        Ok(n)
    }
}
