//! The GPU side of the binary: `slice --device gpu|auto` writes the same
//! statistics as the CPU path, `render` writes a PNG, `bench --device`
//! prints its rows, and bad options are clear errors.

use crate::support;
use crate::support::{json, run, run_ok};

use std::path::{Path, PathBuf};

fn grid(tag: &str) -> PathBuf {
    let g = support::tmp("gpu-cli", &format!("w-{tag}.vts"));
    if !g.exists() {
        run_ok(&[
            "generate",
            "warped",
            "--dims",
            "14,12,10",
            "-o",
            g.to_str().unwrap(),
        ]);
    }
    g
}

fn same_stats(a: &serde_json::Value, b: &serde_json::Value) {
    let (sa, sb) = (
        a["slices"].as_array().unwrap(),
        b["slices"].as_array().unwrap(),
    );
    assert_eq!(sa.len(), sb.len());
    for (x, y) in sa.iter().zip(sb) {
        for k in [
            "index",
            "value",
            "cells",
            "visited",
            "polygons",
            "triangles",
        ] {
            assert_eq!(x[k], y[k], "{k}");
        }
        let (p, q) = (x["area"].as_f64().unwrap(), y["area"].as_f64().unwrap());
        assert!((p - q).abs() <= 1e-5 * p.abs(), "area {p} vs {q}");
    }
}

/// A faulted corner-point deck: pinched cells are split into convex pieces,
/// which every device must count once, as input cells.
fn faulted(tag: &str) -> PathBuf {
    let g = support::tmp("gpu-cli", &format!("f-{tag}.grdecl"));
    if !g.exists() {
        let g = g.to_str().unwrap();
        run_ok(&[
            "generate", "faulted", "--dims", "12,10,6", "--faults", "2", "--seed", "3", "-o", g,
        ]);
    }
    g
}

#[test]
fn slice_stats_are_the_same_on_every_device() {
    let w = grid("stats");
    let f = faulted("stats");
    for (i, (g, extra)) in [
        (&w, vec!["--axis", "z", "--count", "20"]),
        (&w, vec!["--property", "f", "--values", "0.2:0.8:0.15"]),
        (&f, vec!["--axis", "z", "--count", "9"]),
        (
            &f,
            vec!["--axis", "x", "--count", "7", "--structure", "cgraph"],
        ),
    ]
    .iter()
    .enumerate()
    {
        let cpu = support::tmp("gpu-cli", &format!("cpu{i}.json"));
        let mut a = vec!["slice", g.to_str().unwrap()];
        a.extend(extra);
        let with = |dev: &str, out: &Path| {
            let mut v = a.clone();
            v.extend(["--device", dev, "--stats", out.to_str().unwrap()]);
            v.iter().map(|s| s.to_string()).collect::<Vec<_>>()
        };
        let args = with("cpu", &cpu);
        run_ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
        // auto always works (GPU, or the CPU without an adapter).
        let auto = support::tmp("gpu-cli", &format!("auto{i}.json"));
        let args = with("auto", &auto);
        run_ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
        same_stats(&json(&cpu), &json(&auto));
        if support::gpu("slice --device gpu").is_some() {
            let gp = support::tmp("gpu-cli", &format!("gpu{i}.json"));
            let args = with("gpu", &gp);
            run_ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
            same_stats(&json(&cpu), &json(&gp));
        }
    }
}

#[test]
fn render_and_bench_run() {
    if support::gpu("render_and_bench_run").is_none() {
        return;
    }
    let g = grid("render");
    let g = g.to_str().unwrap();
    let png = support::tmp("gpu-cli", "r.png");
    run_ok(&[
        "render",
        g,
        "-o",
        png.to_str().unwrap(),
        "--size",
        "64x48",
        "--slices",
        "30",
        "--background",
        "transparent",
        "--transfer",
        "magma",
        "--projection",
        "perspective",
    ]);
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    let tf = support::tmp("gpu-cli", "t.json");
    std::fs::write(&tf, r#"{"points":[{"value":0,"color":[1,0,0],"opacity":0.1},{"value":1,"color":[0,0,1],"opacity":0.5}]}"#).unwrap();
    run_ok(&[
        "render",
        g,
        "-o",
        png.to_str().unwrap(),
        "--size",
        "40x40",
        "--transfer",
        tf.to_str().unwrap(),
        "--view-dir",
        "0,0,-1",
        "--up",
        "0,1,0",
        "--mode",
        "slices",
        "--slices",
        "10",
    ]);
    run_ok(&[
        "render",
        g,
        "-o",
        png.to_str().unwrap(),
        "--size",
        "40x40",
        "--mode",
        "iso",
        "--iso",
        "0.4,0.6",
    ]);
    let out = run_ok(&[
        "bench", g, "--axis", "z", "--count", "20", "--device", "cpu,gpu", "--repeat", "1",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let rows = v["rows"].as_array().unwrap();
    assert!(rows.len() >= 4);
    let cuts: Vec<_> = rows.iter().map(|r| r["cut_cells"].clone()).collect();
    assert!(
        cuts.windows(2).all(|w| w[0] == w[1]),
        "rows disagree on cut cells: {cuts:?}"
    );
    let tris: Vec<_> = rows.iter().map(|r| r["triangles"].clone()).collect();
    assert!(
        tris.windows(2).all(|w| w[0] == w[1]),
        "rows disagree on triangles: {tris:?}"
    );
    assert!(v["adapter"].is_string());
}

#[test]
fn bad_gpu_options_are_clear_errors() {
    let g = grid("bad");
    let g = g.to_str().unwrap();
    let png = support::tmp("gpu-cli", "bad.png");
    let ply = support::tmp("gpu-cli", "bad.ply");
    let p = png.to_str().unwrap();
    for (args, want) in [
        (vec!["render", g, "-o", p, "--size", "0x10"], "--size"),
        (
            vec!["render", g, "-o", p, "--background", "1,2"],
            "--background",
        ),
        (vec!["render", g, "-o", p, "--mode", "iso"], "--iso"),
        (
            vec!["render", g, "-o", p, "--transfer", "/nonexistent.json"],
            "transfer",
        ),
        (
            vec![
                "slice",
                g,
                "--axis",
                "z",
                "--count",
                "3",
                "--device",
                "gpu",
                "-o",
                ply.to_str().unwrap(),
            ],
            "--device cpu",
        ),
        (
            vec![
                "slice",
                g,
                "--axis",
                "z",
                "--count",
                "3",
                "--device",
                "gpu",
                "--adapter",
                "no-such-adapter-xyz",
            ],
            "mesa-vulkan-drivers",
        ),
        (vec!["bench", g, "--device", "tpu"], "--device tpu"),
    ] {
        let (ok, _, err) = run(&args);
        assert!(!ok, "{args:?} should fail");
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
        assert!(err.contains(want), "{args:?}: '{want}' not in: {err}");
    }
}
