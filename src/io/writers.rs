//! Writers: PLY, VTP polydata, and VTK XML grids.
