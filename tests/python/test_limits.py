"""The library's limits from Python (the CLI's, from `stratasweep::limits`),
Ctrl-C during a long native call, levels outside the field's range as a
warning, and no Mesa "XDG_RUNTIME_DIR" noise on stderr."""

import os
import signal
import subprocess
import sys
import textwrap
import time
import warnings

import pytest

import stratasweep


@pytest.fixture(scope="module")
def grid():
    return stratasweep.generate.warped((6, 6, 6))


def refused_quickly(call, *texts):
    t = time.monotonic()
    with pytest.raises(ValueError) as e:
        call()
    took = time.monotonic() - t
    assert took < 2.0, f"took {took:.1f} s to refuse"
    for text in texts:
        assert text in str(e.value), str(e.value)
    return str(e.value)


def test_threads_beyond_the_limit_are_refused_quickly(grid):
    m = refused_quickly(
        lambda: grid.slice(axis="z", count=3, threads=10**5),
        "threads 100000 is more than the limit of",
        "worker threads",
    )
    limit = int(m.split("limit of ")[1].split()[0])
    assert limit >= 64
    # The limit itself is accepted.
    assert grid.slice(axis="z", count=3, threads=limit, mesh=False).stats["totals"]["cells"] > 0


@pytest.mark.parametrize("count", [10**7, 10**12])
def test_level_counts_beyond_the_limit_are_refused_quickly(grid, count):
    refused_quickly(
        lambda: grid.slice(axis="z", count=count),
        f"count {count} is more than the limit of 100000 levels per run",
    )


def test_values_beyond_the_limit_are_refused(grid):
    refused_quickly(
        lambda: grid.slice(axis="z", values=[float(i) for i in range(100_001)]),
        "values gives 100001 levels, more than the limit of 100000",
    )


def test_render_slices_and_size_beyond_the_limits_are_refused_quickly(grid):
    refused_quickly(lambda: grid.render(slices=10**6), "slices 1000000 is outside 1..=8192")
    refused_quickly(lambda: grid.render(size=(100_000, 10)), "size 100000 is outside 1..=8192")
    refused_quickly(lambda: grid.render(slices=0), "slices must be at least 1")
    refused_quickly(lambda: grid.render(mode="iso", iso=[0.5] * 9000), "iso 9000")


def test_ctrl_c_stops_a_long_slice_within_two_seconds(tmp_path):
    script = textwrap.dedent(
        """
        import sys, time, stratasweep
        g = stratasweep.generate.warped((48, 48, 48))
        g.slice(axis="z", count=3)  # the structure is built
        print("started", flush=True)
        t = time.monotonic()
        try:
            g.slice(axis="z", count=100000, mesh=False, threads=2)
        except KeyboardInterrupt:
            print(f"interrupted {time.monotonic() - t:.3f}", flush=True)
            raise
        print("finished", flush=True)
        """
    )
    # SIGINT at its default disposition in the child: a test run started in
    # the background inherits it ignored, and Python then never installs its
    # KeyboardInterrupt handler.
    p = subprocess.Popen(
        [sys.executable, "-c", script],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        assert p.stdout.readline().strip() == "started"
        time.sleep(1.0)
        sent = time.monotonic()
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=30)
        took = time.monotonic() - sent
    finally:
        p.kill()
    assert "KeyboardInterrupt" in err, err
    assert p.returncode != 0
    assert "finished" not in out, "the slice ran to its end: nothing was cancelled"
    assert took < 2.0, f"the process ended {took:.1f} s after SIGINT"


def test_depths_on_reek_warn_that_z_is_minus_depth(data_dir):
    grid = stratasweep.load(data_dir / "reek" / "2_R001_REEK-0.EGRID")
    with pytest.warns(UserWarning) as record:
        sl = grid.slice(axis="z", values=[1600.0, 1700.0])
    assert sl.stats["totals"]["polygons"] == 0
    msg = str(record[0].message)
    assert "all 2 levels (1600..1700) lie outside z's range" in msg, msg
    assert "z is minus depth: for depths 1600..1700 take the levels -1700..-1600" in msg, msg
    # The levels it suggests cut the grid, without a warning.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sl = grid.slice(axis="z", values=[-1700.0, -1600.0])
    assert all(s["polygons"] > 0 for s in sl.stats["slices"])
    assert sl.stats["field"] == "z"


def test_no_xdg_runtime_dir_noise_from_a_render():
    env = {k: v for k, v in os.environ.items()
           if k not in ("XDG_RUNTIME_DIR", "NODEVICE_SELECT", "MESA_VK_DEVICE_SELECT")}
    script = textwrap.dedent(
        """
        import os, stratasweep
        print(os.environ.get("NODEVICE_SELECT"))
        g = stratasweep.generate.warped((6, 6, 6))
        img = g.render(slices=8, size=(32, 32), device="cpu")
        print(img.shape)
        """
    )
    r = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split("\n")[:2] == ["1", "(32, 32, 4)"], r.stdout
    assert "XDG_RUNTIME_DIR" not in r.stderr, r.stderr
