//! Slices of grids the GPU tables cannot express (CIEL: polyhedra with
//! more than 12 vertices, e.g. Voronoi/PEBI cells): the CPU pipeline
//! sweeps and emits the polygons, which are fan-triangulated per level
//! into the same [`FrameOutput`] layout the compute passes write (draw
//! arguments in both orders, counters), uploaded once and drawn by the
//! same render pass as every other slice set. Iso slices carry normals
//! averaged over the welded mesh (the CPU mesh has no field gradient).

use crate::grid::Grid;
use crate::mesh::PolyMesh;
use crate::pipeline::slice;
use crate::structures::Structure;

use crate::gpu::compute::emit::GpuEmitter;
use crate::gpu::compute::frame::FrameOutput;
use crate::gpu::compute::tables::GridBuffers;
use crate::gpu::context::GpuContext;
use crate::gpu::shared::{ControlLayout, DrawArgs, OutVertex};

use super::emit_slices::{emit_slices, shown_range, slice_request};
use super::error::RenderError;
use super::slice_cache::{SliceKey, SliceSet};

/// Per mesh vertex: the area-weighted mean of its polygons' normals (the
/// mesh is welded by grid edge), each polygon's normal flipped to agree
/// with the sum so far (the render shades both sides alike), so a smooth
/// isosurface gets smooth normals without the field's gradient.
pub fn vertex_normals(mesh: &PolyMesh) -> Vec<[f32; 4]> {
    let mut acc = vec![[0f64; 3]; mesh.positions.len()];
    for p in 0..mesh.polygon_count() {
        let ids = mesh.polygon(p);
        let pos = |i: u32| mesh.positions[i as usize].map(f64::from);
        let o = pos(ids[0]);
        let mut n = [0f64; 3];
        for j in 1..ids.len().saturating_sub(1) {
            let (a, b) = (pos(ids[j]), pos(ids[j + 1]));
            let u = [a[0] - o[0], a[1] - o[1], a[2] - o[2]];
            let v = [b[0] - o[0], b[1] - o[1], b[2] - o[2]];
            n[0] += u[1] * v[2] - u[2] * v[1];
            n[1] += u[2] * v[0] - u[0] * v[2];
            n[2] += u[0] * v[1] - u[1] * v[0];
        }
        for &i in ids {
            let a = &mut acc[i as usize];
            let sign = if a[0] * n[0] + a[1] * n[1] + a[2] * n[2] < 0.0 {
                -1.0
            } else {
                1.0
            };
            for c in 0..3 {
                a[c] += sign * n[c];
            }
        }
    }
    acc.iter()
        .map(|a| [a[0] as f32, a[1] as f32, a[2] as f32, 0.0])
        .collect()
}

/// One level's fan triangles (3 corners each), their normals (empty
/// unless asked for) and its polygon count.
#[derive(Clone, Debug, Default)]
pub struct LevelTriangles {
    /// Triangle corners.
    pub vertices: Vec<OutVertex>,
    /// Per corner normal (xyz, w = 0), parallel to `vertices`, or empty.
    pub normals: Vec<[f32; 4]>,
    /// Polygons.
    pub polygons: u32,
}

/// The polygons of `mesh` fan-triangulated per level (`k` levels), each
/// corner carrying its value, or `flat[cell]` of the polygon's source cell
/// when given, and its vertex normal ([`vertex_normals`]) when `normals`.
pub fn mesh_levels(
    mesh: &PolyMesh,
    k: usize,
    flat: Option<&[f64]>,
    normals: bool,
) -> Vec<LevelTriangles> {
    let vn = if normals {
        vertex_normals(mesh)
    } else {
        Vec::new()
    };
    let mut levels = vec![LevelTriangles::default(); k];
    for p in 0..mesh.polygon_count() {
        let ids = mesh.polygon(p);
        let l = &mut levels[mesh.poly_level[p] as usize];
        let cell_value = flat.map(|v| v.get(mesh.poly_cell[p] as usize).map_or(0.0, |&x| x as f32));
        let corner = |i: u32| OutVertex {
            pos: mesh.positions[i as usize],
            value: cell_value.unwrap_or(mesh.values[i as usize]),
        };
        l.polygons += 1;
        for j in 1..ids.len().saturating_sub(1) {
            let tri = [ids[0], ids[j], ids[j + 1]];
            l.vertices.extend(tri.map(corner));
            if normals {
                l.normals.extend(tri.map(|i| vn[i as usize]));
            }
        }
    }
    levels
}

/// The levels back to back in the control layout of the compute passes
/// (draw arguments in both orders, counts, bases, total).
pub fn assemble(levels: &[LevelTriangles]) -> FrameOutput {
    let k = levels.len();
    let lay = ControlLayout { k: k as u32 };
    let mut control = vec![0u32; lay.words() as usize];
    let mut vertices = Vec::new();
    let mut normals = Vec::new();
    for (j, l) in levels.iter().enumerate() {
        let n = (l.vertices.len() / 3) as u32;
        let base = (vertices.len() / 3) as u32;
        let args = DrawArgs {
            vertex_count: 3 * n,
            instance_count: 1,
            first_vertex: 3 * base,
            first_instance: 0,
        };
        let fwd = (lay.args_fwd() + 4 * j as u32) as usize;
        let rev = (lay.args_rev() + 4 * (k - 1 - j) as u32) as usize;
        control[fwd..fwd + 4].copy_from_slice(bytemuck::cast_slice(&[args]));
        control[rev..rev + 4].copy_from_slice(bytemuck::cast_slice(&[args]));
        control[(lay.tri_count() + j as u32) as usize] = n;
        control[(lay.poly_count() + j as u32) as usize] = l.polygons;
        control[(lay.cursor() + j as u32) as usize] = n;
        control[(lay.base() + j as u32) as usize] = base;
        vertices.extend_from_slice(&l.vertices);
        normals.extend_from_slice(&l.normals);
    }
    control[lay.total() as usize] = (vertices.len() / 3) as u32;
    FrameOutput {
        k: k as u32,
        control,
        vertices,
        areas: Vec::new(),
        normals,
    }
}

/// [`mesh_levels`] assembled into one output.
pub fn mesh_output(mesh: &PolyMesh, k: usize, flat: Option<&[f64]>, normals: bool) -> FrameOutput {
    assemble(&mesh_levels(mesh, k, flat, normals))
}

/// Consecutive level ranges whose triangles (48 bytes each, and as many
/// again for normals) fit `budget` bytes per buffer; a single level over
/// it still gets its own range (its upload then reports the limit).
pub fn level_chunks(levels: &[LevelTriangles], budget: u64) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let (mut a, mut bytes) = (0, 0u64);
    for (i, l) in levels.iter().enumerate() {
        let b = l.vertices.len() as u64 * 16;
        if i > a && bytes + b > budget {
            out.push(a..i);
            (a, bytes) = (i, 0);
        }
        bytes += b;
    }
    if a < levels.len() || out.is_empty() {
        out.push(a..levels.len());
    }
    out
}

/// The slices of `k` (or its isosurfaces) for any structure: emitted on the
/// GPU ([`emit_slices`]), or, for CIEL grids (polyhedra the GPU tables
/// cannot express), the CPU's polygons uploaded ([`build_host_slices`]).
/// Runs on any thread (the viewer builds a new axis's slices on a worker).
pub fn build_slices<'c>(
    ctx: &'c GpuContext,
    grid: &Grid,
    s: &Structure,
    k: &SliceKey,
) -> Result<SliceSet<'c>, RenderError> {
    match s {
        Structure::Ciel(_) => build_host_slices(ctx, grid, s, k),
        _ => emit_slices(ctx, grid, s, k),
    }
}

/// Builds the slices of `k` on a CIEL grid: the CPU sweep's polygons
/// uploaded for drawing (no compute dispatch). Iso slices carry vertex
/// normals averaged over the welded mesh ([`vertex_normals`]).
pub fn build_host_slices<'c>(
    ctx: &'c GpuContext,
    grid: &Grid,
    s: &Structure,
    k: &SliceKey,
) -> Result<SliceSet<'c>, RenderError> {
    if k.clip.is_some() {
        return Err(RenderError::Options(
            "IJK clipping needs an IJK (structured) grid".into(),
        ));
    }
    // A cell property colours each polygon flat, as on the GPU path.
    let (mut req, cell_values) = slice_request(grid, k);
    req.collect_mesh = true;
    let r = slice(grid, s, &req, &|_| {})?;
    let levels = r.level_values.len();
    let mesh = r.mesh.unwrap_or_default();
    let per_level = mesh_levels(&mesh, levels, cell_values.as_deref(), k.iso);
    drop(mesh);
    let spacing = match r.level_values.as_slice() {
        [a, b, ..] => b - a,
        _ => {
            let (lo, hi) = grid.bounds();
            hi[k.axis] - lo[k.axis]
        }
    };
    let range = shown_range(
        grid,
        s,
        &k.property,
        cell_values.as_deref(),
        &r.level_values,
    )?;
    let cut_cells = r.stats.iter().map(|x| x.cells).sum();
    // Level chunks within one storage binding, as the GPU emission's.
    let budget = ctx
        .limits
        .max_storage_buffer_binding_size
        .min(ctx.limits.max_buffer_size);
    let base = GpuEmitter::new(ctx, GridBuffers::default())?;
    let mut chunks = Vec::new();
    for r in level_chunks(&per_level, budget) {
        let mut e = base.fork();
        e.upload_output(&assemble(&per_level[r]), k.iso)?;
        chunks.push(e);
    }
    Ok(SliceSet {
        chunks,
        spacing,
        range,
        cut_cells,
        levels: levels as u32,
        // Host slices carry no gradient: their frames are drawn plain,
        // so no outer surface.
        boundary: None,
        field: None,
        field_fallback: k
            .attr_gradient
            .then(|| "the slices are cut on the host (CIEL), which carries no gradient: drawn as plain slices".into()),
    })
}
