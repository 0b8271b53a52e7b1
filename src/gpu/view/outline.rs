//! The viewer's outline box (no wgpu): the 12 edges of the grid's
//! bounding box in clip space, split into the edges hidden by the box
//! itself (both adjacent faces turned away from the camera) and the others.
//! The present pass draws the hidden ones under the scene (attenuated by
//! the scene's opacity, so opaque isosurfaces and dense volume hide them)
//! and the others over it.

use glam::Vec3;

use crate::gpu::render::camera::OrbitCamera;

/// One line corner: clip position and straight RGBA.
pub type LineVertex = [f32; 8];

/// The box edges of `cam` (display space box `cam.ext` centred on the local
/// origin): (hidden edges, visible edges), two corners per edge.
pub fn box_edges(cam: &OrbitCamera, rgba: [f32; 4]) -> (Vec<LineVertex>, Vec<LineVertex>) {
    let vp = cam.display_view_proj();
    let eye = cam.eye();
    let corner = |i: usize| {
        let s = |b: usize| if i >> b & 1 == 1 { 0.5 } else { -0.5 };
        cam.ext * Vec3::new(s(0), s(1), s(2))
    };
    // Face (axis a, side s = ±1) faces the camera.
    let faces_camera = |a: usize, s: f32| {
        let mut n = Vec3::ZERO;
        n[a] = s;
        if cam.perspective {
            let c = n * cam.ext * 0.5;
            n.dot(eye - c) > 0.0
        } else {
            n.dot(-cam.dir) > 0.0
        }
    };
    let vertex = |p: Vec3| {
        let c = vp * p.extend(1.0);
        [c.x, c.y, c.z, c.w, rgba[0], rgba[1], rgba[2], rgba[3]]
    };
    let (mut hidden, mut shown) = (Vec::new(), Vec::new());
    for i in 0..8usize {
        for b in 0..3 {
            if i >> b & 1 == 1 {
                continue;
            }
            let j = i | 1 << b;
            let back = (0..3).filter(|&a| a != b).all(|a| {
                let s = if i >> a & 1 == 1 { 1.0 } else { -1.0 };
                !faces_camera(a, s)
            });
            let out = if back { &mut hidden } else { &mut shown };
            out.push(vertex(corner(i)));
            out.push(vertex(corner(j)));
        }
    }
    (hidden, shown)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::render::camera::Framing;

    #[test]
    fn a_box_seen_off_axis_hides_three_edges() {
        let pts = [[0.0, 0.0, 0.0], [2.0, 2.0, 2.0]];
        let cam = OrbitCamera::fit(&Framing {
            points: &pts,
            origin: [1.0; 3],
            ext: Vec3::splat(2.0),
            dir: Vec3::new(-1.0, -0.6, -0.8).normalize(),
            up: Vec3::Z,
            aspect: 1.0,
            perspective: false,
            z_scale: 1.0,
        });
        let (hidden, shown) = box_edges(&cam, [0.0, 0.0, 0.0, 1.0]);
        // Looking from +x, +y, +z: the three edges at the far corner
        // (−x, −y, −z) are hidden, 9 are seen.
        assert_eq!((hidden.len() / 2, shown.len() / 2), (3, 9));
        // The hidden edges all meet at that corner: it projects farthest.
        let far = cam.display_view_proj() * Vec3::splat(-1.0).extend(1.0);
        let at_far = hidden
            .chunks(2)
            .filter(|e| e.iter().any(|v| (v[2] / v[3] - far.z / far.w).abs() < 1e-5))
            .count();
        assert_eq!(at_far, 3);
    }
}
