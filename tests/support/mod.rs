//! What the integration-test binaries share: the binary under test, scratch
//! folders, the environment's optional inputs, random and simple grids, the
//! GPU device and the CPU ray integration.
//!
//! Each test binary (`tests/<binary>/main.rs`) includes this module with
//! `#[path = "../support/mod.rs"] mod support;` and uses what it needs.
//!
//! The environment: an optional input is skipped with a `SKIP` line on
//! stderr when its variable is unset, and a set variable that names
//! nothing usable fails the test. `STRATASWEEP_DATA` (the real grids),
//! `STRATASWEEP_PEER_PYTHON` (a Python with `vtk`), `STRATASWEEP_XTGEO_PYTHON`
//! (a Python with `xtgeo`); `STRATASWEEP_REQUIRE_GPU=1` and
//! `STRATASWEEP_REQUIRE_DISPLAY=1` turn a missing adapter or display from a
//! skip into a failure.
#![allow(dead_code)]

pub mod gpu;
pub mod grids;
pub mod peer;
pub mod ray;

#[allow(unused_imports)]
pub use self::gpu::gpu;
#[allow(unused_imports)]
pub use self::grids::*;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};
use std::time::{Duration, Instant};

/// The `stratasweep` binary, with nothing set.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_stratasweep"))
}

/// `args`, with `--quiet` added unless it is there.
fn quiet(args: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = args.iter().map(|s| s.to_string()).collect();
    if !args.contains(&"--quiet") {
        v.push("--quiet".into());
    }
    v
}

/// Runs the binary quietly: (success, stdout, stderr).
pub fn run(args: &[&str]) -> (bool, String, String) {
    let o = bin().args(quiet(args)).output().unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into(),
        String::from_utf8_lossy(&o.stderr).into(),
    )
}

/// Runs the binary quietly; asserts that it succeeded and that its stdout
/// is UTF-8, and returns stdout.
pub fn run_ok(args: &[&str]) -> String {
    let o = bin().args(quiet(args)).output().unwrap();
    assert!(
        o.status.success(),
        "{args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

/// Runs the binary quietly; asserts that it failed without a panic, and
/// returns stderr.
pub fn run_err(args: &[&str]) -> String {
    let o = bin().args(quiet(args)).output().unwrap();
    assert!(!o.status.success(), "{args:?} should fail");
    let e = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(!e.contains("panicked"), "{args:?} panicked: {e}");
    e
}

/// Waits for `child`, killing it after `limit`: its output, or `None` when
/// it ran out of time.
pub fn wait_within(mut child: Child, limit: Duration) -> Option<Output> {
    let t = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            return Some(child.wait_with_output().unwrap());
        }
        if t.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Spawns `cmd` and [`wait_within`] `limit`. Set the command's stdio before.
pub fn output_within(cmd: &mut Command, limit: Duration) -> Option<Output> {
    wait_within(cmd.spawn().unwrap(), limit)
}

/// A JSON file's value.
pub fn json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// The scratch folder `stratasweep-<tag>-<pid>` in the temp dir, created
/// (and kept): one tag per test file, so that files of the same name in
/// two test files of one binary do not meet.
pub fn tmp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("stratasweep-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `name` in [`tmp_dir`]`(tag)`.
pub fn tmp(tag: &str, name: &str) -> PathBuf {
    tmp_dir(tag).join(name)
}

/// A scratch folder of the test's own, `stratasweep-<tag>-<pid>` in the
/// temp dir: emptied when made, removed on drop.
pub struct Dir(pub PathBuf);

impl Dir {
    /// Makes the folder, removing what an earlier run left there.
    pub fn new(tag: &str) -> Dir {
        let d = std::env::temp_dir().join(format!("stratasweep-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        Dir(d)
    }

    /// The path of `name` in the folder.
    pub fn p(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }

    /// The path of `name` in the folder, as a string (for arguments).
    pub fn s(&self, name: &str) -> String {
        self.p(name).display().to_string()
    }

    /// Writes `bytes` to `name`; its path.
    pub fn write(&self, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let p = self.p(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    /// Every entry by name: a plain file's bytes; a link's target and, when
    /// it leads to a plain file, that file's bytes; a named pipe or a
    /// folder as its kind.
    pub fn snapshot(&self) -> BTreeMap<String, Vec<u8>> {
        let mut m = BTreeMap::new();
        for e in std::fs::read_dir(&self.0).unwrap() {
            let e = e.unwrap();
            let t = std::fs::symlink_metadata(e.path()).unwrap().file_type();
            let v = if t.is_symlink() {
                let mut v = format!(
                    "link to {}\n",
                    std::fs::read_link(e.path()).unwrap().display()
                )
                .into_bytes();
                if e.path().is_file() {
                    v.extend(std::fs::read(e.path()).unwrap());
                }
                v
            } else if t.is_dir() {
                b"folder".to_vec()
            } else if t.is_file() {
                std::fs::read(e.path()).unwrap()
            } else {
                b"fifo or other".to_vec()
            };
            m.insert(e.file_name().to_string_lossy().into(), v);
        }
        m
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// `STRATASWEEP_DATA`, or `None` after a loud skip notice naming `test`;
/// panics when it is set but is not a folder.
pub fn data_dir(test: &str) -> Option<PathBuf> {
    match std::env::var_os("STRATASWEEP_DATA") {
        Some(d) => {
            let d = PathBuf::from(d);
            assert!(
                d.is_dir(),
                "STRATASWEEP_DATA={} is not a folder",
                d.display()
            );
            Some(d)
        }
        None => {
            eprintln!(
                "\n*** SKIP {test}: STRATASWEEP_DATA is not set (real grids not tested) ***\n"
            );
            None
        }
    }
}

/// The Python named by `var`, else `fallback` when that exists, or `None`
/// after a loud skip notice naming `test` (`how`: how to get one). Panics
/// when `var` is set but names no file.
fn python(var: &str, fallback: PathBuf, test: &str, how: &str) -> Option<PathBuf> {
    if let Some(p) = std::env::var_os(var) {
        let p = PathBuf::from(p);
        assert!(p.is_file(), "{var}={} does not exist", p.display());
        return Some(p);
    }
    if fallback.is_file() {
        return Some(fallback);
    }
    eprintln!(
        "\n*** SKIP {test}: {var} is not set and there is no {} ({how}) ***\n",
        fallback.display()
    );
    None
}

/// A Python with the `vtk` module: `STRATASWEEP_PEER_PYTHON`, else the
/// crate's `.venv-peer`; `None` after a skip notice naming `test`.
pub fn peer_python(test: &str) -> Option<PathBuf> {
    python(
        "STRATASWEEP_PEER_PYTHON",
        Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv-peer/bin/python"),
        test,
        "point it to a Python with the `vtk` module",
    )
}

/// A Python with `xtgeo`: `STRATASWEEP_XTGEO_PYTHON`, else
/// `../venv-xtgeo/bin/python` beside the crate; `None` after a skip notice
/// naming `test`.
pub fn xtgeo_python(test: &str) -> Option<PathBuf> {
    python(
        "STRATASWEEP_XTGEO_PYTHON",
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../venv-xtgeo/bin/python"),
        test,
        "python3 -m venv ../venv-xtgeo && ../venv-xtgeo/bin/pip install xtgeo",
    )
}

/// Whether a display (X11 or Wayland) is there; without one, skips loudly
/// naming `test`, or panics when `STRATASWEEP_REQUIRE_DISPLAY=1` (CI,
/// under `xvfb-run`).
pub fn display(test: &str) -> bool {
    let set = |v: &str| std::env::var_os(v).is_some_and(|s| !s.is_empty());
    if set("DISPLAY") || set("WAYLAND_DISPLAY") {
        return true;
    }
    if std::env::var("STRATASWEEP_REQUIRE_DISPLAY").as_deref() == Ok("1") {
        panic!("STRATASWEEP_REQUIRE_DISPLAY=1 but neither DISPLAY nor WAYLAND_DISPLAY is set");
    }
    eprintln!(
        "SKIP {test}: no display (run under `xvfb-run -a`; STRATASWEEP_REQUIRE_DISPLAY=1 fails instead)"
    );
    false
}
