//! The slices of a [`SliceKey`] emitted on the GPU: the CPU sweep (or GPU
//! span-space binning) finds the cut cells, the compute engine emits the
//! triangles (S-CGraph, CGraph and CP-Graph; [`super::host_slices`] takes
//! any structure), with the attribute clamped into f32, the gradient or the
//! index-space field that pre-integration needs, and the IJK clip.

use crate::gpu::compute::emit::{GpuEmitter, emit_chunked};
use crate::gpu::compute::gradient::vertex_gradients;
use crate::gpu::compute::slice::{prepare, prepare_unswept};
use crate::gpu::compute::tables::{Frame, GridBuffers, slot_values};
use crate::gpu::context::{GpuContext, GpuError};
use crate::gpu::shared::Entry;
use crate::grid::Grid;
use crate::pipeline::{PipelineError, SliceRequest, vertex_property};
use crate::structures::Structure;

use super::error::RenderError;
use super::options::CellFinding;
use super::preintegrated::boundary::{IjkBox, graph_boundary_triangles};
use super::preintegrated::ijk_field::IjkField;
use super::preintegrated::pass::BoundaryMesh;
use super::slice_cache::{SliceKey, SliceSet};
use super::transfer::VALUE_LIMIT;

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
    shown_values(s, cell_values.as_deref(), &mut p.grid)?;
    let mut cp_boundary = None;
    let (field, field_fallback) = match k.attr_gradient && !k.iso {
        true => match IjkField::new(ctx, grid, s, property.as_deref()) {
            Ok((f, ijk)) => {
                if let Structure::CpGraph(g) = s {
                    // Corner-point grids: the outer surface of the graph.
                    let t = graph_boundary_triangles(g.as_ref(), &ijk);
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

/// The values the slices carry in `g`: the cell values per slot when the
/// shown property is a cell property, then every value clamped into f32.
fn shown_values(
    s: &Structure,
    cell_values: Option<&[f64]>,
    g: &mut GridBuffers,
) -> Result<(), RenderError> {
    if let Some(v) = cell_values {
        g.attr = match s {
            Structure::SCGraph(c) => slot_values(c, v),
            Structure::CGraph(c) => slot_values(c, v),
            Structure::CpGraph(c) => slot_values(c.as_ref(), v),
            // `prepare` already refused CIEL grids.
            Structure::Ciel(_) => {
                return Err(PipelineError::Unsupported(
                    "the GPU path does not take CIEL grids".into(),
                )
                .into());
            }
        };
        g.attr_per_cell = true;
    }
    // Values beyond f32 (or near its limit) clamped, so that no
    // interpolation on the GPU makes a NaN (the LUT's range is clamped alike).
    let limit = VALUE_LIMIT;
    for a in g.attr.iter_mut() {
        *a = a.clamp(-limit, limit);
    }
    Ok(())
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
fn clip_entries(s: &Structure, c: IjkBox, entries: &mut Vec<Entry>) -> Result<(), RenderError> {
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
