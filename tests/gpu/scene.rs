//! The viewer's scene, headless (no window): a view change inside the axis
//! cone draws the cached slices with no sweep and no compute dispatch; an
//! axis change builds on the worker while the old slices keep being drawn;
//! the first image equals `render`'s (with a z-scale); the motion level of
//! detail and the vertical exaggeration keep the analytic alpha of a
//! uniform box, 1 − (1 − a)^(L/U) with L the displayed chord.

use crate::support;

use std::sync::Arc;

use stratasweep::generate::warped;
use stratasweep::gpu::render::{Mode, RenderOptions, Renderer, Transfer};
use stratasweep::gpu::view::scene::Scene;
use stratasweep::grid::Grid;
use stratasweep::structures::{Structure, StructureChoice};

/// Half thickness of the box along z.
const H: f64 = 0.5;

fn flat(a: f32) -> Transfer {
    Transfer::from_json(&format!(
        r#"{{"points":[{{"value":0,"color":[1,0.5,0.25],"opacity":{a}}},{{"value":2,"color":[1,0.5,0.25],"opacity":{a}}}]}}"#
    ))
    .unwrap()
}

fn scene(
    ctx: &'static stratasweep::gpu::context::GpuContext,
    g: Grid,
    o: RenderOptions,
    z: f64,
) -> Scene {
    let s = Structure::build(&g, StructureChoice::Auto).unwrap();
    Scene::new(ctx, Arc::new(g), Arc::new(s), o, z, false).unwrap()
}

fn warped_opts() -> RenderOptions {
    RenderOptions {
        slices: 24,
        size: (48, 36),
        ..Default::default()
    }
}

#[test]
fn view_change_in_cone_dispatches_nothing_and_axis_change_builds_on_the_worker() {
    let Some(ctx) = support::gpu("view_change_in_cone_dispatches_nothing") else {
        return;
    };
    let mut sc = scene(ctx, warped([12, 10, 8], 1), warped_opts(), 1.0);
    let d0 = sc.dispatches();
    assert!(d0 > 0);
    let first = sc.image(1).unwrap();
    // 10° about the up axis: still the x cone.
    sc.camera.orbit(10f32.to_radians(), 0.0);
    sc.request().unwrap();
    assert!(!sc.building(), "a view inside the cone started a build");
    let turned = sc.image(1).unwrap();
    assert_eq!(
        sc.dispatches(),
        d0,
        "a view inside the cone dispatched compute"
    );
    assert_eq!(sc.stats.resweeps, 0);
    assert_ne!(first.rgba8(), turned.rgba8(), "the camera did not move");
    // 80° more: the y cone. The build runs on the worker; the x slices are drawn meanwhile.
    sc.camera.orbit(80f32.to_radians(), 0.0);
    sc.request().unwrap();
    assert!(sc.building());
    let ctx2 = sc.ctx();
    let mut enc = ctx2.device.create_command_encoder(&Default::default());
    let info = sc.encode(&mut enc, 1).unwrap();
    ctx2.queue.submit([enc.finish()]);
    assert_eq!(
        info.axis, 0,
        "the old slices are drawn while the new ones build"
    );
    let old = sc.read_target().unwrap();
    assert!(
        old.premultiplied.iter().any(|p| p[3] > 0.05),
        "nothing drawn during the build"
    );
    assert!(sc.poll(true).unwrap(), "the worker's slices were not taken");
    let mut enc = ctx2.device.create_command_encoder(&Default::default());
    let info = sc.encode(&mut enc, 1).unwrap();
    ctx2.queue.submit([enc.finish()]);
    assert_eq!((info.axis, info.stale), (1, false));
    assert_eq!(sc.stats.resweeps, 1);
    assert!(sc.dispatches() > d0);
}

#[test]
fn dropping_a_scene_mid_build_waits_for_its_worker() {
    let Some(ctx) = support::gpu("dropping_a_scene_mid_build_waits_for_its_worker") else {
        return;
    };
    let g = Arc::new(warped([12, 10, 8], 1));
    let s = Arc::new(Structure::build(&g, StructureChoice::Auto).unwrap());
    let mut sc = Scene::new(ctx, g.clone(), s, warped_opts(), 1.0, false).unwrap();
    // The y cone: a build starts on the worker, which holds the grid.
    sc.camera.orbit(90f32.to_radians(), 0.0);
    sc.request().unwrap();
    assert!(sc.building());
    drop(sc);
    // A worker still running at process exit crashed NVIDIA's driver: once
    // the scene is gone, nothing may hold the grid any more.
    assert_eq!(Arc::strong_count(&g), 1, "the worker outlived its scene");
}

#[test]
fn first_image_equals_render_with_z_scale() {
    let Some(ctx) = support::gpu("first_image_equals_render_with_z_scale") else {
        return;
    };
    let g = warped([10, 9, 8], 2);
    let s = Structure::build(&g, StructureChoice::Auto).unwrap();
    let o = warped_opts();
    let mut r = Renderer::new(ctx).unwrap();
    let want = r.render_exaggerated(&g, &s, &o, 3.0).unwrap();
    let sc = scene(ctx, g, o, 3.0);
    let got = sc.image(1).unwrap();
    assert_eq!(got.premultiplied, want.premultiplied);
}

/// Centre alpha of the uniform box seen along −z (the z axis, 40 slices).
fn centre_alpha(ctx: &'static stratasweep::gpu::context::GpuContext, z: f64, lod: u32) -> f64 {
    let o = RenderOptions {
        property: Some("one".into()),
        slices: 40,
        view_dir: [0.0, 0.0, -1.0],
        up: Some([0.0, 1.0, 0.0]),
        transfer: Some(flat(0.3)),
        unit_distance: Some(1.0),
        background: None,
        size: (33, 33),
        mode: Mode::Volume,
        ..Default::default()
    };
    let sc = scene(ctx, support::box_grid([5, 5, 5], [2.0, 2.0, H]), o, z);
    sc.image(lod).unwrap().pixel(16, 16)[3] as f64
}

#[test]
fn motion_lod_and_z_scale_keep_the_analytic_alpha() {
    let Some(ctx) = support::gpu("motion_lod_and_z_scale_keep_the_analytic_alpha") else {
        return;
    };
    for z in [1.0, 2.5] {
        // The displayed chord is 2H·S, in display units (U = 1).
        let want = 1.0 - 0.7f64.powf(2.0 * H * z);
        for lod in [1, 2, 4] {
            let got = centre_alpha(ctx, z, lod);
            eprintln!("z-scale {z}, every {lod}. slice: alpha {got:.5}, analytic {want:.5}");
            assert!(
                (got - want).abs() <= 2.0 / 255.0,
                "z {z} lod {lod}: {got} vs {want}"
            );
        }
    }
}

#[test]
fn preintegrated_uniform_box_keeps_the_analytic_alpha() {
    let Some(ctx) = support::gpu("preintegrated_uniform_box_keeps_the_analytic_alpha") else {
        return;
    };
    let g = support::box_grid([5, 5, 5], [2.0, 2.0, H]);
    let s = Structure::build(&g, StructureChoice::Auto).unwrap();
    let mut r = Renderer::new(ctx).unwrap();
    r.set_preintegrated(true);
    for deg in [0.0f64, 40.0] {
        let t = deg.to_radians();
        let o = RenderOptions {
            property: Some("one".into()),
            slices: 40,
            view_dir: [t.sin(), 0.0, -t.cos()],
            up: Some([0.0, 1.0, 0.0]),
            transfer: Some(flat(0.3)),
            unit_distance: Some(1.0),
            background: None,
            size: (33, 33),
            mode: Mode::Volume,
            ..Default::default()
        };
        let img = r.render_exaggerated(&g, &s, &o, 1.0).unwrap();
        // A constant property: every slab's front and back values agree.
        let want = 1.0 - 0.7f64.powf(2.0 * H / t.cos());
        let got = img.pixel(16, 16)[3] as f64;
        assert!((got - want).abs() <= 2.0 / 255.0, "{deg}°: {got} vs {want}");
    }
}

#[test]
fn ijk_clip_draws_the_cut_cells_of_the_box_only() {
    let Some(ctx) = support::gpu("ijk_clip_draws_the_cut_cells_of_the_box_only") else {
        return;
    };
    use stratasweep::field::FieldSpec;
    use stratasweep::pipeline::{LevelSpec, SliceRequest, slice};
    let g = warped([12, 10, 8], 3);
    let s = Structure::build(&g, StructureChoice::Auto).unwrap();
    // Reference: the CPU pipeline's polygons, their source cells in the box.
    let r = slice(
        &g,
        &s,
        &SliceRequest {
            field: FieldSpec::Axis {
                axis: 0,
                negative: false,
            },
            levels: LevelSpec::Count(24),
            attribute: None,
            threads: 1,
            brute_force: false,
            collect_mesh: true,
            sweep: Default::default(),
        },
        &|_| {},
    )
    .unwrap();
    let m = r.mesh.unwrap();
    let clip = [[0usize, 6], [2, 10], [1, 5]];
    let mut cut: Vec<(u32, u32)> = m
        .poly_level
        .iter()
        .zip(&m.poly_cell)
        .filter(|(_, c)| {
            let c = **c as usize;
            let ijk = [c % 12, (c / 12) % 10, c / 120];
            (0..3).all(|a| clip[a][0] <= ijk[a] && ijk[a] < clip[a][1])
        })
        .map(|(l, c)| (*l, *c))
        .collect();
    cut.sort_unstable();
    cut.dedup();
    let mut sc = scene(ctx, g, warped_opts(), 1.0);
    let d0 = sc.dispatches();
    sc.clip = Some(clip);
    sc.request().unwrap();
    assert!(sc.poll(true).unwrap());
    let ctx2 = sc.ctx();
    let mut enc = ctx2.device.create_command_encoder(&Default::default());
    let info = sc.encode(&mut enc, 1).unwrap();
    ctx2.queue.submit([enc.finish()]);
    assert_eq!((info.axis, info.stale), (0, false));
    assert!(sc.dispatches() > d0);
    assert_eq!(info.cut_cells, cut.len() as u64);
    assert!(!cut.is_empty() && cut.len() < 24 * 10 * 8);
}
