//! egui drawn over the scene with egui-wgpu: the viewer's panel and the
//! colour legend (the library's painter, [`stratasweep::gpu::legend`],
//! the same for the window and `render --legend`), and the outline box
//! with its axes.

use egui::{Align2, Color32, FontId, Painter, Pos2, Stroke, Vec2, pos2};
use glam::{Mat4, Vec3};

pub use stratasweep::gpu::legend::{LEGEND_SIZE, Legend, Overlay, paint_legend, read_rgba8};

/// Paints the X, Y and Z axes from the lowest corner of the grid's bounding
/// box (display space extents `ext`, centred on the local origin) as seen
/// through `view_proj` (display → clip), in a viewport of `size` points.
/// The box's edges are drawn by the present pass (`gpu::outline`), the
/// hidden ones under the scene.
pub fn paint_outline(p: &Painter, view_proj: Mat4, ext: Vec3, size: Vec2) {
    let corner = |i: usize| {
        let s = |b: usize| if i >> b & 1 == 1 { 0.5 } else { -0.5 };
        ext * Vec3::new(s(0), s(1), s(2))
    };
    let project = |q: Vec3| -> Option<Pos2> {
        let c = view_proj * q.extend(1.0);
        (c.w > 1e-6).then(|| {
            pos2(
                (c.x / c.w * 0.5 + 0.5) * size.x,
                (0.5 - c.y / c.w * 0.5) * size.y,
            )
        })
    };
    let o = corner(0);
    let colors = [
        Color32::from_rgb(220, 40, 40),
        Color32::from_rgb(30, 160, 30),
        Color32::from_rgb(40, 70, 230),
    ];
    for (a, name) in ["X", "Y", "Z"].iter().enumerate() {
        let mut e = Vec3::ZERO;
        e[a] = ext[a].max(1e-6) * 0.3;
        if let (Some(s), Some(t)) = (project(o), project(o + e)) {
            p.line_segment([s, t], Stroke::new(2.5, colors[a]));
            p.text(
                t,
                Align2::CENTER_CENTER,
                *name,
                FontId::proportional(14.0),
                colors[a],
            );
        }
    }
}
