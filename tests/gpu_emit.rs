//! GPU emission against its CPU twin, and the twin against the CPU sweep:
//! equal triangles per level; the twin exactly, the GPU within 1e-5
//! relative after canonical sorting. Grids: warped curvilinear (S-CGraph)
//! and zoo (CGraph); planes along an axis, oblique planes and isosurfaces
//! (ambiguous faces).

mod gpu_common;

use stratasweep::field::FieldSpec;
use stratasweep::generate::{warped, zoo};
use stratasweep::gpu::frame::{FrameOutput, canonical};
use stratasweep::gpu::shared::OutVertex;
use stratasweep::gpu::slice::{Emitter, prepare, slice_on};
use stratasweep::gpu::{emit::GpuEmitter, twin};
use stratasweep::grid::Grid;
use stratasweep::pipeline::{LevelSpec, SliceRequest, Structure, StructureChoice, slice};

fn req(field: FieldSpec, k: usize, threads: usize, mesh: bool) -> SliceRequest {
    SliceRequest {
        field,
        levels: LevelSpec::Count(k),
        attribute: None,
        threads,
        brute_force: false,
        collect_mesh: mesh,
    }
}

fn cases() -> Vec<(String, Grid, FieldSpec, usize)> {
    let w = warped([11, 9, 8], 7);
    let z = zoo(400, 3);
    let prop = FieldSpec::Property("f".into());
    let axis = |a| FieldSpec::Axis {
        axis: a,
        negative: false,
    };
    vec![
        ("warped z".into(), w.clone(), axis(2), 9),
        (
            "warped -y".into(),
            w.clone(),
            FieldSpec::Axis {
                axis: 1,
                negative: true,
            },
            5,
        ),
        (
            "warped oblique".into(),
            w.clone(),
            FieldSpec::Normal([1.0, 2.0, 3.0]),
            13,
        ),
        ("warped iso".into(), w, prop.clone(), 17),
        ("zoo x".into(), z.clone(), axis(0), 8),
        ("zoo iso".into(), z, prop, 15),
    ]
}

/// The CPU sweep's polygons, fan-triangulated, per level, and its stats.
fn cpu_triangles(
    grid: &Grid,
    s: &Structure,
    field: &FieldSpec,
    k: usize,
) -> (Vec<Vec<OutVertex>>, Vec<stratasweep::sweep::LevelStats>) {
    let r = slice(grid, s, &req(field.clone(), k, 1, true), &|_| {}).unwrap();
    let m = r.mesh.unwrap();
    let mut out = vec![Vec::new(); k];
    for p in 0..m.polygon_count() {
        let ids = &m.poly_indices[m.poly_offsets[p] as usize..m.poly_offsets[p + 1] as usize];
        let v = |i: u32| OutVertex {
            pos: m.positions[i as usize],
            value: m.values[i as usize],
        };
        for j in 1..ids.len() - 1 {
            out[m.poly_level[p] as usize].extend([v(ids[0]), v(ids[j]), v(ids[j + 1])]);
        }
    }
    (out, r.stats)
}

#[test]
fn twin_equals_cpu_sweep_exactly() {
    for (name, grid, field, k) in cases() {
        let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
        let (cpu, cpu_stats) = cpu_triangles(&grid, &s, &field, k);
        for threads in [1, 3] {
            let p = prepare(&grid, &s, &req(field.clone(), k, threads, false)).unwrap();
            let out = twin::run(&p.grid, &p.frame, true);
            let mut total = 0;
            for lv in 0..k as u32 {
                let a = canonical(&cpu[lv as usize]);
                let b = out.canonical_level(lv);
                assert_eq!(a.len(), b.len(), "{name}: level {lv} triangle count");
                assert!(
                    a == b,
                    "{name}: level {lv} triangles differ (threads {threads})"
                );
                assert_eq!(
                    out.polygons(lv) as u64,
                    cpu_stats[lv as usize].polygons,
                    "{name}"
                );
                // The cells-only sweep found the same cut cells.
                assert_eq!(
                    p.cpu_stats[lv as usize].cells, cpu_stats[lv as usize].cells,
                    "{name}"
                );
                total += a.len();
            }
            assert!(total > 0, "{name}: nothing cut");
        }
    }
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-5 * a.abs().max(b.abs()).max(1.0)
}

/// Same triangles up to 1e-5 relative: both sorted by centroid, each GPU
/// triangle matched to a twin triangle within a small window.
fn assert_same(name: &str, lv: u32, twin: &[[[f32; 4]; 3]], gpu: &[[[f32; 4]; 3]]) {
    assert_eq!(twin.len(), gpu.len(), "{name}: level {lv} triangle count");
    let key = |t: &[[f32; 4]; 3]| {
        let c = |i: usize| t.iter().map(|v| v[i] as f64).sum::<f64>();
        (c(0), c(1), c(2))
    };
    let mut a: Vec<_> = twin.to_vec();
    let mut b: Vec<_> = gpu.to_vec();
    a.sort_by(|x, y| key(x).partial_cmp(&key(y)).unwrap());
    b.sort_by(|x, y| key(x).partial_cmp(&key(y)).unwrap());
    let same = |x: &[[f32; 4]; 3], y: &[[f32; 4]; 3]| {
        (0..3).all(|c| (0..4).all(|i| close(x[c][i], y[c][i])))
    };
    let mut used = vec![false; a.len()];
    for (i, t) in b.iter().enumerate() {
        let lo = i.saturating_sub(16);
        let hi = (i + 17).min(a.len());
        let j = (lo..hi)
            .find(|&j| !used[j] && same(&a[j], t))
            .unwrap_or_else(|| panic!("{name}: level {lv}: GPU triangle {t:?} has no twin"));
        used[j] = true;
    }
}

#[test]
fn gpu_equals_twin() {
    let Some(ctx) = gpu_common::gpu("gpu_equals_twin") else {
        return;
    };
    for (name, grid, field, k) in cases() {
        let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
        let p = prepare(&grid, &s, &req(field.clone(), k, 2, false)).unwrap();
        let tw: FrameOutput = twin::run(&p.grid, &p.frame, true);
        let mut e = GpuEmitter::new(ctx, p.grid.clone()).unwrap();
        e.run(&p.frame, true).unwrap();
        let g = e.read_output(true).unwrap();
        assert_eq!(g.total_triangles(), tw.total_triangles(), "{name}");
        for lv in 0..k as u32 {
            assert_eq!(g.args(lv), tw.args(lv), "{name}: level {lv} draw args");
            assert_eq!(
                g.args_rev(lv),
                tw.args_rev(lv),
                "{name}: reversed draw args"
            );
            assert_eq!(
                g.polygons(lv),
                tw.polygons(lv),
                "{name}: level {lv} polygons"
            );
            assert_same(&name, lv, &tw.canonical_level(lv), &g.canonical_level(lv));
        }
        // A second frame on the same emitter reuses the buffers.
        e.run(&p.frame, false).unwrap();
        assert_eq!(e.triangles, tw.total_triangles());
    }
}

#[test]
fn gpu_stats_equal_cpu_stats() {
    let Some(ctx) = gpu_common::gpu("gpu_stats_equal_cpu_stats") else {
        return;
    };
    for (name, grid, field, k) in cases() {
        let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
        let cpu = slice(&grid, &s, &req(field.clone(), k, 1, false), &|_| {}).unwrap();
        for em in [Emitter::Twin, Emitter::Gpu(ctx)] {
            let (r, _) = slice_on(em, &grid, &s, &req(field.clone(), k, 1, false)).unwrap();
            assert_eq!(r.level_values, cpu.level_values, "{name}");
            for (a, b) in cpu.stats.iter().zip(&r.stats) {
                assert_eq!(
                    (a.cells, a.visited, a.polygons, a.triangles),
                    (b.cells, b.visited, b.polygons, b.triangles),
                    "{name}"
                );
                assert!(
                    (a.area - b.area).abs() <= 1e-5 * a.area.abs().max(1e-30),
                    "{name}: area {} vs {}",
                    a.area,
                    b.area
                );
            }
        }
    }
}

#[test]
fn empty_frame_is_fine() {
    let Some(ctx) = gpu_common::gpu("empty_frame_is_fine") else {
        return;
    };
    let grid = warped([4, 4, 4], 1);
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    // Levels outside the range cut nothing.
    let r = SliceRequest {
        levels: LevelSpec::Values(vec![-1e12, 1e12]),
        ..req(
            FieldSpec::Axis {
                axis: 2,
                negative: false,
            },
            1,
            1,
            false,
        )
    };
    let p = prepare(&grid, &s, &r).unwrap();
    assert!(p.frame.entries.is_empty());
    let mut e = GpuEmitter::new(ctx, p.grid).unwrap();
    e.run(&p.frame, true).unwrap();
    assert_eq!(e.triangles, 0);
    let out = e.read_output(true).unwrap();
    assert_eq!(out.args(1).vertex_count, 0);
}

#[test]
fn span_space_binning_finds_the_sweep_cells() {
    for (name, grid, field, k) in cases() {
        let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
        let p = prepare(&grid, &s, &req(field.clone(), k, 1, false)).unwrap();
        let mut binned = twin::bin(&p.grid, &p.frame.levels);
        let mut swept = p.frame.entries.clone();
        binned.sort_by_key(|e| (e.level, e.slot));
        swept.sort_by_key(|e| (e.level, e.slot));
        assert!(
            binned == swept,
            "{name}: span-space cells differ from the sweep's"
        );
    }
}

#[test]
fn gpu_span_space_equals_the_swept_frame() {
    let Some(ctx) = gpu_common::gpu("gpu_span_space_equals_the_swept_frame") else {
        return;
    };
    for (name, grid, field, k) in cases() {
        let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
        let p = prepare(&grid, &s, &req(field.clone(), k, 1, false)).unwrap();
        let tw = twin::run(&p.grid, &p.frame, false);
        let mut e = GpuEmitter::new(ctx, p.grid.clone()).unwrap();
        let n = e.run_span(&p.frame.levels, false).unwrap();
        assert_eq!(n as usize, p.frame.entries.len(), "{name}: entries");
        let g = e.read_output(false).unwrap();
        for lv in 0..k as u32 {
            assert_eq!(g.args(lv), tw.args(lv), "{name}: level {lv}");
            assert_eq!(g.polygons(lv), tw.polygons(lv), "{name}: level {lv}");
            assert_same(&name, lv, &tw.canonical_level(lv), &g.canonical_level(lv));
        }
    }
}
