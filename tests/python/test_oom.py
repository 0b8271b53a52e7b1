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
    import resource, sys
    import stratasweep
    resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
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


def run_limited(code, *args):
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "RAYON_NUM_THREADS": "2"}
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
