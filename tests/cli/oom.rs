//! Out of memory under a memory limit (`ulimit -v`, RLIMIT_AS set in the
//! child before exec): a clear error naming what was being allocated and
//! how much, a non-zero exit, never "memory allocation of N bytes failed"
//! and SIGABRT (issue 32, class 5).

use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::Path;
use std::process::Output;

use crate::support;
use crate::support::Dir;

/// One GiB: the binary's own start (libraries, thread stacks) fits well
/// under it (it runs under 300 MB).
const GIB: u64 = 1 << 30;

/// Runs the binary with its address space limited to `limit` bytes.
fn run_limited(args: &[&str], limit: u64) -> Output {
    let mut cmd = support::bin();
    cmd.args(args)
        .env("NODEVICE_SELECT", "1")
        .env("RAYON_NUM_THREADS", "2");
    // SAFETY: setrlimit is async-signal-safe and touches no memory of the
    // parent; it runs in the child between fork and exec.
    unsafe {
        cmd.pre_exec(move || {
            let r = libc::rlimit {
                rlim_cur: limit as libc::rlim_t,
                rlim_max: limit as libc::rlim_t,
            };
            if libc::setrlimit(libc::RLIMIT_AS, &r) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    cmd.output().unwrap()
}

/// The process ended by itself with a non-zero code and said it ran out
/// of memory with a byte count (and `what`, when given); returns stderr.
fn assert_clean_oom(args: &[&str], out: &Output, what: Option<&str>) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(
        out.status.signal(),
        None,
        "{args:?}: killed by a signal: {err}"
    );
    assert!(!out.status.success(), "{args:?}: exit 0: {err}");
    assert!(!err.contains("memory allocation of"), "{args:?}: {err}");
    assert!(err.contains("out of memory"), "{args:?}: {err}");
    // Some " bytes" preceded by a number ("the file's bytes needs 56690593
    // bytes", "an allocation of 42517464 bytes failed").
    let has_bytes = err
        .match_indices(" bytes")
        .any(|(i, _)| err[..i].ends_with(|c: char| c.is_ascii_digit()));
    assert!(has_bytes, "{args:?}: no byte count: {err}");
    if let Some(w) = what {
        assert!(err.contains(w), "{args:?}: '{w}' not named: {err}");
    }
    err
}

/// A small GRDECL whose repeats ask for a 1000×1000×100 grid: ZCORN's
/// 800,000,000 values (6.4 GB) do not fit under 1 GiB.
fn huge_repeat_deck(d: &Dir) -> String {
    let p = d.s("huge.grdecl");
    let text = "SPECGRID\n1000 1000 100 1 F /\nCOORD\n6012006*0 /\nZCORN\n800000000*1 /\n";
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn info_and_slice_name_the_keyword_that_does_not_fit() {
    let d = Dir::new("oom-deck");
    let deck = huge_repeat_deck(&d);
    let out_ply = d.s("out.ply");
    for args in [
        vec!["info", deck.as_str(), "--quiet"],
        vec![
            "slice",
            deck.as_str(),
            "--quiet",
            "--axis",
            "z",
            "--count",
            "20",
            "-o",
            out_ply.as_str(),
        ],
    ] {
        let out = run_limited(&args, GIB);
        let err = assert_clean_oom(&args, &out, Some("ZCORN"));
        assert!(err.contains("6400000000 bytes"), "{err}");
        assert!(err.contains("huge.grdecl"), "{err}");
    }
    assert!(!Path::new(&out_ply).exists());
}

#[test]
fn commands_on_real_sized_inputs_fail_cleanly_under_a_small_limit() {
    let d = Dir::new("oom-real");
    let grdecl = d.s("f.grdecl");
    let vts = d.s("w.vts");
    let g = stratasweep::generate::faulted([60, 60, 40], 2, 3);
    let mut text = Vec::new();
    stratasweep::io::grdecl::write_grdecl(&mut text, &g).unwrap();
    std::fs::write(&grdecl, text).unwrap();
    stratasweep::io::writers::write_vtk_xml_grid(&vts, &stratasweep::generate::warped([120; 3], 1))
        .unwrap();
    let out = d.s("s.ply");
    // Each command succeeds without a limit, so the limit is what fails it.
    for (args, limit) in [
        (vec!["info", grdecl.as_str(), "--quiet"], 120 << 20),
        (
            vec![
                "slice",
                grdecl.as_str(),
                "--quiet",
                "--axis",
                "z",
                "--count",
                "20",
                "-o",
                out.as_str(),
            ],
            120 << 20,
        ),
        (vec!["info", vts.as_str(), "--quiet"], 120 << 20),
        (
            vec![
                "slice",
                vts.as_str(),
                "--quiet",
                "--axis",
                "z",
                "--count",
                "20",
                "-o",
                out.as_str(),
            ],
            120 << 20,
        ),
    ] {
        let free = run_limited(&args, 64 * GIB);
        assert!(
            free.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&free.stderr)
        );
        let _ = std::fs::remove_file(&out);
        let limited = run_limited(&args, limit);
        let err = assert_clean_oom(&args, &limited, None);
        // The stage it was in: reading the file, building, sweeping.
        assert!(err.contains("while ") || err.contains(args[1]), "{err}");
        assert!(!Path::new(&out).exists(), "{args:?} left an output");
    }
}

#[test]
fn generate_fails_cleanly_when_the_grid_does_not_fit() {
    let d = Dir::new("oom-generate");
    let out = d.s("g.grdecl");
    let args = [
        "generate",
        "--quiet",
        "faulted",
        "--dims",
        "800,800,200",
        "-o",
        out.as_str(),
    ];
    let r = run_limited(&args, GIB);
    let err = assert_clean_oom(&args, &r, None);
    assert!(err.contains("while generating the grid"), "{err}");
    assert!(!Path::new(&out).exists());
}

/// The library (what Python calls): a level list that cannot be allocated
/// is an error naming it and its bytes, not an abort.
#[test]
fn a_level_list_that_does_not_fit_is_an_error() {
    use stratasweep::pipeline::{LevelSpec, PipelineError, place_levels};
    let count = usize::MAX / 8;
    let e = place_levels(Some((0.0, 1.0)), 0.0, &LevelSpec::Count(count)).unwrap_err();
    assert!(matches!(e, PipelineError::Levels(_)), "{e:?}");
    let msg = e.to_string();
    assert!(msg.starts_with(stratasweep::mem::OUT_OF_MEMORY), "{msg}");
    assert!(
        msg.contains("the level values") && msg.contains(&format!("{} bytes", count * 8)),
        "{msg}"
    );
}
