//! Issue 32, data loss: every output of the CLI (`slice -o`, `--stats`,
//! `render -o`, `generate -o`, `view --screenshot`, `--window-screenshot`)
//! and of the library's writers (what Python calls)
//!
//! 1. refuses an output that exists and is not a regular file (a named
//!    pipe, or a symbolic link to one), naming it, and leaves the node as
//!    it was;
//! 2. is written atomically: when writes fail part-way (the process runs
//!    under `RLIMIT_FSIZE` with SIGXFSZ ignored, so `write` returns EFBIG as
//!    on a full disk) the old file is unchanged byte for byte, no temporary
//!    file is left, and the error names the file;
//! 3. leaves no temporary file when `slice -o` is interrupted by SIGINT or
//!    SIGTERM while it writes: the process dies by that signal and the old
//!    output is unchanged.
//!
//! Everything happens in folders of the test's own under the temporary
//! folder; nothing under `/dev` is touched and no privilege is needed.

#![cfg(unix)]

use std::collections::BTreeMap;
use std::ffi::CString;
use std::os::unix::fs::FileTypeExt;
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::PathBuf;
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::support;
use crate::support::Dir;

/// The fixtures the tests make in their folder.
trait Fixtures {
    /// Makes a named pipe.
    fn fifo(&self, name: &str) -> PathBuf;
    /// A small grid file (warped 6³ with point property `f`).
    fn grid(&self) -> String;
}

impl Fixtures for Dir {
    fn fifo(&self, name: &str) -> PathBuf {
        let p = self.p(name);
        let c = CString::new(p.as_os_str().as_encoded_bytes()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0, "mkfifo");
        p
    }

    fn grid(&self) -> String {
        let p = self.p("grid.vts");
        let g = stratasweep::generate::warped([6, 6, 6], 1);
        stratasweep::io::writers::write_vtk_xml_grid(&p, &g).unwrap();
        p.display().to_string()
    }
}

/// The binary without a display or a terminal, its output piped.
fn headless() -> Command {
    let mut c = support::bin();
    c.env("NODEVICE_SELECT", "1")
        .env("MESA_SHADER_CACHE_DISABLE", "true")
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    c
}

/// Waits for `child`, killing it after `limit` (a hang fails the test).
fn wait(child: Child, args: &[String], limit: Duration) -> Output {
    support::wait_within(child, limit).unwrap_or_else(|| panic!("{args:?} hung"))
}

/// Runs the binary, optionally with files limited to `fsize` bytes.
fn run(args: &[String], fsize: Option<u64>) -> Output {
    let mut c = headless();
    c.args(args).arg("--quiet");
    if let Some(n) = fsize {
        // SAFETY: only async-signal-safe calls between fork and exec.
        unsafe {
            c.pre_exec(move || {
                let lim = libc::rlimit {
                    rlim_cur: n,
                    rlim_max: n,
                };
                if libc::setrlimit(libc::RLIMIT_FSIZE, &lim) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                // Ignored, so that write() past the limit fails with EFBIG
                // (as on a full disk) instead of killing the process.
                libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
                Ok(())
            });
        }
    }
    wait(c.spawn().unwrap(), args, Duration::from_secs(300))
}

fn args(a: &[&str]) -> Vec<String> {
    a.iter().map(|s| s.to_string()).collect()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into()
}

/// What changed between two snapshots, by name ("" when nothing did).
fn changes(before: &BTreeMap<String, Vec<u8>>, after: &BTreeMap<String, Vec<u8>>) -> String {
    let mut v = Vec::new();
    for (k, b) in before {
        match after.get(k) {
            None => v.push(format!("{k} removed")),
            Some(a) if a != b => v.push(format!("{k} changed ({} -> {} bytes)", b.len(), a.len())),
            _ => {}
        }
    }
    for (k, a) in after {
        if !before.contains_key(k) {
            v.push(format!("{k} appeared ({} bytes)", a.len()));
        }
    }
    v.join(", ")
}

/// Runs `a`; checks a clean failure (exit code 1, no panic) whose message
/// contains every one of `msgs`, with the folder exactly as before.
fn refused(d: &Dir, a: &[String], fsize: Option<u64>, msgs: &[&str]) -> Result<(), String> {
    let before = d.snapshot();
    let o = run(a, fsize);
    let err = stderr(&o);
    let mut why = Vec::new();
    if o.status.code() != Some(1) {
        why.push(format!("exit {:?}", o.status));
    }
    for m in msgs.iter().filter(|m| !err.contains(*m)) {
        why.push(format!("no '{m}' in the message"));
    }
    if err.contains("panicked") {
        why.push("a panic".into());
    }
    let c = changes(&before, &d.snapshot());
    if !c.is_empty() {
        why.push(format!("the folder changed: {c}"));
    }
    match why.is_empty() {
        true => Ok(()),
        false => Err(format!(
            "{}: {}; stderr: {}",
            a.join(" "),
            why.join("; "),
            err.trim()
        )),
    }
}

/// Panics listing every failure, if any.
fn all_ok(failures: Vec<String>) {
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// The commands writing `out` (a path with the extension each needs,
/// swapped in), with `grid` as input.
fn writers(grid: &str, out: &dyn Fn(&str) -> String) -> Vec<Vec<String>> {
    let view = |flag: &str| {
        args(&[
            "view",
            "--demo",
            "--headless",
            "--frames",
            "1",
            "--slices",
            "16",
            "--size",
            "96x64",
            flag,
            &out("png"),
        ])
    };
    let slice = |flag: &str, ext: &str| {
        args(&[
            "slice",
            grid,
            "--axis",
            "z",
            "--count",
            "4",
            flag,
            &out(ext),
        ])
    };
    let faulted = |ext: &str| args(&["generate", "faulted", "--dims", "3,3,2", "-o", &out(ext)]);
    vec![
        slice("-o", "vtp"),
        slice("-o", "ply"),
        slice("--stats", "json"),
        args(&[
            "render",
            grid,
            "--slices",
            "16",
            "--size",
            "64x48",
            "-o",
            &out("png"),
        ]),
        faulted("grdecl"),
        faulted("egrid"),
        faulted("vtu"),
        args(&["generate", "warped", "--dims", "3,3,3", "-o", &out("vts")]),
        args(&["generate", "zoo", "--cells", "50", "-o", &out("vtu")]),
        args(&["generate", "voronoi", "--cells", "20", "-o", &out("vtu")]),
        view("--screenshot"),
        view("--window-screenshot"),
    ]
}

#[test]
fn class1_outputs_that_are_named_pipes_are_refused_by_name() {
    let d = Dir::new("outputs-fifo");
    let grid = d.grid();
    for ext in ["vtp", "ply", "json", "png", "grdecl", "egrid", "vtu", "vts"] {
        d.fifo(&format!("pipe.{ext}"));
        std::os::unix::fs::symlink(d.p(&format!("pipe.{ext}")), d.p(&format!("link.{ext}")))
            .unwrap();
    }
    let mut failures = Vec::new();
    for name in ["pipe", "link"] {
        let out = |ext: &str| d.s(&format!("{name}.{ext}"));
        for a in writers(&grid, &out) {
            let path = a.iter().find(|s| s.contains(name)).unwrap().clone();
            let mut msgs = vec![path.as_str(), "a named pipe (FIFO)", "not a regular file"];
            if name == "link" {
                msgs.push("a symbolic link to");
            }
            failures.extend(refused(&d, &a, None, &msgs).err());
        }
    }
    // The INIT an EGRID brings: a pipe there refuses the pair.
    d.fifo("pair.init");
    let a = args(&[
        "generate",
        "faulted",
        "--dims",
        "3,3,2",
        "-o",
        &d.s("pair.egrid"),
    ]);
    failures.extend(refused(&d, &a, None, &[&d.s("pair.init"), "a named pipe (FIFO)"]).err());
    for e in std::fs::read_dir(&d.0).unwrap() {
        let e = e.unwrap();
        let n = e.file_name().to_string_lossy().to_string();
        if (n.starts_with("pipe") || n.ends_with(".init")) && !e.file_type().unwrap().is_fifo() {
            failures.push(format!("{n} is no longer a named pipe"));
        }
    }
    all_ok(failures);
}

#[test]
fn class1_library_writers_refuse_a_named_pipe() {
    // The writers Python's `Grid.write` and `Slices.write` call.
    let d = Dir::new("outputs-fifo-lib");
    let p = d.fifo("g.vtu");
    let g = stratasweep::generate::zoo(40, 1);
    let e = stratasweep::io::writers::write_vtk_xml_grid(&p, &g)
        .unwrap_err()
        .to_string();
    assert!(e.contains(&p.display().to_string()), "{e}");
    assert!(e.contains("a named pipe (FIFO)"), "{e}");
    let e = stratasweep::io::atomic::write_bytes(&p, b"x").unwrap_err();
    assert!(e.to_string().contains("not a regular file"), "{e}");
    assert!(std::fs::symlink_metadata(&p).unwrap().file_type().is_fifo());
    assert_eq!(d.snapshot().len(), 1);
}

#[test]
fn class3_a_failed_commit_removes_the_temporary_file() {
    use std::io::Write;
    let d = Dir::new("outputs-rename");
    let dest = d.p("out.bin");
    let mut f = stratasweep::io::atomic::AtomicFile::create(&dest).unwrap();
    f.write_all(b"new").unwrap();
    assert!(f.temporary().exists());
    // A folder appears at the destination: the rename fails.
    std::fs::create_dir(&dest).unwrap();
    std::fs::write(dest.join("inside"), b"x").unwrap();
    assert!(f.commit().is_err());
    assert_eq!(
        d.snapshot().into_keys().collect::<Vec<_>>(),
        ["out.bin"],
        "the temporary file is gone"
    );
    // A folder is refused before anything is created, by what it is.
    let e = stratasweep::io::atomic::AtomicFile::create(&dest).unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::IsADirectory);
    assert!(e.to_string().contains("it is a directory"), "{e}");
    assert_eq!(d.snapshot().len(), 1);
}

/// Old content for an output: what a run must leave untouched.
const OLD: &[u8] = b"the previous output, which a failed run must leave as it is\n";

#[test]
fn class2_and_3_a_full_disk_leaves_old_outputs_whole_and_no_temporary_file() {
    let d = Dir::new("outputs-fsize");
    let grid = d.grid();
    // Each writer first runs unlimited (it must succeed and write more than
    // the limit), then with files limited to LIMIT bytes over the old file.
    const LIMIT: u64 = 200;
    let out = |ext: &str| d.s(&format!("out.{ext}"));
    let mut failures = Vec::new();
    for a in writers(&grid, &out) {
        let path = PathBuf::from(a.iter().find(|s| s.contains("out.")).unwrap());
        let o = run(&a, None);
        assert!(o.status.success(), "{a:?}: {}", stderr(&o));
        let size = std::fs::metadata(&path).unwrap().len();
        assert!(size > LIMIT, "{a:?} wrote only {size} bytes");
        let init = path.with_extension("init");
        std::fs::write(&path, OLD).unwrap();
        if init.exists() {
            std::fs::write(&init, OLD).unwrap();
        }
        let msg = format!("cannot write {}", path.display());
        failures.extend(refused(&d, &a, Some(LIMIT), &[&msg, "File too large"]).err());
        // Whatever happened, start the next case clean.
        for e in std::fs::read_dir(&d.0).unwrap() {
            let e = e.unwrap().path();
            if e.file_name().unwrap() != "grid.vts" {
                std::fs::remove_file(e).unwrap();
            }
        }
    }
    all_ok(failures);
}

/// A faulted grid whose `slice --axis z --count 600 -o` output takes a
/// while to write (153 MB, about a second), generated once per test.
fn big_grid(d: &Dir) -> String {
    let g = d.s("big.grdecl");
    let o = run(
        &args(&["generate", "faulted", "--dims", "50,50,20", "-o", &g]),
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    g
}

/// The temporary files beside `out` (hidden, `.tmp`).
fn temporaries(d: &Dir) -> Vec<String> {
    std::fs::read_dir(&d.0)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

/// Starts `slice` writing `out.vtp`, sends `sig` as soon as its temporary
/// file exists, and returns how the process ended.
fn interrupt_slice(d: &Dir, grid: &str, sig: i32, ignore: bool) -> (Output, bool) {
    let a = args(&[
        "slice",
        grid,
        "--axis",
        "z",
        "--count",
        "600",
        "-o",
        &d.s("out.vtp"),
    ]);
    let mut c = headless();
    c.args(&a).arg("--quiet");
    // The signal's disposition is set either way: a test run started in
    // the background (`nohup`, `&` in a script) inherits SIGINT ignored.
    let disposition = if ignore { libc::SIG_IGN } else { libc::SIG_DFL };
    // SAFETY: one async-signal-safe call between fork and exec.
    unsafe {
        c.pre_exec(move || {
            libc::signal(sig, disposition);
            Ok(())
        });
    }
    let child = c.spawn().unwrap();
    let t = Instant::now();
    let mut sent = false;
    while t.elapsed() < Duration::from_secs(240) {
        if !temporaries(d).is_empty() {
            // SAFETY: signalling our own child.
            unsafe { libc::kill(child.id() as i32, sig) };
            sent = true;
            break;
        }
        std::thread::sleep(Duration::from_micros(500));
    }
    (wait(child, &a, Duration::from_secs(240)), sent)
}

#[test]
fn class3_an_interrupted_slice_leaves_no_temporary_file() {
    let d = Dir::new("outputs-signals");
    let grid = big_grid(&d);
    for sig in [libc::SIGINT, libc::SIGTERM] {
        std::fs::write(d.p("out.vtp"), OLD).unwrap();
        let (o, sent) = interrupt_slice(&d, &grid, sig, false);
        assert!(sent, "the temporary file never appeared: {}", stderr(&o));
        assert_eq!(
            o.status.signal(),
            Some(sig),
            "{:?}: {}",
            o.status,
            stderr(&o)
        );
        assert_eq!(temporaries(&d), Vec::<String>::new(), "signal {sig}");
        assert_eq!(std::fs::read(d.p("out.vtp")).unwrap(), OLD, "signal {sig}");
    }
    // A signal ignored by whoever started the process (nohup, background
    // jobs) stays ignored: the run completes.
    let (o, sent) = interrupt_slice(&d, &grid, libc::SIGINT, true);
    assert!(sent);
    assert!(o.status.success(), "{:?}: {}", o.status, stderr(&o));
    assert_eq!(temporaries(&d), Vec::<String>::new());
    assert!(std::fs::metadata(d.p("out.vtp")).unwrap().len() > 100 << 20);
}

/// `--window-screenshot` from a real window (under `xvfb-run -a`): written
/// atomically and named on failure. Skips without a display unless
/// `STRATASWEEP_REQUIRE_DISPLAY=1`.
#[test]
fn class2_window_screenshot_in_a_window_is_atomic() {
    if !support::display("class2_window_screenshot_in_a_window_is_atomic") {
        return;
    }
    let d = Dir::new("outputs-window");
    let shot = d.p("shot.png");
    std::fs::write(&shot, OLD).unwrap();
    let a = args(&[
        "view",
        "--demo",
        "--frames",
        "1",
        "--slices",
        "16",
        "--size",
        "96x64",
        "--window-screenshot",
        &d.s("shot.png"),
    ]);
    let mut c = headless();
    for v in ["DISPLAY", "WAYLAND_DISPLAY"] {
        if let Some(x) = std::env::var_os(v) {
            c.env(v, x);
        }
    }
    c.args(&a).arg("--quiet");
    // SAFETY: as in `run`.
    unsafe {
        c.pre_exec(|| {
            let lim = libc::rlimit {
                rlim_cur: 200,
                rlim_max: 200,
            };
            libc::setrlimit(libc::RLIMIT_FSIZE, &lim);
            libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
            Ok(())
        });
    }
    let o = wait(c.spawn().unwrap(), &a, Duration::from_secs(300));
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&format!("cannot write {}", shot.display())),
        "{err}"
    );
    assert_eq!(std::fs::read(&shot).unwrap(), OLD);
    assert_eq!(temporaries(&d), Vec::<String>::new());
}

/// `slice -o MESH --stats JSON` is one output pair: the statistics are
/// written in full before the mesh replaces anything and renamed after it,
/// so a failure of either (here the statistics, larger than the mesh, do
/// not fit a disk the mesh fits) leaves both old files as they were.
#[test]
fn class3_a_slice_and_its_statistics_are_replaced_together_or_not_at_all() {
    let d = Dir::new("outputs-pair");
    let grid = d.grid();
    let (mesh, stats) = (d.s("out.ply"), d.s("out.json"));
    // 2,001 levels, nearly all outside the grid: a small mesh, long stats.
    let a = args(&[
        "slice",
        &grid,
        "--axis",
        "z",
        "--values",
        "-1000:1000:1",
        "-o",
        &mesh,
        "--stats",
        &stats,
    ]);
    let o = run(&a, None);
    assert!(o.status.success(), "{}", stderr(&o));
    let size = |p: &str| std::fs::metadata(p).unwrap().len();
    let (m, s) = (size(&mesh), size(&stats));
    assert!(s > m + 64, "statistics {s} bytes, mesh {m} bytes");
    std::fs::write(&mesh, OLD).unwrap();
    std::fs::write(&stats, OLD).unwrap();
    let limit = (m + s) / 2;
    let msg = format!("cannot write {stats}");
    all_ok(
        refused(&d, &a, Some(limit), &[&msg, "File too large"])
            .err()
            .into_iter()
            .collect(),
    );
}
