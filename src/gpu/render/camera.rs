//! Cameras of the renderer: the tight fit of a grid seen along a direction
//! (`render`'s camera, [`frame_camera`], [`fit_camera`] for a render's
//! options) and the [`OrbitCamera`] that the viewer turns, pans and zooms
//! from that same fit; the slicing axis of a view direction
//! ([`slicing_axis`]). No wgpu here.
//!
//! Vertical exaggeration: the scene is drawn in *display* space, the grid's
//! local frame with z multiplied by the z-scale `S`. Directions, the eye and
//! the window are display-space; [`OrbitCamera::view_proj`] takes local
//! (physical) positions, applying `S` itself.

use glam::camera::rh::proj::directx::{orthographic, perspective};
use glam::camera::rh::view::look_at_mat4;
use glam::{Mat4, Vec3};

use crate::grid::Grid;

use super::error::RenderError;
use super::options::RenderOptions;

/// Margin around the projected grid: the window is 5 % wider (or taller)
/// than the side of the projected points that limits the fit.
pub const FRAME_MARGIN: f32 = 1.05;

/// Field of view across the smaller image side (perspective).
pub const FOV_DEGREES: f32 = 30.0;

/// A view basis (right `s`, up `u`, direction `d`) and the window's
/// half-slopes `tx`, `ty`.
#[derive(Clone, Copy)]
struct ViewFrame {
    s: Vec3,
    u: Vec3,
    d: Vec3,
    tx: f32,
    ty: f32,
}

/// Extents of the points in view coordinates: (min, max) along the right
/// vector and the up vector of `v`, and the perspective eye distance that
/// fits every point in its window. Points are rebased to `origin` and their
/// z multiplied by `zs` (display space).
fn view_extents(points: &[[f64; 3]], origin: [f64; 3], zs: f32, v: ViewFrame) -> [f32; 5] {
    let ViewFrame { s, u, d, tx, ty } = v;
    use rayon::prelude::*;
    let init = || {
        [
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NEG_INFINITY,
        ]
    };
    points
        .par_iter()
        .fold(init, |mut acc, p| {
            let q = Vec3::new(
                (p[0] - origin[0]) as f32,
                (p[1] - origin[1]) as f32,
                (p[2] - origin[2]) as f32 * zs,
            );
            let (x, y) = (q.dot(s), q.dot(u));
            acc[0] = acc[0].min(x);
            acc[1] = acc[1].max(x);
            acc[2] = acc[2].min(y);
            acc[3] = acc[3].max(y);
            // depth = dist + q·d must reach |x|·m / tx and |y|·m / ty.
            let dist = (x.abs() * FRAME_MARGIN / tx).max(y.abs() * FRAME_MARGIN / ty) - q.dot(d);
            acc[4] = acc[4].max(dist);
            acc
        })
        .reduce(init, |a, b| {
            [
                a[0].min(b[0]),
                a[1].max(b[1]),
                a[2].min(b[2]),
                a[3].max(b[3]),
                a[4].max(b[4]),
            ]
        })
}

/// The camera that frames a grid tightly: its `points` (world), rebased to
/// `origin` (the bounding-box centre, the local frame's origin), with
/// bounding-box extents `ext`, seen along the unit vector `d` with `up`.
/// Returns the world (local frame) → clip matrix and the eye position.
///
/// Orthographic: the window is the projected points' extent, centred on
/// it, widened to the image aspect and enlarged by [`FRAME_MARGIN`] (so a
/// rotated grid fills the image, not its axis-aligned box). Perspective
/// (30° field of view across the smaller image side, looking at the
/// bounding-box centre): the eye is placed at the smallest distance at
/// which every point projects inside the window. Without points the
/// bounding box's corners are framed.
pub fn frame_camera(
    points: &[[f64; 3]],
    origin: [f64; 3],
    ext: Vec3,
    d: Vec3,
    up: Vec3,
    aspect: f32,
    perspective: bool,
) -> (Mat4, Vec3) {
    let c = OrbitCamera::fit(&Framing {
        points,
        origin,
        ext,
        dir: d,
        up,
        aspect,
        perspective,
        z_scale: 1.0,
    });
    (c.view_proj(), c.eye())
}

/// What [`OrbitCamera::fit`] frames.
#[derive(Clone, Copy, Debug)]
pub struct Framing<'a> {
    /// The grid's points (world, f64); empty: the bounding box's corners.
    pub points: &'a [[f64; 3]],
    /// The local frame's origin (bounding-box centre).
    pub origin: [f64; 3],
    /// Bounding-box extents (physical).
    pub ext: Vec3,
    /// Unit view direction (display space).
    pub dir: Vec3,
    /// Up vector (display space), not parallel to `dir`.
    pub up: Vec3,
    /// Image width / height.
    pub aspect: f32,
    /// Perspective (else orthographic).
    pub perspective: bool,
    /// Vertical exaggeration S (z multiplied by S for display).
    pub z_scale: f32,
}

/// A camera around the grid's local origin, in display space: the view
/// direction and up vector, a pan target, the orthographic window's half
/// height or the perspective eye distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    /// Unit view direction (display space).
    pub dir: Vec3,
    /// Up vector (unit, orthogonal to `dir`).
    pub up: Vec3,
    /// The point looked at (display space, relative to the local origin).
    pub target: Vec3,
    /// Orthographic window half height.
    pub half_height: f32,
    /// Perspective eye distance from `target`.
    pub dist: f32,
    /// Perspective (else orthographic).
    pub perspective: bool,
    /// Image width / height.
    pub aspect: f32,
    /// Bounding-box extents in display space.
    pub ext: Vec3,
    /// Vertical exaggeration S.
    pub z_scale: f32,
}

/// The vertical field of view for an aspect ratio (30° across the smaller side).
fn fov_y(aspect: f32) -> f32 {
    let fov = FOV_DEGREES.to_radians();
    if aspect >= 1.0 {
        fov
    } else {
        2.0 * ((0.5 * fov).tan() / aspect).atan()
    }
}

impl OrbitCamera {
    /// The tight fit of [`frame_camera`] (which is this with `z_scale` 1).
    pub fn fit(f: &Framing) -> Self {
        let zs = f.z_scale;
        let ext = f.ext * Vec3::new(1.0, 1.0, zs);
        let r = (0.5 * ext.length()).max(1e-6);
        let d = f.dir;
        let s = d.cross(f.up).normalize();
        let u = s.cross(d);
        let ty = (0.5 * fov_y(f.aspect)).tan();
        let tx = ty * f.aspect;
        let corners: Vec<[f64; 3]>;
        let pts = if f.points.is_empty() {
            corners = (0..8)
                .map(|i| {
                    let c = f.ext * corner(i);
                    [0, 1, 2].map(|a| f.origin[a] + c[a] as f64)
                })
                .collect();
            &corners[..]
        } else {
            f.points
        };
        let [x0, x1, y0, y1, fit] = view_extents(pts, f.origin, zs, ViewFrame { s, u, d, tx, ty });
        let tiny = 1e-6 * r;
        let mut cam = OrbitCamera {
            dir: d,
            up: u,
            target: Vec3::ZERO,
            half_height: 1.0,
            dist: 1.0,
            perspective: f.perspective,
            aspect: f.aspect,
            ext,
            z_scale: zs,
        };
        if f.perspective {
            cam.dist = fit.max(1.05 * cam.depth_half_extent() + tiny);
        } else {
            let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
            let (hx, hy) = ((0.5 * (x1 - x0)).max(tiny), (0.5 * (y1 - y0)).max(tiny));
            cam.half_height = if hx > hy * f.aspect {
                hx * FRAME_MARGIN / f.aspect
            } else {
                hy * FRAME_MARGIN
            };
            cam.target = s * cx + u * cy;
        }
        cam
    }

    /// Bounding-sphere radius (display space).
    pub fn radius(&self) -> f32 {
        (0.5 * self.ext.length()).max(1e-6)
    }

    /// Half the bounding box's depth along the view direction.
    fn depth_half_extent(&self) -> f32 {
        (0..8)
            .map(|i| (self.ext * corner(i)).dot(self.dir).abs())
            .fold(1e-6 * self.radius(), f32::max)
    }

    /// The right vector.
    pub fn right(&self) -> Vec3 {
        self.dir.cross(self.up).normalize()
    }

    /// The eye position (display space).
    pub fn eye(&self) -> Vec3 {
        if self.perspective {
            self.target - self.dir * self.dist
        } else {
            -self.dir * (3.0 * self.radius())
        }
    }

    /// Display → clip matrix.
    pub fn display_view_proj(&self) -> Mat4 {
        let r = self.radius();
        let s = self.right();
        let u = s.cross(self.dir);
        if self.perspective {
            let eye = self.eye();
            let hz = self.depth_half_extent() + self.target.dot(self.dir).abs();
            let depth = (-eye).dot(self.dir);
            let near = (0.9 * (depth - hz)).max(1e-3 * r);
            let far = 1.1 * (depth + hz);
            let view = look_at_mat4(eye, self.target, u);
            perspective(fov_y(self.aspect), self.aspect, near, far) * view
        } else {
            let view = look_at_mat4(self.eye(), Vec3::ZERO, u);
            let (cx, cy) = (self.target.dot(s), self.target.dot(u));
            let (hw, hh) = (self.half_height * self.aspect, self.half_height);
            let proj = orthographic(cx - hw, cx + hw, cy - hh, cy + hh, 1.5 * r, 4.5 * r);
            proj * view
        }
    }

    /// Local (physical) → clip matrix: the display matrix after the z-scale.
    pub fn view_proj(&self) -> Mat4 {
        self.display_view_proj() * Mat4::from_scale(Vec3::new(1.0, 1.0, self.z_scale))
    }

    /// Turns the camera about the display z axis by `yaw` and about its
    /// right vector by `pitch` (radians), around the target.
    pub fn orbit(&mut self, yaw: f32, pitch: f32) {
        let q = glam::Quat::from_axis_angle(Vec3::Z, yaw)
            * glam::Quat::from_axis_angle(self.right(), pitch);
        self.dir = (q * self.dir).normalize();
        self.up = (q * self.up).normalize();
        // Re-orthogonalise.
        self.up = self.right().cross(self.dir).normalize();
    }

    /// Moves the target by fractions of the window (x right, y up).
    pub fn pan(&mut self, fx: f32, fy: f32) {
        let s = self.right();
        let u = s.cross(self.dir);
        let (hw, hh) = if self.perspective {
            let h = self.dist * (0.5 * fov_y(self.aspect)).tan();
            (h * self.aspect, h)
        } else {
            (self.half_height * self.aspect, self.half_height)
        };
        self.target -= s * (2.0 * fx * hw) + u * (2.0 * fy * hh);
    }

    /// Zooms in by `factor` (> 1 brings the grid closer).
    pub fn zoom(&mut self, factor: f32) {
        let f = factor.clamp(1e-3, 1e3);
        if self.perspective {
            self.dist = (self.dist / f).max(1e-3 * self.radius());
        } else {
            self.half_height = (self.half_height / f).max(1e-6 * self.radius());
        }
    }

    /// Looks along `dir` with `up` (standard views), keeping the zoom.
    pub fn look_along(&mut self, dir: Vec3, up: Vec3) {
        self.dir = dir.normalize();
        self.up = self.dir.cross(up).normalize().cross(self.dir).normalize();
    }
}

/// Corner `i` (bits x, y, z) of the unit box centred on the origin.
fn corner(i: usize) -> Vec3 {
    let sign = |b: usize| if i >> b & 1 == 1 { 0.5 } else { -0.5 };
    Vec3::new(sign(0), sign(1), sign(2))
}

/// The default vertical exaggeration for a bounding box: 1 when the grid's
/// height is at least a quarter of its larger horizontal side, else the
/// largest of 1, 2, 5 × 10ⁿ that brings the height to at most that quarter
/// (reservoirs, kilometres wide and metres thick, get 10–50).
pub fn default_z_scale(lo: [f64; 3], hi: [f64; 3]) -> f64 {
    let h = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let z = hi[2] - lo[2];
    if !(z > 0.0 && h.is_finite()) || 4.0 * z >= h {
        return 1.0;
    }
    let want = h / (4.0 * z);
    let mut best = 1.0;
    for e in 0..6 {
        for m in [1.0, 2.0, 5.0] {
            let v = m * 10f64.powi(e);
            if v <= want {
                best = v;
            }
        }
    }
    best
}

/// The slicing axis for a display-space view direction: `argmax |d·e_i|`.
pub fn slicing_axis(d: Vec3) -> usize {
    (0..3)
        .max_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs()))
        .unwrap_or(2)
}

/// `render`'s camera for `o` on `grid` with exaggeration `z_scale`.
pub fn fit_camera(
    grid: &Grid,
    o: &RenderOptions,
    z_scale: f64,
) -> Result<OrbitCamera, RenderError> {
    let d = Vec3::from_array(o.view_dir.map(|c| c as f32));
    if !d.is_finite() || d.length() <= 0.0 {
        return Err(RenderError::Options(
            "the view direction must be a non-zero vector".into(),
        ));
    }
    let d = d.normalize();
    let up = match o.up {
        Some(u) => Vec3::from_array(u.map(|c| c as f32)),
        None if d.z.abs() > 0.99 => Vec3::Y,
        None => Vec3::Z,
    };
    if up.cross(d).length() < 1e-6 {
        return Err(RenderError::Options(
            "the up vector must not be parallel to the view direction".into(),
        ));
    }
    let (lo, hi) = grid.bounds();
    Ok(OrbitCamera::fit(&Framing {
        points: &grid.points,
        origin: grid.origin(),
        ext: Vec3::from_array([0, 1, 2].map(|a| (hi[a] - lo[a]) as f32)),
        dir: d,
        up,
        aspect: o.size.0 as f32 / o.size.1 as f32,
        perspective: o.perspective,
        z_scale: z_scale as f32,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_z_scale_makes_flat_grids_readable() {
        assert_eq!(default_z_scale([0.0; 3], [1.0; 3]), 1.0);
        // 10 km × 5 km × 100 m: 10000 / 400 = 25 → 20.
        assert_eq!(default_z_scale([0.0; 3], [10_000.0, 5_000.0, 100.0]), 20.0);
        assert_eq!(default_z_scale([0.0; 3], [1.0, 1.0, 0.0]), 1.0);
    }

    #[test]
    fn orbit_keeps_an_orthonormal_frame_and_a_full_turn_returns() {
        let f = Framing {
            points: &[],
            origin: [0.0; 3],
            ext: Vec3::new(2.0, 1.0, 0.5),
            dir: Vec3::new(-1.0, -0.6, -0.8).normalize(),
            up: Vec3::Z,
            aspect: 4.0 / 3.0,
            perspective: false,
            z_scale: 3.0,
        };
        let c0 = OrbitCamera::fit(&f);
        let mut c = c0;
        for _ in 0..36 {
            c.orbit(std::f32::consts::TAU / 36.0, 0.0);
            assert!(c.dir.dot(c.up).abs() < 1e-5 && (c.up.length() - 1.0).abs() < 1e-5);
        }
        assert!((c.dir - c0.dir).length() < 1e-4, "{:?} {:?}", c.dir, c0.dir);
        // A box corner projects inside the window at every zoom ≤ 1.
        let m = c0.view_proj();
        for i in 0..8 {
            let p = m * (Vec3::new(2.0, 1.0, 0.5) * corner(i)).extend(1.0);
            assert!(p.x.abs() <= p.w * 1.0001 && p.y.abs() <= p.w * 1.0001);
        }
    }
}
