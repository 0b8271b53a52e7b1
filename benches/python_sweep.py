"""Timings of the Python package (issue 21), run by hand:

    python benches/python_sweep.py overhead N      # Grid.slice vs `stratasweep bench` on warped N^3, 200 z levels
    python benches/python_sweep.py pyvista NI NJ NK  # Grid.slice vs a loop of pyvista.slice on a faulted ExplicitStructuredGrid
    python benches/python_sweep.py alternate N PAIRS  # PAIRS x (Grid.slice best of 3, then `bench --repeat 3`), warped N^3

Prints one JSON object. The CLI is STRATASWEEP_BIN (default target/release/stratasweep).
"""

import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

import stratasweep

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CLI = os.environ.get("STRATASWEEP_BIN", os.path.join(ROOT, "target", "release", "stratasweep"))


def best_of(n, f):
    out = []
    for _ in range(n):
        t = time.perf_counter()
        r = f()
        out.append((time.perf_counter() - t, r))
    return min(out, key=lambda x: x[0])


def overhead(n):
    grid = stratasweep.generate.warped((n, n, n))
    t = time.perf_counter()
    grid.structure  # build once (kept by the Grid)
    build = time.perf_counter() - t
    res = {"grid": f"warped {n}^3", "cells": grid.n_cells, "levels": 200, "build_s": build}
    for mesh in (False, True):
        wall, s = best_of(3, lambda: grid.slice(axis="z", count=200, mesh=mesh))
        t = s.stats["timings_s"]
        res[f"python_mesh_{mesh}"] = {"wall_s": wall, "sweep_s": t["sweep"], "field_s": t["field"], "minima_s": t["minima"]}
    del grid
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "w.vts")
        subprocess.run([CLI, "-q", "generate", "warped", "--dims", f"{n},{n},{n}", "-o", path], check=True)
        out = subprocess.run([CLI, "-q", "bench", path, "--axis", "z", "--count", "200", "--repeat", "3",
                              "--no-brute-force", "--json"], check=True, capture_output=True, text=True).stdout
        b = json.loads(out)
        res["cli_bench"] = {k: b[k] for k in ("sweep_s", "field_s", "minima_s", "build_s", "cut_cells")}
        stats = os.path.join(d, "s.json")
        ply = os.path.join(d, "s.ply")
        t = time.perf_counter()
        subprocess.run([CLI, "-q", "slice", path, "--axis", "z", "--count", "200", "-o", ply, "--stats", stats], check=True)
        st = json.load(open(stats))["timings_s"]
        res["cli_slice_with_mesh"] = {"process_wall_s": time.perf_counter() - t, **st}
    res["ratio_python_sweep_over_cli_sweep"] = res["python_mesh_False"]["sweep_s"] / res["cli_bench"]["sweep_s"]
    py_all = res["python_mesh_False"]
    cli_all = res["cli_bench"]
    res["ratio_python_wall_over_cli_field_minima_sweep"] = py_all["wall_s"] / (cli_all["sweep_s"] + cli_all["field_s"] + cli_all["minima_s"])
    return res


def pyvista(ni, nj, nk):
    t = time.perf_counter()
    esg = stratasweep.generate.faulted_pyvista((ni, nj, nk), faults=3, seed=1)
    make = time.perf_counter() - t
    t = time.perf_counter()
    grid = stratasweep.from_pyvista(esg)
    convert = time.perf_counter() - t
    t = time.perf_counter()
    grid.structure
    build = time.perf_counter() - t
    calls = []
    for _ in range(3):
        t, c = time.perf_counter(), time.process_time()
        s = grid.slice(axis="z", count=200)
        calls.append((time.perf_counter() - t, s.stats["timings_s"]["sweep"], time.process_time() - c))
    wall = min(c[0] for c in calls)
    cpu = min(c[2] for c in calls)
    nomesh = []
    for _ in range(3):
        t = time.perf_counter()
        grid.slice(axis="z", count=200, mesh=False)
        nomesh.append(time.perf_counter() - t)
    t = time.perf_counter()
    cg = grid.slice(axis="z", count=200, structure="cgraph")
    cgraph_wall = time.perf_counter() - t  # includes the CGraph's build
    levels = s.level_values
    t, c = time.perf_counter(), time.process_time()
    areas = []
    for v in levels:
        cut = esg.slice(normal="z", origin=(0.0, 0.0, float(v)))
        areas.append(cut.n_cells)
    pv_wall = time.perf_counter() - t
    pv_cpu = time.process_time() - c
    return {
        "grid": f"faulted ExplicitStructuredGrid {ni}x{nj}x{nk}", "cells": esg.n_cells,
        "make_esg_s": make, "from_pyvista_s": convert, "build_s": build, "structure": grid.structure,
        "stratasweep_slice_calls_wall_sweep_cpu_s": calls,
        "stratasweep_slice_wall_s": wall, "stratasweep_sweep_s": min(c[1] for c in calls),
        "stratasweep_slice_mesh_false_wall_s": nomesh,
        "cut_cells": s.stats["totals"]["cells"],
        "stratasweep_polygons": s.n_polygons,
        "cgraph_slice_wall_s_with_build": cgraph_wall, "cgraph_sweep_s": cg.stats["timings_s"]["sweep"],
        "pyvista_loop_wall_s": pv_wall,
        "pyvista_loop_cpu_s": pv_cpu,
        "stratasweep_slice_cpu_s": cpu,
        "ratio_slice_only_cpu": pv_cpu / cpu,
        "pyvista_cells_out": int(np.sum(areas)),
        "ratio_slice_only": pv_wall / wall,
        "ratio_with_conversion_and_build": pv_wall / (wall + convert + build),
    }


def alternate(n, pairs):
    """Python and CLI sweeps of warped n^3, 200 z levels, one thread,
    alternated: per pair the best sweep_s of 3 Grid.slice(mesh=False) calls
    and the CLI's `bench --repeat 3` sweep_s (its best), on the same grid."""
    grid = stratasweep.generate.warped((n, n, n))
    grid.structure
    out = []
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "w.vts")
        subprocess.run([CLI, "-q", "generate", "warped", "--dims", f"{n},{n},{n}", "-o", path], check=True)
        for _ in range(pairs):
            py = [grid.slice(axis="z", count=200, mesh=False).stats for _ in range(3)]
            b = json.loads(subprocess.run(
                [CLI, "-q", "bench", path, "--axis", "z", "--count", "200", "--repeat", "3",
                 "--no-brute-force", "--json"], check=True, capture_output=True, text=True).stdout)
            p = min(s["timings_s"]["sweep"] for s in py)
            assert py[0]["totals"]["cells"] == b["cut_cells"], (py[0]["totals"], b["cut_cells"])
            out.append({"python_sweep_s": p, "cli_sweep_s": b["sweep_s"], "ratio": p / b["sweep_s"]})
    return {"grid": f"warped {n}^3", "levels": 200, "cut_cells": b["cut_cells"], "pairs": out}


if __name__ == "__main__":
    what = sys.argv[1]
    if what == "overhead":
        print(json.dumps(overhead(int(sys.argv[2])), indent=1))
    elif what == "alternate":
        print(json.dumps(alternate(int(sys.argv[2]), int(sys.argv[3])), indent=1))
    else:
        print(json.dumps(pyvista(*map(int, sys.argv[2:5])), indent=1))
