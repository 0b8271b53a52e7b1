"""One policy for the CLI's `render` and Python's `Grid.render`: the same
request gives the same PNG bytes through both front ends (the same
defaults, including the vertical exaggeration of flat grids), and the same
bad request the same error, options named in each front end's words
(`--mode iso` on the command line, `mode='iso'` in Python)."""

import re
import subprocess

import pytest

import stratasweep


@pytest.fixture(scope="module")
def gpu():
    if not stratasweep.adapters():
        pytest.fail("no GPU adapter (install mesa-vulkan-drivers for llvmpipe)")


@pytest.fixture(scope="module")
def demo():
    # The CLI's --demo grid: warped 64x64x64, seed 1.
    return stratasweep.generate.warped((64, 64, 64))


def cli_png(cli, tmp_path, grid_args, *args):
    out = tmp_path / "cli.png"
    cli("render", *grid_args, "-o", out, *args)
    return out.read_bytes()


def py_png(grid, tmp_path, **kw):
    out = tmp_path / "py.png"
    img = grid.render(output=out, **kw)
    data = out.read_bytes()
    assert img.shape == (kw["size"][1], kw["size"][0], 4)
    return data


@pytest.mark.parametrize(
    "args, kw",
    [
        ([], {}),
        (["--legend", "--preintegrated", "--slices", 50], dict(legend=True, preintegrated=True, slices=50)),
        (["--mode", "iso", "--iso", "0.4,0.6"], dict(mode="iso", iso=[0.4, 0.6])),
        (
            ["--mode", "slices", "--transfer", "magma", "--projection", "perspective", "--background", "transparent"],
            dict(mode="slices", transfer="magma", projection="perspective", background="transparent"),
        ),
        (["--z-scale", 3, "--view-dir", "0,-1,-0.2", "--up", "0,0,1"], dict(z_scale=3, view_dir=(0, -1, -0.2), up=(0, 0, 1))),
    ],
    ids=["default volume", "legend preintegrated", "iso", "slices magma perspective", "z-scale view"],
)
def test_the_same_request_gives_the_same_png(gpu, demo, cli, tmp_path, args, kw):
    ref = cli_png(cli, tmp_path, ["--demo"], "--size", "160x120", *args)
    got = py_png(demo, tmp_path, size=(160, 120), **kw)
    assert got == ref


def test_a_dict_transfer_function_draws_as_its_json_file(gpu, demo, cli, tmp_path):
    tf = {"points": [{"value": 0.2, "color": [0, 0, 1], "opacity": 0.2},
                     {"value": 0.8, "color": [1, 0.5, 0], "opacity": 0.9}]}
    path = tmp_path / "tf.json"
    import json

    path.write_text(json.dumps(tf))
    ref = cli_png(cli, tmp_path, ["--demo"], "--size", "96x64", "--slices", 40, "--transfer", path)
    assert py_png(demo, tmp_path, size=(96, 64), slices=40, transfer=tf) == ref
    assert py_png(demo, tmp_path, size=(96, 64), slices=40, transfer=str(path)) == ref
    assert py_png(demo, tmp_path, size=(96, 64), slices=40, transfer=path) == ref


def test_a_flat_reservoir_gets_the_clis_default_z_scale(gpu, cli, data_dir, tmp_path):
    path = data_dir / "restart" / "BRUGGE_0010.EGRID"
    if not path.exists():
        pytest.skip(f"SKIP: {path} is missing")
    out = tmp_path / "cli.png"
    r = subprocess.run([cli.exe, "render", str(path), "--size", "200x150", "-o", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    m = re.search(r"^z-scale (\S+) \(default for this grid's extents", r.stderr, re.M)
    assert m, r.stderr
    grid = stratasweep.load(path)
    assert grid.default_z_scale == float(m.group(1))
    assert grid.default_z_scale > 1  # flat: exaggerated
    assert py_png(grid, tmp_path, size=(200, 150)) == out.read_bytes()


def cli_error(cli, *args):
    r = subprocess.run([cli.exe, "--quiet", *map(str, args)], capture_output=True, text=True)
    assert r.returncode != 0, f"{args} should fail"
    m = re.search(r"^error: (.*)$", r.stderr, re.M)
    assert m, r.stderr
    return m.group(1)


def python_words(msg):
    """The CLI's message with its flags as Python's keywords."""
    def kw(m):
        name = m.group(1).replace("-", "_")
        return f"{name}='{m.group(2)}'" if m.group(2) else name
    return re.sub(r"--([a-z][a-z-]*)(?: (iso|volume|slices|gpu|cpu|auto)\b)?", kw, msg)


@pytest.mark.parametrize(
    "args, kw, exc",
    [
        (["--background", "1,2"], dict(background="1,2"), ValueError),
        (["--background", "2,0,0,1"], dict(background="2,0,0,1"), ValueError),
        (["--size", "100000x10"], dict(size=(100000, 10)), ValueError),
        (["--mode", "iso"], dict(mode="iso"), ValueError),
        (["--mode", "iso", "--iso", "100,-5"], dict(mode="iso", iso=[100, -5]), ValueError),
        (["--transfer", "plasma"], dict(transfer="plasma"), ValueError),
        (["--transfer", "/nonexistent/tf.json"], dict(transfer="/nonexistent/tf.json"), FileNotFoundError),
        (["--iso", "0.5"], dict(iso=[0.5]), ValueError),
        (["--mode", "slices", "--preintegrated"], dict(mode="slices", preintegrated=True), ValueError),
        (["--z-scale=-1"], dict(z_scale=-1), ValueError),
        (["--slices", "0"], dict(slices=0), ValueError),
    ],
    ids=["background syntax", "background range", "oversize image", "iso without values",
         "isovalues outside", "unknown transfer", "missing transfer file", "iso outside iso mode",
         "preintegrated slices", "z-scale", "no slices"],
)
def test_the_same_bad_request_gives_the_same_error(gpu, demo, cli, tmp_path, args, kw, exc):
    size = [] if "--size" in args else ["--size", "32x24"]
    want = python_words(cli_error(cli, "render", "--demo", "-o", tmp_path / "x.png", *size, *args))
    kw.setdefault("size", (32, 24))
    with pytest.raises(exc) as e:
        demo.render(**kw)
    got = e.value.strerror if isinstance(e.value, OSError) else str(e.value)
    assert got == want
    assert not (tmp_path / "x.png").exists()


def test_python_words_for_the_device_and_the_cli_flags():
    assert python_words("--mode iso needs --iso values") == "mode='iso' needs iso values"
    assert python_words("--z-scale -1: must be") == "z_scale -1: must be"


def test_bad_words_are_refused_naming_the_choices(demo):
    with pytest.raises(ValueError, match=r"^cells 'x': expected 'auto', 'sweep' or 'gpu'$"):
        demo.render(cells="x", size=(8, 8))
    with pytest.raises(ValueError, match=r"^projection 'x': expected 'ortho' or 'perspective'$"):
        demo.render(projection="x", size=(8, 8))
    with pytest.raises(ValueError, match=r"\.png"):
        demo.render(size=(8, 8), output="x.jpg")
