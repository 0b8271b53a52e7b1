"""Out of memory in Python (issue 32, class 5): an allocation that fails is
a MemoryError naming what and how much, and the interpreter lives on. Each
case runs in a child interpreter under RLIMIT_AS (``ulimit -v``), so that
the failure does not depend on the machine's overcommit policy."""

import os
import subprocess
import sys
import textwrap

CHILD = textwrap.dedent(
    """
    import os, resource, sys
    import stratasweep
    limit = os.environ["STRATASWEEP_TEST_AS_LIMIT"]
    if limit.startswith("+"):  # that much above what is mapped now
        with open("/proc/self/statm") as f:
            now = int(f.read().split()[0]) * resource.getpagesize()
        limit = now + int(limit[1:])
    limit = int(limit)
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    try:
        exec(sys.argv[1])
    except MemoryError as e:
        print("MemoryError:", e)
    except ValueError as e:
        print("ValueError:", e)
    else:
        print("no error")
    print("alive", sum(range(10)))
    """
)


def run_limited(code, *args, limit=2 << 30):
    """Runs `code` in a child interpreter under RLIMIT_AS `limit` (bytes;
    a string "+N": N bytes above what the child has mapped once imported)."""
    env = {
        **os.environ,
        "OPENBLAS_NUM_THREADS": "1",
        "RAYON_NUM_THREADS": "2",
        "STRATASWEEP_TEST_AS_LIMIT": str(limit),
    }
    r = subprocess.run(
        [sys.executable, "-c", CHILD, code, *map(str, args)],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert r.returncode == 0, f"the interpreter died ({r.returncode}): {r.stderr}"
    assert "memory allocation of" not in r.stderr, r.stderr
    assert "alive 45" in r.stdout, r.stdout + r.stderr
    return r.stdout


def test_a_grid_that_does_not_fit_is_a_memory_error(tmp_path):
    deck = tmp_path / "huge.grdecl"
    deck.write_text("SPECGRID\n1000 1000 100 1 F /\nCOORD\n6012006*0 /\nZCORN\n800000000*1 /\n")
    out = run_limited("stratasweep.load(sys.argv[2])", deck)
    assert "MemoryError:" in out and "ZCORN" in out and "6400000000 bytes" in out, out


def test_a_level_list_that_does_not_fit_is_not_fatal():
    code = "stratasweep.generate.warped((8, 8, 8)).slice(axis='z', count=10**12, mesh=False)"
    out = run_limited(code)
    # Refused by the count limit (ValueError) before allocating, or the
    # allocation fails (MemoryError naming the level list): never an abort.
    assert "ValueError:" in out or ("MemoryError:" in out and "level values" in out), out


def test_a_slice_whose_output_does_not_fit_is_a_memory_error():
    # A 64^3 grid cut by 12,000 z levels: about 4,096 quadrilaterals and
    # 4,225 vertices a level, some 2.6 GB of polygons and vertices kept per
    # level and as much again for the merged mesh, under a 2 GiB limit.
    code = "stratasweep.generate.warped((64, 64, 64)).slice(axis='z', count=12000)"
    out = run_limited(code)
    assert "MemoryError:" in out and "slice" in out and " bytes" in out, out
    # Without the limit the same call works, with fewer levels.
    small = run_limited(
        "s = stratasweep.generate.warped((64, 64, 64)).slice(axis='z', count=20)\n"
        "print('polygons', len(s.level))",
        limit=16 << 30,
    )
    assert "no error" in small, small
    polygons = int(small.split("polygons ")[1].split()[0])
    assert 20 * 3000 < polygons < 20 * 5000, small


def test_a_vtk_file_that_does_not_fit_is_a_memory_error(tmp_path):
    # Written without a limit, read under one: the .vts (8.1 M points,
    # Float64: 194 MB of points, 65 MB of f) is mapped and f decoded within
    # the limit, then the points' 194 MB do not fit in what is left.
    path = tmp_path / "w.vts"
    made = run_limited(f"stratasweep.generate.warped((200, 200, 200)).save({str(path)!r})", limit=64 << 30)
    assert "no error" in made, made
    size = path.stat().st_size
    out = run_limited("stratasweep.load(sys.argv[2])", path, limit=f"+{size + (130 << 20)}")
    assert "MemoryError:" in out and "DataArray 'Points'" in out and "w.vts" in out, out
    assert "194894424 bytes" in out, out  # 201^3 points, 3 float64 each
    # The same file loads without the limit, and the interpreter that ran
    # out of memory went on (run_limited checks "alive").
    free = run_limited("g = stratasweep.load(sys.argv[2])", path, limit=64 << 30)
    assert "no error" in free, free
