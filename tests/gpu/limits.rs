//! Large frames under artificially lowered limits: a frame whose output
//! exceeds one storage binding is split into level chunks and gives the
//! same statistics and the same image; a binding too small for the
//! meta-cell tables (which every grid part carries whole) is a clear
//! error, not a panic. Grids over the limit are split into parts:
//! `tests/gpu_grid_parts.rs`.

use crate::support;

use stratasweep::field::FieldSpec;
use stratasweep::generate::warped;
use stratasweep::gpu::compute::slice::{Emitter, GpuSliceError, slice_on};
use stratasweep::gpu::context::{ContextOptions, GpuContext, GpuError};
use stratasweep::gpu::render::{RenderOptions, Renderer};
use stratasweep::pipeline::{LevelSpec, SliceRequest, slice};
use stratasweep::structures::{Structure, StructureChoice};

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

fn req(k: usize) -> SliceRequest {
    SliceRequest {
        field: FieldSpec::Axis {
            axis: 2,
            negative: false,
        },
        levels: LevelSpec::Count(k),
        attribute: None,
        threads: 1,
        brute_force: false,
        collect_mesh: false,
        sweep: Default::default(),
    }
}

#[test]
fn frames_over_the_binding_limit_are_chunked_by_levels() {
    let Some(small) = lowered(256 * 1024) else {
        return;
    };
    let grid = warped([20, 18, 16], 2);
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let cpu = slice(&grid, &s, &req(30), &|_| {}).unwrap();
    let (r, t) = slice_on(Emitter::Gpu(&small), &grid, &s, &req(30)).unwrap();
    let tris: u64 = cpu.stats.iter().map(|x| x.triangles).sum();
    assert!(tris * 48 > 256 * 1024, "the test must overflow one binding");
    assert!(t.chunks > 1, "not chunked");
    eprintln!("{tris} triangles in {} chunks", t.chunks);
    for (a, b) in cpu.stats.iter().zip(&r.stats) {
        assert_eq!(
            (a.cells, a.polygons, a.triangles),
            (b.cells, b.polygons, b.triangles)
        );
        assert!((a.area - b.area).abs() <= 1e-5 * a.area);
    }
    // The same image from chunked and unchunked slices.
    let full = support::gpu("chunked render").unwrap();
    let o = RenderOptions {
        size: (64, 48),
        slices: 30,
        view_dir: [0.2, 0.3, -1.0],
        ..Default::default()
    };
    let a = Renderer::new(full).unwrap().render(&grid, &s, &o).unwrap();
    let b = Renderer::new(&small)
        .unwrap()
        .render(&grid, &s, &o)
        .unwrap();
    for (p, q) in a.rgba8().iter().zip(b.rgba8()) {
        assert!((*p as i32 - q as i32).abs() <= 1, "chunked image differs");
    }
}

#[test]
fn a_binding_too_small_for_the_tables_is_a_clear_error() {
    let Some(small) = lowered(8 * 1024) else {
        return;
    };
    let grid = warped([20, 18, 16], 2);
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let e = match slice_on(Emitter::Gpu(&small), &grid, &s, &req(5)) {
        Err(GpuSliceError::Gpu(e @ GpuError::TooLarge { .. })) => e,
        other => panic!("expected TooLarge, got {:?}", other.map(|_| ())),
    };
    let msg = e.to_string();
    assert!(
        msg.contains("meta-cell tables") && msg.contains("the CPU path"),
        "{msg}"
    );
}

#[test]
fn an_allocation_the_device_cannot_satisfy_is_an_error_not_a_panic() {
    let Some(full) = support::gpu("allocation failure") else {
        return;
    };
    // A device of its own: the errors below must not leak into other tests.
    let ctx = GpuContext::new(&ContextOptions {
        adapter: Some(full.adapter.get_info().name),
        limits: None,
        ..Default::default()
    })
    .unwrap();
    let buffer = |size: u64| {
        ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("probe"),
            size,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        })
    };
    // Past the buffer limit: wgpu's validation error, reported as an error.
    let over = ctx.limits.max_buffer_size.saturating_add(4) / 4 * 4;
    let e = ctx
        .allocate("a buffer over the limit", || buffer(over))
        .expect_err("a buffer over max_buffer_size must fail");
    assert!(e.to_string().contains("a buffer over the limit"), "{e}");
    eprintln!("over the limit ({over} bytes): {e}");
    // Within the limit but more than the device has: out of memory.
    let huge = ctx.limits.max_buffer_size / 4 * 4;
    match ctx.allocate("the largest buffer the limit allows", || buffer(huge)) {
        Err(e @ GpuError::OutOfMemory { .. }) => {
            let msg = e.to_string();
            assert!(
                msg.contains("ran out of memory") && msg.contains("the CPU path"),
                "{msg}"
            );
            eprintln!("{huge} bytes: {msg}");
        }
        Err(e) => eprintln!("{huge} bytes: refused as {e}"),
        Ok(_) => eprintln!("{huge} bytes: the device allocated it (no out-of-memory to test)"),
    }
    // The device still works afterwards.
    assert!(ctx.allocate("a small buffer", || buffer(256)).is_ok());
    ctx.wait().unwrap();
}

/// GL is only a fallback: with a primary adapter (Vulkan here), the default
/// options neither list nor open GL, whose never-closed EGL display let
/// Mesa's threads race the process exit (heap corruption at exit in about
/// 1.5 % of `slice --device auto` runs on llvmpipe).
#[test]
fn default_options_keep_gl_closed_when_a_primary_backend_exists() {
    let Some(ctx) = support::gpu("GL fallback") else {
        return;
    };
    let primary = stratasweep::gpu::context::list_adapters(Some(wgpu::Backends::PRIMARY));
    let default = stratasweep::gpu::context::list_adapters(None);
    if primary.is_empty() {
        assert!(default.iter().all(|a| a.backend == wgpu::Backend::Gl));
        return;
    }
    assert_eq!(default.len(), primary.len(), "{default:?}");
    assert!(
        default.iter().all(|a| a.backend != wgpu::Backend::Gl),
        "{default:?}"
    );
    assert!(!ctx.name.ends_with("(Gl)"), "{}", ctx.name);
}
