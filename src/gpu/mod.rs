//! The GPU path: the cell graphs and meta-cell tables in
//! storage buffers, WGSL compute passes that turn the CPU sweep's per-level
//! active cells into triangles and indirect draw arguments, a CPU twin of
//! those passes, and slice-based volume rendering.
//!
//! Nothing outside this module imports wgpu. [`shared`] holds every struct
//! shared with WGSL; [`tables`] builds the host images of the buffers that
//! both the GPU ([`emit`]) and the twin ([`twin`]) read.

pub mod boundary;
pub mod camera;
pub mod context;
pub mod draw;
pub mod emit;
pub mod frame;
pub mod gradient;
pub mod grid_parts;
pub mod host_slices;
pub mod ijk_field;
pub mod iso_cache;
pub mod legend;
pub mod offscreen;
pub mod outline;
pub mod pre_pass;
pub mod preintegrate;
pub mod present;
pub mod render;
pub mod scene;
pub mod shaders;
pub mod shared;
pub mod shown;
pub mod slice;
pub mod tables;
pub mod transfer;
pub mod twin;
