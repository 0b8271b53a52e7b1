//! Pre-integrated volume rendering (opt-in): slabs between consecutive
//! slices coloured from a table over (front, back) value.
//!
//! [`table`] integrates the transfer function into that table (no wgpu);
//! [`pass`] draws the slices far to near, one pass per slice, each slab
//! ending at the far slice read from a ping-ponged target; [`boundary`]
//! gives the grid's outer surface (no wgpu) where rays enter and leave it;
//! [`ijk_field`] holds the shown property in index space for IJK grids.
//! This sub-room imports only the device, the compute engine and the
//! renderer's transfer functions.

pub mod boundary;
pub mod ijk_field;
pub mod pass;
pub mod table;
