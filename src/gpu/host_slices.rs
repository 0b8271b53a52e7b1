//! Slices of grids the GPU tables cannot express (CIEL: polyhedra with
//! more than 12 vertices, e.g. Voronoi/PEBI cells): the CPU pipeline
//! sweeps and emits the polygons, which are fan-triangulated per level
//! into the same [`FrameOutput`] layout the compute passes write (draw
//! arguments in both orders, counters), uploaded once and drawn by the
//! same render pass as every other slice set.

use crate::grid::Grid;
use crate::mesh::PolyMesh;
use crate::pipeline::{SliceRequest, slice, vertex_property};
use crate::structures::Structure;

use super::context::GpuContext;
use super::emit::GpuEmitter;
use super::frame::FrameOutput;
use super::render::{RenderError, SliceKey, SliceSet};
use super::shared::{ControlLayout, DrawArgs, OutVertex};

/// The polygons of `mesh` fan-triangulated per level (`k` levels), each
/// corner carrying its value, or `flat[cell]` of the polygon's source cell
/// when given, in the control layout of the compute passes.
pub fn mesh_output(mesh: &PolyMesh, k: usize, flat: Option<&[f64]>) -> FrameOutput {
    let mut per_level: Vec<Vec<OutVertex>> = vec![Vec::new(); k];
    let mut polys = vec![0u32; k];
    for p in 0..mesh.polygon_count() {
        let ids = mesh.polygon(p);
        let lv = mesh.poly_level[p] as usize;
        let cell_value = flat.map(|v| v.get(mesh.poly_cell[p] as usize).map_or(0.0, |&x| x as f32));
        let corner = |i: u32| OutVertex {
            pos: mesh.positions[i as usize],
            value: cell_value.unwrap_or(mesh.values[i as usize]),
        };
        polys[lv] += 1;
        for j in 1..ids.len().saturating_sub(1) {
            per_level[lv].extend([corner(ids[0]), corner(ids[j]), corner(ids[j + 1])]);
        }
    }
    let lay = ControlLayout { k: k as u32 };
    let mut control = vec![0u32; lay.words() as usize];
    let mut vertices = Vec::new();
    for (j, tris) in per_level.iter().enumerate() {
        let n = (tris.len() / 3) as u32;
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
        control[(lay.poly_count() + j as u32) as usize] = polys[j];
        control[(lay.cursor() + j as u32) as usize] = n;
        control[(lay.base() + j as u32) as usize] = base;
        vertices.extend_from_slice(tris);
    }
    control[lay.total() as usize] = (vertices.len() / 3) as u32;
    FrameOutput {
        k: k as u32,
        control,
        vertices,
        areas: Vec::new(),
        normals: Vec::new(),
    }
}

/// Builds the slices of `k` on a CIEL grid: the CPU sweep's polygons
/// uploaded for drawing (no compute dispatch). Iso slices get zero
/// normals, so the render pass shades them with the facet normal.
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
    // A cell property (no point property of that name) colours each
    // polygon flat with its own cell's value, as on the GPU path.
    let cell_values: Option<Vec<f64>> = match &k.property {
        Some(n) if !k.iso && grid.point_property(n).is_none() => grid
            .cell_property(n)
            .map(|c| (0..c.len()).map(|i| c.scalar_at(i)).collect()),
        _ => None,
    };
    let req = SliceRequest {
        field: k.field.clone(),
        levels: k.levels.clone(),
        attribute: if cell_values.is_some() {
            None
        } else {
            k.property.clone()
        },
        threads: rayon::current_num_threads(),
        brute_force: false,
        collect_mesh: true,
        sweep: Default::default(),
    };
    let r = slice(grid, s, &req, &|_| {})?;
    let levels = r.level_values.len();
    let mesh = r.mesh.unwrap_or_default();
    let out = mesh_output(&mesh, levels, cell_values.as_deref());
    let spacing = match r.level_values.as_slice() {
        [a, b, ..] => b - a,
        _ => {
            let (lo, hi) = grid.bounds();
            hi[k.axis] - lo[k.axis]
        }
    };
    let range = match (&k.property, &cell_values) {
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
        (None, None) => {
            let l = &r.level_values;
            (l[0], l[l.len() - 1])
        }
    };
    let cut_cells = r.stats.iter().map(|x| x.cells).sum();
    let e = GpuEmitter::from_output(ctx, &out, k.iso)?;
    Ok(SliceSet {
        chunks: vec![e],
        spacing,
        range,
        cut_cells,
        levels: levels as u32,
    })
}
