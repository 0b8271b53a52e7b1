//! `slice --device gpu`: the pipeline's field binding and level placement
//! (as [`crate::pipeline::slice`]), the CPU sweep for the per-level active
//! cells, then emission on the GPU (or by the twin) and statistics from its
//! counters.

use std::time::Instant;

use thiserror::Error;

use crate::field::ScalarField;
use crate::grid::Grid;
use crate::pipeline::{PipelineError, SliceRequest, SliceResult, Timings};
use crate::pipeline::{bind, level_value, level_warnings, live_range, place_levels};
use crate::structures::Structure;
use crate::sweep::{CellGraph, LevelStats};

use super::emit::{EmitTimings, GpuEmitter, emit_chunked};
use super::tables::{Frame, GridBuffers, sweep_frame};
use crate::gpu::context::{GpuContext, GpuError};

/// Errors of the GPU slicing path.
#[derive(Debug, Error)]
pub enum GpuSliceError {
    /// The pipeline refused the request.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// The GPU failed.
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// Everything a frame needs, prepared on the CPU.
pub struct Prepared {
    /// Grid-side buffers (field bound).
    pub grid: GridBuffers,
    /// The frame: level values and the sweep's active cells.
    pub frame: Frame,
    /// World level values.
    pub level_values: Vec<f64>,
    /// Levels outside the field's range ([`level_warnings`]).
    pub warnings: Vec<String>,
    /// Name of the interpolated attribute.
    pub attribute_name: String,
    /// The CPU sweep's own per-level statistics (cells and visits; it
    /// emits no polygons).
    pub cpu_stats: Vec<LevelStats>,
    /// Seconds of the sweep (cut cells only, no emission).
    pub sweep_s: f64,
    /// Per level: the distinct input cells among the frame's cut cells (the
    /// convex pieces of a split cell count once, as on the CPU path).
    pub input_cells: Vec<u64>,
}

/// Binds the field as [`crate::pipeline::slice`] does, places the levels,
/// runs the CPU sweep for the active cells and builds the buffers.
pub fn prepare(grid: &Grid, s: &Structure, req: &SliceRequest) -> Result<Prepared, PipelineError> {
    prepare_with(grid, s, req, true)
}

/// As [`prepare`] without the CPU sweep: the frame has its levels and no
/// entries, for GPU span-space binning ([`GpuEmitter::run_span`]).
pub fn prepare_unswept(
    grid: &Grid,
    s: &Structure,
    req: &SliceRequest,
) -> Result<Prepared, PipelineError> {
    prepare_with(grid, s, req, false)
}

fn prepare_with(
    grid: &Grid,
    s: &Structure,
    req: &SliceRequest,
    sweep: bool,
) -> Result<Prepared, PipelineError> {
    let b = bind(grid, s, req)?;
    let (f, attribute) = (b.field(), b.attribute.as_deref());
    let (axis_slot, offset) = (b.axis_slot, b.world_offset);
    let mut p = match s {
        Structure::SCGraph(g) => finish(
            g,
            &f,
            axis_slot,
            offset,
            (req, sweep),
            attribute,
            GridBuffers::scgraph,
        ),
        Structure::CGraph(g) => finish(
            &g.inner,
            &f,
            axis_slot,
            offset,
            (req, sweep),
            attribute,
            GridBuffers::cgraph,
        ),
        Structure::CpGraph(g) => finish(
            g.as_ref(),
            &f,
            axis_slot,
            offset,
            (req, sweep),
            attribute,
            GridBuffers::cgraph,
        ),
        Structure::Ciel(_) => Err(PipelineError::Unsupported(
            "the GPU path takes S-CGraph and CGraph grids; this grid needs CIEL \
             (polyhedra with more than 12 vertices)"
                .into(),
        )),
    }?;
    p.attribute_name = b.attribute_name.unwrap_or_else(|| "level_value".into());
    p.input_cells = match s {
        Structure::SCGraph(g) => input_cells(g, &p.frame),
        Structure::CGraph(g) => input_cells(g, &p.frame),
        Structure::CpGraph(g) => input_cells(g.as_ref(), &p.frame),
        Structure::Ciel(_) => Vec::new(), // refused above
    };
    Ok(p)
}

/// Per level, the number of distinct input cells among the frame's cut
/// cells (slots mapped through [`CellGraph::source_cell`]).
fn input_cells<G: CellGraph>(g: &G, frame: &Frame) -> Vec<u64> {
    let mut per_level = vec![Vec::new(); frame.levels.len()];
    for e in &frame.entries {
        per_level[e.level as usize].push(g.source_cell(e.slot));
    }
    per_level
        .into_iter()
        .map(|mut c| {
            c.sort_unstable();
            c.dedup();
            c.len() as u64
        })
        .collect()
}

fn finish<G: CellGraph, F: ScalarField>(
    g: &G,
    f: &F,
    axis_slot: Option<usize>,
    world_offset: f64,
    (req, sweep): (&SliceRequest, bool),
    attribute: Option<&[f32]>,
    build: impl Fn(&G, &F, Option<&[f32]>) -> GridBuffers,
) -> Result<Prepared, PipelineError> {
    let range = live_range(g, f);
    let (world, levels) = place_levels(range, world_offset, &req.levels)?;
    let warnings = level_warnings(&req.field, range, world_offset, &world, &levels);
    let t = Instant::now();
    let (frame, cpu_stats) = match sweep {
        true => sweep_frame(g, f, axis_slot, &levels, req.threads, &req.sweep.cancel)?,
        false => (
            Frame {
                visited: vec![0; levels.len()],
                levels,
                entries: Vec::new(),
            },
            Vec::new(),
        ),
    };
    let sweep_s = t.elapsed().as_secs_f64();
    let mut grid = build(g, f, attribute);
    if attribute.is_none() {
        // The level's world value on its vertices, as the CPU's
        // (`pipeline::level_value`).
        grid.level_offset = level_value(0.0, world_offset);
    }
    Ok(Prepared {
        grid,
        frame,
        level_values: world,
        warnings: warnings.into_iter().collect(),
        attribute_name: String::new(),
        cpu_stats,
        sweep_s,
        input_cells: Vec::new(),
    })
}

/// Where the emission of [`slice_on`] runs.
pub enum Emitter<'a> {
    /// The GPU.
    Gpu(&'a GpuContext),
    /// The CPU twin of the compute passes.
    Twin,
}

/// Slices with GPU (or twin) emission and returns the pipeline's result
/// type, with statistics from the emitted output (no mesh).
pub fn slice_on(
    em: Emitter,
    grid: &Grid,
    s: &Structure,
    req: &SliceRequest,
) -> Result<(SliceResult, EmitTimings), GpuSliceError> {
    let p = prepare(grid, s, req)?;
    let (stats, timings) = match em {
        Emitter::Gpu(ctx) => {
            let base = GpuEmitter::new(ctx, p.grid)?;
            let chunks = emit_chunked(&base, &p.frame, true)?;
            let mut stats = Vec::with_capacity(p.frame.levels.len());
            let mut t = EmitTimings {
                chunks: chunks.len(),
                grid_parts: base.grid_parts(),
                ..Default::default()
            };
            for (i, (e, a)) in chunks.iter().enumerate() {
                let b = chunks
                    .get(i + 1)
                    .map_or(p.frame.levels.len(), |c| c.1 as usize);
                let sub = p.frame.level_range(*a as usize, b);
                stats.extend(e.read_output(true)?.stats(&sub));
                t.upload += e.timings.upload;
                t.count += e.timings.count;
                t.emit += e.timings.emit;
            }
            (stats, t)
        }
        Emitter::Twin => {
            let out = super::twin::run(&p.grid, &p.frame, true);
            (out.stats(&p.frame), EmitTimings::default())
        }
    };
    let mut stats = stats;
    for (st, &n) in stats.iter_mut().zip(&p.input_cells) {
        st.cells = n;
    }
    Ok((
        SliceResult {
            level_values: p.level_values,
            stats,
            mesh: None,
            minima: 0,
            sweep_state_bytes: 0,
            timings: Timings {
                sweep: p.sweep_s,
                ..Default::default()
            },
            attribute_name: p.attribute_name,
            warnings: p.warnings,
        },
        timings,
    ))
}
