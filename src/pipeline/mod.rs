//! Orchestration without I/O: pick a structure for a grid, bind a field,
//! place the levels, run the sweep (or the brute force) and gather
//! statistics and, on request, the welded output mesh in canonical order.

use std::time::Instant;

use thiserror::Error;

mod canonical;
mod levels;

pub use levels::{field_name, level_warnings};

use canonical::{LevelCopy, canonical_mesh};

use crate::bruteforce::brute_force;
use crate::cancel::{Interrupted, catch_interrupt, stop_if_cancelled};
use crate::extract::{EmitContext, LevelMesh};
use crate::field::{
    AxisField, FieldSpec, LevelError, PlaneField, ScalarField, VertexField, local_levels,
    materialise, try_levels_by_count,
};
use crate::grid::{Grid, GridError};
use crate::mesh::PolyMesh;
use crate::structures::ciel::{Ciel, CielSweeper};
use crate::structures::convex_split::{Split, SplitError, SplitMap};
use crate::structures::{Structure, StructureError};
use crate::sweep::{CellGraph, LevelStats, SweepOptions, Sweeper};

/// Errors of the pipeline.
#[derive(Debug, Error)]
pub enum PipelineError {
    /// Invalid grid.
    #[error(transparent)]
    Grid(#[from] GridError),
    /// Structure build failed.
    #[error(transparent)]
    Structure(#[from] StructureError),
    /// Bad levels.
    #[error(transparent)]
    Levels(#[from] LevelError),
    /// A named property that does not exist.
    #[error(
        "no property named '{name}'{} (point properties: {points:?}; cell properties: {cells:?})",
        suggestion.as_ref().map(|s| format!(": did you mean '{s}'?")).unwrap_or_default()
    )]
    NoSuchProperty {
        /// Requested name.
        name: String,
        /// The closest property name, when one is close.
        suggestion: Option<String>,
        /// Available point properties.
        points: Vec<String>,
        /// Available cell properties.
        cells: Vec<String>,
    },
    /// The run's cancellation token was set.
    #[error("the slicing run was interrupted")]
    Interrupted(#[from] Interrupted),
    /// The field is constant over the grid: no level can cut it.
    #[error("the field is constant ({0}) over the live cells: nothing to slice")]
    ConstantField(f64),
    /// No live cell remains.
    #[error("no live cells to slice (all hidden or degenerate)")]
    NoLiveCells,
    /// The structure cannot be used on this path.
    #[error("{0}")]
    Unsupported(String),
    /// A non-convex cell that cannot be split into convex pieces.
    #[error(transparent)]
    Split(#[from] SplitError),
    /// The structure could not be built.
    #[error(transparent)]
    Build(#[from] crate::structures::BuildError),
    /// The output (or another array the run sizes) did not fit in memory.
    #[error(transparent)]
    Memory(#[from] crate::mem::AllocError),
}

/// How levels are placed.
#[derive(Clone, Debug, PartialEq)]
pub enum LevelSpec {
    /// `t_k = lo + (k + 0.5)(hi − lo)/K` over the live cells' φ range.
    Count(usize),
    /// Explicit world values (increasing).
    Values(Vec<f64>),
}

/// A slicing request.
#[derive(Clone, Debug)]
pub struct SliceRequest {
    /// What to slice by.
    pub field: FieldSpec,
    /// Where the levels go.
    pub levels: LevelSpec,
    /// Property interpolated onto the polygons (default: the isosurface
    /// property, else the first point property, else the level value).
    pub attribute: Option<String>,
    /// Spatial blocks swept in parallel.
    pub threads: usize,
    /// Use the brute-force reference instead of the sweep.
    pub brute_force: bool,
    /// Gather the output mesh (for writing files).
    pub collect_mesh: bool,
    /// The sweep's loop choices (defaults choose by themselves).
    pub sweep: SweepOptions,
}

/// Timings of one slicing run, seconds.
#[derive(Clone, Copy, Debug, Default)]
pub struct Timings {
    /// Binding the field and placing levels.
    pub setup: f64,
    /// Evaluating φ at every vertex (planes; properties are used as they are).
    pub field: f64,
    /// Finding (or fetching cached) minima.
    pub minima: f64,
    /// The sweep itself.
    pub sweep: f64,
}

/// Result of a slicing run.
#[derive(Clone, Debug)]
pub struct SliceResult {
    /// World level values.
    pub level_values: Vec<f64>,
    /// Per-level statistics (summed over blocks).
    pub stats: Vec<LevelStats>,
    /// The output mesh, when requested.
    pub mesh: Option<PolyMesh>,
    /// Number of minima.
    pub minima: usize,
    /// Bytes of sweep state (stamps, queues, minima, buffers).
    pub sweep_state_bytes: usize,
    /// Timings.
    pub timings: Timings,
    /// Name of the interpolated attribute.
    pub attribute_name: String,
    /// What the caller should be told (levels outside the field's range).
    pub warnings: Vec<String>,
}

/// Resolves a point property by name, averaging a cell property to the
/// vertices (volume-weighted) when only a cell property has that name.
pub fn vertex_property(grid: &Grid, s: &Structure, name: &str) -> Result<Vec<f32>, PipelineError> {
    if let Some(p) = grid.point_property(name) {
        let vals: Vec<f64> = (0..p.len()).map(|i| p.scalar_at(i)).collect();
        let vals = match s.split() {
            Some(m) => m.extend_vertex_values(&vals),
            None => vals,
        };
        let mut out = crate::mem::huge_vec(vals.len());
        out.extend(vals.iter().map(|&v| v as f32));
        return Ok(out);
    }
    if let Some(p) = grid.cell_property(name) {
        let vals: Vec<f64> = (0..p.len()).map(|i| p.scalar_at(i)).collect();
        return Ok(match s {
            Structure::SCGraph(g) => crate::properties::cell_to_vertex(g, &vals, grid.points.len()),
            Structure::CGraph(g) => crate::properties::cell_to_vertex(g, &vals, g.positions.len()),
            Structure::CpGraph(g) => {
                crate::properties::cell_to_vertex(g.as_ref(), &vals, g.positions.len())
            }
            Structure::Ciel(g) => match &g.map {
                Some(m) => g.cell_to_vertex(&m.per_output_cell(&vals)),
                None => g.cell_to_vertex(&vals),
            },
        });
    }
    Err(no_such_property(grid, name))
}

/// The error for a property name the grid does not have, with the closest
/// name as a suggestion (names are matched without regard to case first:
/// see [`Grid::point_property`]).
pub fn no_such_property(grid: &Grid, name: &str) -> PipelineError {
    let points: Vec<String> = grid.point_data.iter().map(|p| p.name.clone()).collect();
    let cells: Vec<String> = grid.cell_data.iter().map(|p| p.name.clone()).collect();
    let lower = name.to_lowercase();
    let suggestion = points
        .iter()
        .chain(&cells)
        .map(|c| (strsim::normalized_levenshtein(&lower, &c.to_lowercase()), c))
        .filter(|(score, _)| *score >= 0.5)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, c)| c.clone());
    PipelineError::NoSuchProperty {
        name: name.to_string(),
        suggestion,
        points,
        cells,
    }
}

/// Per-vertex values of a request: the interpolated attribute's name (the
/// isosurface property, else the first point property) and values, and the
/// isosurface property's values. Shared by the CPU and GPU paths.
#[allow(clippy::type_complexity)]
pub fn request_values(
    grid: &Grid,
    s: &Structure,
    req: &SliceRequest,
) -> Result<(Option<String>, Option<Vec<f32>>, Option<Vec<f32>>), PipelineError> {
    let attr_name = req.attribute.clone().or_else(|| match &req.field {
        FieldSpec::Property(p) => Some(p.clone()),
        _ => grid.point_data.first().map(|p| p.name.clone()),
    });
    let attribute = match &attr_name {
        Some(n) => Some(vertex_property(grid, s, n)?),
        None => None,
    };
    let field_values = match &req.field {
        FieldSpec::Property(n) => Some(vertex_property(grid, s, n)?),
        _ => None,
    };
    Ok((attr_name, attribute, field_values))
}

/// A request bound to a grid and its structure: φ per vertex in the
/// structure's f32 local frame (materialised once: planes from the
/// positions by their field function, properties as they are), the
/// interpolated attribute, and what places the levels. Shared by the CPU
/// run, the GPU slice and the renderer, so all of them see the same bits.
pub struct Binding {
    /// φ per vertex.
    pub phi: Vec<f32>,
    /// The interpolated attribute's name (None: the level value).
    pub attribute_name: Option<String>,
    /// The attribute per vertex.
    pub attribute: Option<Vec<f32>>,
    /// World value of local φ = 0 (n·origin for planes, 0 for properties).
    pub world_offset: f64,
    /// The axis direction's slot for cached minima (axis fields only).
    pub axis_slot: Option<usize>,
    /// Seconds resolving the properties.
    pub setup_s: f64,
    /// Seconds materialising φ.
    pub field_s: f64,
}

impl Binding {
    /// φ as a field the sweeps read.
    pub fn field(&self) -> VertexField<'_> {
        VertexField { values: &self.phi }
    }
}

/// Binds `req`'s field, attribute and level frame to `s` (see [`Binding`]).
pub fn bind(grid: &Grid, s: &Structure, req: &SliceRequest) -> Result<Binding, PipelineError> {
    let t0 = Instant::now();
    let (attribute_name, attribute, field_values) = request_values(grid, s, req)?;
    let setup_s = t0.elapsed().as_secs_f64();
    let t_field = Instant::now();
    let pos = s.positions();
    let phi = match (&req.field, field_values) {
        (FieldSpec::Property(_), Some(v)) => v,
        (FieldSpec::Axis { axis, negative }, _) => {
            let sign = if *negative { -1.0 } else { 1.0 };
            let f = AxisField {
                axis: *axis,
                sign,
                positions: pos,
            };
            materialise(&f, pos.len())
        }
        _ => {
            let n = req.field.normal().expect("planar field");
            let f = PlaneField {
                normal: n.map(|c| c as f32),
                positions: pos,
            };
            materialise(&f, pos.len())
        }
    };
    Ok(Binding {
        phi,
        attribute_name,
        attribute,
        world_offset: req.field.world_offset(grid.origin()),
        axis_slot: req.field.axis_slot(),
        setup_s,
        field_s: t_field.elapsed().as_secs_f64(),
    })
}

/// Runs one slicing request on a built structure.
pub fn slice(
    grid: &Grid,
    s: &Structure,
    req: &SliceRequest,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<SliceResult, PipelineError> {
    let b = bind(grid, s, req)?;
    let runner: &dyn Runner = match s {
        Structure::SCGraph(g) => g,
        Structure::CGraph(g) => g,
        Structure::CpGraph(g) => g.as_ref(),
        Structure::Ciel(g) => g,
    };
    let mut r = run(runner, &b, req, s.split(), progress)?;
    r.timings.setup = b.setup_s;
    r.timings.field = b.field_s;
    r.attribute_name = b
        .attribute_name
        .clone()
        .unwrap_or_else(|| "level_value".into());
    if let Some(m) = &mut r.mesh {
        m.property_name = r.attribute_name.clone();
        m.origin = s.origin();
        if b.attribute.is_none() {
            // The sweeps write the local level: give the world one.
            for v in &mut m.values {
                *v = level_value(*v, b.world_offset);
            }
        }
    }
    Ok(r)
}

/// The value written on the vertices of local level `t` when no attribute
/// is interpolated: its world value, in f32 (`world_offset` from
/// [`Binding::world_offset`]; a UTM northing of 5.9e6 is kept to 0.5, a
/// depth of 2e3 to 1e-4; the exact f64 level is the polygons' own). The
/// GPU's emit pass adds the same f32 (`EmitParams::level_offset`), so CPU
/// and GPU values agree bit for bit.
#[inline]
pub fn level_value(t: f32, world_offset: f64) -> f32 {
    t + world_offset as f32
}

/// φ range over the vertices of live cells.
pub fn live_range<G: CellGraph, F: ScalarField>(g: &G, f: &F) -> Option<(f32, f32)> {
    if let Some(r) = g.phi_range_if_all_live(f) {
        return Some(r);
    }
    let mut ids = [0u32; crate::metacell::MAX_META_VERTICES];
    let mut lo = f32::INFINITY;
    let mut hi = f32::NEG_INFINITY;
    for s in 0..g.slot_count() as u32 {
        if g.is_live(s) {
            let (_, n) = g.cell(s, &mut ids);
            for &v in &ids[..n] {
                let p = f.phi(v);
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// World and local levels from a request, given the local φ range.
pub fn place_levels(
    range: Option<(f32, f32)>,
    world_offset: f64,
    spec: &LevelSpec,
) -> Result<(Vec<f64>, Vec<f32>), PipelineError> {
    let (lo, hi) = range.ok_or(PipelineError::NoLiveCells)?;
    let world = match spec {
        LevelSpec::Count(k) => {
            if lo == hi {
                return Err(PipelineError::ConstantField(lo as f64 + world_offset));
            }
            try_levels_by_count(lo as f64 + world_offset, hi as f64 + world_offset, *k)?
        }
        LevelSpec::Values(v) => v.clone(),
    };
    let levels = local_levels(&world, world_offset)?;
    Ok((world, levels))
}

/// Appends the split pieces cut at one level as (input cell, slot):
/// polygons of pieces of split cells, consecutive repeats dropped.
fn cut_pieces(
    mesh: &LevelMesh,
    m: &SplitMap,
    source: impl Fn(u32) -> u32,
    out: &mut Vec<(u32, u32)>,
) {
    for &slot in &mesh.cells {
        let src = source(slot);
        if m.is_split[src as usize] && out.last() != Some(&(src, slot)) {
            out.push((src, slot));
        }
    }
}

/// Per-level `cells` in input cells: the pieces of a split cell cut at a
/// level (gathered by [`cut_pieces`], over all blocks) count once.
fn count_input_cells(stats: &mut [LevelStats], mut cut: Vec<Vec<(u32, u32)>>) {
    for (st, c) in stats.iter_mut().zip(cut.iter_mut()) {
        c.sort_unstable();
        c.dedup();
        let mut sources = c.iter().map(|x| x.0).collect::<Vec<_>>();
        sources.dedup();
        st.cells = st.cells + sources.len() as u64 - c.len() as u64;
    }
}

/// A built structure as the pipeline runs it: the cell graphs (S-CGraph,
/// CGraph, CP-Graph) through the spatial-block [`Sweeper`] (which picks
/// their loop), CIEL through its level-range sweeper; [`run`] does the
/// rest once for all of them.
trait Runner: Sync {
    /// φ range over the vertices of live cells.
    fn live_range(&self, f: &VertexField) -> Option<(f32, f32)>;
    /// Vertex positions (the structure's local frame).
    fn positions(&self) -> &[[f32; 3]];
    /// The input cell of `slot`.
    fn source(&self, slot: u32) -> u32;
    /// The brute force over all levels, through the reused `mesh`.
    fn brute_force(&self, job: &Job, mesh: &mut LevelMesh, on_level: &mut OnLevel);
    /// The sweep, in parts made and filled by `gather`.
    fn sweep(&self, job: &Job, gather: &Gather, timings: &mut Timings) -> Swept;
}

/// A level's output, given to the run.
type OnLevel<'a> = dyn FnMut(usize, &LevelMesh, &LevelStats) + 'a;

/// What a run sweeps: φ, the local levels, the emission context and the
/// request (threads, field), with the axis slot for cached minima.
struct Job<'a> {
    f: &'a VertexField<'a>,
    levels: &'a [f32],
    ctx: &'a EmitContext<'a>,
    req: &'a SliceRequest,
    axis_slot: Option<usize>,
}

/// Levels `first..first + stats.len()` of one part of a run (a spatial
/// block: every level; a CIEL thread: a range of levels): per level its
/// statistics, polygons and cut split pieces.
struct Part {
    first: usize,
    stats: Vec<LevelStats>,
    /// Per level, its polygons (when the run collects the mesh).
    pieces: Vec<LevelCopy>,
    cut: Vec<Vec<(u32, u32)>>,
}

/// How a sweep hands its output to the run: `new_part` makes the part of a
/// range of levels, `on_level` stores a level (absolute index) into it.
struct Gather<'a> {
    new_part: &'a (dyn Fn(std::ops::Range<usize>) -> Part + Sync),
    on_level: &'a (dyn Fn(&mut Part, usize, &LevelMesh, &LevelStats) + Sync),
}

/// A sweep's parts, its minima count and its state bytes.
struct Swept {
    parts: Vec<Part>,
    minima: usize,
    state_bytes: usize,
}

impl<G: CellGraph> Runner for G {
    fn live_range(&self, f: &VertexField) -> Option<(f32, f32)> {
        live_range(self, f)
    }
    fn positions(&self) -> &[[f32; 3]] {
        CellGraph::positions(self)
    }
    fn source(&self, slot: u32) -> u32 {
        self.source_cell(slot)
    }
    fn brute_force(&self, job: &Job, mesh: &mut LevelMesh, on_level: &mut OnLevel) {
        brute_force(self, job.f, job.levels, job.ctx, mesh, on_level);
    }
    fn sweep(&self, job: &Job, gather: &Gather, timings: &mut Timings) -> Swept {
        let k = job.levels.len();
        let mut sw = Sweeper::new(self, job.req.threads.max(1));
        sw.options = job.req.sweep.clone();
        let t = Instant::now();
        let minima = sw.prepare_minima(job.f, job.axis_slot);
        timings.minima = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let parts = sw.sweep(
            job.f,
            job.axis_slot,
            job.levels,
            job.ctx,
            || (gather.new_part)(0..k),
            |p: &mut Part, lv, m, st| (gather.on_level)(p, lv, m, st),
        );
        timings.sweep = t.elapsed().as_secs_f64();
        Swept {
            parts,
            minima,
            state_bytes: sw.state_bytes(),
        }
    }
}

/// CIEL: the edge-based sweep or the CIEL brute force. With `threads > 1`
/// the levels are split into contiguous ranges swept in parallel, each
/// from the state the whole sweep has before its first level
/// ([`CielSweeper::sweep_after`]): the same cells and polygons.
impl Runner for Split<Ciel> {
    fn live_range(&self, f: &VertexField) -> Option<(f32, f32)> {
        self.inner.live_range(f)
    }
    fn positions(&self) -> &[[f32; 3]] {
        &self.positions
    }
    fn source(&self, slot: u32) -> u32 {
        self.map.as_ref().map_or(slot, |m| m.source[slot as usize])
    }
    fn brute_force(&self, job: &Job, mesh: &mut LevelMesh, on_level: &mut OnLevel) {
        crate::structures::ciel::brute_force(
            &self.inner,
            job.f,
            job.levels,
            job.ctx,
            mesh,
            on_level,
        )
    }
    fn sweep(&self, job: &Job, gather: &Gather, timings: &mut Timings) -> Swept {
        use rayon::prelude::*;
        let (levels, k) = (job.levels, job.levels.len());
        let t = Instant::now();
        let minima = crate::structures::ciel::minima(&self.inner, job.f);
        timings.minima = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let n = job.req.threads.clamp(1, k.max(1));
        let runs: Vec<(Part, usize)> = (0..n)
            .into_par_iter()
            .map(|b| {
                let (lo, hi) = (k * b / n, k * (b + 1) / n);
                let mut sw = CielSweeper::new(&self.inner);
                sw.set_minima(minima.clone());
                sw.set_planar(job.req.field.normal().is_some());
                let prev = (lo > 0).then(|| levels[lo - 1]);
                let mut part = (gather.new_part)(lo..hi);
                let mut mesh = LevelMesh::default();
                sw.sweep_after(
                    job.f,
                    prev,
                    &levels[lo..hi],
                    job.ctx,
                    &mut mesh,
                    |lv, m, st| (gather.on_level)(&mut part, lo + lv, m, st),
                );
                let bytes = mesh.capacity_bytes() + sw.state_bytes();
                (part, bytes)
            })
            .collect();
        timings.sweep = t.elapsed().as_secs_f64();
        Swept {
            state_bytes: runs.iter().map(|r| r.1).sum(),
            parts: runs.into_iter().map(|r| r.0).collect(),
            minima: minima.len(),
        }
    }
}

/// Runs `f`, returning the [`crate::mem::AllocError`] a level's output
/// unwound with when it did not fit in memory; any other panic goes on
/// unwinding.
fn catch_out_of_memory<T>(f: impl FnOnce() -> T) -> Result<T, crate::mem::AllocError> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(v) => Ok(v),
        Err(p) => match p.downcast::<crate::mem::AllocError>() {
            Ok(e) => Err(*e),
            Err(p) => std::panic::resume_unwind(p),
        },
    }
}

/// Runs `req` on the structure `r` with the binding `bound`: the levels
/// placed, the sweep (or the brute force), then its parts' statistics and
/// pieces merged (`split`: the convex split's map, whose pieces count once
/// per input cell).
fn run(
    r: &dyn Runner,
    bound: &Binding,
    req: &SliceRequest,
    split: Option<&SplitMap>,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<SliceResult, PipelineError> {
    let f = &bound.field();
    let range = r.live_range(f);
    let (world, levels) = place_levels(range, bound.world_offset, &req.levels)?;
    let warnings = level_warnings(&req.field, range, bound.world_offset, &world, &levels)
        .into_iter()
        .collect();
    let ctx = EmitContext {
        positions: r.positions(),
        attribute: bound.attribute.as_deref(),
        cells_only: false,
    };
    let k = levels.len();
    let mut timings = Timings::default();
    let collect = req.collect_mesh;
    let new_part = |range: std::ops::Range<usize>| Part {
        first: range.start,
        stats: vec![LevelStats::default(); range.len()],
        pieces: vec![LevelCopy::default(); range.len()],
        cut: vec![Vec::new(); range.len()],
    };
    let on_level = |p: &mut Part, lv: usize, mesh: &LevelMesh, st: &LevelStats| {
        let i = lv - p.first;
        p.stats[i] = *st;
        if collect && let Err(e) = p.pieces[i].append(mesh, |s| r.source(s)) {
            // Out of the sweep as an interruption is (the run's state is
            // dropped on the way), then an error below.
            std::panic::resume_unwind(Box::new(e));
        }
        if let Some(m) = split {
            cut_pieces(mesh, m, |s| r.source(s), &mut p.cut[i]);
        }
        progress(1);
        // Every sweep and the brute force come here after each level.
        stop_if_cancelled(&req.sweep.cancel);
    };
    let job = Job {
        f,
        levels: &levels,
        ctx: &ctx,
        req,
        axis_slot: bound.axis_slot,
    };
    req.sweep.cancel.check()?;
    let swept = catch_out_of_memory(|| {
        catch_interrupt(|| {
            if req.brute_force {
                let t = Instant::now();
                let mut part = new_part(0..k);
                let mut mesh = LevelMesh::default();
                r.brute_force(&job, &mut mesh, &mut |lv, m, st| {
                    on_level(&mut part, lv, m, st)
                });
                timings.sweep = t.elapsed().as_secs_f64();
                Swept {
                    parts: vec![part],
                    minima: 0,
                    state_bytes: mesh.capacity_bytes(),
                }
            } else {
                let gather = Gather {
                    new_part: &new_part,
                    on_level: &on_level,
                };
                r.sweep(&job, &gather, &mut timings)
            }
        })
    })??;
    let mut stats = vec![LevelStats::default(); k];
    let mut cut: Vec<Vec<(u32, u32)>> = vec![Vec::new(); k];
    for p in &swept.parts {
        for (i, st) in p.stats.iter().enumerate() {
            stats[p.first + i].add(st);
            cut[p.first + i].extend_from_slice(&p.cut[i]);
        }
    }
    if split.is_some() {
        count_input_cells(&mut stats, cut);
    }
    let mesh = collect
        .then(|| {
            let parts = &swept.parts;
            canonical_mesh(
                parts.len(),
                |p, lv| parts[p].pieces.get(lv.checked_sub(parts[p].first)?),
                &world,
            )
        })
        .transpose()?;
    Ok(SliceResult {
        level_values: world,
        stats,
        mesh,
        minima: swept.minima,
        sweep_state_bytes: swept.state_bytes,
        timings,
        attribute_name: String::new(),
        warnings,
    })
}
