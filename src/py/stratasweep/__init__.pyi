"""Type stubs for stratasweep (the native part is stratasweep._native)."""

from os import PathLike
from typing import Any, Literal, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import generate as generate

__version__: str

_Path = Union[str, PathLike[str]]
_Structure = Literal["auto", "cgraph", "scgraph", "ciel", "cpgraph", "bruteforce"]

class Slices:
    """The polygons of one ``Grid.slice`` call, welded by grid edge."""

    @property
    def points(self) -> npt.NDArray[np.float64]:
        """``(n, 3)`` vertex positions, world coordinates."""
    @property
    def offsets(self) -> npt.NDArray[np.int64]:
        """Polygon offsets into ``connectivity`` (polygons + 1 entries, from 0)."""
    @property
    def connectivity(self) -> npt.NDArray[np.int64]:
        """Vertex ids of every polygon, concatenated."""
    @property
    def values(self) -> npt.NDArray[np.float32]:
        """The interpolated attribute per vertex."""
    @property
    def level(self) -> npt.NDArray[np.uint32]:
        """Level index per polygon."""
    @property
    def cell(self) -> npt.NDArray[np.uint32]:
        """Source cell (input numbering) per polygon."""
    @property
    def level_values(self) -> npt.NDArray[np.float64]:
        """World value of every level."""
    @property
    def attribute(self) -> str:
        """Name of the attribute in ``values``."""
    @property
    def n_polygons(self) -> int: ...
    @property
    def stats(self) -> dict[str, Any]:
        """The same dict as ``stratasweep slice --stats``."""
    def save(self, path: _Path) -> None:
        """Writes ``.ply`` (binary) or ``.vtp`` (VTK XML PolyData)."""
    def to_pyvista(self) -> Any:
        """A ``pyvista.PolyData`` with the attribute (point data) and
        ``level``, ``level_value``, ``cell`` (cell data)."""
    def __len__(self) -> int: ...

class Grid:
    """A grid: ``load``, ``generate.*``, ``from_arrays`` or ``from_pyvista``."""

    def info(self, structure: _Structure = "auto") -> dict[str, Any]:
        """The same content as ``stratasweep info --json``."""
    @property
    def point_properties(self) -> list[str]: ...
    @property
    def cell_properties(self) -> list[str]: ...
    @property
    def bounds(self) -> Tuple[float, float, float, float, float, float]:
        """``(xmin, xmax, ymin, ymax, zmin, zmax)``."""
    @property
    def n_cells(self) -> int: ...
    @property
    def n_points(self) -> int: ...
    @property
    def structure(self) -> Literal["scgraph", "cgraph", "ciel", "cpgraph"]:
        """The structure ``structure="auto"`` builds."""
    def slice(
        self,
        axis: Optional[Literal["x", "y", "z", "-x", "-y", "-z"]] = None,
        normal: Optional[Sequence[float]] = None,
        property: Optional[str] = None,
        count: Optional[int] = None,
        values: Optional[Sequence[float]] = None,
        attribute: Optional[str] = None,
        at: Literal["vertices", "cells"] = "vertices",
        threads: Optional[int] = None,
        structure: _Structure = "auto",
        mesh: bool = True,
        device: Literal["cpu", "gpu", "auto"] = "cpu",
        adapter: Optional[str] = None,
    ) -> Slices:
        """Slices (axis, normal) or contours (property) the grid: exactly
        one of axis, normal or property, and one of count (levels at
        ``lo + (k + 0.5)(hi - lo)/count``) or values (increasing world
        values). ``mesh=False`` gathers statistics only. ``device`` as the
        CLI's ``slice --device``: ``cpu`` the CPU sweep emits the polygons;
        ``gpu`` the CPU sweep finds the cut cells and the GPU (any adapter,
        ``adapter`` a name substring) emits them, statistics only (needs
        ``mesh=False``); ``auto`` the GPU when an adapter exists and the
        request allows it, else the CPU. The CLI's limits apply (at most
        100,000 levels; 1 to 8 threads per core, at least 64): beyond them
        ``ValueError`` names the argument and the limit. Levels outside the
        field's range cut nothing and raise a ``UserWarning`` (world z is
        minus depth: depths are negative z levels). Ctrl-C stops the sweep
        at its next level and raises ``KeyboardInterrupt``."""
    @property
    def default_z_scale(self) -> float:
        """The vertical exaggeration ``render`` uses without ``z_scale``
        (the CLI's default: 1 for grids at least a quarter as high as
        wide, else 2, 5, 10, 20, ...)."""
    def render(
        self,
        property: Optional[str] = None,
        slices: int = 200,
        view_dir: Tuple[float, float, float] = (-1.0, -0.6, -0.8),
        up: Optional[Tuple[float, float, float]] = None,
        projection: Literal["ortho", "perspective"] = "ortho",
        transfer: Union[None, str, PathLike[str], Mapping[str, Any]] = None,
        unit_distance: Optional[float] = None,
        background: Union[None, str, Sequence[float]] = None,
        size: Tuple[int, int] = (800, 600),
        mode: Literal["volume", "slices", "iso"] = "volume",
        iso: Optional[Sequence[float]] = None,
        z_scale: Optional[float] = None,
        preintegrated: bool = False,
        cells: Optional[Literal["auto", "sweep", "gpu"]] = None,
        legend: bool = False,
        adapter: Optional[str] = None,
        device: Literal["auto", "gpu", "cpu"] = "auto",
        output: Optional[_Path] = None,
    ) -> npt.NDArray[np.uint8]:
        """Volume-renders (or draws isosurfaces) into ``(H, W, 4)`` RGBA,
        with every option of the CLI's ``render`` (the same defaults,
        checks and errors, options named by keyword; the same image bits):
        ``transfer`` a colormap name (viridis, magma, coolwarm, greys), a
        ``.json`` file or a dict ``{"points": [...]}``; ``background``
        ``(r, g, b, a)``, ``"r,g,b,a"`` or ``"transparent"``; ``z_scale``
        the vertical exaggeration (default ``default_z_scale``);
        ``preintegrated`` pre-integrated slabs (volume mode); ``cells``
        how cut cells are found (default the sweep: the same bits on every
        run); ``legend`` the colour legend in the bottom-right corner;
        ``output`` also writes the PNG. ``device``: ``auto`` any adapter
        (GPUs first), ``gpu`` hardware only, ``cpu`` a software rasteriser
        (Mesa llvmpipe) only. Limits as the CLI's: 1 to 8192 slices,
        isovalues and pixels per image side. Ctrl-C stops the render
        before its slicing or its drawing."""
    def save(self, path: _Path) -> None:
        """Writes ``.vts`` (curvilinear) or ``.vtu`` (unstructured)."""

def load(path: _Path) -> Grid:
    """Any grid file the CLI reads (VTK legacy/XML, GRDECL, .DATA, EGRID)."""

def from_arrays(
    points: npt.ArrayLike,
    cells: npt.ArrayLike,
    celltypes: npt.ArrayLike,
    point_data: Optional[Mapping[str, npt.ArrayLike]] = None,
    cell_data: Optional[Mapping[str, npt.ArrayLike]] = None,
    merge_points: bool = False,
) -> Grid:
    """An unstructured grid in PyVista's ``UnstructuredGrid`` layout."""

def from_pyvista(mesh: Any) -> Grid:
    """From a PyVista UnstructuredGrid, StructuredGrid or ExplicitStructuredGrid
    (an ExplicitStructuredGrid keeps its IJK layout: ``structure="auto"``
    sweeps it on the corner-point graph)."""

def adapters() -> list[dict[str, str]]:
    """GPU adapters: ``name``, ``backend``, ``device_type``."""
