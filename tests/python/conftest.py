"""Fixtures for the Python package's tests: the CLI to compare with, and
the real-data folder (STRATASWEEP_DATA; tests that need it skip loudly)."""

import json
import os
import pathlib
import subprocess
import sys
import warnings

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def cli():
    """Runs the `stratasweep` CLI (STRATASWEEP_BIN, else target/release)."""
    exe = os.environ.get("STRATASWEEP_BIN") or str(ROOT / "target" / "release" / "stratasweep")
    if not os.path.exists(exe):
        pytest.fail(f"the CLI is not built at {exe}: run `cargo build --release` or set STRATASWEEP_BIN")

    def run(*args):
        r = subprocess.run([exe, "--quiet", *map(str, args)], capture_output=True, text=True)
        if r.returncode != 0:
            raise AssertionError(f"stratasweep {' '.join(map(str, args))} failed:\n{r.stderr}")
        return r

    def stats(tmp_path, *args):
        out = tmp_path / "stats.json"
        run("slice", *args, "--stats", out)
        return json.loads(out.read_text())

    run.stats = stats
    run.exe = exe
    return run


@pytest.fixture(scope="session")
def data_dir():
    d = os.environ.get("STRATASWEEP_DATA")
    if not d or not os.path.isdir(d):
        msg = "SKIP: STRATASWEEP_DATA is not set (real grids, e.g. ../shared/data): real-data test not run"
        print(msg, file=sys.stderr)
        warnings.warn(msg)
        pytest.skip(msg)
    return pathlib.Path(d)


def assert_same_stats(py_stats, cli_stats, rel=1e-12):
    """Per level: same value, cut cells, polygons and (to `rel`) area."""
    a, b = py_stats["slices"], cli_stats["slices"]
    assert len(a) == len(b) > 0
    for x, y in zip(a, b):
        assert x["index"] == y["index"]
        assert x["value"] == pytest.approx(y["value"], rel=1e-15, abs=1e-12)
        assert x["cells"] == y["cells"], (x, y)
        assert x["polygons"] == y["polygons"], (x, y)
        assert x["area"] == pytest.approx(y["area"], rel=rel, abs=1e-12), (x, y)
    assert py_stats["totals"]["cells"] == cli_stats["totals"]["cells"]
    assert py_stats["totals"]["cells"] > 0
