//! `stratasweep view` in a real window: the first frame of `view --frames N
//! --screenshot` equals `render`'s PNG with the same options (mean absolute
//! difference per channel), `--orbit-bench --json` reports its keys over a
//! turn that crosses axis cones, `view` without a display says to use
//! `render`, and `render --legend` changes only the legend's corner. The
//! same frame and bench checks run `--headless` (offscreen, no display).
//!
//! Window tests need a display (X11 or Wayland) and a GPU adapter; without
//! either they skip loudly, unless `STRATASWEEP_REQUIRE_DISPLAY=1` (CI,
//! under `xvfb-run`) or `STRATASWEEP_REQUIRE_GPU=1` makes that a failure.

use crate::support;
use crate::support::{bin, display, run_ok};

use std::path::Path;

/// Decodes an 8-bit RGBA PNG.
fn rgba(p: &Path) -> (u32, u32, Vec<u8>) {
    let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(p).unwrap()));
    let mut r = dec.read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size().unwrap()];
    let info = r.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgba);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

/// Mean absolute difference per channel (8-bit levels).
fn mad(a: &[u8], b: &[u8]) -> [f64; 4] {
    assert_eq!(a.len(), b.len());
    let n = (a.len() / 4) as f64;
    std::array::from_fn(|c| {
        a.iter()
            .zip(b)
            .skip(c)
            .step_by(4)
            .map(|(x, y)| (*x as f64 - *y as f64).abs())
            .sum::<f64>()
            / n
    })
}

const SCENE: [&str; 4] = ["--demo", "--slices", "40", "--quiet"];
const SMALL: [&str; 2] = ["--size", "160x120"];

/// Runs `args` without a display (headless) or as is; panics on failure.
fn run_view(args: &[&str], headless: bool) -> String {
    let mut c = bin();
    c.args(args);
    if headless {
        c.arg("--headless")
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY");
    }
    let o = c.output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success(),
        "{args:?} (headless {headless}) failed: {err}"
    );
    String::from_utf8_lossy(&o.stdout).into()
}

/// `view --frames 1 --screenshot`'s frame (with `extra` options) equals
/// `render`'s PNG.
fn check_first_frame(headless: bool, extra: &[&str]) {
    let tag = match (headless, extra.is_empty()) {
        (false, _) => "window",
        (true, true) => "headless",
        (true, false) => "headless-extra",
    };
    let (r, v) = (
        support::tmp("view", &format!("render-{tag}.png")),
        support::tmp("view", &format!("view-{tag}.png")),
    );
    let z = ["--z-scale", "2"];
    run_ok(
        &[
            &["render"][..],
            &SCENE,
            &SMALL,
            &z,
            &["-o", r.to_str().unwrap()],
        ]
        .concat(),
    );
    run_view(
        &[
            &["view"][..],
            &SCENE,
            &SMALL,
            &z,
            extra,
            &["--frames", "1", "--screenshot", v.to_str().unwrap()],
        ]
        .concat(),
        headless,
    );
    let (a, b) = (rgba(&r), rgba(&v));
    assert_eq!((a.0, a.1), (b.0, b.1));
    let d = mad(&a.2, &b.2);
    eprintln!("{tag}: mean absolute difference per channel: {d:?}");
    assert!(
        d.iter().all(|&x| x <= 0.5),
        "view's first frame ({tag}) differs from render: {d:?}"
    );
    assert!(
        a.2.chunks(4).any(|p| p[0] != 255 || p[1] != 255),
        "render drew nothing"
    );
}

#[test]
fn first_frame_equals_render() {
    if support::gpu("first_frame_equals_render").is_none() || !display("first_frame_equals_render")
    {
        return;
    }
    check_first_frame(false, &[]);
}

#[test]
fn headless_first_frame_equals_render_without_a_display() {
    if support::gpu("headless_first_frame_equals_render").is_none() {
        return;
    }
    check_first_frame(true, &[]);
}

#[test]
fn gpu_binned_first_frame_equals_the_swept_render() {
    if support::gpu("gpu_binned_first_frame_equals_the_swept_render").is_none() {
        return;
    }
    check_first_frame(true, &["--cells", "gpu"]);
}

/// `view --orbit-bench 8 --json` over a turn that crosses axis cones.
fn check_orbit_bench(headless: bool) {
    let out = run_view(
        &[
            &["view"][..],
            &SCENE,
            &SMALL,
            &["--orbit-bench", "8", "--json"],
        ]
        .concat(),
        headless,
    );
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    for k in [
        "frames",
        "frame_ms_p50",
        "frame_ms_p95",
        "frame_ms_max",
        "resweeps",
        "resweep_ms_max",
        "cut_cells_per_frame",
        "adapter",
    ] {
        assert!(j.get(k).is_some(), "missing key {k} in {j}");
    }
    assert_eq!(j["frames"], 8);
    assert_eq!(j["headless"], headless);
    let (p50, p95, max) = (
        j["frame_ms_p50"].as_f64().unwrap(),
        j["frame_ms_p95"].as_f64().unwrap(),
        j["frame_ms_max"].as_f64().unwrap(),
    );
    assert!(0.0 < p50 && p50 <= p95 && p95 <= max);
    // Eight views 45° apart from (−1, −0.6, −0.8) alternate between the x and y
    // cones: at least one re-sweep finishes within the turn.
    assert!(j["resweeps"].as_u64().unwrap() >= 1, "{j}");
    assert!(j["cut_cells_per_frame"].as_f64().unwrap() > 0.0);
}

#[test]
fn orbit_bench_reports_its_keys_over_a_turn() {
    if support::gpu("orbit_bench_reports_its_keys").is_none()
        || !display("orbit_bench_reports_its_keys")
    {
        return;
    }
    check_orbit_bench(false);
}

#[test]
fn headless_orbit_bench_reports_its_keys_without_a_display() {
    if support::gpu("headless_orbit_bench_reports_its_keys").is_none() {
        return;
    }
    check_orbit_bench(true);
}

#[test]
fn headless_without_a_script_is_a_clear_error() {
    let o = bin()
        .args(["view", "--demo", "--headless"])
        .env_remove("DISPLAY")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("--frames N or --orbit-bench N"), "{err}");
}

#[test]
fn view_without_display_suggests_render() {
    let o = bin()
        .args(["view", "--demo"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("DISPLAY") && err.contains("stratasweep render"),
        "{err}"
    );
}

#[test]
fn bad_ijk_clip_is_a_clear_error() {
    if !display("bad_ijk_clip_is_a_clear_error") {
        return;
    }
    let o = bin()
        .args([
            "view",
            "--demo",
            "--ijk-clip",
            "5:2,0:1,0:1",
            "--frames",
            "1",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("--ijk-clip '5:2,0:1,0:1'"), "{err}");
}

#[test]
fn render_legend_draws_in_its_corner_only() {
    if support::gpu("render_legend_draws_in_its_corner_only").is_none() {
        return;
    }
    let (plain, legend) = (
        support::tmp("view", "plain.png"),
        support::tmp("view", "legend.png"),
    );
    let size = ["--size", "400x300"];
    run_ok(
        &[
            &["render"][..],
            &SCENE,
            &size,
            &["-o", plain.to_str().unwrap()],
        ]
        .concat(),
    );
    run_ok(
        &[
            &["render"][..],
            &SCENE,
            &size,
            &["--legend", "-o", legend.to_str().unwrap()],
        ]
        .concat(),
    );
    let (a, b) = (rgba(&plain).2, rgba(&legend).2);
    let (w, h) = (400usize, 300usize);
    let mut inside = 0;
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) * 4;
            let same = a[i..i + 4] == b[i..i + 4];
            // The legend card: 260 × 74 points, 10 from the bottom-right corner.
            let card = x >= w - 272 && y >= h - 86;
            if card {
                inside += !same as usize;
            } else {
                assert!(same, "pixel ({x}, {y}) changed outside the legend");
            }
        }
    }
    assert!(
        inside > 260 * 74 / 2,
        "the legend changed only {inside} pixels"
    );
}
