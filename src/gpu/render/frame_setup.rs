//! What one frame draws ([`FrameSetup`]: camera, slicing axis, unit
//! distance, mode, level of detail) turned into the render pass's
//! parameters, and the bindings that carry them with the transfer LUT and
//! the pre-integrated table ([`DrawBindings`], bound once and rewritten per
//! frame).

use crate::gpu::shared::RenderParams;

use super::camera::OrbitCamera;
use super::options::Mode;
use super::preintegrated::pass::SUB_SLABS;
use super::preintegrated::table::preintegrated_table;
use super::slice_cache::SliceSet;
use super::transfer::Transfer;

/// What one frame draws: camera, slicing axis, unit distance and mode.
#[derive(Clone, Copy, Debug)]
pub struct FrameSetup {
    /// The camera (display space, with its z-scale).
    pub camera: OrbitCamera,
    /// Slicing axis of the drawn slices.
    pub axis: usize,
    /// Unit distance of the opacities (display space).
    pub unit: f64,
    /// Mode.
    pub mode: Mode,
    /// Level of detail: draw every `lod`-th slice, opacity corrected for
    /// the `lod` times wider spacing (1: every slice).
    pub lod: u32,
    /// Volume mode with pre-integrated slabs (the slices must carry the
    /// attribute's gradient).
    pub preintegrated: bool,
}

impl FrameSetup {
    /// The shader parameters for slices `set` and a transfer LUT over `[vlo, vhi]`.
    pub fn params(&self, set: &SliceSet, vlo: f64, vhi: f64) -> RenderParams {
        let cam = &self.camera;
        let d = cam.dir;
        let eye = cam.eye();
        let mut axis_v = [0f32; 4];
        axis_v[self.axis] = 1.0;
        let zs = if self.axis == 2 {
            cam.z_scale as f64
        } else {
            1.0
        };
        let slab = set.spacing * zs * self.lod.max(1) as f64;
        let mode = match self.mode {
            Mode::Volume => 0,
            Mode::Slices => 1,
            Mode::Iso => 2,
        };
        RenderParams {
            view_proj: cam.view_proj().to_cols_array_2d(),
            eye: [eye.x, eye.y, eye.z, 1.0],
            view_dir: [d.x, d.y, d.z, 0.0],
            axis: axis_v,
            value_lo: vlo as f32,
            value_hi: vhi as f32,
            spacing_over_unit: (slab / self.unit) as f32,
            perspective: cam.perspective as u32,
            mode,
            z_scale: cam.z_scale,
            slab: if self.uses_pre(set) { slab as f32 } else { 0.0 },
            field_mode: match &set.field {
                Some(f) if self.uses_pre(set) => f.kind.mode(),
                _ => 0,
            },
        }
    }
}

impl FrameSetup {
    /// Whether this frame draws `set` pre-integrated (volume mode; the
    /// slices must carry the attribute's gradient, else plain).
    pub fn uses_pre(&self, set: &SliceSet) -> bool {
        self.preintegrated
            && self.mode == Mode::Volume
            && set.chunks.first().is_some_and(|e| e.has_normals())
    }
}

/// The uniform parameters, transfer LUT and pre-integrated table of the
/// render pass, bound once and rewritten per frame.
pub struct DrawBindings {
    pub(super) params: wgpu::Buffer,
    pub(super) lut: wgpu::Buffer,
    pub(super) pre: wgpu::Buffer,
    pub(super) group: wgpu::BindGroup,
    /// The (slab ratio bits, LUT) the table was last built for.
    pub(super) pre_for: std::sync::Mutex<Option<(u32, Vec<[f32; 4]>)>>,
}

impl DrawBindings {
    /// Writes this frame's parameters and the transfer function's LUT,
    /// and the pre-integrated table when the frame uses it and its slab
    /// ratio or transfer changed. `transfer` is the one the LUT was made
    /// from, restricted to the LUT's range ([`Transfer::over`]).
    pub fn write(
        &self,
        queue: &wgpu::Queue,
        params: &RenderParams,
        transfer: &Transfer,
        lut: &[[f32; 4]],
    ) {
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(params));
        queue.write_buffer(&self.lut, 0, bytemuck::cast_slice(lut));
        if params.slab > 0.0 {
            // A sub-slab along the view direction: 1/cos thicker than on
            // the axis (exact for orthographic views; `fs_pre` corrects
            // the opacity of perspective rays relative to this one).
            let r = params.spacing_over_unit / view_cos(params) / SUB_SLABS as f32;
            let key = (r.to_bits(), lut.to_vec());
            let mut memo = self.pre_for.lock().unwrap_or_else(|p| p.into_inner());
            if memo.as_ref() != Some(&key) {
                let t = preintegrated_table(transfer, r as f64);
                queue.write_buffer(&self.pre, 0, bytemuck::cast_slice(&t));
                *memo = Some(key);
            }
        }
    }
}

/// |cos| of the angle between the view direction and the slicing axis
/// (at least 1e-3, as `view_cos` in `wgsl/shared/pre.wgsl`).
fn view_cos(p: &RenderParams) -> f32 {
    let d: f32 = (0..3).map(|i| p.view_dir[i] * p.axis[i]).sum();
    d.abs().max(1e-3)
}
