"""The GIL is released while sweeping: another Python thread runs in the
middle of a long `Grid.slice` call (with the GIL held it could not run
between the call's start and its end)."""

import threading
import time

import stratasweep


def test_slice_releases_the_gil():
    grid = stratasweep.generate.warped((96, 96, 96))
    grid.structure  # build first: the timed call sweeps only
    span = {}

    def work():
        span["start"] = time.perf_counter()
        span["slices"] = grid.slice(axis="z", count=800, mesh=True)
        span["end"] = time.perf_counter()

    t = threading.Thread(target=work)
    seen = []
    t.start()
    while t.is_alive():
        seen.append(time.perf_counter())
        time.sleep(0.001)
    t.join()
    a, b = span["start"], span["end"]
    assert span["slices"].stats["totals"]["cells"] > 0
    assert b - a > 0.05, "the call was too short to tell"
    middle = [x for x in seen if a + 0.25 * (b - a) < x < a + 0.75 * (b - a)]
    assert middle, (a, b, len(seen))
