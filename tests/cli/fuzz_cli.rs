//! Property tests over the command line (issue 17): random level specs,
//! thread counts, slice counts and image sizes for `slice` and `render`.
//! Every run must end within a bound, by exiting 0, 1 or 2 (never a signal:
//! no abort, no out-of-memory kill), without a panic. Case counts are kept
//! small: each case runs the binary.

use std::path::PathBuf;
use std::process::Stdio;
use std::sync::OnceLock;
use std::time::Duration;

use crate::support;

use proptest::prelude::*;

/// Wall-clock bound per run (generous for a loaded 2-core CI machine).
const BOUND: Duration = Duration::from_secs(30);

/// A one-cell legacy VTK grid with point property f, written once.
fn grid() -> &'static PathBuf {
    static G: OnceLock<PathBuf> = OnceLock::new();
    G.get_or_init(|| {
        let p = support::tmp("fuzz-cli", "cube.vtk");
        std::fs::write(
            &p,
            "# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_GRID\nDIMENSIONS 2 2 2\nPOINTS 8 double\n\
             0 0 0 1 0 0 0 1 0 1 1 0 0 0 1 1 0 1 0 1 1 1 1 1\nPOINT_DATA 8\nSCALARS f double 1\nLOOKUP_TABLE default\n\
             0 1 2 3 4 5 6 7\n",
        )
        .unwrap();
        p
    })
}

/// Runs the binary; panics when it outlives [`BOUND`], dies by a signal or
/// panics. Returns (exit code, stderr).
fn run_bounded(args: &[String]) -> (i32, String) {
    let o = support::output_within(
        support::bin()
            .args(args)
            .arg("--quiet")
            .env("NODEVICE_SELECT", "1")
            .stdout(Stdio::null())
            .stderr(Stdio::piped()),
        BOUND,
    )
    .unwrap_or_else(|| panic!("{args:?} ran longer than {BOUND:?}"));
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    let code = o
        .status
        .code()
        .unwrap_or_else(|| panic!("{args:?} was killed by a signal: {err}"));
    // 0: done; 1: refused by stratasweep; 2: refused by clap (usage).
    assert!((0..=2).contains(&code), "{args:?}: exit {code}: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    if code != 0 {
        assert!(err.starts_with("error: "), "{args:?}: {err}");
    }
    (code, err)
}

const NUMBERS: &[&str] = &[
    "0", "1", "-1", "0.5", "7", "1e-9", "1e-300", "1e300", "-1e300", "1e290", "1e308", "NaN",
    "inf", "-inf", "-0", "3.5", "100000", "5e-324", "abc", "",
];

const COUNTS: &[&str] = &[
    "0",
    "1",
    "2",
    "7",
    "100",
    "1000",
    "100000",
    "100001",
    "10000000",
    "18446744073709551615",
    "18446744073709551616",
    "-3",
    "x",
];

const THREADS: &[&str] = &[
    "0",
    "1",
    "2",
    "3",
    "64",
    "65",
    "1000000",
    "-1",
    "18446744073709551615",
];

const SIZES: &[&str] = &[
    "1x1",
    "16x16",
    "8x32",
    "0x5",
    "8193x1",
    "100000x100000",
    "x",
    "16X16",
    "4294967296x1",
    "-1x4",
    "1e3x1",
];

const SLICES: &[&str] = &["0", "1", "3", "40", "8192", "8193", "1000000000", "-2"];

fn pick(list: &'static [&'static str]) -> impl Strategy<Value = String> {
    (0..list.len()).prop_map(move |i| list[i].to_string())
}

/// `--count N` or `--values FROM:TO:STEP` from the lists above.
fn levels() -> impl Strategy<Value = Vec<String>> {
    prop_oneof![
        pick(COUNTS).prop_map(|c| vec!["--count".into(), c]),
        (pick(NUMBERS), pick(NUMBERS), pick(NUMBERS))
            .prop_map(|(a, b, c)| vec![format!("--values={a}:{b}:{c}")]),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn slice_arguments_end_in_bounded_time(levels in levels(), threads in pick(THREADS)) {
        let mut args = vec!["slice".to_string(), grid().display().to_string(), "--axis".into(), "z".into()];
        args.extend(levels);
        args.push(format!("--threads={threads}"));
        run_bounded(&args);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 10, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn render_arguments_end_in_bounded_time(size in pick(SIZES), slices in pick(SLICES)) {
        let out = grid().with_file_name(format!("r-{size}-{slices}.png"));
        let args = vec![
            "render".to_string(), grid().display().to_string(), "-o".into(), out.display().to_string(),
            format!("--size={size}"), format!("--slices={slices}"),
        ];
        let (code, err) = run_bounded(&args);
        // An image side over the limit or a slice count over it never runs.
        let side_ok = size.split_once(['x', 'X']).is_some_and(|(w, h)| {
            [w, h].iter().all(|s| s.parse::<u64>().is_ok_and(|v| (1..=8192).contains(&v)))
        });
        let slices_ok = slices.parse::<u64>().is_ok_and(|v| (1..=8192).contains(&v));
        if !side_ok || !slices_ok {
            prop_assert!(code == 1 || code == 2, "{}", err);
        }
        let _ = std::fs::remove_file(out);
    }
}
