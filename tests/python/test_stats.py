"""Slices from Python equal the CLI's --stats level by level (cut cells,
polygons, areas) on the demo grid, Reek and a Voronoi grid."""

import pytest

import stratasweep
from conftest import assert_same_stats


def test_demo_axis_z_equals_cli(cli, tmp_path):
    grid = stratasweep.generate.warped((64, 64, 64))
    s = grid.slice(axis="z", count=100)
    assert_same_stats(s.stats, cli.stats(tmp_path, "--demo", "--axis", "z", "--count", 100))
    # The arrays hold what the statistics count.
    assert len(s.offsets) == s.n_polygons + 1 == s.stats["totals"]["polygons"] + 1
    assert s.offsets[-1] == len(s.connectivity)
    assert s.points.shape == (len(s.values), 3)
    assert s.level.max() < 100 and len(s.cell) == s.n_polygons


def test_demo_normal_and_threads_equal_cli(cli, tmp_path):
    grid = stratasweep.generate.warped((64, 64, 64))
    b = grid.bounds
    n = [v / 14 ** 0.5 for v in (1, 2, 3)]
    mid = sum(n[a] * (b[2 * a] + b[2 * a + 1]) / 2 for a in range(3))
    lo, step = mid - 1.0, 0.5
    values = [lo + k * step for k in range(5)]
    s = grid.slice(normal=(1, 2, 3), values=values, threads=2)
    spec = f"{lo!r}:{values[-1]!r}:{step!r}"
    cs = cli.stats(tmp_path, "--demo", "--normal", "1,2,3", "--values", spec, "--threads", 2)
    assert len(cs["slices"]) == 5
    assert_same_stats(s.stats, cs)


def test_voronoi_equals_cli(cli, tmp_path):
    path = tmp_path / "v.vtu"
    cli("generate", "voronoi", "--cells", 3000, "--seed", 4, "-o", path)
    grid = stratasweep.load(path)
    assert grid.structure == "ciel"
    s = grid.slice(axis="x", count=40)
    assert_same_stats(s.stats, cli.stats(tmp_path, path, "--axis", "x", "--count", 40))
    # The generator gives the same grid as the file.
    g2 = stratasweep.generate.voronoi(3000, seed=4)
    assert_same_stats(g2.slice(axis="x", count=40).stats, s.stats, rel=1e-9)


def test_reek_equals_cli(cli, tmp_path, data_dir):
    deck = data_dir / "reek" / "2_R001_REEK-0.DATA"
    grid = stratasweep.load(deck)
    assert "PORO" in grid.cell_properties
    s = grid.slice(axis="z", count=50)
    assert_same_stats(s.stats, cli.stats(tmp_path, deck, "--axis", "z", "--count", 50))
    p = grid.slice(property="PORO", count=20)
    assert_same_stats(p.stats, cli.stats(tmp_path, deck, "--property", "PORO", "--count", 20))


def test_reek_egrid_info_equals_cli(cli, data_dir):
    import json

    egrid = data_dir / "reek" / "2_R001_REEK-0.EGRID"
    info = stratasweep.load(egrid).info()
    ref = json.loads(cli("info", egrid, "--json").stdout)
    for key in ["vertices", "cells", "live_cells", "hidden_cells", "cell_types", "cell_classes",
                "bounds", "point_properties", "cell_properties", "memory_bytes", "structure"]:
        assert info[key] == ref[key], key
    assert info["bulk_volume"] == pytest.approx(ref["bulk_volume"], rel=1e-12)


def test_grid_properties():
    grid = stratasweep.generate.warped((8, 9, 10))
    assert grid.n_cells == 8 * 9 * 10
    assert grid.point_properties == ["f"]
    assert grid.structure == "scgraph"
    b = grid.bounds
    assert len(b) == 6 and b[0] < b[1] and b[2] < b[3] and b[4] < b[5]
    info = grid.info()
    assert info["cells"] == 720 and info["structure"] == "scgraph"


def test_values_without_a_property_are_world_levels(data_dir):
    import numpy as np

    # Reek's EGRID has no property and UTM coordinates: each polygon's
    # vertices carry its level's world value (f32), not a local position.
    grid = stratasweep.load(data_dir / "reek" / "2_R001_REEK-0.EGRID")
    s = grid.slice(axis="x", count=7)
    assert s.attribute == "level_value"
    want = np.repeat(s.level_values[s.level], np.diff(s.offsets))
    got = s.values[s.connectivity]
    assert want.min() > 4.5e5
    np.testing.assert_allclose(got, want, rtol=4 * np.finfo(np.float32).eps)
