//! Transfer functions over the data's range: the lookup table the shader
//! reads (decoded here as `transfer` in `wgsl/shared/draw.wgsl` reads it) equals
//! `Transfer::eval` over the data, with a control point far outside the
//! data, a narrow spike inside it and values near ±f64::MAX; rendered
//! images (llvmpipe) keep the colours and the spike; JSON errors are
//! readable; the checks shared by the CLI and Python refuse transfer
//! functions that draw nothing and warn when one lies outside the data;
//! the CLI names bad `--transfer` values, ignored `--iso`/`--preintegrated`
//! and bad `WGPU_BACKEND` values.

use crate::support;

use stratasweep::gpu::render::checks::{check_modes, check_options};
use stratasweep::gpu::render::transfer::LUT_KNOTS;
use stratasweep::gpu::render::{
    Mode, RenderError, RenderOptions, Renderer, Transfer, TransferSource,
};
use stratasweep::grid::{Grid, Property, Topology};
use stratasweep::structures::{Structure, StructureChoice};

/// The shader's lookup (`transfer` in `wgsl/shared/draw.wgsl`) on the host, in
/// f32 as on the GPU.
fn lut_eval(lut: &[[f32; 4]], v: f32) -> [f32; 4] {
    let n = lut[0][0] as usize;
    let pos = |i: usize| lut[1 + LUT_KNOTS + i / 4][i % 4];
    if n == 0 || v.is_nan() {
        return [0.0; 4];
    }
    if v <= pos(0) {
        return lut[1];
    }
    if v >= pos(n - 1) {
        return lut[n];
    }
    let (mut lo, mut hi) = (0, n - 1);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if pos(mid) <= v { lo = mid } else { hi = mid }
    }
    let (a, b) = (pos(lo), pos(hi));
    let f = ((0.5 * v - 0.5 * a) / (0.5 * b - 0.5 * a)).clamp(0.0, 1.0);
    std::array::from_fn(|c| lut[1 + lo][c] + f * (lut[1 + hi][c] - lut[1 + lo][c]))
}

fn close(a: [f32; 4], b: [f32; 4], tol: f32) -> bool {
    a.iter().zip(&b).all(|(x, y)| (x - y).abs() <= tol)
}

/// Red at 0 to blue at 1, opaque, with a third point at `far`.
fn red_blue_far(far: f64) -> Transfer {
    Transfer::from_json(&format!(
        r#"{{"points":[{{"value":0,"color":[1,0,0],"opacity":1}},{{"value":1,"color":[0,0,1],"opacity":1}},
                       {{"value":{far},"color":[0,1,0],"opacity":1}}]}}"#
    ))
    .unwrap()
}

/// Transparent everywhere but a spike of width 2e-5 at 0.5003.
fn spike() -> Transfer {
    Transfer::from_json(
        r#"{"points":[{"value":0,"color":[0,0,0],"opacity":0},{"value":0.50029,"color":[0,0,0],"opacity":0},
                      {"value":0.5003,"color":[1,0,0],"opacity":1},{"value":0.50031,"color":[0,0,0],"opacity":0},
                      {"value":1,"color":[0,0,0],"opacity":0}]}"#,
    )
    .unwrap()
}

#[test]
fn a_far_control_point_leaves_red_to_blue_over_the_data() {
    let t = red_blue_far(1000.0);
    let (lut, lo, hi) = t.lut(0.0, 1.0);
    assert_eq!((lo, hi), (0.0, 1.0));
    for i in 0..=100 {
        let v = i as f64 / 100.0;
        let got = lut_eval(&lut, v as f32);
        let want = [1.0 - v as f32, 0.0, v as f32, 1.0];
        assert!(close(got, want, 1e-5), "at {v}: {got:?}, want {want:?}");
    }
}

#[test]
fn a_narrow_spike_inside_the_data_survives_in_the_table() {
    let t = spike();
    let (lut, _, _) = t.lut(0.0, 1.0);
    let peak = lut_eval(&lut, 0.5003_f64 as f32);
    assert!(peak[3] > 0.99 && peak[0] > 0.99, "{peak:?}");
    assert_eq!(lut_eval(&lut, 0.4)[3], 0.0);
    assert_eq!(lut_eval(&lut, 0.6)[3], 0.0);
}

#[test]
fn values_near_f64_max_give_finite_colours() {
    // Control points near ±f64::MAX, data in 0..1: the middle of the map.
    let t = Transfer::from_json(
        r#"{"points":[{"value":-1.7e308,"color":[1,0,0],"opacity":1},{"value":1.7e308,"color":[0,0,1],"opacity":1}]}"#,
    )
    .unwrap();
    let (lut, _, _) = t.lut(0.0, 1.0);
    let c = lut_eval(&lut, 0.5);
    assert!(close(c, [0.5, 0.0, 0.5, 1.0], 1e-6), "{c:?}");
    // Data near ±f64::MAX (infinite in f32) under a colormap and under
    // that transfer function: every lookup is a finite colour, the ends
    // and the middle as Transfer::eval gives them.
    for t in [
        Transfer::named("viridis", -1e308, 1e308).unwrap(),
        t.clone(),
    ] {
        for (lo, hi) in [
            (-1e308, 1e308),
            (-f64::MAX, f64::MAX),
            (f64::NEG_INFINITY, f64::INFINITY),
        ] {
            let (lut, vlo, vhi) = t.lut(lo, hi);
            assert!(vlo.is_finite() && vhi.is_finite() && vlo < vhi);
            for v in [
                f32::NEG_INFINITY,
                -3e38,
                -1.0,
                0.0,
                1.0,
                3e38,
                f32::INFINITY,
            ] {
                let c = lut_eval(&lut, v);
                assert!(c.iter().all(|x| x.is_finite()), "{v}: {c:?}");
            }
            let mid = lut_eval(&lut, 0.0);
            let want = t.eval(0.0);
            assert!(
                close(mid, want, 1e-6),
                "({lo}, {hi}) at 0: {mid:?}, want {want:?}"
            );
        }
        assert!(t.eval(1e308).iter().all(|x| x.is_finite()));
    }
    let named = Transfer::named("viridis", -1e308, 1e308).unwrap();
    assert!(named.points.iter().all(|p| p.value.is_finite()));
}

/// 3 × 1 × 1 cells along x with cell property `c` = `values`.
fn row(values: [f64; 3]) -> Grid {
    let mut points = Vec::new();
    for k in 0..2 {
        for j in 0..2 {
            for i in 0..4 {
                points.push([i as f64, j as f64, k as f64 * 0.5]);
            }
        }
    }
    Grid {
        points,
        topology: Topology::Structured { dims: [4, 2, 2] },
        point_data: Vec::new(),
        cell_data: vec![Property::scalar("c", values.to_vec())],
    }
}

fn opts(t: Option<Transfer>) -> RenderOptions {
    RenderOptions {
        property: Some("c".into()),
        slices: 20,
        view_dir: [0.0, 0.0, -1.0],
        up: Some([0.0, 1.0, 0.0]),
        transfer: t,
        unit_distance: Some(0.01),
        background: Some([1.0, 1.0, 1.0, 1.0]),
        size: (90, 30),
        mode: Mode::Slices,
        ..Default::default()
    }
}

/// Straight RGBA at the centre of cell `i` of [`row`] in the image.
fn cell_colour(img: &stratasweep::gpu::render::Image, i: u32) -> [u8; 4] {
    let rgba = img.rgba8();
    let (x, y) = (img.width * (2 * i + 1) / 6, img.height / 2);
    let o = 4 * (y * img.width + x) as usize;
    [rgba[o], rgba[o + 1], rgba[o + 2], rgba[o + 3]]
}

#[test]
fn rendered_far_point_spike_and_huge_values() {
    let Some(ctx) = support::gpu("rendered_far_point_spike_and_huge_values") else {
        return;
    };
    let mut r = Renderer::new(ctx).unwrap();
    // A far control point: the cells at 0, 0.5 and 1 are red, purple, blue.
    let g = row([0.0, 0.5, 1.0]);
    let s = Structure::build(&g, StructureChoice::Auto).unwrap();
    let img = r.render(&g, &s, &opts(Some(red_blue_far(1000.0)))).unwrap();
    let got: Vec<[u8; 4]> = (0..3).map(|i| cell_colour(&img, i)).collect();
    eprintln!("far control point: {got:?}");
    for (c, want) in got.iter().zip([[255, 0, 0], [128, 0, 128], [0, 0, 255]]) {
        assert!(
            (0..3).all(|k| (c[k] as i32 - want[k]).abs() <= 2),
            "{got:?}"
        );
    }
    // A spike inside the data: the middle cell (value 0.5003) is drawn red,
    // the others (0 and 1, transparent) leave the white background.
    let g = row([0.0, 0.5003, 1.0]);
    let s = Structure::build(&g, StructureChoice::Auto).unwrap();
    let img = r.render(&g, &s, &opts(Some(spike()))).unwrap();
    let got: Vec<[u8; 4]> = (0..3).map(|i| cell_colour(&img, i)).collect();
    eprintln!("spike: {got:?}");
    assert_eq!(got[0], [255, 255, 255, 255]);
    assert_eq!(got[2], [255, 255, 255, 255]);
    assert!(got[1][0] > 250 && got[1][1] < 5 && got[1][2] < 5, "{got:?}");
    // Values near ±f64::MAX (infinite in f32): the ends and the middle of
    // the map, never black, under an opaque viridis whose points are near
    // ±f64::MAX too, and under the default colormap (transparent at the
    // low end).
    let g = row([-1e308, 0.0, 1e308]);
    let s = Structure::build(&g, StructureChoice::Auto).unwrap();
    let mut opaque = Transfer::named("viridis", -1.7e308, 1.7e308).unwrap();
    for p in &mut opaque.points {
        p.opacity = 1.0;
    }
    let v = Transfer::named("viridis", 0.0, 1.0).unwrap();
    for t in [Some(opaque), None] {
        let transparent_low = t.is_none();
        let mut o = opts(t);
        o.unit_distance = None;
        let img = r.render(&g, &s, &o).unwrap();
        assert!(img.premultiplied.iter().flatten().all(|x| x.is_finite()));
        let got: Vec<[u8; 4]> = (0..3).map(|i| cell_colour(&img, i)).collect();
        eprintln!("±1e308: {got:?}");
        for (c, x) in got.iter().zip([0.0, 0.5, 1.0]) {
            // 20 slices of opacity 0.5 or more composite to opaque.
            let want = match transparent_low && x == 0.0 {
                true => [255; 4],
                false => v.eval(x).map(|k| (k * 255.0).round() as i32),
            };
            assert!(
                (0..3).all(|k| (c[k] as i32 - want[k]).abs() <= 3),
                "{got:?}: cell at {x} wants {want:?}"
            );
        }
    }
}

#[test]
fn transfer_functions_that_draw_nothing_are_refused_by_the_library() {
    let g = row([0.0, 0.5, 1.0]);
    let refuse = |json: &str, mode: Mode| {
        let mut o = opts(Some(Transfer::from_json(json).unwrap()));
        o.mode = mode;
        if mode == Mode::Iso {
            o.iso = vec![0.5];
        }
        check_options(&g, &o, false)
    };
    let empty = refuse(r#"{"points":[]}"#, Mode::Volume).unwrap_err();
    assert!(empty.to_string().contains("no points"), "{empty}");
    let clear = r#"{"points":[{"value":0,"color":[1,0,0],"opacity":0},{"value":1,"color":[1,0,0],"opacity":0}]}"#;
    let e = refuse(clear, Mode::Slices).unwrap_err();
    assert!(e.to_string().contains("opacity 0"), "{e}");
    // Iso surfaces are opaque: opacity is not used there.
    assert!(refuse(clear, Mode::Iso).unwrap().is_empty());
    // Opaque only above the data: transparent over it.
    let above = r#"{"points":[{"value":1.5,"color":[1,0,0],"opacity":0},{"value":2,"color":[1,0,0],"opacity":1}]}"#;
    let e = refuse(above, Mode::Volume).unwrap_err();
    assert!(
        e.to_string()
            .contains("opacity 0 over the whole range of property 'c' (0 .. 1)"),
        "{e}"
    );
    // Wholly outside but opaque where the data are: drawn, with a warning.
    let high = r#"{"points":[{"value":5,"color":[1,0,0],"opacity":1},{"value":6,"color":[0,0,1],"opacity":1}]}"#;
    let w = refuse(high, Mode::Volume).unwrap();
    assert_eq!(w.len(), 1);
    assert!(
        w[0].contains("wholly outside") && w[0].contains("(0 .. 1)") && w[0].contains("point at 5"),
        "{w:?}"
    );
    // Inside: no warning.
    assert!(
        refuse(&red_blue_far(3.0).to_json_for_test(), Mode::Volume)
            .unwrap()
            .is_empty()
    );
}

/// JSON of a transfer function (for the test above).
trait ToJson {
    fn to_json_for_test(&self) -> String;
}

impl ToJson for Transfer {
    fn to_json_for_test(&self) -> String {
        let p: Vec<String> = self
            .points
            .iter()
            .map(|p| {
                format!(
                    r#"{{"value":{},"color":[{},{},{}],"opacity":{}}}"#,
                    p.value, p.color[0], p.color[1], p.color[2], p.opacity
                )
            })
            .collect();
        format!(r#"{{"points":[{}]}}"#, p.join(","))
    }
}

#[test]
fn the_renderer_refuses_an_empty_transfer_function() {
    let Some(ctx) = support::gpu("the_renderer_refuses_an_empty_transfer_function") else {
        return;
    };
    let g = row([0.0, 0.5, 1.0]);
    let s = Structure::build(&g, StructureChoice::Auto).unwrap();
    let mut r = Renderer::new(ctx).unwrap();
    let o = opts(Some(Transfer::from_json(r#"{"points":[]}"#).unwrap()));
    match r.render(&g, &s, &o) {
        Err(RenderError::Transfer(e)) => assert!(e.to_string().contains("no points")),
        other => panic!("{:?}", other.map(|_| ())),
    }
}

#[test]
fn options_the_mode_ignores_are_refused() {
    let mut o = opts(None);
    o.mode = Mode::Volume;
    o.iso = vec![0.5];
    let e = check_modes(&o, false).unwrap_err().to_string();
    assert!(e.contains("isovalues") && e.contains("volume"), "{e}");
    o.iso.clear();
    assert!(check_modes(&o, true).is_ok());
    o.mode = Mode::Slices;
    let e = check_modes(&o, true).unwrap_err().to_string();
    assert!(e.contains("pre-integration") && e.contains("slices"), "{e}");
}

#[test]
fn json_errors_are_readable() {
    let err = |s: &str| Transfer::from_json(s).unwrap_err().to_string();
    // A byte-order mark is skipped.
    let t =
        Transfer::from_json("\u{feff}{\"points\":[{\"value\":0,\"color\":[1,0,0],\"opacity\":1}]}")
            .unwrap();
    assert_eq!(t.points.len(), 1);
    // Four colour components: named as such, with the opacity field.
    let e = err(
        r#"{"points":[{"value":0,"color":[1,0,0],"opacity":1},{"value":1,"color":[1,0,0,0.5],"opacity":1}]}"#,
    );
    assert!(
        e.contains("point 1") && e.contains("4 components") && e.contains("\"opacity\""),
        "{e}"
    );
    assert!(!e.contains("trailing"), "{e}");
    // Out of range: the point and field, no Rust structure.
    let e = err(r#"{"points":[{"value":0,"color":[1.5,0,0],"opacity":1}]}"#);
    assert!(
        e.contains("point 0") && e.contains("color[0] (red)") && e.contains("1.5"),
        "{e}"
    );
    for e in [
        e,
        err(r#"{"points":[{"value":0,"color":[1,0,0],"opacity":2}]}"#),
        err(r#"{"points":[{"value":0,"color":[1,0,0]}]}"#),
        err(r#"{"points":[{"value":"a","color":[1,0,0],"opacity":1}]}"#),
        err(r#"{"points":{}}"#),
        err(r#"[1, 2]"#),
        err(r#"{"points":[{"value":0,"color":[1,0,0],"opacity":1},]}"#),
    ] {
        eprintln!("{e}");
        assert!(
            !e.contains("TransferPoint") && !e.contains("{ value"),
            "{e}"
        );
    }
    assert!(err(r#"{"points":[{"value":0,"color":[1,0,0]}]}"#).contains("no \"opacity\""));
    assert!(err("{\"points\":[\n{]}").contains("line 2"));
    // A name that is neither a colormap nor a .json path.
    assert_eq!(
        TransferSource::parse("viridis").unwrap(),
        TransferSource::Colormap("viridis".into())
    );
    assert_eq!(
        TransferSource::parse("a/TF.JSON").unwrap(),
        TransferSource::File("a/TF.JSON".into())
    );
    let e = TransferSource::parse("tf.txt").unwrap_err().to_string();
    assert!(
        e.contains("colormap") && e.contains("viridis") && e.contains(".json"),
        "{e}"
    );
}

/// Runs the CLI with `args` (and `env`), returning (success, stderr).
fn cli(args: &[&str], env: &[(&str, &str)]) -> (bool, String) {
    let mut c = support::bin();
    c.args(args).env("NODEVICE_SELECT", "1");
    for (k, v) in env {
        c.env(k, v);
    }
    let out = c.output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn the_cli_names_bad_transfer_values_and_ignored_options() {
    let png = support::tmp("transfer", "x.png");
    let png = png.to_str().unwrap();
    let base = [
        "render", "--demo", "-o", png, "--size", "32x24", "--slices", "4",
    ];
    let run = |extra: &[&str]| {
        let mut a = base.to_vec();
        a.extend_from_slice(extra);
        cli(&a, &[])
    };
    // A transfer file not named .json: refused naming both possibilities
    // (and that the file exists), before anything is written.
    let txt = support::tmp("transfer", "tf.txt");
    std::fs::write(
        &txt,
        r#"{"points":[{"value":0,"color":[1,0,0],"opacity":1}]}"#,
    )
    .unwrap();
    let (ok, err) = run(&["--transfer", txt.to_str().unwrap()]);
    assert!(!ok, "{err}");
    assert!(
        err.contains("neither a colormap name") && err.contains(".json") && err.contains("exists"),
        "{err}"
    );
    assert!(!std::path::Path::new(png).exists());
    // BOM and a four-component colour.
    let json = support::tmp("transfer", "tf.json");
    std::fs::write(
        &json,
        "\u{feff}{\"points\":[{\"value\":0,\"color\":[1,0,0,1],\"opacity\":1}]}",
    )
    .unwrap();
    let (ok, err) = run(&["--transfer", json.to_str().unwrap()]);
    assert!(
        !ok && err.contains("4 components") && err.contains("tf.json"),
        "{err}"
    );
    // Ignored options.
    let (ok, err) = run(&["--iso", "0.5"]);
    assert!(
        !ok && err.contains("--iso") && err.contains("isovalues"),
        "{err}"
    );
    let (ok, err) = run(&["--mode", "slices", "--preintegrated"]);
    assert!(!ok && err.contains("pre-integration"), "{err}");
    // A bad WGPU_BACKEND: named, with the valid names.
    let (ok, err) = cli(&base, &[("WGPU_BACKEND", "foo")]);
    assert!(!ok, "{err}");
    assert!(
        err.contains("'foo' is not a backend name")
            && err.contains("vulkan")
            && !err.contains("Install a Vulkan driver"),
        "{err}"
    );
}

#[test]
fn the_cli_warns_when_the_transfer_function_lies_outside_the_data() {
    let Some(_) = support::gpu("the_cli_warns_when_the_transfer_function_lies_outside_the_data")
    else {
        return;
    };
    let png = support::tmp("transfer", "far.png");
    let json = support::tmp("transfer", "far.json");
    // The demo's f lies in 0..1.
    std::fs::write(
        &json,
        r#"{"points":[{"value":5,"color":[1,0,0],"opacity":1},{"value":6,"color":[0,0,1],"opacity":1}]}"#,
    )
    .unwrap();
    let (ok, err) = cli(
        &[
            "render",
            "--demo",
            "-o",
            png.to_str().unwrap(),
            "--size",
            "32x24",
            "--slices",
            "4",
            "--transfer",
            json.to_str().unwrap(),
        ],
        &[],
    );
    assert!(ok, "{err}");
    assert!(
        err.contains("warning") && err.contains("wholly outside"),
        "{err}"
    );
    let clear = support::tmp("transfer", "clear.json");
    std::fs::write(
        &clear,
        r#"{"points":[{"value":5,"color":[1,0,0],"opacity":0},{"value":6,"color":[0,0,1],"opacity":1}]}"#,
    )
    .unwrap();
    let out = support::tmp("transfer", "clear.png");
    let (ok, err) = cli(
        &[
            "render",
            "--demo",
            "-o",
            out.to_str().unwrap(),
            "--size",
            "32x24",
            "--slices",
            "4",
            "--transfer",
            clear.to_str().unwrap(),
        ],
        &[],
    );
    assert!(!ok && err.contains("nothing would be drawn"), "{err}");
    assert!(!out.exists());
}
