//! The GPU half through the library: compute (emission, grid parts,
//! limits, layouts) and render (images, scenes, iso levels, pre-integration,
//! the boundary, transfer functions). One device per binary
//! (`support::gpu`). One test binary; each module is one concern.

#[path = "../support/mod.rs"]
mod support;

mod boundary;
mod boundary_data;
mod emit;
mod grid_parts;
mod host_slices;
mod iso_levels;
mod layout;
mod limits;
mod preintegrate;
mod preintegrate_ijk;
mod render;
mod scene;
mod transfer;
