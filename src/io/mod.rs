//! Readers and writers. The only module (with the binary) that touches files.

pub mod atomic;
pub mod checks;
pub mod egrid;
pub mod egrid_write;
pub mod grdecl;
pub mod guard;
pub mod load;
pub mod mapped;
pub(crate) mod number;
pub mod vtk_read;
pub mod writers;

pub use load::{Format, LoadError, Loaded, load};
