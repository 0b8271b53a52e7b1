"""Grid.render gives the CLI's image (same options, same adapter)."""

import numpy as np
import pytest

import stratasweep


def read_png(path):
    png = pytest.importorskip("PIL.Image", reason="SKIP: Pillow is not installed")
    return np.asarray(png.open(path).convert("RGBA"))


def test_render_equals_cli(cli, tmp_path):
    if not stratasweep.adapters():
        pytest.fail("no GPU adapter (install mesa-vulkan-drivers for llvmpipe)")
    out = tmp_path / "demo.png"
    cli("render", "--demo", "-o", out, "--size", "96x64", "--slices", 40)
    ref = read_png(out)
    img = stratasweep.generate.warped((64, 64, 64)).render(size=(96, 64), slices=40)
    assert img.shape == (64, 96, 4) and img.dtype == np.uint8
    assert len(np.unique(img.reshape(-1, 4), axis=0)) > 10
    assert np.abs(img.astype(int) - ref.astype(int)).max() <= 1
