//! The renderer: slice-based volume rendering and isosurfaces of a grid,
//! drawn from the compute engine's triangles.
//!
//! From the bottom: [`error`], [`options`] and [`transfer`] (what a render
//! asks for), [`shown`] and [`checks`] (what it shows, what it refuses),
//! [`image`] (the read-back pixels and PNG), [`camera`] (framing, no
//! wgpu); [`preintegrated`] (the slab passes and the outer surface, over
//! the transfer functions only); the slices: [`slice_cache`] (what a set
//! of slices is, its typed cache key), [`emit_slices`] and [`host_slices`]
//! (building them), [`iso_cache`] (the viewer's isosurfaces per
//! isovalue); at the top [`frame_setup`] and [`renderer`] (the
//! [`Renderer`], its pipelines, cache and passes). Nothing here imports
//! the viewer (`gpu::view`).

pub mod camera;
pub mod checks;
pub mod emit_slices;
pub mod error;
pub mod frame_setup;
pub mod host_slices;
pub mod image;
pub mod iso_cache;
pub mod legend;
pub mod options;
pub mod preintegrated;
pub mod renderer;
pub mod shown;
pub mod slice_cache;
pub mod transfer;

pub use error::RenderError;
pub use image::Image;
pub use options::{CellFinding, Mode, RenderOptions};
pub use renderer::Renderer;
pub use transfer::{Transfer, TransferError, TransferPoint, TransferSource};
