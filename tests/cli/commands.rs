//! End-to-end tests of the `stratasweep` binary: JSON keys, stats, thread
//! invariance of the output files, generators, and clear errors on bad input.

use crate::support;
use crate::support::{bin, json, run_err, run_ok};

#[test]
fn info_json_has_the_documented_keys() {
    let out = run_ok(&["info", "--demo", "--json"]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["vertices"], 65 * 65 * 65);
    assert_eq!(v["cells"], 64 * 64 * 64);
    assert_eq!(v["cell_types"]["hexahedron"], 64 * 64 * 64);
    let mem = v["memory_bytes"].as_object().unwrap();
    let parts: u64 = mem
        .iter()
        .filter(|(k, _)| *k != "total")
        .map(|(_, x)| x.as_u64().unwrap())
        .sum();
    assert_eq!(parts, mem["total"].as_u64().unwrap());
    // S-CGraph with one f32 property and the stamps: at most 20 B per vertex.
    assert!(
        v["bytes_per_vertex"].as_f64().unwrap() <= 20.0,
        "{}",
        v["bytes_per_vertex"]
    );
}

#[test]
fn slice_stats_match_between_structures_and_threads() {
    let grid = support::tmp("cli", "zoo.vtu");
    run_ok(&[
        "generate",
        "zoo",
        "--cells",
        "3000",
        "--seed",
        "3",
        "-o",
        grid.to_str().unwrap(),
    ]);
    let mut all = Vec::new();
    for (structure, threads) in [("cgraph", "1"), ("cgraph", "2"), ("bruteforce", "1")] {
        let stats = support::tmp("cli", &format!("zoo-{structure}-{threads}.json"));
        let out = support::tmp("cli", &format!("zoo-{structure}-{threads}.vtp"));
        run_ok(&[
            "slice",
            grid.to_str().unwrap(),
            "--property",
            "f",
            "--count",
            "12",
            "--structure",
            structure,
            "--threads",
            threads,
            "--stats",
            stats.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        let s = json(&stats);
        for key in ["load", "build", "minima", "sweep"] {
            assert!(s["timings_s"][key].is_number(), "timings_s.{key}");
        }
        assert!(s["memory_bytes"]["total"].as_u64().unwrap() > 0);
        let per: Vec<(u64, u64, u64, f64)> = s["slices"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| {
                (
                    x["cells"].as_u64().unwrap(),
                    x["polygons"].as_u64().unwrap(),
                    x["triangles"].as_u64().unwrap(),
                    x["area"].as_f64().unwrap(),
                )
            })
            .collect();
        assert_eq!(per.len(), 12);
        assert!(per.iter().map(|p| p.1).sum::<u64>() > 100);
        all.push((per, std::fs::read(&out).unwrap()));
    }
    for (per, file) in &all[1..] {
        for (a, b) in per.iter().zip(&all[0].0) {
            assert_eq!((a.0, a.1, a.2), (b.0, b.1, b.2));
            assert!((a.3 - b.3).abs() <= 1e-9 * b.3.max(1e-30));
        }
        assert_eq!(file, &all[0].1, "output files must be identical");
    }
}

#[test]
fn slice_writes_ply_and_axis_variants() {
    let ply = support::tmp("cli", "demo.ply");
    for axis in ["x", "-y", "z", "-z"] {
        run_ok(&[
            "slice",
            "--demo",
            "--axis",
            axis,
            "--count",
            "5",
            "-o",
            ply.to_str().unwrap(),
        ]);
        let bytes = std::fs::read(&ply).unwrap();
        assert!(bytes.starts_with(b"ply\nformat binary_little_endian 1.0\n"));
    }
    let stats = support::tmp("cli", "normal.json");
    run_ok(&[
        "slice",
        "--demo",
        "--normal",
        "1,1,0",
        "--values",
        "-1:1:0.5",
        "--stats",
        stats.to_str().unwrap(),
    ]);
    assert!(!json(&stats)["slices"].as_array().unwrap().is_empty());
}

#[test]
fn bad_inputs_give_errors_naming_the_problem() {
    let bad = support::tmp("cli", "bad.vtk");
    std::fs::write(&bad, "# vtk DataFile Version 3.0\nbad\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 0 0\n").unwrap();
    let e = run_err(&["info", bad.to_str().unwrap()]);
    assert_eq!(
        e.matches(bad.to_str().unwrap()).count(),
        1,
        "named once: {e}"
    );
    let e = run_err(&[
        "slice",
        "/nonexistent/grid.vtu",
        "--axis",
        "z",
        "--count",
        "3",
    ]);
    assert!(e.contains("grid.vtu"), "{e}");
    let e = run_err(&["slice", "--demo", "--axis", "w", "--count", "3"]);
    assert!(e.contains("--axis"), "{e}");
    let e = run_err(&["slice", "--demo", "--property", "nope", "--count", "3"]);
    assert!(e.contains("nope"), "{e}");
    let e = run_err(&["slice", "--demo", "--axis", "z", "--values", "3:1:1"]);
    assert!(e.contains("--values"), "{e}");
    let e = run_err(&[
        "slice", "--demo", "--axis", "z", "--count", "3", "-o", "x.obj",
    ]);
    assert!(e.contains(".ply"), "{e}");
    let e = run_err(&["generate", "warped", "--dims", "2,0,3", "-o", "x.vts"]);
    assert!(e.contains("--dims"), "{e}");
}

#[test]
fn bench_reports_figures() {
    let out = run_ok(&[
        "bench", "--demo", "--axis", "z", "--count", "20", "--repeat", "1", "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(v["sweep_cut_cells_per_s"].as_f64().unwrap() > 0.0);
    assert!(v["speedup_vs_brute_force"].as_f64().unwrap() > 0.0);
    assert!(v["cut_cells"].as_u64().unwrap() > 0);
}

#[test]
fn corner_point_generate_info_and_slice() {
    let g = support::tmp("cli", "faulted.grdecl");
    let gs = g.to_str().unwrap();
    run_ok(&[
        "generate", "faulted", "--dims", "20,15,8", "--faults", "2", "--seed", "4", "-o", gs,
    ]);
    let v: serde_json::Value = serde_json::from_str(&run_ok(&["info", "--json", gs])).unwrap();
    let bv = v["bulk_volume"].as_f64().unwrap();
    assert!(bv > 0.0);
    let c = &v["cornerpoint"]["classes"];
    assert_eq!(
        c["active"].as_u64().unwrap() + c["inactive"].as_u64().unwrap(),
        20 * 15 * 8
    );
    assert!(c["wedges"].as_u64().unwrap() > 0);
    assert_eq!(v["cell_properties"][0], "PORO");
    // Isosurfaces of PORO averaged to vertices, and flat per-cell colours.
    let o = support::tmp("cli", "poro.vtp");
    run_ok(&[
        "slice",
        gs,
        "--property",
        "PORO",
        "--at",
        "vertices",
        "--count",
        "4",
        "-o",
        o.to_str().unwrap(),
    ]);
    let o = support::tmp("cli", "flat.ply");
    run_ok(&[
        "slice",
        gs,
        "--axis",
        "z",
        "--count",
        "10",
        "--attribute",
        "PORO",
        "--at",
        "cells",
        "-o",
        o.to_str().unwrap(),
    ]);
    let e = run_err(&[
        "slice",
        gs,
        "--axis",
        "z",
        "--count",
        "10",
        "--at",
        "cells",
        "-o",
        o.to_str().unwrap(),
    ]);
    assert!(e.contains("--at cells needs a cell property"), "{e}");
    run_ok(&["bench", gs, "--load-only"]);
    // --threads bounds the load and the build (they once ran on every
    // core whatever it said).
    for t in ["1", "3"] {
        let out = run_ok(&["bench", gs, "--load-only", "--threads", t, "--json"]);
        let j: serde_json::Value = serde_json::from_str(&out).unwrap();
        assert_eq!(j["threads"].to_string(), t, "{out}");
        // The build's stages, in order, fit inside the build's time.
        let st = j["build_stages"].as_object().expect("build_stages");
        let names: Vec<&str> = st.keys().map(|k| k.as_str()).collect();
        assert_eq!(names, ["graph_s", "split_s", "validate_s"], "{out}");
        let sum: f64 = st.values().map(|v| v.as_f64().unwrap()).sum();
        let build = j["build_s"].as_f64().unwrap();
        assert!(sum > 0.0 && sum <= build, "{sum} against {build}: {out}");
    }
    // A bad GRDECL names file, line and keyword.
    let b = support::tmp("cli", "bad.grdecl");
    std::fs::write(&b, "SPECGRID\n 1 1 1 /\nZCORN\n 7*1 /\n").unwrap();
    let e = run_err(&["info", b.to_str().unwrap()]);
    assert!(
        e.contains("bad.grdecl:3") && e.contains("ZCORN has 7 values, expected 8"),
        "{e}"
    );
    assert_eq!(e.matches(b.to_str().unwrap()).count(), 1, "named once: {e}");
}

/// A missing file is named, and the OS error is printed once (an error that
/// prints its source must not have that source repeated after it).
#[test]
fn missing_file_error_names_it_once() {
    for name in ["missing.grdecl", "missing.vtu", "missing.EGRID"] {
        let p = support::tmp("cli", name);
        let e = run_err(&["info", p.to_str().unwrap()]);
        assert!(e.contains(p.to_str().unwrap()), "{name}: {e}");
        assert_eq!(e.matches("os error 2").count(), 1, "{name}: {e}");
    }
}

/// A reader that stops early (`stratasweep info … | head -1`) ends the
/// command quietly: no panic message about a broken pipe.
#[test]
fn closed_stdout_is_not_a_panic() {
    let grid = support::tmp("cli", "pipe.vts");
    run_ok(&[
        "generate",
        "warped",
        "--dims",
        "24,24,24",
        "-o",
        grid.to_str().unwrap(),
    ]);
    let mut child = bin()
        .args(["info", grid.to_str().unwrap(), "--json"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Close the pipe's read end while the command is still loading the
    // grid, so that its first write meets a closed pipe.
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "stderr: {err}");
}

/// `args` run without `--quiet`: (success, stdout, stderr).
fn run_loud(args: &[&str]) -> (bool, String, String) {
    let o = bin().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).to_string(),
        err,
    )
}

#[test]
fn depths_as_z_values_warn_and_name_the_values_that_cut() {
    let g = support::tmp("cli", "depth.grdecl");
    let gs = g.to_str().unwrap();
    run_ok(&[
        "generate", "faulted", "--dims", "20,15,8", "--faults", "2", "--seed", "4", "-o", gs,
    ]);
    let v: serde_json::Value = serde_json::from_str(&run_ok(&["info", "--json", gs])).unwrap();
    let (zlo, zhi) = (
        v["bounds"]["min"][2].as_f64().unwrap(),
        v["bounds"]["max"][2].as_f64().unwrap(),
    );
    assert!(zhi < 0.0, "the generated reservoir lies below z = 0");
    // Depths inside the reservoir, as a reservoir engineer gives them.
    let (d0, d1) = ((-zhi).ceil(), (-zlo).floor());
    let step = ((d1 - d0) / 4.0).floor();
    let values = format!("{d0}:{}:{step}", d0 + 4.0 * step);
    let out = support::tmp("cli", "depth.ply");
    let stats = support::tmp("cli", "depth.json");
    let (ok, _, err) = run_loud(&[
        "slice",
        gs,
        "--axis",
        "z",
        "--values",
        &values,
        "-o",
        out.to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let w = err
        .lines()
        .find(|l| l.contains("outside z's range"))
        .unwrap_or_else(|| {
            panic!("no warning for levels outside z's range: {err}");
        });
    assert!(w.contains("all 5 levels"), "{w}");
    assert!(w.contains("lie outside z's range"), "{w}");
    assert!(w.contains("z is minus depth"), "{w}");
    let hint = format!(
        "did you mean --values {}:{}:{step}?",
        -(d0 + 4.0 * step),
        -d0
    );
    assert!(w.contains(&hint), "{w} (expected {hint})");
    let st = json(&stats);
    assert_eq!(st["totals"]["polygons"], 0);
    assert_eq!(st["field"], "z", "the field is named, not a Debug struct");
    // The suggested values cut every level, without a warning.
    let neg = format!("{}:{}:{step}", -(d0 + 4.0 * step), -d0);
    let (ok, _, err) = run_loud(&[
        "slice",
        gs,
        "--axis",
        "z",
        &format!("--values={neg}"),
        "--stats",
        stats.to_str().unwrap(),
    ]);
    assert!(ok && !err.contains("outside z's range"), "{err}");
    let st = json(&stats);
    assert!(
        st["slices"]
            .as_array()
            .unwrap()
            .iter()
            .all(|s| s["polygons"].as_u64() > Some(0))
    );
    // Property names: any case, and a suggestion on a miss.
    run_ok(&["slice", gs, "--property", "poro", "--count", "3"]);
    let e = run_err(&["slice", gs, "--property", "PORRO", "--count", "3"]);
    assert!(
        e.contains("no property named 'PORRO': did you mean 'PORO'?"),
        "{e}"
    );
    // bench --load-only prints no Rust Option and no infinite rate.
    let (ok, out, err) = run_loud(&["bench", gs, "--load-only"]);
    assert!(ok, "{err}");
    assert!(!out.contains("Some(") && !out.contains("inf"), "{out}");
}

#[test]
fn repeats_frames_and_clip_boxes_are_checked_with_their_option_named() {
    let e = run_err(&["bench", "--demo", "--repeat", "0"]);
    assert!(e.contains("--repeat must be at least 1 (got 0)"), "{e}");
    let e = run_err(&["bench", "--demo", "--repeat", "1000000"]);
    assert!(
        e.contains("--repeat 1000000 is more than the limit of 1000"),
        "{e}"
    );
    let head = ["view", "--demo", "--headless"];
    let e = run_err(&[&head[..], &["--frames", "4000000000"]].concat());
    assert!(
        e.contains("--frames 4000000000 is more than the limit of 10000"),
        "{e}"
    );
    let e = run_err(&[&head[..], &["--orbit-bench", "100000"]].concat());
    assert!(
        e.contains("--orbit-bench 100000 is more than the limit"),
        "{e}"
    );
    let frames = [&head[..], &["--frames", "1", "--ijk-clip"]].concat();
    for (clip, text) in [
        (
            "0:a,0:4,0:4",
            "--ijk-clip '0:a,0:4,0:4': the I range '0:a': 'a' is not a cell index",
        ),
        ("0:4,0:4", "--ijk-clip '0:4,0:4': 2 range(s) given"),
        ("0:4,5:5,0:4", "the J range 5:5 is empty"),
        ("0:4,0-4,0:4", "the J range '0-4' has no ':'"),
        (
            "100:120,0:4,0:4",
            "--ijk-clip 100:120,0:4,0:4: the box lies outside the grid, whose cells are I 0:64, J 0:64, K 0:64",
        ),
    ] {
        let e = run_err(&[&frames[..], &[clip]].concat());
        assert!(e.contains(text), "{clip}: {e}");
    }
}
