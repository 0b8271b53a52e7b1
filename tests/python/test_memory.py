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
    # 30 MB at 159^3). The resident set moves with the allocator (one
    # output more or less kept in free lists) but has no upward trend: the
    # last 50 calls end no higher than the first 50 reached, and no sample
    # exceeds the first by more than a few outputs.
    slack = 32 << 20
    assert max(samples[5:]) <= max(samples[:5]) + slack, (samples, per_call)
    assert max(samples) <= samples[0] + 3 * per_call + slack, (samples, per_call)
