//! `render`: one offscreen image of a grid, the top of the render layers.
//! It slices (or reuses the cached slices of) the axis the view needs,
//! fits `render`'s camera and draws through [`FrameSetup`]. Kept apart from
//! [`super::render`] so that the imports of `render` -> `draw` -> `scene`
//! run one way (render.rs holds the shared types, draw.rs the pass, scene.rs
//! the viewer's state; this module uses all three).

use glam::Vec3;

use crate::grid::Grid;
use crate::pipeline::PipelineError;
use crate::structures::Structure;

use super::draw::FrameSetup;
use super::host_slices::build_slices;
use super::render::{
    GridStamp, Image, Mode, RenderError, RenderOptions, Renderer, check_transfer, slice_key,
    slicing_axis, transfer_for, unit_distance,
};
use super::scene::fit_camera;
use super::shown::check_shown_property;

impl Renderer<'_> {
    /// Renders `grid` (with its built structure `s`).
    pub fn render(
        &mut self,
        grid: &Grid,
        s: &Structure,
        o: &RenderOptions,
    ) -> Result<Image, RenderError> {
        self.render_exaggerated(grid, s, o, 1.0)
    }

    /// Renders `grid` with its z multiplied by `z_scale` for display
    /// (vertical exaggeration; opacities and the unit distance are taken
    /// in that display space).
    pub fn render_exaggerated(
        &mut self,
        grid: &Grid,
        s: &Structure,
        o: &RenderOptions,
        z_scale: f64,
    ) -> Result<Image, RenderError> {
        let d = Vec3::from_array(o.view_dir.map(|c| c as f32));
        if !d.is_finite() || d.length() <= 0.0 {
            return Err(RenderError::Options(
                "the view direction must be a non-zero vector".into(),
            ));
        }
        if !(z_scale.is_finite() && z_scale > 0.0) {
            return Err(RenderError::Options(format!(
                "the z-scale {z_scale} must be positive"
            )));
        }
        let d = d.normalize();
        let (w, h) = o.size;
        if w == 0
            || h == 0
            || w > self.ctx.limits.max_texture_dimension_2d
            || h > self.ctx.limits.max_texture_dimension_2d
        {
            return Err(RenderError::Options(format!(
                "image size {w}x{h}: each side must be 1..={}",
                self.ctx.limits.max_texture_dimension_2d
            )));
        }
        let stamp = GridStamp::of(grid, s);
        if self.stamp != Some(stamp) {
            // Another grid or structure: its slices are not these.
            self.clear_cache();
            self.stamp = Some(stamp);
        }
        check_shown_property(grid, o)?;
        check_transfer(grid, o)?;
        let axis = slicing_axis(d);
        let mut k = slice_key(grid, o, axis)?;
        // The sweep stops between levels when the render is cancelled.
        k.cancel = self.cancel.clone();
        if self.preintegrated && o.mode == Mode::Volume {
            k = k.with_attr_gradient();
        }
        let stop = |c: &crate::cancel::Cancel| c.check().map_err(PipelineError::from);
        if !self.cache.contains_key(&k.key) {
            stop(&self.cancel)?;
            let set = build_slices(self.ctx, grid, s, &k)?;
            self.insert(&k.key, set);
        }
        let c = &self.cache[&k.key];
        let transfer = transfer_for(o, c.range)?;
        let unit = unit_distance(grid, o, z_scale)?;
        let cam = fit_camera(grid, o, z_scale)?;
        let frame = FrameSetup {
            camera: cam,
            axis,
            unit,
            mode: o.mode,
            lod: 1,
            preintegrated: self.preintegrated,
        };
        stop(&self.cancel)?;
        self.draw_image(c, &transfer, &frame, o.size, o.background)
    }
}
