#!/usr/bin/env python3
"""The VTK peer's copy of a corner-point grid: its active cells as unwelded
hexahedra (8 points per cell, from xtgeo's corner geometry), in a .vtu that
`../shared/peer/vtk_slices.py` slices. This is the reference issue 19's
ratios against VTK are measured on: the same active cells as the engine's,
read by an independent reader.

Setup (once):  python3 -m venv .venv-xtgeo && .venv-xtgeo/bin/pip install xtgeo vtk==9.7.2 numpy
Usage:         .venv-xtgeo/bin/python benches/cornerpoint_vtu.py GRID.grdecl OUT.vtu
"""
import sys

import numpy as np
import vtk
import xtgeo
from vtk.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray

# VTK's hexahedron corner order, as (di, dj, dk) offsets on the corner lattice.
HEX_ORDER = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    src, out = sys.argv[1], sys.argv[2]
    try:
        grid = xtgeo.grid_from_file(src, fformat="grdecl")
    except Exception as e:  # xtgeo raises several types for a bad file
        sys.exit(f"cornerpoint_vtu: cannot read {src}: {e}")
    dims, corners, inactive = grid.get_vtk_geometries()
    nx, ny, nz = (int(v) - 1 for v in dims)
    corners = np.asarray(corners, dtype=np.float64)
    if corners.shape != (8 * nx * ny * nz, 3):
        sys.exit(f"cornerpoint_vtu: unexpected corner array {corners.shape} for {nx}x{ny}x{nz} cells")
    keep = np.ones(nx * ny * nz, bool)
    keep[np.asarray(inactive, dtype=np.int64)] = False
    cell = np.nonzero(keep)[0]  # i fastest, as xtgeo and VTK order cells
    i, j, k = cell % nx, (cell // nx) % ny, cell // (nx * ny)
    # Corner (2i+a, 2j+b, 2k+c) of the (2nx, 2ny, 2nz) corner lattice, i fastest.
    at = np.stack([(2 * i + a) + 2 * nx * ((2 * j + b) + 2 * ny * (2 * k + c)) for a, b, c in HEX_ORDER], axis=1)
    n = len(cell)
    points = vtk.vtkPoints()
    points.SetData(numpy_to_vtk(np.ascontiguousarray(corners[at.reshape(-1)]), deep=1))
    cells = vtk.vtkCellArray()
    cells.SetData(
        numpy_to_vtkIdTypeArray(np.arange(0, 8 * n + 1, 8, dtype=np.int64), deep=1),
        numpy_to_vtkIdTypeArray(np.arange(8 * n, dtype=np.int64), deep=1),
    )
    ug = vtk.vtkUnstructuredGrid()
    ug.SetPoints(points)
    ug.SetCells(vtk.VTK_HEXAHEDRON, cells)
    w = vtk.vtkXMLUnstructuredGridWriter()
    w.SetFileName(out)
    w.SetInputData(ug)
    if not w.Write():
        sys.exit(f"cornerpoint_vtu: cannot write {out}")
    print(f"{out}: {n} active cells of {nx}x{ny}x{nz} as unwelded hexahedra ({8 * n} points)")


if __name__ == "__main__":
    main()
