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


def _ramp_grid():
    # One tetrahedron with a point property 0..3 (as test_errors' grid).
    return stratasweep.from_arrays(
        [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
        [4, 0, 1, 2, 3],
        [10],
        point_data={"ramp": [0.0, 1.0, 2.0, 3.0]},
    )


def _point(v, a, color=(1, 0, 0)):
    return {"value": v, "color": list(color), "opacity": a}


def test_transfer_functions_that_draw_nothing_are_refused_as_the_cli_refuses_them(tmp_path):
    # The library's checks (the CLI's): no blank image without a word.
    grid = _ramp_grid()
    kw = {"property": "ramp", "size": (16, 16)}
    with pytest.raises(ValueError, match="has no points"):
        grid.render(transfer={"points": []}, **kw)
    with pytest.raises(ValueError, match="opacity 0"):
        grid.render(transfer={"points": [_point(0, 0), _point(3, 0)]}, **kw)
    # Opaque only above the data: transparent over its whole range.
    with pytest.raises(ValueError, match=r"opacity 0 over the whole range of property 'ramp' \(0 \.\. 3\)"):
        grid.render(transfer={"points": [_point(5, 0), _point(6, 1)]}, **kw)
    # Wholly outside but opaque at the data: drawn, with a warning.
    with pytest.warns(UserWarning, match="wholly outside the data"):
        img = grid.render(transfer={"points": [_point(5, 1), _point(6, 1)]}, **kw)
    assert (img[..., 3] > 0).any()
    # Isovalues outside iso mode are refused, not ignored.
    with pytest.raises(ValueError, match="isovalues are drawn only in iso mode"):
        grid.render(iso=[1.5], **kw)


def test_transfer_names_and_files_are_read_as_the_cli_reads_them(tmp_path):
    grid = _ramp_grid()
    kw = {"property": "ramp", "size": (16, 16)}
    txt = tmp_path / "tf.txt"
    txt.write_text('{"points": [{"value": 0, "color": [1, 0, 0], "opacity": 1}]}')
    with pytest.raises(ValueError, match=r"neither a colormap name .* nor a transfer-function file"):
        grid.render(transfer=str(txt), **kw)
    bom = tmp_path / "bom.json"
    bom.write_text('{"points": [{"value": 0, "color": [1, 0, 0], "opacity": 1},'
                   ' {"value": 3, "color": [0, 0, 1], "opacity": 1}]}', encoding="utf-8-sig")
    assert (grid.render(transfer=str(bom), **kw)[..., 3] > 0).any()
    with pytest.raises(ValueError, match=r"point 0: \"color\" has 4 components"):
        grid.render(transfer={"points": [_point(0, 1, color=(1, 0, 0, 1))]}, **kw)
    with pytest.raises(ValueError) as e:
        grid.render(transfer={"points": [_point(0, 1, color=(1.5, 0, 0))]}, **kw)
    assert "TransferPoint" not in str(e.value) and "color[0] (red)" in str(e.value)
