"""stratasweep: incremental slicing, contouring and volume rendering of
geological grids (Caumon et al. 2005), from Python.

    import stratasweep
    grid = stratasweep.load("NORNE.EGRID")
    sl = grid.slice(axis="z", count=100)
    sl.to_pyvista().plot()

Heavy work (loading, building, sweeping, rendering, writing) runs without
the GIL. Errors: ``OSError`` for files, ``ValueError`` for bad arguments
and grids, ``RuntimeError`` for GPU faults.
"""

from __future__ import annotations

import os as _os
import sys as _sys

import numpy as _np

# As the CLI does (src/cli/mod.rs): without a desktop session (no
# XDG_RUNTIME_DIR: servers, containers, CI) Mesa's Vulkan device-selection
# layer connects to Wayland only to reorder the adapter list, which the
# renderer sorts itself, and prints "XDG_RUNTIME_DIR is invalid or not set"
# twice per render. Turned off unless the user configured it; set before
# the native module (and any Vulkan instance) exists.
if _sys.platform.startswith("linux") and not any(
    k in _os.environ for k in ("XDG_RUNTIME_DIR", "NODEVICE_SELECT", "MESA_VK_DEVICE_SELECT")
):
    _os.environ["NODEVICE_SELECT"] = "1"

from . import _native
from ._native import Grid, Slices, adapters, load
from . import generate

__all__ = [
    "Grid",
    "Slices",
    "adapters",
    "from_arrays",
    "from_pyvista",
    "generate",
    "load",
]
__version__ = _native.__version__

# VTK cell types that carry no volume (0D-2D); kept, counted and skipped.
_VTK_POLYHEDRON = 42


def _float_dict(d, n, kind):
    out = {}
    for name, arr in (d or {}).items():
        a = _np.ascontiguousarray(arr, dtype=_np.float64)
        if a.ndim == 0 or a.shape[0] != n:
            raise ValueError(
                f"{kind} property '{name}' has shape {a.shape}, expected ({n},) or ({n}, k)"
            )
        out[str(name)] = a if a.ndim <= 2 else a.reshape(n, -1)
    return out


def from_arrays(points, cells, celltypes, point_data=None, cell_data=None, merge_points=False):
    """An unstructured grid from arrays in PyVista's ``UnstructuredGrid`` layout.

    ``points``: ``(n, 3)`` coordinates. ``cells``: the padded cell array
    (``[k, id0, ..., k, ...]``; a polyhedron's entry is its face stream
    ``nf, n0, ids..., n1, ids...``). ``celltypes``: one VTK type per cell.
    ``point_data`` / ``cell_data``: dicts of arrays (a ``vtkGhostType`` cell
    array hides cells). ``merge_points=True`` merges exactly coincident
    points (cells that each own their corners) and turns hexahedra whose
    corners then repeat into polyhedra (or hides them when flat).
    """
    pts = _np.ascontiguousarray(points, dtype=_np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), found {pts.shape}")
    c = _np.ascontiguousarray(cells, dtype=_np.int64).ravel()
    t = _np.ascontiguousarray(celltypes, dtype=_np.int64).ravel()
    return _native.from_arrays(
        pts,
        c,
        t,
        _float_dict(point_data, pts.shape[0], "point"),
        _float_dict(cell_data, t.shape[0], "cell"),
        bool(merge_points),
    )


def _data(arrays, n, kind):
    out = {}
    for name in arrays.keys():
        a = _np.asarray(arrays[name])
        if a.dtype.kind in "fiub" and a.shape[:1] == (n,):
            out[name] = a
    return _float_dict(out, n, kind)


def from_pyvista(mesh):
    """A grid from a PyVista ``UnstructuredGrid``, ``StructuredGrid`` or
    ``ExplicitStructuredGrid`` (point and cell arrays come along; an
    explicit structured grid's coincident corners are merged, its hidden
    cells stay hidden, and its IJK layout is kept: ``structure="auto"``
    then sweeps it on the corner-point graph, as GRDECL input)."""
    try:
        import pyvista as pv
    except ImportError as e:  # pragma: no cover - depends on the install
        raise ImportError("from_pyvista needs PyVista: pip install pyvista") from e
    if isinstance(mesh, pv.StructuredGrid):
        dims = tuple(int(d) for d in mesh.dimensions)
        return _native.from_structured(
            dims,
            _np.ascontiguousarray(mesh.points, dtype=_np.float64),
            _data(mesh.point_data, mesh.n_points, "point"),
            _data(mesh.cell_data, mesh.n_cells, "cell"),
        )
    if isinstance(mesh, pv.ExplicitStructuredGrid):
        # Cells in IJK order (I fastest): the grid keeps its IJK layout, so
        # structure="auto" sweeps it on the corner-point graph.
        dims = tuple(int(d) - 1 for d in mesh.dimensions)
        ug = mesh.cast_to_unstructured_grid()
        return _native.from_explicit_structured(
            dims,
            _np.ascontiguousarray(ug.points, dtype=_np.float64),
            _np.ascontiguousarray(ug.cells, dtype=_np.int64).ravel(),
            _np.ascontiguousarray(ug.celltypes, dtype=_np.int64).ravel(),
            _data(ug.point_data, ug.n_points, "point"),
            _data(ug.cell_data, ug.n_cells, "cell"),
        )
    if not isinstance(mesh, pv.UnstructuredGrid):
        raise ValueError(
            f"from_pyvista takes an UnstructuredGrid, StructuredGrid or "
            f"ExplicitStructuredGrid, not {type(mesh).__name__}"
        )
    types = _np.asarray(mesh.celltypes, dtype=_np.int64)
    if (types == _VTK_POLYHEDRON).any():
        # VTK >= 9.4 keeps polyhedron faces apart from the cell array: go
        # through VTK's own writer and the .vtu reader.
        import os
        import tempfile

        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "mesh.vtu")
            mesh.save(path)
            return load(path)
    cells = _np.asarray(mesh.cells, dtype=_np.int64)
    return from_arrays(
        mesh.points,
        cells,
        types,
        _data(mesh.point_data, mesh.n_points, "point"),
        _data(mesh.cell_data, mesh.n_cells, "cell"),
    )
