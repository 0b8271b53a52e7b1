//! Pre-integrated volume mode against a CPU integration along the ray: a
//! box whose value rises linearly with z, a transfer function whose
//! colour and opacity ramp with the value, a handful of slices. Between
//! slices the value is linear, so the slab reconstruction (Hermite from
//! the slices' values and gradients), the pre-integrated table, the
//! segments from where the ray enters the grid to the nearest slice and
//! from the farthest slice to where it leaves, and the opacity correction
//! for the ray's angle together must give the continuous integral.

use crate::support;
use crate::support::ray::integrate_linear;

use stratasweep::gpu::render::{Mode, RenderOptions, Renderer};
use stratasweep::grid::{Grid, Property};
use stratasweep::structures::{Structure, StructureChoice};

/// Half thickness of the box along z.
const H: f64 = 0.5;

/// A box [−2, 2] × [−2, 2] × [−H, H] with the point property `v` = z/(2H) + 1/2.
fn ramp_box() -> Grid {
    let mut g = support::box_grid([5, 5, 7], [2.0, 2.0, H]);
    let v = g.points.iter().map(|p| p[2] / (2.0 * H) + 0.5).collect();
    g.point_data = vec![Property::scalar("v", v)];
    g
}

#[test]
fn few_preintegrated_slices_give_the_integral_along_the_ray() {
    let Some(ctx) = support::gpu("few_preintegrated_slices_give_the_integral_along_the_ray") else {
        return;
    };
    let g = ramp_box();
    let s = Structure::build(&g, StructureChoice::Auto).unwrap();
    let t = support::ray::ramp_transfer();
    for deg in [0.0f64, 35.0] {
        let th = deg.to_radians();
        let o = RenderOptions {
            property: Some("v".into()),
            slices: 5,
            view_dir: [th.sin(), 0.0, -th.cos()],
            up: Some([0.0, 1.0, 0.0]),
            transfer: Some(t.clone()),
            unit_distance: Some(1.0),
            background: None,
            size: (33, 33),
            mode: Mode::Volume,
            ..Default::default()
        };
        // Looking down: the ray enters at the top (v = 1), leaves at the bottom.
        let want = integrate_linear(&t, 1.0, 0.0, 2.0 * H / th.cos());
        let err = |pre: bool| {
            let mut r = Renderer::new(ctx).unwrap();
            r.set_preintegrated(pre);
            let img = r.render_exaggerated(&g, &s, &o, 1.0).unwrap();
            let got = img.pixel(16, 16);
            (0..4)
                .map(|c| (got[c] as f64 - want[c]).abs())
                .fold(0.0, f64::max)
        };
        let (pre, plain) = (err(true), err(false));
        eprintln!("{deg}°: max channel error pre-integrated {pre:.5}, plain {plain:.5}");
        assert!(pre <= 2.0 / 255.0, "{deg}°: pre-integrated error {pre}");
        assert!(pre < plain / 2.0, "{deg}°: pre {pre} vs plain {plain}");
    }
}
