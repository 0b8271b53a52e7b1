"""Grid.slice(device=...) as the CLI's `slice --device`: the GPU emission
(llvmpipe counts) gives the CPU sweep's cut cells, polygons and areas per
level; the CLI's rules for mesh output and the brute force."""

import pytest

import stratasweep


@pytest.fixture(scope="module")
def gpu():
    if not stratasweep.adapters():
        pytest.fail("no GPU adapter (install mesa-vulkan-drivers for llvmpipe)")


def same_levels(a, b, rel, cells=True):
    assert len(a["slices"]) == len(b["slices"]) > 0
    for x, y in zip(a["slices"], b["slices"]):
        assert x["value"] == y["value"]
        assert (x["polygons"], x["triangles"]) == (y["polygons"], y["triangles"]), (x, y)
        if cells:
            assert x["cells"] == y["cells"], (x, y)
        assert x["area"] == pytest.approx(y["area"], rel=rel, abs=1e-9), (x, y)
    assert a["totals"]["polygons"] > 0


@pytest.mark.parametrize(
    "make, kw",
    [
        (lambda: stratasweep.generate.warped((24, 20, 16)), dict(axis="z", count=30)),
        (lambda: stratasweep.generate.warped((24, 20, 16)), dict(property="f", count=12)),
        (lambda: stratasweep.generate.zoo(3000), dict(normal=(0.3, -0.5, 0.8), count=15)),
    ],
    ids=["scgraph z", "scgraph isosurfaces", "cgraph oblique"],
)
def test_gpu_emission_equals_cpu(gpu, make, kw):
    grid = make()
    cpu = grid.slice(mesh=False, device="cpu", **kw).stats
    on_gpu = grid.slice(mesh=False, device="gpu", **kw).stats
    auto = grid.slice(mesh=False, device="auto", **kw).stats
    # f32 emission on the GPU against the CPU's: areas to 1e-5 (as the
    # Rust gpu_emit tests).
    same_levels(on_gpu, cpu, 1e-5)
    same_levels(auto, cpu, 1e-5)


def test_gpu_emission_on_split_cells_equals_cpu_and_cli(gpu, cli, tmp_path):
    # A faulted corner-point grid (pinched cells split into convex pieces):
    # the GPU path gives the CPU's cut cells (input cells: the convex pieces
    # of a split cell count once), polygons and areas, exactly as the CLI's
    # `slice --device gpu` does.
    grid = stratasweep.generate.faulted((12, 10, 6), faults=2, seed=3)
    path = tmp_path / "f.grdecl"
    cli("generate", "faulted", "--dims", "12,10,6", "--faults", 2, "--seed", 3, "-o", path)
    for structure in ("auto", "cgraph"):
        kw = dict(axis="z", count=9, mesh=False, structure=structure)
        cpu = grid.slice(device="cpu", **kw).stats
        on_gpu = grid.slice(device="gpu", **kw).stats
        same_levels(on_gpu, cpu, 1e-5)
        ref = cli.stats(tmp_path, path, "--axis", "z", "--count", 9, "--device", "gpu", "--structure", structure)
        assert on_gpu["structure"] == ref["structure"]
        same_levels(on_gpu, ref, 1e-12)


def test_device_rules(gpu):
    grid = stratasweep.generate.warped((8, 8, 8))
    with pytest.raises(ValueError, match="mesh=False"):
        grid.slice(axis="z", count=3, device="gpu")
    with pytest.raises(ValueError, match="bruteforce"):
        grid.slice(axis="z", count=3, device="gpu", mesh=False, structure="bruteforce")
    with pytest.raises(ValueError, match="device 'tpu'"):
        grid.slice(axis="z", count=3, device="tpu")
    with pytest.raises(RuntimeError, match="no GPU adapter matching"):
        grid.slice(axis="z", count=3, device="gpu", mesh=False, adapter="no-such-adapter-anywhere")
    # auto with a mesh runs the CPU path (the GPU path gives no polygons).
    s = grid.slice(axis="z", count=3, device="auto")
    assert s.n_polygons > 0
