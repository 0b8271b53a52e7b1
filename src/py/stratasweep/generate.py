"""Synthetic grids, as `stratasweep generate` makes them."""

from __future__ import annotations

import numpy as _np

from . import _native

__all__ = ["faulted", "faulted_pyvista", "voronoi", "warped", "zoo"]


def warped(dims=(64, 64, 64), seed=1):
    """A smoothly warped curvilinear grid of ``dims`` cells carrying the
    Marschner-Lobb signal as point property ``f`` (the CLI's ``--demo`` is
    ``warped((64, 64, 64))``)."""
    return _native.generate_warped(tuple(int(d) for d in dims), int(seed))


def zoo(cells, seed=1):
    """A conforming tetrahedron/pyramid/wedge/hexahedron grid of about
    ``cells`` cells with a noisy point property ``f``."""
    return _native.generate_zoo(int(cells), int(seed))


def voronoi(cells, seed=1):
    """A clipped 3D Voronoi grid of ``cells`` random sites in the unit box
    (VTK polyhedra) with a smooth point property ``f``."""
    return _native.generate_voronoi(int(cells), int(seed))


def faulted(dims, faults=3, fault_dip=None, seed=1):
    """A faulted corner-point reservoir (folded layers, faults with throw,
    pinch-outs, inactive cells, cell property ``PORO``) converted as the
    GRDECL reader converts it (faults unsewn, pinched cells as wedges,
    pyramids or tetrahedra, inactive and zero-volume cells left out)."""
    return _native.generate_faulted(
        tuple(int(d) for d in dims), int(faults), fault_dip, int(seed)
    )


def faulted_pyvista(dims, faults=3, fault_dip=None, seed=1):
    """The same faulted model as a ``pyvista.ExplicitStructuredGrid`` (the
    corner-point cells as hexahedra, inactive cells hidden, ``PORO`` and
    ``ACTNUM`` as cell data): what PyVista users build from a GRDECL."""
    import pyvista as pv

    ni, nj, nk = (int(d) for d in dims)
    corners, actnum, cell_data = _native.faulted_corners(
        (ni, nj, nk), int(faults), fault_dip, int(seed)
    )
    grid = pv.ExplicitStructuredGrid((ni + 1, nj + 1, nk + 1), corners)
    for name, values in cell_data.items():
        grid.cell_data[name] = values
    grid.cell_data["ACTNUM"] = actnum
    inactive = _np.flatnonzero(actnum == 0)
    if inactive.size:
        grid = grid.hide_cells(inactive)
    return grid
