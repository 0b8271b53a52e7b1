//! Memory-mapped inputs truncated while they load: a clear error naming the
//! file, never SIGBUS (issue 32, class 4).
//!
//! The truncation is made while the map is live: the test waits until the
//! file appears in the reading process's `/proc/PID/maps` (the reader has
//! mapped it and is parsing), then cuts the file to a third.

use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::time::{Duration, Instant};

use stratasweep::io::grdecl::{read_grdecl, write_grdecl};
use stratasweep::io::mapped::MappedFile;
use stratasweep::io::vtk_read::{parse_vtk_xml, read_vtk};
use stratasweep::io::writers::write_vtk_xml_grid;

use crate::support;

/// A faulted corner-point grid as GRDECL text of at least 8 MiB (mapped
/// when more than one thread reads it).
fn big_grdecl(path: &Path, n: usize) {
    let g = stratasweep::generate::faulted([n, n, n], 2, 7);
    let mut out = Vec::new();
    write_grdecl(&mut out, &g).unwrap();
    assert!(out.len() >= 8 << 20, "{} bytes", out.len());
    std::fs::write(path, out).unwrap();
}

/// A warped structured grid as `.vts` of at least 16 MiB (mapped).
fn big_vts(path: &Path, n: usize) -> PathBuf {
    let g = stratasweep::generate::warped([n, n, n], 3);
    write_vtk_xml_grid(path, &g).unwrap();
    let len = std::fs::metadata(path).unwrap().len();
    assert!(len >= 16 << 20, "{len} bytes");
    path.to_path_buf()
}

/// Whether `maps` (the text of a `/proc/PID/maps`) maps `path`.
fn maps_file(pid: &str, path: &Path) -> bool {
    let maps = std::fs::read_to_string(format!("/proc/{pid}/maps")).unwrap_or_default();
    let p = path.to_string_lossy();
    maps.lines().any(|l| l.ends_with(&*p))
}

/// Cuts `path` to a third of its length.
fn truncate_to_a_third(path: &Path) {
    let f = std::fs::OpenOptions::new().write(true).open(path).unwrap();
    let len = f.metadata().unwrap().len();
    f.set_len(len / 3).unwrap();
}

/// Waits (60 s at most) until process `pid` maps `path`; whether it did.
fn wait_for_map(pid: &str, path: &Path, running: impl Fn() -> bool) -> bool {
    let t = Instant::now();
    while t.elapsed() < Duration::from_secs(60) {
        if maps_file(pid, path) {
            return true;
        }
        if !running() {
            return false;
        }
        std::thread::sleep(Duration::from_micros(200));
    }
    false
}

/// Runs `stratasweep info FILE` on two threads, truncates FILE once the
/// process has mapped it, and checks the outcome: a non-zero exit (not a
/// signal) with a message naming the file and the truncation.
fn info_with_truncation(path: &Path) {
    let child = support::bin()
        .args(["info", path.to_str().unwrap(), "--quiet"])
        .env("NODEVICE_SELECT", "1")
        .env("RAYON_NUM_THREADS", "2")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id().to_string();
    let mapped = wait_for_map(&pid, path, || {
        std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|s| !s.contains(") Z "))
    });
    assert!(
        mapped,
        "{}: the process never mapped the file",
        path.display()
    );
    truncate_to_a_third(path);
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    use std::os::unix::process::ExitStatusExt;
    assert_eq!(
        out.status.signal(),
        None,
        "killed by a signal; stderr: {err}"
    );
    assert!(!out.status.success(), "exit 0 on a truncated file: {err}");
    assert!(
        err.contains(&*path.to_string_lossy()) && err.contains("truncated while being read"),
        "{err}"
    );
}

#[test]
fn cli_info_on_a_grdecl_truncated_while_it_loads_fails_cleanly() {
    let d = support::Dir::new("mapped-cli-grdecl");
    let path = d.0.join("big.grdecl");
    big_grdecl(&path, 80);
    info_with_truncation(&path);
}

#[test]
fn cli_info_on_a_vts_truncated_while_it_loads_fails_cleanly() {
    let d = support::Dir::new("mapped-cli-vts");
    let path = big_vts(&d.0.join("big.vts"), 100);
    info_with_truncation(&path);
}

/// The library's GRDECL reader on two threads, in this process: the file
/// is truncated once it is mapped; the read returns an error naming it.
#[test]
fn read_grdecl_of_a_file_truncated_while_it_loads_is_an_error() {
    let d = support::Dir::new("mapped-lib-grdecl");
    let path = d.0.join("lib.grdecl");
    big_grdecl(&path, 80);
    let p = path.clone();
    let reader = std::thread::spawn(move || {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        pool.install(|| read_grdecl(&p).map(|_| ()).map_err(|e| e.to_string()))
    });
    let mapped = wait_for_map("self", &path, || !reader.is_finished());
    assert!(mapped, "never mapped");
    truncate_to_a_third(&path);
    let e = reader.join().unwrap().unwrap_err();
    assert!(
        e.contains("lib.grdecl") && e.contains("truncated while being read"),
        "{e}"
    );
}

/// A map truncated before the parse (deterministic): the parse runs over
/// zeros without a fault, and the map reports the truncation whatever the
/// parse said; `read_vtk` of the truncated file then fails on its own.
#[test]
fn a_vts_map_truncated_before_its_parse_reports_the_truncation() {
    let d = support::Dir::new("mapped-lib-vts");
    let path = big_vts(&d.0.join("lib.vts"), 100);
    let map = MappedFile::map(std::fs::File::open(&path).unwrap()).expect("mapped");
    let whole = parse_vtk_xml(&map, "lib.vts").expect("the whole file parses");
    assert!(whole.cell_count() > 0);
    truncate_to_a_third(&path);
    let r = parse_vtk_xml(&map, "lib.vts")
        .map(|_| ())
        .map_err(|e| e.to_string());
    let e = map
        .settle(r, |e| e.to_string())
        .expect_err("a truncated map must not pass");
    assert!(e.contains("truncated while being read"), "{e}");
    drop(map);
    assert!(read_vtk(&path).is_err());
}
