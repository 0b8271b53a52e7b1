//! The core: grids, structures, sweeps and the slicing pipeline against
//! references (brute force, analytic areas and volumes, VTK's cutter).
//! One test binary; each module is one concern.

#[path = "../support/mod.rs"]
mod support;

mod ciel;
mod ciel_build;
mod convex_split;
mod cornerpoint;
mod cornerpoint_data;
mod cpgraph;
mod explicit_structured;
mod generate;
mod limits;
mod metacell_tables;
mod model;
mod peer;
mod sweep_reference;
mod twisted_cells;
