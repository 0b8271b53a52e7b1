//! stratasweep: incremental slicing, contouring and volume rendering of
//! geological grids (Caumon et al. 2005).
#![warn(missing_docs)]

pub mod grid;
pub mod io;
pub mod mesh;
