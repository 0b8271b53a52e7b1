"""One model, every route into Python: bulk volumes agree across GRDECL,
EGRID and VTU; pinched hexahedra handed over with repeated points keep their
volume and are typed as the corner-point path types them; an EGRID without
its INIT warns, naming the files looked for."""

import warnings

import numpy as np
import pytest

import stratasweep


def _generate(cli, tmp_path, ext):
    out = tmp_path / f"m.{ext}"
    cli("generate", "faulted", "--dims", "10,8,5", "--faults", "3", "--seed", "1", "-o", out)
    return out


def test_bulk_volume_agrees_across_formats(cli, tmp_path):
    grdecl = _generate(cli, tmp_path, "grdecl")
    vtu = _generate(cli, tmp_path, "vtu")
    egrid = _generate(cli, tmp_path, "egrid")
    vg = stratasweep.load(grdecl).info()
    vv = stratasweep.load(vtu).info()
    ve = stratasweep.load(egrid).info()
    assert vv["bulk_volume"] == pytest.approx(vg["bulk_volume"], rel=1e-9)
    # EGRID stores coordinates as f32.
    assert ve["bulk_volume"] == pytest.approx(vg["bulk_volume"], rel=1e-6)
    assert vv["cells"] == vg["cells"] == ve["cells"]
    assert vv["live_cells"] == vg["live_cells"]


def _pinched_arrays():
    # A cube and, beside it, a hexahedron whose top edge 6-7 lies on 5-4:
    # each cell owns its eight points (as a cast ExplicitStructuredGrid).
    cube = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]]
    wedge = [[2, 0, 0], [3, 0, 0], [3, 1, 0], [2, 1, 0], [2, 0, 1], [3, 0, 1], [3, 0, 1], [2, 0, 1]]
    points = np.array(cube + wedge, dtype=np.float64)
    cells = np.array([8, *range(8), 8, *range(8, 16)], dtype=np.int64)
    types = np.array([12, 12], dtype=np.int64)
    return points, cells, types


def test_pinched_hexahedra_from_arrays_keep_their_volume():
    points, cells, types = _pinched_arrays()
    for merge in (False, True):
        g = stratasweep.from_arrays(points, cells, types, merge_points=merge)
        info = g.info()
        # Cube 1 + wedge 1/2; the pinched cell is a live wedge.
        assert info["bulk_volume"] == pytest.approx(1.5, rel=1e-12)
        assert info["cell_types"] == {"hexahedron": 1, "wedge": 1}
        assert info["live_cells"] == 2


def test_pinched_hexahedra_from_pyvista():
    pv = pytest.importorskip("pyvista")
    points, cells, types = _pinched_arrays()
    ug = pv.UnstructuredGrid(cells, types.astype(np.uint8), points)
    info = stratasweep.from_pyvista(ug).info()
    assert info["bulk_volume"] == pytest.approx(1.5, rel=1e-12)
    assert info["live_cells"] == 2


def test_missing_init_warns(cli, tmp_path):
    egrid = _generate(cli, tmp_path, "egrid")
    for init in tmp_path.glob("m.[iI][nN][iI][tT]"):
        init.unlink()
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        g = stratasweep.load(egrid)
    msgs = [str(x.message) for x in w]
    assert any("no INIT beside" in m and "m.INIT, m.init" in m for m in msgs), msgs
    assert g.info()["cell_properties"] == []
