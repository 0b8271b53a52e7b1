"""No leak: 100 slice calls on a large grid keep the resident set bounded.

The grid is warped 159^3 = 4,019,679 cells (the issue's 4M); the structure
is built once and kept by the Grid, every call sweeps 20 z levels and
gathers the mesh, and the arrays are read out each time."""

import gc
import os

import pytest

import stratasweep

N = int(os.environ.get("STRATASWEEP_LEAK_N", "159"))


def rss_bytes():
    """Resident bytes after glibc returned its free pages (malloc_trim), so
    that freed outputs are not counted."""
    try:
        import ctypes

        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    pytest.skip("SKIP: no /proc/self/status on this system")


def test_hundred_slices_do_not_leak():
    grid = stratasweep.generate.warped((N, N, N))
    assert grid.n_cells == N ** 3
    per_call = None
    samples = []
    for i in range(100):
        s = grid.slice(axis="z", count=20)
        pts, conn = s.points, s.connectivity
        if per_call is None:
            per_call = pts.nbytes + conn.nbytes + s.values.nbytes + s.level.nbytes + s.cell.nbytes
        del s, pts, conn
        if i % 10 == 9:
            gc.collect()
            samples.append(rss_bytes())
    # 100 calls made and dropped 100 outputs of per_call bytes each (about
    # 34 MB at 159^3; 3.4 GB in all). The resident set moves with the
    # allocator (an output or two more or less held) but has no upward
    # trend: the last 50 calls end within two outputs of what the first 50
    # reached (a leak of 2 MB per call would add 100 MB), and no sample
    # exceeds the first by more than four outputs.
    slack = 2 * per_call + (32 << 20)
    assert max(samples[5:]) <= max(samples[:5]) + slack, (samples, per_call)
    assert max(samples) <= samples[0] + 2 * slack, (samples, per_call)
