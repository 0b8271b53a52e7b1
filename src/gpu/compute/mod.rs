//! The compute engine: the cut cells of the CPU sweep (or of GPU span-space
//! binning) turned into triangles and indirect draw arguments on the GPU,
//! and its CPU twin.
//!
//! [`tables`] builds the host images of the buffers that both the GPU
//! ([`emit`]) and the twin ([`twin`]) read; [`grid_parts`] splits grids
//! over one storage binding; [`frame`] reads results back;
//! [`slice`](mod@slice) slices a grid with GPU emission and per-level
//! statistics. This room imports the device ([`crate::gpu::context`],
//! [`crate::gpu::shaders`], [`crate::gpu::shared`]) and the core, never
//! the renderer.

pub mod emit;
pub mod frame;
pub mod gradient;
pub mod grid_parts;
pub mod slice;
pub mod tables;
pub mod twin;
