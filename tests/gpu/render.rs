//! Rendering with analytic expectations: a uniform box viewed
//! orthographically reaches alpha 1 − (1 − a)^(L/U) at the image centre (L
//! the chord through the box), for 50, 200 and 800 slices and 0°, 30°, 60°
//! off-axis; an empty transfer function is refused; two
//! half-boxes composite in the right order from both sides; a second view in
//! the same axis cone dispatches no compute.

use crate::support;

use stratasweep::generate::warped;
use stratasweep::gpu::render::{CellFinding, Mode, RenderOptions, Renderer, Transfer};
use stratasweep::grid::{Grid, Property, Topology};
use stratasweep::structures::{Structure, StructureChoice};

/// Half thickness of the box along z.
const H: f64 = 0.5;
/// Half width along x, chosen so that at 60° the centre ray crosses exactly
/// 0.4·K slices along x (its ends fall midway between slices).
const W: f64 = 50.0 * 0.5 * 1.732_050_807_568_877_2 / 20.0;

/// A box [−W, W] × [−2, 2] × [−H, H] with point properties `one` = 1 and `z`.
fn box_with_z() -> Grid {
    let mut g = support::box_grid([9, 5, 5], [W, 2.0, H]);
    let z = g.points.iter().map(|p| p[2]).collect();
    g.point_data.push(Property::scalar("z", z));
    g
}

fn flat(a: f32) -> Transfer {
    Transfer::from_json(&format!(
        r#"{{"points":[{{"value":0,"color":[1,0.5,0.25],"opacity":{a}}},{{"value":2,"color":[1,0.5,0.25],"opacity":{a}}}]}}"#
    ))
    .unwrap()
}

fn opts(property: &str, transfer: Transfer, view: [f64; 3], slices: usize) -> RenderOptions {
    RenderOptions {
        property: Some(property.into()),
        slices,
        view_dir: view,
        up: Some([0.0, 1.0, 0.0]),
        perspective: false,
        transfer: Some(transfer),
        unit_distance: Some(1.0),
        background: None,
        size: (65, 65),
        mode: Mode::Volume,
        ..Default::default()
    }
}

#[test]
fn uniform_box_reaches_the_analytic_alpha() {
    let Some(ctx) = support::gpu("uniform_box_reaches_the_analytic_alpha") else {
        return;
    };
    let grid = box_with_z();
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let mut r = Renderer::new(ctx).unwrap();
    let a = 0.3f64;
    for slices in [50, 200, 800] {
        for deg in [0.0f64, 30.0, 60.0] {
            let t = deg.to_radians();
            let view = [t.sin(), 0.0, -t.cos()];
            let img = r
                .render(&grid, &s, &opts("one", flat(a as f32), view, slices))
                .unwrap();
            let chord = 2.0 * H / t.cos();
            let want = 1.0 - (1.0 - a).powf(chord / 1.0);
            let got = img.pixel(32, 32)[3] as f64;
            eprintln!("{slices} slices, {deg}°: alpha {got:.5}, analytic {want:.5}");
            assert!(
                (got - want).abs() <= 2.0 / 255.0,
                "{slices} slices at {deg}°: alpha {got}, analytic {want}"
            );
            // Straight PNG colour is the transfer colour.
            let rgba = img.rgba8();
            let c = &rgba[(32 * 65 + 32) * 4..][..4];
            assert!(
                (c[0] as i32 - 255).abs() <= 1 && (c[1] as i32 - 128).abs() <= 1,
                "{c:?}"
            );
        }
    }
}

#[test]
fn an_empty_transfer_is_refused() {
    let Some(ctx) = support::gpu("an_empty_transfer_is_refused") else {
        return;
    };
    let grid = box_with_z();
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let mut r = Renderer::new(ctx).unwrap();
    let empty = Transfer::from_json(r#"{"points":[]}"#).unwrap();
    let mut o = opts("one", empty, [0.2, 0.1, -1.0], 64);
    o.background = Some([0.2, 0.4, 0.6, 1.0]);
    // It could only give the background: refused (the CLI and Python alike).
    let e = r.render(&grid, &s, &o).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("no points"), "{e}");
}

#[test]
fn half_boxes_composite_in_order_from_both_sides() {
    let Some(ctx) = support::gpu("half_boxes_composite_in_order_from_both_sides") else {
        return;
    };
    let grid = box_with_z();
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let mut r = Renderer::new(ctx).unwrap();
    // z < 0 red, z > 0 blue, both nearly opaque over half the thickness.
    let t = Transfer::from_json(
        r#"{"points":[{"value":-1,"color":[1,0,0],"opacity":0.95},{"value":-0.01,"color":[1,0,0],"opacity":0.95},
                      {"value":0.01,"color":[0,0,1],"opacity":0.95},{"value":1,"color":[0,0,1],"opacity":0.95}]}"#,
    )
    .unwrap();
    for (view, near_is_blue) in [
        ([0.0, 0.0, -1.0], true),
        ([0.0, 0.0, 1.0], false),
        ([0.3, 0.2, -1.0], true),
        ([-0.3, 0.1, 1.0], false),
    ] {
        let mut o = opts("z", t.clone(), view, 100);
        o.unit_distance = Some(0.05);
        o.up = Some([0.0, 1.0, 0.0]);
        let img = r.render(&grid, &s, &o).unwrap();
        let [red, _, blue, alpha] = img.pixel(32, 32);
        eprintln!("view {view:?}: red {red:.3} blue {blue:.3} alpha {alpha:.3}");
        assert!(alpha > 0.99);
        if near_is_blue {
            assert!(
                blue > 0.9 && red < 0.1,
                "view {view:?}: red {red} blue {blue}"
            );
        } else {
            assert!(
                red > 0.9 && blue < 0.1,
                "view {view:?}: red {red} blue {blue}"
            );
        }
    }
}

#[test]
fn same_axis_cone_renders_without_dispatch() {
    let Some(ctx) = support::gpu("same_axis_cone_renders_without_dispatch") else {
        return;
    };
    let grid = warped([12, 10, 8], 5);
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let mut r = Renderer::new(ctx).unwrap();
    let mut o = RenderOptions {
        size: (48, 40),
        slices: 40,
        view_dir: [0.1, 0.05, -1.0],
        ..Default::default()
    };
    let a = r.render(&grid, &s, &o).unwrap();
    let n = r.dispatches();
    assert!(n > 0);
    o.view_dir = [-0.3, 0.2, -1.0];
    let b = r.render(&grid, &s, &o).unwrap();
    assert_eq!(
        r.dispatches(),
        n,
        "another view in the z cone dispatched compute"
    );
    o.view_dir = [0.2, 0.1, 1.0];
    r.render(&grid, &s, &o).unwrap();
    assert_eq!(
        r.dispatches(),
        n,
        "the opposite z direction reuses the same slices"
    );
    assert_ne!(a.rgba8(), b.rgba8());
    o.view_dir = [1.0, 0.1, 0.2];
    r.render(&grid, &s, &o).unwrap();
    assert!(r.dispatches() > n, "a new axis must slice again");
    // Iso mode: opaque pixels over a white background.
    o.mode = Mode::Iso;
    o.iso = vec![0.3, 0.6];
    o.background = None;
    let img = r.render(&grid, &s, &o).unwrap();
    let opaque = img.premultiplied.iter().filter(|p| p[3] > 0.999).count();
    assert!(opaque > 20, "iso: {opaque} opaque pixels");
    assert!(img.png().unwrap().starts_with(b"\x89PNG"));
}

/// [`box_grid`] with cell property `half`: 0 on the cells with x < 0 (red)
/// and 1 on those with x > 0 (blue); the boundary is the grid plane x = 0.
fn half_cell_grid() -> Grid {
    let mut g = box_with_z();
    let (ni, nj, nk) = (8, 4, 4);
    let v = (0..ni * nj * nk)
        .map(|c| if c % ni < ni / 2 { 0.0 } else { 1.0 })
        .collect();
    g.cell_data.push(Property::scalar("half", v));
    g
}

fn red_blue() -> Transfer {
    Transfer::from_json(
        r#"{"points":[{"value":0,"color":[1,0,0],"opacity":0.6},{"value":1,"color":[0,0,1],"opacity":0.6}]}"#,
    )
    .unwrap()
}

/// A cell property colours each polygon flat with its own cell's value:
/// looking down −z at the two halves, every covered pixel is pure red
/// (x < 0) or pure blue (x > 0), never a mix, and the columns follow the
/// analytic framing (the box fills the image height up to the margin).
/// The same values averaged to the vertices do give mixed colours.
#[test]
fn cell_property_gives_flat_colour_per_polygon() {
    let Some(ctx) = support::gpu("cell_property_gives_flat_colour_per_polygon") else {
        return;
    };
    let mut grid = half_cell_grid();
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let (w, h) = (80u32, 40u32);
    // Orthographic window: the box is 2W × 4 across, the image aspect 2,
    // so the height limits: half-height 2·margin, half-width twice that.
    let hh = 2.0 * stratasweep::gpu::render::camera::FRAME_MARGIN as f64;
    let hw = hh * w as f64 / h as f64;
    let world = |x: u32, y: u32| {
        (
            ((x as f64 + 0.5) / w as f64 * 2.0 - 1.0) * hw,
            (1.0 - (y as f64 + 0.5) / h as f64 * 2.0) * hh,
        )
    };
    let px_w = 2.0 * hw / w as f64;
    let mut r = Renderer::new(ctx).unwrap();
    for mode in [Mode::Slices, Mode::Volume] {
        let mut o = opts("half", red_blue(), [0.0, 0.0, -1.0], 40);
        o.size = (w, h);
        o.mode = mode;
        let img = r.render(&grid, &s, &o).unwrap();
        let rgba = img.rgba8();
        let (mut red, mut blue) = (0, 0);
        for y in 0..h {
            for x in 0..w {
                let p = &rgba[((y * w + x) * 4) as usize..][..4];
                let (wx, wy) = world(x, y);
                let inside = wx.abs() < W - px_w && wy.abs() < 2.0 - px_w;
                let outside = wx.abs() > W + px_w || wy.abs() > 2.0 + px_w;
                if p[3] > 0 {
                    // Straight colour: pure red or pure blue, nothing between.
                    assert!(
                        p[..3] == [255, 0, 0] || p[..3] == [0, 0, 255],
                        "{mode:?}: pixel ({x}, {y}) = {p:?} mixes the cells' colours"
                    );
                }
                if inside {
                    assert!(p[3] > 128, "{mode:?}: ({x}, {y}) inside the box is empty");
                    let want = if wx < 0.0 { [255, 0, 0] } else { [0, 0, 255] };
                    assert_eq!(p[..3], want, "{mode:?}: pixel ({x}, {y}) at x = {wx:.3}");
                    if wx < 0.0 { red += 1 } else { blue += 1 }
                }
                if outside {
                    assert_eq!(p[3], 0, "{mode:?}: ({x}, {y}) outside the box is covered");
                }
            }
        }
        eprintln!("{mode:?}: {red} red and {blue} blue pixels inside");
        assert_eq!(red, blue, "{mode:?}: the boundary is not at x = 0");
        assert!(red > 200);
    }
    // Averaged to the vertices, the same values blend across the boundary.
    let avg = stratasweep::pipeline::vertex_property(&grid, &s, "half").unwrap();
    grid.point_data.push(Property::scalar(
        "avg",
        avg.iter().map(|&v| v as f64).collect(),
    ));
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let mut o = opts("avg", red_blue(), [0.0, 0.0, -1.0], 40);
    o.size = (w, h);
    o.mode = Mode::Slices;
    let img = r.render(&grid, &s, &o).unwrap();
    let mixed = img
        .rgba8()
        .chunks_exact(4)
        .filter(|p| p[3] > 0 && p[0] > 20 && p[2] > 20)
        .count();
    assert!(
        mixed > 20,
        "averaged values should blend ({mixed} mixed pixels)"
    );
}

/// A cube [−1, 1]³ of `n`³ points with point property `d`, the distance to
/// the origin (a sphere distance field).
fn sphere_grid(n: usize) -> Grid {
    let mut points = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let f = |m: usize| m as f64 / (n - 1) as f64 * 2.0 - 1.0;
                points.push([f(i), f(j), f(k)]);
            }
        }
    }
    let d = points
        .iter()
        .map(|p| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt())
        .collect();
    Grid {
        point_data: vec![Property::scalar("d", d)],
        points,
        topology: Topology::Structured { dims: [n, n, n] },
        cell_data: Vec::new(),
    }
}

/// Iso mode lit by the interpolated gradient: an isosphere seen
/// orthographically under the headlight has, at distance ρ from its
/// silhouette's centre, the shade 0.2 + 0.8·√(1 − (ρ/R)²) (white transfer).
#[test]
fn isosphere_shading_follows_the_analytic_normal() {
    let Some(ctx) = support::gpu("isosphere_shading_follows_the_analytic_normal") else {
        return;
    };
    let grid = sphere_grid(25);
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let mut r = Renderer::new(ctx).unwrap();
    let white = Transfer::from_json(
        r#"{"points":[{"value":0,"color":[1,1,1],"opacity":1},{"value":2,"color":[1,1,1],"opacity":1}]}"#,
    )
    .unwrap();
    let mut o = opts("d", white, [0.0, 0.0, -1.0], 1);
    o.mode = Mode::Iso;
    o.iso = vec![0.6];
    o.size = (96, 96);
    let img = r.render(&grid, &s, &o).unwrap();
    let (w, h) = (96u32, 96u32);
    // The silhouette: centroid and radius from the covered area.
    let (mut n, mut sx, mut sy) = (0f64, 0f64, 0f64);
    for y in 0..h {
        for x in 0..w {
            if img.pixel(x, y)[3] > 0.5 {
                n += 1.0;
                sx += x as f64 + 0.5;
                sy += y as f64 + 0.5;
            }
        }
    }
    let (cx, cy, rad) = (sx / n, sy / n, (n / std::f64::consts::PI).sqrt());
    // The framing: the cube fills the image up to the margin, so the
    // sphere's radius is 0.6 / (1 · margin) of the half-image.
    let want_rad = 0.6 / stratasweep::gpu::render::camera::FRAME_MARGIN as f64 * 48.0;
    eprintln!("silhouette: centre ({cx:.2}, {cy:.2}), radius {rad:.2} px (framing: {want_rad:.2})");
    assert!((cx - 48.0).abs() < 0.5 && (cy - 48.0).abs() < 0.5);
    assert!(
        (rad - want_rad).abs() < 1.0,
        "radius {rad} px, framing {want_rad}"
    );
    let (mut worst, mut sum, mut m) = (0f64, 0f64, 0);
    for y in 0..h {
        for x in 0..w {
            let rho = ((x as f64 + 0.5 - cx).powi(2) + (y as f64 + 0.5 - cy).powi(2)).sqrt() / rad;
            if rho > 0.85 {
                continue;
            }
            let p = img.pixel(x, y);
            let want = 0.2 + 0.8 * (1.0 - rho * rho).sqrt();
            for c in &p[..3] {
                let e = (*c as f64 - want).abs();
                worst = worst.max(e);
                sum += e;
                m += 1;
            }
        }
    }
    eprintln!(
        "shade error over {m} channels: mean {:.4}, max {worst:.4}",
        sum / m as f64
    );
    // Facet normals miss by up to ~0.06 here; the interpolated gradient by < 0.004.
    assert!(worst < 0.02, "shade off the analytic normal by {worst}");
}

/// The camera frames the grid itself: a rotated warped grid (whose
/// axis-aligned box is larger than it) fills the image up to the margin.
#[test]
fn rotated_grid_fills_the_frame() {
    let Some(ctx) = support::gpu("rotated_grid_fills_the_frame") else {
        return;
    };
    let grid = warped([12, 12, 12], 3);
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let mut r = Renderer::new(ctx).unwrap();
    let flat_opaque = Transfer::from_json(
        r#"{"points":[{"value":-10,"color":[1,0,0],"opacity":1},{"value":10,"color":[1,0,0],"opacity":1}]}"#,
    )
    .unwrap();
    for (view, perspective) in [
        ([-1.0, -0.6, -0.8], false),
        ([0.2, 0.1, -1.0], false),
        ([-1.0, -0.6, -0.8], true),
    ] {
        let mut o = opts("f", flat_opaque.clone(), view, 60);
        o.mode = Mode::Slices;
        o.up = None;
        o.perspective = perspective;
        o.size = (160, 120);
        let img = r.render(&grid, &s, &o).unwrap();
        let (mut x0, mut x1, mut y0, mut y1) = (u32::MAX, 0, u32::MAX, 0);
        for y in 0..120 {
            for x in 0..160 {
                if img.pixel(x, y)[3] > 0.5 {
                    (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
                }
            }
        }
        let fw = (x1 + 1 - x0) as f64 / 160.0;
        let fh = (y1 + 1 - y0) as f64 / 120.0;
        eprintln!(
            "view {view:?} perspective {perspective}: covers {fw:.3} of the width, {fh:.3} of the height"
        );
        assert!(x0 > 0 && y0 > 0 && x1 < 159 && y1 < 119, "clipped");
        assert!(
            fw.max(fh) > 0.9,
            "the grid covers only {fw} × {fh} of the image"
        );
    }
}

/// A small faulted corner-point grid and its IJK layout.
fn small_faulted() -> (Grid, stratasweep::grid::IjkLayout) {
    let cp = stratasweep::generate::faulted([14, 11, 7], 3, 4);
    let dims = cp.dims;
    let (grid, rep) = cp.into_grid().unwrap();
    let layout = stratasweep::grid::IjkLayout {
        dims,
        source_cell: rep.source_cell,
    };
    (grid, layout)
}

/// Pixels of two RGBA8 images that differ in any channel.
fn pixels_differing(a: &[u8], b: &[u8]) -> usize {
    a.chunks(4).zip(b.chunks(4)).filter(|(x, y)| x != y).count()
}

/// `render` and `view` give corner-point input the CP-Graph (its IJK
/// layout kept): a faulted deck with a cell property must render the
/// CGraph's image on it, in volume, slices and iso modes, up to pixels on
/// polygon edges (the two structures cut an edge from either end, so
/// vertices may differ in their last bits): at most 2 % of the pixels, and
/// a mean difference under 0.05 levels.
#[test]
fn a_faulted_grid_renders_alike_on_the_cp_graph_and_the_cgraph() {
    let Some(ctx) = support::gpu("a_faulted_grid_renders_alike_on_the_cp_graph_and_the_cgraph")
    else {
        return;
    };
    let (grid, layout) = small_faulted();
    let on_cp = Structure::build_with(&grid, StructureChoice::Auto, Some(&layout)).unwrap();
    assert!(matches!(on_cp, Structure::CpGraph(_)));
    let on_cg = Structure::build(&grid, StructureChoice::CGraph).unwrap();
    let mut r = Renderer::new(ctx).unwrap();
    for (mode, iso) in [
        (Mode::Volume, vec![]),
        (Mode::Slices, vec![]),
        (Mode::Iso, vec![0.2]),
    ] {
        let o = RenderOptions {
            property: Some("PORO".into()),
            slices: 40,
            view_dir: [0.5, 0.4, -0.77],
            size: (96, 72),
            mode,
            iso,
            ..Default::default()
        };
        let a = r.render(&grid, &on_cp, &o).unwrap().rgba8();
        let b = r.render(&grid, &on_cg, &o).unwrap().rgba8();
        let drawn = a.chunks(4).filter(|p| p[3] > 0).count();
        assert!(drawn > 500, "{mode:?}: {drawn} pixels drawn");
        let px = a.len() / 4;
        let differ = pixels_differing(&a, &b);
        let sum: u64 = a.iter().zip(&b).map(|(x, y)| x.abs_diff(*y) as u64).sum();
        let mean = sum as f64 / a.len() as f64;
        eprintln!("{mode:?}: {differ} of {px} pixels differ, mean {mean:.4}");
        assert!(
            differ * 50 <= px,
            "{mode:?}: {differ} of {px} pixels differ"
        );
        assert!(mean < 0.05, "{mode:?}: mean difference {mean}");
    }
}

/// The slice cache is keyed by view and property: one renderer used for a
/// second grid (or the same grid with other values) must draw that grid,
/// as a fresh renderer does, not the first grid's cached slices.
#[test]
fn a_renderer_reused_for_another_grid_draws_that_grid() {
    let Some(ctx) = support::gpu("a_renderer_reused_for_another_grid_draws_that_grid") else {
        return;
    };
    let a = warped([12, 10, 8], 3);
    let mut b = warped([12, 10, 8], 3);
    for p in &mut b.points {
        p[0] *= 1.5;
    }
    let mut c = warped([12, 10, 8], 3);
    for p in &mut c.point_data[0].values {
        *p = -*p;
    }
    let name = a.point_data[0].name.clone();
    let o = RenderOptions {
        property: Some(name),
        slices: 30,
        size: (64, 48),
        view_dir: [0.3, 0.2, -0.93],
        ..Default::default()
    };
    let mut shared = Renderer::new(ctx).unwrap();
    let first = {
        let s = Structure::build(&a, StructureChoice::Auto).unwrap();
        shared.render(&a, &s, &o).unwrap().rgba8()
    };
    for (what, g) in [("moved points", &b), ("other values", &c)] {
        let s = Structure::build(g, StructureChoice::Auto).unwrap();
        let reused = shared.render(g, &s, &o).unwrap().rgba8();
        let fresh = Renderer::new(ctx)
            .unwrap()
            .render(g, &s, &o)
            .unwrap()
            .rgba8();
        assert_ne!(reused, first, "{what}: the first grid's image");
        assert_eq!(reused, fresh, "{what}: differs from a fresh renderer's");
    }
}

/// GPU span-space binning (`CellFinding::Gpu`) finds the cut cells the CPU
/// sweep finds: the same pictures on the lattice, the CP-Graph (cell
/// property: flat colours, and iso) and the CGraph, and the binning really
/// ran (two more dispatches per slice set).
#[test]
fn gpu_binned_cells_render_as_the_sweep() {
    let Some(ctx) = support::gpu("gpu_binned_cells_render_as_the_sweep") else {
        return;
    };
    let (faulted, layout) = small_faulted();
    let lattice = warped([12, 10, 8], 1);
    let cases = [
        (
            "lattice",
            &lattice,
            Structure::build(&lattice, StructureChoice::Auto).unwrap(),
            None,
        ),
        (
            "cp-graph",
            &faulted,
            Structure::build_with(&faulted, StructureChoice::Auto, Some(&layout)).unwrap(),
            Some("PORO"),
        ),
        (
            "cgraph",
            &faulted,
            Structure::build(&faulted, StructureChoice::CGraph).unwrap(),
            Some("PORO"),
        ),
    ];
    for (name, grid, s, property) in &cases {
        for (mode, iso) in [(Mode::Volume, vec![]), (Mode::Iso, vec![0.2])] {
            if mode == Mode::Iso && property.is_none() {
                continue;
            }
            let o = RenderOptions {
                property: property.map(String::from),
                slices: 40,
                view_dir: [0.5, 0.4, -0.77],
                size: (96, 72),
                mode,
                iso,
                ..Default::default()
            };
            let mut images = Vec::new();
            let mut dispatches = Vec::new();
            for cells in [CellFinding::Sweep, CellFinding::Gpu] {
                let mut r = Renderer::new(ctx).unwrap();
                let o = RenderOptions { cells, ..o.clone() };
                images.push(r.render(grid, s, &o).unwrap().rgba8());
                dispatches.push(r.dispatches());
            }
            let (a, b) = (&images[0], &images[1]);
            let drawn = a.chunks(4).filter(|p| p[3] > 0).count();
            assert!(drawn > 500, "{name} {mode:?}: {drawn} pixels drawn");
            let px = a.len() / 4;
            let differ = pixels_differing(a, b);
            let worst = a
                .iter()
                .zip(b)
                .map(|(x, y)| x.abs_diff(*y))
                .max()
                .unwrap_or(0);
            eprintln!(
                "{name} {mode:?}: {differ} of {px} pixels differ (at most {worst} levels), \
                 dispatches {dispatches:?}"
            );
            assert!(
                differ * 100 <= px,
                "{name} {mode:?}: {differ} of {px} pixels differ"
            );
            assert_eq!(
                dispatches[1],
                dispatches[0] + 2,
                "{name} {mode:?}: the binning did not run"
            );
        }
    }
}

/// `grid` fitted to a reservoir's size (10 × 12 km, 400 m thick), without
/// its properties, centred on the origin or in reservoir coordinates (UTM
/// easting and northing, depth below sea level).
fn reservoir_sized(mut grid: Grid, far: bool) -> Grid {
    grid.point_data.clear();
    grid.cell_data.clear();
    let (lo, hi) = grid.bounds();
    let (size, at) = (
        [10_000.0, 12_000.0, 400.0],
        [456_510.0, 5_926_880.0, -1_900.0],
    );
    for p in &mut grid.points {
        for c in 0..3 {
            let unit = (p[c] - lo[c]) / (hi[c] - lo[c]) - 0.5;
            p[c] = unit * size[c] + if far { at[c] } else { 0.0 };
        }
    }
    grid
}

/// With no property the slices show their position along the axis, with
/// the colormap over the world range: a grid in reservoir coordinates must
/// render as the same grid at the origin. (The slices once carried their
/// local position against the world range, so such a grid drew nothing
/// when sliced along x or y and one flat colour along z.)
#[test]
fn a_grid_without_properties_far_from_the_origin_renders_as_at_the_origin() {
    let Some(ctx) =
        support::gpu("a_grid_without_properties_far_from_the_origin_renders_as_at_the_origin")
    else {
        return;
    };
    let near = reservoir_sized(warped([10, 9, 8], 5), false);
    let far = reservoir_sized(warped([10, 9, 8], 5), true);
    let mut r = Renderer::new(ctx).unwrap();
    for view in [[-1.0, -0.3, -0.2], [0.2, -1.0, -0.3], [0.2, 0.1, -1.0]] {
        let o = RenderOptions {
            property: None,
            slices: 60,
            view_dir: view,
            size: (64, 64),
            background: Some([0.0; 4]),
            ..Default::default()
        };
        let mut imgs = Vec::new();
        for g in [&near, &far] {
            let s = Structure::build(g, StructureChoice::Auto).unwrap();
            imgs.push(r.render(g, &s, &o).unwrap().rgba8());
        }
        let drawn = imgs[0].chunks(4).filter(|p| p[3] > 0).count();
        assert!(
            drawn > 500,
            "view {view:?}: {drawn} pixels drawn at the origin"
        );
        let worst = imgs[0]
            .iter()
            .zip(&imgs[1])
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap();
        eprintln!("view {view:?}: {drawn} pixels drawn, largest difference {worst} levels");
        assert!(
            worst <= 2,
            "view {view:?}: the far grid differs by {worst} levels"
        );
    }
}

/// Without `--property` the renderer shows the first property that varies
/// (a constant one would draw one colour: SPE10's PORO), else the first
/// one, else none (the slice position). No GPU needed.
#[test]
fn the_default_property_is_the_first_that_varies() {
    use stratasweep::gpu::render::shown::default_property;
    let mut g = warped([3, 3, 3], 1);
    g.point_data.clear();
    assert_eq!(default_property(&g), None);
    let cells = g.cell_count();
    let mut varying: Vec<f64> = (0..cells).map(|c| c as f64).collect();
    varying[0] = f64::NAN;
    g.cell_data = vec![
        Property::scalar("PORO", vec![0.2; cells]),
        Property::scalar(
            "NAN_THEN_ONE",
            [f64::NAN].into_iter().chain(vec![1.0; cells - 1]).collect(),
        ),
        Property::scalar("PERMX", varying),
    ];
    assert_eq!(default_property(&g).as_deref(), Some("PERMX"));
    g.point_data = vec![Property::scalar("one", vec![1.0; g.points.len()])];
    assert_eq!(default_property(&g).as_deref(), Some("PERMX"));
    g.cell_data.truncate(2);
    assert_eq!(
        default_property(&g).as_deref(),
        Some("one"),
        "all constant: the first"
    );
}

/// A constant property is refused by the library, as the CLI refuses it,
/// unless a transfer function's points colour it (volume and slices); no
/// isosurface lies inside a constant's range.
#[test]
fn a_constant_property_is_refused_without_a_transfer_function() {
    let Some(ctx) = support::gpu("a_constant_property_is_refused_without_a_transfer_function")
    else {
        return;
    };
    let grid = box_with_z();
    let s = Structure::build(&grid, StructureChoice::Auto).unwrap();
    let mut r = Renderer::new(ctx).unwrap();
    let mut o = opts("one", flat(0.3), [0.2, 0.1, -1.0], 16);
    assert!(
        r.render(&grid, &s, &o).is_ok(),
        "a transfer function colours it"
    );
    o.transfer = None;
    let e = r.render(&grid, &s, &o).unwrap_err().to_string();
    assert!(e.contains("property 'one' is constant (1)"), "{e}");
    o.transfer = Some(flat(0.3));
    o.mode = Mode::Iso;
    o.iso = vec![1.0];
    let e = r.render(&grid, &s, &o).unwrap_err().to_string();
    assert!(e.contains("is constant"), "{e}");
}
