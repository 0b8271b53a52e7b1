"""Every error class: OSError for files, ValueError for bad arguments and
grids, RuntimeError for GPU faults, ImportError without PyVista."""

import sys

import numpy as np
import pytest

import stratasweep


@pytest.fixture(scope="module")
def grid():
    return stratasweep.generate.warped((8, 8, 8))


def test_missing_file_is_oserror(tmp_path):
    missing = tmp_path / "nope.vtk"
    with pytest.raises(FileNotFoundError) as e:
        stratasweep.load(missing)
    assert isinstance(e.value, OSError) and str(missing) in str(e.value)


def test_directory_is_oserror(tmp_path):
    with pytest.raises(OSError):
        stratasweep.load(tmp_path)


def test_unwritable_output_is_oserror(grid, tmp_path):
    s = grid.slice(axis="z", count=3)
    with pytest.raises(OSError):
        s.save(tmp_path / "no" / "such" / "dir" / "out.ply")
    with pytest.raises(OSError):
        grid.save(tmp_path / "no" / "dir" / "g.vts")


def test_bad_grid_file_is_valueerror_naming_file_and_line(tmp_path):
    bad = tmp_path / "bad.vtk"
    bad.write_text("# vtk DataFile Version 3.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 2 float\n0 0 0\n")
    with pytest.raises(ValueError) as e:
        stratasweep.load(bad)
    assert "bad.vtk" in str(e.value)
    g = tmp_path / "bad.grdecl"
    g.write_text("SPECGRID\n 2 2 1 1 F /\nCOORD\n 1 2 3 /\n")
    with pytest.raises(ValueError) as e:
        stratasweep.load(g)
    assert "bad.grdecl" in str(e.value)


@pytest.mark.parametrize(
    "kwargs, text",
    [
        (dict(count=3), "exactly one of axis, normal or property"),
        (dict(axis="z", normal=(0, 0, 1), count=3), "exactly one of axis, normal or property"),
        (dict(axis="z"), "exactly one of count or values"),
        (dict(axis="z", count=3, values=[0.1]), "exactly one of count or values"),
        (dict(axis="w", count=3), "axis 'w'"),
        (dict(axis="z", count=0), "count must be at least 1"),
        (dict(normal=(0, 0, 0), count=3), "normal must not be zero"),
        (dict(property="nope", count=3), "no property named 'nope'"),
        (dict(axis="z", values=[0.5, 0.2]), "must increase strictly"),
        (dict(axis="z", values=[]), "no levels"),
        (dict(axis="z", values=[float("nan")]), "not finite"),
        (dict(axis="z", count=3, at="faces"), "at 'faces'"),
        (dict(axis="z", count=3, at="cells"), "at='cells' needs a cell property"),
        (dict(axis="z", count=3, threads=0), "threads must be at least 1"),
        (dict(axis="z", count=3, structure="octree"), "structure 'octree'"),
        (dict(axis="z", count=3, structure="cgraph"), ""),
    ],
)
def test_bad_arguments_are_valueerror(grid, kwargs, text):
    if kwargs.get("structure") == "cgraph":
        # A valid request: CGraph on a curvilinear grid works.
        assert grid.slice(**kwargs).stats["structure"] == "cgraph"
        return
    with pytest.raises(ValueError) as e:
        grid.slice(**kwargs)
    assert text in str(e.value)


def test_bad_arrays_are_valueerror():
    pts = np.zeros((4, 3))
    with pytest.raises(ValueError, match="out of range"):
        stratasweep.from_arrays(pts, [4, 0, 1, 2, 9], [10])
    with pytest.raises(ValueError, match="runs past the end"):
        stratasweep.from_arrays(pts, [4, 0, 1, 2], [10])
    with pytest.raises(ValueError, match=r"shape \(n, 3\)"):
        stratasweep.from_arrays(np.zeros((4, 2)), [4, 0, 1, 2, 3], [10])
    with pytest.raises(ValueError, match="property 'p'"):
        stratasweep.from_arrays(pts, [4, 0, 1, 2, 3], [10], point_data={"p": [1.0, 2.0]})
    with pytest.raises(ValueError, match="dims"):
        stratasweep.generate.warped((0, 4, 4))
    with pytest.raises(ValueError, match="fault_dip"):
        stratasweep.generate.faulted((4, 4, 4), fault_dip=10)


def test_bad_save_extension_is_valueerror(grid, tmp_path):
    with pytest.raises(ValueError, match=r"\.ply or \.vtp"):
        grid.slice(axis="z", count=2).save(tmp_path / "x.obj")
    with pytest.raises(ValueError, match=r"\.vts"):
        grid.save(tmp_path / "x.vtu")


def test_gpu_faults_are_runtimeerror(grid):
    with pytest.raises(RuntimeError, match="no GPU adapter matching"):
        grid.render(adapter="no-such-adapter-anywhere", size=(8, 8))
    kinds = {a["device_type"] for a in stratasweep.adapters()}
    if kinds and kinds <= {"Cpu"}:
        with pytest.raises(RuntimeError, match="no hardware GPU adapter"):
            grid.render(device="gpu", size=(8, 8))


def test_bad_render_options_are_valueerror(grid):
    with pytest.raises(ValueError, match="device 'tpu'"):
        grid.render(device="tpu")
    with pytest.raises(ValueError, match="mode='iso' needs iso values"):
        grid.render(mode="iso")
    with pytest.raises(ValueError, match="background"):
        grid.render(background=(2, 0, 0, 1))


def test_to_pyvista_without_pyvista_is_importerror(grid, monkeypatch):
    s = grid.slice(axis="z", count=2)
    monkeypatch.setitem(sys.modules, "pyvista", None)
    with pytest.raises(ImportError, match="pip install pyvista"):
        s.to_pyvista()


def test_stats_only_slices_refuse_arrays(grid):
    s = grid.slice(axis="z", count=4, mesh=False)
    assert s.stats["totals"]["cells"] > 0
    with pytest.raises(ValueError, match="mesh=False"):
        s.points


def test_control_bytes_in_messages_are_escaped_as_the_cli_escapes_them(tmp_path, cli):
    # A file name and a keyword with control bytes (ESC, BEL): the message
    # quotes them escaped (\u{1b}), as the CLI's error line does.
    missing = tmp_path / "x\x1b[31mred.vtk"
    with pytest.raises(FileNotFoundError) as e:
        stratasweep.load(missing)
    msg = str(e.value)
    assert "\x1b" not in msg and "\\u{1b}[31mred.vtk" in msg, msg
    g = tmp_path / "ctl.grdecl"
    g.write_bytes(b'SPECGRID\n 2 2 1 1 F /\nINCLUDE\n "a\x07b" /\n')
    with pytest.raises((OSError, ValueError)) as e:
        stratasweep.load(g)
    err = e.value
    msg = err.strerror if isinstance(err, OSError) and err.strerror else str(err)
    assert "\x07" not in msg and "a\\u{7}b" in msg and "ctl.grdecl" in msg, msg
    import subprocess

    r = subprocess.run([cli.exe, "info", str(g)], capture_output=True, text=True)
    assert r.returncode != 0
    assert "a\\u{7}b" in r.stderr and "\x07" not in r.stderr, r.stderr
    # The same message text as the CLI's error line.
    assert msg in r.stderr, (msg, r.stderr)


def test_a_constant_property_is_refused_as_the_cli_refuses_it():
    # One colour over a range of zero width draws nothing: ValueError, not
    # a blank image (a transfer function's own points still colour it).
    grid = stratasweep.from_arrays(
        [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
        [4, 0, 1, 2, 3],
        [10],
        point_data={"flat": [2.5, 2.5, 2.5, 2.5], "ramp": [0.0, 1.0, 2.0, 3.0]},
    )
    with pytest.raises(ValueError, match=r"property 'flat' is constant \(2\.5\)"):
        grid.render(property="flat", size=(16, 16))
    flat = {"points": [{"value": 0, "color": [1, 0, 0], "opacity": 1},
                       {"value": 5, "color": [1, 0, 0], "opacity": 1}]}
    img = grid.render(property="flat", transfer=flat, size=(16, 16))
    assert (img[..., 3] > 0).any()
    with pytest.raises(ValueError, match="is constant"):
        grid.render(property="flat", transfer=flat, mode="iso", iso=[2.5], size=(16, 16))
    assert grid.render(size=(16, 16)) is not None  # the default skips 'flat'
