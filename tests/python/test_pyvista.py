"""PyVista round trips: to_pyvista() areas equal PyVista's own cell sizes;
from_pyvista on PyVista's example grids slices to the areas of
pyvista's own slice (VTK's cutter)."""

import numpy as np
import pytest

import stratasweep
from conftest import assert_same_stats

pv = pytest.importorskip("pyvista", reason="SKIP: pyvista is not installed (pip install pyvista)")
from pyvista import examples  # noqa: E402


def level_areas(poly, levels):
    """Per level, the area of the polygons of that level (PyVista's sizes)."""
    sizes = poly.compute_cell_sizes(length=False, volume=False)
    area = np.asarray(sizes.cell_data["Area"])
    return np.bincount(np.asarray(poly.cell_data["level"]), weights=area, minlength=levels)


def test_to_pyvista_areas_equal_compute_cell_sizes():
    grid = stratasweep.generate.warped((32, 32, 32))
    s = grid.slice(axis="z", count=25)
    poly = s.to_pyvista()
    assert poly.n_points == len(s.points) and poly.n_cells == s.n_polygons
    np.testing.assert_array_equal(np.asarray(poly.points), s.points)
    np.testing.assert_array_equal(poly.point_data["f"], s.values)
    ours = np.array([x["area"] for x in s.stats["slices"]])
    np.testing.assert_allclose(level_areas(poly, 25), ours, rtol=1e-5)
    assert ours.sum() > 0


def vtk_slice_areas(mesh, normal, values):
    out = []
    for v in values:
        origin = np.zeros(3)
        n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
        origin = n * v
        cut = mesh.slice(normal=n, origin=origin)
        if cut.n_cells == 0:
            out.append(0.0)
            continue
        out.append(float(cut.compute_cell_sizes(length=False, volume=False).cell_data["Area"].sum()))
    return np.array(out)


def warped_structured():
    """A 3D curvilinear PyVista StructuredGrid (PyVista's own structured
    example is a 2D sheet)."""
    i, j, k = np.meshgrid(np.linspace(0, 1, 9), np.linspace(0, 2, 11), np.linspace(0, 1, 7), indexing="ij")
    x = i + 0.1 * np.sin(3 * k)
    y = j + 0.05 * i * k
    z = k + 0.1 * np.cos(2 * i + j)
    g = pv.StructuredGrid(x, y, z)
    g.point_data["h"] = np.asarray(g.points)[:, 2].copy()
    return g


@pytest.mark.parametrize(
    "make",
    [examples.load_hexbeam, warped_structured, examples.load_explicit_structured],
    ids=["UnstructuredGrid hexbeam", "StructuredGrid", "ExplicitStructuredGrid"],
)
def test_from_pyvista_slices_like_pyvista(make):
    mesh = make()
    grid = stratasweep.from_pyvista(mesh)
    assert grid.n_cells == mesh.n_cells
    for normal, axis in [((0, 0, 1), "z"), ((1, 0, 0), "x")]:
        s = grid.slice(axis=axis, count=7)
        ours = np.array([x["area"] for x in s.stats["slices"]])
        ref = vtk_slice_areas(mesh, normal, s.level_values)
        assert ours.sum() > 0
        np.testing.assert_allclose(ours, ref, rtol=1e-5, atol=1e-9)


def ambiguous_at(points, hexes, t):
    """Per hexahedron (VTK order), whether the level z = t crosses one of
    its faces twice on each diagonal (a saddle): VTK's case table and the
    sweep's face decider (the bilinear saddle) may join such crossings
    differently, with very different areas when the level barely cuts the
    face."""
    faces = [(0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    above = points[hexes][:, :, 2] >= t
    out = np.zeros(len(hexes), dtype=bool)
    for f in faces:
        a = above[:, f]
        out |= (a[:, 0] == a[:, 2]) & (a[:, 1] == a[:, 3]) & (a[:, 0] != a[:, 1])
    return out


def polygon_areas(s):
    """Each output polygon's area (fan of cross products)."""
    pts, off, con = s.points, s.offsets, s.connectivity
    areas = np.empty(len(off) - 1)
    for p in range(len(off) - 1):
        q = pts[con[off[p] : off[p + 1]]]
        areas[p] = np.linalg.norm(np.cross(q[1:-1] - q[0], q[2:] - q[0]).sum(axis=0)) / 2
    return areas


def test_faulted_explicit_structured_grid_slices_like_pyvista():
    esg = stratasweep.generate.faulted_pyvista((12, 10, 6), faults=2, seed=3)
    grid = stratasweep.from_pyvista(esg)
    s = grid.slice(axis="z", count=9)
    ours_all = np.array([x["area"] for x in s.stats["slices"]])
    assert ours_all.sum() > 0
    visible = esg.cast_to_unstructured_grid()
    keep = np.ones(visible.n_cells, dtype=bool)
    ghost = visible.cell_data.get("vtkGhostType")
    if ghost is not None:
        keep &= (np.asarray(ghost) & 32) == 0
    # Cells with a face that crosses itself are sliced (a tetrahedral
    # decomposition), as VTK slices them: none is left out.
    assert grid.info()["self_intersecting_cells"]["count"] == 0
    points = np.asarray(visible.points)
    hexes = visible.cells.reshape(-1, 9)[:, 1:]
    areas = polygon_areas(s)
    ours, ref, left_out, cut = [], [], 0, 0
    for k, t in enumerate(s.level_values):
        # Cells with a saddle face at this level leave both sides.
        amb = ambiguous_at(points, hexes, t)
        z = points[hexes][:, :, 2]
        cut += int(((z.min(axis=1) < t) & (t <= z.max(axis=1)) & keep).sum())
        left_out += int((amb & keep).sum())
        mine = (s.level == k) & ~amb[s.cell]
        ours.append(areas[mine].sum())
        ref.append(vtk_slice_areas(visible.extract_cells(np.flatnonzero(keep & ~amb)), (0, 0, 1), [t])[0])
    assert left_out <= 0.05 * cut, (left_out, cut)
    # Corner-point cells have warped (non-planar) faces, and pinched ones
    # become polyhedra: VTK's hexahedron case table and the sweep's convex
    # pieces cut such cells differently (measured: up to 4.2 % per level on
    # this model, 0.0001 % on the last level, which crosses flat cells).
    np.testing.assert_allclose(ours, ref, rtol=0.05)
    ours = ours_all
    # The same model through the GRDECL path (zoo grid: pinched cells as
    # wedges, pyramids, tetrahedra; here polyhedra of the collapsed
    # hexahedra's faces, whose warped faces are cut differently): within
    # 1.5 % per level (measured 1.06 %; the hexahedra alone are cut
    # identically, per cell: tests/explicit_structured.rs).
    zoo = stratasweep.generate.faulted((12, 10, 6), faults=2, seed=3)
    s2 = zoo.slice(values=list(s.level_values), axis="z")
    np.testing.assert_allclose([x["area"] for x in s2.stats["slices"]], ours, rtol=0.015)


def test_explicit_structured_grid_sweeps_on_the_corner_point_graph():
    # from_pyvista keeps the ExplicitStructuredGrid's IJK layout: auto picks
    # the corner-point graph, whose cut cells, polygons and areas per level
    # equal the CGraph's on the same grid (and the brute force's).
    esg = stratasweep.generate.faulted_pyvista((14, 11, 9), faults=3, seed=2)
    grid = stratasweep.from_pyvista(esg)
    assert grid.structure == "cpgraph"
    assert grid.info()["structure"] == "cpgraph"
    for kw in (dict(axis="z", count=23), dict(axis="x", count=9), dict(normal=(0.3, -0.5, 0.8), count=11)):
        cp = grid.slice(**kw)
        assert cp.stats["structure"] == "cpgraph"
        cg = grid.slice(structure="cgraph", **kw)
        assert cg.stats["structure"] == "cgraph"
        assert_same_stats(cp.stats, cg.stats)
        bf = grid.slice(structure="bruteforce", **kw)
        assert_same_stats(bf.stats, cg.stats)
        # The same polygons (as sets: each structure visits cells in its own order).
        assert cp.n_polygons == cg.n_polygons
        np.testing.assert_array_equal(np.sort(cp.cell), np.sort(cg.cell))
    # Hidden (inactive) cells stay out: the corner-point graph's live cells
    # are the CGraph's.
    assert grid.info()["live_cells"] == grid.info(structure="cgraph")["live_cells"]


def test_from_arrays_layout():
    # Two tetrahedra sharing a face, with point and cell data.
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], float)
    cells = np.array([4, 0, 1, 2, 3, 4, 1, 2, 3, 4])
    grid = stratasweep.from_arrays(pts, cells, [10, 10], point_data={"h": pts[:, 2]},
                                   cell_data={"id": [0.0, 1.0]})
    assert grid.n_cells == 2 and grid.point_properties == ["h"] and grid.cell_properties == ["id"]
    s = grid.slice(property="h", values=[0.5])
    ug = pv.UnstructuredGrid(cells, np.array([10, 10], np.uint8), pts)
    ref = ug.slice(normal="z", origin=(0, 0, 0.5)).compute_cell_sizes().cell_data["Area"].sum()
    assert s.stats["slices"][0]["area"] == pytest.approx(ref, rel=1e-6)
