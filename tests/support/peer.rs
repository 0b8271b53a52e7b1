//! Running VTK's plane cutter (`../shared/peer/vtk_slices.py`) on a grid
//! file, for tests that compare slice areas with VTK.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The peer's Python (STRATASWEEP_PEER_PYTHON, else the crate's
/// `.venv-peer`) and script, or `None` (after printing a loud SKIP line
/// naming `what`) when either is missing.
pub fn peer(what: &str) -> Option<(PathBuf, PathBuf)> {
    let py = std::env::var("STRATASWEEP_PEER_PYTHON")
        .ok()
        .map(PathBuf::from)
        .or_else(|| {
            let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv-peer/bin/python");
            p.exists().then_some(p)
        });
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/peer/vtk_slices.py");
    match py {
        Some(py) if script.exists() => Some((py, script)),
        Some(_) => {
            eprintln!("SKIP {what}: {} missing", script.display());
            None
        }
        None => {
            eprintln!("SKIP {what}: no STRATASWEEP_PEER_PYTHON and no .venv-peer");
            None
        }
    }
}

/// VTK's slices of `grid` along `axis` (0–2) at `count` levels: the peer's
/// JSON (`slices: [{value, area, ..}]`), written to and removed from the
/// temp dir. Panics with VTK's stderr when the peer fails.
pub fn vtk_slices(
    py: &Path,
    script: &Path,
    grid: &Path,
    axis: usize,
    count: usize,
) -> serde_json::Value {
    let json = std::env::temp_dir().join(format!(
        "peer-{}-{}-{axis}-{count}.json",
        std::process::id(),
        grid.file_stem().unwrap().to_string_lossy()
    ));
    let out = Command::new(py)
        .arg(script)
        .arg(grid)
        .args([
            "--axis",
            ["x", "y", "z"][axis],
            "--count",
            &count.to_string(),
            "--json",
        ])
        .arg(&json)
        .output()
        .expect("run the peer");
    assert!(
        out.status.success(),
        "peer failed on {}: {}",
        grid.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    let v = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let _ = std::fs::remove_file(&json);
    v
}
