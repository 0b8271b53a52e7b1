//! Grids over the storage-binding limit: the grid buffers split into parts
//! (`gpu::compute::grid_parts`) emit exactly the triangles of the whole grid.
//! Host side: the CPU twin run part by part equals the twin on the whole
//! grid bit for bit (S-CGraph windows and CGraph vertex subsets, vertex and
//! cell attributes, iso gradients). Device side: with a small part budget
//! (`GpuEmitter::with_part_budget`) the chunked GPU emission equals the
//! unchunked one bit for bit; under a lowered binding limit (a library
//! option: `ContextOptions::limits`) `slice_on`'s statistics equal the CPU
//! pipeline's and `render` gives the same image as on the full device.

use crate::support;

use stratasweep::field::FieldSpec;
use stratasweep::generate::{warped, zoo};
use stratasweep::gpu::compute::emit::{GpuEmitter, emit_chunked};
use stratasweep::gpu::compute::frame::canonical;
use stratasweep::gpu::compute::gradient::vertex_gradients;
use stratasweep::gpu::compute::grid_parts::{largest_buffer, split_frame, split_grid};
use stratasweep::gpu::compute::slice::{Emitter, prepare, slice_on};
use stratasweep::gpu::compute::tables::{Frame, GridBuffers, slot_values};
use stratasweep::gpu::compute::twin;
use stratasweep::gpu::context::{ContextOptions, GpuContext};
use stratasweep::gpu::render::{RenderOptions, Renderer};
use stratasweep::grid::Grid;
use stratasweep::pipeline::{LevelSpec, SliceRequest, slice};
use stratasweep::structures::{Structure, StructureChoice};

fn req(field: FieldSpec, k: usize, attribute: Option<&str>) -> SliceRequest {
    SliceRequest {
        field,
        levels: LevelSpec::Count(k),
        attribute: attribute.map(str::to_string),
        threads: 1,
        brute_force: false,
        collect_mesh: false,
        sweep: Default::default(),
    }
}

fn axis(a: usize) -> FieldSpec {
    FieldSpec::Axis {
        axis: a,
        negative: false,
    }
}

/// (name, grid, structure, field, levels, attribute, iso gradients, cell attribute)
type Case = (
    &'static str,
    Grid,
    StructureChoice,
    FieldSpec,
    usize,
    Option<&'static str>,
    bool,
    bool,
);

/// The cases on grids of about `n` cells per side (zoo: `n³ / 4` cells).
fn cases(n: usize) -> Vec<Case> {
    let w = warped([n + 2, n, n - 2], 3);
    let z = zoo(n * n * n / 4, 5);
    let prop = || FieldSpec::Property("f".into());
    vec![
        (
            "warped z, f",
            w.clone(),
            StructureChoice::Auto,
            axis(2),
            9,
            Some("f"),
            false,
            false,
        ),
        (
            "warped iso",
            w.clone(),
            StructureChoice::Auto,
            prop(),
            7,
            None,
            true,
            false,
        ),
        (
            "warped x, cell values",
            w.clone(),
            StructureChoice::Auto,
            axis(0),
            6,
            None,
            false,
            true,
        ),
        (
            "warped as CGraph, oblique",
            w,
            StructureChoice::CGraph,
            FieldSpec::Normal([1.0, 2.0, 3.0]),
            11,
            Some("f"),
            false,
            false,
        ),
        (
            "zoo iso",
            z.clone(),
            StructureChoice::Auto,
            prop(),
            9,
            None,
            true,
            false,
        ),
        (
            "zoo y, cell values",
            z,
            StructureChoice::Auto,
            axis(1),
            8,
            None,
            false,
            true,
        ),
    ]
}

/// The buffers of a case, with the gradient or per-slot values it asks for.
fn buffers(c: &Case) -> (GridBuffers, Frame) {
    let s = Structure::build(&c.1, c.2).unwrap();
    let mut p = prepare(&c.1, &s, &req(c.3.clone(), c.4, c.5)).unwrap();
    if c.6 {
        p.grid.grad = vertex_gradients(&p.grid);
    }
    if c.7 {
        let v: Vec<f64> = (0..c.1.cell_count())
            .map(|i| (i % 17) as f64 * 0.5)
            .collect();
        p.grid.attr = match &s {
            Structure::SCGraph(g) => slot_values(g, &v),
            Structure::CGraph(g) => slot_values(g, &v),
            Structure::CpGraph(g) => slot_values(g.as_ref(), &v),
            Structure::Ciel(_) => unreachable!("no CIEL case"),
        };
        p.grid.attr_per_cell = true;
    }
    (p.grid, p.frame)
}

#[test]
fn twin_over_parts_equals_twin_over_the_whole_grid() {
    for c in cases(12) {
        let (g, frame) = buffers(&c);
        let whole = twin::run(&g, &frame, true);
        let budget = (largest_buffer(&g) / 5).div_ceil(16) * 16;
        let parts = split_grid(g.clone(), budget).unwrap();
        assert!(parts.len() >= 5, "{}: {} parts", c.0, parts.len());
        for p in &parts {
            assert!(
                largest_buffer(&p.buffers) <= budget,
                "{}: part over budget",
                c.0
            );
        }
        let ranges: Vec<(u32, u32)> = parts.iter().map(|p| (p.slot_lo, p.slot_hi)).collect();
        let subs = split_frame(&ranges, &frame);
        assert_eq!(
            subs.iter().map(|f| f.entries.len()).sum::<usize>(),
            frame.entries.len(),
            "{}: entries lost",
            c.0
        );
        let outs: Vec<_> = parts
            .iter()
            .zip(&subs)
            .map(|(p, f)| twin::run(&p.buffers, f, true))
            .collect();
        let mut tris = 0;
        for lv in 0..frame.levels.len() as u32 {
            let mut merged = Vec::new();
            let mut merged_n = Vec::new();
            let mut polys = 0;
            for o in &outs {
                merged.extend_from_slice(o.level_vertices(lv));
                if c.6 {
                    let a = o.args(lv);
                    let r = a.first_vertex as usize..(a.first_vertex + a.vertex_count) as usize;
                    merged_n.extend_from_slice(&o.normals[r]);
                }
                polys += o.polygons(lv);
            }
            assert_eq!(polys, whole.polygons(lv), "{} level {lv}: polygons", c.0);
            if c.6 {
                let a = whole.canonical_level_with_normals(lv);
                let b =
                    stratasweep::gpu::compute::frame::canonical_with_normals(&merged, &merged_n);
                assert!(a == b, "{} level {lv}: triangles with normals differ", c.0);
            } else {
                assert!(
                    whole.canonical_level(lv) == canonical(&merged),
                    "{} level {lv}: triangles differ",
                    c.0
                );
            }
            tris += merged.len() / 3;
        }
        assert!(tris > 100, "{}: only {tris} triangles", c.0);
        eprintln!(
            "{}: {} parts, {tris} triangles, identical",
            c.0,
            parts.len()
        );
    }
}

#[test]
fn a_cell_over_the_budget_is_a_clear_error() {
    let c = &cases(12)[0];
    let (g, _) = buffers(c);
    let e = split_grid(g, 64).unwrap_err();
    assert!(e.bytes > e.budget, "{e:?}");
}

fn lowered(binding: u64) -> Option<GpuContext> {
    let full = support::gpu("lowered limits")?;
    let mut limits = full.limits.clone();
    limits.max_storage_buffer_binding_size = binding;
    Some(
        GpuContext::new(&ContextOptions {
            adapter: Some(full.adapter.get_info().name),
            limits: Some(limits),
            ..Default::default()
        })
        .unwrap(),
    )
}

/// Per level: polygons and canonical triangles (with normals when `normals`)
/// of `frame` emitted by `base` (level-chunked when the output is large).
fn levels(base: &GpuEmitter, frame: &Frame, normals: bool) -> Vec<(u32, Vec<Vec<f32>>)> {
    let chunks = emit_chunked(base, frame, true).unwrap();
    let mut out = Vec::new();
    for (e, _) in &chunks {
        let o = e.read_output(true).unwrap();
        for lv in 0..o.k {
            let tris: Vec<Vec<f32>> = if normals {
                o.canonical_level_with_normals(lv)
                    .iter()
                    .map(|t| t.iter().flatten().copied().collect())
                    .collect()
            } else {
                o.canonical_level(lv)
                    .iter()
                    .map(|t| t.iter().flatten().copied().collect())
                    .collect()
            };
            out.push((o.polygons(lv), tris));
        }
    }
    out
}

#[test]
fn chunked_gpu_emission_equals_the_unchunked_one() {
    let Some(full) = support::gpu("chunked grid") else {
        return;
    };
    for c in cases(24) {
        let (g, frame) = buffers(&c);
        let budget = largest_buffer(&g) / 4;
        let a = GpuEmitter::new(full, g.clone()).unwrap();
        let b = GpuEmitter::with_part_budget(full, g, Some(budget)).unwrap();
        assert_eq!(a.grid_parts(), 1);
        assert!(b.grid_parts() >= 4, "{}: {} parts", c.0, b.grid_parts());
        let (la, lb) = (levels(&a, &frame, c.6), levels(&b, &frame, c.6));
        assert_eq!(la.len(), frame.levels.len());
        let tris: usize = lb.iter().map(|l| l.1.len()).sum();
        assert!(tris > 1000, "{}: only {tris} triangles", c.0);
        for (lv, (x, y)) in la.iter().zip(&lb).enumerate() {
            assert!(x == y, "{} level {lv}: polygons or triangles differ", c.0);
        }
        eprintln!(
            "{}: {} grid parts, {tris} triangles, identical to one part",
            c.0,
            b.grid_parts(),
        );
    }
}

#[test]
fn chunked_grid_slices_and_renders_like_the_cpu_and_the_unchunked_gpu() {
    // The render pass binds a 256 KiB pre-integration table.
    let Some(small) = lowered(256 * 1024) else {
        return;
    };
    let full = support::gpu("chunked grid render").unwrap();
    let grid = warped([40, 36, 32], 2);
    for choice in [StructureChoice::Auto, StructureChoice::CGraph] {
        let s = Structure::build(&grid, choice).unwrap();
        let r = req(axis(2), 30, Some("f"));
        let cpu = slice(&grid, &s, &r, &|_| {}).unwrap();
        let (g, t) = slice_on(Emitter::Gpu(&small), &grid, &s, &r).unwrap();
        assert!(t.grid_parts >= 3, "{choice:?}: {} grid parts", t.grid_parts);
        for (lv, (a, b)) in cpu.stats.iter().zip(&g.stats).enumerate() {
            assert_eq!(
                (a.cells, a.polygons, a.triangles),
                (b.cells, b.polygons, b.triangles),
                "{choice:?} level {lv}"
            );
            assert!(
                (a.area - b.area).abs() <= 1e-5 * a.area,
                "{choice:?} level {lv}"
            );
        }
        let o = RenderOptions {
            size: (96, 72),
            slices: 40,
            view_dir: [0.3, 0.2, -1.0],
            ..Default::default()
        };
        let a = Renderer::new(full).unwrap().render(&grid, &s, &o).unwrap();
        let b = Renderer::new(&small)
            .unwrap()
            .render(&grid, &s, &o)
            .unwrap();
        let (pa, pb) = (a.rgba8(), b.rgba8());
        let distinct: std::collections::HashSet<&[u8]> = pa.chunks(4).collect();
        assert!(distinct.len() > 50, "{choice:?}: blank render");
        let worst = pa
            .iter()
            .zip(&pb)
            .map(|(p, q)| (*p as i32 - *q as i32).abs())
            .max()
            .unwrap();
        assert!(worst <= 1, "{choice:?}: chunked image differs by {worst}");
        eprintln!(
            "{choice:?}: {} grid parts, {} level chunks; image max diff {worst}",
            t.grid_parts, t.chunks
        );
    }
}
