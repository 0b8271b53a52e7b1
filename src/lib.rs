//! stratasweep: incremental slicing, contouring and volume rendering of
//! geological grids (Caumon et al. 2005).
#![warn(missing_docs)]

pub mod generate;
pub mod grid;
pub mod io;
pub mod mesh;
pub mod pipeline;
pub mod properties;
pub mod metacell;
pub mod bruteforce;
pub mod cgraph;
pub mod extract;
pub mod field;
pub mod scgraph;
pub mod structure;
pub mod sweep;
