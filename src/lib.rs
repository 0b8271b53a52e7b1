//! stratasweep: incremental slicing, contouring and volume rendering of
//! geological grids (Caumon et al. 2005).
#![warn(missing_docs)]
// Numeric kernels index several parallel arrays in one loop and pass many
// small inputs; these style lints would make them harder to read.
#![allow(clippy::needless_range_loop, clippy::type_complexity)]

pub mod bruteforce;
pub mod cancel;
pub mod cellgraph;
pub mod cornerpoint;

pub mod extract;
pub mod field;
pub mod generate;
pub mod gpu;
pub mod grid;
pub mod io;
#[cfg(test)]
mod layers;
pub mod limits;
pub mod mem;
pub mod mesh;
pub mod metacell;
pub mod pipeline;
pub mod policy;
pub mod properties;
#[cfg(feature = "python")]
pub mod py;
pub mod report;
pub mod structures;
pub mod sweep;
pub(crate) mod vec3;
pub mod voronoi;
