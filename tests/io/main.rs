//! Reading and writing: VTK legacy and XML, GRDECL, EGRID, memory-mapped
//! inputs, the mesh and grid writers, and other tools reading our files.
//! One test binary; each module is one concern.

#[path = "../support/mod.rs"]
mod support;

mod egrid;
mod formats;
mod fuzz_vtk_legacy;
mod grdecl;
mod mapped;
mod vtk_read;
mod writers;
